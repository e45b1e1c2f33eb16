//! `shutter quality`: what accuracy costs in time, for one scene.
//!
//! Renders the CPU reference once (cached under `--cache` by the reference's version, the scene's content
//! hash, size, spp and seed), then sweeps series of configurations — a technique with its settings over a
//! list of sample counts — recording per point the median GPU ms per frame (after warm-up) and the error
//! against the reference (RMSE, mean FLIP). Each finished point is appended to the CSV at once, so an
//! interrupted sweep resumes from it (points already there for the same scene hash, size and reference are
//! skipped). Outputs: the CSV, a log-log plot of FLIP against ms (one curve per series, the Pareto front over
//! all points marked) as PNG and SVG, a markdown table, and the ratio of milliseconds at equal FLIP between
//! two series (the thesis' claim: stochastic rasterization vs accumulation).

use std::fmt::Write as _;
use std::io::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use plotters::prelude::*;
use shutter::image::LinearImage;
use shutter::image_io::save_image;
use shutter::metrics::compare;
use shutter::reference::{render_reference_cached, ReferenceSettings};
use shutter::scene::Scene;
use shutter::techniques::{RenderSettings, Renderer, Technique};

/// A curve: `technique[:key=value...]@S1,S2,...` (keys as in `shutter bench`).
#[derive(Clone, Debug)]
pub struct Series {
    /// The spec without the sample counts, e.g. `stochastic:shading=per-sample`.
    pub name: String,
    pub technique: Technique,
    pub settings: RenderSettings,
    pub spp: Vec<u32>,
}

impl Series {
    pub fn parse(spec: &str, defaults: &RenderSettings) -> Result<Series> {
        let (name, spp) =
            spec.split_once('@').with_context(|| format!("series `{spec}` has no @S1,S2,..."))?;
        let spp = spp
            .split(',')
            .map(|s| match s.trim().parse::<u32>() {
                Ok(n) if n >= 1 => Ok(n),
                _ => anyhow::bail!("sample count `{s}` in `{spec}`: give whole numbers ≥ 1"),
            })
            .collect::<Result<Vec<_>>>()?;
        let config = crate::bench::Config::parse(name, defaults)?;
        Ok(Series { name: name.to_string(), technique: config.technique, settings: config.settings, spp })
    }
}

pub struct QualityArgs {
    pub series: Vec<Series>,
    pub reference_spp: u32,
    pub frames: usize,
    pub warmup: usize,
    pub width: u32,
    pub height: u32,
    pub seed: u64,
    pub cache: PathBuf,
    /// Output stem: `<out>.csv`, `<out>.png`, `<out>.svg`, `<out>.md`.
    pub out: PathBuf,
    /// Also save each point's image as `<out>-<series>-S<n>.png` and its FLIP map as `…-flip.png`.
    pub images: bool,
    /// Pairs of series whose milliseconds are compared at equal FLIP (first ÷ second).
    pub compare: Vec<(String, String)>,
}

/// One measured point.
#[derive(Clone, Debug)]
pub struct Point {
    pub series: String,
    pub spp: u32,
    pub ms: f64,
    pub rmse: f64,
    pub flip: f64,
    pub passes: u32,
    pub msaa: u32,
}

const CSV_HEADER: &str =
    "scene,scene_hash,width,height,reference_spp,seed,device,series,spp,gpu_ms_median,rmse,flip,passes,msaa";

/// The cached reference, rendering it on a miss ([`render_reference_cached`]).
fn reference(scene: &Scene, a: &QualityArgs) -> Result<LinearImage> {
    let t = std::time::Instant::now();
    let settings = ReferenceSettings {
        width: a.width,
        height: a.height,
        spp: a.reference_spp,
        seed: a.seed,
        progress: true,
        shading: Default::default(),
    };
    let (img, cached) = render_reference_cached(&a.cache, scene, &settings)?;
    if cached {
        errln!("reference: cached in {}", a.cache.display());
    } else {
        errln!(
            "reference: rendering {}x{} at {} spp on the CPU took {:.1} s, cached in {}",
            a.width,
            a.height,
            a.reference_spp,
            t.elapsed().as_secs_f64(),
            a.cache.display()
        );
    }
    Ok(img)
}

/// Points already in the CSV for this scene, size and reference.
fn resume(csv: &Path, key: &str) -> Result<Vec<Point>> {
    let Ok(text) = std::fs::read_to_string(csv) else { return Ok(vec![]) };
    let mut pts = vec![];
    for line in text.lines().skip(1).filter(|l| !l.starts_with('#')) {
        let f: Vec<&str> = split_csv(line);
        if f.len() < 14 || f[..6].join(",") != key {
            continue;
        }
        let num = |i: usize| {
            f[i].parse::<f64>().with_context(|| format!("{}: bad number `{}`", csv.display(), f[i]))
        };
        pts.push(Point {
            series: f[7].to_string(),
            spp: f[8].parse()?,
            ms: num(9)?,
            rmse: num(10)?,
            flip: num(11)?,
            passes: f[12].parse()?,
            msaa: f[13].parse()?,
        });
    }
    Ok(pts)
}

/// Splits one CSV line (fields may be double-quoted, without embedded quotes).
fn split_csv(line: &str) -> Vec<&str> {
    let mut out = vec![];
    let mut rest = line;
    loop {
        if let Some(r) = rest.strip_prefix('"') {
            let end = r.find('"').unwrap_or(r.len());
            out.push(&r[..end]);
            rest = r.get(end + 1..).unwrap_or("");
        } else {
            let end = rest.find(',').unwrap_or(rest.len());
            out.push(&rest[..end]);
            rest = &rest[end..];
        }
        match rest.strip_prefix(',') {
            Some(r) => rest = r,
            None => return out,
        }
    }
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(|a, b| a.total_cmp(b));
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

pub fn run(renderer: &mut Renderer, scene: &Scene, a: &QualityArgs) -> Result<Vec<Point>> {
    if a.series.is_empty() {
        bail!("no series to sweep");
    }
    let device = renderer.device().caps.device_name.clone();
    let key = format!(
        "{},{:016x},{},{},{},{}",
        scene.name,
        scene.content_hash(),
        a.width,
        a.height,
        a.reference_spp,
        a.seed
    );
    if let Some(dir) = a.out.parent() {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    let csv_path = a.out.with_extension("csv");
    // Before the reference and the sweep: every output can be written.
    for ext in ["csv", "md", "png", "svg"] {
        shutter::image_io::check_output_file(a.out.with_extension(ext))?;
    }
    let mut points = resume(&csv_path, &key)?;
    let todo: Vec<(usize, u32)> = a
        .series
        .iter()
        .enumerate()
        .flat_map(|(i, s)| s.spp.iter().map(move |&n| (i, n)))
        .filter(|&(i, n)| !points.iter().any(|p| p.series == a.series[i].name && p.spp == n))
        .collect();
    if !points.is_empty() {
        errln!("resuming {}: {} point(s) done, {} to go", csv_path.display(), points.len(), todo.len());
    }
    let truth = reference(scene, a)?;
    if a.images {
        save_image(format!("{}-reference.png", a.out.display()), &truth)?;
    }
    let new_file = !csv_path.exists();
    let mut csv = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(&csv_path)
        .with_context(|| format!("opening {}", csv_path.display()))?;
    if new_file {
        writeln!(csv, "{CSV_HEADER}")?;
    }
    if !todo.is_empty() {
        // The rows this run appends were measured under these conditions.
        write!(csv, "{}", crate::provenance::Provenance::of(&renderer.device().caps).csv_comment())?;
    }
    let bar = shutter::progress::Progress::new("quality", todo.len() as u64, "points");
    for (i, spp) in todo {
        shutter::progress::check_interrupt()?;
        let s = &a.series[i];
        bar.set_message(format!("{} S={spp}", s.name));
        let settings = RenderSettings { spp, width: a.width, height: a.height, seed: a.seed, ..s.settings };
        let outs = renderer
            .render_frames(scene, s.technique, &settings, a.warmup + a.frames)
            .with_context(|| format!("rendering {} at S={spp}", s.name))?;
        let timed = &outs[a.warmup..];
        let last = timed.last().expect("at least one timed frame");
        let m = compare(&truth, &last.image)?;
        let p = Point {
            series: s.name.clone(),
            spp,
            ms: median(timed.iter().map(|o| o.timings.total_ms()).collect()),
            rmse: m.rmse,
            flip: m.flip,
            passes: last.stats.passes,
            msaa: last.stats.msaa_samples,
        };
        if a.images {
            let stem = format!("{}-{}-S{spp}", a.out.display(), s.name.replace([':', '=', '/'], "-"));
            save_image(format!("{stem}.png"), &last.image)?;
            shutter::metrics::write_flip_diff_png(format!("{stem}-flip.png"), &truth, &last.image)?;
        }
        writeln!(
            csv,
            "{key},\"{device}\",{},{},{:.4},{:.6},{:.6},{},{}",
            p.series, p.spp, p.ms, p.rmse, p.flip, p.passes, p.msaa
        )?;
        csv.flush()?;
        points.push(p);
        bar.inc(1);
    }
    bar.finish();
    // Keep only the requested series, in their order.
    points.retain(|p| a.series.iter().any(|s| s.name == p.series && s.spp.contains(&p.spp)));
    points.sort_by_key(|p| (a.series.iter().position(|s| s.name == p.series), p.spp));
    Ok(points)
}

/// Indices of the points no other point beats in both time and FLIP.
pub fn pareto(points: &[Point]) -> Vec<usize> {
    let mut idx: Vec<usize> = (0..points.len()).collect();
    idx.sort_by(|&i, &j| {
        points[i].ms.total_cmp(&points[j].ms).then(points[i].flip.total_cmp(&points[j].flip))
    });
    let mut front = vec![];
    let mut best = f64::INFINITY;
    for i in idx {
        if points[i].flip < best {
            best = points[i].flip;
            front.push(i);
        }
    }
    front
}

/// Milliseconds a series needs to reach `flip`, interpolating its points linearly in log-log space
/// (None outside the FLIP range its points span). Points are taken in order of increasing time.
pub fn ms_at_flip(points: &[&Point], flip: f64) -> Option<f64> {
    let mut pts: Vec<&&Point> = points.iter().collect();
    pts.sort_by(|a, b| a.ms.total_cmp(&b.ms));
    for w in pts.windows(2) {
        let (p, q) = (w[0], w[1]);
        let (lo, hi) = (p.flip.min(q.flip), p.flip.max(q.flip));
        if flip >= lo && flip <= hi {
            if p.flip == q.flip {
                return Some(p.ms.min(q.ms));
            }
            let t = (flip.ln() - p.flip.ln()) / (q.flip.ln() - p.flip.ln());
            return Some((p.ms.ln() + t * (q.ms.ln() - p.ms.ln())).exp());
        }
    }
    None
}

/// `slow` ÷ `fast` milliseconds at each FLIP of `fast`'s points that `slow`'s curve also reaches.
pub fn ratios_at_equal_flip(points: &[Point], slow: &str, fast: &str) -> Vec<(f64, f64, f64, f64)> {
    let s: Vec<&Point> = points.iter().filter(|p| p.series == slow).collect();
    let f: Vec<&Point> = points.iter().filter(|p| p.series == fast).collect();
    let mut out = vec![];
    for p in &f {
        if let Some(ms_slow) = ms_at_flip(&s, p.flip) {
            out.push((p.flip, ms_slow, p.ms, ms_slow / p.ms));
        }
    }
    for p in &s {
        if let Some(ms_fast) = ms_at_flip(&f, p.flip) {
            out.push((p.flip, p.ms, ms_fast, p.ms / ms_fast));
        }
    }
    out.sort_by(|a, b| a.0.total_cmp(&b.0));
    out.dedup_by(|a, b| (a.0 - b.0).abs() < 1e-12);
    out
}

pub fn markdown(
    scene: &Scene,
    a: &QualityArgs,
    points: &[Point],
    prov: &crate::provenance::Provenance,
) -> String {
    let front = pareto(points);
    let mut md = format!(
        "Scene `{}` (content hash {:016x}), {}×{}, reference: CPU distribution ray tracer at {} spp, seed {}; \
         GPU ms = median of {} frame(s) after {} warm-up frame(s) on `{}` ({}, {}); error of the last frame. \
         Points resumed from the CSV keep the conditions of the run that measured them (its `#` lines).\n\n{}\n",
        scene.name,
        scene.content_hash(),
        a.width,
        a.height,
        a.reference_spp,
        a.seed,
        a.frames,
        a.warmup,
        prov.driver,
        prov.device,
        prov.driver_info,
        prov.markdown()
    );
    md.push_str("| series | S | passes × MSAA | GPU ms | RMSE | FLIP | Pareto |\n|---|---:|---:|---:|---:|---:|:---:|\n");
    for (i, p) in points.iter().enumerate() {
        let _ = writeln!(
            md,
            "| {} | {} | {} × {} | {:.1} | {:.5} | {:.5} | {} |",
            p.series,
            p.spp,
            p.passes,
            p.msaa,
            p.ms,
            p.rmse,
            p.flip,
            if front.contains(&i) { "●" } else { "" }
        );
    }
    for (slow, fast) in &a.compare {
        let r = ratios_at_equal_flip(points, slow, fast);
        let _ = writeln!(
            md,
            "\n**ms of `{slow}` ÷ ms of `{fast}` at equal FLIP** (log-log interpolation along each curve):\n"
        );
        if r.is_empty() {
            let _ = writeln!(md, "the two curves' FLIP ranges do not overlap: no ratio at equal FLIP.");
        } else {
            md.push_str("| FLIP | ms slow | ms fast | ratio |\n|---:|---:|---:|---:|\n");
            for (flip, s, f, ratio) in &r {
                let _ = writeln!(md, "| {flip:.5} | {s:.1} | {f:.1} | {ratio:.3} |");
            }
        }
    }
    md
}

/// Draws a `width`×`height` plot with `draw` into an RGB buffer and writes it as a PNG, all or
/// nothing. The buffer is encoded with the engine's `image` crate rather than plotters' own PNG
/// encoder (its `bitmap_encoder` feature), which would build a second, older `image` and `png` into
/// the CLI (about 25 s of the 2-core test build; docs/CI.md).
pub fn draw_png(
    path: &Path,
    (width, height): (u32, u32),
    draw: impl FnOnce(DrawingArea<BitMapBackend<'_>, plotters::coord::Shift>) -> Result<()>,
) -> Result<()> {
    let mut rgb = vec![0u8; 3 * width as usize * height as usize];
    draw(BitMapBackend::with_buffer(&mut rgb, (width, height)).into_drawing_area())
        .with_context(|| format!("drawing {}", path.display()))?;
    let mut bytes = Vec::new();
    {
        use image::ImageEncoder;
        image::codecs::png::PngEncoder::new(&mut bytes)
            .write_image(&rgb, width, height, image::ExtendedColorType::Rgb8)
            .with_context(|| format!("encoding {}", path.display()))?;
    }
    shutter::image_io::write_file_atomically(path, &bytes)?;
    Ok(())
}

/// Registers a TrueType font for the plots' text (plotters' ab_glyph backend needs one).
pub fn register_font() -> Result<()> {
    const CANDIDATES: &[&str] = &[
        "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf",
        "/usr/share/fonts/TTF/DejaVuSans.ttf",
        "/usr/share/fonts/dejavu/DejaVuSans.ttf",
    ];
    let path = CANDIDATES.iter().find(|p| Path::new(p).exists()).with_context(|| {
        format!("no font for the plots; install fonts-dejavu-core (scripts/setup.sh does); looked in {CANDIDATES:?}")
    })?;
    let bytes: &'static [u8] = Box::leak(std::fs::read(path)?.into_boxed_slice());
    plotters::style::register_font("sans-serif", FontStyle::Normal, bytes)
        .map_err(|_| anyhow::anyhow!("{path} is not a usable font"))?;
    Ok(())
}

/// The log-log plot of FLIP against GPU ms: one curve per series (labelled by S), the Pareto front.
pub fn plot(scene: &Scene, a: &QualityArgs, points: &[Point]) -> Result<()> {
    register_font()?;
    let png = a.out.with_extension("png");
    let svg = a.out.with_extension("svg");
    draw_png(&png, (960, 640), |area| draw(area, scene, a, points))?;
    draw(SVGBackend::new(&svg, (960, 640)).into_drawing_area(), scene, a, points)
        .with_context(|| format!("drawing {}", svg.display()))?;
    errln!("wrote {} and {}", png.display(), svg.display());
    Ok(())
}

fn draw<DB: DrawingBackend>(
    root: DrawingArea<DB, plotters::coord::Shift>,
    scene: &Scene,
    a: &QualityArgs,
    points: &[Point],
) -> Result<()>
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE)?;
    // On log axes a FLIP (or a time) of 0 — an image equal to the reference, e.g. a scene with
    // nothing in it — sits at the floor: its log is −∞, and a range to −∞ never finishes its ticks.
    let (ms, flip) = (|p: &Point| p.ms.max(1e-6), |p: &Point| p.flip.max(1e-6));
    let (mut x0, mut x1, mut y0, mut y1) = (f64::INFINITY, 0.0f64, f64::INFINITY, 0.0f64);
    for p in points {
        x0 = x0.min(ms(p));
        x1 = x1.max(ms(p));
        y0 = y0.min(flip(p));
        y1 = y1.max(flip(p));
    }
    // Log-log through log10 coordinates on linear axes (tick labels at any range, not only decades).
    let (x0, x1, y0, y1) = ((x0 / 1.5).log10(), (x1 * 1.5).log10(), (y0 / 1.3).log10(), (y1 * 1.3).log10());
    let l = |p: &Point| (ms(p).log10(), flip(p).log10());
    let mut chart = ChartBuilder::on(&root)
        .caption(
            format!(
                "{}: error vs time ({}x{}, reference {} spp)",
                scene.name, a.width, a.height, a.reference_spp
            ),
            ("sans-serif", 22),
        )
        .margin(16)
        .x_label_area_size(44)
        .y_label_area_size(64)
        .build_cartesian_2d(x0..x1, y0..y1)?;
    chart
        .configure_mesh()
        .x_desc("GPU ms per frame (median, log)")
        .y_desc("mean FLIP vs reference (log)")
        .label_style(("sans-serif", 14))
        .x_labels(12)
        .y_labels(12)
        .x_label_formatter(&|v| format_sig(10f64.powf(*v)))
        .y_label_formatter(&|v| format_sig(10f64.powf(*v)))
        .draw()?;
    let front = pareto(points);
    let mut fp: Vec<(f64, f64)> = front.iter().map(|&i| l(&points[i])).collect();
    fp.sort_by(|p, q| p.0.total_cmp(&q.0));
    chart
        .draw_series(LineSeries::new(fp.clone(), ShapeStyle::from(&BLACK.mix(0.35)).stroke_width(6)))?
        .label("Pareto front")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLACK.mix(0.35).stroke_width(6)));
    for (si, s) in a.series.iter().enumerate() {
        let color = PALETTE[si % PALETTE.len()];
        let pts: Vec<&Point> = points.iter().filter(|p| p.series == s.name).collect();
        let line: Vec<(f64, f64)> = pts.iter().map(|p| l(p)).collect();
        chart
            .draw_series(LineSeries::new(line.clone(), color.stroke_width(2)))?
            .label(s.name.as_str())
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], color.stroke_width(2)));
        chart.draw_series(pts.iter().map(|p| Circle::new(l(p), 4, color.filled())))?;
        chart.draw_series(pts.iter().map(|p| {
            Text::new(
                format!("S={}", p.spp),
                (l(p).0 + 0.01, l(p).1 + 0.01),
                ("sans-serif", 12).into_font().color(&color),
            )
        }))?;
    }
    chart.draw_series(fp.iter().map(|&(x, y)| Circle::new((x, y), 7, BLACK.stroke_width(1))))?;
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .label_font(("sans-serif", 14))
        .draw()?;
    root.present()?;
    Ok(())
}

/// The series' colours, in order (Tableau 10): ten series before a colour repeats.
pub const PALETTE: [RGBColor; 10] = [
    RGBColor(214, 39, 40),
    RGBColor(31, 119, 180),
    RGBColor(44, 160, 44),
    RGBColor(148, 103, 189),
    RGBColor(255, 127, 14),
    RGBColor(23, 190, 207),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
    RGBColor(188, 189, 34),
];

/// A tick label with three significant digits.
pub fn format_sig(v: f64) -> String {
    if v >= 100.0 {
        format!("{v:.0}")
    } else if v >= 10.0 {
        format!("{v:.1}")
    } else {
        let digits = (2 - v.log10().floor() as i32).clamp(0, 8) as usize;
        format!("{v:.digits$}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pt(series: &str, ms: f64, flip: f64) -> Point {
        Point { series: series.into(), spp: 1, ms, rmse: 0.0, flip, passes: 1, msaa: 1 }
    }

    #[test]
    fn pareto_keeps_the_points_nothing_beats() {
        let p = vec![
            pt("a", 1.0, 0.5),
            pt("a", 2.0, 0.3),
            pt("b", 1.5, 0.6),
            pt("b", 3.0, 0.1),
            pt("b", 4.0, 0.2),
        ];
        assert_eq!(pareto(&p), vec![0, 1, 3]);
    }

    #[test]
    fn equal_flip_ratio_interpolates_in_log_log() {
        // slow: FLIP halves per 4× ms; fast reaches FLIP 0.2 at 10 ms; slow reaches it at 40 ms.
        let p =
            vec![pt("slow", 10.0, 0.4), pt("slow", 40.0, 0.2), pt("slow", 160.0, 0.1), pt("fast", 10.0, 0.2)];
        let r = ratios_at_equal_flip(&p, "slow", "fast");
        assert_eq!(r.len(), 1);
        assert!((r[0].3 - 4.0).abs() < 1e-9, "{r:?}");
        let s: Vec<&Point> = p.iter().filter(|q| q.series == "slow").collect();
        assert!((ms_at_flip(&s, 0.1414213562).unwrap() - 80.0).abs() < 1e-3);
        assert!(ms_at_flip(&s, 0.5).is_none());
    }

    #[test]
    fn csv_lines_split_with_quotes() {
        assert_eq!(split_csv("a,\"b, c\",3"), vec!["a", "b, c", "3"]);
        assert_eq!(split_csv("x,,\"\""), vec!["x", "", ""]);
    }
}
