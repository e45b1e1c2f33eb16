//! `shutter quality`.

use anyhow::{Context, Result};
use clap::Args;

use crate::*;

/// What accuracy costs in time: sweep series of techniques × sample counts against the cached CPU
/// reference; CSV (resumable), log-log plot of FLIP vs GPU ms with the Pareto front (PNG, SVG),
/// markdown table with the ms ratio at equal FLIP.
#[derive(Args)]
pub struct QualityArgs {
    #[arg(default_value = "default")]
    pub scene: String,
    /// A series `technique[:key=value...]@S1,S2,...` (the keys `shutter techniques` lists); repeat
    /// for more.
    #[arg(short = 's', long = "series", default_values_t = [
        "accumulation@4,16,64,256".to_string(),
        "stochastic@4,16,64".to_string(),
        "stochastic:shading=per-sample@4,16,64".to_string(),
        "auto@4,16,64".to_string(),
    ])]
    pub series: Vec<String>,
    /// Reference rays per pixel.
    #[arg(long, default_value_t = 1024)]
    pub reference_spp: u32,
    #[arg(long, default_value_t = 3)]
    pub frames: usize,
    #[arg(long, default_value_t = 1)]
    pub warmup: usize,
    /// Image size WxH.
    #[arg(long, value_parser = parse_size, default_value = "160x90")]
    pub size: (u32, u32),
    #[arg(long)]
    pub seed: Option<u64>,
    /// Where cached references live.
    #[arg(long, default_value = "out/cache")]
    pub cache: PathBuf,
    /// Output stem: <out>.csv, .png, .svg, .md. Default: out/quality-<scene>.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Also save every point's image as <out>-<series>-S<n>.png with its FLIP error map against the
    /// reference as <out>-<series>-S<n>-flip.png, and the reference as <out>-reference.png.
    #[arg(long)]
    pub images: bool,
    /// Two series `A,B` whose ms are compared at equal FLIP (A ÷ B); repeat for more pairs.
    /// Default: `accumulation` against every other series, when there is an `accumulation` series.
    #[arg(long)]
    pub compare: Vec<String>,
}

pub fn run(args: QualityArgs) -> Result<()> {
    let QualityArgs { scene, series, reference_spp, frames, warmup, size, seed, cache, out, images, compare } =
        args;
    let sc = load_scene(&scene)?;
    let mut defaults = RenderSettings::from_scene(&sc);
    (defaults.width, defaults.height) = size;
    defaults.seed = seed.unwrap_or(defaults.seed);
    let series = series.iter().map(|s| quality::Series::parse(s, &defaults)).collect::<Result<Vec<_>>>()?;
    let out = match out {
        Some(o) => o,
        None => {
            std::fs::create_dir_all("out").context("creating out/")?;
            PathBuf::from(format!("out/quality-{}", sc.name))
        }
    };
    let compare = if compare.is_empty() {
        let names: Vec<&str> = series.iter().map(|s| s.name.as_str()).collect();
        match names.iter().find(|n| **n == "accumulation") {
            Some(acc) => {
                names.iter().filter(|n| *n != acc).map(|n| (acc.to_string(), n.to_string())).collect()
            }
            None => vec![],
        }
    } else {
        compare
            .iter()
            .map(|c| {
                c.split_once(',')
                    .map(|(a, b)| (a.trim().to_string(), b.trim().to_string()))
                    .with_context(|| format!("--compare `{c}` is not A,B"))
            })
            .collect::<Result<Vec<_>>>()?
    };
    for name in compare.iter().flat_map(|(a, b)| [a, b]) {
        if !series.iter().any(|s| &s.name == name) {
            let names: Vec<String> = series.iter().map(|s| format!("`{}`", s.name)).collect();
            anyhow::bail!(
                "--compare: no series `{name}`; the series are {} (a series' name is its -s without @…)",
                names.join(", ")
            );
        }
    }
    let args = quality::QualityArgs {
        series,
        reference_spp,
        frames: frames.max(1),
        warmup,
        width: size.0,
        height: size.1,
        seed: defaults.seed,
        cache,
        out: out.clone(),
        images,
        compare,
    };
    let mut renderer = Renderer::new(create_device()?)?;
    let prov = provenance::Provenance::of(&renderer.device().caps);
    let points = quality::run(&mut renderer, &sc, &args)?;
    let md = quality::markdown(&sc, &args, &points, &prov);
    outln!("{md}");
    let md_path = out.with_extension("md");
    write_file_atomically(&md_path, md.as_bytes())?;
    quality::plot(&sc, &args, &points)?;
    errln!("wrote {} and {}", md_path.display(), out.with_extension("csv").display());
    Ok(())
}
