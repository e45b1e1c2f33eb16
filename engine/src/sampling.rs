//! Sample sets over the five dimensions of the pixel integral: subpixel (x,y), lens (u,v), time t.
//!
//! docs/MODEL.md "Samples": each dimension is stratified on its own, then the dimensions are permuted
//! independently so (x,y), (u,v) and t are uncorrelated inside a pixel (Toth & Linder §9.4). A
//! [`SampleTile`] holds the sets of `tile × tile` pixels and is repeated over the screen; every GPU
//! technique and the CPU reference can draw from the same tile, which makes paired comparisons possible.
//!
//! 2D dimensions use multi-jittered sampling (Chiu, Shirley & Wang 1994): `n = m·k` samples land one in
//! each cell of an `m × k` grid *and* one in each of the `n` 1D strata of both axes. Time uses 1D jittered
//! strata. The aperture shape and shutter curve are applied by warping these uniform samples
//! ([`ApertureShape::map`], [`ShutterCurve::warp`]), never by special code in a technique.

use glam::{Vec2, Vec3};

/// Minimal PCG32 (O'Neill 2014): small, fast, seedable, identical on every platform.
#[derive(Clone, Debug)]
pub struct Pcg32 {
    state: u64,
    inc: u64,
}

impl Pcg32 {
    pub fn new(seed: u64, stream: u64) -> Self {
        let mut r = Pcg32 { state: 0, inc: (stream << 1) | 1 };
        r.next_u32();
        r.state = r.state.wrapping_add(seed);
        r.next_u32();
        r
    }
    pub fn next_u32(&mut self) -> u32 {
        let old = self.state;
        self.state = old.wrapping_mul(6364136223846793005).wrapping_add(self.inc);
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        let rot = (old >> 59) as u32;
        xorshifted.rotate_right(rot)
    }
    /// Uniform in [0, 1), 24 bits of precision so it never rounds to 1.0.
    pub fn next_f32(&mut self) -> f32 {
        (self.next_u32() >> 8) as f32 * (1.0 / 16_777_216.0)
    }
    /// Uniform integer in [0, n).
    pub fn below(&mut self, n: u32) -> u32 {
        ((self.next_u32() as u64 * n as u64) >> 32) as u32
    }
    pub fn shuffle<T>(&mut self, v: &mut [T]) {
        for i in (1..v.len()).rev() {
            let j = self.below(i as u32 + 1) as usize;
            v.swap(i, j);
        }
    }
}

/// One pass' sample of the lens and shutter.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PassSample {
    /// Shutter time in [0, 1] (already warped by the shutter curve).
    pub time: f32,
    /// Lens point in unit aperture coordinates (already mapped to the aperture shape).
    pub lens: Vec2,
    /// Subpixel offset in pixels, in [-0.5, 0.5)²: the pass samples pixel centre + jitter.
    pub jitter: Vec2,
}

/// The width, in pixels, of the texture filter of one of `passes` jittered passes that together
/// sample the pixel (`accumulation`, and the forward passes of `pinhole` with 1): each stands for
/// 1/P of the pixel's area, so its filter spans 1/√P of the pixel's side. The fragment stages scale
/// the uv derivatives by it (`common/pass_texture.glsl`), so the mip level falls by ½·log2 P: the
/// passes' average converges to the base level integrated over the pixel box — the reference's —
/// instead of that box blurred by a one-pixel filter. A deliberate departure from the hardware's
/// choice, which assumes one sample per pixel (issue 33).
pub fn pass_texture_footprint(passes: u32) -> f32 {
    1.0 / (passes.max(1) as f32).sqrt()
}

/// One sample of the pixel integral, all coordinates uniform in [0,1): `xy` is the subpixel position,
/// `lens` the unit square that [`ApertureShape::map`] takes onto the aperture, `time` the uniform value
/// that [`ShutterCurve::warp`] takes to shutter time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample5 {
    pub xy: Vec2,
    pub lens: Vec2,
    pub time: f32,
}

/// Grid shape `m × k = n` with `m` the largest divisor of `n` not above `sqrt(n)`.
pub fn grid_shape(n: u32) -> (u32, u32) {
    let mut m = (n as f64).sqrt().floor().max(1.0) as u32;
    while !n.is_multiple_of(m) {
        m -= 1;
    }
    (m, n / m)
}

/// Two unit vectors completing the unit vector `n` to a right-handed orthonormal frame `(t, b, n)`,
/// continuous but across `n.z = 0` (Duff et al., "Building an Orthonormal Basis, Revisited", 2017).
pub fn orthonormal_frame(n: Vec3) -> (Vec3, Vec3) {
    let sign = 1.0f32.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    (Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x), Vec3::new(b, sign + n.y * n.y * a, -n.y))
}

/// `n` multi-jittered points in [0,1)²: one per cell of an `m × k` grid and one per 1D stratum of width
/// `1/n` on each axis.
pub fn multi_jittered(n: u32, rng: &mut Pcg32) -> Vec<Vec2> {
    let (m, k) = grid_shape(n);
    let (mu, ku) = (m as usize, k as usize);
    // Canonical arrangement: cell (i, j) (column i of m, row j of k) takes x-substratum i·k + j and
    // y-substratum j·m + i.
    let mut xs = vec![0u32; n as usize]; // x substratum offset (0..k) per cell, indexed j*m + i
    let mut ys = vec![0u32; n as usize]; // y substratum offset (0..m)
    for j in 0..ku {
        for i in 0..mu {
            xs[j * mu + i] = j as u32;
            ys[j * mu + i] = i as u32;
        }
    }
    // Shuffle the x-substrata within each column and the y-substrata within each row.
    for i in 0..mu {
        let mut col: Vec<u32> = (0..ku).map(|j| xs[j * mu + i]).collect();
        rng.shuffle(&mut col);
        for j in 0..ku {
            xs[j * mu + i] = col[j];
        }
    }
    for j in 0..ku {
        rng.shuffle(&mut ys[j * mu..(j + 1) * mu]);
    }
    let mut out = Vec::with_capacity(n as usize);
    for j in 0..k {
        for i in 0..m {
            let c = (j * m + i) as usize;
            let x = stratum_value(i * k + xs[c], rng.next_f32(), n);
            let y = stratum_value(j * m + ys[c], rng.next_f32(), n);
            out.push(Vec2::new(x, y));
        }
    }
    out
}

/// `(stratum + jitter) / n` as f32, guaranteed to fall in stratum `stratum` when a consumer computes
/// `floor(v · n)` in f32: the sum is formed in f64 (an f32 `200.0 + 0.99999994` rounds to 201), and a
/// value that rounding pushed across a stratum edge is nudged back one ulp at a time.
fn stratum_value(stratum: u32, jitter: f32, n: u32) -> f32 {
    let mut v = ((stratum as f64 + jitter as f64) / n as f64) as f32;
    for _ in 0..8 {
        let bucket = (v * n as f32).floor() as i64;
        if bucket == stratum as i64 {
            break;
        }
        v = if bucket > stratum as i64 { v.next_down() } else { v.next_up() };
    }
    v.min(1.0 - f32::EPSILON / 2.0)
}

/// `n` jittered points in [0,1), one per stratum of width `1/n`, in random order.
pub fn jittered_1d(n: u32, rng: &mut Pcg32) -> Vec<f32> {
    let mut v: Vec<f32> = (0..n).map(|s| stratum_value(s, rng.next_f32(), n)).collect();
    rng.shuffle(&mut v);
    v
}

/// `n` samples of all five dimensions, each stratified, the three sets permuted independently.
pub fn stratified_samples(n: u32, rng: &mut Pcg32) -> Vec<Sample5> {
    let mut xy = multi_jittered(n, rng);
    let mut lens = multi_jittered(n, rng);
    let time = jittered_1d(n, rng);
    rng.shuffle(&mut xy);
    rng.shuffle(&mut lens);
    (0..n as usize).map(|i| Sample5 { xy: xy[i], lens: lens[i], time: time[i] }).collect()
}

/// The samples of one pixel of a [`SampleTile`]: [`stratified_samples`] in shutter-time order. Time is
/// jittered with one sample per stratum of width 1/n, so for every K dividing n the k-th run of n/K
/// consecutive samples holds exactly the times in `[k/K, (k+1)/K)`: the stochastic rasterizer bounds
/// each run over its own sub-interval of the shutter (interval bounds) and the reference, which uses
/// the same order, groups per-pixel shading by the same runs. Sorting only reorders the set: the
/// pairing of (x, y), lens and time stays the random one.
pub fn pixel_sample_set(n: u32, rng: &mut Pcg32) -> Vec<Sample5> {
    let mut samples = stratified_samples(n, rng);
    samples.sort_by(|a, b| a.time.total_cmp(&b.time));
    samples
}

/// Sample sets for a `size × size` tile of pixels, repeated over the screen.
#[derive(Clone, Debug)]
pub struct SampleTile {
    pub size: u32,
    pub spp: u32,
    pub seed: u64,
    samples: Vec<Sample5>,
}

/// docs/MODEL.md asks for tiles of at least 64×64 pixels so the repetition is not visible.
pub const SAMPLE_TILE_SIZE: u32 = 64;

impl SampleTile {
    pub fn new(spp: u32, size: u32, seed: u64) -> Self {
        let mut samples = Vec::with_capacity((size * size * spp) as usize);
        for p in 0..size * size {
            // One stream per pixel: the tile is the same whatever order pixels are generated in.
            let mut rng = Pcg32::new(seed, p as u64 + 1);
            samples.extend(pixel_sample_set(spp, &mut rng));
        }
        SampleTile { size, spp, seed, samples }
    }
    /// The `spp` samples of pixel `(x, y)` (screen coordinates; the tile repeats).
    pub fn pixel(&self, x: u32, y: u32) -> &[Sample5] {
        let (tx, ty) = (x % self.size, y % self.size);
        let base = ((ty * self.size + tx) * self.spp) as usize;
        &self.samples[base..base + self.spp as usize]
    }
}

/// Shape of the aperture, inscribed in the unit disk (the lens radius is `aperture_radius`).
/// Scene files spell it `aperture = { shape = … }` (`scene::file`).
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub enum ApertureShape {
    /// A round aperture.
    #[default]
    Disk,
    /// A regular polygon of `blades` sides (≥ 3) inscribed in the unit circle, rotated by `rotation_deg`.
    Blades { blades: u32, rotation_deg: f32 },
    /// A round aperture whose transmission falls off smoothly at its rim: the smooth lens of
    /// Vaidyanathan et al. 2012 (§4, a smoothstep over `[0.9 r, 1.1 r]` of the lens radius `r`), whose
    /// spectrum has less support than the sharp disk's. Here the camera's `aperture_radius` is the
    /// outer end of the falloff (the paper's `1.1 r`), so every lens point stays inside it and every
    /// bound and culling test keeps its meaning: full transmission out to [`SMOOTH_LENS_INNER`] of it,
    /// `1 − smoothstep` down to zero at its edge. Samples are importance-sampled from that
    /// transmission ([`smooth_lens_radius`]), so every sample still weighs the same.
    SmoothDisk,
}

/// Where [`ApertureShape::SmoothDisk`]'s falloff starts, as a fraction of the aperture radius: the
/// paper's `0.9 r` with the radius at `1.1 r`.
pub const SMOOTH_LENS_INNER: f64 = 0.9 / 1.1;

/// [`ApertureShape::SmoothDisk`]'s transmission at distance `rho` from the centre (unit-disk
/// coordinates): 1 inside [`SMOOTH_LENS_INNER`], `1 − smoothstep` to 0 at 1.
pub fn smooth_lens_transmission(rho: f64) -> f64 {
    let a = SMOOTH_LENS_INNER;
    let t = ((rho - a) / (1.0 - a)).clamp(0.0, 1.0);
    1.0 - t * t * (3.0 - 2.0 * t)
}

/// `∫₀^ρ transmission(s)·s ds` of [`smooth_lens_transmission`], in closed form (the smoothstep is a
/// cubic in `t = (s − a)/(1 − a)`, so the integrand is a quintic in `t`).
fn smooth_lens_mass(rho: f64) -> f64 {
    let a = SMOOTH_LENS_INNER;
    let h = 1.0 - a;
    if rho <= a {
        return 0.5 * rho * rho;
    }
    let t = ((rho - a) / h).min(1.0);
    // (1 − 3t² + 2t³)(a + h t) = a + h t − 3a t² + (2a − 3h) t³ + 2h t⁴, integrated over [0, t], × h.
    0.5 * a * a
        + h * (a * t + 0.5 * h * t * t - a * t.powi(3)
            + 0.25 * (2.0 * a - 3.0 * h) * t.powi(4)
            + 0.4 * h * t.powi(5))
}

/// The radius (unit-disk coordinates) below which the fraction `u ∈ [0, 1]` of
/// [`ApertureShape::SmoothDisk`]'s transmitted light passes: the inverse of its radial distribution,
/// by bisection in f64 (monotone, so a stratified `u` stays stratified).
pub fn smooth_lens_radius(u: f64) -> f64 {
    let target = u.clamp(0.0, 1.0) * smooth_lens_mass(1.0);
    let a = SMOOTH_LENS_INNER;
    if target <= 0.5 * a * a {
        return (2.0 * target).sqrt();
    }
    let (mut lo, mut hi) = (a, 1.0);
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if smooth_lens_mass(mid) < target {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

impl ApertureShape {
    /// Area-preserving map from the unit square onto the aperture (so stratification survives); for
    /// [`ApertureShape::SmoothDisk`], onto the disk with density proportional to its transmission (the
    /// concentric map, then a monotone remap of the radius).
    pub fn map(&self, sq: Vec2) -> Vec2 {
        match *self {
            ApertureShape::Disk => concentric_disk(sq),
            ApertureShape::SmoothDisk => {
                let p = concentric_disk(sq);
                let r = p.length();
                if r == 0.0 {
                    return p;
                }
                // A uniform disk point's r² is uniform: the fraction of the disk inside it.
                let rho = smooth_lens_radius((r as f64) * (r as f64)) as f32;
                p * (rho / r)
            }
            ApertureShape::Blades { blades, rotation_deg } => {
                // Pick a triangular sector with the first coordinate (keeps strata contiguous), then a
                // uniform point in the triangle (centre, vertex i, vertex i+1).
                let n = blades.max(3) as f32;
                let s = sq.x * n;
                let sector = s.floor().min(n - 1.0);
                let a = (s - sector).clamp(0.0, 1.0);
                let b = sq.y;
                let rot = rotation_deg.to_radians();
                let th0 = rot + sector * std::f32::consts::TAU / n;
                let th1 = th0 + std::f32::consts::TAU / n;
                let v0 = Vec2::new(th0.cos(), th0.sin());
                let v1 = Vec2::new(th1.cos(), th1.sin());
                // Uniform in triangle (0, v0, v1): radius sqrt(b), position along the edge a.
                let r = b.sqrt();
                r * (v0 * (1.0 - a) + v1 * a)
            }
        }
    }
    /// Does the shape contain `p` (unit-disk coordinates)? Used by tests and bounds.
    pub fn contains(&self, p: Vec2) -> bool {
        match *self {
            ApertureShape::Disk | ApertureShape::SmoothDisk => p.length_squared() <= 1.0 + 1e-5,
            ApertureShape::Blades { blades, rotation_deg } => {
                let n = blades.max(3) as f32;
                let apothem = (std::f32::consts::PI / n).cos();
                let rot = rotation_deg.to_radians();
                (0..blades.max(3)).all(|i| {
                    let mid = rot + (i as f32 + 0.5) * std::f32::consts::TAU / n;
                    p.dot(Vec2::new(mid.cos(), mid.sin())) <= apothem + 1e-5
                })
            }
        }
    }
}

/// Shirley & Chiu's concentric map from [0,1)² to the unit disk (area-preserving, low distortion).
pub fn concentric_disk(sq: Vec2) -> Vec2 {
    let o = sq * 2.0 - Vec2::ONE;
    if o.x == 0.0 && o.y == 0.0 {
        return Vec2::ZERO;
    }
    let (r, theta) = if o.x.abs() > o.y.abs() {
        (o.x, std::f32::consts::FRAC_PI_4 * (o.y / o.x))
    } else {
        (o.y, std::f32::consts::FRAC_PI_2 - std::f32::consts::FRAC_PI_4 * (o.x / o.y))
    };
    r * Vec2::new(theta.cos(), theta.sin())
}

/// Shutter curve S(t): how the exposure is weighted over `[0, 1]`. Applied by warping uniform time.
/// Scene files spell it `shutter = "box" | "tent"` (`scene::file`).
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub enum ShutterCurve {
    /// Constant exposure while open (the default; docs/MODEL.md).
    #[default]
    Box,
    /// Linear ramp up to mid-shutter and down again (a shutter that opens and closes gradually).
    Tent,
}

impl ShutterCurve {
    /// Inverse CDF of S: uniform `xi` in [0,1) → shutter time distributed as S.
    pub fn warp(&self, xi: f32) -> f32 {
        match self {
            ShutterCurve::Box => xi,
            ShutterCurve::Tent => {
                if xi < 0.5 {
                    (xi * 0.5).sqrt()
                } else {
                    1.0 - ((1.0 - xi) * 0.5).sqrt()
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn strata_hit_once(values: impl Iterator<Item = f32>, n: u32) -> bool {
        let mut hits = vec![0u32; n as usize];
        for v in values {
            if !(0.0..1.0).contains(&v) {
                return false;
            }
            hits[((v * n as f32) as u32).min(n - 1) as usize] += 1;
        }
        hits.iter().all(|&h| h == 1)
    }

    #[test]
    fn one_pass_keeps_the_hardware_footprint() {
        assert_eq!(pass_texture_footprint(1), 1.0);
        assert_eq!(pass_texture_footprint(0), 1.0);
        assert_eq!(pass_texture_footprint(4), 0.5);
        assert_eq!(pass_texture_footprint(64), 0.125);
    }

    proptest! {
        // The P filters together cover the pixel's area once: P · footprint² = 1, and more passes
        // never widen the filter (the mip level only falls with P).
        #[test]
        fn pass_footprints_share_the_pixel(p in 1u32..100_000) {
            let f = pass_texture_footprint(p);
            prop_assert!((p as f64 * (f as f64).powi(2) - 1.0).abs() < 1e-5);
            prop_assert!(pass_texture_footprint(p + 1) <= f);
            prop_assert!(f > 0.0 && f <= 1.0);
        }

        #[test]
        fn pixel_sample_runs_are_shutter_strata(log_n in 0u32..9, seed in any::<u64>()) {
            let n = 1u32 << log_n;
            let samples = pixel_sample_set(n, &mut Pcg32::new(seed, 3));
            for k_log in 0..=log_n {
                let k = 1u32 << k_log;
                let run = (n / k) as usize;
                for (j, chunk) in samples.chunks(run).enumerate() {
                    let (lo, hi) = (j as f32 / k as f32, (j + 1) as f32 / k as f32);
                    prop_assert!(chunk.iter().all(|s| s.time >= lo && s.time < hi), "run {} of {}", j, k);
                }
            }
        }

        #[test]
        fn multi_jittered_hits_every_stratum_once(n in 1u32..300, seed in any::<u64>()) {
            let mut rng = Pcg32::new(seed, 7);
            let pts = multi_jittered(n, &mut rng);
            prop_assert_eq!(pts.len(), n as usize);
            prop_assert!(strata_hit_once(pts.iter().map(|p| p.x), n), "x strata");
            prop_assert!(strata_hit_once(pts.iter().map(|p| p.y), n), "y strata");
            let (m, k) = grid_shape(n);
            let mut cells = vec![0u32; n as usize];
            // A cell is a block of fine strata (row j: y strata j·m .. j·m + m − 1), so it is found from
            // the fine stratum, which stratum_value guarantees: `floor(y·k)` in f32 can round a value
            // at the top of a row's last stratum up into the next row (n = 237 did).
            for p in &pts {
                let fine = |v: f32| ((v * n as f32) as u32).min(n - 1);
                let c = (fine(p.y) / m) * m + fine(p.x) / k;
                cells[c as usize] += 1;
            }
            prop_assert!(cells.iter().all(|&c| c == 1), "2D cells");
        }

        #[test]
        fn stratified_samples_stratify_every_dimension(n in 1u32..200, seed in any::<u64>()) {
            let s = stratified_samples(n, &mut Pcg32::new(seed, 1));
            prop_assert!(strata_hit_once(s.iter().map(|s| s.xy.x), n));
            prop_assert!(strata_hit_once(s.iter().map(|s| s.lens.y), n));
            prop_assert!(strata_hit_once(s.iter().map(|s| s.time), n));
        }

        #[test]
        fn aperture_maps_inside_shape(u in 0.0f32..1.0, v in 0.0f32..1.0, blades in 3u32..12, rot in -180.0f32..180.0) {
            prop_assert!(ApertureShape::Disk.contains(ApertureShape::Disk.map(Vec2::new(u, v))));
            let smooth = ApertureShape::SmoothDisk;
            prop_assert!(smooth.contains(smooth.map(Vec2::new(u, v))));
            let b = ApertureShape::Blades { blades, rotation_deg: rot };
            prop_assert!(b.contains(b.map(Vec2::new(u, v))));
        }

        #[test]
        fn shutter_warp_stays_in_unit_interval_and_is_monotone(a in 0.0f32..1.0, b in 0.0f32..1.0) {
            for c in [ShutterCurve::Box, ShutterCurve::Tent] {
                let (wa, wb) = (c.warp(a), c.warp(b));
                prop_assert!((0.0..=1.0).contains(&wa));
                if a < b { prop_assert!(wa <= wb); }
            }
        }
    }

    #[test]
    fn prime_sample_count_keeps_strata_despite_f32_rounding() {
        // Found by proptest: n = 239 → 1 × 239 grid; f32 `s + jitter` rounded into the next stratum.
        let pts = multi_jittered(239, &mut Pcg32::new(11524451655901442155, 7));
        assert!(strata_hit_once(pts.iter().map(|p| p.y), 239));
        assert!(strata_hit_once(pts.iter().map(|p| p.x), 239));
    }

    #[test]
    fn dimensions_are_decorrelated() {
        // Correlation between x and t over many pixels should be near zero.
        let tile = SampleTile::new(16, 16, 3);
        let mut acc = 0.0f64;
        let mut cnt = 0.0f64;
        for y in 0..16 {
            for x in 0..16 {
                for s in tile.pixel(x, y) {
                    acc += ((s.xy.x - 0.5) * (s.time - 0.5)) as f64;
                    cnt += 1.0;
                }
            }
        }
        assert!((acc / cnt).abs() < 0.01, "cov = {}", acc / cnt);
    }

    #[test]
    fn disk_map_is_area_uniform() {
        // Fraction of a stratified set falling inside radius 0.5 is the area ratio 1/4.
        let pts = multi_jittered(4096, &mut Pcg32::new(1, 1));
        let inside = pts.iter().filter(|p| concentric_disk(**p).length() < 0.5).count();
        assert!((inside as f32 / 4096.0 - 0.25).abs() < 0.01);
    }

    #[test]
    fn tent_shutter_has_triangular_density() {
        // P(t < 0.25) = 2·0.25² = 0.125 for the tent.
        let n = 10000;
        let below = (0..n).filter(|i| ShutterCurve::Tent.warp((*i as f32 + 0.5) / n as f32) < 0.25).count();
        assert!((below as f32 / n as f32 - 0.125).abs() < 0.002);
    }

    #[test]
    fn tile_is_deterministic() {
        let a = SampleTile::new(4, 8, 42);
        let b = SampleTile::new(4, 8, 42);
        assert_eq!(a.pixel(3, 5), b.pixel(3, 5));
        assert_eq!(a.pixel(3, 5), a.pixel(11, 13));
        assert_ne!(a.pixel(3, 5), SampleTile::new(4, 8, 43).pixel(3, 5));
    }

    /// The smooth lens: its transmission is 1 inside the falloff, 0 at the rim, continuous; mapped lens
    /// points are distributed as the transmission says — the share of a stratified 256² grid of unit
    /// square points landing within radius x is the transmitted light within x (closed form) to within
    /// the grid's resolution; the map keeps the disk's direction and is monotone in radius (strata
    /// survive); and the smooth lens puts less light near its rim than the sharp disk.
    #[test]
    fn smooth_lens_samples_follow_its_transmission() {
        let a = SMOOTH_LENS_INNER;
        assert_eq!(smooth_lens_transmission(0.5 * a), 1.0);
        assert_eq!(smooth_lens_transmission(a), 1.0);
        assert_eq!(smooth_lens_transmission(1.0), 0.0);
        assert!((smooth_lens_transmission(0.5 * (1.0 + a)) - 0.5).abs() < 1e-12);
        let total = smooth_lens_mass(1.0);
        // The mass by a fine midpoint sum, against the closed form.
        let n = 200_000;
        let numeric: f64 = (0..n)
            .map(|i| {
                let s = (i as f64 + 0.5) / n as f64;
                smooth_lens_transmission(s) * s / n as f64
            })
            .sum();
        assert!((numeric - total).abs() < 1e-9, "{numeric} vs {total}");
        let m = 256;
        let mut radii: Vec<f64> = vec![];
        for j in 0..m {
            for i in 0..m {
                let sq = Vec2::new((i as f32 + 0.5) / m as f32, (j as f32 + 0.5) / m as f32);
                let (disk, smooth) = (concentric_disk(sq), ApertureShape::SmoothDisk.map(sq));
                assert!(smooth.length() <= disk.length() + 1e-6, "the remap moves points outward");
                if disk.length() > 1e-3 {
                    assert!(disk.normalize().dot(smooth.normalize()) > 0.9999, "direction changed");
                }
                radii.push(smooth.length() as f64);
            }
        }
        for x in [0.2, 0.5, a, 0.85, 0.9, 0.95, 0.99] {
            let share = radii.iter().filter(|&&r| r <= x).count() as f64 / radii.len() as f64;
            let want = smooth_lens_mass(x) / total;
            assert!((share - want).abs() < 0.01, "within {x}: {share} of the samples, {want} of the light");
        }
        assert!(radii.iter().all(|&r| r <= 1.0));
        let near_rim = radii.iter().filter(|&&r| r > 0.9).count() as f64 / radii.len() as f64;
        assert!(near_rim < 0.5 * (1.0 - 0.81), "smooth lens: {near_rim} of the samples beyond 0.9");
        // Monotone in radius along a ray of the concentric map.
        let mut last = 0.0;
        for k in 0..=100 {
            let r = smooth_lens_radius(k as f64 / 100.0);
            assert!(r >= last, "{r} after {last}");
            last = r;
        }
        // The transmission's last stretch is flat to f64 (it vanishes like (1 − ρ)² at the rim).
        assert!((smooth_lens_radius(1.0) - 1.0).abs() < 1e-4);
    }
}
