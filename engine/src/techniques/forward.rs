//! The forward pass shared by `pinhole` and `accumulation`: the whole scene rendered with one
//! (u, v, t) and one subpixel offset per pass, on the multipass frame of [`super::targets`].
//! Shaders: `shaders-glsl/forward/`.

use ash::vk;
use glam::Vec2;

use super::gpu_scene::GpuScene;
use super::targets::{PassTargets, COLOR_FORMAT, DEPTH_FORMAT};
use crate::error::Result;
use crate::image::LinearImage;
use crate::shaders;
use crate::vk::{CommandRecorder, Device, GraphicsDesc, PassTimings, Pipeline, PipelineLayout, ShaderModule};

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

#[repr(C)]
#[derive(Clone, Copy)]
struct ForwardPush {
    object: u32,
    time: f32,
    lens: [f32; 2],
    jitter: [f32; 2],
}

/// The forward pipeline for one MSAA count, without targets: drawn by [`ForwardRenderer`] and, for the
/// objects the planner leaves on the pinhole path, into the stochastic frame's targets.
pub struct ForwardPipeline {
    pipeline: Pipeline,
    layout: PipelineLayout,
    _shaders: Vec<ShaderModule>,
}

impl ForwardPipeline {
    pub fn new(device: &Device, scene: &GpuScene, samples: u32) -> Result<Self> {
        let vert = ShaderModule::new(device, shaders::FORWARD_FORWARD_VERT)?;
        let frag = ShaderModule::new(device, shaders::FORWARD_FORWARD_FRAG)?;
        let layout = PipelineLayout::new(
            device,
            &[&scene.frame_layout, &scene.material_layout],
            std::mem::size_of::<ForwardPush>() as u32,
            vk::ShaderStageFlags::VERTEX | vk::ShaderStageFlags::FRAGMENT,
        )?;
        let (bindings, attributes) = GpuScene::vertex_input();
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

    /// Draws the objects `i` with `include(i)` with one pass' (t, lens, jitter).
    pub fn record_draws(
        &self,
        d: &Device,
        cmd: vk::CommandBuffer,
        scene: &GpuScene,
        pass: &PassSample,
        include: impl Fn(usize) -> bool,
    ) {
        unsafe { d.raw.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::GRAPHICS, self.pipeline.raw) };
        let push = |i: usize| ForwardPush {
            object: i as u32,
            time: pass.time,
            lens: pass.lens.to_array(),
            jitter: pass.jitter.to_array(),
        };
        let stages = vk::ShaderStageFlags::VERTEX | vk::ShaderStageFlags::FRAGMENT;
        scene.record_object_draws(d, cmd, &self.layout, stages, include, push, |_| None);
    }
}

/// The forward pipeline and its targets for one image size and MSAA count.
pub struct ForwardRenderer {
    targets: PassTargets,
    pipeline: ForwardPipeline,
}

impl ForwardRenderer {
    pub fn new(device: &Device, scene: &GpuScene, samples: u32) -> Result<Self> {
        let pipeline = ForwardPipeline::new(device, scene, samples)?;
        let targets = PassTargets::new(device, scene.width, scene.height, samples)?;
        Ok(ForwardRenderer { targets, pipeline })
    }

    pub fn samples(&self) -> u32 {
        self.targets.samples()
    }

    /// Renders every pass, averages them (equal weights) and reads the result back.
    pub fn render(
        &self,
        device: &Device,
        rec: &mut CommandRecorder,
        scene: &GpuScene,
        passes: &[PassSample],
    ) -> Result<(LinearImage, PassTimings)> {
        self.targets.render(device, rec, scene.background, passes.len(), "forward", &mut |d, cmd, i| {
            self.pipeline.record_draws(d, cmd, scene, &passes[i], |_| true)
        })
    }
}
