//! Mirror reflection and refraction by Snell's law.

use crate::math::lanes::sqrt;
use glam::Vec3;

/// `d` mirrored about the unit normal `n`.
#[inline]
pub fn reflect(d: Vec3, n: Vec3) -> Vec3 {
    d - n * (2.0 * d.dot(n))
}

/// The direction of the unit vector `d` refracted through a surface with unit normal `n` facing
/// against `d` (`d·n ≤ 0`), going from index `n1` into index `n2`; `None` on total internal
/// reflection (`sin θt > 1`). The result has unit length.
#[inline]
pub fn refract(d: Vec3, n: Vec3, n1: f32, n2: f32) -> Option<Vec3> {
    let eta = n1 / n2;
    let cos_i = -d.dot(n);
    let sin2_t = eta * eta * (1.0 - cos_i * cos_i).max(0.0);
    if sin2_t > 1.0 {
        return None;
    }
    let cos_t = sqrt(1.0 - sin2_t);
    Some(d * eta + n * (eta * cos_i - cos_t))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::norm::Norm;

    #[test]
    fn snell_holds_and_total_internal_reflection_starts_at_the_critical_angle() {
        let n = Vec3::Y;
        let theta = 30f32.to_radians();
        let d = Vec3::new(libm::sinf(theta), -libm::cosf(theta), 0.0);
        let t = refract(d, n, 1.0, 1.5).expect("refracts");
        assert!((t.x - libm::sinf(theta) / 1.5).abs() < 1e-6, "{t:?}");
        assert!((t.norm() - 1.0).abs() < 1e-6);
        let critical = libm::asinf(1.0 / 1.5);
        let just_under = critical - 1e-3;
        let just_over = critical + 1e-3;
        let dir = |a: f32| Vec3::new(libm::sinf(a), -libm::cosf(a), 0.0);
        assert!(refract(dir(just_under), n, 1.5, 1.0).is_some());
        assert!(refract(dir(just_over), n, 1.5, 1.0).is_none());
        assert_eq!(
            reflect(Vec3::new(1.0, -1.0, 0.0), n),
            Vec3::new(1.0, 1.0, 0.0)
        );
    }
}
