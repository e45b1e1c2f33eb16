//! The one place techniques are registered. A new technique is one file under `techniques/` (plus one
//! shader folder) exposing a `pub const INFO: `[`TechniqueInfo`], added to [`TECHNIQUES`] here with a
//! constant on [`Technique`] — nothing else in the engine or the CLI names it.

use super::{accumulation, auto, interleaved, pinhole, stochastic, TechniqueInfo};

/// A way of estimating the pixel integral on the GPU: a handle to a registry entry.
#[derive(Clone, Copy)]
pub struct Technique(&'static TechniqueInfo);

impl Technique {
    pub const AUTO: Technique = Technique(&auto::INFO);
    pub const PINHOLE: Technique = Technique(&pinhole::INFO);
    pub const ACCUMULATION: Technique = Technique(&accumulation::INFO);
    pub const STOCHASTIC: Technique = Technique(&stochastic::INFO);
    pub const INTERLEAVED: Technique = Technique(&interleaved::INFO);

    pub fn name(&self) -> &'static str {
        self.0.name
    }
    pub fn summary(&self) -> &'static str {
        self.0.summary
    }
    pub fn info(&self) -> &'static TechniqueInfo {
        self.0
    }
}

/// Every registered technique, the default (`auto`) first.
pub const TECHNIQUES: &[Technique] = &[
    Technique::AUTO,
    Technique::PINHOLE,
    Technique::ACCUMULATION,
    Technique::STOCHASTIC,
    Technique::INTERLEAVED,
];

impl PartialEq for Technique {
    fn eq(&self, other: &Self) -> bool {
        self.0.name == other.0.name
    }
}
impl Eq for Technique {}

impl std::fmt::Debug for Technique {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Technique({})", self.0.name)
    }
}

impl std::fmt::Display for Technique {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.0.name)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_are_unique_and_parse_back() {
        for (i, t) in TECHNIQUES.iter().enumerate() {
            assert_eq!(t.name().parse::<Technique>().unwrap(), *t);
            assert!(TECHNIQUES[i + 1..].iter().all(|u| u.name() != t.name()), "{} twice", t.name());
            assert!(!t.summary().is_empty());
        }
        let e = "nope".parse::<Technique>().unwrap_err().to_string();
        assert!(e.contains("auto, pinhole, accumulation, stochastic"), "{e}");
    }
}
