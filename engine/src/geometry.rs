//! The geometry model, written once: a triangle moving linearly over the shutter
//! ([`MovingTriangle`]) and the one ray–triangle intersector ([`intersect_triangle`]) that every CPU
//! consumer uses — the bounds' inside test ([`crate::mirror::bounds::sample_hit`], the specification of the
//! GPU's `sample_hit` in `shaders-glsl/stochastic/inside.glsl`) and the reference's BVH
//! ([`crate::reference::Bvh`]). A hit is therefore the same hit, with the same barycentrics and the
//! same depth, whether the reference or a GPU technique finds it (docs/MODEL.md "The model").
//!
//! Why a module of its own and not `bounds`: the bounds are the CPU mirror of one GPU technique's
//! culling (stochastic rasterization), while the triangle and the hit are the model itself, which the
//! reference must share without depending on any technique.

use glam::{DVec3, Vec3};

/// Relative threshold of [`MovingTriangle::is_degenerate`] (times the longest edge², `f64`). The GLSL
/// mirror (`shaders-glsl/stochastic/bounds.glsl`) uses the same value in `float`, where rounding
/// usually keeps an exactly degenerate triangle above it: the GPU then builds a (conservative) bound
/// where the CPU culls.
pub const DEGENERATE_EPS: f64 = 1e-12;

/// Relative threshold of [`intersect_triangle`] below which a triangle is treated as degenerate
/// (`|e₁ × e₂| ≤ ε·|e₁|·|e₂|`) or the ray as parallel to it (`|d · n| ≤ ε·|n|`): both cover no area.
/// `PARALLEL_EPS` in `inside.glsl`.
pub const PARALLEL_EPS: f32 = 1e-7;

/// A triangle whose camera-space vertices move linearly from `v0` (shutter open) to `v1` (close).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MovingTriangle {
    pub v0: [Vec3; 3],
    pub v1: [Vec3; 3],
}

impl MovingTriangle {
    /// A triangle that does not move.
    pub fn fixed(v: [Vec3; 3]) -> Self {
        MovingTriangle { v0: v, v1: v }
    }
    /// Camera-space vertices at shutter time `t ∈ [0, 1]`, interpolated as the GPU does: GLSL
    /// `mix(p0, p1, t)`, which the GLSL spec defines as `p0·(1 − t) + p1·t` — glam's `lerp`.
    #[inline(always)]
    /// The triangle at shutter time `t`: `v0 + (v1 − v0)·t`, which is exactly `v0` for a vertex that
    /// does not move (the `(1 − t)·v0 + t·v1` form is not: a face exactly on the near plane then rounded
    /// out of `[near, far]` for some t). `shutter_lerp` in `inside.glsl` is the same expression.
    pub fn at(&self, t: f32) -> [Vec3; 3] {
        std::array::from_fn(|i| self.v0[i] + (self.v1[i] - self.v0[i]) * t)
    }
    /// The six end vertices (open then close); their convex hull contains the triangle at every time.
    pub fn end_vertices(&self) -> [Vec3; 6] {
        [self.v0[0], self.v0[1], self.v0[2], self.v1[0], self.v1[1], self.v1[2]]
    }
    /// Are all six end vertices finite?
    pub fn is_finite(&self) -> bool {
        self.end_vertices().iter().all(|v| v.is_finite())
    }
    /// Does the triangle have zero area at every time in [0, 1]? The area vector
    /// `cross(e₁(t), e₂(t)) = (1−t)²·X₀ + t(1−t)·Xₘ + t²·X₁` is checked coefficient by coefficient in
    /// `f64`, relative to the triangle's extent (threshold [`DEGENERATE_EPS`]·L²).
    pub fn is_degenerate(&self) -> bool {
        let d = |v: Vec3| v.as_dvec3();
        let e = |v: &[Vec3; 3]| (d(v[1]) - d(v[0]), d(v[2]) - d(v[0]));
        let (a0, b0) = e(&self.v0);
        let (a1, b1) = e(&self.v1);
        let x0 = a0.cross(b0);
        let x1 = a1.cross(b1);
        let xm = a0.cross(b1) + a1.cross(b0);
        let l2 = [a0, b0, a1, b1].iter().map(|v| v.length_squared()).fold(0.0, f64::max);
        let eps = DEGENERATE_EPS * l2;
        let small = |x: DVec3| x.length() <= eps;
        small(x0) && small(x1) && small(xm)
    }
}

/// The shutter times of an object's motion keys (strictly increasing, the first 0 and the last 1, at
/// least two) and the one rule, shared by the reference and every GPU path, that maps a shutter time to
/// the key segment holding it and the time within it:
///
/// - segment `j` holds `t` when `times[j] ≤ t < times[j + 1]`; `t` below 0 goes to the first segment
///   and `t ≥ 1` to the last;
/// - the local time is `min((t − times[j]) · inv_len[j], 1)` with `inv_len[j] = 1 / (times[j+1] −
///   times[j])` rounded once to `f32` (on the CPU, and handed to the GPU as is): one subtraction and
///   one multiplication, exactly rounded on both sides. With the two keys (0, 1) it is `t` itself, so
///   two-key scenes render exactly as before keys existed.
#[derive(Clone, Debug, PartialEq)]
pub struct KeyTimes {
    times: Vec<f32>,
    inv_len: Vec<f32>,
}

impl KeyTimes {
    /// The keys at `times`; `None` unless there are at least two, strictly increasing, the first 0
    /// and the last 1.
    pub fn new(times: Vec<f32>) -> Option<KeyTimes> {
        let ok = times.len() >= 2
            && times[0] == 0.0
            && *times.last().expect("two") == 1.0
            && times.windows(2).all(|w| w[0] < w[1]);
        if !ok {
            return None;
        }
        let inv_len = times.windows(2).map(|w| 1.0 / (w[1] - w[0])).collect();
        Some(KeyTimes { times, inv_len })
    }
    pub fn times(&self) -> &[f32] {
        &self.times
    }
    /// `1 / (times[j+1] − times[j])` per segment.
    pub fn inv_len(&self) -> &[f32] {
        &self.inv_len
    }
    pub fn segments(&self) -> usize {
        self.times.len() - 1
    }
    /// The segment holding shutter time `t`.
    #[inline(always)]
    pub fn segment_of(&self, t: f32) -> usize {
        // Interior keys at or below t (a NaN t goes to the first segment).
        self.times[1..self.times.len() - 1].partition_point(|&k| k <= t)
    }
    /// The time within segment `j` of shutter time `t` (see the type's docs).
    #[inline(always)]
    pub fn local_time(&self, j: usize, t: f32) -> f32 {
        ((t - self.times[j]) * self.inv_len[j]).min(1.0)
    }
    /// The segment holding `t` and the time within it.
    #[inline(always)]
    pub fn locate(&self, t: f32) -> (usize, f32) {
        let j = self.segment_of(t);
        (j, self.local_time(j, t))
    }
}

/// Where a ray meets a triangle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TriangleHit {
    /// View depth `z = −p.z` of the hit point `p`: the barycentric interpolation of the vertices' `z`
    /// (what the GPU interpolates and depth-tests), clamped to the vertices' depth range (rounding can
    /// leave it by an ulp; a face exactly on the near plane must stay at `near`).
    pub depth_z: f32,
    /// Weights of the triangle's vertices (sum to 1, each ≥ 0).
    pub barycentrics: Vec3,
    /// The ray sees the triangle's back (`d · n > 0`, n = (b − a) × (c − a)): Möller–Trumbore's
    /// determinant is negative. The side of the stochastic rasterizer's per-pixel shading groups.
    pub back: bool,
}

impl TriangleHit {
    /// The hit point `w₀·a + w₁·b + w₂·c` on the triangle `p` it was found on, as the GPU shades it
    /// (`stochastic.frag`); its `−z`, clamped to the vertices' depth range, is exactly
    /// [`TriangleHit::depth_z`].
    #[inline]
    pub fn point(&self, p: &[Vec3; 3]) -> Vec3 {
        let w = self.barycentrics;
        w.x * p[0] + w.y * p[1] + w.z * p[2]
    }
}

/// Möller–Trumbore intersection of the ray `o + s·d` (camera space) with the triangle `p` (two-sided,
/// edges inclusive), with no range on the ray parameter: the caller tests [`TriangleHit::depth_z`]
/// (the GPU's `[near, far]`, the reference's nearest hit). `None` for a miss, a degenerate triangle
/// (`|e₁ × e₂| ≤ ε·|e₁|·|e₂|`), a ray in the triangle's plane (`|d·n| ≤ ε·|n|`, ε = [`PARALLEL_EPS`])
/// and non-finite input, so it never returns NaN.
///
/// The arithmetic is that of `sample_hit` in `shaders-glsl/stochastic/inside.glsl`, operation for
/// operation, so a hit has the same barycentrics and depth on both sides. The rejection tests form a
/// pure conjunction, so their order cannot change the answer: the cheap barycentric range tests come
/// first here (most of the reference's triangle tests are misses), the degeneracy test with its square
/// roots last, while the GLSL tests degeneracy first.
#[inline(always)]
pub fn intersect_triangle(p: &[Vec3; 3], o: Vec3, d: Vec3) -> Option<TriangleHit> {
    let [a, b, c] = *p;
    let e1 = b - a;
    let e2 = c - a;
    let pv = d.cross(e2);
    let det = e1.dot(pv); // = −d·n
    let inv = 1.0 / det;
    let s = o - a;
    let b1 = s.dot(pv) * inv;
    if !(0.0..=1.0).contains(&b1) {
        return None;
    }
    let q = s.cross(e1);
    let b2 = d.dot(q) * inv;
    if !(b2 >= 0.0 && b1 + b2 <= 1.0) {
        return None;
    }
    if !(a.is_finite() && b.is_finite() && c.is_finite() && o.is_finite() && d.is_finite()) {
        return None;
    }
    let n_len = e1.cross(e2).length();
    if n_len.is_nan() || n_len <= PARALLEL_EPS * e1.length() * e2.length() {
        return None; // degenerate
    }
    if det.is_nan() || det.abs() <= PARALLEL_EPS * n_len {
        return None; // the ray lies in the triangle's plane
    }
    let w = Vec3::new(1.0 - b1 - b2, b1, b2);
    // Clamped to the vertices' depth range, which holds every convex combination: the rounded sum can
    // leave it by an ulp (w's rounded components need not sum to 1), and for a face lying exactly on the
    // near (or far) plane that decided [near, far] by rounding noise, differently on the GPU.
    let (z_lo, z_hi) = (-(a.z.max(b.z).max(c.z)), -(a.z.min(b.z).min(c.z)));
    let depth_z = (-(w.x * a.z + w.y * b.z + w.z * c.z)).max(z_lo).min(z_hi);
    Some(TriangleHit { depth_z, barycentrics: w, back: det < 0.0 })
}

/// Barycentrics of the point where the ray `o + s·d` meets the plane of `p` (no range checks): `None`
/// for a degenerate triangle or a ray in its plane. `plane_barycentrics` in `inside.glsl` (footprints;
/// decoupled shading's shading points, [`crate::mirror::decoupled::shading_point`]).
pub fn plane_barycentrics(p: &[Vec3; 3], o: Vec3, d: Vec3) -> Option<Vec3> {
    let (e1, e2) = (p[1] - p[0], p[2] - p[0]);
    let n_len = e1.cross(e2).length();
    let pv = d.cross(e2);
    let det = e1.dot(pv);
    let eps = PARALLEL_EPS;
    if !(n_len > eps * e1.length() * e2.length() && det.abs() > eps * n_len) {
        return None;
    }
    let inv = 1.0 / det;
    let s = o - p[0];
    let b1 = s.dot(pv) * inv;
    let b2 = d.dot(s.cross(e1)) * inv;
    Some(Vec3::new(1.0 - b1 - b2, b1, b2))
}

/// Relative margin of [`back_facing_segment`]: the facing function must exceed this fraction of its
/// scale (`|n|·(|a| + R)`) before a triangle counts as back-facing, far above the rounding of the GPU's
/// determinant, so a triangle seen nearly edge-on is always kept.
pub const BACK_FACING_MARGIN: f32 = 1e-4;

/// Whether every camera ray from any lens point (a thin lens of radius `r`: any aperture inside that
/// disk, centred on the camera-space origin in the plane z = 0) meets the triangle from its back
/// ([`TriangleHit::back`]) at every time of a linear motion from `p` (its vertices at the start) to
/// `q` (at the end), by relative margin `margin` ([`BACK_FACING_MARGIN`]). Conservative: `true` only
/// when no such ray sees the front. Texture-space shading's pass 1 culls one-sided triangles with it
/// over every key segment (`texture_space::cull::back_facing`), the stochastic rasterizer's geometry
/// stage over each draw's time interval (`common/back_facing.glsl`, the GLSL mirror).
///
/// A ray from lens point `L = (Lx, Ly, 0)` meets the triangle `(a, b, c)` from the back when
/// `g = n·(a − L) > 0`, `n = (b − a) × (c − a)` (Möller–Trumbore's determinant is `−d·n`, and `d` points
/// from `L` towards the hit, which lies in front of the lens). Over the lens disk `|L| ≤ r` its smallest
/// value is `n·a − r·|(nx, ny)|`. At time `s` of the motion the edges are linear in `s`, so `n(s)` is a
/// quadratic and `n(s)·a(s)` a cubic: in the Bernstein basis, the smallest of the cubic's four
/// coefficients bounds it from below over `s ∈ [0, 1]`, and since a norm is convex `|nxy(s)|` is at most
/// the largest `|Nxy|` of the quadratic's three control vectors. When the lower bound minus `r` times
/// the upper bound is positive, by the margin, no ray sees the front. For a triangle at rest (`p = q`)
/// the test is exact but for the margin.
pub fn back_facing_segment(r: f32, p: &[Vec3; 3], q: &[Vec3; 3], margin: f32) -> bool {
    let (e1p, e2p) = (p[1] - p[0], p[2] - p[0]);
    let (e1q, e2q) = (q[1] - q[0], q[2] - q[0]);
    // n(s) = (1 − s)²·n0 + 2s(1 − s)·n1 + s²·n2.
    let n0 = e1p.cross(e2p);
    let n1 = 0.5 * (e1p.cross(e2q) + e1q.cross(e2p));
    let n2 = e1q.cross(e2q);
    let (a0, a1) = (p[0], q[0]);
    // n(s)·a(s), a(s) = (1 − s)·a0 + s·a1: its cubic Bernstein coefficients.
    let c = [
        n0.dot(a0),
        (2.0 * n1.dot(a0) + n0.dot(a1)) / 3.0,
        (n2.dot(a0) + 2.0 * n1.dot(a1)) / 3.0,
        n2.dot(a1),
    ];
    let lowest = c.iter().copied().fold(f32::INFINITY, f32::min);
    let xy = |n: Vec3| n.truncate().length();
    let lens = r * xy(n0).max(xy(n1)).max(xy(n2));
    let scale = n0.length().max(n1.length()).max(n2.length()) * (a0.length().max(a1.length()) + r);
    // NaN (non-finite input) is not > 0: kept.
    lowest - lens - margin * scale > 0.0
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Pcg32;

    /// `sample_hit` of `inside.glsl` transcribed line for line (its test order), minus the depth range:
    /// the oracle that pins [`intersect_triangle`]'s reordered tests to the GPU's answer.
    fn inside_glsl(a: Vec3, b: Vec3, c: Vec3, o: Vec3, d: Vec3) -> Option<(f32, Vec3)> {
        let e1 = b - a;
        let e2 = c - a;
        let n = e1.cross(e2);
        let n_len = n.length();
        if n_len.is_nan() || n_len <= PARALLEL_EPS * e1.length() * e2.length() {
            return None;
        }
        let p = d.cross(e2);
        let det = e1.dot(p);
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
        let z_lo = -(a.z.max(b.z).max(c.z));
        let z_hi = -(a.z.min(b.z).min(c.z));
        Some(((-(w.x * a.z + w.y * b.z + w.z * c.z)).max(z_lo).min(z_hi), w))
    }

    fn rnd3(r: &mut Pcg32, scale: f32) -> Vec3 {
        Vec3::new(r.next_f32() - 0.5, r.next_f32() - 0.5, r.next_f32() - 0.5) * scale
    }

    /// Random, needle, sliver, edge-on, huge, tiny and non-finite triangles and rays, many of them
    /// aimed at the triangle so that hits and near-misses are common.
    #[test]
    fn intersector_is_bit_identical_to_the_glsl_order() {
        let mut r = Pcg32::new(3, 11);
        let specials = [0.0, -0.0, 1e-30, 1e30, f32::INFINITY, f32::NEG_INFINITY, f32::NAN];
        let (mut hits, mut n) = (0, 0);
        for i in 0..200_000 {
            let scale = [1.0, 1e-4, 1e4, 1e18][i % 4];
            let mut v = [rnd3(&mut r, scale), rnd3(&mut r, scale), rnd3(&mut r, scale)];
            match i % 7 {
                0 => v[2] = v[0].lerp(v[1], r.next_f32()),     // collinear
                1 => v[2] = v[1] + rnd3(&mut r, scale * 1e-6), // sliver
                2 => v[1] = v[0],
                3 if i % 5 == 0 => v[r.below(3) as usize][r.below(3) as usize] = specials[i % specials.len()],
                _ => {}
            }
            let o = Vec3::new(r.next_f32() - 0.5, r.next_f32() - 0.5, 0.0) * 0.2;
            let w = Vec3::new(r.next_f32(), r.next_f32(), r.next_f32());
            let target = (w.x * v[0] + w.y * v[1] + w.z * v[2]) / w.element_sum();
            let d = match i % 3 {
                0 => (target - o).normalize(),
                1 => (target + rnd3(&mut r, scale * 0.1) - o).normalize(),
                _ => ((v[1] - v[0]) + rnd3(&mut r, 1e-3 * scale)).normalize(), // grazing
            };
            let got = intersect_triangle(&v, o, d);
            let want = inside_glsl(v[0], v[1], v[2], o, d);
            let bits = |h: Option<(f32, Vec3)>| h.map(|(z, w)| (z.to_bits(), w.to_array().map(f32::to_bits)));
            assert_eq!(bits(got.map(|h| (h.depth_z, h.barycentrics))), bits(want), "{v:?} {o} {d}");
            if let Some(h) = got {
                hits += 1;
                assert!(h.depth_z.is_finite() && h.barycentrics.is_finite(), "{h:?}");
                let z = [-v[0].z, -v[1].z, -v[2].z];
                assert_eq!(
                    (-h.point(&v).z).clamp(
                        z.into_iter().fold(f32::INFINITY, f32::min),
                        z.into_iter().fold(f32::NEG_INFINITY, f32::max)
                    ),
                    h.depth_z
                );
            }
            n += 1;
        }
        assert!(hits > n / 10, "the rays should hit often ({hits} of {n})");
    }

    #[test]
    fn glsl_mirror_uses_the_cpu_threshold() {
        let src = include_str!("../../shaders-glsl/stochastic/inside.glsl");
        let line = format!("const float PARALLEL_EPS = {PARALLEL_EPS:?};");
        assert!(src.contains(&line), "inside.glsl lacks `{line}`");
    }

    #[test]
    fn moving_triangle_interpolates_like_shutter_lerp() {
        let tri = MovingTriangle {
            v0: [Vec3::new(0.1, 0.2, -1.0), Vec3::new(1.0, 0.0, -2.0), Vec3::new(0.0, 3.0, -1.5)],
            v1: [Vec3::new(0.7, -0.2, -4.0), Vec3::new(1.0, 0.5, -2.0), Vec3::new(-1.0, 3.0, -0.5)],
        };
        for t in [0.0f32, 0.1, 0.5, 0.9, 1.0] {
            // `shutter_lerp` in inside.glsl: a + (b − a)·t.
            assert_eq!(tri.at(t), [0, 1, 2].map(|i| tri.v0[i] + (tri.v1[i] - tri.v0[i]) * t));
        }
        assert_eq!(tri.at(0.0), tri.v0);
        for (p, q) in tri.at(1.0).iter().zip(&tri.v1) {
            assert!((*p - *q).abs().max_element() <= 1e-6, "{p} vs {q}");
        }
        // A vertex that does not move stays exactly put (the near-plane hard case): 1.0 stays, and
        // 0.1 — not exact in binary — stays the same f32 at every t.
        let still = MovingTriangle { v0: [Vec3::new(0.3, 0.2, -0.1); 3], v1: [Vec3::new(0.3, 0.2, -0.1); 3] };
        for i in 0..1000 {
            let t = i as f32 / 1000.0;
            assert_eq!(still.at(t), still.v0, "t = {t}");
        }
        assert!(tri.is_finite() && !tri.is_degenerate());
    }

    #[test]
    fn key_times_locate_every_time_in_one_segment() {
        assert!(KeyTimes::new(vec![0.0]).is_none());
        assert!(KeyTimes::new(vec![0.0, 0.5, 0.5, 1.0]).is_none());
        assert!(KeyTimes::new(vec![0.1, 1.0]).is_none());
        assert!(KeyTimes::new(vec![0.0, 0.9]).is_none());
        // Two keys: the local time is t itself, bit for bit.
        let ends = KeyTimes::new(vec![0.0, 1.0]).unwrap();
        assert_eq!(ends.inv_len(), [1.0]);
        let mut r = Pcg32::new(3, 1);
        for _ in 0..10_000 {
            let t = r.next_f32();
            assert_eq!(ends.locate(t), (0, t));
        }
        let k = KeyTimes::new(vec![0.0, 0.25, 0.3, 1.0]).unwrap();
        assert_eq!(k.segments(), 3);
        assert_eq!(k.locate(0.0), (0, 0.0));
        assert_eq!(k.segment_of(0.25), 1);
        assert_eq!(k.local_time(1, 0.25), 0.0);
        assert_eq!(k.segment_of(0.2999), 1);
        assert_eq!(k.segment_of(0.3), 2);
        assert_eq!(k.locate(1.0), (2, 1.0));
        assert_eq!(k.segment_of(-1.0), 0);
        assert_eq!(k.segment_of(f32::NAN), 0);
        // Local times stay in [0, 1] and grow with t within a segment.
        let mut last = (0usize, 0.0f32);
        for i in 0..=100_000 {
            let t = i as f32 / 100_000.0;
            let (j, s) = k.locate(t);
            assert!((0.0..=1.0).contains(&s), "t {t}: s {s}");
            assert!(k.times()[j] <= t && (t < k.times()[j + 1] || j == 2), "t {t} in segment {j}");
            if j == last.0 {
                assert!(s >= last.1, "t {t}");
            }
            last = (j, s);
        }
    }
}
