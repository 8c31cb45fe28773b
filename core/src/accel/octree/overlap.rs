//! Triangle/box overlap by the separating-axis theorem (Akenine-Möller 2001).

use glam::Vec3;

/// True unless one of the 13 separating axes (3 box faces, the triangle's plane, 9 edge cross
/// products) separates the triangle from the box `centre ± half`. Touching counts as overlap.
pub(super) fn triangle_box_overlap(center: Vec3, half: Vec3, tri: &[Vec3; 3]) -> bool {
    let v = [tri[0] - center, tri[1] - center, tri[2] - center];
    // Box face normals: the triangle's extent on each axis.
    for a in 0..3 {
        let lo = v[0][a].min(v[1][a]).min(v[2][a]);
        let hi = v[0][a].max(v[1][a]).max(v[2][a]);
        if lo > half[a] || hi < -half[a] {
            return false;
        }
    }
    let e = [v[1] - v[0], v[2] - v[1], v[0] - v[2]];
    // The triangle's plane.
    let n = e[0].cross(e[1]);
    let d = n.dot(v[0]);
    let r = half.dot(n.abs());
    if d.abs() > r {
        return false;
    }
    // Cross products of the box axes with the triangle edges.
    for edge in &e {
        for a in 0..3 {
            let mut unit = Vec3::ZERO;
            unit[a] = 1.0;
            let axis = unit.cross(*edge);
            let p0 = axis.dot(v[0]);
            let p1 = axis.dot(v[1]);
            let p2 = axis.dot(v[2]);
            let r = half.dot(axis.abs());
            if p0.min(p1).min(p2) > r || p0.max(p1).max(p2) < -r {
                return false;
            }
        }
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn separates_and_touches() {
        let c = Vec3::ZERO;
        let h = Vec3::ONE;
        let inside = [
            Vec3::new(-0.5, 0.0, 0.0),
            Vec3::new(0.5, 0.0, 0.0),
            Vec3::new(0.0, 0.5, 0.0),
        ];
        assert!(triangle_box_overlap(c, h, &inside));
        let far = inside.map(|p| p + Vec3::new(5.0, 0.0, 0.0));
        assert!(!triangle_box_overlap(c, h, &far));
        // Touches the face x = 1 at a vertex.
        let touch = [
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(2.0, 0.0, 0.0),
            Vec3::new(2.0, 0.5, 0.0),
        ];
        assert!(triangle_box_overlap(c, h, &touch));
        // Its bounding box overlaps the corner, the triangle does not (diagonal edge axis).
        let diag = [
            Vec3::new(2.5, 0.0, 0.0),
            Vec3::new(0.0, 2.5, 0.0),
            Vec3::new(2.5, 2.5, 0.0),
        ];
        assert!(!triangle_box_overlap(c, h, &diag));
    }
}
