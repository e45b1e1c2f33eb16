//! What GPU renders write out: values beyond half float (65504) survive the forward passes and the EXR
//! (the per-pass colour target is RGBA32F), and identical renders give byte-identical EXR files.

use std::path::Path;

use shutter::image_io::{encode_exr, load_image, save_image};
use shutter::scene::file::parse_scene;
use shutter::techniques::{RenderSettings, Technique};
use shutter_tests::{output_dir, renderer};

/// A plane lit far beyond half float's range in front of a background beyond it too.
const BRIGHT: &str = r#"
[image]
width = 32
height = 18
spp = 4
seed = 1

[camera]
position = [0.0, 1.0, 6.0]
look_at = [0.0, 0.0, 0.0]
vfov_deg = 40.0

[[object]]
name = "ground"
mesh = "plane"
[object.transform]
scale = [2.0, 1.0, 2.0]
[object.material]
albedo = [0.5, 0.5, 0.5]

[[light]]
type = "directional"
direction = [0.0, -1.0, 0.0]
color = [200000.0, 300000.0, 400000.0]

[environment]
background = [100000.0, 70000.5, 1.0e6]
"#;

#[test]
fn values_beyond_half_float_survive_the_passes_and_the_exr() {
    let scene = parse_scene(BRIGHT, Path::new("."), "bright").expect("scene");
    let mut r = renderer();
    for technique in [Technique::PINHOLE, Technique::ACCUMULATION] {
        let out = r.render(&scene, technique, &RenderSettings::new(32, 18, 4, 1)).expect("render");
        let img = &out.image;
        assert!(img.all_finite(), "{}: non-finite pixels", technique.name());
        // The top-left corner sees only the background: every sample cleared to it, averaged exactly
        // (weights 1/4 of values exact in f32). A half-float target held 65504 or infinity.
        assert_eq!(img.get(0, 0)[..3], [100000.0, 70000.5, 1.0e6], "{}", technique.name());
        // The lit plane: 0.5 × 2e5 × N·L (+ ambient) in red, far above 65504.
        let lit = img.pixels.iter().filter(|p| p[2] < 1e6).map(|p| p[0]).fold(0.0, f32::max);
        assert!(lit > 65504.0 * 1.2, "{}: brightest lit red {lit}", technique.name());
        let path = output_dir().join(format!("bright-{}.exr", technique.name()));
        save_image(&path, img).expect("write EXR");
        assert_eq!(&load_image(&path).expect("read EXR"), img, "{}", technique.name());
    }
}

#[test]
fn identical_gpu_renders_write_byte_identical_exrs() {
    let scene = shutter::scene::builtin::builtin_scene("default").expect("built-in").expect("scene");
    let mut r = renderer();
    let settings = RenderSettings::new(96, 54, 4, 1);
    let dir = output_dir();
    let files: Vec<Vec<u8>> = (0..5)
        .map(|i| {
            let out = r.render(&scene, Technique::ACCUMULATION, &settings).expect("render");
            let path = dir.join(format!("exr-determinism-{i}.exr"));
            save_image(&path, &out.image).expect("write EXR");
            let bytes = std::fs::read(&path).expect("read EXR");
            assert_eq!(bytes, encode_exr(&out.image).expect("encode"));
            bytes
        })
        .collect();
    for (i, f) in files.iter().enumerate() {
        assert!(f == &files[0], "render {i}'s EXR differs from render 0's");
    }
}
