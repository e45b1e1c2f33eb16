//! The pre-filter of a shading-texture texel (Andersson et al. 2014, §3.1.2 and Appendix B): the
//! generalised Loviscach filter. Each variable of the pixel integral — x, y (the pixel), u, v (the
//! lens), t (the shutter) — moves the shading coordinate `T` by its derivative; taken as independent
//! standard normals, their sum is one 2D Gaussian with covariance `Σᵢ ∂ᵢT ∂ᵢTᵀ`, written back as two
//! axes `(e, f)` and `(g, h)` that an anisotropic texture lookup (`textureGrad`) takes as its two
//! derivatives.
//!
//! Sampling: a lookup per pixel (MSAA-like, `N = 1`) filters over the whole footprint; one per sample
//! of `N` divides the pixel and lens derivatives by `√N` and the time derivative by `N` (the paper's
//! rule: `N` samples share an area of four dimensions and a line of one). The level's texel size is
//! the smallest footprint ([`floor_axes`]).

use glam::Vec2;

/// The derivatives of the shading coordinate with respect to the five variables of the integral.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Derivatives {
    pub x: Vec2,
    pub y: Vec2,
    pub u: Vec2,
    pub v: Vec2,
    pub t: Vec2,
}

impl Derivatives {
    /// The share of one of `n` samples per pixel: x, y, u, v by `1/√n`, t by `1/n`.
    pub fn per_sample(&self, n: u32) -> Derivatives {
        let n = n.max(1) as f32;
        let k = 1.0 / n.sqrt();
        Derivatives { x: k * self.x, y: k * self.y, u: k * self.u, v: k * self.v, t: self.t / n }
    }

    fn all(&self) -> [Vec2; 5] {
        [self.x, self.y, self.u, self.v, self.t]
    }
}

/// The combined footprint's covariance `(A, B, C) = (Σ ∂s², Σ ∂s ∂t, Σ ∂t²)` (Appendix B, eq. 15).
pub fn covariance(d: &Derivatives) -> (f64, f64, f64) {
    d.all().iter().fold((0.0, 0.0, 0.0), |(a, b, c), g| {
        let (s, t) = (g.x as f64, g.y as f64);
        (a + s * s, b + s * t, c + t * t)
    })
}

/// Two axes `(e, f)`, `(g, h)` whose Gaussian is the combined one: `e² + g² = A`, `ef + gh = B`,
/// `f² + h² = C`; one axis along s when `A > C`, else along t (Loviscach's choice, the better
/// conditioned). A rounding-negative square is clamped to 0.
pub fn combined_axes(d: &Derivatives) -> (Vec2, Vec2) {
    let (a, b, c) = covariance(d);
    let (e, f, g, h) = if a > c {
        let e = a.sqrt();
        let f = if e > 0.0 { b / e } else { 0.0 };
        (e, f, 0.0, (c - f * f).max(0.0).sqrt())
    } else {
        let h = c.sqrt();
        let g = if h > 0.0 { b / h } else { 0.0 };
        ((a - g * g).max(0.0).sqrt(), 0.0, g, h)
    };
    (Vec2::new(e as f32, f as f32), Vec2::new(g as f32, h as f32))
}

/// [`combined_axes`], each at least `texel` long (the level's grid is the finest the shading
/// resolves; the paper bounds the filter's extent by it from below).
pub fn floor_axes(axes: (Vec2, Vec2), texel: f32) -> (Vec2, Vec2) {
    let floor = |a: Vec2| {
        let l = a.length();
        if l >= texel {
            a
        } else if l > 0.0 {
            a * (texel / l)
        } else {
            Vec2::ZERO
        }
    };
    let (p, q) = (floor(axes.0), floor(axes.1));
    // A vanished axis: the perpendicular of the other, one texel long (a footprint is never a line).
    match (p == Vec2::ZERO, q == Vec2::ZERO) {
        (true, true) => (Vec2::new(texel, 0.0), Vec2::new(0.0, texel)),
        (true, false) => (q.perp().normalize() * texel, q),
        (false, true) => (p, p.perp().normalize() * texel),
        (false, false) => (p, q),
    }
}

/// Most taps [`anisotropic_taps`] spreads along a footprint's major axis (beyond, the taps widen:
/// the minor axis is blurred, as hardware anisotropic filtering does past its maximum ratio).
pub const MAX_ANISOTROPIC_TAPS: u32 = 8;

/// Lookups that filter a material texture over an elliptical footprint: `count` trilinear taps at
/// level of detail `lod`, spaced `step` apart (uv) along the major axis and centred on the lookup.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Taps {
    pub count: u32,
    pub lod: f32,
    pub step: Vec2,
}

impl Taps {
    /// Tap `i`'s offset from the footprint's centre, uv.
    pub fn offset(&self, i: u32) -> Vec2 {
        self.step * (i as f32 + 0.5 - 0.5 * self.count as f32)
    }
}

/// The pre-filter of pass 1 (`shaders-glsl/common/texture_sample.glsl`, `texture_prefiltered`): the
/// footprint spanned by the uv derivatives `dx`, `dy` (per atlas texel) over a texture of `size`
/// texels, as taps along its longer axis — as many as the axes' ratio asks, at most
/// [`MAX_ANISOTROPIC_TAPS`] — each at the level whose texel is the larger of the minor axis and the
/// taps' spacing (never below level 0).
pub fn anisotropic_taps(dx: Vec2, dy: Vec2, size: Vec2) -> Taps {
    let (lx, ly) = ((dx * size).length(), (dy * size).length());
    let (major, l_major, l_minor) = if lx >= ly { (dx, lx, ly) } else { (dy, ly, lx) };
    let ratio = l_major / l_minor.max(1e-6);
    let count = (ratio.ceil() as u32).clamp(1, MAX_ANISOTROPIC_TAPS);
    let width = (l_major / count as f32).max(l_minor);
    let lod = if width > 1.0 { width.log2() } else { 0.0 };
    Taps { count, lod, step: major / count as f32 }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn v2() -> impl Strategy<Value = Vec2> {
        (-50.0f32..50.0, -50.0f32..50.0).prop_map(|(x, y)| Vec2::new(x, y))
    }

    fn derivatives() -> impl Strategy<Value = Derivatives> {
        (v2(), v2(), v2(), v2(), v2()).prop_map(|(x, y, u, v, t)| Derivatives { x, y, u, v, t })
    }

    proptest! {
        /// The axes reproduce the covariance of the five independent contributions (eq. 15).
        #[test]
        fn axes_reproduce_the_covariance(d in derivatives()) {
            let (a, b, c) = covariance(&d);
            let (p, q) = combined_axes(&d);
            let (p, q) = (p.as_dvec2(), q.as_dvec2());
            let scale = a.max(c).max(1e-6);
            prop_assert!((p.x * p.x + q.x * q.x - a).abs() <= 1e-5 * scale);
            prop_assert!((p.x * p.y + q.x * q.y - b).abs() <= 1e-5 * scale);
            prop_assert!((p.y * p.y + q.y * q.y - c).abs() <= 1e-5 * scale);
        }

        /// With the pixel alone (EWA), the combined Gaussian is the pixel's: its axes span the same
        /// area, |e h − f g| = |det [∂T/∂x ∂T/∂y]|.
        #[test]
        fn two_dimensions_keep_the_pixel_footprint(x in v2(), y in v2()) {
            let d = Derivatives { x, y, ..Default::default() };
            let (p, q) = combined_axes(&d);
            let area = (p.x as f64 * q.y as f64 - p.y as f64 * q.x as f64).abs();
            let det = (x.x as f64 * y.y as f64 - x.y as f64 * y.x as f64).abs();
            let scale = (x.length() as f64 + 1e-3) * (y.length() as f64 + 1e-3);
            prop_assert!((area - det).abs() <= 1e-4 * scale, "{} vs {}", area, det);
        }

        /// N samples per pixel: the covariance of the lens and pixel terms falls as 1/N, the time
        /// term's as 1/N².
        #[test]
        fn per_sample_scaling(d in derivatives(), n in 1u32..64) {
            let s = d.per_sample(n);
            let n = n as f64;
            let var = |g: Vec2| g.as_dvec2().length_squared();
            for (full, part) in [(d.x, s.x), (d.y, s.y), (d.u, s.u), (d.v, s.v)] {
                prop_assert!((var(part) - var(full) / n).abs() <= 1e-4 * (1.0 + var(full)));
            }
            prop_assert!((var(s.t) - var(d.t) / (n * n)).abs() <= 1e-4 * (1.0 + var(d.t)));
        }
    }

    /// Motion along s alone (Loviscach's case): the footprint stretches along s only.
    #[test]
    fn motion_stretches_along_its_direction() {
        let d = Derivatives {
            x: Vec2::new(1.0, 0.0),
            y: Vec2::new(0.0, 1.0),
            t: Vec2::new(10.0, 0.0),
            ..Default::default()
        };
        let (p, q) = combined_axes(&d);
        assert!((p - Vec2::new(101f32.sqrt(), 0.0)).length() < 1e-5, "{p}");
        assert!((q - Vec2::new(0.0, 1.0)).length() < 1e-6, "{q}");
    }

    /// Axes shorter than a texel grow to one; a vanished one becomes the other's perpendicular.
    #[test]
    fn the_level_texel_bounds_the_footprint_below() {
        let (p, q) = floor_axes((Vec2::new(0.25, 0.0), Vec2::new(0.0, 3.0)), 1.0);
        assert_eq!((p, q), (Vec2::new(1.0, 0.0), Vec2::new(0.0, 3.0)));
        let (p, q) = floor_axes((Vec2::ZERO, Vec2::new(0.0, 2.0)), 0.5);
        assert!((p.length() - 0.5).abs() < 1e-6 && p.dot(q).abs() < 1e-6);
        assert_eq!(floor_axes((Vec2::ZERO, Vec2::ZERO), 2.0), (Vec2::new(2.0, 0.0), Vec2::new(0.0, 2.0)));
    }
    /// The taps cover the footprint's major axis end to end, never exceed the maximum, and their
    /// level's texel is as wide as the minor axis or the taps' spacing, whichever is larger.
    #[test]
    fn anisotropic_taps_span_the_major_axis() {
        let mut rng = crate::sampling::Pcg32::new(41, 2);
        let mut unit = || rng.next_u32() as f32 / 4_294_967_296.0;
        let size = Vec2::new(256.0, 128.0);
        for _ in 0..2000 {
            let scale = 2f32.powf(12.0 * unit() - 10.0);
            let dx = scale * Vec2::new(unit() - 0.5, unit() - 0.5);
            let dy = scale * Vec2::new(unit() - 0.5, unit() - 0.5);
            let taps = anisotropic_taps(dx, dy, size);
            let (lx, ly) = ((dx * size).length(), (dy * size).length());
            let (major, minor) = if lx >= ly { (dx, ly) } else { (dy, lx) };
            assert!((1..=MAX_ANISOTROPIC_TAPS).contains(&taps.count));
            let span = taps.step * taps.count as f32;
            assert!((span - major).length() <= 1e-5 * major.length().max(1e-12), "{span} vs {major}");
            // Symmetric about the centre.
            let (first, last) = (taps.offset(0), taps.offset(taps.count - 1));
            assert!((first + last).length() <= 1e-5 * major.length().max(1e-12));
            let width = ((major * size).length() / taps.count as f32).max(minor);
            let texel = 2f32.powf(taps.lod);
            assert!(taps.lod >= 0.0);
            if width > 1.0 {
                assert!((texel - width).abs() <= 1e-3 * width, "level texel {texel} vs width {width}");
            }
            if taps.count < MAX_ANISOTROPIC_TAPS {
                // Enough taps that their spacing is no wider than the minor axis.
                assert!((major * size).length() / taps.count as f32 <= minor * (1.0 + 1e-4) + 1e-6);
            }
        }
        // An isotropic footprint of 4 texels: one tap at level 2.
        let t = anisotropic_taps(Vec2::new(4.0 / 256.0, 0.0), Vec2::new(0.0, 4.0 / 128.0), size);
        assert_eq!((t.count, t.lod), (1, 2.0));
    }
}
