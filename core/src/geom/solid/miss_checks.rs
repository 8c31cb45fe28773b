//! Test support: the checks every sure-miss test must pass.
//!
//! [`sphere_miss`](super::sphere_miss) and [`cylinder_miss`](super::cylinder_miss) each say
//! "surely missed" without the division of the full test, for one ray and for four at once.
//! [`sure_misses_are_misses`] checks, on rays from each module's own generator (near the
//! shape's rim and far from it, at every scale), that a sure miss is a miss of the full test
//! and that clear misses from close by are caught; [`four_lanes_answer_as_one`] that the
//! four-lane form gives the one-ray answer in every lane, bit for bit, with zero, infinite and
//! NaN components mixed in.

#![cfg(test)]

use crate::math::norm::Norm;
use crate::scene::mesh::Rng;
use glam::{Vec3, Vec4};

/// A ray generator: `(rng, k)` to `(r, o, d)`, a ray passing at `r·(1 + k)` from the shape.
pub type NearRim = fn(&mut Rng, f32) -> (f32, Vec3, Vec3);

/// A yes-or-no question about the ray `o + t·d` and a shape of radius `r`.
pub type Answer = fn(f32, Vec3, Vec3) -> bool;

/// Checks over 400,000 rays from `near_rim`, from just inside the rim to well outside it, that
/// wherever `sure(r, o, d)` says "miss", `full(r, o, d)` (the full test's miss) holds too; and
/// that `sure` says so for every ray from within 16 radii that passes the rim by more than 1 %
/// where `covered(r, o, d)` (the scales the rounding argument covers). From farther away the
/// cancellation grows with the square of the distance, and rays nearer the rim are left to the
/// full test.
pub fn sure_misses_are_misses(
    seed: u64,
    near_rim: NearRim,
    (sure, full): (Answer, Answer),
    covered: Answer,
) {
    let mut rng = Rng::new(seed);
    let (mut sure_misses, mut clear_misses, mut caught) = (0, 0, 0);
    for case in 0..400_000 {
        let k = match case % 4 {
            0 => (rng.next_f32() - 0.5) * 1e-6,
            1 => (rng.next_f32() - 0.5) * 1e-4,
            2 => (rng.next_f32() - 0.5) * 1e-2,
            _ => rng.next_f32() * 4.0,
        };
        let (r, o, d) = near_rim(&mut rng, k);
        if sure(r, o, d) {
            sure_misses += 1;
            assert!(full(r, o, d), "case {case}: r {r:e}, o {o:?}, d {d:?}");
        }
        if k > 1e-2 && o.norm() < 16.0 * r && covered(r, o, d) {
            clear_misses += 1;
            caught += usize::from(sure(r, o, d));
        }
    }
    assert!(sure_misses > 50_000, "only {sure_misses} sure misses");
    assert!(clear_misses > 10_000, "only {clear_misses} clear misses");
    assert_eq!(caught, clear_misses, "clear misses from close by");
}

/// Checks that `four(r, o, d)` (per axis, lane by lane) reports exactly the lanes where
/// `one(r, o, d)` answers true, over 50,000 sets of four rays from `near_rim`; both answers
/// must occur more than 20,000 times.
pub fn four_lanes_answer_as_one(
    seed: u64,
    near_rim: NearRim,
    one: Answer,
    four: fn(f32, [Vec4; 3], [Vec4; 3]) -> u32,
) {
    let mut rng = Rng::new(seed);
    let special = [
        0.0,
        -0.0,
        f32::INFINITY,
        f32::NAN,
        1e30,
        1e-30,
        f32::MIN_POSITIVE,
    ];
    let (mut sure, mut not) = (0, 0);
    for case in 0..50_000usize {
        let rays: [(f32, Vec3, Vec3); 4] = core::array::from_fn(|l| {
            let k = (rng.next_f32() - 0.3) * 10f32.powi(-((case % 6) as i32));
            let (r, mut o, mut d) = near_rim(&mut rng, k);
            if (case + l) % 7 == 0 {
                let s = special[(rng.next_u64() % special.len() as u64) as usize];
                let axis = (rng.next_u64() % 3) as usize;
                if l % 2 == 0 {
                    o[axis] = s;
                } else {
                    d[axis] = s;
                }
            }
            (r, o, d)
        });
        // One radius for the four (the lanes share a shape): rescale each ray to it.
        let r = rays[0].0;
        let rays = rays.map(|(q, o, d)| (o * (r / q), d));
        let lanes = |f: &dyn Fn(&(Vec3, Vec3)) -> Vec3| {
            let v = rays.map(|ray| f(&ray));
            [0, 1, 2].map(|a| Vec4::new(v[0][a], v[1][a], v[2][a], v[3][a]))
        };
        let got = four(r, lanes(&|ray| ray.0), lanes(&|ray| ray.1));
        for (l, &(o, d)) in rays.iter().enumerate() {
            let answer = one(r, o, d);
            assert_eq!(
                got >> l & 1 == 1,
                answer,
                "case {case} lane {l}: {o:?} {d:?}"
            );
            sure += usize::from(answer);
            not += usize::from(!answer);
        }
    }
    assert!(sure > 20_000 && not > 20_000, "{sure} sure, {not} not");
}
