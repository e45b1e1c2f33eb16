//! The display transform of 8-bit output: an exposure in stops, then a tone curve, then (in
//! [`crate::image_io::write_png`]) the sRGB encoding.
//!
//! Rendering, EXR output and every metric stay linear: the transform is applied only where an image
//! becomes a PNG for a person to look at ([`crate::image_io::save_image_displayed`]). The default,
//! [`Display::LINEAR`], is what every PNG was before it existed — no exposure, values above 1 clipped —
//! so a scene that does not ask for it gets the same bytes.
//!
//! Curves, per colour channel (so a hue may shift towards white as it saturates, as film does):
//! - `clip`: `min(x, 1)` — exact for values up to 1, everything brighter is white.
//! - `reinhard`: `x / (1 + x)` (Reinhard et al., "Photographic Tone Reproduction for Digital Images",
//!   2002, its simple global operator): approaches white without reaching it (in 8 bits, linear values
//!   up to about 220 stay below code 255), but mid-grey 0.18 comes out at 0.15 — raise the exposure
//!   about 0.3 EV to keep mid-tones.
//! - `aces`: Narkowicz's rational fit of the ACES reference rendering transform ("ACES Filmic Tone
//!   Mapping Curve", 2015), with its 0.6 input scale: a toe, a shoulder, mid-grey 0.18 at 0.14, and
//!   white from a linear value of about 12.

use crate::image::LinearImage;

/// A tone curve: what a display value in [0, 1] a linear, exposed value becomes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum ToneCurve {
    /// `min(x, 1)`: linear up to white, brighter clips.
    #[default]
    Clip,
    /// `x / (1 + x)`: approaches white, never clips below ~10⁷.
    Reinhard,
    /// Narkowicz's fit of the ACES filmic curve.
    Aces,
}

impl ToneCurve {
    /// Every curve, in the order the docs list them.
    pub const ALL: [ToneCurve; 3] = [ToneCurve::Clip, ToneCurve::Reinhard, ToneCurve::Aces];

    /// The name scene files and the command line use.
    pub fn name(self) -> &'static str {
        match self {
            ToneCurve::Clip => "clip",
            ToneCurve::Reinhard => "reinhard",
            ToneCurve::Aces => "aces",
        }
    }

    /// The curve named `name` ([`ToneCurve::name`]).
    pub fn from_name(name: &str) -> Option<ToneCurve> {
        Self::ALL.into_iter().find(|c| c.name() == name)
    }

    /// [`ToneCurve::from_name`], or the message scene files and the command line both give: the name
    /// (quoted safely) and the names there are.
    pub fn parse(name: &str) -> Result<ToneCurve, String> {
        Self::from_name(name).ok_or_else(|| {
            let names: Vec<&str> = Self::ALL.iter().map(|c| c.name()).collect();
            let name = crate::limits::quote_safely(name, 40);
            format!("unknown tone curve `{name}`; expected one of {}", names.join(", "))
        })
    }

    /// The display value of the linear value `x` (already exposed); negative values are black, NaN
    /// stays NaN (the PNG encoder's business).
    pub fn map(self, x: f32) -> f32 {
        if x.is_nan() {
            return x;
        }
        let x = if x < 0.0 { 0.0 } else { x };
        match self {
            ToneCurve::Clip => x.min(1.0),
            ToneCurve::Reinhard => {
                if x == f32::INFINITY {
                    1.0
                } else {
                    x / (1.0 + x)
                }
            }
            ToneCurve::Aces => {
                let x = (x * 0.6).min(ACES_SATURATION);
                ((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14)).clamp(0.0, 1.0)
            }
        }
    }
}

/// Above this (scaled) input the ACES fit exceeds 1 and is clipped anyway; clamping the input first
/// keeps the rational function away from overflow (∞/∞) for huge values.
const ACES_SATURATION: f32 = 1.0e4;

/// Exposure and tone curve of 8-bit output (scene files' `[image] exposure` and `tone`; the command
/// line's `--exposure` and `--tone`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Display {
    /// Stops: the linear value is multiplied by 2^EV before the curve. Finite, in ±[`MAX_EXPOSURE_EV`].
    pub exposure_ev: f32,
    pub curve: ToneCurve,
}

/// The largest exposure adjustment, in stops, either way (2^±64 keeps every f32 radiance finite or
/// zero in a way a person could still ask for).
pub const MAX_EXPOSURE_EV: f32 = 64.0;

/// Whether `ev` is an exposure [`Display`] takes: finite, within ±[`MAX_EXPOSURE_EV`].
pub fn exposure_in_range(ev: f32) -> bool {
    ev.is_finite() && ev.abs() <= MAX_EXPOSURE_EV
}

impl Default for Display {
    fn default() -> Self {
        Display::LINEAR
    }
}

impl Display {
    /// No exposure, values above 1 clipped: every PNG before the transform existed.
    pub const LINEAR: Display = Display { exposure_ev: 0.0, curve: ToneCurve::Clip };

    /// Whether this is [`Display::LINEAR`] (the transform changes nothing a PNG can hold).
    pub fn is_linear(&self) -> bool {
        *self == Display::LINEAR
    }

    /// The display value of one linear colour channel.
    pub fn map(&self, x: f32) -> f32 {
        self.curve.map(x * self.exposure_ev.exp2())
    }

    /// `image` through the transform (colour only; alpha, which is coverage, as it was).
    pub fn apply(&self, image: &LinearImage) -> LinearImage {
        let mut out = image.clone();
        if self.is_linear() {
            return out;
        }
        for p in &mut out.pixels {
            for c in &mut p[..3] {
                *c = self.map(*c);
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn the_linear_display_changes_nothing_a_png_holds() {
        for i in 0..=1000 {
            let x = i as f32 / 1000.0;
            assert_eq!(Display::LINEAR.map(x), x);
        }
        assert_eq!(Display::LINEAR.map(7.0), 1.0);
        assert_eq!(Display::LINEAR.map(-0.5), 0.0);
        for c in ToneCurve::ALL {
            assert!(c.map(f32::NAN).is_nan(), "{c:?}");
        }
    }

    #[test]
    fn names_round_trip() {
        for c in ToneCurve::ALL {
            assert_eq!(ToneCurve::from_name(c.name()), Some(c));
        }
        assert_eq!(ToneCurve::from_name("filmic"), None);
    }

    #[test]
    fn known_values() {
        assert_eq!(ToneCurve::Reinhard.map(1.0), 0.5);
        assert_eq!(ToneCurve::Reinhard.map(f32::INFINITY), 1.0);
        assert!((ToneCurve::Reinhard.map(0.18) - 0.18 / 1.18).abs() < 1e-7);
        assert_eq!(ToneCurve::Aces.map(0.0), 0.0);
        // Mid-grey 0.18 → 0.140 through the toe; white from about 12 (0.6 x ≈ 7.24 solves f = 1).
        let grey = ToneCurve::Aces.map(0.18);
        assert!((grey - 0.1401).abs() < 1e-3, "{grey}");
        assert!(ToneCurve::Aces.map(11.5) < 1.0 && ToneCurve::Aces.map(12.5) == 1.0);
        assert_eq!(ToneCurve::Aces.map(1.0e30), 1.0);
        assert_eq!(ToneCurve::Aces.map(f32::INFINITY), 1.0);
        let d = Display { exposure_ev: 1.0, curve: ToneCurve::Clip };
        assert_eq!(d.map(0.25), 0.5);
        let d = Display { exposure_ev: -2.0, curve: ToneCurve::Clip };
        assert_eq!(d.map(2.0), 0.5);
    }

    #[test]
    fn alpha_is_left_alone() {
        let img =
            LinearImage { width: 2, height: 1, pixels: vec![[4.0, 0.5, 0.0, 0.25], [0.1, 0.2, 0.3, 1.0]] };
        let out = Display { exposure_ev: 1.0, curve: ToneCurve::Reinhard }.apply(&img);
        assert_eq!(out.pixels[0][3], 0.25);
        assert_eq!(out.pixels[1][3], 1.0);
        assert_eq!(out.pixels[0][0], 8.0 / 9.0);
        assert_eq!(Display::LINEAR.apply(&img).pixels, img.pixels);
    }

    proptest! {
        /// Every curve maps into [0, 1] and never darkens a brighter value.
        #[test]
        fn curves_are_monotone_into_the_unit_interval(a in -10.0f32..1.0e6, b in -10.0f32..1.0e6) {
            let (lo, hi) = if a <= b { (a, b) } else { (b, a) };
            for c in ToneCurve::ALL {
                let (ml, mh) = (c.map(lo), c.map(hi));
                prop_assert!((0.0..=1.0).contains(&ml) && (0.0..=1.0).contains(&mh), "{c:?} {lo} {hi}");
                prop_assert!(ml <= mh, "{c:?}: map({lo}) = {ml} > map({hi}) = {mh}");
            }
        }

        /// Reinhard keeps every value a scene holds below white: a bright scene keeps its gradations.
        #[test]
        fn reinhard_never_clips(x in 0.0f32..1.0e6) {
            prop_assert!(ToneCurve::Reinhard.map(x) < 1.0);
        }

        /// An exposure of EV stops is the same as the input multiplied by 2^EV.
        #[test]
        fn exposure_is_a_power_of_two_scale(x in 0.0f32..100.0, ev in -8i32..8) {
            for c in ToneCurve::ALL {
                let d = Display { exposure_ev: ev as f32, curve: c };
                prop_assert_eq!(d.map(x), c.map(x * (ev as f32).exp2()));
            }
        }
    }
}
