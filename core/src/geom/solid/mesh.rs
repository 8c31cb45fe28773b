//! Closed triangle meshes as CSG operands: the spans of a ray inside a mesh.
//!
//! Every face the line of the ray crosses is a crossing (the watertight test, run forwards and
//! backwards from the origin, so a ray starting inside sees the faces behind it too); a crossing
//! against the face's normal enters, one along it leaves. Sorted by `t`, entries and exits pair up
//! into spans by counting depth, so overlapping shells of one mesh merge. An exit before any
//! entry opens its span at `−∞`, an entry never closed runs to `+∞`. Meshes are tested triangle
//! by triangle: this suits the small meshes CSG is built from, not large models (those belong
//! outside CSG, where the octree holds their triangles).

use super::spans::{Boundary, Span};
use crate::geom::triangle::{area_normal, intersect, RayFrame};
use crate::math::ray::Ray;
use alloc::vec::Vec;
use glam::Vec3;

/// One face crossing: `t`, its error bound, the face index and whether the ray enters there.
pub type MeshCrossing = (f32, f32, u32, bool);

/// Appends to `out` the spans of the object-space ray `o + t·d` inside the mesh `triangles`,
/// whose boundaries name leaf `leaf` and the face crossed. `crossings` is scratch.
pub fn spans(
    triangles: &[[Vec3; 3]],
    o: Vec3,
    d: Vec3,
    leaf: u32,
    crossings: &mut Vec<MeshCrossing>,
    out: &mut Vec<Span>,
) {
    crossings.clear();
    for (sign, ray) in [(1.0f32, Ray::new(o, d)), (-1.0, Ray::new(o, -d))] {
        let frame = RayFrame::new(&ray);
        for (i, p) in triangles.iter().enumerate() {
            if let Some(h) = intersect(&frame, p, f32::INFINITY) {
                crossings.push((sign * h.t, h.t_error, i as u32, area_normal(p).dot(d) < 0.0));
            }
        }
    }
    crossings.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.2.cmp(&b.2)));
    let at = |c: &MeshCrossing| Boundary {
        t: c.0,
        t_error: c.1,
        merge_error: c.1,
        leaf,
        face: c.2,
        flip: false,
    };
    let far = |t: f32| Boundary {
        t,
        t_error: 0.0,
        merge_error: 0.0,
        leaf,
        face: 0,
        flip: false,
    };
    let mut open: Option<Boundary> = None;
    let mut depth = 0u32;
    for c in crossings.iter() {
        if c.3 {
            depth += 1;
            if depth == 1 {
                open = Some(at(c));
            }
        } else if depth <= 1 {
            let enter = open.take().unwrap_or(far(f32::NEG_INFINITY));
            out.push(Span { enter, exit: at(c) });
            depth = 0;
        } else {
            depth -= 1;
        }
    }
    if let Some(enter) = open {
        out.push(Span {
            enter,
            exit: far(f32::INFINITY),
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The 12 triangles of the cube `[-1, 1]³`, wound counter-clockwise seen from outside.
    fn cube() -> Vec<[Vec3; 3]> {
        let v = |i: u32| {
            Vec3::new(
                if i & 1 == 0 { -1.0 } else { 1.0 },
                if i & 2 == 0 { -1.0 } else { 1.0 },
                if i & 4 == 0 { -1.0 } else { 1.0 },
            )
        };
        let quads = [
            [0, 2, 3, 1], // z = -1
            [4, 5, 7, 6], // z = +1
            [0, 1, 5, 4], // y = -1
            [2, 6, 7, 3], // y = +1
            [0, 4, 6, 2], // x = -1
            [1, 3, 7, 5], // x = +1
        ];
        let mut t = Vec::new();
        for q in quads {
            t.push([v(q[0]), v(q[1]), v(q[2])]);
            t.push([v(q[0]), v(q[2]), v(q[3])]);
        }
        t
    }

    fn run(o: Vec3, d: Vec3) -> Vec<(f32, f32)> {
        let (mut c, mut out) = (Vec::new(), Vec::new());
        spans(&cube(), o, d, 7, &mut c, &mut out);
        out.iter().map(|s| (s.enter.t, s.exit.t)).collect()
    }

    #[test]
    fn cube_mesh_spans_like_the_box() {
        assert_eq!(run(Vec3::new(0.2, 0.3, -5.0), Vec3::Z), [(4.0, 6.0)]);
        // Starting inside: the span began behind the origin.
        assert_eq!(run(Vec3::new(0.2, 0.3, 0.5), Vec3::Z), [(-1.5, 0.5)]);
        // Through an edge shared by two triangles of a face: still one span.
        assert_eq!(run(Vec3::new(0.0, 0.0, -5.0), Vec3::Z), [(4.0, 6.0)]);
        assert!(run(Vec3::new(3.0, 0.0, -5.0), Vec3::Z).is_empty());
    }
}
