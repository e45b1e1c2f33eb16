//! `shutter compare`: one image against a reference, with thresholds a script can gate on.

use std::path::PathBuf;

use anyhow::Result;
use clap::Args;
use serde::Serialize;

use shutter::image_io::load_image;
use shutter::metrics::{compare, write_flip_diff_png};

/// Compare two images: RMSE, PSNR and mean FLIP of B against reference A. With `--max-flip` or
/// `--max-rmse` the exit code says whether B is within them: 0 within, 1 beyond (a regression),
/// 2 not compared (an image that cannot be read, sizes that differ).
#[derive(Args)]
pub struct CompareArgs {
    /// The reference image (.exr or .png).
    pub a: PathBuf,
    /// The image compared with it.
    pub b: PathBuf,
    /// Write the FLIP error map (magma colour map) as a PNG.
    #[arg(long)]
    pub diff: Option<PathBuf>,
    /// Largest mean FLIP that passes.
    #[arg(long)]
    pub max_flip: Option<f64>,
    /// Largest RMSE that passes.
    #[arg(long)]
    pub max_rmse: Option<f64>,
    /// Print one JSON object instead of the text lines.
    #[arg(long)]
    pub json: bool,
}

/// What `--json` prints.
#[derive(Serialize)]
struct Verdict {
    reference: String,
    test: String,
    width: u32,
    height: u32,
    rmse: f64,
    /// Null where the images are equal (infinite PSNR).
    psnr: Option<f64>,
    flip: f64,
    max_flip: Option<f64>,
    max_rmse: Option<f64>,
    /// True where every threshold given holds (and where none is given).
    pass: bool,
    /// Each threshold exceeded, as `metric value > limit`.
    failures: Vec<String>,
    diff: Option<String>,
}

/// The exit code a comparison that could not be made ends with (an unreadable image, a size
/// mismatch): distinct from 1, a regression.
pub const EXIT_NOT_COMPARED: i32 = 2;

/// An error that ends `compare` with [`EXIT_NOT_COMPARED`].
#[derive(Debug)]
pub struct NotCompared(pub String);

impl std::fmt::Display for NotCompared {
    fn fmt(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for NotCompared {}

pub fn run(args: CompareArgs) -> Result<()> {
    let CompareArgs { a, b, diff, max_flip, max_rmse, json } = args;
    for (name, limit) in [("--max-flip", max_flip), ("--max-rmse", max_rmse)] {
        if limit.is_some_and(|l| !(l.is_finite() && l >= 0.0)) {
            return Err(NotCompared(format!("{name} must be a finite number ≥ 0")).into());
        }
    }
    // load_image's errors name the file.
    let load = |p: &PathBuf| load_image(p).map_err(|e| NotCompared(e.to_string()));
    let (ia, ib) = (load(&a)?, load(&b)?);
    let m = compare(&ia, &ib)
        .map_err(|e| NotCompared(format!("{} against {}: {e}", b.display(), a.display())))?;
    let mut failures = Vec::new();
    if let Some(l) = max_flip.filter(|&l| m.flip > l) {
        failures.push(format!("FLIP {:.6} > {l}", m.flip));
    }
    if let Some(l) = max_rmse.filter(|&l| m.rmse > l) {
        failures.push(format!("RMSE {:.6} > {l}", m.rmse));
    }
    if let Some(d) = &diff {
        write_flip_diff_png(d, &ia, &ib)?;
    }
    if json {
        let verdict = Verdict {
            reference: a.display().to_string(),
            test: b.display().to_string(),
            width: ia.width,
            height: ia.height,
            rmse: m.rmse,
            psnr: m.psnr.is_finite().then_some(m.psnr),
            flip: m.flip,
            max_flip,
            max_rmse,
            pass: failures.is_empty(),
            failures: failures.clone(),
            diff: diff.as_ref().map(|d| d.display().to_string()),
        };
        outln!("{}", serde_json::to_string_pretty(&verdict)?);
    } else {
        outln!("RMSE {:.6}", m.rmse);
        outln!("PSNR {:.3}", m.psnr);
        outln!("FLIP {:.6}", m.flip);
        if let Some(d) = &diff {
            outln!("wrote {}", d.display());
        }
        if max_flip.is_some() || max_rmse.is_some() {
            outln!("{}", if failures.is_empty() { "pass" } else { "FAIL" });
        }
    }
    if !failures.is_empty() {
        anyhow::bail!("{} beyond its threshold: {}", b.display(), failures.join(", "));
    }
    Ok(())
}
