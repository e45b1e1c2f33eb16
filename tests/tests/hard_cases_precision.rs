//! Issue 28, hard cases of numeric extremes: every technique against the CPU reference on tiny images.

use std::sync::Arc;

use glam::{Mat4, Quat, Vec3};
use shutter::image::LinearImage;
use shutter::metrics::compare;
use shutter::reference::ReferenceSettings;
use shutter::scene::builtin::builtin_mesh;
use shutter::scene::{Light, Material, Mesh, Object, Scene};
use shutter::techniques::{RenderSettings, Renderer, ShadingRate, StochasticOptions, Technique};
use shutter_tests::render_reference;
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

/// Issue 28 item 2: a lit sphere whose z scale goes 0.5 → 0 → −0.5 over three motion keys (turned
/// so that the squashed axis is seen obliquely). `keys` are the three keys' times.
fn zero_scale_scene(keys: [f32; 3]) -> Scene {
    let key = |sz: f32| {
        Mat4::from_translation(Vec3::new(0.0, 0.0, -3.0))
            * Mat4::from_rotation_y(0.6)
            * Mat4::from_scale(Vec3::new(1.0, 1.0, sz))
    };
    let mut s = single_object_scene(camera(40.0, 0.0, 3.0), sphere(), key(0.5), None, 48, 32);
    s.objects[0].transforms = vec![(keys[0], key(0.5)), (keys[1], key(0.0)), (keys[2], key(-0.5))];
    s.environment.ambient = Vec3::splat(0.05);
    s.lights = vec![Light::Directional {
        direction: Vec3::new(-1.0, -0.5, -0.3).normalize(),
        color: Vec3::ONE,
        shadows: false,
    }];
    s
}

fn mean(img: &LinearImage) -> f64 {
    img.pixels.iter().map(|p| (p[0] + p[1] + p[2]) as f64).sum::<f64>() / (3 * img.pixels.len()) as f64
}

/// Issue 28 item 2: the singular key's inverse-transpose was NaN and poisoned the normals of both
/// segments around it: accumulation RMSE 0.375, pinhole (at mid-shutter, the singular key itself) 0.426,
/// texture-space 0.227; the stochastic rates and the reference agreed only because both fell back to
/// the faceted geometric normal. The cofactor matrix (`camera_space::normal_matrices`) is defined there.
#[test]
fn a_motion_key_of_scale_zero_does_not_poison_the_normals() {
    let mut r = renderer();
    let scene = zero_scale_scene([0.0, 0.5, 1.0]);
    let truth = reference(&scene, 256, 1);
    let rmse = forward_rmse(&mut r, "zero-scale-accumulation", &scene, Technique::ACCUMULATION, 64, &truth);
    assert!(rmse < 0.02, "accumulation: RMSE {rmse}");
    // Pinhole sees the mid-shutter key: the sphere squashed flat, against the reference of that instant.
    let mut frozen = scene.clone();
    frozen.objects[0].transforms = vec![(0.0, scene.objects[0].transforms[1].1)];
    let rmse = forward_rmse(
        &mut r,
        "zero-scale-pinhole",
        &scene,
        Technique::PINHOLE,
        16,
        &reference(&frozen, 64, 1),
    );
    assert!(rmse < 0.04, "pinhole: RMSE {rmse}");
    // Smooth shading, not facets: the reference's image is not the geometric normals' any more.
    let lit = truth.pixels.iter().filter(|p| p[0] > 0.2).count();
    assert!(lit > 300, "the sphere is not lit in the reference ({lit} px)");
    let rates = [
        ("per-sample", ShadingRate::PerSample),
        ("per-pixel", ShadingRate::PerPixel),
        (
            "decoupled",
            ShadingRate::Decoupled { grid: shutter::mirror::decoupled::GridKind::Pixel, deferred: false },
        ),
    ];
    for (name, rate) in rates {
        let rmse = stochastic_rmse(&mut r, &format!("zero-scale-{name}"), &scene, rate, 16);
        assert!(rmse < 1e-4, "stochastic {name}: RMSE {rmse}");
    }
    // Texture-space shading freezes each point's shading at one value per frame: here (a scale
    // through zero, half a turn per segment for `rate::shading_time_count`) the average over 8 times
    // weighed by the samples that see the point then (it shaded the flat disc of mid-shutter alone
    // before issue 28 item 3: RMSE 0.125, now 0.084), so it is only close; with the singular key off
    // mid-shutter (0.25) the segment after it, which NaN used to blacken, is shaded too.
    for keys in [[0.0, 0.5, 1.0], [0.0, 0.25, 1.0]] {
        let scene = zero_scale_scene(keys);
        let truth = reference(&scene, 256, 1);
        let o = StochasticOptions { shading: ShadingRate::TextureSpace, ..Default::default() };
        let out = r
            .render(&scene, Technique::STOCHASTIC, &RenderSettings::new(48, 32, 64, 5).with_stochastic(o))
            .unwrap();
        assert_finite("texture-space", &out.image);
        let m = compare(&truth, &out.image).unwrap();
        let ratio = mean(&out.image) / mean(&truth);
        println!(
            "zero-scale texture-space, keys {keys:?}: RMSE {:.5}, mean {ratio:.4} of the reference's",
            m.rmse
        );
        save_montage(&format!("zero-scale-texture-space-{}", keys[1]), &truth, &out.image);
        assert!(
            m.rmse < 0.15 && (0.8..1.25).contains(&ratio),
            "texture-space, keys {keys:?}: RMSE {}, mean ratio {ratio}",
            m.rmse
        );
    }
}

/// A mirroring transform (scale −1 along x) of a sphere is the same sphere: it must be lit the same.
/// The inverse-transpose kept the outward normal while the mirrored winding flips which side a ray
/// sees, so every technique and the reference turned it inwards and lit the sphere from behind.
#[test]
fn a_mirrored_object_is_lit_from_the_front() {
    let mut r = renderer();
    let plain = zero_scale_scene([0.0, 0.5, 1.0]);
    let mut plain = Scene { objects: plain.objects.clone(), ..plain };
    plain.objects[0].transforms = vec![(0.0, Mat4::from_translation(Vec3::new(0.0, 0.0, -3.0)))];
    let mut mirrored = plain.clone();
    mirrored.objects[0].transforms[0].1 *= Mat4::from_scale(Vec3::new(-1.0, 1.0, 1.0));
    let (a, b) = (reference(&plain, 64, 1), reference(&mirrored, 64, 1));
    let m = compare(&a, &b).unwrap();
    save_montage("mirrored-reference", &a, &b);
    println!("mirrored sphere: reference RMSE {:.5} against the plain one", m.rmse);
    assert!(m.rmse < 0.01, "the mirrored sphere is lit differently: RMSE {}", m.rmse);
    let rmse = forward_rmse(&mut r, "mirrored-accumulation", &mirrored, Technique::ACCUMULATION, 16, &b);
    assert!(rmse < 0.02, "accumulation: RMSE {rmse}");
}

/// Issue 28 item 4: a two-triangle ground plane scaled 1e7 (corners 1e7 m away, two behind the
/// camera), the camera 1 m above it, `far` beyond the corners. The absolute depth floor of item 1
/// raised each front corner's clip z from 0.045 to z·2⁻²⁰ ≈ 9.5, and clip z is interpolated linearly
/// along an edge, so the rasterizer's near-plane clip (z_c ≤ w_c) fell about 5 m from the eye instead
/// of 0.05: the near part of the plane vanished.
fn huge_plane_scene() -> Scene {
    let mut cam = camera(40.0, 0.0, 5.0);
    cam.open.position = Vec3::new(0.0, 1.0, 0.0);
    cam.open.look_at = Vec3::new(0.0, 0.0, -5.0);
    cam.far = 1e8;
    let ground = Mat4::from_scale(Vec3::splat(1e7)) * Mat4::from_rotation_x(-std::f32::consts::FRAC_PI_2);
    let mut s = single_object_scene(cam, square(2.0), ground, None, 48, 32);
    s.environment.ambient = Vec3::splat(0.05);
    s.environment.background = Vec3::new(0.2, 0.3, 0.5);
    s.lights = vec![Light::Directional {
        direction: Vec3::new(0.3, -1.0, 0.5).normalize(),
        color: Vec3::ONE,
        shadows: false,
    }];
    s
}

/// Accumulation RMSE 0.41 against the reference before the relative floor (measured), 0.0026 after
/// (pinhole 0.0042); the stochastic rasterizer, which intersects rays, was and is exact.
#[test]
fn huge_plane_in_the_forward_passes() {
    let mut r = renderer();
    let scene = huge_plane_scene();
    let truth = reference(&scene, 64, 1);
    for technique in [Technique::PINHOLE, Technique::ACCUMULATION] {
        let name = format!("huge-plane-{}", technique.name());
        let rmse = forward_rmse(&mut r, &name, &scene, technique, 16, &truth);
        assert!(rmse < 0.03, "{name}: RMSE {rmse}");
    }
    let rmse = stochastic_rmse(&mut r, "huge-plane-stochastic", &scene, ShadingRate::PerSample, 16);
    assert!(rmse < 1e-4, "stochastic: RMSE {rmse}");
}

/// Issue 28 item 5: vfov 0.001° from 20 km, lens 0.5 focused at 20 km.
fn telephoto_scene(position: Vec3) -> Scene {
    let mut cam = camera(0.001, 0.5, position.length());
    cam.open.position = position;
    cam.open.look_at = Vec3::ZERO;
    cam.far = 100000.0;
    let mut s = single_object_scene(cam, sphere(), Mat4::from_scale(Vec3::splat(0.1)), None, 48, 32);
    s.lights = vec![Light::Directional {
        direction: Vec3::new(-1.0, -0.5, -1.0).normalize(),
        color: Vec3::ONE,
        shadows: false,
    }];
    s.environment.ambient = Vec3::splat(0.1);
    s
}

/// Issue 28 item 5: through a 0.001° lens from 20 km one ulp of a camera-space vertex or of a ray
/// direction is about a fifth of a pixel, and the GPU rounded `model_view * p` and the inside test's
/// dot and cross products differently from the reference (fused multiply-adds, other orders): with the
/// camera off the axes, edge samples went to other triangles (RMSE 8.0e-4 per sample, 9.6e-4 per pixel
/// against the same samples). The stochastic path now computes both operation for operation as the CPU
/// (`transform_point_exact`, `inside.glsl`'s `*_exact`, all `precise`). On the axis (a view matrix
/// that is a translation) it was already exact.
#[test]
fn telephoto_from_20_km_matches_the_same_sample_reference() {
    let mut r = renderer();
    for (i, p) in [Vec3::new(0.0, 0.0, 20000.0), Vec3::new(3000.0, 5000.0, 19138.0)].into_iter().enumerate() {
        let scene = telephoto_scene(p);
        for (name, rate) in [("per-sample", ShadingRate::PerSample), ("per-pixel", ShadingRate::PerPixel)] {
            let rmse = stochastic_rmse(&mut r, &format!("telephoto-{i}-{name}"), &scene, rate, 16);
            assert!(rmse < 1e-4, "telephoto {p} {name}: RMSE {rmse}");
        }
    }
}

/// Issue 28 item 6, normals: an OBJ whose normals are 3e38 long. Their f32 length overflowed, so
/// `normalize` made them 0: accumulation shaded black (normalize(0) is NaN) while the reference fell
/// back to the face normal. Mesh::new normalises them in f64.
#[test]
fn huge_obj_normals_are_directions_in_every_technique() {
    let obj =
        "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nvn 0 0 3e38\nvn 0 3e38 3e38\nvn 3e38 0 3e38\nvn 0 0 3e38\n\
               f 1//1 2//2 3//3\nf 1//1 3//3 4//4\n";
    let mesh =
        Arc::new(shutter::scene::mesh::parse_obj(obj.as_bytes(), "huge-normals.obj", false).expect("parses"));
    assert!(mesh.normals.iter().all(|n| (n.length() - 1.0).abs() < 1e-6), "{:?}", mesh.normals);
    let mut scene = single_object_scene(
        camera(40.0, 0.0, 4.0),
        mesh,
        Mat4::from_translation(Vec3::new(0.0, 0.0, -4.0)),
        None,
        48,
        32,
    );
    scene.environment.ambient = Vec3::splat(0.05);
    scene.lights = vec![Light::Directional {
        direction: Vec3::new(-0.3, -0.4, -1.0).normalize(),
        color: Vec3::ONE,
        shadows: false,
    }];
    let mut r = renderer();
    let truth = reference(&scene, 64, 1);
    let lit = truth.pixels.iter().filter(|p| p[0] > 0.3).count();
    assert!(lit > 200, "the reference does not light the face ({lit} px)");
    for technique in [Technique::PINHOLE, Technique::ACCUMULATION] {
        let name = format!("huge-normals-{}", technique.name());
        let rmse = forward_rmse(&mut r, &name, &scene, technique, 16, &truth);
        assert!(rmse < 0.03, "{name}: RMSE {rmse}");
    }
    let rmse = stochastic_rmse(&mut r, "huge-normals-stochastic", &scene, ShadingRate::PerSample, 16);
    assert!(rmse < 1e-4, "stochastic: RMSE {rmse}");
}

/// Issue 28 item 6, the one rule for coordinates and colours (scene::extremes): a triangle at ±1e18
/// (the reference's inside test overflowed and dropped it, the rasterizers drew it) and two lights of
/// colour 3e38 (Inf pixels in every technique) are refused with a message naming the part — by the
/// GPU renderer, the reference and the scene file alike.
#[test]
fn coordinates_and_colours_beyond_the_limits_are_refused_everywhere() {
    let mut r = renderer();
    let far = Mesh::new(
        "far",
        vec![Vec3::new(-1e18, -1e18, -5.0), Vec3::new(1e18, -1e18, -5.0), Vec3::new(0.0, 1e18, -5.0)],
        vec![],
        vec![],
        vec![0, 1, 2],
    )
    .expect("mesh");
    let mut huge = single_object_scene(camera(40.0, 0.0, 4.0), Arc::new(far), Mat4::IDENTITY, None, 32, 18);
    huge.objects[0].name = "sky-plate".into();
    let mut bright = single_object_scene(
        camera(40.0, 0.0, 4.0),
        square(1.0),
        Mat4::from_translation(Vec3::new(0.0, 0.0, -3.0)),
        None,
        32,
        18,
    );
    bright.lights =
        vec![
            Light::Point { position: Vec3::new(0.0, 0.0, -2.0), color: Vec3::splat(3e38), shadows: false };
            2
        ];
    for (scene, part) in [(&huge, "object `sky-plate`"), (&bright, "light 0")] {
        for technique in [Technique::PINHOLE, Technique::ACCUMULATION, Technique::STOCHASTIC] {
            let e = match r.render(scene, technique, &RenderSettings::new(32, 18, 4, 1)) {
                Ok(_) => panic!("{}: {part} rendered", technique.name()),
                Err(e) => e.to_string(),
            };
            assert!(e.contains(part) && e.contains("MAX_"), "{}: {e}", technique.name());
        }
        let settings = ReferenceSettings {
            width: 32,
            height: 18,
            spp: 4,
            seed: 1,
            progress: false,
            shading: Default::default(),
        };
        let e =
            render_reference(scene, &settings).map(|_| ()).expect_err("the reference refuses").to_string();
        assert!(e.contains(part) && e.contains("MAX_"), "reference: {e}");
    }
    // The same through the scene file, naming the file.
    let file = "[camera]\nposition = [0, 0, 0]\nlook_at = [0, 0, -1]\n[[light]]\ntype = \"point\"\n\
                position = [0, 0, -2]\ncolor = [3e38, 3e38, 3e38]\n";
    let e = shutter::scene::file::parse_scene(file, std::path::Path::new("."), "bright")
        .expect_err("refused")
        .to_string();
    assert!(e.contains("light 0") && e.contains("MAX_COLOR"), "{e}");
    let file =
        "[camera]\nposition = [0, 0, 0]\nlook_at = [0, 0, -1]\n[[object]]\nname = \"big\"\nmesh = \"box\"\n\
                [object.transform]\nscale = 1e18\n";
    let e = shutter::scene::file::parse_scene(file, std::path::Path::new("."), "big")
        .expect_err("refused")
        .to_string();
    assert!(e.contains("object `big`") && e.contains("MAX_COORDINATE"), "{e}");
    // At the limits themselves every technique stays finite: two lights of MAX_COLOR on a surface of
    // albedo and specular MAX_COLOR, one of them on the surface.
    let mut edge = bright.clone();
    let max = shutter::limits::MAX_COLOR;
    edge.lights = vec![
        Light::Point { position: Vec3::new(0.0, 0.0, -3.0), color: Vec3::splat(max), shadows: false },
        Light::Directional { direction: -Vec3::Z, color: Vec3::splat(max), shadows: false },
    ];
    edge.objects[0].material.albedo = Vec3::splat(max);
    edge.objects[0].material.specular = max;
    edge.environment.ambient = Vec3::splat(max);
    for technique in [Technique::PINHOLE, Technique::ACCUMULATION, Technique::STOCHASTIC] {
        let out = r.render(&edge, technique, &RenderSettings::new(32, 18, 4, 1)).expect("renders");
        assert_finite(technique.name(), &out.image);
    }
    assert_finite("reference", &reference(&edge, 4, 1));
}
