//! The plain forward path shared by `pinhole`, `accumulation` and `auto`'s still, sharp objects: the
//! objects rendered with one (u, v, t) and one subpixel offset per pass, into the passes of a
//! [`MultipassFrame`]. Shaders: `shaders-glsl/forward/`.

use ash::vk;
use bytemuck::{Pod, Zeroable};
use glam::Vec2;

use super::multipass::{FrameUse, MultipassFrame, PassDraws, COLOR_FORMAT, DEPTH_FORMAT};
use super::{FrameContext, FrameInputs, FrameTechnique, PrepareContext, TechniqueFrame};
use crate::error::Result;
use crate::gpu::layout::{shared_struct, vertex_input, SharedStruct};
use crate::gpu::{GpuView, GpuWorld};
use crate::graph::{FrameGraph, PassContext};
use crate::shaders;
use crate::vk::{Device, GraphicsDesc, Pipeline, PipelineLayout, ShaderModule};

/// One pass' sample of the lens and shutter.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PassSample {
    /// Shutter time in [0, 1] (already warped by the shutter curve).
    pub time: f32,
    /// Lens point in unit aperture coordinates (already mapped to the aperture shape).
    pub lens: Vec2,
    /// Subpixel offset in pixels, in [-0.5, 0.5)²: the pass samples pixel centre + jitter.
    pub jitter: Vec2,
}

/// Push constants of `forward.vert`/`forward.frag`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct ForwardPush {
    /// The object (its material).
    pub object: u32,
    /// Shutter time (the lights').
    pub time: f32,
    pub lens: [f32; 2],
    pub jitter: [f32; 2],
    /// The object's key segment holding `time` (its `ObjectViews` index) and the time within it
    /// ([`GpuView::segment_at`]).
    pub segment: u32,
    pub segment_time: f32,
}

impl ForwardPush {
    /// Object `object` of `view` at `pass`'s time, lens point and jitter.
    pub fn new(view: &GpuView, object: usize, pass: &PassSample) -> Self {
        let (segment, segment_time) = view.segment_at(object, pass.time);
        ForwardPush {
            object: object as u32,
            time: pass.time,
            lens: pass.lens.to_array(),
            jitter: pass.jitter.to_array(),
            segment,
            segment_time,
        }
    }
}

/// For the reflection test.
pub const FORWARD_STRUCTS: &[SharedStruct] =
    &[shared_struct!("Push", ForwardPush, [object, time, lens, jitter, segment, segment_time])];

/// The forward pipeline for one MSAA count.
pub struct ForwardPipeline {
    pipeline: Pipeline,
    layout: PipelineLayout,
    _shaders: Vec<ShaderModule>,
}

impl ForwardPipeline {
    pub fn new(device: &Device, world: &GpuWorld, samples: u32) -> Result<Self> {
        let vert = ShaderModule::new(device, shaders::FORWARD_FORWARD_VERT)?;
        let frag = ShaderModule::new(device, shaders::FORWARD_FORWARD_FRAG)?;
        let layout = world.pipeline_layout(
            device,
            &[],
            std::mem::size_of::<ForwardPush>() as u32,
            vk::ShaderStageFlags::VERTEX | vk::ShaderStageFlags::FRAGMENT,
        )?;
        let (bindings, attributes) = vertex_input();
        let pipeline = Pipeline::graphics(
            device,
            &layout,
            &GraphicsDesc {
                name: "forward",
                stages: &[&vert, &frag],
                vertex_bindings: &bindings,
                vertex_attributes: &attributes,
                color_formats: &[COLOR_FORMAT],
                depth_format: Some(DEPTH_FORMAT),
                samples,
                sample_shading: None,
                // Two-sided surfaces: nothing is culled (the reference intersects both sides too).
                cull_mode: vk::CullModeFlags::NONE,
                front_face: vk::FrontFace::COUNTER_CLOCKWISE,
                depth_compare: vk::CompareOp::GREATER,
                depth_write: true,
            },
        )?;
        Ok(ForwardPipeline { pipeline, layout, _shaders: vec![vert, frag] })
    }

    /// Draws the objects `i` with `include(i)` seen from `view` with one pass' (t, lens, jitter).
    pub fn record_draws(
        &self,
        d: &Device,
        cmd: vk::CommandBuffer,
        world: &GpuWorld,
        view: &GpuView,
        pass: &PassSample,
        include: impl Fn(usize) -> bool,
    ) {
        unsafe { d.raw.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::GRAPHICS, self.pipeline.raw) };
        let push = |i: usize| ForwardPush::new(view, i, pass);
        let stages = vk::ShaderStageFlags::VERTEX | vk::ShaderStageFlags::FRAGMENT;
        world.record_object_draws(d, cmd, view, &self.layout, stages, include, push, |_| None);
    }
}

/// The forward path of every object: one [`PassSample`] per pass of the frame.
pub struct ForwardDraws {
    pipeline: ForwardPipeline,
    samples: Vec<PassSample>,
}

impl ForwardDraws {
    /// Pass p drawn with `samples[p]`, at `msaa` samples.
    pub fn new(device: &Device, world: &GpuWorld, msaa: u32, samples: Vec<PassSample>) -> Result<Self> {
        Ok(ForwardDraws { pipeline: ForwardPipeline::new(device, world, msaa)?, samples })
    }
}

impl PassDraws for ForwardDraws {
    fn add_frame_passes<'a>(
        &'a self,
        _g: &mut FrameGraph<'a>,
        _inputs: &FrameInputs<'a>,
    ) -> Result<FrameUse> {
        // Reads only the world and the view (host-written before the frame): nothing to declare.
        Ok(FrameUse::default())
    }
    fn record(&self, ctx: &mut PassContext<'_>, inputs: &FrameInputs<'_>, pass: u32) {
        let sample = &self.samples[pass as usize];
        self.pipeline.record_draws(ctx.device, ctx.cmd, inputs.world, inputs.camera, sample, |_| true);
    }
}

/// Every object on the forward path, one [`PassSample`] per pass: `pinhole` and `accumulation`.
pub struct ForwardTechnique {
    frame: MultipassFrame,
    draws: ForwardDraws,
}

impl ForwardTechnique {
    /// `samples.len()` passes at `msaa` samples per pass, every object drawn.
    pub fn new(ctx: &PrepareContext<'_>, msaa: u32, samples: Vec<PassSample>) -> Result<Self> {
        let passes = samples.len() as u32;
        let draws = ForwardDraws::new(ctx.device, ctx.world, msaa, samples)?;
        let frame = MultipassFrame::new(ctx.device, ctx.world, ctx.camera.size(), msaa, passes, "forward")?;
        Ok(ForwardTechnique { frame, draws })
    }
}

impl FrameTechnique for ForwardTechnique {
    fn render(&mut self, inputs: &FrameInputs<'_>, frame: &mut FrameContext<'_>) -> Result<TechniqueFrame> {
        let draws: [&dyn PassDraws; 1] = [&self.draws];
        let image = self.frame.render(frame, inputs, &draws)?;
        Ok(self.frame.technique_frame(image, None))
    }
}

/// What `forward/` expects of [`ForwardPipeline`]'s layout: sets 0 and 1, [`ForwardPush`].
pub const SHADER_INTERFACES: &[crate::gpu::layout::ShaderInterface] =
    &[crate::gpu::layout::ShaderInterface::technique(
        &["forward/forward.vert", "forward/forward.frag"],
        None,
        None,
        Some(FORWARD_STRUCTS[0]),
    )];
