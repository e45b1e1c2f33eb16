//! Bad requests get clear errors, never panics: device selection, limits, missing features, alpha.

use glam::{Mat4, Vec3};
use shutter::techniques::{RenderSettings, Technique};
use shutter::vk::{DeviceDesc, DeviceShared};
use shutter::Error;
use shutter_tests::{camera, renderer, single_object_scene, square};

#[test]
fn unknown_device_name_lists_the_devices() {
    let err =
        DeviceShared::new(&DeviceDesc { device_name: Some("no-such-gpu-xyz".into()), ..Default::default() })
            .err()
            .expect("must fail");
    let msg = err.to_string();
    assert!(matches!(err, Error::NoDevice { .. }), "{msg}");
    assert!(msg.contains("no-such-gpu-xyz") && msg.contains("available devices"), "{msg}");
}

#[test]
fn absurd_sizes_and_sample_counts_are_rejected_with_the_limit() {
    let scene = single_object_scene(
        camera(40.0, 0.0, 5.0),
        square(1.0),
        Mat4::from_translation(-5.0 * Vec3::Z),
        None,
        8,
        8,
    );
    let mut r = renderer();
    for (s, what) in [
        (RenderSettings::new(100_000, 8, 1, 0), "width"),
        (RenderSettings::new(8, 0, 1, 0), "height"),
        (RenderSettings::new(8, 8, 0, 0), "spp"),
        (RenderSettings::new(8, 8, 10_000_000, 0), "spp"),
    ] {
        let err = r.render(&scene, Technique::ACCUMULATION, &s).expect_err("must fail");
        let msg = err.to_string();
        assert!(matches!(err, Error::Limit { .. }) && msg.contains(what) && msg.contains("..="), "{msg}");
    }
}

#[test]
fn missing_device_feature_is_a_clear_error() {
    let r = renderer();
    let mut caps = r.device().caps.clone();
    caps.geometry_shader = false;
    let err =
        caps.require(shutter::vk::Feature::GeometryShader, "the stochastic rasterizer's hull").unwrap_err();
    let msg = err.to_string();
    assert!(
        msg.contains("geometryShader") && msg.contains("stochastic") && msg.contains(&caps.device_name),
        "{msg}"
    );
    assert!(r.device().caps.require(shutter::vk::Feature::TimestampQueries, "bench").is_ok());
}

/// The transparency methods a technique does not have are refused with the ones it has (the stochastic
/// rasterizer renders stochastic transparency, tints included, but not depth-based ST or peeling), and
/// shadows of moving casters by the stochastic rasterizer (its maps are of one time).
#[test]
fn transparency_methods_and_moving_shadows_are_refused_where_missing() {
    let mut scene = single_object_scene(
        camera(40.0, 0.0, 5.0),
        square(1.0),
        Mat4::from_translation(-5.0 * Vec3::Z),
        None,
        8,
        8,
    );
    scene.objects[0].material.alpha = 0.5;
    scene.objects[0].material.tint = Vec3::new(1.0, 0.5, 0.5);
    let mut r = renderer();
    r.render(&scene, Technique::STOCHASTIC, &RenderSettings::new(8, 8, 1, 0)).expect("tints in stochastic");
    let mut depth_based = RenderSettings::new(8, 8, 1, 0);
    depth_based.transparency =
        shutter::transparency::TransparencyMethod::DepthBased { alpha_correction: true };
    let err = r.render(&scene, Technique::STOCHASTIC, &depth_based).unwrap_err();
    assert!(err.to_string().contains("depth-based") && err.to_string().contains("pinhole"), "{err}");
    scene.objects[0].material.tint = Vec3::ONE;
    scene.objects[0].material.alpha = 1.0;
    scene.lights = vec![shutter::scene::Light::Point { position: Vec3::Y, color: Vec3::ONE, shadows: true }];
    // Shadows of still casters render everywhere; of moving ones, not in the stochastic rasterizer.
    for t in [Technique::PINHOLE, Technique::STOCHASTIC] {
        assert!(r.render(&scene, t, &RenderSettings::new(8, 8, 1, 0)).is_ok(), "{t}");
    }
    scene.objects[0].transforms.push((1.0, Mat4::from_translation(Vec3::new(0.5, 0.0, -5.0))));
    let err = r.render(&scene, Technique::STOCHASTIC, &RenderSettings::new(8, 8, 1, 0)).unwrap_err();
    assert!(err.to_string().contains("moving") && err.to_string().contains("accumulation"), "{err}");
}

#[test]
fn probe_names_the_device_and_lavapipe() {
    let r = renderer();
    let caps = &r.device().caps;
    let text = caps.to_string();
    assert!(text.contains(&caps.device_name) && text.contains("MSAA counts"), "{text}");
    if caps.device_name.contains("llvmpipe") {
        assert!(caps.is_lavapipe() && text.contains("lavapipe"), "{text}");
        // Lavapipe offers 1x and 4x MSAA, a geometry shader and sample-rate shading (docs/MODEL.md).
        assert!(caps.has(shutter::vk::Feature::Msaa(4)) && caps.geometry_shader && caps.sample_rate_shading);
    }
}

/// Issue 28, item 16: a scene built in code is checked before it renders, as a scene file is, with the
/// file's words. Before, `vfov_deg = 0` hung the GPU path, a negative focus distance rendered a wrong
/// image and `near = 0` rendered.
#[test]
fn scenes_built_in_code_are_validated_like_files() {
    let scene = single_object_scene(
        camera(40.0, 0.05, 5.0),
        square(1.0),
        Mat4::from_translation(-5.0 * Vec3::Z),
        None,
        16,
        9,
    );
    let mut r = renderer();
    let settings = RenderSettings::new(16, 9, 4, 1);
    r.render(&scene, Technique::ACCUMULATION, &settings).expect("the valid scene renders");
    type Edit<'a> = &'a dyn Fn(&mut shutter::scene::Scene);
    let cases: [(Edit, &str); 4] = [
        (&|s| s.camera.vfov_deg = 0.0, "camera.vfov_deg: 0 is out of range: must be in [0.001, 180) degrees"),
        (&|s| s.camera.focus_distance = -1.0, "camera.focus_distance: -1 is out of range: must be > 0"),
        (&|s| s.camera.near = 0.0, "camera.near: 0 is out of range: must be > 0"),
        (
            &|s| s.objects[0].material.roughness = 0.0,
            "material.roughness: 0 is out of range: must be in (0, 1]",
        ),
    ];
    for (edit, words) in cases {
        let mut bad = scene.clone();
        edit(&mut bad);
        for technique in [Technique::PINHOLE, Technique::ACCUMULATION, Technique::STOCHASTIC, Technique::AUTO]
        {
            let start = std::time::Instant::now();
            let err = r.render(&bad, technique, &settings).expect_err("must be refused");
            let msg = err.to_string();
            assert!(matches!(err, Error::Scene { .. }) && msg.ends_with(words), "{technique}: {msg}");
            assert!(
                start.elapsed().as_secs_f64() < 5.0,
                "{technique}: refused only after {:?}",
                start.elapsed()
            );
        }
        // The same words from the reference and from `Scene::validate` itself.
        assert!(bad.validate().unwrap_err().to_string().ends_with(words));
        let reference = shutter::reference::ReferenceSettings {
            width: 16,
            height: 9,
            spp: 1,
            seed: 1,
            progress: false,
            shading: Default::default(),
        };
        let e = shutter::reference::render_reference(&bad, &reference).unwrap_err().to_string();
        assert!(e.ends_with(words), "{e}");
    }
}

/// Issue 28, items 10 and 11: a scene with no object, and one whose only object has no triangle (an
/// OBJ of zero-area faces loads as an empty mesh), under a shadow-casting light: every technique and
/// every stochastic shading rate (texture-space included), both hull expansions and the instrumented
/// frame `bench` and `bounds` count with, render the background — equal to the reference's — without
/// a panic or a validation message; the planner plans them.
#[test]
fn empty_scenes_render_the_background_in_every_technique() {
    use shutter::reference::ReferenceSettings;
    use shutter::techniques::compute_hull::HullExpansion;
    use shutter::techniques::registry::TECHNIQUES;
    use shutter::techniques::stochastic::{ShadingRate, StochasticOptions};
    use shutter_tests::render_reference;
    let (w, h) = (16, 9);
    let mut empty = single_object_scene(camera(40.0, 0.1, 5.0), square(1.0), Mat4::IDENTITY, None, w, h);
    empty.environment.background = Vec3::new(0.2, 0.3, 0.4);
    empty.lights =
        vec![shutter::scene::Light::Directional { direction: -Vec3::Y, color: Vec3::ONE, shadows: true }];
    let mut no_triangles = empty.clone();
    no_triangles.objects[0].mesh = std::sync::Arc::new(
        shutter::scene::Mesh::new(
            "zero-area",
            vec![Vec3::ZERO, Vec3::X, 2.0 * Vec3::X],
            vec![],
            vec![],
            vec![],
        )
        .unwrap(),
    );
    empty.objects.clear();
    let mut r = renderer();
    for scene in [&empty, &no_triangles] {
        let settings = ReferenceSettings {
            width: w,
            height: h,
            spp: 4,
            seed: 1,
            progress: false,
            shading: Default::default(),
        };
        let reference = render_reference(scene, &settings).expect("reference");
        let _ = shutter::plan::Plan::for_view(scene, &shutter::scene::View::camera(scene, w, h), 0.0);
        let mut runs: Vec<(String, Technique, RenderSettings)> =
            TECHNIQUES.iter().map(|&t| (t.name().to_string(), t, RenderSettings::new(w, h, 4, 1))).collect();
        for shading in ShadingRate::NAMED {
            // Both hull expansions for one rate (the other rates take the default's).
            let expansions =
                if shading == ShadingRate::PerSample { &[HullExpansion::Compute][..] } else { &[] };
            for &expansion in std::iter::once(&HullExpansion::default()).chain(expansions) {
                let options =
                    StochasticOptions { shading, expansion, instrumented: true, ..Default::default() };
                let name = format!("stochastic {} {}", shading.name(), expansion.name());
                runs.push((
                    name,
                    Technique::STOCHASTIC,
                    RenderSettings::new(w, h, 4, 1).with_stochastic(options),
                ));
            }
        }
        for (name, t, s) in runs {
            // `interleaved` estimates one-bounce light, which the scene must ask for (nothing
            // bounces here: the reference's image is the same).
            let mut scene = scene.clone();
            if t == Technique::INTERLEAVED {
                scene.environment.indirect = shutter::scene::Indirect::OneBounce;
            }
            let scene = &scene;
            let out =
                r.render(scene, t, &s).unwrap_or_else(|e| panic!("{} {name}: {e}", scene.objects.len()));
            let diff = shutter_tests::max_abs_diff(&out.image, &reference);
            assert!(diff < 1e-6, "{} object(s), {name}: off the background by {diff}", scene.objects.len());
            if let Some(c) = out.stats.counters {
                assert_eq!(c.samples_hit, 0, "{name}");
            }
        }
    }
}
