//! The frame graph proved on the shapes the next techniques need, through the graph probe
//! (`engine/src/techniques/graph_probe.rs`, written only against the graph and world/view API), on
//! lavapipe with validation on: a depth pre-pass, a second view (a directional light's shadow map),
//! compute between draws reading both depth images, a colour pass with the pre-pass' depth loaded
//! (not cleared), host readbacks — each checked against the CPU; and a repeat node across submissions.

use std::any::Any;
use std::sync::Arc;

use glam::{Mat4, Vec2, Vec3};
use shutter::graph::{Access, MAX_PASSES_PER_SUBMIT};
use shutter::mirror::bounds::{sample_hit, MovingTriangle};
use shutter::scene::builtin::builtin_mesh;
use shutter::scene::{Environment, Light, Material, Mesh, Object, Scene, View};
use shutter::techniques::graph_probe::{pixel_point, GraphProbe};
use shutter::techniques::{FrameTechnique, PreparedFrame, RenderSettings, Renderer};
use shutter_tests::{camera, output_dir, renderer};

const SUN: Vec3 = Vec3::new(-0.4, -1.0, -0.3);

/// A floating box over a ground plane, lit by one directional light: the box shadows the ground.
fn probe_scene(w: u32, h: u32) -> Scene {
    let mesh = |name: &str, detail| Arc::new(builtin_mesh(name, detail).expect("built-in").expect("mesh"));
    let object = |name: &str, mesh: Arc<Mesh>, m: Mat4| Object {
        name: name.into(),
        mesh,
        transforms: vec![(0.0, m)],
        material: Material { albedo: Vec3::new(0.7, 0.6, 0.5), ..Material::default() },
    };
    let mut cam = camera(40.0, 0.0, 7.0);
    cam.open.position = Vec3::new(0.0, 4.0, 7.0);
    cam.open.look_at = Vec3::new(0.0, 0.5, 0.0);
    Scene {
        name: "graph probe".into(),
        image: shutter::scene::ImageSettings {
            width: w,
            height: h,
            spp: 1,
            seed: 1,
            display: Default::default(),
        },
        camera: cam,
        objects: vec![
            object("ground", mesh("plane", Some(4)), Mat4::from_scale(Vec3::splat(6.0))),
            object(
                "box",
                mesh("box", None),
                Mat4::from_translation(Vec3::new(0.0, 1.2, 0.0)) * Mat4::from_scale(Vec3::splat(0.7)),
            ),
        ],
        lights: vec![Light::Directional { direction: SUN, color: Vec3::splat(0.9), shadows: false }],
        environment: Environment {
            ambient: Vec3::splat(0.1),
            background: Vec3::new(0.2, 0.3, 0.5),
            ..Default::default()
        },
    }
}

fn prepare(r: &mut Renderer, scene: &Scene, shadow_size: u32, max_count: u32) -> PreparedFrame {
    let s = RenderSettings::new(scene.image.width, scene.image.height, 1, 1);
    r.prepare_with(scene, &s, |ctx| {
        let t: Box<dyn FrameTechnique> = Box::new(GraphProbe::new(ctx, shadow_size, max_count)?);
        Ok(t)
    })
    .expect("prepare the probe")
}

/// World-space triangles of the scene (shutter open).
fn world_triangles(scene: &Scene) -> Vec<[Vec3; 3]> {
    let mut out = vec![];
    for o in &scene.objects {
        for t in o.mesh.indices.chunks_exact(3) {
            out.push([0, 1, 2].map(|i| o.transform_open().transform_point3(o.mesh.positions[t[i] as usize])));
        }
    }
    out
}

/// Does the ray `o + s·d`, s > 0.3, hit any triangle? (Möller–Trumbore, two-sided.) Hits closer than
/// 0.3 are ignored: the probe's points are displaced across the light by up to two shadow-map texels
/// (< 0.15 here), which can put them just below the surface they lie on, while every real occluder is
/// farther (the box floats 0.5 above the ground).
fn occluded(tris: &[[Vec3; 3]], o: Vec3, d: Vec3) -> bool {
    tris.iter().any(|[a, b, c]| {
        let (e1, e2) = (*b - *a, *c - *a);
        let p = d.cross(e2);
        let det = e1.dot(p);
        if det.abs() < 1e-9 {
            return false;
        }
        let s = o - *a;
        let u = s.dot(p) / det;
        let q = s.cross(e1);
        let v = d.dot(q) / det;
        let t = e2.dot(q) / det;
        (0.0..=1.0).contains(&u) && v >= 0.0 && u + v <= 1.0 && t > 0.3
    })
}

#[test]
fn probe_depth_prepass_second_view_compute_and_loaded_depth() {
    let (w, h) = (96, 64);
    let scene = probe_scene(w, h);
    let mut r = renderer();
    let mut prepared = prepare(&mut r, &scene, 256, 1);
    let out = r.render_prepared(&mut prepared).expect("probe frame");
    let probe = prepared.technique_as::<GraphProbe>().expect("the probe");
    let res = &probe.results;
    let dir = output_dir();
    let _ = shutter::image_io::save_image(dir.join("graph-probe-loaded.png"), &res.loaded);
    let _ = shutter::image_io::save_image(dir.join("graph-probe-cleared.png"), &res.cleared);
    // The mask for a person to look at: depth as grey, shadowed points dark red.
    let mut mask_image = shutter::image::LinearImage::new(w, h);
    for (px, [z, lit]) in mask_image.pixels.iter_mut().zip(&res.mask) {
        let g = if *z > 0.0 { 2.0 / z } else { 0.0 };
        *px = if *lit > 0.5 { [g, g, g, 1.0] } else { [0.4 * g + 0.1, 0.0, 0.0, 1.0] };
    }
    let _ = shutter::image_io::save_image(dir.join("graph-probe-mask.png"), &mask_image);
    let names: Vec<&str> = out.timings.passes.iter().map(|(n, _)| n.as_str()).collect();
    println!("passes: {names:?}");
    for p in ["depth pre-pass", "shadow map", "shadow mask", "colour, depth loaded", "readback"] {
        assert!(names.contains(&p), "no timestamp scope `{p}` in {names:?}");
    }

    // Depth loaded, not cleared: EQUAL against the pre-pass gives exactly the ordinary image (a
    // cleared depth of 0 would pass nothing, leaving the background).
    assert_eq!(res.loaded, res.cleared, "colour with the loaded depth differs from the ordinary pass");
    let bg = scene.environment.background;
    let covered =
        res.loaded.pixels.iter().filter(|p| (Vec3::new(p[0], p[1], p[2]) - bg).length() > 1e-3).count();
    assert!(covered * 2 > res.loaded.pixels.len(), "only {covered} pixels show geometry");

    // Compute between draws, depth side: the view depth the compute pass read back from the pre-pass
    // equals the CPU's pinhole ray depth at each pixel centre.
    let camera_view = View::camera(&scene, w, h);
    let k = camera_view.intrinsics().expect("thin lens");
    let tris: Vec<MovingTriangle> = {
        let cs = &camera_view.space;
        let mut v = vec![];
        for (o, m) in scene.objects.iter().zip(&cs.objects) {
            for t in o.mesh.indices.chunks_exact(3) {
                v.push(MovingTriangle::fixed(
                    [0, 1, 2].map(|i| m.model_view[0].transform_point3(o.mesh.positions[t[i] as usize])),
                ));
            }
        }
        v
    };
    // The nearest hit of the pixel centre's pinhole ray: (view depth, triangle), depth 0 for none.
    let cpu_hit = |x: u32, y: u32| -> (f32, usize) {
        let px = Vec2::new(x as f32 + 0.5, y as f32 + 0.5);
        let hits = tris
            .iter()
            .enumerate()
            .filter_map(|(i, t)| sample_hit(t, &k, px, Vec2::ZERO, 0.0).map(|h| (h.depth_z, i)));
        hits.fold((0.0, 0), |a, b| if a.0 == 0.0 || b.0 < a.0 { b } else { a })
    };
    let (mut compared, mut edge_mismatch, mut worst) = (0, 0, 0.0f32);
    for y in 0..h {
        for x in 0..w {
            let gpu = res.mask[(y * w + x) as usize][0];
            let (cpu, _) = cpu_hit(x, y);
            if (gpu == 0.0) != (cpu == 0.0) {
                edge_mismatch += 1; // a silhouette pixel centre on an edge: fill rules differ
                continue;
            }
            if cpu > 0.0 {
                let rel = (gpu - cpu).abs() / cpu;
                worst = worst.max(rel);
                compared += 1;
            }
        }
    }
    println!("depth: {compared} pixels compared, worst relative error {worst:.2e}, {edge_mismatch} coverage mismatches");
    assert!(compared > (w * h / 2) as usize);
    assert!(worst < 1e-3, "GPU view depth differs from the ray's by {worst}");
    assert!(edge_mismatch <= (w * h / 100) as usize, "{edge_mismatch} pixels disagree on coverage");

    // Compute between draws, shadow side, through the second view: lit or not as the CPU's shadow
    // ray says, wherever the shadow-map texel size cannot change the answer.
    let world = world_triangles(&scene);
    let to_light = -SUN.normalize();
    let texel = match probe.light_view.projection {
        shutter::scene::Projection::Orthographic { half_extent, width, .. } => {
            2.0 * half_extent.x / width as f32
        }
        _ => unreachable!(),
    };
    let light_axes = {
        let m = probe.light_view.world_to_view[0].inverse();
        (m.transform_vector3(Vec3::X), m.transform_vector3(Vec3::Y))
    };
    let (mut lit, mut shadowed, mut ambiguous, mut grazing, mut wrong) = (0, 0, 0, 0, vec![]);
    for y in 0..h {
        for x in 0..w {
            let [z, gpu_lit] = res.mask[(y * w + x) as usize];
            if z == 0.0 {
                continue;
            }
            // A plain shadow map with a constant bias shows acne on surfaces the light grazes (the
            // box's sides here): those are left to the shadow-map work of the transparency issue.
            let [a, b, c] = world[cpu_hit(x, y).1];
            if (b - a).cross(c - a).normalize().dot(to_light).abs() < 0.5 {
                grazing += 1;
                continue;
            }
            let (_, p) = pixel_point(&camera_view, x, y, z);
            let offsets = [Vec3::ZERO, light_axes.0, -light_axes.0, light_axes.1, -light_axes.1];
            let answers: Vec<bool> =
                offsets.iter().map(|&o| !occluded(&world, p + 2.0 * texel * o, to_light)).collect();
            if answers.iter().any(|&a| a != answers[0]) {
                ambiguous += 1;
                continue;
            }
            if answers[0] {
                lit += 1;
            } else {
                shadowed += 1;
            }
            if (gpu_lit > 0.5) != answers[0] {
                wrong.push((x, y, answers[0]));
            }
        }
    }
    println!(
        "shadow: {lit} lit, {shadowed} shadowed, {ambiguous} near a shadow edge, {grazing} grazing; {} disagree",
        wrong.len()
    );
    assert!(lit > 100 && shadowed > 50, "the scene should have both lit and shadowed pixels");
    assert!(
        wrong.is_empty(),
        "{} of {} unambiguous pixels disagree with the CPU shadow ray, e.g. {:?}",
        wrong.len(),
        lit + shadowed,
        &wrong[..wrong.len().min(8)]
    );

    // The graph's bookkeeping: what each persistent resource saw last.
    let states = probe.states();
    println!("{states:?}");
    let (_, depth) = &states[0];
    assert_eq!(depth.layout, ash::vk::ImageLayout::DEPTH_STENCIL_READ_ONLY_OPTIMAL);
    let (_, mask) = &states[2];
    assert_eq!(mask.last_write, Some(Access::ComputeShaderWrite));
    assert!(mask.reads.contains(&Access::HostRead), "{mask:?}");
}

#[test]
fn repeat_node_runs_in_order_across_submissions() {
    let n = 2 * MAX_PASSES_PER_SUBMIT as u32 + 37;
    let scene = probe_scene(32, 24);
    let mut r = renderer();
    let mut prepared = prepare(&mut r, &scene, 32, n);
    let counts = r
        .run_with(&mut prepared, |t, inputs, frame| {
            let any: &mut dyn Any = t;
            any.downcast_mut::<GraphProbe>().expect("the probe").count_passes(frame, inputs, n)
        })
        .expect("count");
    assert_eq!(counts[0], n, "the counter after {n} passes");
    let out_of_order: Vec<(usize, u32)> =
        counts[1..].iter().copied().enumerate().filter(|&(k, c)| c != k as u32).take(5).collect();
    assert!(out_of_order.is_empty(), "passes saw the counter out of order: {out_of_order:?}");
}

/// One resource, one state: importing the same persistent buffer twice into a graph (two paths of a
/// frame naming the same triangles, say) gives the same handle, so the graph orders the second
/// use after the first. (Two handles would track two states and miss the barrier between them —
/// synchronization validation caught exactly that in the stochastic frame.)
#[test]
fn importing_a_resource_twice_gives_one_handle() {
    let scene = probe_scene(16, 16);
    let mut r = renderer();
    let mut prepared = prepare(&mut r, &scene, 16, 1);
    r.run_with(&mut prepared, |_, _, frame| {
        let device = frame.device().clone();
        let usage = ash::vk::BufferUsageFlags::STORAGE_BUFFER;
        let a =
            shutter::graph::Tracked::new(shutter::vk::Buffer::with_data(&device, "a", usage, &[0u32; 4])?);
        let b =
            shutter::graph::Tracked::new(shutter::vk::Buffer::with_data(&device, "b", usage, &[0u32; 4])?);
        let mut g = frame.graph();
        let (a1, a2, b1) =
            (g.import_buffer("a", &a), g.import_buffer("a again", &a), g.import_buffer("b", &b));
        assert_eq!(a1, a2, "the same buffer imported twice");
        assert_ne!(a1, b1, "two buffers");
        Ok(())
    })
    .expect("graph");
}

/// A descriptor set is written once, at prepare time, and what a dispatch reads through it is
/// declared on the pass: dispatching `accumulate.comp` (set 3: binding 0 read, binding 1 read and
/// written) with a set whose binding 0 is an image of the graph the pass did not declare panics with
/// the pipeline, the binding and the image (a forgotten declaration would be a missing barrier);
/// declaring it dispatches the very same set without complaint, and binding 2 — in the set, not used
/// by the shader — needs no declaration.
#[test]
fn a_dispatch_checks_the_pass_declared_what_its_sets_reach() {
    use ash::vk;
    use shutter::vk::{
        write_descriptors, DescriptorPool, DescriptorSetLayout, DescriptorWrite, Image, ImageDesc, Pipeline,
        PipelineLayout, ShaderModule,
    };

    let scene = probe_scene(16, 16);
    let mut r = renderer();
    let mut prepared = prepare(&mut r, &scene, 16, 1);
    let mut dispatch = |declare_a: bool| {
        r.run_with(&mut prepared, |_, _, frame| {
            let device = frame.device().clone();
            let desc = ImageDesc::new_2d(4, 4, vk::Format::R32G32B32A32_SFLOAT, vk::ImageUsageFlags::STORAGE);
            let image = |name: &str| Image::new(&device, name, desc).map(shutter::graph::Tracked::new);
            let (a, b, c) = (image("a")?, image("b")?, image("c")?);
            let (storage, compute) = (vk::DescriptorType::STORAGE_IMAGE, vk::ShaderStageFlags::COMPUTE);
            let empty = DescriptorSetLayout::new(&device, "empty", &[])?;
            let set3 = DescriptorSetLayout::new(
                &device,
                "accumulate",
                &[(0, storage, compute), (1, storage, compute), (2, storage, compute)],
            )?;
            let layout = PipelineLayout::new(&device, &[&empty, &empty, &empty, &set3], 4, compute)?;
            let shader = ShaderModule::new(&device, shutter::shaders::ACCUMULATION_ACCUMULATE_COMP)?;
            assert_eq!(shader.used_descriptors, [(3, 0), (3, 1)], "what accumulate.comp reads");
            let pipeline = Pipeline::compute(&device, "accumulate", &layout, &shader)?;
            let pool = DescriptorPool::new(&device, 1, &[(storage, 3)])?;
            let set = pool.allocate(&set3)?;
            write_descriptors(
                &device,
                set,
                &[
                    DescriptorWrite::StorageImage { binding: 0, view: a.view },
                    DescriptorWrite::StorageImage { binding: 1, view: b.view },
                    DescriptorWrite::StorageImage { binding: 2, view: c.view },
                ],
            );
            let mut g = frame.graph();
            let (ha, hb) = (g.import_image("a", &a), g.import_image("b", &b));
            g.import_image("c", &c);
            let pass = g.pass("accumulate").access(hb, Access::ComputeShaderReadWrite);
            let pass = if declare_a { pass.access(ha, Access::ComputeShaderReadOther) } else { pass };
            let (layout, pipeline) = (&layout, &pipeline);
            pass.record(move |ctx| {
                ctx.bind_pipeline(pipeline);
                ctx.bind_sets(vk::PipelineBindPoint::COMPUTE, layout, 3, &[set]);
                ctx.push(layout, &0.5f32);
                ctx.dispatch(1, 1, 1);
                Ok(())
            });
            frame.run(g)?;
            Ok(())
        })
    };
    dispatch(true).expect("a declared: the dispatch records and runs");
    let undeclared = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| dispatch(false)));
    let message = undeclared.expect_err("a undeclared: the dispatch must panic");
    let message = message.downcast_ref::<String>().cloned().unwrap_or_default();
    assert!(
        message.contains(
            "dispatch: pipeline `accumulate` reads set 3, binding 0: `a`, which the pass did not declare"
        ),
        "the panic: {message}"
    );
}

/// A technique prepared again on the same device takes the pipelines its first prepare made (the
/// device's `PipelineStore`) and renders the same image; another technique adds its own.
#[test]
fn a_second_prepare_reuses_the_devices_pipelines() {
    let mut r = renderer();
    assert!(r.device().pipelines.reuses(), "Shutter's own device enables maintenance4");
    let scene = shutter::scene::builtin::builtin_scene("one-mover").expect("known").expect("parses");
    let settings = RenderSettings::new(48, 27, 4, 3);
    let technique = shutter::techniques::Technique::STOCHASTIC;
    let first = r.render(&scene, technique, &settings).expect("first render");
    let made = r.device().pipelines.len();
    assert!(made > 0, "the store kept none of the stochastic frame's pipelines");
    let second = r.render(&scene, technique, &settings).expect("second render");
    assert_eq!(r.device().pipelines.len(), made, "the second prepare compiled pipelines again");
    assert_eq!(first.image.pixels, second.image.pixels, "a reused pipeline rendered another image");
    r.render(&scene, shutter::techniques::Technique::ACCUMULATION, &settings).expect("accumulation");
    assert!(r.device().pipelines.len() > made, "accumulation's pipelines are not the stochastic ones");
}

/// Pipelines that differ only in fixed state are different pipelines in the store: the mask path's
/// coverage pipelines at S = 1 and S = 4 (one pass each, of one and of four samples) have the same
/// shaders and differ in their sample count, and each, rendered after the other on one device, makes
/// the image a fresh device makes.
#[test]
fn pipelines_differing_only_in_fixed_state_are_not_shared() {
    use shutter::techniques::stochastic::{Coverage, MaskRate};
    use shutter::techniques::{StochasticOptions, Technique};
    let scene = shutter::scene::builtin::builtin_scene("one-mover").expect("known").expect("parses");
    let o = StochasticOptions { coverage: Coverage::Mask(MaskRate::Sample), ..Default::default() };
    let render = |r: &mut Renderer, spp| {
        let out = r
            .render(&scene, Technique::STOCHASTIC, &RenderSettings::new(48, 27, spp, 3).with_stochastic(o))
            .expect("render");
        assert_eq!((out.stats.msaa_samples, out.stats.passes), (spp, 1), "S = {spp}: one pass of S samples");
        out.image.pixels
    };
    let fresh = [1, 4].map(|spp| render(&mut renderer(), spp));
    let mut r = renderer();
    for (i, spp) in [1, 4, 1].into_iter().enumerate() {
        let fresh = &fresh[usize::from(spp == 4)];
        assert_eq!(&render(&mut r, spp), fresh, "render {i} (S = {spp}) on a used device");
    }
}
