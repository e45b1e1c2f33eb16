//! The hard-case matrix: every technique and shading rate against the CPU reference on scenes built to
//! break numerics (`scenes/hard/*.toml`), with a convergence check.
//!
//! A technique that claims to estimate the pixel integral without bias must have an error that falls
//! with S the way the reference's own does; an error that stops falling is a bias. For each scene the
//! matrix renders a converged *truth* (the reference at [`MatrixSettings::truth_spp`]), the reference
//! itself at the two sample counts S₁ < S₂ with the techniques' seed (its own noise, the yardstick), and
//! every column at S₁ and S₂; errors are RMSE against the truth (display-clamped, [`crate::metrics`]).
//!
//! * An **exact** column (`accumulation`, `stochastic` per-sample, `auto` where it blurs) passes when its error at S₂ is within [`EXACT_FACTOR`] of the reference's at S₂
//!   plus [`EXACT_SLACK`] (and the truth's own noise): a floor above that is a bias.
//! * An **approximation** (per-pixel, texture-space and decoupled shading, and `pinhole`'s MSAA — with
//!   `auto` on a scene with nothing to blur, which is `pinhole` — each shading fewer points than it has
//!   samples) has a floor by design. Its floor — the part of the error at S₂ that the
//!   reference's noise does not explain, √(e₂² − r₂²) — is measured and must stay under the rate's
//!   documented limit ([`Column::floor_limit`], docs/HARD_CASES.md), so a regression still fails.
//! * A floor in an exact column that an open issue owns is listed in [`KNOWN_BIASES`] with its
//!   cause and a bound: the table footnotes it, and the cell fails if it grows past the bound.
//! * A column that refuses a scene says why (a documented refusal is a result, not a failure);
//!   `pinhole` is not applicable where the scene has blur.
//!
//! Non-finite pixels fail every column. `shutter hard-cases` writes the table to docs/HARD_CASES.md;
//! `tests/tests/hard_cases.rs` runs the same matrix small in CI.

use std::path::Path;

use crate::error::{Error, Result};
use crate::image::LinearImage;
use crate::metrics::compare;
use crate::mirror::decoupled::GridKind;
use crate::plan::Plan;
use crate::reference::{render_reference, render_reference_cached, ReferenceSettings};
use crate::scene::file::parse_scene;
use crate::scene::Scene;
use crate::techniques::stochastic::{Coverage, MaskRate};
use crate::techniques::{RenderSettings, Renderer, ShadingRate, StochasticOptions, Technique};

/// One named hard scene: its file under `scenes/hard/`, embedded.
#[derive(Clone, Copy, Debug)]
pub struct HardCase {
    pub name: &'static str,
    pub source: &'static str,
}

macro_rules! hard_cases {
    ($($name:literal),* $(,)?) => {
        /// Every hard scene, in the order of docs/HARD_CASES.md.
        pub const CASES: &[HardCase] = &[
            $(HardCase { name: $name, source: include_str!(concat!("../../scenes/hard/", $name, ".toml")) }),*
        ];
    };
}

hard_cases!(
    "far-from-origin",
    "near-far-extreme",
    "telephoto",
    "wide-179",
    "focus-inside-near",
    "through-lens",
    "camera-turn-180",
    "camera-roll-180",
    "scale-through-zero",
    "tiny-shutter",
    "multi-turn",
    "stacked-alpha",
    "grazing-light",
    "light-on-surface",
    "huge-and-tiny",
    "huge-plane",
    "slivers",
    "hard-shadow",
);

impl HardCase {
    /// The scene, parsed as `shutter render scenes/hard/NAME.toml` would (built-in meshes only).
    pub fn scene(&self) -> Result<Scene> {
        parse_scene(self.source, Path::new("."), self.name)
    }

    /// What the case tests: the file's first comment paragraph, without its `Hard case:` prefix.
    pub fn what(&self) -> String {
        let text: Vec<&str> = self
            .source
            .lines()
            .take_while(|l| l.starts_with('#'))
            .map(|l| l.trim_start_matches('#').trim())
            .collect();
        text.join(" ").trim_start_matches("Hard case:").trim().to_string()
    }

    /// The case called `name`.
    pub fn named(name: &str) -> Result<&'static HardCase> {
        CASES.iter().find(|c| c.name == name).ok_or_else(|| {
            let names: Vec<&str> = CASES.iter().map(|c| c.name).collect();
            Error::Unsupported(format!("unknown hard case `{name}`; available: {}", names.join(", ")))
        })
    }
}

/// A technique (and shading rate) of the matrix.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Column {
    Pinhole,
    Accumulation,
    Stochastic(ShadingRate),
    /// `stochastic` on the mask coverage path (per-sample shading): per sample, exact; per fragment,
    /// one depth per pixel and triangle (`techniques::stochastic::Coverage::Mask`).
    StochasticMask(MaskRate),
    Auto,
}

/// Every column, in table order.
pub const COLUMNS: &[Column] = &[
    Column::Pinhole,
    Column::Accumulation,
    Column::Stochastic(ShadingRate::PerSample),
    Column::Stochastic(ShadingRate::PerPixel),
    Column::Stochastic(ShadingRate::TextureSpace),
    Column::Stochastic(ShadingRate::Decoupled { grid: GridKind::Pixel, deferred: true }),
    Column::StochasticMask(MaskRate::Sample),
    Column::StochasticMask(MaskRate::Fragment),
    Column::Auto,
];

/// The floor `pinhole` may show (and `auto`, which renders a still scene with it): its MSAA shades
/// once per pixel, at the centre (measured 0.054 on `grazing-light`'s hard spot rim at 48×27).
pub const PINHOLE_FLOOR_LIMIT: f64 = 0.07;

/// The floor the mask path's per-fragment mode may show: measured on the matrix (docs/HARD_CASES.md,
/// docs/HARDWARE.md), with margin.
pub const MASK_PER_FRAGMENT_FLOOR_LIMIT: f64 = 0.10;

/// An exact column passes at S₂ within this factor of the reference's own error …
pub const EXACT_FACTOR: f64 = 1.5;
/// … plus this much RMSE (rasterization's and the reference's tie rules, mip filtering of textures).
pub const EXACT_SLACK: f64 = 0.004;

impl Column {
    pub fn name(&self) -> String {
        match self {
            Column::Pinhole => "pinhole".into(),
            Column::Accumulation => "accumulation".into(),
            Column::Stochastic(rate) => format!("stochastic {}", rate.name()),
            Column::StochasticMask(rate) => format!("stochastic {}", Coverage::Mask(*rate).name()),
            Column::Auto => "auto".into(),
        }
    }

    pub fn technique(&self) -> Technique {
        match self {
            Column::Pinhole => Technique::PINHOLE,
            Column::Accumulation => Technique::ACCUMULATION,
            Column::Stochastic(_) | Column::StochasticMask(_) => Technique::STOCHASTIC,
            Column::Auto => Technique::AUTO,
        }
    }

    /// The render settings of this column at S = `spp`.
    pub fn settings(&self, width: u32, height: u32, spp: u32, seed: u64) -> RenderSettings {
        let settings = RenderSettings::new(width, height, spp, seed);
        match self {
            Column::Stochastic(shading) => {
                settings.with_stochastic(StochasticOptions { shading: *shading, ..Default::default() })
            }
            Column::StochasticMask(rate) => settings
                .with_stochastic(StochasticOptions { coverage: Coverage::Mask(*rate), ..Default::default() }),
            _ => settings,
        }
    }

    /// `None` for a column that claims no bias; else the largest floor (RMSE) its approximation may
    /// show on a hard case before the matrix calls it a regression. Measured on the matrix (docs/
    /// HARD_CASES.md), with margin; each is the rate's own floor, not a tolerance of the exact ones.
    pub fn floor_limit(&self) -> Option<f64> {
        match self {
            // 4× MSAA shaded once per pixel (the classic rasterizer; `auto` on a still scene is it).
            Column::Pinhole => Some(PINHOLE_FLOOR_LIMIT),
            Column::Stochastic(ShadingRate::PerPixel) => Some(0.10),
            Column::Stochastic(ShadingRate::TextureSpace | ShadingRate::TextureSpacePerPixel) => Some(0.08),
            Column::Stochastic(ShadingRate::Decoupled { .. }) => Some(0.08),
            // One depth per pixel and triangle: where two surfaces cross within a pixel's blur.
            Column::StochasticMask(MaskRate::Fragment) => Some(MASK_PER_FRAGMENT_FLOOR_LIMIT),
            _ => None,
        }
    }
}

/// A bias the matrix knows of — in a column that claims none, or past an approximation's limit —
/// owned by an open issue: the cell passes while its floor stays under `max_floor` and the table names
/// the cause. Listed as measured, not
/// hoped: a fix that removes it must remove its line too (the cell then reads `exact`).
#[derive(Clone, Copy, Debug)]
pub struct KnownBias {
    pub case: &'static str,
    pub column: Column,
    pub max_floor: f64,
    pub why: &'static str,
}

/// Every known bias (docs/HARD_CASES.md "Known biases").
pub const KNOWN_BIASES: &[KnownBias] = &[KnownBias {
    case: "wide-179",
    column: Column::Accumulation,
    // Was 0.045 (floor 0.034) before issue 33; `tiny-shutter`'s entry (0.057) is gone.
    max_floor: 0.025,
    why: "each pass filters textures over 1/√P of the pixel (issue 33), so the bias falls with P, \
          but on the 179° lens' grazing checkered ground a quarter-pixel filter at S = 16 still \
          blurs, and the floor estimate from S = 4 and 16 reads it as a floor (0.0187 on lavapipe \
          25.0, was 0.034)",
}];

impl KnownBias {
    /// The known bias of `column` on `case`, if any.
    pub fn of(case: &str, column: Column) -> Option<&'static KnownBias> {
        KNOWN_BIASES.iter().find(|k| k.case == case && k.column == column)
    }
}

/// Sizes and sample counts of one run of the matrix.
#[derive(Clone, Copy, Debug)]
pub struct MatrixSettings {
    pub width: u32,
    pub height: u32,
    /// S₁ < S₂.
    pub spp: [u32; 2],
    /// Samples per pixel of the truth.
    pub truth_spp: u32,
    /// Seed of the techniques and of the reference's own runs at S₁, S₂ (the truth takes another).
    pub seed: u64,
    /// Where to write each failing cell's picture (`<case>-<column>-S₂.png` beside `<case>-truth.png`
    /// and the FLIP map `<case>-<column>-diff.png`), if anywhere.
    pub pictures: Option<&'static str>,
    /// Where to keep the CPU references (the truth and the reference's own runs at S₁, S₂), if
    /// anywhere: they depend on the scene, size, samples and seed, never on the GPU driver, so a
    /// second driver's matrix (CI runs two) takes them from here instead of tracing them again.
    pub reference_cache: Option<&'static str>,
}

impl Default for MatrixSettings {
    fn default() -> Self {
        MatrixSettings {
            width: 96,
            height: 54,
            spp: [4, 16],
            truth_spp: 1024,
            seed: 1,
            pictures: None,
            reference_cache: None,
        }
    }
}

/// What a column did with one scene.
#[derive(Clone, Debug)]
pub enum Outcome {
    /// The column does not apply (pinhole on a scene with blur).
    NotApplicable,
    /// The technique refused the scene, with its reason.
    Refused(String),
    Measured(Measurement),
}

/// One column's errors on one scene.
#[derive(Clone, Debug)]
pub struct Measurement {
    /// RMSE against the truth at S₁ and S₂.
    pub error: [f64; 2],
    /// GPU ms of the render at S₂.
    pub gpu_ms: f64,
    /// The part of the error at S₂ the reference's noise does not explain, √max(0, e₂² − r₂²).
    pub floor: f64,
    /// Non-finite colour values in either render.
    pub non_finite: usize,
    pub verdict: Verdict,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Verdict {
    /// An exact column whose error falls with S like the reference's.
    Converges,
    /// An approximation whose floor is within its documented limit.
    FloorWithinLimit,
    /// A floor listed in [`KNOWN_BIASES`] (an exact column's, or past an approximation's limit), within it.
    KnownBias,
    /// An exact column with a floor, or an approximation past its limit: fails.
    Biased,
    /// Inf or NaN pixels: fails.
    NonFinite,
}

impl Verdict {
    pub fn passes(&self) -> bool {
        matches!(self, Verdict::Converges | Verdict::FloorWithinLimit | Verdict::KnownBias)
    }
}

/// One scene's row: the reference's own errors and every column's outcome.
#[derive(Clone, Debug)]
pub struct Row {
    pub case: &'static HardCase,
    /// The reference's RMSE against the truth at S₁ and S₂ (same seed as the techniques).
    pub reference_error: [f64; 2],
    /// The truth's own expected error, estimated from the reference's at S₂ (∝ 1/√S).
    pub truth_noise: f64,
    pub cells: Vec<(Column, Outcome)>,
}

impl Row {
    /// Whether every cell passes (refusals and n/a included).
    pub fn passes(&self) -> bool {
        self.failures().is_empty()
    }

    /// The columns that fail, with a line each.
    pub fn failures(&self) -> Vec<String> {
        self.cells
            .iter()
            .filter_map(|(column, outcome)| match outcome {
                Outcome::Measured(m) if !m.verdict.passes() => Some(format!(
                    "{} / {}: {:?}: RMSE {:.4} → {:.4} (reference {:.4} → {:.4}), floor {:.4}, {} non-finite",
                    self.case.name,
                    column.name(),
                    m.verdict,
                    m.error[0],
                    m.error[1],
                    self.reference_error[0],
                    self.reference_error[1],
                    m.floor,
                    m.non_finite
                )),
                _ => None,
            })
            .collect()
    }
}

fn non_finite(image: &LinearImage) -> usize {
    image.pixels.iter().map(|p| p[..3].iter().filter(|v| !v.is_finite()).count()).sum()
}

/// The CPU reference at `spp` and `seed`, from [`MatrixSettings::reference_cache`] where it is there.
fn reference(scene: &Scene, m: &MatrixSettings, spp: u32, seed: u64) -> Result<LinearImage> {
    let settings = ReferenceSettings {
        width: m.width,
        height: m.height,
        spp,
        seed,
        progress: false,
        shading: Default::default(),
    };
    match m.reference_cache {
        Some(dir) => render_reference_cached(Path::new(dir), scene, &settings).map(|(image, _)| image),
        None => render_reference(scene, &settings),
    }
}

/// Whether a scene has anything to blur at this size (else `pinhole` applies, and `auto` renders it).
pub fn is_sharp(scene: &Scene, width: u32, height: u32) -> bool {
    !Plan::new(scene, width, height).needs_stochastic()
}

/// Runs one scene's row: the truth, the reference's own errors, every column in `columns`.
pub fn run_row(
    renderer: &mut Renderer,
    case: &'static HardCase,
    columns: &[Column],
    m: &MatrixSettings,
) -> Result<Row> {
    let scene = case.scene()?;
    // The truth takes a seed of its own: the same samples as the runs it judges would hide their noise.
    let truth = reference(&scene, m, m.truth_spp, m.seed.wrapping_add(1_000_003))?;
    let mut reference_error = [0.0; 2];
    for (i, &spp) in m.spp.iter().enumerate() {
        reference_error[i] = compare(&truth, &reference(&scene, m, spp, m.seed)?)?.rmse;
    }
    let truth_noise = reference_error[1] * (m.spp[1] as f64 / m.truth_spp as f64).sqrt();
    let sharp = is_sharp(&scene, m.width, m.height);
    let mut cells = Vec::new();
    for &column in columns {
        let outcome = if column == Column::Pinhole && !sharp {
            Outcome::NotApplicable
        } else {
            measure(renderer, case, &scene, &truth, column, m, reference_error, truth_noise, sharp)?
        };
        cells.push((column, outcome));
    }
    Ok(Row { case, reference_error, truth_noise, cells })
}

#[allow(clippy::too_many_arguments)]
fn measure(
    renderer: &mut Renderer,
    case: &HardCase,
    scene: &Scene,
    truth: &LinearImage,
    column: Column,
    m: &MatrixSettings,
    reference_error: [f64; 2],
    truth_noise: f64,
    sharp: bool,
) -> Result<Outcome> {
    let mut error = [0.0; 2];
    let mut non_finite_values = 0;
    let mut gpu_ms = 0.0;
    let mut last = None;
    for (i, &spp) in m.spp.iter().enumerate() {
        let settings = column.settings(m.width, m.height, spp, m.seed);
        let out = match renderer.render(scene, column.technique(), &settings) {
            Ok(out) => out,
            Err(Error::Unsupported(why)) => return Ok(Outcome::Refused(why)),
            Err(e @ Error::MissingFeature { .. }) => return Ok(Outcome::Refused(e.to_string())),
            Err(e) => return Err(e),
        };
        non_finite_values += non_finite(&out.image);
        error[i] = compare(truth, &out.image)?.rmse;
        gpu_ms = out.timings.total_ms();
        last = Some(out.image);
    }
    // Pinhole (and auto on a sharp scene, which is pinhole) takes 4 MSAA samples whatever S: it is
    // judged at S₁ = its own count against the reference's error there.
    let fixed_samples = column == Column::Pinhole || (column == Column::Auto && sharp);
    let (e, r) = if fixed_samples { (error[0], reference_error[0]) } else { (error[1], reference_error[1]) };
    let floor = (e * e - r * r).max(0.0).sqrt();
    let verdict = if non_finite_values > 0 {
        Verdict::NonFinite
    } else {
        let converges = e <= EXACT_FACTOR * r + EXACT_SLACK + truth_noise;
        let limit = if fixed_samples { Some(PINHOLE_FLOOR_LIMIT) } else { column.floor_limit() };
        match (limit, KnownBias::of(case.name, column)) {
            (None, _) if converges => Verdict::Converges,
            (Some(limit), _) if floor <= limit => Verdict::FloorWithinLimit,
            (_, Some(known)) if floor <= known.max_floor => Verdict::KnownBias,
            _ => Verdict::Biased,
        }
    };
    if let (Some(dir), Some(image), false) = (m.pictures, &last, verdict.passes()) {
        let dir = Path::new(dir);
        std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
        let stem = format!("{}-{}", case.name, column.name().replace(' ', "-"));
        crate::image_io::save_image(dir.join(format!("{}-truth.png", case.name)), truth)?;
        crate::image_io::save_image(dir.join(format!("{stem}-s{}.png", m.spp[1])), image)?;
        crate::metrics::write_flip_diff_png(dir.join(format!("{stem}-diff.png")), truth, image)?;
    }
    Ok(Outcome::Measured(Measurement { error, gpu_ms, floor, non_finite: non_finite_values, verdict }))
}

/// The matrix as docs/HARD_CASES.md's tables: one row per scene, a cell per column with the error at
/// S₁ and S₂ and the verdict; then what each case tests.
pub fn markdown(rows: &[Row], m: &MatrixSettings, columns: &[Column], device: &str) -> String {
    use std::fmt::Write as _;
    let mut s = String::new();
    let [s1, s2] = m.spp;
    let _ = writeln!(
        s,
        "{}×{}, S = {s1} and {s2}, truth = the reference at {} spp (another seed); device: {device}. Each \
         cell: RMSE against the truth at S = {s1} → {s2}, then the verdict — `exact` (an unbiased column \
         whose error falls like the reference's), `floor X` (an approximation's floor √(e₂² − r₂²), within \
         its limit), `known bias X` (a floor an open issue owns, footnoted), **`BIAS`** or **`NON-FINITE`** \
         (fails), `refused` (the technique refuses the scene, footnoted), `n/a` (pinhole on a scene with \
         blur).\n",
        m.width, m.height, m.truth_spp
    );
    let _ = write!(s, "| scene | reference |");
    for c in columns {
        let _ = write!(s, " {} |", c.name());
    }
    let _ = write!(s, "\n|---|---|");
    for _ in columns {
        let _ = write!(s, "---|");
    }
    s.push('\n');
    let mut notes: Vec<String> = Vec::new();
    for row in rows {
        let _ = write!(
            s,
            "| `{}` | {:.4} → {:.4} |",
            row.case.name, row.reference_error[0], row.reference_error[1]
        );
        for (column, outcome) in &row.cells {
            let cell = match outcome {
                Outcome::NotApplicable => "n/a".to_string(),
                Outcome::Refused(why) => {
                    let line = format!("{} on `{}`: {why}", column.name(), row.case.name);
                    let n = match notes.iter().position(|n| *n == line) {
                        Some(i) => i + 1,
                        None => {
                            notes.push(line);
                            notes.len()
                        }
                    };
                    format!("refused [{n}]")
                }
                Outcome::Measured(me) => {
                    let verdict = match me.verdict {
                        Verdict::Converges => "exact".to_string(),
                        Verdict::FloorWithinLimit => format!("floor {:.4}", me.floor),
                        Verdict::KnownBias => {
                            let why = KnownBias::of(row.case.name, *column).map_or("", |k| k.why);
                            let line = format!("{} on `{}`: {why}", column.name(), row.case.name);
                            notes.push(line);
                            format!("known bias {:.4} [{}]", me.floor, notes.len())
                        }
                        Verdict::Biased => format!("**BIAS {:.4}**", me.floor),
                        Verdict::NonFinite => format!("**NON-FINITE ({})**", me.non_finite),
                    };
                    format!("{:.4} → {:.4} {verdict}", me.error[0], me.error[1])
                }
            };
            let _ = write!(s, " {cell} |");
        }
        s.push('\n');
    }
    if !notes.is_empty() {
        s.push('\n');
        for (i, n) in notes.iter().enumerate() {
            let _ = writeln!(s, "[{}] {n}", i + 1);
        }
    }
    let _ = writeln!(s, "\nGPU ms of each render at S = {s2} (timestamps; the same run):\n");
    let _ = write!(s, "| scene |");
    for c in columns {
        let _ = write!(s, " {} |", c.name());
    }
    let _ = write!(s, "\n|---|");
    for _ in columns {
        let _ = write!(s, "---|");
    }
    s.push('\n');
    for row in rows {
        let _ = write!(s, "| `{}` |", row.case.name);
        for (_, outcome) in &row.cells {
            match outcome {
                Outcome::Measured(me) => {
                    let _ = write!(s, " {:.1} |", me.gpu_ms);
                }
                _ => s.push_str(" – |"),
            }
        }
        s.push('\n');
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_case_parses_and_says_what_it_tests() {
        for case in CASES {
            let scene = case.scene().unwrap_or_else(|e| panic!("{}: {e:#}", case.name));
            assert!(!scene.objects.is_empty(), "{}", case.name);
            assert!(case.what().len() > 20, "{}: no header comment", case.name);
            assert!(!case.what().starts_with("Hard case"), "{}", case.name);
        }
    }

    #[test]
    fn every_file_under_scenes_hard_is_a_case() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/hard");
        let mut files: Vec<String> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().path().file_stem().unwrap().to_string_lossy().into_owned())
            .collect();
        files.sort();
        let mut names: Vec<String> = CASES.iter().map(|c| c.name.to_string()).collect();
        names.sort();
        assert_eq!(files, names);
    }

    #[test]
    fn verdict_rule_separates_noise_from_bias() {
        // A floor is judged on the part of the error the reference's noise does not explain.
        let (e, r) = (0.05f64, 0.03f64);
        assert!(((e * e - r * r).sqrt() - 0.04).abs() < 1e-12);
        assert!(Column::Accumulation.floor_limit().is_none());
        assert!(Column::Stochastic(ShadingRate::PerSample).floor_limit().is_none());
        assert!(Column::Stochastic(ShadingRate::PerPixel).floor_limit().is_some());
    }
}
