//! The one shading model (DESIGN.md "Shading"), CPU side. `shaders-glsl/common/shading.glsl` is its
//! GLSL mirror; `tests/` compares the two through rendered images.
//!
//! ```text
//!     L = albedo · (ambient + Σ E_i · max(0, N·L_i))
//!       + specular · Σ E_i · (n + 8)/(8π) · max(0, N·H_i)^n · max(0, N·L_i)
//! ```
//!
//! with Blinn-Phong exponent `n = 2/roughness² − 2` clamped to [1, 10⁴], `E_i` the light colour
//! (divided by d² for point lights) and `H_i = normalize(L_i + V)`. V points from the shaded point to
//! the **lens sample** (thesis §5.1), not to the lens centre.

use glam::Vec3;

/// A light as seen by the shader at one shutter time, camera space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ShadingLight {
    /// `to_light` is the unit direction towards the light.
    Directional {
        to_light: Vec3,
        color: Vec3,
    },
    Point {
        position: Vec3,
        color: Vec3,
    },
}

/// Blinn-Phong exponent from roughness.
pub fn specular_exponent(roughness: f32) -> f32 {
    let r = roughness.max(1e-3);
    (2.0 / (r * r) - 2.0).clamp(1.0, 1.0e4)
}

/// Outgoing radiance at `position` with unit shading normal `normal` (already facing the viewer) and
/// unit `view` towards the lens sample. Same argument list as `shade()` in `common/shading.glsl`.
#[allow(clippy::too_many_arguments)]
pub fn shade(
    position: Vec3,
    normal: Vec3,
    view: Vec3,
    albedo: Vec3,
    specular: f32,
    roughness: f32,
    lights: &[ShadingLight],
    ambient: Vec3,
) -> Vec3 {
    let n_exp = specular_exponent(roughness);
    let norm = (n_exp + 8.0) / (8.0 * std::f32::consts::PI);
    let mut diffuse = ambient;
    let mut spec = Vec3::ZERO;
    for light in lights {
        let (l, e) = match *light {
            ShadingLight::Directional { to_light, color } => (to_light, color),
            ShadingLight::Point { position: lp, color } => {
                let d = lp - position;
                let d2 = d.length_squared().max(1e-8);
                (d / d2.sqrt(), color / d2)
            }
        };
        let ndl = normal.dot(l).max(0.0);
        if ndl <= 0.0 {
            continue;
        }
        diffuse += e * ndl;
        if specular > 0.0 {
            let h = (l + view).normalize_or_zero();
            spec += e * (norm * normal.dot(h).max(0.0).powf(n_exp) * ndl);
        }
    }
    albedo * diffuse + specular * spec
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lambert_only_matches_cosine() {
        let l =
            [ShadingLight::Directional { to_light: Vec3::new(0.0, 1.0, 1.0).normalize(), color: Vec3::ONE }];
        let c = shade(Vec3::ZERO, Vec3::Y, Vec3::Z, Vec3::ONE, 0.0, 0.5, &l, Vec3::ZERO);
        assert!((c.x - std::f32::consts::FRAC_1_SQRT_2).abs() < 1e-6);
    }

    #[test]
    fn point_light_falls_off_with_square_distance() {
        let l = |d: f32| [ShadingLight::Point { position: Vec3::new(0.0, d, 0.0), color: Vec3::ONE }];
        let a = shade(Vec3::ZERO, Vec3::Y, Vec3::Y, Vec3::ONE, 0.0, 0.5, &l(1.0), Vec3::ZERO);
        let b = shade(Vec3::ZERO, Vec3::Y, Vec3::Y, Vec3::ONE, 0.0, 0.5, &l(2.0), Vec3::ZERO);
        assert!((a.x / b.x - 4.0).abs() < 1e-4);
    }

    #[test]
    fn specular_peaks_at_mirror_direction() {
        let l =
            [ShadingLight::Directional { to_light: Vec3::new(1.0, 1.0, 0.0).normalize(), color: Vec3::ONE }];
        let mirror = Vec3::new(-1.0, 1.0, 0.0).normalize();
        let off = Vec3::new(-0.2, 1.0, 0.5).normalize();
        let a = shade(Vec3::ZERO, Vec3::Y, mirror, Vec3::ZERO, 1.0, 0.2, &l, Vec3::ZERO);
        let b = shade(Vec3::ZERO, Vec3::Y, off, Vec3::ZERO, 1.0, 0.2, &l, Vec3::ZERO);
        assert!(a.x > 2.0 * b.x);
    }
}
