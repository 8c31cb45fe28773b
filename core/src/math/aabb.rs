//! Axis-aligned boxes and the robust ray/box slab test.

use crate::math::float::gamma;
use crate::math::ray::Ray;
use glam::{BVec4A, Vec3, Vec3A, Vec4};

/// An axis-aligned box; `min <= max` on every axis once anything was added (zero volume is fine).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    /// The corner with the smallest coordinates.
    pub min: Vec3,
    /// The corner with the largest coordinates.
    pub max: Vec3,
}

impl Aabb {
    /// The empty box: adding any point makes it that point.
    pub const EMPTY: Aabb = Aabb {
        min: Vec3::splat(f32::INFINITY),
        max: Vec3::splat(f32::NEG_INFINITY),
    };

    /// Grows the box to contain `p`.
    #[inline]
    pub fn add_point(&mut self, p: Vec3) {
        self.min = self.min.min(p);
        self.max = self.max.max(p);
    }

    /// The box around three points.
    #[inline]
    pub fn of_triangle(p: &[Vec3; 3]) -> Aabb {
        Aabb {
            min: p[0].min(p[1]).min(p[2]),
            max: p[0].max(p[1]).max(p[2]),
        }
    }

    /// True if nothing was added.
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.min.x > self.max.x || self.min.y > self.max.y || self.min.z > self.max.z
    }

    /// The box grown by `m` on every side.
    #[inline]
    pub fn grown(&self, m: f32) -> Aabb {
        Aabb {
            min: self.min - Vec3::splat(m),
            max: self.max + Vec3::splat(m),
        }
    }

    /// True if the two closed boxes share a point (touching counts).
    #[inline]
    pub fn meets(&self, other: &Aabb) -> bool {
        self.min.cmple(other.max).all() && self.max.cmpge(other.min).all()
    }

    /// True if the closed box holds `p`.
    #[inline]
    pub fn holds(&self, p: Vec3) -> bool {
        self.min.cmple(p).all() && p.cmple(self.max).all()
    }

    /// The centre point.
    #[inline]
    pub fn center(&self) -> Vec3 {
        (self.min + self.max) * 0.5
    }

    /// Robust slab test (pbrt-v4): the parameter interval `[t0, t1]` in which `ray` is inside the
    /// box, clipped to `[0, t_max]`, or `None`. `inv_dir` is `1 / ray.dir` per axis (infinite for
    /// zero components, with the sign of the zero). The far value of every slab is enlarged by its
    /// rounding error bound, so a ray through an edge or corner is never reported as a miss.
    #[inline]
    pub fn intersect(&self, ray: &Ray, inv_dir: Vec3, t_max: f32) -> Option<(f32, f32)> {
        if inv_dir.is_finite() {
            self.intersect_lanes(ray, inv_dir, t_max)
        } else {
            self.intersect_axes(ray, inv_dir, t_max)
        }
    }

    /// [`Aabb::intersect`] axis by axis: any ray, a zero direction component included.
    #[inline]
    fn intersect_axes(&self, ray: &Ray, inv_dir: Vec3, t_max: f32) -> Option<(f32, f32)> {
        let mut t0 = 0.0f32;
        let mut t1 = t_max;
        for axis in 0..3 {
            let o = ray.origin[axis];
            let inv = inv_dir[axis];
            if ray.dir[axis] == 0.0 {
                // Parallel to the slab: inside (boundaries included) or a miss, no division.
                if o < self.min[axis] || o > self.max[axis] {
                    return None;
                }
                continue;
            }
            let mut near = (self.min[axis] - o) * inv;
            let mut far = (self.max[axis] - o) * inv;
            if near > far {
                core::mem::swap(&mut near, &mut far);
            }
            far *= 1.0 + 2.0 * gamma(3);
            t0 = if near > t0 { near } else { t0 };
            t1 = if far < t1 { far } else { t1 };
            if t0 > t1 {
                return None;
            }
        }
        Some((t0, t1))
    }

    /// [`Aabb::intersect`] for a ray whose reciprocal direction is finite: the three slabs in
    /// vector lanes, without a branch per axis. The slabs' values are the loop's (the same
    /// operations lane by lane), and with a finite `inv_dir` none is NaN, so their minima and
    /// maxima are what the loop's comparisons pick; the loop returns `None` as soon as the
    /// interval is empty, and the interval only shrinks, so checking it once at the end agrees.
    #[inline]
    fn intersect_lanes(&self, ray: &Ray, inv_dir: Vec3, t_max: f32) -> Option<(f32, f32)> {
        let (o, inv) = (Vec3A::from(ray.origin), Vec3A::from(inv_dir));
        let a = (Vec3A::from(self.min) - o) * inv;
        let b = (Vec3A::from(self.max) - o) * inv;
        let far = a.max(b) * (1.0 + 2.0 * gamma(3));
        let t0 = a.min(b).max_element().max(0.0);
        let t1 = far.min_element().min(t_max);
        (t0 <= t1).then_some((t0, t1))
    }

    /// [`Aabb::intersect`] for four rays, their origins and reciprocal directions per axis lane
    /// by lane (ray `l`'s bound is lane `l` of `t_max`): each lane's `[t0, t1]`, empty
    /// (`t0 > t1`) for a miss, and which lanes are exact. Each lane computes
    /// `intersect_lanes`'s slab values by its operations; where the reciprocal direction is
    /// finite and none of those values is NaN, minima and maxima are exact whatever their
    /// order, so an exact lane's interval is `intersect`'s (equal values; a zero's sign may
    /// differ, which only comparisons read). Other lanes must be asked one ray at a time.
    #[inline(always)]
    pub fn enter4(
        &self,
        origin: &[Vec4; 3],
        inv_dir: &[Vec4; 3],
        t_max: Vec4,
    ) -> (Vec4, Vec4, BVec4A) {
        let (mut t0, mut t1) = (Vec4::ZERO, t_max);
        let mut exact = t_max.cmpeq(t_max);
        for k in 0..3 {
            let a = (Vec4::splat(self.min[k]) - origin[k]) * inv_dir[k];
            let b = (Vec4::splat(self.max[k]) - origin[k]) * inv_dir[k];
            exact &= inv_dir[k].is_finite_mask() & a.cmpeq(a) & b.cmpeq(b);
            t0 = t0.max(a.min(b));
            t1 = t1.min(a.max(b) * (1.0 + 2.0 * gamma(3)));
        }
        (t0, t1, exact)
    }

    /// The rays of four that [`Aabb::intersect`] surely finds missing the box within
    /// `[0, t_max]` (bit `l` for ray `l`): the exact lanes of [`Aabb::enter4`] whose interval is
    /// empty. Other lanes are never reported.
    #[inline(always)]
    pub fn missed_by4(&self, origin: &[Vec4; 3], inv_dir: &[Vec4; 3], t_max: Vec4) -> u32 {
        let (t0, t1, exact) = self.enter4(origin, inv_dir, t_max);
        (t0.cmpgt(t1) & exact).bitmask()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The slabs in lanes give the loop's answer (equal values, both or neither `None`) for
    /// random boxes and rays, rays aimed at corners and edges, and bounds that cut the box.
    #[test]
    fn lanes_agree_with_the_loop() {
        let mut rng = crate::scene::mesh::Rng::new(0x2545_f491);
        let mut unit = move || rng.next_f32();
        let (mut hits, mut misses) = (0, 0);
        for case in 0..100_000 {
            let mut v = || Vec3::new(unit(), unit(), unit()) * 8.0 - 4.0;
            let (a, b) = (v(), v());
            let bx = Aabb {
                min: a.min(b),
                max: a.max(b),
            };
            let origin = v() * 2.0;
            let target = match case % 3 {
                0 => bx.min,                                                     // a corner
                1 => Vec3::new(bx.min.x, bx.max.y, 0.5 * (bx.min.z + bx.max.z)), // an edge
                _ => v(),
            };
            let ray = Ray::new(origin, target - origin);
            let inv = Vec3::ONE / ray.dir;
            if !inv.is_finite() {
                continue;
            }
            let t_max = if case % 5 == 0 {
                unit() * 10.0
            } else {
                f32::INFINITY
            };
            let lanes = bx.intersect_lanes(&ray, inv, t_max);
            assert_eq!(lanes, bx.intersect_axes(&ray, inv, t_max), "case {case}");
            hits += usize::from(lanes.is_some());
            misses += usize::from(lanes.is_none());
        }
        assert!(
            hits > 30_000 && misses > 10_000,
            "{hits} hits, {misses} misses"
        );
    }

    fn inv(d: Vec3) -> Vec3 {
        Vec3::ONE / d
    }

    #[test]
    fn ray_along_box_edge_hits() {
        let b = Aabb {
            min: Vec3::ZERO,
            max: Vec3::ONE,
        };
        let r = Ray::new(Vec3::new(0.0, 0.0, -5.0), Vec3::new(0.0, 0.0, 1.0));
        assert_eq!(
            b.intersect(&r, inv(r.dir), f32::INFINITY),
            Some((5.0, 6.0 * (1.0 + 2.0 * gamma(3))))
        );
    }

    #[test]
    fn negative_zero_direction_is_parallel() {
        let b = Aabb {
            min: Vec3::ZERO,
            max: Vec3::ONE,
        };
        let r = Ray::new(Vec3::new(0.5, 1.0, -5.0), Vec3::new(-0.0, 0.0, 1.0));
        assert!(b.intersect(&r, inv(r.dir), f32::INFINITY).is_some());
        let r = Ray::new(Vec3::new(1.5, 0.5, -5.0), Vec3::new(-0.0, 0.0, 1.0));
        assert!(b.intersect(&r, inv(r.dir), f32::INFINITY).is_none());
    }

    #[test]
    fn flat_box_is_hit() {
        let b = Aabb {
            min: Vec3::new(0.0, 0.0, 1.0),
            max: Vec3::new(1.0, 1.0, 1.0),
        };
        let r = Ray::new(Vec3::new(0.5, 0.5, 0.0), Vec3::new(0.0, 0.0, 1.0));
        assert!(b.intersect(&r, inv(r.dir), f32::INFINITY).is_some());
    }

    /// Four rays at a time: every lane reported missed is one `intersect` misses, every miss of
    /// a ray with a finite reciprocal direction is reported, and an exact lane's interval is
    /// `intersect`'s. Corners, edges, bounds that cut the box, directions along an axis, and
    /// infinite and NaN components included.
    #[test]
    fn four_lanes_report_the_misses_of_intersect() {
        let mut rng = crate::scene::mesh::Rng::new(0x9e37_79b9);
        let mut unit = move || rng.next_f32();
        let special = [0.0, -0.0, f32::INFINITY, f32::NAN, 1e30, 1e-30];
        let (mut reported, mut clear, mut entered) = (0, 0, 0);
        for case in 0..40_000usize {
            let mut v = || Vec3::new(unit(), unit(), unit()) * 8.0 - 4.0;
            let (a, b) = (v(), v());
            let bx = Aabb {
                min: a.min(b),
                max: a.max(b),
            };
            let rays: [(Ray, f32); 4] = core::array::from_fn(|l| {
                let mut origin = v() * 2.0;
                let target = match (case + l) % 3 {
                    0 => bx.min,
                    1 => Vec3::new(bx.min.x, bx.max.y, 0.5 * (bx.min.z + bx.max.z)),
                    _ => v(),
                };
                let mut dir = target - origin;
                if (case + l) % 5 == 0 {
                    let s = special[(case / 5 + l) % special.len()];
                    let axis = (case + l) % 3;
                    if l % 2 == 0 {
                        dir[axis] = s;
                    } else {
                        origin[axis] = s;
                    }
                }
                let t_max = if (case + l) % 4 == 0 {
                    v().x.abs() * 2.0
                } else {
                    f32::INFINITY
                };
                (Ray { origin, dir }, t_max)
            });
            let inv = rays.map(|(r, _)| Vec3::ONE / r.dir);
            let lanes = |f: &dyn Fn(usize) -> Vec3| {
                [0, 1, 2].map(|k| Vec4::from(core::array::from_fn::<f32, 4, _>(|l| f(l)[k])))
            };
            let t_max = Vec4::from(rays.map(|(_, t)| t));
            let (origin, inv_dir) = (lanes(&|l| rays[l].0.origin), lanes(&|l| inv[l]));
            let missed = bx.missed_by4(&origin, &inv_dir, t_max);
            let (t0, t1, exact) = bx.enter4(&origin, &inv_dir, t_max);
            for (l, (ray, t)) in rays.iter().enumerate() {
                let one = bx.intersect(ray, inv[l], *t);
                if exact.bitmask() >> l & 1 == 1 {
                    // An exact lane's interval is `intersect`'s.
                    let four = (t0[l] <= t1[l]).then_some((t0[l], t1[l]));
                    assert_eq!(four, one, "case {case} lane {l}: {ray:?} {t}");
                    entered += usize::from(one.is_some());
                }
                if missed >> l & 1 == 1 {
                    assert_eq!(one, None, "case {case} lane {l}: {ray:?} {t}");
                    reported += 1;
                } else if one.is_none() && inv[l].is_finite() && ray.origin.is_finite() {
                    panic!("case {case} lane {l}: a clear miss not reported: {ray:?} {t}");
                }
                clear += usize::from(one.is_none());
            }
        }
        assert!(
            reported > 20_000,
            "only {reported} of {clear} misses reported"
        );
        assert!(
            entered > 20_000,
            "only {entered} exact lanes entered the box"
        );
    }
}
