//! Issue 28, hard cases of numeric extremes: every technique against the CPU reference on tiny images.

use std::sync::Arc;

use glam::{Mat4, Quat, Vec3};
use shutter::image::LinearImage;
use shutter::metrics::compare;
use shutter::reference::{render_reference, ReferenceSettings};
use shutter::scene::builtin::builtin_mesh;
use shutter::scene::{Material, Mesh, Object, Scene};
use shutter::techniques::{RenderSettings, Renderer, ShadingRate, StochasticOptions, Technique};
use shutter_tests::{camera, renderer, same_sample_reference, single_object_scene, square};

fn reference(scene: &Scene, spp: u32, seed: u64) -> LinearImage {
    let (width, height) = (scene.image.width, scene.image.height);
    render_reference(
        scene,
        &ReferenceSettings { width, height, spp, seed, progress: false, shading: Default::default() },
    )
    .expect("reference")
}

/// Reference | actual | |difference|×4, each pixel 6×6, for a person to look at.
fn save_montage(name: &str, truth: &LinearImage, actual: &LinearImage) {
    const K: u32 = 6;
    let (w, h) = (truth.width, truth.height);
    let mut m = LinearImage::new(3 * w * K + 2 * K, h * K);
    for y in 0..h * K {
        for x in 0..w * K {
            let (a, b) = (truth.get(x / K, y / K), actual.get(x / K, y / K));
            let d = [0, 1, 2].map(|c| 4.0 * (a[c] - b[c]).abs());
            m.set(x, y, a);
            m.set(x + w * K + K, y, b);
            m.set(x + 2 * (w * K + K), y, [d[0], d[1], d[2], 1.0]);
        }
    }
    let _ =
        shutter::image_io::save_image(shutter_tests::output_dir().join(format!("precision-{name}.png")), &m);
}

fn assert_finite(name: &str, img: &LinearImage) {
    let bad = img.pixels.iter().filter(|p| p.iter().any(|c| !c.is_finite())).count();
    assert_eq!(bad, 0, "{name}: {bad} pixels with NaN/Inf");
}

fn sphere() -> Arc<Mesh> {
    Arc::new(builtin_mesh("sphere", Some(24)).expect("known").expect("builds"))
}

/// A forward technique (`pinhole` or `accumulation`) at S = `spp`: its RMSE against `truth`.
fn forward_rmse(
    r: &mut Renderer,
    name: &str,
    scene: &Scene,
    technique: Technique,
    spp: u32,
    truth: &LinearImage,
) -> f64 {
    let (w, h) = (scene.image.width, scene.image.height);
    let out = r.render(scene, technique, &RenderSettings::new(w, h, spp, 1)).expect("render");
    assert_finite(name, &out.image);
    let m = compare(truth, &out.image).unwrap();
    println!("{name}: RMSE {:.5} FLIP {:.5}", m.rmse, m.flip);
    save_montage(name, truth, &out.image);
    m.rmse
}

/// `stochastic` at `rate` against the reference with the same samples: its RMSE.
fn stochastic_rmse(r: &mut Renderer, name: &str, scene: &Scene, rate: ShadingRate, spp: u32) -> f64 {
    let (w, h) = (scene.image.width, scene.image.height);
    let o = StochasticOptions { shading: rate, ..Default::default() };
    let out = r
        .render(scene, Technique::STOCHASTIC, &RenderSettings::new(w, h, spp, 5).with_stochastic(o))
        .expect("stochastic render");
    assert_finite(name, &out.image);
    let same = same_sample_reference(scene, (w, h), spp, 5, rate, &out);
    let m = compare(&same, &out.image).unwrap();
    println!("{name}: RMSE {:.6} FLIP {:.5} vs the same-sample reference", m.rmse, m.flip);
    save_montage(name, &same, &out.image);
    m.rmse
}

/// Issue 28 item 1: near 1 mm, far 10 km, a red sphere at 2 km in front of a blue one at 3 km.
fn depth_order_scene() -> Scene {
    let mut cam = camera(40.0, 0.0, 2000.0);
    cam.near = 0.001;
    cam.far = 10000.0;
    let mut s = single_object_scene(cam, sphere(), Mat4::IDENTITY, None, 48, 32);
    let ball = |name: &str, scale: f32, z: f32, albedo: Vec3| Object {
        name: name.into(),
        mesh: sphere(),
        transforms: vec![(
            0.0,
            Mat4::from_scale_rotation_translation(Vec3::splat(scale), Quat::IDENTITY, Vec3::new(0.0, 0.0, z)),
        )],
        material: Material { albedo, ..Material::default() },
    };
    s.objects = vec![
        ball("blue", 700.0, -3000.0, Vec3::new(0.1, 0.1, 1.0)),
        ball("red", 300.0, -2000.0, Vec3::new(1.0, 0.1, 0.1)),
    ];
    s
}

/// Issue 28 item 1: `thin_lens_clip` floored the stored depth at 2⁻²⁰, which near = 1 mm reaches at
/// 1 km: both spheres got the same depth and the one drawn first (the farther) won — pinhole and
/// accumulation RMSE 0.199 and 0.201 against the reference. The floor is now relative to view depth.
#[test]
fn depth_order_kept_at_extreme_near_far_ratios() {
    let mut r = renderer();
    let scene = depth_order_scene();
    let truth = reference(&scene, 64, 1);
    for technique in [Technique::PINHOLE, Technique::ACCUMULATION] {
        let name = format!("depth-order-{}", technique.name());
        let rmse = forward_rmse(&mut r, &name, &scene, technique, 16, &truth);
        assert!(rmse < 0.03, "{name}: RMSE {rmse} (the far sphere in front?)");
    }
    let rmse = stochastic_rmse(&mut r, "depth-order-stochastic", &scene, ShadingRate::PerSample, 16);
    assert!(rmse < 1e-4, "stochastic: RMSE {rmse}");
}

/// The far end of the same guard: a face lying exactly on the far plane (depth 0 before the floor,
/// which fails the GREATER test against the cleared 0) is still drawn by the forward passes.
#[test]
fn forward_passes_keep_a_surface_on_the_far_plane() {
    let mut r = renderer();
    let mut cam = camera(40.0, 0.0, 8.0);
    cam.far = 8.0;
    let scene = single_object_scene(
        cam,
        square(4.0),
        Mat4::from_translation(Vec3::new(0.3, 0.2, -8.0)),
        None,
        48,
        32,
    );
    let truth = reference(&scene, 64, 1);
    let lit = truth.pixels.iter().filter(|p| p[0] > 0.99).count();
    assert!(lit > 200, "the face is missing from the reference ({lit} px)");
    for technique in [Technique::PINHOLE, Technique::ACCUMULATION] {
        let name = format!("far-plane-{}", technique.name());
        let rmse = forward_rmse(&mut r, &name, &scene, technique, 16, &truth);
        assert!(rmse < 0.03, "{name}: RMSE {rmse} (the face clipped?)");
    }
}
