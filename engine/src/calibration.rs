//! What Shutter measured on each driver, and uses at run time: which stochastic bound is cheapest
//! (`--bound device`), which exact coverage path is (`--set coverage=device`) and what the per-object stochastic frame costs against `accumulation` (the
//! quality planner's [`CostModel`]).
//!
//! The answer depends on the driver *and its version* (Mesa 25.0's lavapipe runs the stochastic frame
//! several times faster, relative to accumulation, than Debian 12's 22.3), so each entry names a driver
//! by Shutter's name for it ([`crate::vk::drivers::driver_matches`]: `lavapipe-25.0` for every 25.0.x)
//! and, optionally, a device. Entries come from two TOML files of the same format:
//!
//! - the user's, written by `shutter calibrate` (`$SHUTTER_CACHE_DIR`, else `$XDG_CACHE_HOME/shutter`,
//!   else `~/.cache/shutter`, file `calibration.toml`): measured on this machine, so it comes first;
//! - the built-in `engine/data/calibrations.toml`, measured by the project with the command each
//!   entry quotes.
//!
//! The first entry that matches the device and has a field gives that field; a device no entry
//! matches gets the adaptive bound and equal costs (an uncalibrated guess, said so).
//!
//! ```toml
//! [[calibration]]
//! driver = "lavapipe-25.0"        # which drivers it is for
//! device = "llvmpipe"             # optional: a part of the device's name
//! bound = "bbox"                  # optional: `--bound device`'s bound ...
//! bound_measured = "..."          # ... and where it was measured
//! coverage = "visibility"         # optional: `coverage=device`'s path (visibility or mask) ...
//! coverage_measured = "..."       # ... and where it was measured
//!
//! [[calibration.cost]]            # optional, one per image size measured:
//! width = 160                     #   the size
//! height = 90
//! spp = 16                        #   the S both techniques ran at
//! stochastic_ms_ratio = 0.4       #   the per-object stochastic frame's GPU ms / accumulation's
//! stochastic_flip_ratio = 0.9     #   its noise (against other seeds' mean) / accumulation's
//! measured = "..."                #   the command, driver, CPU, commit and date
//! ```
//!
//! The cost ratio is kept per image size because the two techniques do not scale alike: on lavapipe
//! accumulation's passes grow more slowly with the pixel count than the stochastic frame's coverage and
//! shading. At a size between two measured ones the ratios are interpolated linearly in log(pixels);
//! outside them the nearest is used (and the model's `source` says which).

use std::path::PathBuf;

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::mirror::bounds::BoundKind;
use crate::quality_plan::CostModel;
use crate::techniques::stochastic::{Coverage, MaskRate};
use crate::vk::drivers::driver_matches;
use crate::vk::Capabilities;

/// The calibrations the project measured (the file's own comments say how).
pub const BUILT_IN: &str = include_str!("../data/calibrations.toml");

/// One driver's measurements (module docs).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Calibration {
    /// A driver name: `lavapipe-25.0`, `lavapipe`, `nvidia-h200-580`.
    pub driver: String,
    /// A part of the device's name (case-insensitive); None: any device of the driver.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub device: Option<String>,
    /// The cheapest stochastic bound, by its `--bound` name.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bound: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bound_measured: Option<String>,
    /// The faster exact coverage path, by its `coverage=` name: `visibility` or `mask` (per sample;
    /// both give the same image, so only time decides).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub coverage: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub coverage_measured: Option<String>,
    /// The quality planner's cost ratios, one point per image size measured.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub cost: Vec<CostPoint>,
}

/// The coverage paths a calibration may choose between: those that give the same image.
pub const EXACT_COVERAGE: [Coverage; 2] = [Coverage::Visibility, Coverage::Mask(MaskRate::Sample)];

/// The per-object stochastic frame against `accumulation` at equal S, at one image size.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CostPoint {
    pub width: u32,
    pub height: u32,
    pub spp: u32,
    /// Its GPU ms over `accumulation`'s.
    pub stochastic_ms_ratio: f64,
    /// Its noise (each seed against the mean of the others, `quality_plan::measure_noise`) over
    /// `accumulation`'s.
    pub stochastic_flip_ratio: f64,
    /// The command, driver, CPU, commit and date.
    pub measured: String,
}

impl CostPoint {
    fn pixels(&self) -> f64 {
        self.width as f64 * self.height as f64
    }
}

/// A calibration file: `[[calibration]]` entries.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CalibrationFile {
    #[serde(default)]
    pub calibration: Vec<Calibration>,
}

impl Calibration {
    /// Whether the entry is for `caps`' driver and device.
    pub fn applies_to(&self, caps: &Capabilities) -> bool {
        driver_matches(&self.driver, &caps.driver_id, &caps.device_name, &caps.driver_info)
            && self
                .device
                .as_ref()
                .is_none_or(|d| caps.device_name.to_lowercase().contains(&d.to_lowercase()))
    }

    /// Both cost ratios, where present, finite and positive; a bound name Shutter knows.
    fn check(&self, origin: &str) -> Result<()> {
        let bad = |what: String| {
            Err(Error::Unsupported(format!("{origin}: calibration for `{}`: {what}", self.driver)))
        };
        if self.driver.trim().is_empty() {
            return bad("an empty driver name".into());
        }
        for p in &self.cost {
            for (name, r) in [
                ("stochastic_ms_ratio", p.stochastic_ms_ratio),
                ("stochastic_flip_ratio", p.stochastic_flip_ratio),
            ] {
                if !(r.is_finite() && r > 0.0) {
                    return bad(format!("{name} = {r} (must be finite and > 0)"));
                }
            }
            if p.width == 0 || p.height == 0 || p.spp == 0 {
                return bad(format!("a cost point of {}x{} at S = {}", p.width, p.height, p.spp));
            }
        }
        if let Some(w) = self.cost.windows(2).find(|w| w[0].pixels() == w[1].pixels()) {
            return bad(format!("two cost points for {}x{} pixels", w[0].width, w[0].height));
        }
        if let Some(b) = &self.bound {
            b.parse::<BoundKind>().map_err(|e| Error::Unsupported(format!("{origin}: {e}")))?;
        }
        if let Some(c) = &self.coverage {
            let path = c.parse::<Coverage>().map_err(|e| Error::Unsupported(format!("{origin}: {e}")))?;
            if !EXACT_COVERAGE.contains(&path) {
                return bad(format!(
                    "coverage `{c}`: a calibration chooses between the exact paths ({})",
                    EXACT_COVERAGE.map(|p| p.name()).join(", ")
                ));
            }
        }
        Ok(())
    }
}

impl CalibrationFile {
    /// Parses and checks a calibration file's text; `origin` names it in errors.
    pub fn parse(text: &str, origin: &str) -> Result<CalibrationFile> {
        let mut file: CalibrationFile =
            toml::from_str(text).map_err(|e| Error::Unsupported(format!("{origin}: {e}")))?;
        for c in &mut file.calibration {
            // Interpolation and the duplicate check read the points in order of size, whatever
            // order a hand-edited file lists them in.
            c.cost.sort_by(|a, b| a.pixels().total_cmp(&b.pixels()));
            c.check(origin)?;
        }
        Ok(file)
    }

    /// The built-in calibrations.
    pub fn built_in() -> CalibrationFile {
        Self::parse(BUILT_IN, "engine/data/calibrations.toml")
            .expect("the built-in calibrations parse (tested)")
    }

    /// Where `shutter calibrate` writes the user's calibrations (module docs).
    pub fn user_path() -> Option<PathBuf> {
        let dir = std::env::var_os("SHUTTER_CACHE_DIR")
            .filter(|d| !d.is_empty())
            .map(PathBuf::from)
            .or_else(|| std::env::var_os("XDG_CACHE_HOME").map(|d| PathBuf::from(d).join("shutter")))
            .or_else(|| std::env::var_os("HOME").map(|d| PathBuf::from(d).join(".cache/shutter")))?;
        Some(dir.join("calibration.toml"))
    }

    /// The user's calibrations (empty where there is no file). A file that does not parse is an error
    /// (rather than silently ignored).
    pub fn user() -> Result<(Option<PathBuf>, CalibrationFile)> {
        let Some(path) = Self::user_path() else { return Ok((None, CalibrationFile::default())) };
        match std::fs::read_to_string(&path) {
            Ok(text) => {
                let file = Self::parse(
                    &text,
                    &format!("{} (fix or delete it, or rerun `shutter calibrate`)", path.display()),
                )?;
                Ok((Some(path), file))
            }
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                Ok((Some(path), CalibrationFile::default()))
            }
            Err(e) => Err(Error::io(&path, e)),
        }
    }

    /// Merges `entry` into the entry for exactly this driver and device (adding one if none): its
    /// bound replaces the old one where it has one; each of its cost points replaces the old point of
    /// the same pixel count or joins the list (kept sorted by pixels).
    pub fn upsert(&mut self, entry: Calibration) {
        let Some(old) =
            self.calibration.iter_mut().find(|c| c.driver == entry.driver && c.device == entry.device)
        else {
            let mut entry = entry;
            entry.cost.sort_by(|a, b| a.pixels().total_cmp(&b.pixels()));
            self.calibration.push(entry);
            return;
        };
        if entry.bound.is_some() {
            old.bound = entry.bound;
            old.bound_measured = entry.bound_measured;
        }
        if entry.coverage.is_some() {
            old.coverage = entry.coverage;
            old.coverage_measured = entry.coverage_measured;
        }
        for p in entry.cost {
            old.cost.retain(|q| q.pixels() != p.pixels());
            old.cost.push(p);
        }
        old.cost.sort_by(|a, b| a.pixels().total_cmp(&b.pixels()));
    }

    /// Writes the file atomically to `path`.
    pub fn save(&self, path: &std::path::Path) -> Result<()> {
        if let Some(dir) = path.parent() {
            std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
        }
        let mut text = String::from(
            "# Shutter's calibrations measured on this machine by `shutter calibrate`; they come before the\n\
             # built-in ones (engine/data/calibrations.toml). Delete an entry to fall back to those.\n\n",
        );
        text.push_str(&toml::to_string(self).map_err(|e| Error::Unsupported(format!("calibration: {e}")))?);
        crate::image_io::write_file_atomically(path, text.as_bytes())
    }
}

/// The calibrations that apply to `caps`' device, the user's first, each with where it comes from.
pub fn for_device(caps: &Capabilities) -> Result<Vec<(String, Calibration)>> {
    let (path, user) = CalibrationFile::user()?;
    let origin = path.map_or_else(|| "user calibration".to_string(), |p| p.display().to_string());
    Ok(user
        .calibration
        .into_iter()
        .map(|c| (origin.clone(), c))
        .chain(CalibrationFile::built_in().calibration.into_iter().map(|c| ("built-in".to_string(), c)))
        .filter(|(_, c)| c.applies_to(caps))
        .collect())
}

/// `--bound device`'s bound on `caps`' device and why. Without a calibration (or with an unreadable
/// user file, which the quality planner reports), the adaptive bound.
pub fn device_bound(caps: &Capabilities) -> (BoundKind, String) {
    let entries = match for_device(caps) {
        Ok(e) => e,
        Err(e) => return (BoundKind::Adaptive, format!("adaptive ({e})")),
    };
    for (origin, c) in entries {
        if let Some(Ok(kind)) = c.bound.as_deref().map(str::parse::<BoundKind>) {
            let measured = c.bound_measured.as_deref().unwrap_or("no measurement recorded");
            return (kind, format!("calibrated for {} ({origin}): {measured}", c.driver));
        }
    }
    (
        BoundKind::Adaptive,
        format!("no calibration for {} (run `shutter calibrate`): adaptive", caps.driver_key),
    )
}

/// The exact coverage path the driver's calibration found faster, and where it was measured; None
/// without one (or with an unreadable user file: `device_bound` and the planner report that).
pub fn device_coverage(caps: &Capabilities) -> Option<(Coverage, String)> {
    for (origin, c) in for_device(caps).ok()? {
        if let Some(Ok(path)) = c.coverage.as_deref().map(str::parse::<Coverage>) {
            let measured = c.coverage_measured.as_deref().unwrap_or("no measurement recorded");
            return Some((path, format!("calibrated for {} ({origin}): {measured}", c.driver)));
        }
    }
    None
}

/// The quality planner's cost model on `caps`' device for a `width`×`height` image: the first
/// calibration with cost points, interpolated to that size (module docs); else equal costs (an
/// uncalibrated guess, said in `source`).
pub fn cost_model(caps: &Capabilities, size: (u32, u32)) -> Result<CostModel> {
    Ok(cost_model_from(caps, for_device(caps)?, size))
}

/// The first of `entries` with cost points, as a [`CostModel`] at `size`; equal costs without one.
pub fn cost_model_from(
    caps: &Capabilities,
    entries: impl IntoIterator<Item = (String, Calibration)>,
    size: (u32, u32),
) -> CostModel {
    let model = |ms: f64, flip: f64, source: String| CostModel {
        driver_id: caps.driver_id.clone(),
        device_name: caps.device_name.clone(),
        stochastic_ms_ratio: ms,
        stochastic_flip_ratio: flip,
        source,
    };
    for (origin, c) in entries {
        let Some((ms, flip, how)) = interpolate(&c.cost, size) else { continue };
        return model(ms, flip, format!("{how} [{origin} calibration for {}]", c.driver));
    }
    model(
        1.0,
        1.0,
        format!("equal costs: a guess, no calibration for {} (run `shutter calibrate`)", caps.driver_key),
    )
}

/// The cost ratios at `size` from `points` (sorted by pixels): linear in log(pixels) between the two
/// around it, the nearest outside them; with a line saying which points.
fn interpolate(points: &[CostPoint], (w, h): (u32, u32)) -> Option<(f64, f64, String)> {
    let px = (w as f64 * h as f64).max(1.0);
    let first = points.first()?;
    let last = points.last()?;
    let one = |p: &CostPoint, why: &str| {
        Some((p.stochastic_ms_ratio, p.stochastic_flip_ratio, format!("{why}{}", p.measured)))
    };
    if px <= first.pixels() {
        return one(first, if px < first.pixels() { "the smallest size measured: " } else { "" });
    }
    if px >= last.pixels() {
        return one(last, if px > last.pixels() { "the largest size measured: " } else { "" });
    }
    let i = points.iter().position(|p| p.pixels() >= px)?;
    let (a, b) = (&points[i - 1], &points[i]);
    if b.pixels() == px {
        return one(b, "");
    }
    let f = (px.ln() - a.pixels().ln()) / (b.pixels().ln() - a.pixels().ln());
    let lerp = |x: f64, y: f64| x + (y - x) * f;
    Some((
        lerp(a.stochastic_ms_ratio, b.stochastic_ms_ratio),
        lerp(a.stochastic_flip_ratio, b.stochastic_flip_ratio),
        format!(
            "interpolated in log(pixels) between {}x{} ({:.2}x ms) and {}x{} ({:.2}x ms): {} / {}",
            a.width,
            a.height,
            a.stochastic_ms_ratio,
            b.width,
            b.height,
            b.stochastic_ms_ratio,
            a.measured,
            b.measured
        ),
    ))
}

/// Measures the quality planner's cost point on `scene` at `settings`' size and S (`shutter
/// calibrate`): `accumulation` and the per-object stochastic frame (`auto` at fixed S), `frames` warm
/// frames each; the ratio of their median GPU ms, and of their noise as the planner uses it.
/// `measured_on` describes the machine for the point's `measured` text.
///
/// The planner predicts accumulation's noise at S from its pilot (S = `PILOT_SPP`,
/// `PILOT_SUBFRAMES` seeds, each against the others' mean) scaled by `(PILOT_SPP / S)^NOISE_EXPONENT`,
/// and the stochastic frame's as the ratio times that. So the ratio's denominator is that very
/// prediction, measured as the pilot measures it, and its numerator the stochastic frame's noise at
/// S (each seed against the others' mean). Comparing the two techniques' noise at S directly, as
/// before, gave 0.71–0.75 on `default` at 160×90 where their errors against the ground truth differ
/// by 0.50, and the stochastic frame at its ratio met `final` at about 0.64 of the pilot's
/// prediction: the pilot's scaling law, not the stochastic frame, is what the ratio has to carry.
pub fn measure_cost_point(
    renderer: &mut crate::techniques::Renderer,
    scene: &crate::scene::Scene,
    settings: &crate::techniques::RenderSettings,
    frames: usize,
    measured_on: &str,
) -> Result<CostPoint> {
    use crate::quality_plan::{measure_ms, measure_noise, noise_scale, PILOT_SPP, PILOT_SUBFRAMES};
    use crate::techniques::{RenderSettings, Technique};
    let spp = settings.spp;
    let (acc_ms, _) = measure_ms(renderer, scene, Technique::ACCUMULATION, settings, frames)?;
    let pilot = RenderSettings { spp: PILOT_SPP, ..*settings };
    let acc_pilot =
        measure_noise(renderer, scene, Technique::ACCUMULATION, &pilot, 1, PILOT_SUBFRAMES)?.noise_flip;
    let acc_noise = acc_pilot * noise_scale(PILOT_SPP, spp);
    let stochastic = measure_noise(renderer, scene, Technique::AUTO, settings, frames, 4)?;
    let (st_ms, st_noise) = (stochastic.ms, stochastic.noise_flip);
    let point = CostPoint {
        width: settings.width,
        height: settings.height,
        spp,
        stochastic_ms_ratio: st_ms / acc_ms,
        stochastic_flip_ratio: st_noise / acc_noise,
        measured: format!(
            "`shutter calibrate` ({}, {}x{}, S = {spp}): accumulation {acc_ms:.1} ms, noise FLIP {acc_noise:.4} (the pilot's prediction from {acc_pilot:.4} at S = {PILOT_SPP}); stochastic {st_ms:.1} ms, {st_noise:.4}; {measured_on}",
            scene.name, settings.width, settings.height,
        ),
    };
    let valid =
        [point.stochastic_ms_ratio, point.stochastic_flip_ratio].iter().all(|r| r.is_finite() && *r > 0.0);
    if !valid {
        return Err(Error::Unsupported(format!(
            "cost model not measured: ratios {} (ms) and {} (noise) — measure it on a scene that blurs, e.g. `shutter calibrate default`",
            point.stochastic_ms_ratio, point.stochastic_flip_ratio
        )));
    }
    Ok(point)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_built_in_file_parses_and_names_both_lavapipes() {
        let file = CalibrationFile::built_in();
        for key in ["lavapipe-22.3", "lavapipe-25.0"] {
            let c = file.calibration.iter().find(|c| c.driver == key).unwrap_or_else(|| panic!("{key}"));
            assert!(c.bound.is_some() && c.coverage.is_some() && c.cost.len() >= 2, "{c:?}");
            let measured = c
                .cost
                .iter()
                .map(|p| p.measured.as_str())
                .chain(c.bound_measured.as_deref())
                .chain(c.coverage_measured.as_deref());
            for m in measured {
                assert!(m.contains("shutter calibrate") && m.contains("Mesa"), "{key}: {m}");
            }
        }
    }

    #[test]
    fn bad_files_are_refused_with_their_origin() {
        for (text, needle) in [
            (
                "[[calibration]]\ndriver = \"x\"\n[[calibration.cost]]\nwidth = 1\nheight = 1\nspp = 1\n\
                 stochastic_ms_ratio = -1.0\nstochastic_flip_ratio = 1.0\nmeasured = \"\"\n",
                "must be finite",
            ),
            ("[[calibration]]\ndriver = \"x\"\n[[calibration.cost]]\nwidth = 1\n", "missing field"),
            ("[[calibration]]\ndriver = \"x\"\nbound = \"blob\"\n", "blob"),
            ("[[calibration]]\ndriver = \"x\"\ncoverage = \"blob\"\n", "blob"),
            ("[[calibration]]\ndriver = \"x\"\ncoverage = \"mask-per-fragment\"\n", "exact paths"),
            ("[[calibration]]\ndriver = \"x\"\ncoverage = \"device\"\n", "exact paths"),
            ("[[calibration]]\ndriver = \"x\"\nspeed = 2\n", "unknown field"),
            ("[[calibration]]\ndriver = \"\"\n", "empty driver"),
        ] {
            let e = CalibrationFile::parse(text, "my.toml").unwrap_err().to_string();
            assert!(e.contains("my.toml") && e.contains(needle), "{e}");
        }
    }

    fn point(w: u32, h: u32, ms: f64) -> CostPoint {
        CostPoint {
            width: w,
            height: h,
            spp: 16,
            stochastic_ms_ratio: ms,
            stochastic_flip_ratio: 1.0,
            measured: format!("{w}x{h}"),
        }
    }

    #[test]
    fn upsert_merges_bounds_and_cost_points_by_size() {
        let mut f = CalibrationFile::default();
        f.upsert(Calibration {
            driver: "lavapipe-25.0".into(),
            bound: Some("bbox".into()),
            ..Default::default()
        });
        f.upsert(Calibration {
            driver: "lavapipe-25.0".into(),
            cost: vec![point(640, 360, 1.2), point(160, 90, 0.5)],
            ..Default::default()
        });
        f.upsert(Calibration {
            driver: "lavapipe-25.0".into(),
            cost: vec![point(160, 90, 0.4)],
            ..Default::default()
        });
        f.upsert(Calibration { driver: "lavapipe-22.3".into(), ..Default::default() });
        assert_eq!(f.calibration.len(), 2);
        let c = &f.calibration[0];
        assert_eq!(c.bound.as_deref(), Some("bbox"));
        assert_eq!(
            c.cost.iter().map(|p| (p.width, p.stochastic_ms_ratio)).collect::<Vec<_>>(),
            [(160, 0.4), (640, 1.2)]
        );
        let again = CalibrationFile::parse(&toml::to_string(&f).unwrap(), "round trip").unwrap();
        assert_eq!(again, f);
    }

    #[test]
    fn a_file_may_list_its_points_in_any_order() {
        let entry = |w: u32, h: u32, ms: f64| {
            format!(
                "[[calibration.cost]]\nwidth = {w}\nheight = {h}\nspp = 16\nstochastic_ms_ratio = {ms}\n\
                 stochastic_flip_ratio = 1.0\nmeasured = \"\"\n"
            )
        };
        let head = "[[calibration]]\ndriver = \"x\"\n";
        let text = format!("{head}{}{}", entry(640, 360, 2.0), entry(160, 90, 0.5));
        let file = CalibrationFile::parse(&text, "unsorted.toml").unwrap();
        assert!((interpolate(&file.calibration[0].cost, (320, 180)).unwrap().0 - 1.25).abs() < 1e-12);
        let twice = format!("{head}{}{}{}", entry(160, 90, 0.5), entry(640, 360, 2.0), entry(160, 90, 0.4));
        let e = CalibrationFile::parse(&twice, "twice.toml").unwrap_err().to_string();
        assert!(e.contains("two cost points for 160x90"), "{e}");
    }

    #[test]
    fn cost_ratios_interpolate_in_log_pixels_and_clamp_outside() {
        let pts = [point(160, 90, 0.5), point(640, 360, 2.0)];
        let at = |w, h| interpolate(&pts, (w, h)).unwrap();
        assert_eq!(at(160, 90).0, 0.5);
        assert_eq!(at(640, 360).0, 2.0);
        assert_eq!(at(80, 45).0, 0.5);
        assert!(at(80, 45).2.starts_with("the smallest size measured"));
        assert_eq!(at(1280, 720).0, 2.0);
        // 320x180 is half-way in log(pixels).
        assert!((at(320, 180).0 - 1.25).abs() < 1e-12, "{}", at(320, 180).0);
        assert!(interpolate(&[], (10, 10)).is_none());
    }
}
