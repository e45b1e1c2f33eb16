//! The shading stages of the stochastic frame: one compute pass per frame pass reads the visibility
//! buffer the visibility core ([`super::visibility`]) left and adds every sample's radiance to the
//! accumulation image — the background for the samples without a hit, then one dispatch per object.
//! *How* a hit's radiance is found is the shading rate's, one [`ShadingStage`] per file with its
//! shader:
//!
//! | rate | file | its CPU mirror | shader |
//! |---|---|---|---|
//! | per pixel / per sample (exact) | `exact.rs` | the reference's own shading ([`crate::shading`]) | `stochastic/shade_exact.comp` |
//! | texture-space lookup | `texture_space.rs` | [`crate::mirror::texture_space`] | `stochastic/shade_texture_space.comp` |
//! | decoupled (memoization cache or deferred) | `decoupled.rs` | [`crate::mirror::decoupled`], [`crate::mirror::aas`] | `stochastic/shade_decoupled.comp` |
//!
//! Tints (stochastic transparency's tint buffer) and shadow maps are axes every stage takes
//! ([`ShadeVariant`]); the pass here binds sets 0, 3 and 4, the stage its own bindings. Every stage
//! pushes its own struct, declared in its file with its GLSL block in its shader: [`ShadePush`], the
//! fields every stage reads, first, then its own (`stochastic/shade_push.glsl`; the stage files include
//! `stochastic/shade.glsl`, what they share).

mod decoupled;
mod exact;
mod texture_space;

pub(super) use decoupled::DecoupledPhase;
pub(super) use decoupled::SHADER_INTERFACE as DECOUPLED_INTERFACE;
pub(super) use exact::SHADER_INTERFACE as EXACT_INTERFACE;
pub(super) use texture_space::SHADER_INTERFACE as TEXTURE_SPACE_INTERFACE;

pub use decoupled::{
    DecoupledMemory, CACHE_ENTRY_BYTES, DEFAULT_CACHE_ENTRIES, DEFERRED_ARGS_OFFSET,
    DEFERRED_QUEUE_HEADER_BYTES, DEFERRED_REF_BYTES, MAX_CACHE_ENTRIES, MSAA_GBUFFER_BYTES_PER_SAMPLE,
};

use ash::vk;
use bytemuck::{Pod, Zeroable};

use super::super::shadow_maps::{ShadowHandles, ShadowMaps};
use super::super::{FrameInputs, PrepareContext};
use super::layout::{STOCHASTIC_OBJECT_BINDINGS_WITHOUT_ATLAS, STOCHASTIC_OBJECT_SET};
use super::options::{ShadingRate, StochasticOptions};
use super::visibility::{SetLayouts, Visibility, VisibilityHandles};
use super::CacheCounters;
use crate::error::{Error, Result};
use crate::gpu::layout::{
    shared_struct, Binding, Component, GpuField, SharedStruct, FRAME_SET_INDEX, OBJECT_SET_INDEX,
    TECHNIQUE_SET_INDEX,
};
use crate::gpu::GpuView;
use crate::graph::{Access, FrameGraph, ImageHandle, PassContext, ResourceHandle};
use crate::plan::Effects;
use crate::shaders::{axes, ShaderSource};
use crate::vk::{Device, Pipeline, PipelineLayout, ShaderModule};

/// The push constants every shading stage's struct starts with (`stochastic/shade_push.glsl`): which
/// object the dispatch shades, from which pixel on, in which pass.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub(super) struct ShadePush {
    /// The object's index, or [`SHADE_BACKGROUND`].
    pub object: u32,
    pub pass_index: u32,
    pub spp: u32,
    pub per_pass: u32,
    /// The dispatch covers the object's screen box from this pixel on.
    pub origin_x: u32,
    pub origin_y: u32,
    /// The object's first triangle in the frame's numbering (visibility payloads) and its count.
    pub triangle_base: u32,
    pub triangle_count: u32,
    /// The object's first key segment in the view's object records and its segment count.
    pub segment_first: u32,
    pub segment_count: u32,
}

impl ShadePush {
    /// Of pass `pass`' dispatch for object `object` of `visibility` (or [`SHADE_BACKGROUND`]) from pixel
    /// `origin` on.
    fn new(visibility: &Visibility, view: &GpuView, object: u32, pass: u32, origin: [u32; 2]) -> Self {
        let o = visibility.objects.get(object as usize).map(|o| &o.choices);
        let (triangle_base, triangle_count) = o.map_or((0, 0), |c| (c.triangle_base, c.triangle_count));
        let (segment_first, segment_count) =
            if o.is_some() { view.segments(object as usize) } else { (0, 1) };
        let s = &visibility.sampling;
        ShadePush {
            object,
            pass_index: pass,
            spp: s.spp,
            per_pass: s.per_pass,
            origin_x: origin[0],
            origin_y: origin[1],
            triangle_base,
            triangle_count,
            segment_first,
            segment_count,
        }
    }
}

/// `ShadePush shade` is each stage's block's first member: the reflection test checks its members too.
impl GpuField for ShadePush {
    const COMPONENT: Component = Component::Struct("ShadePush");
    const LAYOUT: Option<&'static SharedStruct> = Some(&SHADE_PUSH);
}

const SHADE_PUSH: SharedStruct = shared_struct!(
    "ShadePush",
    ShadePush,
    [
        object,
        pass_index,
        spp,
        per_pass,
        origin_x,
        origin_y,
        triangle_base,
        triangle_count,
        segment_first,
        segment_count
    ]
);

/// [`ShadePush::object`] of the shading pass' dispatch that adds the background for the samples without
/// a hit (`SHADE_BACKGROUND` in `stochastic/shade.glsl`).
pub(super) const SHADE_BACKGROUND: u32 = u32::MAX;

/// The axes every shading stage's shader has besides its rate.
#[derive(Clone, Copy, Debug)]
pub(super) struct ShadeVariant {
    pub instrumented: bool,
    pub effects: axes::Effects,
    pub shadows: axes::Shadows,
    pub shadow_color: bool,
    pub tints: bool,
}

/// A shading rate: its shader, the bindings and passes it adds, its dispatches' push constants.
/// Everything has a default but the shader and the push constants: the exact rates need nothing more.
pub(super) trait ShadingStage {
    /// Its shader permutation for `v`.
    fn shader(&self, v: ShadeVariant) -> ShaderSource;

    /// The size of its push constants (the pipeline layout's range).
    fn push_size(&self) -> u32;

    /// Its push constants for a `phase` dispatch of `shade`'s object (or the background's): its own
    /// struct, `shade` first, as bytes.
    fn push(&self, shade: ShadePush, phase: DecoupledPhase) -> Vec<u8>;

    /// Set 2's binding table (bindings 5–7, the shading atlas, only where a stage reads them: lavapipe
    /// (Mesa 22.3) crashes binding a set whose combined image sampler was never written).
    fn object_bindings(&self) -> &'static [Binding] {
        &STOCHASTIC_OBJECT_SET[..STOCHASTIC_OBJECT_BINDINGS_WITHOUT_ATLAS]
    }

    /// Writes its own bindings of set 3 (`technique_set`) and of each object's set 2.
    fn write_sets(
        &self,
        _device: &Device,
        _technique_set: vk::DescriptorSet,
        _object_sets: &[vk::DescriptorSet],
    ) {
    }

    /// Host work before the frame's graph (counters reset).
    fn before_frame(&mut self) -> Result<()> {
        Ok(())
    }

    /// Its passes before the frame's repeat, and what its dispatches read and write besides the
    /// visibility core's buffers.
    fn add_frame_passes<'a>(
        &'a self,
        _g: &mut FrameGraph<'a>,
        _inputs: &FrameInputs<'a>,
        _shadows: Option<ShadowHandles>,
    ) -> Vec<(ResourceHandle, Access)> {
        vec![]
    }

    /// The dispatches per object and pass.
    fn phases(&self) -> &'static [DecoupledPhase] {
        &[DecoupledPhase::Memo]
    }

    /// The indirect arguments of a [`DecoupledPhase::Shade`] dispatch.
    fn indirect_args(&self) -> Option<vk::Buffer> {
        None
    }

    /// Texture-space shading: the atlas texels pass 1 shaded (shade, conservative sub-pass).
    fn atlas_texels(&self) -> Result<Option<(u64, u64)>> {
        Ok(None)
    }

    /// Decoupled shading: its counters from the counters buffer (`raw`), for `samples` pixels ×
    /// samples of a pass.
    fn cache_counters(&self, _raw: &[u32], _samples: u64) -> Option<CacheCounters> {
        None
    }

    /// Decoupled shading, deferred: its memory for `samples` pixels × samples of a pass.
    fn decoupled_memory(&self, _samples: u64) -> Option<DecoupledMemory> {
        None
    }
}

/// The shading stage of `options.shading`.
pub(super) fn stage(
    ctx: &PrepareContext<'_>,
    options: &StochasticOptions,
    pass_samples: u64,
    shadows: Option<&ShadowMaps>,
) -> Result<Box<dyn ShadingStage>> {
    Ok(match options.shading {
        ShadingRate::PerPixel | ShadingRate::PerSample => Box::new(exact::Exact::new(options.shading)),
        ShadingRate::TextureSpace | ShadingRate::TextureSpacePerPixel => {
            Box::new(texture_space::TextureSpaceLookup::new(ctx, options, shadows)?)
        }
        ShadingRate::Decoupled { .. } => Box::new(decoupled::Decoupled::new(ctx, options, pass_samples)?),
    })
}

/// The shadow maps the shading reads as set 4: of still casters only (every sample has its own time;
/// maps at one time are exact only when nothing moves), rendered once per frame.
pub(super) fn shadow_maps(ctx: &PrepareContext<'_>) -> Result<Option<ShadowMaps>> {
    if !(ctx.scene.lights.iter().any(|l| l.shadows()) && ctx.settings.shadows.enabled) {
        return Ok(None);
    }
    if crate::mirror::shadow_maps::casters_move(ctx.scene) {
        return Err(Error::Unsupported(
            "shadow-casting lights with moving objects: the stochastic rasterizer renders shadow \
             maps once per frame, exact only when nothing moves (every sample has its own time); \
             accumulation renders them per pass (auto takes it for such scenes)"
                .into(),
        ));
    }
    let caps = &ctx.device.caps;
    if caps.max_bound_descriptor_sets <= crate::gpu::layout::SHADOW_SET_INDEX {
        return Err(Error::Unsupported(format!(
            "shadow maps in the stochastic shading pass are descriptor set {}; this device binds {} \
             sets (maxBoundDescriptorSets)",
            crate::gpu::layout::SHADOW_SET_INDEX,
            caps.max_bound_descriptor_sets
        )));
    }
    ShadowMaps::new(ctx.device, ctx.world, ctx.scene, &ctx.settings.shadows, &[], ctx.settings.seed)
}

/// The shading pass: its stage, layout (sets 0–3, the shadow maps' set 4) and a pipeline per effects
/// path.
pub(super) struct ShadingPass {
    pipelines: Vec<(Effects, Pipeline)>,
    layout: PipelineLayout,
    _shaders: Vec<ShaderModule>,
    pub stage: Box<dyn ShadingStage>,
    /// Last, so dropped after the pipelines and the stage (the atlas passes) whose layouts name its
    /// set layout.
    pub shadows: Option<ShadowMaps>,
}

impl ShadingPass {
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        ctx: &PrepareContext<'_>,
        options: &StochasticOptions,
        stage: Box<dyn ShadingStage>,
        shadows: Option<ShadowMaps>,
        layouts: &SetLayouts,
        paths: &[Effects],
        tints: bool,
    ) -> Result<Self> {
        let device = ctx.device;
        let sets: Vec<_> =
            layouts.both().into_iter().chain(shadows.as_ref().map(ShadowMaps::set_layout)).collect();
        let layout =
            ctx.world.pipeline_layout(device, &sets, stage.push_size(), vk::ShaderStageFlags::COMPUTE)?;
        let (shadow_axis, shadow_color) =
            shadows.as_ref().map_or((axes::Shadows::None, false), |m| m.lookup());
        let mut pipelines = Vec::with_capacity(paths.len());
        let mut shaders = Vec::with_capacity(paths.len());
        for &effects in paths {
            let v = ShadeVariant {
                instrumented: options.instrumented,
                effects: effects.shader_axis(),
                shadows: shadow_axis,
                shadow_color,
                tints,
            };
            let shade = ShaderModule::new(device, stage.shader(v))?;
            let name = format!("stochastic shading ({}, {})", effects.name(), options.shading.name());
            pipelines.push((effects, Pipeline::compute(device, &name, &layout, &shade)?));
            shaders.push(shade);
        }
        Ok(ShadingPass { pipelines, layout, _shaders: shaders, stage, shadows })
    }

    /// The passes before the frame's repeat (the shadow maps, the stage's), and everything the shading
    /// pass reads and writes besides the visibility buffer and the accumulation image.
    pub fn add_frame_passes<'a>(
        &'a self,
        g: &mut FrameGraph<'a>,
        inputs: &FrameInputs<'a>,
        vis: &VisibilityHandles,
    ) -> Vec<(ResourceHandle, Access)> {
        let mut uses: Vec<(ResourceHandle, Access)> =
            vis.triangles.iter().map(|&h| (h.into(), Access::ComputeShaderReadOther)).collect();
        if let Some(h) = vis.counters {
            // Atomics read and write.
            uses.push((h.into(), Access::ComputeShaderReadOther));
            uses.push((h.into(), Access::ComputeShaderWrite));
        }
        let mut shadow_handles = None;
        if let Some(maps) = &self.shadows {
            let h = maps.import(g);
            maps.add_frame_passes(g, h, inputs);
            uses.extend(ShadowMaps::reads_as(h, Access::ComputeShaderReadSampledImageOrUniformTexelBuffer));
            shadow_handles = Some(h);
        }
        uses.extend(self.stage.add_frame_passes(g, inputs, shadow_handles));
        if let Some(t) = vis.tints {
            uses.push((t.into(), Access::ComputeShaderReadOther));
        }
        uses
    }

    /// One pass' shading (inside the frame's repeat), after the visibility core's passes.
    pub fn add_pass<'a>(
        &'a self,
        g: &mut FrameGraph<'a>,
        visibility: &'a Visibility,
        vis: &VisibilityHandles,
        uses: &[(ResourceHandle, Access)],
        accum: ImageHandle,
        inputs: &FrameInputs<'a>,
    ) {
        let inputs = *inputs;
        g.pass("stochastic shading")
            .access(vis.visibility, Access::ComputeShaderReadOther)
            .access(accum, Access::ComputeShaderReadWrite)
            .accesses(uses.iter().copied())
            .record(move |ctx| {
                self.record(ctx, visibility, &inputs, ctx.iteration);
                Ok(())
            });
    }

    /// The dispatches of pass `pass`: the background for the samples without a hit, then one per
    /// object with its sets (each adds its own samples; the accumulation image orders them).
    fn record(
        &self,
        ctx: &mut PassContext<'_>,
        visibility: &Visibility,
        inputs: &FrameInputs<'_>,
        pass: u32,
    ) {
        let (d, cmd) = (ctx.device, ctx.cmd);
        let bind = vk::PipelineBindPoint::COMPUTE;
        let layout = &self.layout;
        let (w, h) = visibility.sampling.size;
        let (world, view, objects) = (inputs.world, inputs.camera, &visibility.objects);
        let barrier = || {
            // Read-modify-write of the accumulation image by consecutive dispatches; the deferred mode's
            // table, queue and G-buffer, and its shading dispatch's indirect arguments.
            ctx.compute_write_barrier(
                vk::PipelineStageFlags2::COMPUTE_SHADER | vk::PipelineStageFlags2::DRAW_INDIRECT,
                vk::AccessFlags2::SHADER_STORAGE_READ
                    | vk::AccessFlags2::SHADER_STORAGE_WRITE
                    | vk::AccessFlags2::INDIRECT_COMMAND_READ,
            );
        };
        ctx.bind_sets(bind, layout, FRAME_SET_INDEX, &[view.frame_set]);
        ctx.bind_sets(bind, layout, TECHNIQUE_SET_INDEX, &[visibility.technique_set]);
        if let Some(maps) = &self.shadows {
            maps.bind(ctx, bind, &self.layout, crate::gpu::layout::SHADOW_SET_INDEX);
        }
        let mut first = true;
        let indirect = self.stage.indirect_args();
        let mut dispatch = |pipeline: &Pipeline,
                            object: u32,
                            sets: [vk::DescriptorSet; 2],
                            rect: [u32; 4],
                            phase: DecoupledPhase| {
            let [x0, y0, rw, rh] = rect;
            if rw == 0 || rh == 0 {
                return;
            }
            if !first {
                barrier();
            }
            first = false;
            let push = self.stage.push(ShadePush::new(visibility, view, object, pass, [x0, y0]), phase);
            debug_assert_eq!(push.len(), self.stage.push_size() as usize);
            ctx.bind_pipeline(pipeline);
            ctx.bind_sets(bind, layout, OBJECT_SET_INDEX, &sets);
            ctx.push_bytes(layout, &push);
            match phase {
                DecoupledPhase::Args => ctx.dispatch(1, 1, 1),
                DecoupledPhase::Shade => {
                    let queue = indirect.expect("the deferred mode has its queue");
                    // SAFETY: the recording contract of `PassContext`; the indirect buffer (the deferred
                    // queue, a buffer the stage owns) is declared by the stage's frame passes, not by
                    // this pass, so `PassContext::dispatch_indirect`'s check cannot be used here.
                    unsafe { d.raw.cmd_dispatch_indirect(cmd, queue, decoupled::DEFERRED_ARGS_OFFSET) }
                }
                _ => ctx.dispatch(rw.div_ceil(8), rh.div_ceil(8), 1),
            }
        };
        // The background dispatch reads no object's data; any permutation does it. Set 1 and 2 of the
        // first drawn object (or of the first object) keep the layout's sets valid.
        let i = objects.iter().position(|o| o.is_drawn()).unwrap_or(0);
        dispatch(
            &self.pipelines[0].1,
            SHADE_BACKGROUND,
            [world.objects[i].set, objects[i].set],
            [0, 0, w, h],
            DecoupledPhase::Memo,
        );
        for (effects, pipeline) in &self.pipelines {
            for (i, (o, so)) in world.objects.iter().zip(objects).enumerate() {
                if so.choices.effects == *effects && so.is_drawn() {
                    for &phase in self.stage.phases() {
                        dispatch(pipeline, i as u32, [o.set, so.set], so.choices.shade_rect, phase);
                    }
                }
            }
        }
    }
}
