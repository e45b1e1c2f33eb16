//! The spectra of the three filters between a surface's shading and a pixel (Vaidyanathan et al. 2012,
//! §3.1): the aperture `A`, the shutter `S` and the reconstruction filter `R`. None has bounded support
//! in frequency, so each is cut where it holds a chosen share of its energy (the paper's Figure 3); the
//! cutoffs are constants of the camera, computed once here:
//!
//! * **aperture**, in cycles per unit of the lens radius: a radially symmetric transmission `T(ρ)` on
//!   the unit disk has the Hankel transform `F(ω) = 2π ∫₀¹ T(ρ) J₀(2πωρ) ρ dρ`; by Parseval its energy
//!   is `2π ∫₀¹ T² ρ dρ`, and the cutoff is the radius `Ω` whose disk holds the share `kept` of it. Seen
//!   on the image through a circle of confusion of radius `φ` pixels the aperture is `φ` times larger,
//!   so its cutoff there is `Ω / φ` cycles per pixel. For the sharp disk the encircled energy has a
//!   closed form (Rayleigh's `1 − J₀² − J₁²` of `2πΩ`), which the tests use as an oracle;
//! * **shutter**, in cycles per shutter interval: the box `S = 1` on `[0, 1]` has `|F(ν)| = |sinc ν|`,
//!   the tent `sinc²`; a point moving at `|µ|` pixels per shutter smears it over a segment `|µ|` long,
//!   so its cutoff along the motion is `Ω / |µ|` cycles per pixel (§3.1, Eq. 7);
//! * **reconstruction**: the box pixel filter of the stochastic frame, cut at the pixel grid's Nyquist
//!   rate, 1/2 cycle per pixel — so a surface without blur is shaded once per pixel, as decoupled
//!   sampling's screen-space grid does.
//!
//! With `kept` = [`ENERGY_KEPT`] (90 %) the sharp disk's cutoff is 0.951 cycles per lens radius, and the
//! defocus-only grid spacing `1 / (2 min(Ω/φ, 1/2))` is `max(1.05 φ/2, 1)` pixels: within 5 % of the rule
//! the ATSS paper takes from this one, `max(φ/2, 1)` (`texture_space::rate::grid_spacing_px`), so the two
//! shading techniques agree where they overlap.

use crate::sampling::{smooth_lens_transmission, ApertureShape, ShutterCurve};

/// The share of a filter's spectral energy its cutoff keeps.
pub const ENERGY_KEPT: f64 = 0.9;

/// The reconstruction filter's cutoff, cycles per pixel (module docs).
pub const RECONSTRUCTION_CUTOFF: f64 = 0.5;

/// Bessel function `J₀` (Abramowitz & Stegun 9.4.1 and 9.4.3: |error| < 5e-8).
pub fn bessel_j0(x: f64) -> f64 {
    let x = x.abs();
    if x <= 3.0 {
        let y = (x / 3.0).powi(2);
        1.0 + y
            * (-2.249_999_7
                + y * (1.265_620_8
                    + y * (-0.316_386_6 + y * (0.044_447_9 + y * (-0.003_944_4 + y * 0.000_21)))))
    } else {
        let y = 3.0 / x;
        let f0 = 0.797_884_56
            + y * (-0.000_000_77
                + y * (-0.005_527_40
                    + y * (-0.000_095_12 + y * (0.001_372_37 + y * (-0.000_728_05 + y * 0.000_144_76)))));
        let t0 = x - std::f64::consts::FRAC_PI_4
            + y * (-0.041_663_97
                + y * (-0.000_039_54
                    + y * (0.002_625_73 + y * (-0.000_541_25 + y * (-0.000_293_33 + y * 0.000_135_58)))));
        f0 * t0.cos() / x.sqrt()
    }
}

/// A radially symmetric aperture's transmission at radius `rho` of the unit disk, `None` for shapes
/// that are not (blades).
fn transmission(shape: ApertureShape) -> Option<fn(f64) -> f64> {
    match shape {
        ApertureShape::Disk => Some(|rho| if rho <= 1.0 { 1.0 } else { 0.0 }),
        ApertureShape::SmoothDisk => Some(smooth_lens_transmission),
        ApertureShape::Blades { .. } => None,
    }
}

/// Midpoint nodes over `[0, 1]`.
const RADIAL_NODES: usize = 2048;
/// Frequency step of the energy integral, cycles per lens radius.
const FREQUENCY_STEP: f64 = 1e-3;
/// Where the search gives up (every share below 0.99 is reached long before for both disks).
const FREQUENCY_LIMIT: f64 = 64.0;

/// The Hankel transform `F(ω)` of transmission `t` (module docs), by the midpoint rule.
fn hankel(t: fn(f64) -> f64, omega: f64) -> f64 {
    let h = 1.0 / RADIAL_NODES as f64;
    let sum: f64 = (0..RADIAL_NODES)
        .map(|i| {
            let rho = (i as f64 + 0.5) * h;
            t(rho) * bessel_j0(std::f64::consts::TAU * omega * rho) * rho
        })
        .sum();
    std::f64::consts::TAU * sum * h
}

/// The energy of transmission `t` over the unit disk, `2π ∫₀¹ t² ρ dρ` — its spectrum's, by Parseval.
fn energy(t: fn(f64) -> f64) -> f64 {
    let h = 1.0 / RADIAL_NODES as f64;
    std::f64::consts::TAU
        * (0..RADIAL_NODES).map(|i| (i as f64 + 0.5) * h).map(|r| t(r) * t(r) * r).sum::<f64>()
        * h
}

/// The share of the aperture's spectral energy inside frequency radius `omega` (cycles per unit lens
/// radius); `None` for a shape that is not radially symmetric.
pub fn aperture_energy_within(shape: ApertureShape, omega: f64) -> Option<f64> {
    let t = transmission(shape)?;
    let total = energy(t);
    let steps = (omega / FREQUENCY_STEP).ceil().max(1.0) as usize;
    let dw = omega / steps as f64;
    let within: f64 = (0..steps)
        .map(|k| {
            let w = (k as f64 + 0.5) * dw;
            hankel(t, w).powi(2) * w
        })
        .sum::<f64>()
        * std::f64::consts::TAU
        * dw;
    Some(within / total)
}

/// The aperture's cutoff (module docs): the smallest frequency radius, cycles per unit lens radius,
/// holding the share `kept` of its spectral energy, to `FREQUENCY_STEP`. `None` for blades (not
/// radially symmetric; AAS then treats defocus as unbounded and does not coarsen for it).
pub fn aperture_cutoff(shape: ApertureShape, kept: f64) -> Option<f64> {
    let t = transmission(shape)?;
    let total = energy(t);
    let mut within = 0.0;
    let mut w = 0.0;
    while w < FREQUENCY_LIMIT {
        let mid = w + 0.5 * FREQUENCY_STEP;
        within += std::f64::consts::TAU * hankel(t, mid).powi(2) * mid * FREQUENCY_STEP;
        w += FREQUENCY_STEP;
        if within >= kept * total {
            return Some(w);
        }
    }
    None
}

/// The cutoffs of a camera with this aperture and shutter, keeping [`ENERGY_KEPT`] of each filter's
/// energy.
pub fn camera_cutoffs(aperture: ApertureShape, shutter: ShutterCurve) -> super::bounds::Cutoffs {
    super::bounds::Cutoffs {
        aperture: aperture_cutoff(aperture, ENERGY_KEPT),
        shutter: shutter_cutoff(shutter, ENERGY_KEPT),
    }
}

/// The shutter's cutoff, cycles per shutter interval: the smallest `Ω` with the share `kept` of the
/// curve's spectral energy in `[−Ω, Ω]`, to `FREQUENCY_STEP` (the box's power spectrum is `sinc²`, the
/// unit-area tent's `sinc⁴(ν/2)`; their energies by Parseval, 1 and 4/3).
pub fn shutter_cutoff(curve: ShutterCurve, kept: f64) -> f64 {
    let sinc =
        |v: f64| if v == 0.0 { 1.0 } else { (std::f64::consts::PI * v).sin() / (std::f64::consts::PI * v) };
    // |F(ν)|²: the box is sinc²; the tent (unit area, width 1: a box of width 1/2 convolved with itself)
    // is sinc⁴(ν/2).
    let power = |v: f64| match curve {
        ShutterCurve::Box => sinc(v).powi(2),
        ShutterCurve::Tent => sinc(0.5 * v).powi(4),
    };
    // Total energy by Parseval: box ∫₀¹ 1 = 1; tent 2·∫₀^½ (4t)² dt = 4/3.
    let total = match curve {
        ShutterCurve::Box => 1.0,
        ShutterCurve::Tent => 4.0 / 3.0,
    };
    let dv = FREQUENCY_STEP;
    let (mut within, mut v) = (0.0, 0.0);
    while within < kept * total {
        within += 2.0 * power(v + 0.5 * dv) * dv;
        v += dv;
    }
    v
}

#[cfg(test)]
mod tests {
    use super::*;

    /// J₀ against its integral `(1/π) ∫₀^π cos(x sin τ) dτ`.
    #[test]
    fn bessel_j0_matches_its_integral() {
        for k in 0..=200 {
            let x = k as f64 * 0.1;
            let n = 4000;
            let integral: f64 = (0..n)
                .map(|i| {
                    let tau = (i as f64 + 0.5) * std::f64::consts::PI / n as f64;
                    (x * tau.sin()).cos()
                })
                .sum::<f64>()
                / n as f64;
            assert!((bessel_j0(x) - integral).abs() < 1e-7, "J0({x}) = {} vs {integral}", bessel_j0(x));
        }
    }

    /// The sharp disk against the closed form: its transform at 0 is its area π; inside the first
    /// dark ring of the Airy pattern (2πΩ = 3.8317, J₁'s first zero) lies 1 − J₀(3.8317)² = 83.8 % of
    /// the energy (Rayleigh's encircled energy); with 90 % kept its cutoff, 0.951 cycles per lens
    /// radius, makes the defocus grid within 5 % of ATSS's `max(φ/2, 1)`.
    #[test]
    fn the_sharp_disk_keeps_the_airy_energy() {
        let disk = ApertureShape::Disk;
        let t = transmission(disk).unwrap();
        assert!((hankel(t, 0.0) - std::f64::consts::PI).abs() < 1e-5);
        let first_ring = 3.831_705_97 / std::f64::consts::TAU;
        let e = aperture_energy_within(disk, first_ring).unwrap();
        let rayleigh = 1.0 - bessel_j0(3.831_705_97).powi(2);
        assert!((e - rayleigh).abs() < 2e-3, "{e} vs {rayleigh}");
        let cutoff = aperture_cutoff(disk, ENERGY_KEPT).unwrap();
        assert!((cutoff - 0.951).abs() < 0.005, "sharp disk: {cutoff}");
        let atss = crate::mirror::texture_space::rate::grid_spacing_px(12.0) as f64;
        let aas = 1.0 / (2.0 * (cutoff / 12.0).min(RECONSTRUCTION_CUTOFF));
        assert!((aas / atss - 1.0).abs() < 0.06, "AAS spacing {aas} vs ATSS {atss} at φ = 12 px");
    }

    /// The paper's claim for its smooth lens: less spectral support than the sharp disk, so AAS may
    /// shade more sparsely behind it — where the cutoff lies in the sharp rim's slowly decaying tail
    /// (90 % and more kept; at 80 % both cut in the main lobe, which the rim barely changes). Cutoffs
    /// grow with the share kept; blades are not radially symmetric and have none.
    #[test]
    fn the_smooth_lens_has_less_spectral_support() {
        let mut last = (0.0, 0.0);
        for kept in [0.8, 0.9, 0.95] {
            let sharp = aperture_cutoff(ApertureShape::Disk, kept).unwrap();
            let smooth = aperture_cutoff(ApertureShape::SmoothDisk, kept).unwrap();
            println!(
                "{:.0} % kept: sharp disk {sharp:.3}, smooth lens {smooth:.3} cycles per lens radius",
                100.0 * kept
            );
            assert!(smooth <= sharp, "{kept}: smooth {smooth} vs sharp {sharp}");
            if kept >= 0.9 {
                assert!(smooth < 0.95 * sharp, "{kept}: smooth {smooth} vs sharp {sharp}");
            }
            assert!(sharp > last.0 && smooth > last.1);
            last = (sharp, smooth);
        }
        assert!(aperture_cutoff(ApertureShape::Blades { blades: 6, rotation_deg: 0.0 }, 0.9).is_none());
    }

    /// The box shutter keeps 90.3 % of its energy in sinc's main lobe (|ν| < 1), so its 90 % cutoff lies
    /// just inside it (0.849: sinc² is nearly 0 over the lobe's last stretch); the unit-area tent's lobe
    /// is twice as wide (zeros at ±2) and its 90 % cutoff about the same. Cutoffs grow with the share.
    #[test]
    fn shutter_cutoffs() {
        let b = shutter_cutoff(ShutterCurve::Box, ENERGY_KEPT);
        assert!((b - 0.849).abs() < 0.005, "box {b}");
        let t = shutter_cutoff(ShutterCurve::Tent, ENERGY_KEPT);
        assert!(t > 0.7 && t < 1.2, "tent {t}");
        assert!(shutter_cutoff(ShutterCurve::Box, 0.95) > b && shutter_cutoff(ShutterCurve::Tent, 0.95) > t);
    }
}
