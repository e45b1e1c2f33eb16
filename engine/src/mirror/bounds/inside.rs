//! The 5D inside test: does the thin-lens ray for (pixel, lens) hit the triangle at shutter time t?
//! This is what the stochastic rasterizer's fragment shader does for every sample a bound covers.

use glam::Vec2;

use super::{bound, BoundKind, MovingTriangle};
use crate::geometry::{intersect_triangle, TriangleHit};
use crate::sampling::Pcg32;
use crate::scene::camera::Intrinsics;

/// Intersects the thin-lens primary ray through `pixel` from lens sample `lens` (unit-aperture
/// coordinates, already mapped to the aperture shape) with the triangle at shutter time `t`: the shared
/// [`intersect_triangle`] (Möller–Trumbore in camera space, edges inclusive; degenerate triangles and
/// rays in the triangle's plane rejected), then the depth range — hits whose view depth lies outside
/// `[near, far]` are rejected. `sample_hit` in `shaders-glsl/stochastic/inside.glsl` mirrors exactly
/// this.
///
/// As on the GPU, it is meant for samples inside a non-culled [`super::bound`]: for a triangle that is
/// degenerate at every time (culled) it may report hits that are f32 rounding artifacts.
pub fn sample_hit(
    tri: &MovingTriangle,
    k: &Intrinsics,
    pixel: Vec2,
    lens: Vec2,
    t: f32,
) -> Option<TriangleHit> {
    let (o, d) = k.primary_ray(pixel, lens);
    let hit = intersect_triangle(&tri.at(t), o, d)?;
    (hit.depth_z >= k.near && hit.depth_z <= k.far).then_some(hit)
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
