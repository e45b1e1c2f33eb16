//! Stochastic coverage: which of a pixel's samples a partly covering surface covers. One function for
//! the CPU reference and the GPU (`shaders-glsl/common/coverage.glsl` mirrors it with the same 32-bit
//! integer operations, so both make the same decision for the same sample), and the transparency
//! methods a GPU technique can use (docs/TRANSPARENCY.md, "Stochastic transparency (GPU)").
//!
//! **Stratified per pixel** (Laine & Karras 2011, the idea of their stratified masks): for one pixel
//! and one triangle of coverage α, the pixel's S samples are ranked by a bijection of `[0, S)` drawn
//! from a hash of (seed, pixel, triangle), and sample k is covered iff `rank(k) < n` with
//! `n = floor(α·S + u)`, `u` a uniform of the same hash. So exactly n samples are covered — `n` is
//! `floor(α·S)` or `ceil(α·S)` with mean α·S, the least spread a count can have — while each sample is
//! still covered with probability α: its rank is uniform over `[0, S)` (a random rotation follows the
//! scrambling permutation) and independent of `u`. Different triangles draw independent hashes, so
//! their decisions for one sample are independent, which is what makes the expected value of the
//! nearest covered surface the sorted composite (Enderton et al. 2011).
//!
//! α enters as 24-bit fixed point (`α·2²⁴`, exact in f32), so the decision needs only integer
//! arithmetic after that one exact conversion.

use std::fmt;
use std::str::FromStr;

use crate::error::{Error, Result};

/// lowbias32 (Wellons' 32-bit integer finalizer): a bijection of u32 with good avalanche.
pub fn hash32(mut x: u32) -> u32 {
    x ^= x >> 16;
    x = x.wrapping_mul(0x7feb_352d);
    x ^= x >> 15;
    x = x.wrapping_mul(0x846c_a68b);
    x ^ (x >> 16)
}

/// The 32-bit seed of the coverage hashes for a render seed (both halves of it count).
pub fn coverage_seed(seed: u64) -> u32 {
    hash32(seed as u32 ^ hash32((seed >> 32) as u32 ^ 0x5bd1_e995))
}

/// The key of one (pixel, triangle) from which its count and ranks are drawn.
pub fn coverage_key(seed: u32, x: u32, y: u32, triangle: u32) -> u32 {
    let h = hash32(triangle.wrapping_add(seed));
    let h = hash32(h ^ x.wrapping_mul(0x9e37_79b9));
    hash32(h ^ y.wrapping_mul(0x85eb_ca6b))
}

/// `α` in 24-bit fixed point, clamped to `[0, 2²⁴]` (NaN counts as 0).
pub fn alpha_fixed(alpha: f32) -> u32 {
    // Scaling by a power of two is exact and the conversion truncates: the GPU gets the same integer.
    (alpha.clamp(0.0, 1.0) * 16_777_216.0) as u32
}

/// How many of the pixel's `samples` samples a surface of coverage `alpha` covers:
/// `floor(α·S + u)` with `u` the key's 24-bit uniform.
pub fn covered_count(alpha: f32, samples: u32, key: u32) -> u32 {
    let u = hash32(key ^ 0x68e3_1da4) >> 8;
    ((alpha_fixed(alpha) as u64 * samples as u64 + u as u64) >> 24) as u32
}

/// The rank of sample `k` among the pixel's `samples` samples: a bijection of `[0, samples)` drawn
/// from `key` — a scrambling permutation (xor, odd multiply and xorshift rounds inside the next
/// power of two, cycle-walked back into range), then a rotation by a uniform offset, which makes every
/// sample's rank uniform.
pub fn coverage_rank(k: u32, samples: u32, key: u32) -> u32 {
    if samples <= 1 {
        return 0;
    }
    // All ones up to the highest bit of samples − 1: the scramble is a bijection of [0, mask].
    let mask = u32::MAX >> (samples - 1).leading_zeros();
    let p0 = hash32(key ^ 0x1b87_3593);
    let p1 = hash32(key ^ 0xcc9e_2d51) | 1;
    // Cycle walking ends because the walk starts inside [0, samples).
    let mut i = k % samples;
    loop {
        i ^= p0;
        i &= mask;
        i = i.wrapping_mul(p1) & mask;
        i ^= i >> 3;
        i = i.wrapping_mul(0x2c1b_3c6d) & mask;
        i ^= i >> 7;
        if i < samples {
            break;
        }
    }
    let offset = hash32(key ^ 0x0d1a_b7c5) % samples;
    (i + offset) % samples
}

/// Whether sample `k` of pixel `(x, y)`'s `samples` samples is covered by triangle `triangle` of
/// coverage `alpha` (module docs). α ≥ 1 always, α ≤ 0 never.
pub fn covered(seed: u32, x: u32, y: u32, k: u32, triangle: u32, alpha: f32, samples: u32) -> bool {
    let key = coverage_key(seed, x, y, triangle);
    coverage_rank(k, samples, key) < covered_count(alpha, samples, key)
}

/// Fixed-point units per unit of `−log₂ T` in the stochastic rasterizer's tint buffer
/// ([`tint_log`]).
pub const TINT_LOG_ONE: u32 = 1 << 16;
/// `−log₂ T` at and above which a channel transmits nothing: `2⁻⁶⁴` is below every radiance we
/// resolve, and the cap keeps the sums of up to 1023 layers inside 32 bits.
pub const TINT_LOG_CAP: u32 = 64 * TINT_LOG_ONE;

/// A tint as the stochastic rasterizer accumulates it (`shaders-glsl/stochastic/stochastic.frag`,
/// TINT_PASS): `−log₂ T` per channel in 16.16 fixed point, rounded to nearest, capped at
/// [`TINT_LOG_CAP`] (T = 0 or NaN gives the cap). A sample's product of tints is then an integer sum —
/// `atomicAdd` in any order gives the same bits — and [`tint_from_log`] turns the sum back. Rounding
/// costs at most `2⁻¹⁷` in `log₂ T`, a relative error below 5.3·10⁻⁶ per tinted layer; a tint of
/// 1, ½, ¼, … is exact.
pub fn tint_log(t: [f32; 3]) -> [u32; 3] {
    t.map(|c| {
        let l = -(c as f64).log2() * TINT_LOG_ONE as f64;
        if l.is_nan() || l >= TINT_LOG_CAP as f64 {
            TINT_LOG_CAP
        } else {
            // A tint above 1 is refused by the scene model; clamp anyway (transmittance ≤ 1).
            l.max(0.0).round() as u32
        }
    })
}

/// The transmittance of a sum of [`tint_log`]s (`stochastic/shade.glsl`'s `sample_tint`): `2^(−l/2¹⁶)`, 0 at
/// or beyond the cap.
pub fn tint_from_log(l: u32) -> f32 {
    if l >= TINT_LOG_CAP {
        0.0
    } else {
        (-(l as f32) / TINT_LOG_ONE as f32).exp2()
    }
}

/// The sorted Porter-Duff composite of `layers` (front to back: coverage α, colour C, tint T) over
/// `background` — `Σ vis_i·α_i·C_i + vis_N·background` with `vis_i = Π_{j<i} (1 − α_j)·T_j` — and the
/// per-channel variance of one sample of stochastic coverage with independent decisions (the sample
/// stops at layer i with probability `α_i·Π_{j<i}(1 − α_j)`, carrying `Π_{j<i} T_j · C_i`), in f64:
/// the closed form the reference and the GPU techniques are tested against (docs/TRANSPARENCY.md).
/// Stratified masks ([`covered`]) have the same mean and at most this variance per pixel.
pub fn composite(layers: &[(f64, [f64; 3], [f64; 3])], background: [f64; 3]) -> ([f64; 3], [f64; 3]) {
    let mut mean = [0.0; 3];
    let mut second = [0.0; 3];
    let (mut reach, mut vis, mut tint) = (1.0, [1.0; 3], [1.0; 3]);
    for &(alpha, c, t) in layers {
        for ch in 0..3 {
            mean[ch] += vis[ch] * alpha * c[ch];
            second[ch] += reach * alpha * (tint[ch] * c[ch]).powi(2);
            vis[ch] *= (1.0 - alpha) * t[ch];
            tint[ch] *= t[ch];
        }
        reach *= 1.0 - alpha;
    }
    for ch in 0..3 {
        mean[ch] += vis[ch] * background[ch];
        second[ch] += reach * (tint[ch] * background[ch]).powi(2);
    }
    (mean, std::array::from_fn(|ch| second[ch] - mean[ch] * mean[ch]))
}

/// How a GPU technique renders partial coverage and tints (`--transparency`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum TransparencyMethod {
    /// Stochastic transparency (Enderton et al. 2011) with per-pixel stratified masks: the default.
    #[default]
    Stochastic,
    /// Stochastic transparency with Enderton's alpha correction (`stochastic/corrected`,
    /// `techniques/oit.rs`): the transparent samples' colour is rescaled so that their share of the
    /// pixel is the exact total alpha `1 − Π(1 − α)` from a multiplicative pass, and what lies behind
    /// every transparent surface is weighted by the exact transmittance `Π (1 − α)·T`.
    StochasticCorrected,
    /// Depth-based stochastic transparency (Enderton et al. 2011): the stochastic masks write depth
    /// only, and every transparent fragment adds `vis(z)·α·C` with `vis` estimated from the pixel's
    /// stochastic depths (`techniques/oit.rs`). `alpha_correction`: normalise the layer sum by the
    /// exact total transmittance (`depth-based`), or not (`depth-based/uncorrected`).
    DepthBased { alpha_correction: bool },
    /// Depth peeling of `layers` transparent layers, composited front to back: exact where a sample
    /// has at most `layers` transparent surfaces in front of its opaque one (`peeling/K`).
    Peeling { layers: u32 },
}

/// Layers of `peeling` without `/K`.
pub const DEFAULT_PEELING_LAYERS: u32 = 8;
/// Most layers `peeling/K` accepts (each is a raster pass and a compute pass per frame pass).
pub const MAX_PEELING_LAYERS: u32 = 64;

impl TransparencyMethod {
    /// One of each kind (peeling with its default layer count).
    pub const ALL: &'static [TransparencyMethod] = &[
        TransparencyMethod::Stochastic,
        TransparencyMethod::StochasticCorrected,
        TransparencyMethod::DepthBased { alpha_correction: true },
        TransparencyMethod::DepthBased { alpha_correction: false },
        TransparencyMethod::Peeling { layers: DEFAULT_PEELING_LAYERS },
    ];
}

impl fmt::Display for TransparencyMethod {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            TransparencyMethod::Stochastic => f.write_str("stochastic"),
            TransparencyMethod::StochasticCorrected => f.write_str("stochastic/corrected"),
            TransparencyMethod::DepthBased { alpha_correction: true } => f.write_str("depth-based"),
            TransparencyMethod::DepthBased { alpha_correction: false } => {
                f.write_str("depth-based/uncorrected")
            }
            TransparencyMethod::Peeling { layers } => write!(f, "peeling/{layers}"),
        }
    }
}

impl FromStr for TransparencyMethod {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        let unknown = || {
            Error::Unsupported(format!(
                "unknown transparency method `{s}`; available: stochastic, stochastic/corrected, \
                 depth-based, depth-based/uncorrected, peeling/K (K layers, 1..={MAX_PEELING_LAYERS}; `peeling` is \
                 peeling/{DEFAULT_PEELING_LAYERS})"
            ))
        };
        match s {
            "stochastic" => Ok(TransparencyMethod::Stochastic),
            "stochastic/corrected" => Ok(TransparencyMethod::StochasticCorrected),
            "depth-based" => Ok(TransparencyMethod::DepthBased { alpha_correction: true }),
            "depth-based/uncorrected" => Ok(TransparencyMethod::DepthBased { alpha_correction: false }),
            "peeling" => Ok(TransparencyMethod::Peeling { layers: DEFAULT_PEELING_LAYERS }),
            _ => {
                let k = s.strip_prefix("peeling/").ok_or_else(unknown)?;
                match k.parse::<u32>() {
                    Ok(layers) if (1..=MAX_PEELING_LAYERS).contains(&layers) => {
                        Ok(TransparencyMethod::Peeling { layers })
                    }
                    _ => Err(Error::Limit {
                        what: "peeling layers",
                        value: k.to_string(),
                        limit: format!("1..={MAX_PEELING_LAYERS}"),
                    }),
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const SEED: u32 = 0x1234_5678;

    fn mask(x: u32, y: u32, tri: u32, alpha: f32, s: u32) -> Vec<bool> {
        (0..s).map(|k| covered(SEED, x, y, k, tri, alpha, s)).collect()
    }

    #[test]
    fn ranks_are_a_bijection() {
        for s in [1u32, 2, 3, 4, 5, 7, 8, 16, 33, 64, 100, 256, 1000] {
            for key in [0u32, 1, 0xdead_beef, 12345] {
                let mut seen = vec![false; s as usize];
                for k in 0..s {
                    let r = coverage_rank(k, s, key);
                    assert!(r < s && !seen[r as usize], "S {s} key {key}: rank {r} twice or out of range");
                    seen[r as usize] = true;
                }
            }
        }
    }

    #[test]
    fn popcount_is_floor_or_ceil_of_alpha_times_s() {
        for s in [1u32, 3, 4, 7, 16, 64] {
            for alpha in [0.05f32, 0.25, 0.3, 0.5, 0.77, 0.999] {
                let (lo, hi) = ((alpha * s as f32).floor() as usize, (alpha * s as f32).ceil() as usize);
                for p in 0..200u32 {
                    let n = mask(p % 17, p / 17, p * 7 + 3, alpha, s).iter().filter(|&&c| c).count();
                    assert!(n == lo || n == hi, "S {s} alpha {alpha}: {n} covered, not {lo} or {hi}");
                }
            }
        }
    }

    #[test]
    fn zero_never_one_always() {
        for s in [1u32, 4, 9, 64] {
            for p in 0..300u32 {
                assert!(mask(p, p / 3, p, 0.0, s).iter().all(|&c| !c));
                assert!(mask(p, p / 3, p, 1.0, s).iter().all(|&c| c));
                assert!(mask(p, p / 3, p, 1.5, s).iter().all(|&c| c));
                assert!(mask(p, p / 3, p, -0.5, s).iter().all(|&c| !c));
            }
        }
    }

    /// Every sample is covered with probability α: over N pixels the fraction of pixels whose sample k
    /// is covered lies within 4.5σ of α for each k (σ² = α(1 − α)/N).
    #[test]
    fn each_sample_is_covered_with_probability_alpha() {
        let n = 40_000u32;
        for s in [1u32, 4, 7, 16] {
            for alpha in [0.1f32, 0.37, 0.5, 0.9] {
                let mut hits = vec![0u32; s as usize];
                for p in 0..n {
                    for (k, c) in mask(p % 200, p / 200, 11, alpha, s).into_iter().enumerate() {
                        hits[k] += c as u32;
                    }
                }
                let a = alpha as f64;
                let sigma = (a * (1.0 - a) / n as f64).sqrt();
                for (k, &h) in hits.iter().enumerate() {
                    let f = h as f64 / n as f64;
                    assert!((f - a).abs() < 4.5 * sigma, "S {s} alpha {alpha} sample {k}: {f}");
                }
            }
        }
    }

    /// Two triangles' decisions for one sample are independent: P(both) = α_A·α_B, and their popcounts
    /// are uncorrelated.
    #[test]
    fn different_triangles_are_uncorrelated() {
        let n = 40_000u32;
        let s = 8u32;
        let (aa, ab) = (0.5f32, 0.3f32);
        let (mut both, mut sum_a, mut sum_b, mut sum_ab) = (0u32, 0f64, 0f64, 0f64);
        let mut slots = 0u32;
        for p in 0..n {
            let (x, y) = (p % 200, p / 200);
            let ma = mask(x, y, 5, aa, s);
            let mb = mask(x, y, 6, ab, s);
            both += ma.iter().zip(&mb).filter(|(a, b)| **a && **b).count() as u32;
            slots += s;
            let (ca, cb) =
                (ma.iter().filter(|&&c| c).count() as f64, mb.iter().filter(|&&c| c).count() as f64);
            sum_a += ca;
            sum_b += cb;
            sum_ab += ca * cb;
        }
        let p = (aa * ab) as f64;
        let f = both as f64 / slots as f64;
        // Samples of one pixel are not independent draws, so bound with the pixel count.
        let sigma = (p * (1.0 - p) / n as f64).sqrt();
        assert!((f - p).abs() < 4.5 * sigma, "P(both) {f} vs {p}");
        let nf = n as f64;
        let cov = sum_ab / nf - (sum_a / nf) * (sum_b / nf);
        // Each count takes two neighbouring values: variances ≤ 1/4, so |cov| is tiny if independent.
        assert!(cov.abs() < 0.01, "popcount covariance {cov}");
        // Masks also differ between neighbouring pixels and seeds.
        assert_ne!(mask(0, 0, 5, 0.5, 16), mask(1, 0, 5, 0.5, 16));
        assert_ne!(coverage_seed(1), coverage_seed(1 << 32));
    }

    proptest::proptest! {
        /// The product of up to 8 tints from the sum of their fixed-point logs is within the stated
        /// rounding (5.3·10⁻⁶ relative per layer, plus f32 rounding) of the f64 product, in any order.
        #[test]
        fn tint_log_sums_are_products(
            tints in proptest::collection::vec(proptest::array::uniform3(1e-4f32..=1.0), 1..8)
        ) {
            let mut sum = [0u32; 3];
            let mut rev = [0u32; 3];
            let mut exact = [1.0f64; 3];
            for t in &tints {
                let l = tint_log(*t);
                for ch in 0..3 {
                    sum[ch] += l[ch];
                    exact[ch] *= t[ch] as f64;
                }
            }
            for t in tints.iter().rev() {
                let l = tint_log(*t);
                for ch in 0..3 {
                    rev[ch] += l[ch];
                }
            }
            proptest::prop_assert_eq!(sum, rev);
            for ch in 0..3 {
                let got = tint_from_log(sum[ch]) as f64;
                let bound = exact[ch] * (6e-6 * tints.len() as f64 + 1e-6);
                proptest::prop_assert!((got - exact[ch]).abs() <= bound, "{got} vs {}", exact[ch]);
            }
        }
    }

    #[test]
    fn tint_logs_of_powers_of_two_are_exact_and_zero_blocks() {
        assert_eq!(tint_log([1.0, 0.5, 0.25]), [0, TINT_LOG_ONE, 2 * TINT_LOG_ONE]);
        let l = tint_log([0.5, 0.5, 0.125]);
        assert_eq!(tint_from_log(l[0] + l[0]), 0.25);
        assert_eq!(tint_from_log(l[2]), 0.125);
        assert_eq!(tint_from_log(0), 1.0);
        assert_eq!(tint_log([0.0, f32::NAN, 1e-30]), [TINT_LOG_CAP; 3]);
        assert_eq!(tint_from_log(TINT_LOG_CAP), 0.0);
        // 1023 fully blocking layers still fit 32 bits.
        assert!(1023u64 * TINT_LOG_CAP as u64 <= u32::MAX as u64);
    }

    #[test]
    fn methods_parse_back() {
        for m in TransparencyMethod::ALL.iter().chain(&[TransparencyMethod::Peeling { layers: 3 }]) {
            assert_eq!(m.to_string().parse::<TransparencyMethod>().unwrap(), *m);
        }
        assert_eq!(
            "peeling".parse::<TransparencyMethod>().unwrap(),
            TransparencyMethod::Peeling { layers: 8 }
        );
        let e = "nope".parse::<TransparencyMethod>().unwrap_err().to_string();
        assert!(e.contains("stochastic") && e.contains("depth-based") && e.contains("peeling/K"), "{e}");
        for bad in ["peeling/0", "peeling/65", "peeling/x"] {
            let e = bad.parse::<TransparencyMethod>().unwrap_err().to_string();
            assert!(e.contains("peeling layers") && e.contains("1..=64"), "{bad}: {e}");
        }
    }
}
