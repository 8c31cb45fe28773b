//! `shape::first_crossing` is exactly the first front end of `shape::span` below `t_max`, for
//! rays from outside, inside and on the surface of every shape, with `t_max` before, between and
//! beyond the crossings.

use glam::Vec3;
use strahl_core::geom::solid::shape::{first_crossing, span};
use strahl_core::geom::solid::Shape;
use strahl_core::scene::mesh::Rng;

/// The first end of the span in front of the origin and below `t_max`, as the span path finds it.
fn by_span(shape: &Shape, o: Vec3, d: Vec3, t_max: f32) -> Option<(u32, u32, u32)> {
    let s = span(shape, o, d)?;
    let first = [s.enter, s.exit]
        .into_iter()
        .find(|c| c.t > c.t_error && c.t.is_finite())?;
    (first.t < t_max).then_some((first.t.to_bits(), first.t_error.to_bits(), first.face))
}

#[test]
fn first_crossing_is_the_first_front_end_of_the_span() {
    let shapes = [
        Shape::Sphere { radius: 1.3 },
        Shape::Sphere { radius: 1e-3 },
        Shape::Cuboid {
            size: Vec3::new(1.0, 2.0, 0.5),
        },
        Shape::Cylinder {
            bottom_radius: 1.0,
            top_radius: 0.2,
            height: 2.0,
        },
        Shape::Plane {
            normal: Vec3::new(0.3, 1.0, 0.0),
            d: 0.5,
        },
    ];
    let mut rng = Rng::new(11);
    let mut hits = 0;
    for shape in &shapes {
        let scale = match shape {
            Shape::Sphere { radius } => *radius,
            _ => 1.0,
        };
        for i in 0..20_000 {
            let o = match i % 3 {
                0 => rng.direction() * scale * 3.0 * rng.next_f32(),
                // On the surface of a sphere (within rounding), the awkward case.
                1 => rng.direction() * scale,
                _ => rng.direction() * scale * 0.5,
            };
            let d = rng.direction() * (0.1 + 3.0 * rng.next_f32());
            let t_max = match i % 4 {
                0 => f32::INFINITY,
                _ => rng.next_f32() * 4.0 * scale,
            };
            let want = by_span(shape, o, d, t_max);
            let got =
                first_crossing(shape, o, d, t_max).map(|(t, e, f)| (t.to_bits(), e.to_bits(), f));
            assert_eq!(got, want, "{shape:?} o {o:?} d {d:?} t_max {t_max}");
            hits += usize::from(got.is_some());
        }
    }
    assert!(hits > 20_000, "{hits} hits: the rays must meet the shapes");
}

#[test]
fn the_reject_box_never_drops_a_hit() {
    use strahl_core::geom::solid::prepared::{Solids, SpanScratch};
    use strahl_core::geom::solid::{CsgOp, SolidNode};
    use strahl_core::math::ray::Ray;
    use strahl_core::math::transform::Transform;
    let leaf = |shape: Shape, transform: Transform| SolidNode::Leaf {
        shape,
        transform,
        shader: 0,
    };
    let turned = Transform::rotate_xyz_deg(Vec3::new(30.0, 45.0, 10.0));
    let nodes = vec![
        leaf(
            Shape::Cylinder {
                bottom_radius: 1.0,
                top_radius: 0.0,
                height: 3.0,
            },
            Transform::translate(Vec3::new(2.0, 0.0, 0.0)).after(&turned),
        ),
        leaf(
            Shape::Cuboid {
                size: Vec3::new(2.0, 0.1, 1.0),
            },
            turned,
        ),
        leaf(Shape::Sphere { radius: 1.0 }, Transform::IDENTITY),
        SolidNode::Csg {
            op: CsgOp::Subtract,
            a: 1,
            b: 2,
        },
    ];
    let objects = [0, 3];
    let solids = Solids::new(&nodes, &objects, &[]);
    let mut rng = Rng::new(5);
    let mut spans = SpanScratch::default();
    let mut hits = 0;
    for i in 0..40_000 {
        // Aimed near one of the two objects (the cone around x = 2, the box at the origin).
        let centre = if i % 4 < 2 {
            Vec3::new(2.0, 0.0, 0.0)
        } else {
            Vec3::ZERO
        };
        let target = centre + Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 2.0 - 1.0;
        let origin = target + rng.direction() * (0.01 + 8.0 * rng.next_f32());
        // Some rays graze: aimed at a point and nudged along a random direction.
        let dir = if i % 2 == 0 {
            target - origin
        } else {
            rng.direction()
        };
        let ray = Ray::new(origin, dir);
        let inv_dir = Vec3::ONE / ray.dir;
        let t_max = if i % 3 == 0 {
            f32::INFINITY
        } else {
            8.0 * rng.next_f32()
        };
        for object in 0..objects.len() as u32 {
            let plain = solids.first_hit(object, &ray, t_max, &mut spans);
            let boxed = solids.first_hit_in_box(object, &ray, inv_dir, t_max, &mut spans);
            assert_eq!(boxed, plain, "object {object}, {ray:?}, t_max {t_max}");
            hits += usize::from(plain.is_some());
        }
    }
    assert!(hits > 5_000, "{hits} hits: the rays must meet the objects");
}
