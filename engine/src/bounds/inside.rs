//! The 5D inside test: does the thin-lens ray for (pixel, lens) hit the triangle at shutter time t?
//! This is what the stochastic rasterizer's fragment shader does for every sample a bound covers.

use glam::{Vec2, Vec3};

use super::{bound, BoundKind, MovingTriangle};
use crate::sampling::Pcg32;
use crate::scene::camera::Intrinsics;

/// A ray–triangle hit at one (x, y, u, v, t) sample.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// View depth `z = −p.z` of the hit point (for the depth test), within `[near, far]`.
    pub depth_z: f32,
    /// Weights of the triangle's vertices at time t (sum to 1, each ≥ 0).
    pub barycentrics: Vec3,
}

/// Relative threshold below which a triangle is treated as degenerate (`|e₁ × e₂| ≤ ε·|e₁|·|e₂|`) or
/// the ray as parallel to it (`|d · n| ≤ ε·|n|`): both cover no area.
const PARALLEL_EPS: f32 = 1e-7;

/// Intersects the thin-lens primary ray through `pixel` from lens sample `lens` (unit-aperture
/// coordinates, already mapped to the aperture shape) with the triangle at shutter time `t`
/// (Möller–Trumbore in camera space). Edges are inclusive. Hits outside the depth range
/// `[near, far]` are rejected; so are degenerate triangles and rays in the triangle's plane.
///
/// As on the GPU, it is meant for samples inside a non-culled [`super::bound`]: for a triangle that is
/// degenerate at every time (culled) it may report hits that are f32 rounding artifacts.
pub fn sample_hit(tri: &MovingTriangle, k: &Intrinsics, pixel: Vec2, lens: Vec2, t: f32) -> Option<Hit> {
    let [a, b, c] = tri.at(t);
    let (o, d) = k.primary_ray(pixel, lens);
    if !(a.is_finite() && b.is_finite() && c.is_finite() && o.is_finite() && d.is_finite()) {
        return None;
    }
    let e1 = b - a;
    let e2 = c - a;
    let n = e1.cross(e2);
    let n_len = n.length();
    if n_len.is_nan() || n_len <= PARALLEL_EPS * e1.length() * e2.length() {
        return None; // degenerate
    }
    let p = d.cross(e2);
    let det = e1.dot(p); // = −d·n
    if det.is_nan() || det.abs() <= PARALLEL_EPS * n_len {
        return None;
    }
    let inv = 1.0 / det;
    let s = o - a;
    let b1 = s.dot(p) * inv;
    if !(0.0..=1.0).contains(&b1) {
        return None;
    }
    let q = s.cross(e1);
    let b2 = d.dot(q) * inv;
    if !(b2 >= 0.0 && b1 + b2 <= 1.0) {
        return None;
    }
    let w = Vec3::new(1.0 - b1 - b2, b1, b2);
    // Depth from the barycentric interpolation of the vertices (what the GPU interpolates).
    let depth_z = -(w.x * a.z + w.y * b.z + w.z * c.z);
    if !(depth_z >= k.near && depth_z <= k.far) {
        return None;
    }
    Some(Hit { depth_z, barycentrics: w })
}

/// Monte Carlo sample-test efficiency of `kind` for `tri`: the fraction of the samples the bound makes
/// the GPU test — pixel positions uniform in (bound ∩ viewport), lens uniform on the aperture, t
/// uniform — that [`sample_hit`] accepts. `n_samples` counts tested samples (rejection sampling in the
/// bound's box, at most 64 tries per sample). Deterministic (fixed seed). Returns 0 when the bound is
/// culled or does not overlap the viewport.
pub fn sample_test_efficiency_estimate(
    tri: &MovingTriangle,
    k: &Intrinsics,
    kind: BoundKind,
    n_samples: usize,
) -> f64 {
    let b = bound(tri, k, kind);
    let Some((lo, hi)) = b.aabb() else { return 0.0 };
    let lo = lo.max(Vec2::ZERO);
    let hi = hi.min(Vec2::new(k.width, k.height));
    if !(lo.x < hi.x && lo.y < hi.y) {
        return 0.0;
    }
    let mut rng = Pcg32::new(0x5eed_b0d5, 7);
    let (mut tested, mut hits) = (0usize, 0usize);
    for _ in 0..n_samples.saturating_mul(64) {
        if tested == n_samples {
            break;
        }
        let px = lo + (hi - lo) * Vec2::new(rng.next_f32(), rng.next_f32());
        if !b.contains(px, 0.0) {
            continue;
        }
        tested += 1;
        let lens = k.aperture.map(Vec2::new(rng.next_f32(), rng.next_f32()));
        let t = rng.next_f32();
        if sample_hit(tri, k, px, lens, t).is_some() {
            hits += 1;
        }
    }
    if tested == 0 {
        0.0
    } else {
        hits as f64 / tested as f64
    }
}
