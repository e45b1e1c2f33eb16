//! Thresholds measured per case (`shutter check --measure-thresholds`).
//!
//! A tolerance threshold sits between two measured sizes of change:
//!
//! * **what a machine moves the image**: each case rendered on this driver and CPU against its
//!   expected image (zero on the recording machine for the bit-exact paths; f32 rounding on another
//!   driver; run-to-run noise for a path that is not reproducible), kept per machine so that several
//!   drivers' runs accumulate in one file;
//! * **what a change of seed moves the image**: the case rendered with [`RESEED_COUNT`] other seeds
//!   against its expected image, the smallest of them. A regression that only moves the samples
//!   (a sample tile off by one, a rotated pattern) looks like a reseed, so a threshold must sit well
//!   below it.
//!
//! The threshold is their geometric mean, equally far (on a log scale) from both: the largest
//! machine spread, raised to [`SPREAD_FLOOR`], and the smallest reseed. The floor is a choice, not a
//! measurement: the two lavapipes differ by at most ~6e-9 RMSE on every case, so a threshold built on
//! that alone would fail the first driver or CPU that rounds differently; 1e-5 forgives such rounding
//! and still puts the thresholds (2e-4–1.7e-3 on the suites) below one wrong sample in a pixel. Where the reseed is less than [`MIN_SEPARATION`]× the spread
//! there is no threshold that tells them apart, and the file says so beside the case. A case with no
//! randomness (a reseed moves nothing) keeps the suite's thresholds.
//!
//! The file, `thresholds.toml` beside the expected images, is read by every check: a measured
//! threshold replaces the suite's defaults, and a threshold a case sets in the suite file itself
//! replaces both.

use std::collections::BTreeMap;
use std::path::Path;

use anyhow::{Context, Result};
use serde::{Deserialize, Serialize};

/// Other seeds each case renders with.
pub const RESEED_COUNT: u64 = 2;
/// The smallest machine spread a threshold is built on (per metric; module docs).
pub const SPREAD_FLOOR: f64 = 1e-5;
/// A reseed must move the image this many times more than any machine did for a threshold to
/// separate the two with margin both ways (√ of it each way).
pub const MIN_SEPARATION: f64 = 100.0;

/// `thresholds.toml`.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct ThresholdFile {
    /// Case name → what was measured and the thresholds derived.
    #[serde(default)]
    pub cases: BTreeMap<String, Measured>,
}

/// One case's measurements and its thresholds.
#[derive(Clone, Debug, Default, Serialize, Deserialize, PartialEq)]
pub struct Measured {
    /// Derived thresholds (None: a reseed moved nothing; the suite's apply).
    pub max_rmse: Option<f64>,
    pub max_flip: Option<f64>,
    /// The smallest RMSE and FLIP that another seed moved the image by.
    pub reseed_rmse: f64,
    pub reseed_flip: f64,
    /// Machine (`driver on cpu`) → [RMSE, FLIP] of its render against the expected image.
    pub spread: BTreeMap<String, [f64; 2]>,
    /// Why a threshold cannot separate, where it cannot.
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub note: String,
}

/// The threshold between `spread` (the largest a machine moved the image) and `reseed` (module docs).
pub fn derive(spread: f64, reseed: f64) -> Option<f64> {
    (reseed > 0.0).then(|| (spread.max(SPREAD_FLOOR) * reseed).sqrt())
}

impl Measured {
    /// Records `machine`'s spread and this run's reseed measurement (the smaller reseed of this run
    /// and the file's, where the file has one), then derives the thresholds.
    pub fn update(&mut self, machine: &str, spread: [f64; 2], reseed: [f64; 2]) {
        let first = self.spread.is_empty();
        self.spread.insert(machine.to_string(), spread);
        if first {
            (self.reseed_rmse, self.reseed_flip) = (reseed[0], reseed[1]);
        } else {
            self.reseed_rmse = self.reseed_rmse.min(reseed[0]);
            self.reseed_flip = self.reseed_flip.min(reseed[1]);
        }
        let worst = |i: usize| self.spread.values().map(|s| s[i]).fold(0.0, f64::max);
        self.max_rmse = derive(worst(0), self.reseed_rmse);
        self.max_flip = derive(worst(1), self.reseed_flip);
        let mut notes = Vec::new();
        if self.reseed_rmse == 0.0 && self.reseed_flip == 0.0 {
            notes.push(
                "another seed renders the same image (nothing random): the suite's thresholds apply".into(),
            );
        }
        for (what, spread, reseed) in
            [("RMSE", worst(0), self.reseed_rmse), ("FLIP", worst(1), self.reseed_flip)]
        {
            if reseed == 0.0 {
                continue;
            } else if reseed < MIN_SEPARATION * spread.max(SPREAD_FLOOR) {
                notes.push(format!(
                    "{what}: a reseed ({reseed:.2e}) is within {MIN_SEPARATION}× of the machine spread \
                     ({:.2e}): no threshold tells them apart with margin",
                    spread.max(SPREAD_FLOOR)
                ));
            }
        }
        self.note = notes.join("; ");
    }
}

impl ThresholdFile {
    pub fn path(dir: &Path) -> std::path::PathBuf {
        dir.join("thresholds.toml")
    }

    /// The file in `dir`, or an empty one where there is none.
    pub fn load(dir: &Path) -> Result<ThresholdFile> {
        let path = Self::path(dir);
        match std::fs::read_to_string(&path) {
            Ok(t) => toml::from_str(&t).with_context(|| format!("parsing {}", path.display())),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(ThresholdFile::default()),
            Err(e) => Err(e).with_context(|| format!("reading {}", path.display())),
        }
    }

    pub fn save(&self, dir: &Path) -> Result<()> {
        let path = Self::path(dir);
        let text = format!(
            "# Tolerance thresholds measured per case (`shutter check --measure-thresholds`, once per\n\
             # driver and CPU; runs accumulate): each is the geometric mean of the largest spread a\n\
             # machine showed against the expected image (at least {SPREAD_FLOOR:e}) and the smallest change\n\
             # that {RESEED_COUNT} other seeds made (docs/CI.md, \"Thresholds\").\n{}",
            toml::to_string(self)?
        );
        std::fs::write(&path, text).with_context(|| format!("writing {}", path.display()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_threshold_lies_between_the_spread_and_the_reseed() {
        // Equal margins both ways on a log scale.
        let t = derive(1e-4, 1e-2).unwrap();
        assert!((t / 1e-4 - 1e-2 / t).abs() < 1e-9 && (t - 1e-3).abs() < 1e-12);
        // Spreads below the floor (the exact tier's zero) are raised to it.
        assert_eq!(derive(0.0, 1e-1), derive(SPREAD_FLOOR, 1e-1));
        // A deterministic case has nothing to derive from.
        assert_eq!(derive(1e-4, 0.0), None);
    }

    #[test]
    fn machines_accumulate_and_the_worst_decides() {
        let mut m = Measured::default();
        m.update("a", [0.0, 0.0], [3e-2, 5e-2]);
        let only_a = m.max_rmse.unwrap();
        assert!(m.note.is_empty(), "{}", m.note);
        m.update("b", [1e-4, 1e-4], [4e-2, 4e-2]);
        assert!(m.max_rmse.unwrap() > only_a, "a larger spread raises the threshold");
        assert_eq!((m.reseed_rmse, m.reseed_flip), (3e-2, 4e-2), "the smaller reseed of both runs");
        assert_eq!(m.spread.len(), 2);
        // Re-measuring a machine replaces its spread, it does not add a second.
        m.update("b", [0.0, 0.0], [4e-2, 4e-2]);
        assert_eq!(m.max_rmse, Some(only_a));
        // A reseed close to the spread: named, not hidden.
        m.update("c", [1e-3, 0.0], [3e-2, 4e-2]);
        assert!(m.note.contains("RMSE") && !m.note.contains("FLIP"), "{}", m.note);
        let t = m.max_rmse.unwrap();
        assert!(t > 1e-3 && t < 3e-2);
    }
}
