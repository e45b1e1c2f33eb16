//! A test technique written only against the frame graph and the world/view API: it exercises every
//! shape the techniques still to come need, and `tests/tests/graph.rs` checks each against the CPU.
//! It is not in the registry (it estimates nothing; its image is a plain pinhole frame).
//!
//! One frame, one graph:
//! 1. `depth pre-pass` — the camera view's depth only (no fragment stage) into a persistent D32 image;
//! 2. `shadow map` — a **second view**, an orthographic directional-light view
//!    ([`View::directional_light`]), its depth into a second image;
//! 3. `shadow mask` — **compute between draws**: reads both depth images (sampled: the graph
//!    transitions them from attachments) and writes, per pixel, the view depth and whether the point
//!    is lit, to a host-visible buffer;
//! 4. `colour, depth loaded` — the forward shading with the pre-pass' depth **loaded, not cleared**,
//!    read-only, tested EQUAL: only the visible surface passes;
//! 5. `colour, depth cleared` — the same draws the ordinary way (cleared depth, GREATER), as a check;
//! 6. host reads of the mask and both colour images (**readback with its device→host barrier**).
//!
//! [`GraphProbe::count_passes`] runs a repeat node of N compute passes that count in a buffer, to
//! check iteration order and barriers across submissions.
//!
//! Shaders: `shaders-glsl/graph_probe/`. The scene is drawn at shutter open through the lens centre
//! (a still scene is the intended input; the light view does not move).

use ash::vk;
use bytemuck::{Pod, Zeroable};
use glam::{Mat4, Vec3};

use super::forward::ForwardPush;
use super::multipass::DEPTH_FORMAT;
use super::{FrameContext, FrameInputs, FrameTechnique, PrepareContext, TechniqueFrame};
use crate::error::{Error, Result};
use crate::gpu::layout::{shared_struct, vertex_input, SharedStruct, FRAME_SET_INDEX, TECHNIQUE_SET_INDEX};
use crate::gpu::{GpuView, GpuWorld};
use crate::graph::{Access, FrameGraph, Load, Store, Tracked};
use crate::image::LinearImage;
use crate::scene::{Light, Projection, View};
use crate::shaders;
use crate::vk::{
    write_descriptors, Binding, Buffer, DescriptorPool, DescriptorSetLayout, DescriptorWrite, Faces,
    GraphicsDesc, Image, ImageDesc, Pipeline, PipelineLayout, Sampler, ShaderModule,
};

/// Set 3 of `shadow_mask.comp`.
pub const MASK_SET: [Binding; 3] = [
    Binding { binding: 0, ty: vk::DescriptorType::COMBINED_IMAGE_SAMPLER, block: "camera_depth" },
    Binding { binding: 1, ty: vk::DescriptorType::COMBINED_IMAGE_SAMPLER, block: "shadow_depth" },
    Binding { binding: 2, ty: vk::DescriptorType::STORAGE_BUFFER, block: "Mask" },
];

/// Set 3 of `count.comp`.
pub const COUNT_SET: [Binding; 1] =
    [Binding { binding: 0, ty: vk::DescriptorType::STORAGE_BUFFER, block: "Counts" }];

/// Push constants of `shadow_mask.comp`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct MaskPush {
    pub camera_to_light: [f32; 16],
    /// Orthographic half extents x, y; near, far of the light view.
    pub light: [f32; 4],
    pub bias: f32,
}

/// Push constants of `count.comp`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct CountPush {
    pub pass_index: u32,
}

/// For the reflection test.
pub const GRAPH_PROBE_STRUCTS: &[SharedStruct] = &[
    shared_struct!("Push", MaskPush, [camera_to_light, light, bias]),
    shared_struct!("Push", CountPush, [pass_index]),
];

/// Reversed-depth bias of the shadow test (the light view's depth range is 2 scene radii).
pub const SHADOW_BIAS: f32 = 2e-3;
const COLOR_FORMAT: vk::Format = vk::Format::R32G32B32A32_SFLOAT;

/// What the last frame produced besides its image.
#[derive(Clone, Debug, Default)]
pub struct ProbeResults {
    /// The colour pass with the pre-pass depth loaded (also the frame's image).
    pub loaded: LinearImage,
    /// The same draws with depth cleared and written.
    pub cleared: LinearImage,
    /// Per pixel (row-major): view depth of the pre-pass (0 where it saw nothing) and 1 if lit.
    pub mask: Vec<[f32; 2]>,
}

/// The probe: pipelines, the light's view, persistent images and the mask buffer.
pub struct GraphProbe {
    depth_only: Pipeline,
    colour_loaded: Pipeline,
    colour_cleared: Pipeline,
    draw_layout: PipelineLayout,
    mask_pipeline: Pipeline,
    mask_layout: PipelineLayout,
    mask_set: vk::DescriptorSet,
    count_pipeline: Pipeline,
    count_layout: PipelineLayout,
    count_set: vk::DescriptorSet,
    light: GpuView,
    mask_push: MaskPush,
    depth: Tracked<Image>,
    shadow: Tracked<Image>,
    mask: Tracked<Buffer>,
    counts: Tracked<Buffer>,
    max_count: u32,
    loaded: Tracked<Image>,
    cleared: Tracked<Image>,
    /// The light view on the CPU (for tests).
    pub light_view: View,
    pub results: ProbeResults,
    _set_layouts: [DescriptorSetLayout; 2],
    _pool: DescriptorPool,
    _sampler: Sampler,
    _shaders: Vec<ShaderModule>,
}

impl GraphProbe {
    /// The probe for the scene's first directional light, with a `shadow_size²` shadow map, and a
    /// counting buffer for repeat tests of up to `max_count` passes.
    pub fn new(ctx: &PrepareContext<'_>, shadow_size: u32, max_count: u32) -> Result<Self> {
        let (device, world) = (ctx.device, ctx.world);
        let direction = ctx
            .scene
            .lights
            .iter()
            .find_map(|l| match *l {
                Light::Directional { direction, .. } => Some(direction),
                _ => None,
            })
            .ok_or_else(|| Error::Unsupported("the graph probe needs a directional light".into()))?;
        let light_view =
            View::directional_light(ctx.scene, "light 0", direction, shadow_size).ok_or_else(|| {
                Error::Unsupported("the graph probe needs geometry and a non-zero light".into())
            })?;
        let light = GpuView::new(device, world, &light_view)?;
        let Projection::Orthographic { half_extent, near, far, .. } = light_view.projection else {
            return Err(Error::Unsupported("a directional light's view is orthographic".into()));
        };
        // Camera space at shutter open -> world -> light space.
        let camera_to_light = light_view.world_to_view[0] * ctx.camera.world_to_view[0].inverse();
        let mask_push = MaskPush {
            camera_to_light: camera_to_light.to_cols_array(),
            light: [half_extent.x, half_extent.y, near, far],
            bias: SHADOW_BIAS,
        };

        let vert = ShaderModule::new(device, shaders::GRAPH_PROBE_PROBE_VERT)?;
        let frag = ShaderModule::new(device, shaders::FORWARD_FORWARD_FRAG)?;
        let mask_shader = ShaderModule::new(device, shaders::GRAPH_PROBE_SHADOW_MASK_COMP)?;
        let count_shader = ShaderModule::new(device, shaders::GRAPH_PROBE_COUNT_COMP)?;
        let draw_layout = world.pipeline_layout(
            device,
            &[],
            std::mem::size_of::<ForwardPush>() as u32,
            vk::ShaderStageFlags::VERTEX | vk::ShaderStageFlags::FRAGMENT,
        )?;
        let (bindings, attributes) = vertex_input();
        let draw = |name: &str, stages: &[&ShaderModule], colour: bool, compare, write| {
            Pipeline::graphics(
                device,
                &draw_layout,
                &GraphicsDesc {
                    name,
                    stages,
                    vertex_bindings: &bindings,
                    vertex_attributes: &attributes,
                    color_formats: if colour { &[COLOR_FORMAT] } else { &[] },
                    depth_format: Some(DEPTH_FORMAT),
                    samples: 1,
                    sample_shading: None,
                    faces: Faces::Both,
                    depth_compare: compare,
                    depth_write: write,
                    overestimate: false,
                },
            )
        };
        let depth_only = draw("probe depth", &[&vert], false, vk::CompareOp::GREATER, true)?;
        let colour_loaded =
            draw("probe colour (depth loaded)", &[&vert, &frag], true, vk::CompareOp::EQUAL, false)?;
        let colour_cleared =
            draw("probe colour (depth cleared)", &[&vert, &frag], true, vk::CompareOp::GREATER, true)?;

        let stages = vk::ShaderStageFlags::COMPUTE;
        let mask_set_layout =
            DescriptorSetLayout::from_table(device, "probe mask set layout", &MASK_SET, stages)?;
        let count_set_layout =
            DescriptorSetLayout::from_table(device, "probe count set layout", &COUNT_SET, stages)?;
        let e = &world.empty_layout;
        let mask_layout = world.pipeline_layout(
            device,
            &[e, &mask_set_layout],
            std::mem::size_of::<MaskPush>() as u32,
            stages,
        )?;
        let count_layout = world.pipeline_layout(
            device,
            &[e, &count_set_layout],
            std::mem::size_of::<CountPush>() as u32,
            stages,
        )?;
        let mask_pipeline = Pipeline::compute(device, "probe shadow mask", &mask_layout, &mask_shader)?;
        let count_pipeline = Pipeline::compute(device, "probe count", &count_layout, &count_shader)?;

        let (w, h) = ctx.camera.size();
        let depth_usage = vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT | vk::ImageUsageFlags::SAMPLED;
        let depth = Tracked::new(Image::new(
            device,
            "probe depth",
            ImageDesc::new_2d(w, h, DEPTH_FORMAT, depth_usage),
        )?);
        let shadow = Tracked::new(Image::new(
            device,
            "probe shadow map",
            ImageDesc::new_2d(shadow_size, shadow_size, DEPTH_FORMAT, depth_usage),
        )?);
        let colour_usage = vk::ImageUsageFlags::COLOR_ATTACHMENT | vk::ImageUsageFlags::TRANSFER_SRC;
        let colour = |name| Image::new(device, name, ImageDesc::new_2d(w, h, COLOR_FORMAT, colour_usage));
        let loaded = Tracked::new(colour("probe colour (depth loaded)")?);
        let cleared = Tracked::new(colour("probe colour (depth cleared)")?);
        let storage = vk::BufferUsageFlags::STORAGE_BUFFER;
        let mask = Tracked::new(Buffer::with_data(
            device,
            "probe mask",
            storage,
            &vec![[0f32; 2]; (w * h) as usize],
        )?);
        let counts = Tracked::new(Buffer::with_data(
            device,
            "probe counts",
            storage,
            &vec![0u32; 1 + max_count as usize],
        )?);

        let pool = DescriptorPool::for_tables(device, 2, &[(&MASK_SET, 1), (&COUNT_SET, 1)])?;
        let sampler = Sampler::nearest_clamp(device, "probe depth sampler")?;
        let mask_set = pool.allocate(&mask_set_layout)?;
        write_descriptors(
            device,
            mask_set,
            &[
                DescriptorWrite::SampledImage { binding: 0, view: depth.view, sampler: sampler.raw },
                DescriptorWrite::SampledImage { binding: 1, view: shadow.view, sampler: sampler.raw },
                DescriptorWrite::storage_buffer(2, &mask),
            ],
        );
        let count_set = pool.allocate(&count_set_layout)?;
        write_descriptors(device, count_set, &[DescriptorWrite::storage_buffer(0, &counts)]);
        Ok(GraphProbe {
            depth_only,
            colour_loaded,
            colour_cleared,
            draw_layout,
            mask_pipeline,
            mask_layout,
            mask_set,
            count_pipeline,
            count_layout,
            count_set,
            light,
            mask_push,
            depth,
            shadow,
            mask,
            counts,
            max_count,
            loaded,
            cleared,
            light_view,
            results: ProbeResults::default(),
            _set_layouts: [mask_set_layout, count_set_layout],
            _pool: pool,
            _sampler: sampler,
            _shaders: vec![vert, frag, mask_shader, count_shader],
        })
    }

    /// Draws every object seen from `view` with `pipeline` (shutter open, lens centre, no jitter).
    fn draw<'a>(
        &'a self,
        world: &'a GpuWorld,
        view: &'a GpuView,
        pipeline: &'a Pipeline,
    ) -> impl FnMut(&mut crate::graph::PassContext<'_>) -> Result<()> + 'a {
        move |ctx| {
            ctx.bind_pipeline(pipeline);
            let still =
                super::forward::PassSample { time: 0.0, lens: glam::Vec2::ZERO, jitter: glam::Vec2::ZERO };
            let push = |i: usize| ForwardPush::new(view, i, &still);
            world.record_object_draws(ctx, view, pipeline, &self.draw_layout, |_| true, push, |_| None);
            Ok(())
        }
    }

    /// A graph of one repeat node: `n` passes of `count.comp`, then the host read of the counts.
    /// Returns the counter and the count each pass saw.
    pub fn count_passes(
        &mut self,
        frame: &mut FrameContext<'_>,
        inputs: &FrameInputs<'_>,
        n: u32,
    ) -> Result<Vec<u32>> {
        if n > self.max_count {
            return Err(Error::Unsupported(format!("{n} passes > the probe's {} counts", self.max_count)));
        }
        self.counts.get_mut().write(&vec![0u32; 1 + n as usize])?;
        let this = &*self;
        let mut g: FrameGraph<'_> = frame.graph();
        let counts = g.import_buffer("probe counts", &this.counts);
        let frame_set = inputs.camera.frame_set;
        g.repeat(n, |g| {
            g.pass("count")
                .access(counts, Access::ComputeShaderReadOther)
                .access(counts, Access::ComputeShaderWrite)
                .record(move |ctx| {
                    let (layout, bind) = (&this.count_layout, vk::PipelineBindPoint::COMPUTE);
                    ctx.bind_pipeline(&this.count_pipeline);
                    ctx.bind_sets(bind, layout, FRAME_SET_INDEX, &[frame_set]);
                    ctx.bind_sets(bind, layout, TECHNIQUE_SET_INDEX, &[this.count_set]);
                    ctx.push(layout, &CountPush { pass_index: ctx.iteration });
                    ctx.dispatch(1, 1, 1);
                    Ok(())
                });
            Ok(())
        })?;
        g.host_read(counts);
        frame.run(g)?;
        this.counts.read_u32s(1 + n as usize)
    }

    /// The persistent resources' synchronization states (for tests of the graph's bookkeeping).
    pub fn states(&self) -> [(&'static str, crate::graph::ResourceState); 3] {
        [("depth", self.depth.state()), ("shadow", self.shadow.state()), ("mask", self.mask.state())]
    }
}

impl FrameTechnique for GraphProbe {
    fn render(&mut self, inputs: &FrameInputs<'_>, frame: &mut FrameContext<'_>) -> Result<TechniqueFrame> {
        let this = &*self;
        let (world, camera) = (inputs.world, inputs.camera);
        let mut g = frame.graph();
        let depth = g.import_image("probe depth", &this.depth);
        let shadow = g.import_image("probe shadow map", &this.shadow);
        let mask = g.import_buffer("probe mask", &this.mask);
        let loaded = g.import_image("probe colour (depth loaded)", &this.loaded);
        let cleared = g.import_image("probe colour (depth cleared)", &this.cleared);
        let (w, h) = (camera.width, camera.height);
        let scratch = g.create_image(
            "probe scratch depth",
            ImageDesc::new_2d(w, h, DEPTH_FORMAT, vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT),
        )?;
        let background = world.background;

        g.pass("depth pre-pass").depth(depth, Load::Clear(0.0), Store::Store).record(this.draw(
            world,
            camera,
            &this.depth_only,
        ));
        g.pass("shadow map").depth(shadow, Load::Clear(0.0), Store::Store).record(this.draw(
            world,
            &this.light,
            &this.depth_only,
        ));
        let sampled = Access::ComputeShaderReadSampledImageOrUniformTexelBuffer;
        g.pass("shadow mask")
            .access(depth, sampled)
            .access(shadow, sampled)
            .overwrite(mask, Access::ComputeShaderWrite)
            .record(move |ctx| {
                let (layout, bind) = (&this.mask_layout, vk::PipelineBindPoint::COMPUTE);
                ctx.bind_pipeline(&this.mask_pipeline);
                ctx.bind_sets(bind, layout, FRAME_SET_INDEX, &[camera.frame_set]);
                ctx.bind_sets(bind, layout, TECHNIQUE_SET_INDEX, &[this.mask_set]);
                ctx.push(layout, &this.mask_push);
                ctx.dispatch(w.div_ceil(8), h.div_ceil(8), 1);
                Ok(())
            });
        g.pass("colour, depth loaded")
            .color(loaded, Load::Clear(background), Store::Store)
            .depth_read_only(depth)
            .record(this.draw(world, camera, &this.colour_loaded));
        g.pass("colour, depth cleared")
            .color(cleared, Load::Clear(background), Store::Store)
            .depth(scratch, Load::Clear(0.0), Store::DontCare)
            .record(this.draw(world, camera, &this.colour_cleared));
        g.host_read(mask);
        let loaded = g.read_back(loaded)?;
        let cleared = g.read_back(cleared)?;
        let mut result = frame.run(g)?;
        let bytes = self.mask.mapped()?;
        let f = |c: &[u8]| f32::from_ne_bytes([c[0], c[1], c[2], c[3]]);
        let mask: Vec<[f32; 2]> =
            bytes[..(w * h) as usize * 8].chunks_exact(8).map(|c| [f(c), f(&c[4..])]).collect();
        self.results =
            ProbeResults { loaded: result.take_image(loaded), cleared: result.take_image(cleared), mask };
        Ok(TechniqueFrame {
            image: self.results.loaded.clone(),
            passes: 1,
            msaa_samples: 1,
            counters: None,
            clusters: vec![],
        })
    }
}

/// The camera-space point a camera pixel's view depth `z` puts on the pixel centre's pinhole ray, and
/// its world position (the CPU side of `shadow_mask.comp`, for tests).
pub fn pixel_point(camera: &View, x: u32, y: u32, z: f32) -> (Vec3, Vec3) {
    let k = camera.intrinsics().expect("a camera view");
    let tan = k.pixel_to_tan(glam::Vec2::new(x as f32 + 0.5, y as f32 + 0.5));
    let p = Vec3::new(tan.x * z, tan.y * z, -z);
    let to_world: Mat4 = camera.world_to_view[0].inverse();
    (p, to_world.transform_point3(p))
}

/// What `graph_probe/` expects of the probe's layouts: `probe.vert` shares the forward pipeline's
/// layout (sets 0 and 1, [`ForwardPush`]; its fragment stage is `forward.frag`); the compute passes
/// have set 2 empty and [`MASK_SET`] or [`COUNT_SET`] as set 3, with [`MaskPush`] or [`CountPush`].
pub const SHADER_INTERFACES: &[crate::gpu::layout::ShaderInterface] = &[
    crate::gpu::layout::ShaderInterface::technique(
        &["graph_probe/probe.vert"],
        None,
        None,
        Some(super::forward::FORWARD_STRUCTS[0]),
    ),
    crate::gpu::layout::ShaderInterface::technique(
        &["graph_probe/shadow_mask.comp"],
        None,
        Some(&MASK_SET),
        Some(GRAPH_PROBE_STRUCTS[0]),
    ),
    crate::gpu::layout::ShaderInterface::technique(
        &["graph_probe/count.comp"],
        None,
        Some(&COUNT_SET),
        Some(GRAPH_PROBE_STRUCTS[1]),
    ),
];
