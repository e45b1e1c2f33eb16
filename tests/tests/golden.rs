//! Golden image hashes: every configuration of [`configs`] rendered small on lavapipe (validation on) must
//! give the very pixels recorded in `tests/golden/image-hashes-DRIVER.txt` (one file per driver, e.g.
//! `lavapipe-25.0`) — bit for bit, so a refactor of the renderer's internals can prove it changed
//! nothing.
//!
//! llvmpipe JIT-compiles its shaders for the host CPU, so another CPU may legitimately round
//! differently: each file records the machine it was made on, and only there are hashes compared
//! (the **exact tier**). Everywhere — on that machine too, and on any other driver or device, which has
//! no hash file at all — the **tolerance tier** runs: each image against the one recorded on the
//! project's first-class driver ([`IMAGE_DRIVER`], `tests/golden/images/`, small lossless EXRs) within
//! [`MAX_RMSE`] and [`MAX_FLIP`], and the instrumented rows' counters within [`COUNTER_TOLERANCE`].
//! On the other lavapipe this is a real cross-driver comparison on every CI run. A failure leaves the
//! expected and actual images and a FLIP map in `target/test-output/`.
//!
//! Record (or re-record, after an intended change) on each driver with
//! `SHUTTER_RECORD_GOLDEN=1 SHUTTER_DEVICE=llvmpipe SHUTTER_DRIVER=lavapipe-25.0 cargo test -p shutter-tests --test integration golden::`
//! (and `SHUTTER_DRIVER=lavapipe-22.3`); the images are recorded on [`IMAGE_DRIVER`] only.

use std::collections::{BTreeMap, HashMap};
use std::fmt::Write as _;
use std::path::PathBuf;
use std::time::Instant;

use shutter::image::LinearImage;
use shutter::image_io::{load_image, save_image};
use shutter::metrics::{compare, write_flip_diff_png};
use shutter::mirror::bounds::BoundKind;
use shutter::scene::builtin::builtin_scene;
use shutter::scene::Scene;
use shutter::techniques::{
    Clusters, HullExpansion, RenderOutput, RenderSettings, Renderer, SampleCounters, ShadingRate,
    StochasticOptions, Technique,
};
use shutter_tests::{output_dir, renderer};

/// One row of the table: a stable label, the built-in scene, the technique and its settings. The
/// technique goes by its command-line name, parsed at render time: names survive a change in how
/// techniques are represented, so this file compiles on both sides of a refactor.
struct Config {
    label: String,
    scene: &'static str,
    technique: &'static str,
    settings: RenderSettings,
}

const SEED: u64 = 1;

/// Small sizes keep the whole test under 90 s on two cores; `focus-sweep`'s stochastic path costs many
/// seconds even so (lavapipe bounding its 327,680 triangles), hence smaller still.
fn size(scene: &str) -> (u32, u32) {
    if scene == "focus-sweep" {
        (32, 18)
    } else {
        (64, 36)
    }
}

fn config(scene: &'static str, technique: &'static str, spp: u32, o: StochasticOptions) -> Config {
    let mut label = format!("{scene}/{technique}");
    // Pinhole ignores spp (fixed MSAA) and, like accumulation, every stochastic option.
    if technique != "pinhole" {
        let _ = write!(label, "/s{spp}");
    }
    if matches!(technique, "stochastic" | "auto") {
        let _ = write!(
            label,
            "/bound={}/shading={}/hull={}",
            o.bound.name(),
            o.shading.name(),
            o.expansion.name()
        );
        if let Some(m) = o.per_pass {
            let _ = write!(label, "/per-pass={m}");
        }
        // Rows recorded before cluster bounds pin one bound per triangle (`opts`).
        if o.clusters != Clusters::Off {
            let _ = write!(label, "/clusters={}", o.clusters.name());
        }
        if o.instrumented {
            label.push_str("/instrumented");
        }
    }
    let (w, h) = size(scene);
    Config { label, scene, technique, settings: RenderSettings::new(w, h, spp, SEED).with_stochastic(o) }
}

fn opts(bound: BoundKind, shading: ShadingRate, expansion: HullExpansion) -> StochasticOptions {
    // Not instrumented, one pass, intervals as the policy picks, one bound per triangle.
    StochasticOptions {
        bound: bound.into(),
        shading,
        expansion,
        clusters: Clusters::Off,
        ..Default::default()
    }
}

/// THE table. Labels are keys into the golden file: add rows freely (then re-record), but never change
/// what an existing label renders.
fn configs() -> Vec<Config> {
    use HullExpansion::{Compute, GeometryShader as Gs};
    use ShadingRate::{PerPixel, PerSample};
    let base = opts(BoundKind::Adaptive, PerPixel, Gs);
    let mut c = vec![];
    // Every built-in scene through pinhole, accumulation and auto. `auto` on `focus-sweep`
    // takes the stochastic path for the displaced sphere (defocus only) with the bounding box: the
    // adaptive bound of its 327,680 triangles doubles the frame (measured 29 s against 15 s on a loaded
    // machine; the compute hull took 46 s), and the image does not depend on the bound.
    for scene in ["default", "static", "focus-sweep", "one-mover"] {
        c.push(config(scene, "pinhole", 1, base));
        c.push(config(scene, "accumulation", 4, base));
        let bound = if scene == "focus-sweep" { BoundKind::BoundingBox } else { BoundKind::Adaptive };
        c.push(config(scene, "auto", 4, opts(bound, PerPixel, Gs)));
    }
    // Every bound kind (the GLSL `compute_bound` branches). The image does not depend on the bound (it
    // only has to be conservative), so each is also rendered instrumented: the fragment and sample-test
    // counts pin the bound's exact shape.
    for bound in BoundKind::ALL {
        c.push(config("default", "stochastic", 4, opts(bound, PerPixel, Gs)));
        c.push(config(
            "default",
            "stochastic",
            4,
            StochasticOptions { instrumented: true, ..opts(bound, PerPixel, Gs) },
        ));
    }
    // Both shading rates × both hull expansions, on a scene with both effects and on one with a single
    // mover among still objects. default/per-pixel/gs is already a row of the bound sweep.
    for scene in ["default", "one-mover"] {
        for shading in [PerPixel, PerSample] {
            for expansion in [Gs, Compute] {
                if scene == "default" && shading == PerPixel && expansion == Gs {
                    continue;
                }
                c.push(config(scene, "stochastic", 4, opts(BoundKind::Adaptive, shading, expansion)));
            }
        }
    }
    // S = 16 (one pass of 16 samples), one sample per pass forced (4 passes through the visibility
    // buffer), per-sample shading instrumented (per-pixel is in the bound sweep), and `auto` at S = 16.
    c.push(config("default", "stochastic", 16, base));
    c.push(config("default", "stochastic", 4, StochasticOptions { per_pass: Some(1), ..base }));
    c.push(config(
        "default",
        "stochastic",
        4,
        StochasticOptions { instrumented: true, ..opts(BoundKind::Adaptive, PerSample, Gs) },
    ));
    c.push(config("one-mover", "auto", 16, base));
    // Cluster bounds: `auto` as it ships (clusters where they pay: default's spheres, focus-sweep's
    // displaced sphere), and every object in clusters of 4, instrumented (the counters pin the
    // clusters' screen boxes and per-sample tests).
    let auto_clusters = StochasticOptions { clusters: Clusters::Auto, ..base };
    c.push(config("default", "auto", 4, auto_clusters));
    c.push(config(
        "focus-sweep",
        "auto",
        4,
        StochasticOptions { bound: BoundKind::BoundingBox.into(), ..auto_clusters },
    ));
    c.push(config(
        "default",
        "stochastic",
        4,
        StochasticOptions { instrumented: true, clusters: Clusters::Fixed(4), ..base },
    ));
    // Left out: `stochastic` on `focus-sweep` (measured 15 s a frame even at 32×18, lavapipe bounding
    // 327,680 triangles: one row took the test from about 50 s to 65 s, past 90 s on a busy machine).
    // `auto` above already runs the stochastic renderer on that mesh, and the both-effects permutation
    // is covered on `default`.
    c
}

/// FNV-1a, 64 bits.
struct Fnv(u64);

impl Fnv {
    fn new() -> Self {
        Fnv(0xcbf2_9ce4_8422_2325)
    }
    fn bytes(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 ^= u64::from(b);
            self.0 = self.0.wrapping_mul(0x0000_0100_0000_01b3);
        }
    }
}

/// The hash of the image's exact bits (every f32 of every RGBA pixel, little-endian, after the
/// dimensions) and, for instrumented renders, of the four counters.
fn hash(image: &LinearImage, counters: Option<&SampleCounters>) -> u64 {
    let mut h = Fnv::new();
    h.bytes(&image.width.to_le_bytes());
    h.bytes(&image.height.to_le_bytes());
    for p in &image.pixels {
        for c in p {
            h.bytes(&c.to_le_bytes());
        }
    }
    if let Some(k) = counters {
        for v in [k.fragments, k.samples_tested, k.samples_hit, k.shading_invocations] {
            h.bytes(&v.to_le_bytes());
        }
    }
    h.0
}

/// One file per driver (`image-hashes-lavapipe-25.0.txt`): each lavapipe version rounds in its own way,
/// and CI runs this test on both.
fn golden_path(r: &Renderer) -> PathBuf {
    let key = &r.device().caps.driver_key;
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join(format!("golden/image-hashes-{key}.txt"))
}

const SIGNATURE_PREFIX: &str = "# machine: ";

/// What decides llvmpipe's rounding: the driver (Mesa and LLVM versions) and the CPU features its JIT
/// targets.
fn machine_signature(r: &Renderer) -> String {
    let caps = &r.device().caps;
    let cpuinfo = std::fs::read_to_string("/proc/cpuinfo").unwrap_or_default();
    let flags: Vec<&str> = cpuinfo
        .lines()
        .find(|l| l.starts_with("flags"))
        .and_then(|l| l.split_once(':'))
        .map(|(_, f)| f.split_whitespace().collect())
        .unwrap_or_default();
    let cpu: Vec<String> =
        ["avx2", "fma", "avx512f"].iter().map(|f| format!("{f}={}", u8::from(flags.contains(f)))).collect();
    let sig = format!(
        "device={} | driver={} | driver_info={} | cpu {}",
        caps.device_name,
        caps.driver_name,
        caps.driver_info,
        cpu.join(" ")
    );
    // One line in the file whatever the driver reports.
    sig.replace(['\n', '\r'], " ")
}

/// A file-name-safe version of a label.
fn file_stem(label: &str) -> String {
    label.chars().map(|c| if c.is_ascii_alphanumeric() || c == '-' { c } else { '_' }).collect()
}

fn render(
    r: &mut Renderer,
    scenes: &mut HashMap<&'static str, Scene>,
    c: &Config,
) -> Result<RenderOutput, String> {
    let scene = scenes.entry(c.scene).or_insert_with(|| {
        builtin_scene(c.scene)
            .unwrap_or_else(|| panic!("no built-in scene `{}`", c.scene))
            .unwrap_or_else(|e| panic!("built-in scene `{}`: {e}", c.scene))
    });
    let technique: Technique = c.technique.parse().map_err(|e| format!("{e}"))?;
    r.render(scene, technique, &c.settings).map_err(|e| e.to_string())
}

/// The driver whose images the tolerance tier compares every run with.
const IMAGE_DRIVER: &str = "lavapipe-25.0";

/// The project's drivers: each must have its hash file (elsewhere the tolerance tier runs alone).
const PROJECT_DRIVERS: [&str; 2] = ["lavapipe-25.0", "lavapipe-22.3"];

/// Tolerance tier: RMSE and mean FLIP of each image against [`IMAGE_DRIVER`]'s. The two lavapipes
/// differ on these rows by f32 rounding only (RMSE at most ~1e-5 here, most rows identical), so
/// 1e-3 keeps two orders of magnitude of margin while one pixel of a 64×36 image wrong by 0.5 is
/// RMSE ~0.01. The same thresholds as `shutter check`'s smoke suite.
const MAX_RMSE: f64 = 1e-3;
const MAX_FLIP: f64 = 1e-3;

/// Tolerance tier: the instrumented rows' counters (fragments of the bounds, samples tested and hit,
/// shading invocations) may differ by this fraction: a bound's edge rounded differently covers a
/// few pixels more or fewer.
const COUNTER_TOLERANCE: f64 = 0.01;

fn images_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("golden/images")
}

/// The hash of an image's bits alone: the name of its file in [`images_dir`] (rows rendering the
/// same image share one).
fn image_hash(image: &LinearImage) -> String {
    format!("{:016x}", hash(image, None))
}

/// One row of `golden/images/index.txt`: the image's file and the counters of an instrumented row.
struct Expected {
    image: String,
    counters: Option<[u64; 4]>,
}

fn counters_of(k: &SampleCounters) -> [u64; 4] {
    [k.fragments, k.samples_tested, k.samples_hit, k.shading_invocations].map(u64::from)
}

fn read_index() -> Result<BTreeMap<String, Expected>, String> {
    let path = images_dir().join("index.txt");
    let text = std::fs::read_to_string(&path).map_err(|e| format!("{}: {e}", path.display()))?;
    let mut rows = BTreeMap::new();
    for line in text.lines().filter(|l| !l.starts_with('#') && !l.trim().is_empty()) {
        let f: Vec<&str> = line.split_whitespace().collect();
        let counters = match f.len() {
            2 => None,
            6 => {
                let v: Vec<u64> = f[2..]
                    .iter()
                    .map(|x| x.parse().map_err(|_| format!("bad index line `{line}`")))
                    .collect::<Result<_, _>>()?;
                Some([v[0], v[1], v[2], v[3]])
            }
            _ => return Err(format!("bad index line `{line}`")),
        };
        rows.insert(f[0].to_string(), Expected { image: f[1].to_string(), counters });
    }
    Ok(rows)
}

/// Writes the images and their index (all of them anew: files no row names are removed).
fn record_images(signature: &str, rows: &[(String, LinearImage, Option<[u64; 4]>)]) {
    let dir = images_dir();
    std::fs::create_dir_all(&dir).expect("create tests/golden/images");
    for entry in std::fs::read_dir(&dir).expect("list tests/golden/images").flatten() {
        if entry.path().extension().is_some_and(|e| e == "exr") {
            std::fs::remove_file(entry.path()).expect("remove an old golden image");
        }
    }
    let mut index = format!(
        "# Golden images for the tolerance tier of tests/tests/golden.rs: label, image file (the hash of its\n\
         # bits, .exr beside this file), the counters of instrumented rows. Recorded with\n\
         # SHUTTER_RECORD_GOLDEN=1 on {IMAGE_DRIVER}.\n# machine: {signature}\n"
    );
    for (label, image, counters) in rows {
        let name = image_hash(image);
        let path = dir.join(format!("{name}.exr"));
        if !path.exists() {
            save_image(&path, image).expect("write a golden image");
        }
        let _ = write!(index, "{label} {name}");
        if let Some(k) = counters {
            let _ = write!(index, " {} {} {} {}", k[0], k[1], k[2], k[3]);
        }
        index.push('\n');
    }
    std::fs::write(dir.join("index.txt"), index).expect("write the golden image index");
}

/// The tolerance tier: every rendered row against [`IMAGE_DRIVER`]'s image and counters.
fn tolerance_tier(rows: &[(String, LinearImage, Option<[u64; 4]>)]) -> Vec<String> {
    let index = match read_index() {
        Ok(i) => i,
        Err(e) => return vec![format!("tolerance tier: no golden images: {e}")],
    };
    let mut images: HashMap<String, LinearImage> = HashMap::new();
    let mut failures = vec![];
    let (mut worst_rmse, mut worst_flip, mut worst_counter) = (0.0f64, 0.0f64, 0.0f64);
    for (label, image, counters) in rows {
        let Some(want) = index.get(label) else {
            failures.push(format!("{label}: not in the golden image index"));
            continue;
        };
        if !images.contains_key(&want.image) {
            let path = images_dir().join(format!("{}.exr", want.image));
            match load_image(&path) {
                Ok(i) => {
                    images.insert(want.image.clone(), i);
                }
                Err(e) => {
                    failures.push(format!("{label}: {e}"));
                    continue;
                }
            }
        }
        let expected = &images[&want.image];
        let m = match compare(expected, image) {
            Ok(m) => m,
            Err(e) => {
                failures.push(format!("{label}: not comparable: {e}"));
                continue;
            }
        };
        worst_rmse = worst_rmse.max(m.rmse);
        worst_flip = worst_flip.max(m.flip);
        let mut beyond = vec![];
        if m.rmse.is_nan() || m.rmse > MAX_RMSE {
            beyond.push(format!("RMSE {:.3e} > {MAX_RMSE}", m.rmse));
        }
        if m.flip.is_nan() || m.flip > MAX_FLIP {
            beyond.push(format!("FLIP {:.3e} > {MAX_FLIP}", m.flip));
        }
        match (want.counters, counters) {
            (Some(w), Some(a)) => {
                for (name, (w, a)) in ["fragments", "samples tested", "samples hit", "shading invocations"]
                    .iter()
                    .zip(w.iter().zip(a))
                {
                    let rel = (*a as f64 - *w as f64).abs() / (*w as f64).max(1.0);
                    worst_counter = worst_counter.max(rel);
                    if rel > COUNTER_TOLERANCE {
                        beyond
                            .push(format!("{name} {a}, expected {w} (±{:.0} %)", COUNTER_TOLERANCE * 100.0));
                    }
                }
            }
            (None, None) => {}
            _ => beyond.push("counters present on one side only".into()),
        }
        if !beyond.is_empty() {
            let stem = format!("golden-{}", file_stem(label));
            let out = output_dir();
            let _ = save_image(out.join(format!("{stem}-expected.png")), expected);
            let _ = save_image(out.join(format!("{stem}-actual.png")), image);
            let _ = write_flip_diff_png(out.join(format!("{stem}-flip.png")), expected, image);
            failures.push(format!(
                "{label}: {} (tolerance tier; {stem}-{{expected,actual,flip}}.png)",
                beyond.join(", ")
            ));
        }
    }
    println!(
        "tolerance tier against {IMAGE_DRIVER}'s images: {} rows, worst RMSE {worst_rmse:.2e} (max {MAX_RMSE}), \
         worst FLIP {worst_flip:.2e} (max {MAX_FLIP}), worst counter {:.3} % (max {:.0} %)",
        rows.len(),
        worst_counter * 100.0,
        COUNTER_TOLERANCE * 100.0
    );
    failures
}

#[test]
fn images_match_the_golden_hashes() {
    let table = configs();
    let mut labels: Vec<&str> = table.iter().map(|c| c.label.as_str()).collect();
    labels.sort_unstable();
    if let Some(w) = labels.windows(2).find(|w| w[0] == w[1]) {
        panic!("label `{}` appears twice in the table", w[0]);
    }
    let record = std::env::var("SHUTTER_RECORD_GOLDEN").is_ok_and(|v| v == "1");
    let mut r = renderer();
    let signature = machine_signature(&r);
    println!("machine: {signature}");

    let driver = r.device().caps.driver_key.clone();
    // The exact tier's hashes: None where this machine is not the one they were recorded on.
    let expected: Option<BTreeMap<String, String>> = if record {
        None
    } else {
        let path = golden_path(&r);
        match std::fs::read_to_string(&path) {
            Err(e) if PROJECT_DRIVERS.contains(&driver.as_str()) => {
                panic!("{}: {e} (record it with SHUTTER_RECORD_GOLDEN=1)", path.display())
            }
            Err(e) => {
                eprintln!(
                    "golden: exact tier not run: no hashes for driver `{driver}` ({}: {e}); the tolerance tier runs",
                    path.display()
                );
                None
            }
            Ok(text) => {
                let recorded =
                    text.lines().find_map(|l| l.strip_prefix(SIGNATURE_PREFIX)).unwrap_or("<none>");
                if recorded != signature {
                    eprintln!(
                        "golden: exact tier not run: the hashes were recorded on another machine, and llvmpipe \
                         may round differently on another driver or CPU; the tolerance tier runs.\n  recorded: \
                         {recorded}\n  this machine: {signature}"
                    );
                    None
                } else {
                    Some(
                        text.lines()
                            .filter(|l| !l.starts_with('#') && !l.trim().is_empty())
                            .map(|l| {
                                let (label, hash) =
                                    l.rsplit_once(' ').unwrap_or_else(|| panic!("bad golden line `{l}`"));
                                (label.trim().to_string(), hash.trim().to_string())
                            })
                            .collect(),
                    )
                }
            }
        }
    };

    let mut scenes = HashMap::new();
    let mut lines = vec![];
    let mut failures = vec![];
    let mut rows = vec![];
    let t0 = Instant::now();
    for c in &table {
        let t = Instant::now();
        let out = match render(&mut r, &mut scenes, c) {
            Ok(out) => out,
            Err(e) => {
                failures.push(format!("{}: render failed: {e}", c.label));
                continue;
            }
        };
        let counters = out.stats.counters.as_ref();
        let actual = format!("{:016x}", hash(&out.image, counters));
        let counters_text = counters.map(|k| {
            format!(
                " counters: fragments {} tested {} hit {} shaded {}",
                k.fragments, k.samples_tested, k.samples_hit, k.shading_invocations
            )
        });
        println!(
            "{:<75} {actual} {:>6.0} ms{}",
            c.label,
            t.elapsed().as_secs_f64() * 1e3,
            counters_text.unwrap_or_default()
        );
        rows.push((c.label.clone(), out.image.clone(), counters.map(counters_of)));
        if record {
            // A uniform image is almost surely a broken render, not a baseline worth keeping.
            let first = out.image.pixels.first().copied();
            assert!(
                out.image.pixels.iter().any(|p| Some(*p) != first),
                "{}: the image is one uniform colour; not recording it",
                c.label
            );
            lines.push(format!("{} {actual}", c.label));
            continue;
        }
        let Some(expected) = &expected else { continue };
        match expected.get(&c.label) {
            None => failures.push(format!("{}: not in the golden file (actual {actual})", c.label)),
            Some(want) if *want != actual => {
                let png = output_dir().join(format!("golden-{}.png", file_stem(&c.label)));
                let saved = shutter::image_io::save_image(&png, &out.image)
                    .map_or_else(|e| format!("PNG not saved: {e}"), |()| png.display().to_string());
                failures.push(format!("{}: expected {want}, actual {actual} ({saved})", c.label));
            }
            Some(_) => {}
        }
    }
    println!("{} configurations in {:.1} s", table.len(), t0.elapsed().as_secs_f64());

    if record {
        // A file lacking rows would only make later comparisons fail: write all or nothing.
        assert!(failures.is_empty(), "not recording, renders failed:\n{}", failures.join("\n"));
        let mut text = String::new();
        text.push_str(
            "# Golden image hashes: tests/tests/golden.rs (FNV-1a 64 of each image's f32 RGBA bits, plus the\n\
             # counters of instrumented renders). Re-record with SHUTTER_RECORD_GOLDEN=1. The hashes hold only\n\
             # on the machine below (llvmpipe JIT-compiles for the host CPU); elsewhere only the tolerance\n\
             # tier runs (golden/images/).\n",
        );
        let _ = writeln!(text, "{SIGNATURE_PREFIX}{signature}");
        for l in &lines {
            let _ = writeln!(text, "{l}");
        }
        let path = golden_path(&r);
        if let Some(dir) = path.parent() {
            std::fs::create_dir_all(dir).expect("create tests/golden");
        }
        std::fs::write(&path, text).expect("write the golden file");
        println!("recorded {} hashes in {}", lines.len(), path.display());
        if driver == IMAGE_DRIVER {
            record_images(&signature, &rows);
            println!("recorded the tolerance tier's images in {}", images_dir().display());
        }
        return;
    }

    // Rows of the file the table no longer has: the two must not drift apart either way.
    if let Some(expected) = &expected {
        for label in expected.keys() {
            if !table.iter().any(|c| &c.label == label) {
                failures.push(format!("{label}: in the golden file but not in the table"));
            }
        }
    }
    failures.extend(tolerance_tier(&rows));
    assert!(
        failures.is_empty(),
        "{} golden mismatches over {} configurations (PNGs of differing images under {}):\n{}",
        failures.len(),
        table.len(),
        output_dir().display(),
        failures.join("\n")
    );
}

/// The tolerance tier fails a changed image and a changed counter, and passes rounding-sized changes:
/// checked on the recorded images themselves (no rendering), since the two lavapipes render these
/// rows bit-identically and a real run shows no difference to catch.
#[test]
fn tolerance_tier_catches_a_changed_image() {
    let index = read_index().expect("the golden image index");
    let load = |label: &str| {
        let want = &index[label];
        let image = load_image(images_dir().join(format!("{}.exr", want.image))).expect("a golden image");
        (label.to_string(), image, want.counters)
    };
    let plain = "default/stochastic/s4/bound=adaptive/shading=per-pixel/hull=gs";
    let counted = index
        .iter()
        .find(|(_, e)| e.counters.is_some())
        .map(|(l, _)| l.clone())
        .expect("an instrumented row");
    let rows = vec![load(plain), load(&counted)];
    assert!(tolerance_tier(&rows).is_empty(), "the recorded rows must pass against themselves");

    // f32 rounding everywhere: within the thresholds.
    let mut rounded = rows.clone();
    for p in &mut rounded[0].1.pixels {
        for c in &mut p[..3] {
            *c *= 1.0 + 1e-6;
        }
    }
    assert!(tolerance_tier(&rounded).is_empty());

    // A block of pixels wrong by 0.5: a regression, named with its pictures.
    let mut broken = rows.clone();
    let w = broken[0].1.width as usize;
    for y in 10..14 {
        for x in 20..24 {
            broken[0].1.pixels[y * w + x][1] += 0.5;
        }
    }
    let failures = tolerance_tier(&broken);
    assert_eq!(failures.len(), 1, "{failures:?}");
    assert!(failures[0].starts_with(plain) && failures[0].contains("RMSE"), "{failures:?}");

    // A bound's fragment count 5 % higher.
    let mut more = rows;
    let k = more[1].2.as_mut().expect("counters");
    k[0] += k[0] / 20 + 1;
    let failures = tolerance_tier(&more);
    assert!(failures.len() == 1 && failures[0].contains("fragments"), "{failures:?}");
}
