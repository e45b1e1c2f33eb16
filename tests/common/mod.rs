//! Helpers shared by the integration tests: devices with validation on, small hand-built scenes,
//! image measurements, and writing actual/reference/difference images when a check fails.

use std::path::PathBuf;
use std::sync::Arc;

use glam::{Mat4, Vec2, Vec3};
use shutter::image::LinearImage;
use shutter::reference::{render_reference_cached, ReferenceSettings};
use shutter::sampling::{ApertureShape, ShutterCurve};
use shutter::scene::{Camera, CameraPose, Environment, ImageSettings, Light, Material, Mesh, Object, Scene};
use shutter::techniques::{RenderOutput, Renderer, ShadingRate};

/// A renderer on the environment's device with validation forced on (any message fails a render).
pub fn renderer() -> Renderer {
    // SAFETY of set_var: tests in one binary all set the same value.
    unsafe { std::env::set_var("SHUTTER_VALIDATION", "1") };
    let device = shutter::vk::create_device().expect("a Vulkan device (run scripts/setup.sh for lavapipe)");
    assert!(device.validation_enabled, "validation layer missing: install vulkan-validationlayers");
    Renderer::new(device).expect("renderer")
}

/// The CPU reference through the test run's cache, where the run has one: `SHUTTER_TEST_REFERENCE_CACHE`
/// names a folder that `scripts/test.sh` makes fresh for each run, so the second driver's pass takes
/// the first pass's references instead of tracing them again (the reference runs on the CPU; its
/// images do not depend on the driver). Without it every reference is traced. A run's own folder,
/// never a lasting one: a cache that outlived a change to the reference would hide the change.
pub fn render_reference(scene: &Scene, settings: &ReferenceSettings) -> shutter::Result<LinearImage> {
    match reference_cache_dir() {
        Some(dir) => {
            render_reference_cached(std::path::Path::new(&dir), scene, settings).map(|(image, _)| image)
        }
        None => shutter::reference::render_reference(scene, settings),
    }
}

/// The test run's reference cache, `SHUTTER_TEST_REFERENCE_CACHE` where set and not empty
/// ([`render_reference`]).
pub fn reference_cache_dir() -> Option<String> {
    std::env::var("SHUTTER_TEST_REFERENCE_CACHE").ok().filter(|d| !d.is_empty())
}

/// The CPU reference with the same samples *and* the same shading rate as a stochastic (or `auto`)
/// render `out` of S = `spp`: per-pixel shading groups the samples of each of its passes.
pub fn same_sample_reference(
    scene: &Scene,
    (w, h): (u32, u32),
    spp: u32,
    seed: u64,
    shading: ShadingRate,
    out: &RenderOutput,
) -> LinearImage {
    // Texture-space shading approximates the exact rates; the reference does not mirror it.
    let shading = shading.exact().reference(spp / out.stats.passes.max(1)).expect("exact rates are mirrored");
    render_reference(scene, &ReferenceSettings { width: w, height: h, spp, seed, progress: false, shading })
        .expect("reference")
}

/// The CPU reference of `scene` at `spp` samples per pixel and `seed`, shaded per sample.
pub fn reference_image(scene: &Scene, (w, h): (u32, u32), spp: u32, seed: u64) -> LinearImage {
    render_reference(
        scene,
        &ReferenceSettings { width: w, height: h, spp, seed, progress: false, shading: Default::default() },
    )
    .expect("reference")
}

/// Largest absolute difference of two images over the colour channels.
pub fn max_abs_diff(a: &LinearImage, b: &LinearImage) -> f32 {
    a.pixels
        .iter()
        .zip(&b.pixels)
        .flat_map(|(p, q)| (0..3).map(move |c| (p[c] - q[c]).abs()))
        .fold(0.0, f32::max)
}

/// Where tests write images for a person to look at.
pub fn output_dir() -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../target/test-output");
    std::fs::create_dir_all(&dir).expect("create target/test-output");
    dir
}

/// Saves `actual`, `reference` and their FLIP map under target/test-output/<name>-*.png.
pub fn save_comparison(name: &str, reference: &LinearImage, actual: &LinearImage) {
    let dir = output_dir();
    let _ = shutter::image_io::save_image(dir.join(format!("{name}-actual.png")), actual);
    let _ = shutter::image_io::save_image(dir.join(format!("{name}-reference.png")), reference);
    let _ =
        shutter::metrics::write_flip_diff_png(dir.join(format!("{name}-difference.png")), reference, actual);
}

/// An axis-aligned square of side `size` in the XY plane facing +Z, centred at the origin.
pub fn square(size: f32) -> Arc<Mesh> {
    let h = size * 0.5;
    Arc::new(
        Mesh::new(
            "square",
            vec![Vec3::new(-h, -h, 0.0), Vec3::new(h, -h, 0.0), Vec3::new(h, h, 0.0), Vec3::new(-h, h, 0.0)],
            vec![],
            vec![Vec2::new(0.0, 1.0), Vec2::new(1.0, 1.0), Vec2::new(1.0, 0.0), Vec2::ZERO],
            vec![0, 1, 2, 0, 2, 3],
        )
        .expect("square mesh"),
    )
}

/// A camera at the origin looking down −Z.
pub fn camera(vfov_deg: f32, aperture_radius: f32, focus_distance: f32) -> Camera {
    Camera {
        open: CameraPose { position: Vec3::ZERO, look_at: -Vec3::Z, up: Vec3::Y },
        close: None,
        vfov_deg,
        aperture_radius,
        focus_distance,
        aperture: ApertureShape::Disk,
        shutter: ShutterCurve::Box,
        near: 0.05,
        far: 1000.0,
    }
}

/// A scene of one emissive-looking (ambient-only, albedo 1) object over black.
pub fn single_object_scene(
    camera: Camera,
    mesh: Arc<Mesh>,
    open: Mat4,
    close: Option<Mat4>,
    w: u32,
    h: u32,
) -> Scene {
    Scene {
        name: "test".into(),
        image: ImageSettings { width: w, height: h, spp: 16, seed: 1, display: Default::default() },
        camera,
        objects: vec![Object {
            name: "object".into(),
            mesh,
            transforms: match close {
                Some(c) => vec![(0.0, open), (1.0, c)],
                None => vec![(0.0, open)],
            },
            material: Material { albedo: Vec3::ONE, ..Material::default() },
        }],
        lights: vec![],
        environment: Environment { ambient: Vec3::ONE, background: Vec3::ZERO, ..Default::default() },
    }
}

/// Luminance-weighted moments of an image: (energy, centroid, covariance xx, yy).
pub fn moments(img: &LinearImage) -> (f64, (f64, f64), (f64, f64)) {
    let (mut e, mut sx, mut sy) = (0.0f64, 0.0f64, 0.0f64);
    for y in 0..img.height {
        for x in 0..img.width {
            let v = img.get(x, y)[1] as f64;
            e += v;
            sx += v * (x as f64 + 0.5);
            sy += v * (y as f64 + 0.5);
        }
    }
    let (cx, cy) = (sx / e, sy / e);
    let (mut vxx, mut vyy) = (0.0f64, 0.0f64);
    for y in 0..img.height {
        for x in 0..img.width {
            let v = img.get(x, y)[1] as f64;
            vxx += v * (x as f64 + 0.5 - cx).powi(2);
            vyy += v * (y as f64 + 0.5 - cy).powi(2);
        }
    }
    (e, (cx, cy), (vxx / e, vyy / e))
}

/// The closed-form pane scenes of the transparency tests (`transparency.rs`, `oit.rs`): triangles
/// covering pixel rectangles at given depths, in front of a known background, whose sorted composite
/// is known exactly.
pub mod panes {
    use std::sync::Arc;

    use glam::{Mat4, Vec3};
    use shutter::scene::{Camera, Material, Mesh, Object, Scene};

    use super::{camera, single_object_scene, square};

    /// The pane scenes' image size.
    pub const W: u32 = 48;
    pub const H: u32 = 32;

    /// Front to back: (pixel rectangle, depth, alpha, colour, tint).
    pub type PaneSpec = ([f32; 4], f32, f32, Vec3, Vec3);
    pub const BACKGROUND: Vec3 = Vec3::new(0.6, 0.7, 0.8);

    /// One triangle covering pixel rectangle `[x0, x1] × [y0, y1]` at view depth `z` of a `W × H`
    /// image (its three edges are x = x1 and two edges far outside the image on the other sides, so
    /// no edge shared by two triangles crosses the image: a sample on such an edge may go to either
    /// triangle, and the rasterizer's tie rule is not the reference's).
    pub fn pixel_triangle(cam: &Camera, [x0, x1, y0, y1]: [f32; 4], z: f32) -> Arc<Mesh> {
        let s = cam.intrinsics(W, H).pixel_scale;
        let p = |x: f32, y: f32| Vec3::new((x - W as f32 / 2.0) / s * z, -(y - H as f32 / 2.0) / s * z, -z);
        // The apex far left; the right edge from (x1, y0 − d) to (x1, y1 + d) with d large enough that
        // the other two edges pass outside [x0, x1] × [y0, y1].
        let width = x1 - x0;
        let d = 2.0 * (y1 - y0) + 10.0;
        let apex = p(x0 - 4.0 * width - 10.0, 0.5 * (y0 + y1));
        Arc::new(
            Mesh::new("pane", vec![apex, p(x1, y1 + d), p(x1, y0 - d)], vec![], vec![], vec![0, 1, 2])
                .expect("triangle"),
        )
    }

    /// A still pane of `mesh` with that albedo, coverage and tint.
    pub fn pane(mesh: Arc<Mesh>, albedo: Vec3, alpha: f32, tint: Vec3) -> Object {
        Object {
            name: format!("pane {alpha}"),
            mesh,
            transforms: vec![(0.0, Mat4::IDENTITY)],
            material: Material { albedo, alpha, tint, ..Material::default() },
        }
    }

    /// The nearest pane covers the left half only; the last is a pure filter (alpha 0).
    pub fn panes() -> Vec<PaneSpec> {
        let full = [-1.0, W as f32 + 1.0, -1.0, H as f32 + 1.0];
        let left = [-1.0, W as f32 / 2.0, -1.0, H as f32 + 1.0];
        vec![
            (left, 2.0, 0.3, Vec3::new(0.9, 0.2, 0.1), Vec3::new(1.0, 0.6, 0.3)),
            (full, 3.0, 0.5, Vec3::new(0.1, 0.8, 0.3), Vec3::new(0.4, 1.0, 0.7)),
            (full, 4.0, 0.2, Vec3::new(0.2, 0.3, 0.9), Vec3::new(0.9, 0.9, 0.2)),
            (full, 5.0, 0.0, Vec3::ONE, Vec3::new(0.5, 0.8, 1.0)),
        ]
    }

    /// The panes (untinted when `tinted` is false; in reverse object order when `reversed`) under
    /// unit ambient light: each pane's colour is its albedo.
    pub fn pane_scene(tinted: bool, reversed: bool) -> Scene {
        let cam = camera(40.0, 0.0, 5.0);
        let mut scene = single_object_scene(cam.clone(), square(1.0), Mat4::IDENTITY, None, W, H);
        scene.environment.background = BACKGROUND;
        scene.objects = panes()
            .into_iter()
            .map(|(r, z, a, c, t)| pane(pixel_triangle(&cam, r, z), c, a, if tinted { t } else { Vec3::ONE }))
            .collect();
        if reversed {
            scene.objects.reverse();
        }
        scene
    }

    /// `layers` as `transparency::composite` takes them (tints ignored unless `tinted`).
    pub fn composite_layers(layers: &[PaneSpec], tinted: bool) -> Vec<(f64, [f64; 3], [f64; 3])> {
        let f64x3 = |v: Vec3| v.as_dvec3().to_array();
        layers
            .iter()
            .map(|&(_, _, a, c, t)| (a as f64, f64x3(c), f64x3(if tinted { t } else { Vec3::ONE })))
            .collect()
    }

    /// Closed-form composite of `layers` over the background and the variance of one independent
    /// stochastic-coverage sample, per channel (`transparency::composite`).
    pub fn composite(layers: &[PaneSpec], tinted: bool) -> ([f64; 3], [f64; 3]) {
        shutter::transparency::composite(&composite_layers(layers, tinted), BACKGROUND.as_dvec3().to_array())
    }
}

/// Unused-import guard for helpers only some test binaries use.
pub fn _unused(_: Light) {}
