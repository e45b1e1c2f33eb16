//! The multipass frame shared by every rasterizing technique: P passes, each rendered into an MSAA
//! colour + reversed-Z depth target, resolved (box filter over the pixel's samples), then added with
//! weight 1/P into an RGBA32F accumulation image (Haeberli & Akeley 1990) that is read back at the end.
//!
//! As a graph: `clear accumulation` → repeat P × { `<name>` (raster: every [`PassDraws`]' draws) →
//! `accumulate` (compute) } → `readback`. What goes into the passes comes from one or more
//! [`PassDraws`] (the forward path of `pinhole` and `accumulation`; `stochastic` and `auto` have a
//! frame of their own, `StochasticDraws::render`). Shader: `shaders-glsl/accumulation/accumulate.comp`.

use ash::vk;
use bytemuck::{Pod, Zeroable};

use super::shadow_maps::ShadowMaps;
use super::{FrameContext, FrameInputs};
use crate::error::Result;
use crate::gpu::layout::{shared_struct, Binding, SharedStruct, TECHNIQUE_SET_INDEX};
use crate::gpu::GpuWorld;
use crate::graph::{Access, BufferHandle, FrameGraph, Load, PassContext, ResourceHandle, Store, Tracked};
use crate::image::LinearImage;
use crate::shaders;
use crate::vk::{
    write_descriptors, DescriptorPool, DescriptorSetLayout, DescriptorWrite, Device, Image, ImageDesc,
    Pipeline, PipelineLayout, ShaderModule,
};

/// Pass colour format (HDR) and depth format. Depth is reversed Z: cleared to 0, nearer is greater.
///
/// Colour is 32-bit float like the accumulation, not 16-bit: a half-float target saturates at 65504
/// (an EXR of a bright scene came out clamped), and lavapipe converts to half by rounding toward zero,
/// which left `accumulation` about 0.05 % darker than the reference. Lavapipe blends and resolves
/// RGBA32F in MSAA targets; what it costs is measured in docs/RESULTS.md.
pub const COLOR_FORMAT: vk::Format = vk::Format::R32G32B32A32_SFLOAT;
pub const DEPTH_FORMAT: vk::Format = vk::Format::D32_SFLOAT;
pub const ACCUM_FORMAT: vk::Format = vk::Format::R32G32B32A32_SFLOAT;

/// An RGBA32F accumulation image (storage, cleared and read back by transfers): the multipass frame's
/// and the stochastic frame's.
pub fn accumulation_image(device: &Device, name: &str, (width, height): (u32, u32)) -> Result<Image> {
    let usage =
        vk::ImageUsageFlags::STORAGE | vk::ImageUsageFlags::TRANSFER_SRC | vk::ImageUsageFlags::TRANSFER_DST;
    Image::new(device, name, ImageDesc::new_2d(width, height, ACCUM_FORMAT, usage))
}

/// Set 3 of `accumulate.comp`.
pub const ACCUMULATE_SET: [Binding; 2] = [
    Binding { binding: 0, ty: vk::DescriptorType::STORAGE_IMAGE, block: "resolved_pass" },
    Binding { binding: 1, ty: vk::DescriptorType::STORAGE_IMAGE, block: "accum" },
];

/// Push constants of `accumulate.comp`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct AccumulatePush {
    pub weight: f32,
}

/// For the reflection test.
pub const ACCUMULATE_STRUCTS: &[SharedStruct] = &[shared_struct!("Push", AccumulatePush, [weight])];

/// What a per-object path needs from the frame besides its draws.
#[derive(Default)]
pub struct FrameUse {
    /// Accesses of its draws inside every pass (declared on the raster pass).
    pub pass_accesses: Vec<(ResourceHandle, Access)>,
    /// Host-visible buffers the CPU reads after the frame (counters, debug output).
    pub host_reads: Vec<BufferHandle>,
}

/// The draws of one per-object path, composed into the passes of a [`MultipassFrame`].
pub trait PassDraws {
    /// Adds the path's once-per-frame passes ahead of the P passes (e.g. the view's camera-space
    /// triangles) and says what its draws use.
    fn add_frame_passes<'a>(&'a self, g: &mut FrameGraph<'a>, inputs: &FrameInputs<'a>) -> Result<FrameUse>;
    /// Records the draws of pass `pass` (of the frame's P) inside the open rendering.
    fn record(&self, ctx: &mut PassContext<'_>, inputs: &FrameInputs<'_>, pass: u32);
}

/// Targets and the accumulate pipeline for P passes of one size and MSAA count.
pub struct MultipassFrame {
    /// Debug label and timestamp scope of the raster passes (`forward`, `stochastic`).
    name: &'static str,
    samples: u32,
    passes: u32,
    resolved: Tracked<Image>,
    accum: Tracked<Image>,
    accumulate: Pipeline,
    accumulate_layout: PipelineLayout,
    accumulate_set: vk::DescriptorSet,
    _accumulate_set_layout: DescriptorSetLayout,
    _pool: DescriptorPool,
    _shader: ShaderModule,
}

impl MultipassFrame {
    /// `passes` passes of `width × height` at `samples` MSAA samples, named `name`.
    pub fn new(
        device: &Device,
        world: &GpuWorld,
        (width, height): (u32, u32),
        samples: u32,
        passes: u32,
        name: &'static str,
    ) -> Result<Self> {
        let comp = ShaderModule::new(device, shaders::ACCUMULATION_ACCUMULATE_COMP)?;
        let set_layout = DescriptorSetLayout::from_table(
            device,
            "accumulate set layout",
            &ACCUMULATE_SET,
            vk::ShaderStageFlags::COMPUTE,
        )?;
        let accumulate_layout = world.pipeline_layout(
            device,
            &[&world.empty_layout, &set_layout],
            std::mem::size_of::<AccumulatePush>() as u32,
            vk::ShaderStageFlags::COMPUTE,
        )?;
        let accumulate = Pipeline::compute(device, "accumulate", &accumulate_layout, &comp)?;
        let attach = vk::ImageUsageFlags::COLOR_ATTACHMENT;
        let resolved = Tracked::new(Image::new(
            device,
            "pass resolved",
            ImageDesc::new_2d(width, height, COLOR_FORMAT, attach | vk::ImageUsageFlags::STORAGE),
        )?);
        let accum = Tracked::new(accumulation_image(device, "accumulation", (width, height))?);
        let pool = DescriptorPool::for_tables(device, 1, &[(&ACCUMULATE_SET, 1)])?;
        let accumulate_set = pool.allocate(&set_layout)?;
        write_descriptors(
            device,
            accumulate_set,
            &[
                DescriptorWrite::StorageImage { binding: 0, view: resolved.view },
                DescriptorWrite::StorageImage { binding: 1, view: accum.view },
            ],
        );
        Ok(MultipassFrame {
            name,
            samples,
            passes,
            resolved,
            accum,
            accumulate,
            accumulate_layout,
            accumulate_set,
            _accumulate_set_layout: set_layout,
            _pool: pool,
            _shader: comp,
        })
    }

    /// A frame's result: `image` from [`MultipassFrame::render`], this frame's pass and sample counts.
    pub fn technique_frame(
        &self,
        image: LinearImage,
        counters: Option<super::SampleCounters>,
    ) -> super::TechniqueFrame {
        super::TechniqueFrame {
            image,
            passes: self.passes,
            msaa_samples: self.samples,
            counters,
            clusters: vec![],
        }
    }

    /// Renders the P passes with every path of `draws` (in order) in each, averages them and reads the
    /// result back. Each pass clears colour to the world's background and depth to 0. With `shadows`,
    /// their maps are rendered first — once, or before every pass when something moves — and read by
    /// the passes.
    pub fn render<'a>(
        &'a self,
        frame: &mut FrameContext<'_>,
        inputs: &FrameInputs<'a>,
        draws: &'a [&'a dyn PassDraws],
        shadows: Option<&'a ShadowMaps>,
    ) -> Result<LinearImage> {
        let mut g = frame.graph();
        let shadows = shadows.map(|s| (s, s.import(&mut g)));
        if let Some((s, h)) = shadows {
            s.add_frame_passes(&mut g, h, inputs);
        }
        let shadow_reads = shadows.map(|(_, h)| ShadowMaps::reads(h)).unwrap_or_default();
        let mut uses = Vec::with_capacity(draws.len());
        for d in draws {
            uses.push(d.add_frame_passes(&mut g, inputs)?);
        }
        let (w, h) = (self.resolved.desc.width, self.resolved.desc.height);
        let resolved = g.import_image("pass resolved", &self.resolved);
        let accum = g.import_image("accumulation", &self.accum);
        let depth = g.create_image(
            "pass depth",
            ImageDesc::new_2d(w, h, DEPTH_FORMAT, vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT)
                .samples(self.samples),
        )?;
        let color_ms = if self.samples > 1 {
            let usage = vk::ImageUsageFlags::COLOR_ATTACHMENT | vk::ImageUsageFlags::TRANSIENT_ATTACHMENT;
            Some(g.create_image(
                "pass color (MSAA)",
                ImageDesc::new_2d(w, h, COLOR_FORMAT, usage).samples(self.samples),
            )?)
        } else {
            None
        };

        g.clear_color("clear accumulation", accum, [0.0; 4]);
        let background = inputs.world.background;
        let weight = 1.0 / self.passes.max(1) as f32;
        let inputs = *inputs;
        g.repeat(self.passes, |g| {
            if let Some((s, h)) = shadows {
                s.add_pass_passes(g, h, &inputs);
            }
            let mut pass = g.pass(self.name);
            pass = match color_ms {
                Some(ms) => pass.color(ms, Load::Clear(background), Store::DontCare).resolve(resolved),
                None => pass.color(resolved, Load::Clear(background), Store::Store),
            };
            pass = pass
                .depth(depth, Load::Clear(0.0), Store::DontCare)
                .accesses(uses.iter().flat_map(|u| u.pass_accesses.iter().copied()))
                .accesses(shadow_reads.iter().copied());
            pass.record(move |ctx| {
                for d in draws {
                    d.record(ctx, &inputs, ctx.iteration);
                }
                Ok(())
            });
            g.pass("accumulate")
                .access(resolved, Access::ComputeShaderReadOther)
                .access(accum, Access::ComputeShaderReadWrite)
                .record(move |ctx| {
                    self.record_accumulate(ctx, weight);
                    Ok(())
                });
            Ok(())
        })?;
        for &b in uses.iter().flat_map(|u| &u.host_reads) {
            g.host_read(b);
        }
        let readback = g.read_back(accum)?;
        let mut result = frame.run(g)?;
        Ok(result.take_image(readback))
    }

    /// `accum += weight · resolved`.
    fn record_accumulate(&self, ctx: &PassContext<'_>, weight: f32) {
        let layout = &self.accumulate_layout;
        ctx.bind_pipeline(&self.accumulate);
        ctx.bind_sets(vk::PipelineBindPoint::COMPUTE, layout, TECHNIQUE_SET_INDEX, &[self.accumulate_set]);
        ctx.push(layout, &AccumulatePush { weight });
        ctx.dispatch(self.accum.desc.width.div_ceil(8), self.accum.desc.height.div_ceil(8), 1);
    }
}

/// What `accumulate.comp` expects of [`MultipassFrame`]'s accumulate layout: set 2 empty, set 3
/// [`ACCUMULATE_SET`], [`AccumulatePush`].
pub const SHADER_INTERFACES: &[crate::gpu::layout::ShaderInterface] =
    &[crate::gpu::layout::ShaderInterface::technique(
        &["accumulation/accumulate.comp"],
        None,
        Some(&ACCUMULATE_SET),
        Some(ACCUMULATE_STRUCTS[0]),
    )];
