//! The stochastic frame's two coverage paths (engine/src/techniques/stochastic/mask.rs): the mask path
//! per sample finds the same nearest hits as the visibility buffer, so its images are the same-sample
//! reference's — on the built-in scenes and on every hard case, with each shading rate the reference
//! mirrors and behind both hulls. The per-fragment mode's error is the hard-case matrix' business
//! (tests/tests/hard_cases.rs, its own column).

use shutter::hard_cases::CASES;
use shutter::metrics::compare;
use shutter::scene::builtin::builtin_scene;
use shutter::scene::Scene;
use shutter::techniques::stochastic::{Clusters, Coverage, MaskRate};
use shutter::techniques::{
    HullExpansion, RenderOutput, RenderSettings, Renderer, ShadingRate, StochasticOptions, Technique,
};
use shutter_tests::{max_abs_diff, renderer, same_sample_reference};

/// As tests/tests/stochastic.rs: only f32 rounding may differ from the same-sample reference.
const SAME_SAMPLES_RMSE_MAX: f64 = 1e-4;

fn render(
    r: &mut Renderer,
    scene: &Scene,
    (w, h): (u32, u32),
    spp: u32,
    o: StochasticOptions,
) -> RenderOutput {
    r.render(scene, Technique::STOCHASTIC, &RenderSettings::new(w, h, spp, 3).with_stochastic(o))
        .unwrap_or_else(|e| panic!("{} coverage: {e:#}", o.coverage.name()))
}

#[test]
fn mask_coverage_per_sample_is_the_same_sample_reference() {
    let mut r = renderer();
    let size = (96, 54);
    for name in ["default", "one-mover"] {
        let scene = builtin_scene(name).unwrap().unwrap();
        for (spp, expansion) in [(16, HullExpansion::GeometryShader), (8, HullExpansion::Compute)] {
            for shading in ShadingRate::ALL {
                let o = StochasticOptions {
                    coverage: Coverage::Mask(MaskRate::Sample),
                    shading,
                    expansion,
                    ..Default::default()
                };
                let out = render(&mut r, &scene, size, spp, o);
                assert!(out.stats.msaa_samples > 1, "{name}: the mask path ran without MSAA");
                assert_eq!(out.stats.msaa_samples * out.stats.passes, spp);
                let same = same_sample_reference(&scene, size, spp, 3, shading, &out);
                let m = compare(&same, &out.image).unwrap();
                println!(
                    "{name} S={spp} {} hull, {}: MSAA {}x × {} passes, RMSE {:.2e} vs the same-sample reference",
                    expansion.name(),
                    shading.name(),
                    out.stats.msaa_samples,
                    out.stats.passes,
                    m.rmse
                );
                assert!(m.rmse < SAME_SAMPLES_RMSE_MAX, "{name} {}: RMSE {}", shading.name(), m.rmse);
            }
        }
    }
}

/// Every hard case: the mask path per sample against the visibility path at the same samples (both
/// exact, so the images agree to rounding); the per-fragment mode is printed beside it.
#[test]
fn mask_coverage_per_sample_matches_the_visibility_buffer_on_every_hard_case() {
    let mut r = renderer();
    let (size, spp) = ((48, 27), 4);
    for case in CASES {
        let scene = case.scene().unwrap();
        let with = |coverage| StochasticOptions { coverage, ..Default::default() };
        let visibility = render(&mut r, &scene, size, spp, with(Coverage::Visibility));
        let mask = render(&mut r, &scene, size, spp, with(Coverage::Mask(MaskRate::Sample)));
        let fragment = render(&mut r, &scene, size, spp, with(Coverage::Mask(MaskRate::Fragment)));
        let m = compare(&visibility.image, &mask.image).unwrap();
        let f = compare(&visibility.image, &fragment.image).unwrap();
        println!(
            "{}: mask RMSE {:.2e} (max |Δ| {:.2e}); mask-per-fragment RMSE {:.4}",
            case.name,
            m.rmse,
            max_abs_diff(&visibility.image, &mask.image),
            f.rmse
        );
        // The same hits, ties included (mask.frag): the very same image, bit for bit.
        let d = max_abs_diff(&visibility.image, &mask.image);
        assert!(
            d == 0.0,
            "{}: mask per sample differs from the visibility buffer by {d} (RMSE {})",
            case.name,
            m.rmse
        );
    }
}

/// One sample per pass (M = 1: S = 1, and S = 2 on a device without 2x MSAA, lavapipe among them):
/// the mask target is single-sampled, its resolve reads it through single-sampled samplers
/// (`MASK_SINGLE_SAMPLE`), and the image is the visibility buffer's (bit for bit in one pass, to
/// rounding in two). Before that permutation both S failed validation (a multisampled sampler bound
/// to a one-sample image).
#[test]
fn mask_coverage_with_one_sample_per_pass_matches_the_visibility_buffer() {
    let mut r = renderer();
    let scene = builtin_scene("one-mover").unwrap().unwrap();
    for spp in [1, 2] {
        let with = |coverage| StochasticOptions { coverage, ..Default::default() };
        let visibility = render(&mut r, &scene, (48, 27), spp, with(Coverage::Visibility));
        for rate in [MaskRate::Sample, MaskRate::Fragment] {
            let mask = render(&mut r, &scene, (48, 27), spp, with(Coverage::Mask(rate)));
            assert_eq!(mask.stats.msaa_samples * mask.stats.passes, spp);
            if mask.stats.msaa_samples != 1 {
                continue; // a device with 2x MSAA: the multisampled path, tested above
            }
            // One sample per pixel: per fragment is per sample, so both rates are exact. In one pass the
            // very same image; in P passes the frame's mean adds P pass means where the visibility
            // path averages its one pass, so only the last bits of that sum may differ.
            let d = max_abs_diff(&visibility.image, &mask.image);
            let limit = if mask.stats.passes == 1 { 0.0 } else { 1e-6 };
            assert!(
                d <= limit,
                "S = {spp}, {rate:?}: the mask path differs from the visibility buffer by {d}"
            );
        }
    }
}

/// `--hull mesh` (shaders-glsl/stochastic/stochastic.mesh) hands the rasterizer the geometry shader's
/// triangles: the same image, bit for bit, on `default` and `one-mover` on both coverage paths, and
/// on every hard case on one of them (alternately). A device without `VK_EXT_mesh_shader` (Debian
/// 12's lavapipe) refuses it by name, and that refusal is what is tested there.
#[test]
fn mesh_hull_is_bit_identical_to_the_geometry_shader_hull() {
    let mut r = renderer();
    let with = |expansion, coverage| StochasticOptions { expansion, coverage, ..Default::default() };
    if !r.device().caps.mesh_shader {
        let scene = builtin_scene("default").unwrap().unwrap();
        let settings = RenderSettings::new(32, 18, 4, 3)
            .with_stochastic(with(HullExpansion::Mesh, Coverage::Visibility));
        let Err(err) = r.render(&scene, Technique::STOCHASTIC, &settings) else {
            panic!("a device without mesh shaders rendered --hull mesh")
        };
        let err = err.to_string();
        println!("no mesh shaders on this device: {err}");
        assert!(err.contains("VK_EXT_mesh_shader") && err.contains("--hull gs"), "{err}");
        return;
    }
    let mut scenes: Vec<(String, Scene, (u32, u32), u32)> = ["default", "one-mover"]
        .into_iter()
        .map(|n| (n.to_string(), builtin_scene(n).unwrap().unwrap(), (96, 54), 8))
        .collect();
    scenes.extend(CASES.iter().map(|c| (c.name.to_string(), c.scene().unwrap(), (48, 27), 4)));
    // The task shader's culling (`--hull mesh-task`) where the device has task shaders.
    let mut hulls = vec![HullExpansion::Mesh];
    if r.device().caps.task_shader {
        hulls.push(HullExpansion::MeshTask);
    }
    // Both coverage paths on the two built-in scenes; each hard case on one of them, alternately
    // (the hull is the vertex half of the pipeline and the coverage path its fragment half, so a
    // hull bug shows on either; all of them on both took 29 s of the suite on lavapipe 25.0).
    for (i, (name, scene, size, spp)) in scenes.iter().enumerate() {
        let coverages = match i {
            0 | 1 => vec![Coverage::Visibility, Coverage::Mask(MaskRate::Sample)],
            i if i % 2 == 0 => vec![Coverage::Visibility],
            _ => vec![Coverage::Mask(MaskRate::Sample)],
        };
        for coverage in coverages {
            let gs = render(&mut r, scene, *size, *spp, with(HullExpansion::GeometryShader, coverage));
            for &hull in &hulls {
                let mesh = render(&mut r, scene, *size, *spp, with(hull, coverage));
                let d = max_abs_diff(&gs.image, &mesh.image);
                assert!(
                    d == 0.0,
                    "{name}, {} coverage: hull {} differs from gs by {d}",
                    coverage.name(),
                    hull.name()
                );
            }
        }
    }
    let names: Vec<_> = hulls.iter().map(|h| h.name()).collect();
    println!("{names:?} hull = gs hull, bit for bit, on {} scenes (both coverage paths on 2)", scenes.len());
}

/// A one-sided sphere half out of the image, moving and defocused: `--hull mesh-task`'s task shader
/// drops its back-facing and off-image triangles before the mesh shader bounds them — the device
/// counts fewer mesh-shader invocations (where it counts them, `meshShaderQueries`) — and every hit
/// stays: the same hits and the same image as `--hull mesh`. Refused by name on a device without
/// task shaders.
#[test]
fn task_shader_culling_drops_work_and_no_hit() {
    let mut r = renderer();
    let scene = shutter::scene::file::parse_scene(
        "[image]\nwidth = 64\nheight = 36\nspp = 8\nseed = 1\n\
         [camera]\nposition = [0, 0, 4]\nlook_at = [0, 0, 0]\nvfov_deg = 40.0\n\
         aperture_radius = 0.05\nfocus_distance = 3.5\n\
         [[object]]\nname = \"ball\"\nmesh = \"sphere\"\ndetail = 16\n\
         [object.transform]\ntranslate = [2.6, 0, 0]\n\
         [object.transform_close]\ntranslate = [2.9, 0.1, 0]\n\
         [object.material]\none_sided = true\n",
        std::path::Path::new("."),
        "half-out",
    )
    .unwrap();
    let with = |expansion| StochasticOptions {
        expansion,
        instrumented: true,
        clusters: Clusters::Off,
        ..Default::default()
    };
    let settings = |h| RenderSettings::new(64, 36, 8, 3).with_stochastic(with(h));
    let caps = r.device().caps.clone();
    if !(caps.mesh_shader && caps.task_shader) {
        let Err(err) = r.render(&scene, Technique::STOCHASTIC, &settings(HullExpansion::MeshTask)) else {
            panic!("a device without task shaders rendered --hull mesh-task")
        };
        let err = err.to_string();
        println!("no task shaders on this device: {err}");
        assert!(err.contains("VK_EXT_mesh_shader"), "{err}");
        return;
    }
    let mesh = r.render(&scene, Technique::STOCHASTIC, &settings(HullExpansion::Mesh)).unwrap();
    let task = r.render(&scene, Technique::STOCHASTIC, &settings(HullExpansion::MeshTask)).unwrap();
    let (m, t) = (mesh.stats.counters.unwrap(), task.stats.counters.unwrap());
    println!(
        "mesh: {} fragments, {} tested, {} hit; mesh-task: {} fragments, {} tested, {} hit",
        m.fragments, m.samples_tested, m.samples_hit, t.fragments, t.samples_tested, t.samples_hit
    );
    assert!(m.samples_hit > 0, "the sphere is not in the image");
    assert_eq!(max_abs_diff(&mesh.image, &task.image), 0.0);
    assert_eq!(m.samples_hit, t.samples_hit, "a culled triangle had a hit");
    assert!(t.fragments <= m.fragments && t.samples_tested <= m.samples_tested);
    if caps.mesh_shader_queries {
        let (pm, pt) = (mesh.stats.pipeline_statistics.unwrap(), task.stats.pipeline_statistics.unwrap());
        println!("mesh: {}\nmesh-task: {}", pm.summary(), pt.summary());
        let (ms, ts) = (pm.mesh_shader_invocations.unwrap(), pt.mesh_shader_invocations.unwrap());
        // One task invocation per triangle slot of each cluster; the sphere's far half and the part
        // beyond the image edge launch no mesh workgroup.
        assert_eq!(pm.task_shader_invocations, None);
        assert!(pt.task_shader_invocations.unwrap() > 0);
        assert!(2 * ts < ms, "the task shader kept {ts} of {ms} mesh workgroups");
    }
}

#[test]
fn an_instrumented_frame_carries_the_devices_pipeline_statistics() {
    let mut r = renderer();
    let scene = builtin_scene("default").unwrap().unwrap();
    let plain = StochasticOptions { expansion: HullExpansion::GeometryShader, ..Default::default() };
    let counted = StochasticOptions { instrumented: true, ..plain };
    assert_eq!(
        render(&mut r, &scene, (48, 27), 4, plain).stats.pipeline_statistics,
        None,
        "timed frames count nothing"
    );
    let out = render(&mut r, &scene, (48, 27), 4, counted);
    if !r.device().caps.pipeline_statistics {
        assert_eq!(out.stats.pipeline_statistics, None);
        return;
    }
    let p = out.stats.pipeline_statistics.expect("pipeline statistics of an instrumented frame");
    let c = out.stats.counters.expect("sample counters");
    println!("{}; Shutter's fragments {}", p.summary(), c.fragments);
    // The coverage pass draws the triangles' bounds through the geometry shader (one invocation per
    // primitive drawn, each emitting a strip), and every fragment Shutter counts is a fragment
    // invocation the device counts (a driver may count more: Mesa 22.3 counts masked lanes).
    let (ia, gs) = (p.input_assembly_primitives.unwrap(), p.geometry_shader_invocations.unwrap());
    assert!(ia > 0 && gs > 0 && gs <= ia && p.geometry_shader_primitives.unwrap() >= gs, "{p:?}");
    assert!(p.clipping_primitives > 0 && p.compute_shader_invocations > 0, "{p:?}");
    assert!(p.fragment_shader_invocations >= c.fragments, "{p:?} {c:?}");
    if r.device().caps.mesh_shader {
        // Around mesh draws only the statistics Vulkan allows there are counted.
        let mesh = StochasticOptions { expansion: HullExpansion::Mesh, ..counted };
        let p = render(&mut r, &scene, (48, 27), 4, mesh).stats.pipeline_statistics.unwrap();
        assert_eq!((p.input_assembly_primitives, p.geometry_shader_invocations), (None, None), "{p:?}");
        assert!(p.fragment_shader_invocations >= c.fragments, "{p:?}");
        // The mesh shader's own count, where the device has meshShaderQueries (lavapipe 25.0 does).
        assert_eq!(p.mesh_shader_invocations.is_some(), r.device().caps.mesh_shader_queries, "{p:?}");
        assert!(p.mesh_shader_invocations.is_none_or(|n| n > 0), "{p:?}");
    }
}

/// The rasterizer's overestimation (`VK_EXT_conservative_rasterization`) in place of shader dilation
/// for the conservative hulls (engine/src/mirror/conservative.rs holds the selection and its CPU
/// tests). Where the device offers the extension, the stochastic frame on both coverage paths and
/// texture-space shading render the image they render with the feature disabled (shader dilation):
/// overestimation only adds fragments that find no sample or texel to keep. Where it does not
/// (neither lavapipe), the capabilities report no overestimation and a pipeline asked to
/// overestimate is refused, naming the extension.
#[test]
fn conservative_rasterization_replaces_shader_dilation_where_the_device_has_it() {
    use shutter::vk::{DeviceDesc, DeviceShared, Faces, Feature, GraphicsDesc, Pipeline, PipelineLayout};
    let mut r = renderer();
    if !r.device().caps.conservative_rasterization {
        assert!(r.device().caps.overestimation().is_none());
        let device = r.device();
        let vert = shutter::vk::ShaderModule::new(device, shutter::shaders::GRAPH_PROBE_PROBE_VERT).unwrap();
        let layout = PipelineLayout::new(device, &[], 0, ash::vk::ShaderStageFlags::VERTEX).unwrap();
        let desc = GraphicsDesc {
            name: "overestimating probe",
            stages: &[&vert],
            vertex_bindings: &[],
            vertex_attributes: &[],
            color_formats: &[],
            depth_format: None,
            samples: 1,
            sample_shading: None,
            faces: Faces::Both,
            depth_compare: ash::vk::CompareOp::ALWAYS,
            depth_write: false,
            overestimate: true,
        };
        let Err(err) = Pipeline::graphics(device, &layout, &desc) else {
            panic!("a device without VK_EXT_conservative_rasterization built an overestimating pipeline")
        };
        let err = err.to_string();
        println!("no conservative rasterization on this device: {err}");
        assert!(err.contains("VK_EXT_conservative_rasterization"), "{err}");
        return;
    }
    let o = r.device().caps.overestimation().unwrap();
    println!("overestimation {} px (extra up to {} px)", o.primitive_px, o.max_extra_px);
    let mut desc = DeviceDesc::from_env().unwrap();
    desc.validation = true;
    desc.disabled.push(Feature::ConservativeRasterization);
    let mut without = Renderer::new(DeviceShared::new(&desc).unwrap()).unwrap();
    assert!(without.device().caps.overestimation().is_none());
    let size = (96, 54);
    for name in ["default", "one-mover"] {
        let scene = builtin_scene(name).unwrap().unwrap();
        for coverage in [Coverage::Visibility, Coverage::Mask(MaskRate::Sample)] {
            for shading in [ShadingRate::PerSample, ShadingRate::TextureSpace] {
                let opts = StochasticOptions { coverage, shading, ..Default::default() };
                let a = render(&mut r, &scene, size, 8, opts);
                let b = render(&mut without, &scene, size, 8, opts);
                let d = max_abs_diff(&a.image, &b.image);
                println!(
                    "{name} {} {}: |overestimated − shader-dilated| ≤ {d}",
                    coverage.name(),
                    shading.name()
                );
                assert!(
                    d < 1e-5,
                    "{name} {} {}: the hulls' dilations differ by {d}",
                    coverage.name(),
                    shading.name()
                );
            }
        }
    }
}
