//! Adaptive texture-space shading on the GPU (docs/ATSS.md), so far its per-triangle shading rate:
//! `shaders-glsl/texture_space/rate.glsl` (run by `ShadingRates`) against its CPU mirror
//! `shutter::texture_space::rate::triangle_level`, triangle by triangle, on built-in scenes with
//! depth of field, motion, Spot's own uvs and generated charts.

use glam::{Vec2, Vec3};
use shutter::scene::builtin::builtin_scene;
use shutter::scene::camera_space::CameraSpaceScene;
use shutter::techniques::texture_space::ShadingRates;
use shutter::techniques::{FrameTechnique, RenderSettings};
use shutter::texture_space::rate::triangle_level;
use shutter_tests::renderer;

/// Relative difference of the minor radius allowed between the GPU (f32 throughout) and the CPU (f32
/// derivatives, f64 ellipse): the footprint's determinant cancels for a triangle seen nearly edge-on.
const RADIUS_TOLERANCE: f64 = 1e-2;

/// Same level, minor radius within [`RADIUS_TOLERANCE`], and a footprint at the same vertices —
/// except where the radius sits within that tolerance of a power of two, where rounding may pick
/// either neighbouring level.
#[test]
fn gpu_shading_rates_match_the_cpu_mirror() {
    let (w, h, finest) = (320, 180, 4096);
    let mut r = renderer();
    for name in ["default", "focus-sweep", "glass", "foliage"] {
        let scene = builtin_scene(name).expect("built-in").expect("parses");
        let settings = RenderSettings::new(w, h, 1, 1);
        let mut prepared = r
            .prepare_with(&scene, &settings, |ctx| {
                let t: Box<dyn FrameTechnique> = Box::new(ShadingRates::new(ctx, finest)?);
                Ok(t)
            })
            .expect("prepare");
        r.render_prepared(&mut prepared).expect("run");
        let rates = prepared.technique_as::<ShadingRates>().expect("the probe");
        let intrinsics = scene.camera.intrinsics(w, h);
        let space = CameraSpaceScene::new(&scene);
        let (mut compared, mut levels_differ, mut near_boundary) = (0usize, 0usize, 0usize);
        let mut worst = 0.0f64;
        let mut histogram = vec![0usize; rates.levels() as usize];
        for (i, o) in scene.objects.iter().enumerate() {
            let (Some(gpu), Some((shading, coords))) = (&rates.results[i], rates.object(i)) else { continue };
            let motion = &space.objects[i];
            let (j, s) = motion.keys.locate(0.5);
            let (mv0, mv1) = (motion.model_view[j], motion.model_view[j + 1]);
            for (t, g) in gpu.iter().enumerate() {
                let tri: [Vec3; 3] = [0, 1, 2].map(|k| {
                    let p = o.mesh.positions[o.mesh.indices[3 * t + k] as usize];
                    let (a, b) = (mv0.transform_point3(p), mv1.transform_point3(p));
                    a + (b - a) * s
                });
                let tex: [Vec2; 3] = [0, 1, 2].map(|k| coords[3 * t + k]);
                let cpu = triangle_level(&intrinsics, tri, tex, rates.levels());
                let what = format!("{name} `{}` ({shading}) triangle {t}", o.name);
                assert_eq!(g.valid, cpu.is_some(), "{what}: GPU {g:?}, CPU {cpu:?}");
                let Some(cpu) = cpu else { continue };
                compared += 1;
                let (a, b) = (g.radius_texels as f64, cpu.radius_texels);
                let rel = (a - b).abs() / b.max(1e-3);
                worst = worst.max(rel);
                assert!(rel <= RADIUS_TOLERANCE, "{what}: radius GPU {a} vs CPU {b}");
                let spacing = (g.spacing_px - cpu.spacing_px).abs() / cpu.spacing_px;
                assert!(
                    spacing < 1e-5,
                    "{what}: grid spacing GPU {} vs CPU {}",
                    g.spacing_px,
                    cpu.spacing_px
                );
                if g.level != cpu.level {
                    let to_boundary = (b.log2() - b.log2().round()).abs();
                    assert!(
                        to_boundary < 2e-3,
                        "{what}: level GPU {} vs CPU {} (r = {b})",
                        g.level,
                        cpu.level
                    );
                    near_boundary += 1;
                    levels_differ += 1;
                }
                histogram[g.level as usize] += 1;
            }
        }
        println!(
            "{name}: {compared} triangles, radius within {worst:.1e} (relative), levels differ on {levels_differ} \
             ({near_boundary} at a power-of-two radius); triangles per level {histogram:?}"
        );
        assert!(compared >= 40, "{name}: {compared} triangles compared");
    }
}

/// Too many generated charts for the atlas: a clear error naming the sizes, not a silent overlap.
/// (`focus-sweep`'s displaced sphere has 327,680 triangles and no uvs of its own: at 2048² its
/// charts with 2-texel gutters do not fit; at 4096² they do.)
#[test]
fn charts_that_do_not_fit_are_a_clear_error() {
    let scene = builtin_scene("focus-sweep").expect("built-in").expect("parses");
    let mut r = renderer();
    let settings = RenderSettings::new(64, 36, 1, 1);
    let err = r
        .prepare_with(&scene, &settings, |ctx| {
            let t: Box<dyn FrameTechnique> = Box::new(ShadingRates::new(ctx, 2048)?);
            Ok(t)
        })
        .map(|_| ())
        .expect_err("2048² is too small for its charts")
        .to_string();
    assert!(err.contains("2048") && err.contains("per-triangle charts"), "{err}");
}
