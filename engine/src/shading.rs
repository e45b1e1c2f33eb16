//! The one shading model (docs/MODEL.md "Shading"), CPU side. `shaders-glsl/common/shading.glsl` is its
//! GLSL mirror; `tests/` compares the two through rendered images.
//!
//! ```text
//!     L = albedo · (ambient + Σ E_i · max(0, N·L_i))
//!       + specular · Σ E_i · (n + 8)/(8π) · max(0, N·H_i)^n · max(0, N·L_i)
//! ```
//!
//! with Blinn-Phong exponent `n = 2/roughness² − 2` clamped to [1, 10⁴], `E_i` the light's irradiance
//! ([`ShadingLight::incident`]) and `H_i = normalize(L_i + V)`. V points from the shaded point to the
//! **lens sample** (thesis §5.1), not to the lens centre.
//!
//! `E_i` is the light colour for a directional light, divided by d² (d the distance to the light) for
//! a point light, and for a spot light with unit axis `a` (from the light into the scene) also
//! multiplied by the cone falloff of the angle θ between `a` and the direction from the light to the
//! point:
//!
//! ```text
//!     falloff = 1                      when cos θ ≥ cos θ_inner
//!             = 0                      when cos θ ≤ cos θ_outer
//!             = x² (3 − 2x),  x = (cos θ − cos θ_outer) / (cos θ_inner − cos θ_outer)   otherwise
//! ```
//!
//! (a smoothstep in cos θ; a hard edge when the two angles are equal). A light that casts shadows has
//! its colour multiplied by the transmittance towards it before it gets here
//! ([`ShadingLight::attenuated`], the CPU reference's shadow rays).

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
    /// `axis`: unit direction the spot points (from the light into the scene); the cone's cosines,
    /// `cos_inner ≥ cos_outer`.
    Spot {
        position: Vec3,
        axis: Vec3,
        cos_inner: f32,
        cos_outer: f32,
        color: Vec3,
    },
}

/// The spot cone's falloff at `cos_angle`, the cosine of the angle between the spot's axis and the
/// direction from the light to the shaded point (see the module docs). `spot_falloff` in
/// `common/shading.glsl`.
pub fn spot_falloff(cos_angle: f32, cos_inner: f32, cos_outer: f32) -> f32 {
    if cos_angle >= cos_inner {
        1.0
    } else if cos_angle <= cos_outer {
        0.0
    } else {
        let x = (cos_angle - cos_outer) / (cos_inner - cos_outer);
        x * x * (3.0 - 2.0 * x)
    }
}

impl ShadingLight {
    /// The unit direction from `position` towards the light and the irradiance `E` it brings there
    /// (before the cosine): the light's colour, over d² for point and spot lights, times the cone
    /// falloff for a spot.
    #[inline]
    pub fn incident(&self, position: Vec3) -> (Vec3, Vec3) {
        match *self {
            ShadingLight::Directional { to_light, color } => (to_light, color),
            ShadingLight::Point { position: lp, color } => {
                let d = lp - position;
                let d2 = d.length_squared().max(1e-8);
                (d / d2.sqrt(), color / d2)
            }
            ShadingLight::Spot { position: lp, axis, cos_inner, cos_outer, color } => {
                let d = lp - position;
                let d2 = d.length_squared().max(1e-8);
                let l = d / d2.sqrt();
                (l, color * spot_falloff(-l.dot(axis), cos_inner, cos_outer) / d2)
            }
        }
    }
    /// The light with its colour multiplied per channel by `transmittance` (a shadow ray's answer).
    pub fn attenuated(self, transmittance: Vec3) -> ShadingLight {
        match self {
            ShadingLight::Directional { to_light, color } => {
                ShadingLight::Directional { to_light, color: color * transmittance }
            }
            ShadingLight::Point { position, color } => {
                ShadingLight::Point { position, color: color * transmittance }
            }
            ShadingLight::Spot { position, axis, cos_inner, cos_outer, color } => {
                ShadingLight::Spot { position, axis, cos_inner, cos_outer, color: color * transmittance }
            }
        }
    }
    /// Where the light is, for a shadow ray: `Err(direction towards it)` for a directional light,
    /// `Ok(position)` otherwise.
    pub fn position(&self) -> Result<Vec3, Vec3> {
        match *self {
            ShadingLight::Directional { to_light, .. } => Err(to_light),
            ShadingLight::Point { position, .. } | ShadingLight::Spot { position, .. } => Ok(position),
        }
    }
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
        let (l, e) = light.incident(position);
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
    fn spot_cone_is_full_inside_dark_outside_and_monotone_between() {
        let (inner, outer) = (20f32.to_radians(), 35f32.to_radians());
        let spot = ShadingLight::Spot {
            position: Vec3::new(0.0, 2.0, 0.0),
            axis: -Vec3::Y,
            cos_inner: inner.cos(),
            cos_outer: outer.cos(),
            color: Vec3::ONE,
        };
        let point = ShadingLight::Point { position: Vec3::new(0.0, 2.0, 0.0), color: Vec3::ONE };
        // Floor points at angle θ off the axis.
        let at = |deg: f32| Vec3::new(2.0 * deg.to_radians().tan(), 0.0, 0.0);
        let shade_at = |l: ShadingLight, deg: f32| {
            shade(at(deg), Vec3::Y, Vec3::Y, Vec3::ONE, 0.0, 0.5, &[l], Vec3::ZERO).x
        };
        for deg in [0.0, 5.0, 19.9] {
            assert_eq!(shade_at(spot, deg), shade_at(point, deg), "inside the inner cone at {deg}°");
        }
        for deg in [35.1, 50.0, 89.0] {
            assert_eq!(shade_at(spot, deg), 0.0, "outside the outer cone at {deg}°");
        }
        let mut last = 1.0;
        for i in 0..=150 {
            let deg = 20.0 + 15.0 * i as f32 / 150.0;
            let f = spot_falloff(deg.to_radians().cos(), inner.cos(), outer.cos());
            assert!(f <= last && (0.0..=1.0).contains(&f), "{deg}°: {f} after {last}");
            last = f;
        }
        assert_eq!(spot_falloff(inner.cos(), inner.cos(), outer.cos()), 1.0);
        assert_eq!(spot_falloff(outer.cos(), inner.cos(), outer.cos()), 0.0);
        // Half-way in cos θ, the smoothstep is one half; a hard edge when the angles are equal.
        let mid = 0.5 * (inner.cos() + outer.cos());
        assert!((spot_falloff(mid, inner.cos(), outer.cos()) - 0.5).abs() < 1e-5);
        assert_eq!(spot_falloff(0.9, 0.9, 0.9), 1.0);
        assert_eq!(spot_falloff(0.8999, 0.9, 0.9), 0.0);
    }

    #[test]
    fn attenuation_scales_each_channel_of_the_light() {
        let l = ShadingLight::Point { position: Vec3::new(0.0, 1.0, 0.0), color: Vec3::ONE };
        let v = Vec3::new(0.5, 0.25, 0.0);
        let a = shade(Vec3::ZERO, Vec3::Y, Vec3::Y, Vec3::ONE, 0.3, 0.5, &[l], Vec3::splat(0.1));
        let b =
            shade(Vec3::ZERO, Vec3::Y, Vec3::Y, Vec3::ONE, 0.3, 0.5, &[l.attenuated(v)], Vec3::splat(0.1));
        assert!(((b - 0.1) - (a - 0.1) * v).abs().max_element() < 1e-6, "{a} {b}");
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
