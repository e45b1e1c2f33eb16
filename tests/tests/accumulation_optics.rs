//! The circle of confusion and the motion streak measured on GPU images match the model's formulas.
//!
//! A tiny bright square (side `a` px) seen through a disk aperture becomes a uniform disc of radius
//! R = |φ(z)|; moving `L` px during a box shutter, a uniform segment of length L. Both are measured
//! from second moments of the accumulation image: per axis, variance = (shape) + a²/12 + 1/12 (the
//! square's own extent and the pixel box), with a uniform disc contributing R²/4 per axis and a
//! uniform segment L²/12 along its direction.

use glam::{Mat4, Vec3};
use shutter::techniques::{RenderSettings, Technique};
use shutter_tests::{camera, moments, renderer, single_object_scene, square};

const W: u32 = 96;
const H: u32 = 96;

#[test]
fn defocus_blur_radius_matches_circle_of_confusion() {
    let cam = camera(40.0, 0.4, 2.0);
    let k = cam.intrinsics(W, H);
    let z = 8.0;
    let px_world = z / k.pixel_scale; // one pixel at depth z
    let a = 1.0f32; // square side in pixels
    let scene = single_object_scene(
        cam,
        square(a * px_world),
        Mat4::from_translation(Vec3::new(0.0, 0.0, -z)),
        None,
        W,
        H,
    );
    let phi = k.circle_of_confusion_px(z).abs();
    assert!(phi > 15.0, "test wants a large blur, got {phi}");
    let mut r = renderer();
    let out = r.render(&scene, Technique::ACCUMULATION, &RenderSettings::new(W, H, 1024, 7)).expect("render");
    let _ = shutter::image_io::save_image(shutter_tests::output_dir().join("coc-disc.png"), &out.image);
    let (_, (cx, cy), (vxx, vyy)) = moments(&out.image);
    let a2 = (a * a) as f64;
    let radius = (2.0 * (vxx + vyy) - (a2 + 1.0) / 3.0).sqrt();
    println!("measured radius {radius:.3} px, |phi| {phi:.3} px, centroid ({cx:.2}, {cy:.2})");
    assert!((radius / phi as f64 - 1.0).abs() < 0.05, "radius {radius} vs |phi| {phi}");
    assert!((cx - W as f64 / 2.0).abs() < 0.5 && (cy - H as f64 / 2.0).abs() < 0.5, "centroid moved");
}

#[test]
fn motion_streak_length_matches_screen_motion() {
    let cam = camera(40.0, 0.0, 5.0);
    let k = cam.intrinsics(W, H);
    let z = 5.0;
    let px_world = z / k.pixel_scale;
    let a = 1.0f32;
    let motion_px = 40.0f32;
    let open = Mat4::from_translation(Vec3::new(-0.5 * motion_px * px_world, 0.0, -z));
    let close = Mat4::from_translation(Vec3::new(0.5 * motion_px * px_world, 0.0, -z));
    let scene = single_object_scene(cam, square(a * px_world), open, Some(close), W, H);
    let mut r = renderer();
    let out = r.render(&scene, Technique::ACCUMULATION, &RenderSettings::new(W, H, 512, 3)).expect("render");
    let _ = shutter::image_io::save_image(shutter_tests::output_dir().join("motion-streak.png"), &out.image);
    let (_, (cx, _), (vxx, vyy)) = moments(&out.image);
    let length = (12.0 * vxx - a as f64 * a as f64 - 1.0).sqrt();
    println!("measured streak {length:.3} px, expected {motion_px} px; vertical variance {vyy:.4}");
    assert!((length / motion_px as f64 - 1.0).abs() < 0.05, "streak {length} vs {motion_px}");
    assert!((cx - W as f64 / 2.0).abs() < 0.5);
    // Across the streak only the square and the pixel box remain: the 1-px square centred on the pixel
    // boundary y = 48, box-filtered, is a tent of half-width 1 px sampled at pixel centres 47.5 and
    // 48.5 → weights ½, ½ → variance exactly 0.25 px² (no smear from the motion).
    assert!((vyy - 0.25).abs() < 0.01, "vertical spread {vyy}");
}

#[test]
fn same_seed_gives_bit_identical_images() {
    let cam = camera(40.0, 0.2, 3.0);
    let open = Mat4::from_translation(Vec3::new(-0.3, 0.0, -5.0));
    let close = Mat4::from_translation(Vec3::new(0.3, 0.1, -4.0));
    let scene = single_object_scene(cam, square(1.0), open, Some(close), 64, 48);
    let mut r = renderer();
    for t in [Technique::PINHOLE, Technique::ACCUMULATION] {
        let s = RenderSettings::new(64, 48, 16, 11);
        let a = r.render(&scene, t, &s).expect("render");
        let b = r.render(&scene, t, &s).expect("render");
        assert!(a.image == b.image, "{t:?} not deterministic");
        if t == Technique::ACCUMULATION {
            let c = r.render(&scene, t, &RenderSettings { seed: 12, ..s }).expect("render");
            assert!(a.image != c.image, "seed has no effect");
        }
    }
}
