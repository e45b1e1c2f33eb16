//! The plain forward path shared by `pinhole`, `accumulation` and `auto`'s still, sharp objects: the
//! objects rendered with one (u, v, t) and one subpixel offset per pass, into the passes of a
//! [`MultipassFrame`]. Shaders: `shaders-glsl/forward/`.
//!
//! **Stochastic transparency** ([`TransparentDraws`], docs/TRANSPARENCY.md): objects with coverage
//! below 1 are drawn by `transparent.frag`, which keeps the MSAA samples of the pass that
//! [`crate::transparency::covered`] gives them (sample `pass × M + j` of the pixel's S = M × P) and
//! discards the fragment before shading when it keeps none; then tinted ones are drawn again, nearer
//! than the stored depth only, multiplying their tint into the samples they do not cover. Both are
//! draws inside the same raster pass of the frame graph, after the opaque ones: draws in one pass
//! meet the depth test and blending in submission order, so no barrier and no second pass (storing
//! and reloading the MSAA targets) is needed. An opaque scene builds none of it.

use ash::vk;
use bytemuck::{Pod, Zeroable};

use super::multipass::{FrameUse, MultipassFrame, PassDraws, COLOR_FORMAT, DEPTH_FORMAT};
use super::settings::{key, OptionKey};
use super::shadow_maps::ShadowMaps;
use super::{FrameContext, FrameInputs, FrameTechnique, PrepareContext, TechniqueFrame};
use crate::error::Result;
use crate::gpu::layout::{shared_struct, vertex_input, SharedStruct, TECHNIQUE_SET_INDEX};
use crate::gpu::{GpuView, GpuWorld};
use crate::graph::{FrameGraph, PassContext};
use crate::scene::Scene;
use crate::shaders;
use crate::shaders::axes::{Shadows, TransparencyPass};
use crate::transparency::{coverage_seed, TransparencyMethod};
use crate::vk::{
    ColorBlend, DescriptorSetLayout, Device, Faces, Feature, GraphicsDesc, Pipeline, PipelineLayout,
    ShaderModule,
};

/// The forward frame's transparency key (parsed by [`TransparencyMethod`]'s `FromStr`): the method
/// for coverage below 1, read by `pinhole` and `accumulation` ([`prepare_frame`]).
pub const TRANSPARENCY_KEYS: &[OptionKey] = &[key(
    "transparency",
    "pinhole, accumulation",
    "a transparency method (docs/TRANSPARENCY.md)",
    "peeling/4",
)];

use crate::sampling::pass_texture_footprint;
/// Moved to [`crate::sampling`] (the CPU mirrors use it too); re-exported for the techniques.
pub use crate::sampling::PassSample;

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
    /// The texture filter's width in pixels ([`pass_texture_footprint`] of the frame's pass count):
    /// the fragment stages scale the uv derivatives by it (`common/pass_texture.glsl`).
    pub texture_footprint: f32,
}

impl ForwardPush {
    /// Object `object` of `view` at `pass`'s time, lens point and jitter, textures filtered over the
    /// whole pixel (one pass); [`ForwardPush::with_passes`] for one of several.
    pub fn new(view: &GpuView, object: usize, pass: &PassSample) -> Self {
        let (segment, segment_time) = view.segment_at(object, pass.time);
        ForwardPush {
            object: object as u32,
            time: pass.time,
            lens: pass.lens.to_array(),
            jitter: pass.jitter.to_array(),
            segment,
            segment_time,
            texture_footprint: 1.0,
        }
    }

    /// The same push for one of `passes` passes that together sample the pixel: textures filtered
    /// over its share ([`pass_texture_footprint`]).
    pub fn with_passes(self, passes: u32) -> Self {
        ForwardPush { texture_footprint: pass_texture_footprint(passes), ..self }
    }
}

/// Push constants of `transparent.frag`: [`ForwardPush`]'s members (`forward.vert` reads them) and
/// what the coverage decision and the tint pass need.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct TransparentPush {
    pub object: u32,
    pub time: f32,
    pub lens: [f32; 2],
    pub jitter: [f32; 2],
    pub segment: u32,
    pub segment_time: f32,
    /// rgb: the object's tint (transmission); w unused (vec4 alignment).
    pub tint: [f32; 4],
    /// [`coverage_seed`] of the render seed.
    pub coverage_seed: u32,
    /// S: samples per pixel over the frame (MSAA × passes).
    pub samples: u32,
    /// Index among the S of the pass' first MSAA sample (pass × MSAA).
    pub sample_base: u32,
    /// MSAA samples of the pass.
    pub msaa: u32,
    /// The object's first triangle in the scene's numbering (the reference's).
    pub first_triangle: u32,
    /// 1: coverage is alpha × the texture's alpha.
    pub alpha_from_texture: u32,
    /// [`ForwardPush::texture_footprint`].
    pub texture_footprint: f32,
}

/// For the reflection test.
pub const FORWARD_STRUCTS: &[SharedStruct] = &[
    shared_struct!(
        "Push",
        ForwardPush,
        [object, time, lens, jitter, segment, segment_time, texture_footprint]
    ),
    shared_struct!(
        "Push",
        TransparentPush,
        [
            object,
            time,
            lens,
            jitter,
            segment,
            segment_time,
            tint,
            coverage_seed,
            samples,
            sample_base,
            msaa,
            first_triangle,
            alpha_from_texture,
            texture_footprint
        ]
    ),
];

/// How a receiving forward pipeline reads shadow maps: its set 3 and the lookup permutation.
#[derive(Clone, Copy)]
pub struct ShadowLookup {
    set: vk::DescriptorSet,
    shadows: Shadows,
    color: bool,
}

impl ShadowLookup {
    pub fn of(maps: &ShadowMaps) -> Self {
        let (shadows, color) = maps.lookup();
        ShadowLookup { set: maps.set(), shadows, color }
    }
}

/// The vertex stage of a forward pipeline: with the object-space outputs a shadow receiver reads.
pub(super) fn forward_vert(device: &Device, receives_shadows: bool) -> Result<ShaderModule> {
    ShaderModule::new(device, shaders::ForwardVert { shadow_receiver: receives_shadows }.source())
}

/// The layout of a forward pipeline: sets 0 and 1, with shadows set 2 empty and set 3 the shadow
/// maps' ([`ShadowMaps::set_layout`]); push constants of `push_bytes`.
fn forward_layout(
    device: &Device,
    world: &GpuWorld,
    shadows: Option<&ShadowMaps>,
    push_bytes: usize,
) -> Result<PipelineLayout> {
    let stages = vk::ShaderStageFlags::VERTEX | vk::ShaderStageFlags::FRAGMENT;
    let sets: Vec<&DescriptorSetLayout> = match shadows {
        Some(maps) => vec![&world.empty_layout, maps.set_layout()],
        None => vec![],
    };
    world.pipeline_layout(device, &sets, push_bytes as u32, stages)
}

/// Binds the shadow maps' set 3, when the pipeline receives shadows.
fn bind_shadows(ctx: &PassContext<'_>, layout: &PipelineLayout, lookup: Option<ShadowLookup>) {
    if let Some(l) = lookup {
        ctx.bind_sets(vk::PipelineBindPoint::GRAPHICS, layout, TECHNIQUE_SET_INDEX, &[l.set]);
    }
}

/// The forward pipeline for one MSAA count.
pub struct ForwardPipeline {
    pipeline: Pipeline,
    layout: PipelineLayout,
    shadows: Option<ShadowLookup>,
    _shaders: Vec<ShaderModule>,
}

impl ForwardPipeline {
    /// Shadow-casting lights attenuated by `shadows`' maps, when given.
    pub fn with_shadows(
        device: &Device,
        world: &GpuWorld,
        samples: u32,
        shadows: Option<&ShadowMaps>,
    ) -> Result<Self> {
        let format = COLOR_FORMAT;
        let lookup = shadows.map(ShadowLookup::of);
        let vert = forward_vert(device, lookup.is_some())?;
        let (shadow_axis, shadow_color) = lookup.map_or((Shadows::None, false), |l| (l.shadows, l.color));
        let frag =
            ShaderModule::new(device, shaders::ForwardFrag { shadows: shadow_axis, shadow_color }.source())?;
        let layout = forward_layout(device, world, shadows, std::mem::size_of::<ForwardPush>())?;
        let (bindings, attributes) = vertex_input();
        let pipeline = Pipeline::graphics(
            device,
            &layout,
            &GraphicsDesc {
                name: "forward",
                stages: &[&vert, &frag],
                vertex_bindings: &bindings,
                vertex_attributes: &attributes,
                color_formats: &[format],
                depth_format: Some(DEPTH_FORMAT),
                samples,
                // Once per pixel (pinhole's 4× MSAA): the classic path, an approximation with a floor
                // where shading varies inside a pixel (docs/HARD_CASES.md). Per-sample evaluation on
                // Mesa 22.3.6 lavapipe was tried and left out: the pipeline's minSampleShading = 1
                // changed nothing, and the `sample` qualifier gave images further from the reference.
                sample_shading: None,
                // One-sided materials' back faces culled per draw, as the reference's camera rays skip them.
                faces: Faces::PerObject,
                depth_compare: vk::CompareOp::GREATER,
                depth_write: true,
                overestimate: false,
            },
        )?;
        Ok(ForwardPipeline { pipeline, layout, shadows: lookup, _shaders: vec![vert, frag] })
    }

    /// Draws the objects `i` with `include(i)` seen from `view` with one pass' (t, lens, jitter), one
    /// of `passes` that sample the pixel together (its share sets the texture filter).
    pub fn record_draws(
        &self,
        ctx: &PassContext<'_>,
        world: &GpuWorld,
        view: &GpuView,
        (pass, passes): (&PassSample, u32),
        include: impl Fn(usize) -> bool,
    ) {
        ctx.bind_pipeline(&self.pipeline);
        bind_shadows(ctx, &self.layout, self.shadows);
        let push = |i: usize| ForwardPush::new(view, i, pass).with_passes(passes);
        world.record_object_draws(ctx, view, &self.pipeline, &self.layout, include, push, |_| None);
    }
}

/// Per object, what a stochastic coverage draw needs to know of it: the forward transparency draws,
/// the shadow casters ([`super::shadow_maps`]) and the OIT draws ([`super::oit`]).
#[derive(Clone, Copy, Debug)]
pub struct TransparentObject {
    /// Coverage below 1 somewhere (alpha < 1 or from the texture).
    pub transparent: bool,
    /// Transparent with a tint other than white: drawn again by the tint (or hue) pass.
    pub tinted: bool,
    pub tint: [f32; 4],
    /// The texture's alpha counts: as the reference, only with a texture and uvs.
    pub alpha_from_texture: bool,
    /// The object's first triangle in the scene's numbering (the reference's).
    pub first_triangle: u32,
}

/// Every object of `scene`, in order.
pub fn transparent_objects(scene: &Scene) -> Vec<TransparentObject> {
    let mut first_triangle = 0u32;
    scene
        .objects
        .iter()
        .map(|o| {
            let m = &o.material;
            let transparent = !m.is_opaque();
            let t = TransparentObject {
                transparent,
                tinted: transparent && m.tint != glam::Vec3::ONE,
                tint: m.tint.extend(0.0).to_array(),
                alpha_from_texture: m.alpha_from_texture && m.texture.is_some() && o.mesh.has_uvs(),
                first_triangle,
            };
            first_triangle += (o.mesh.indices.len() / 3) as u32;
            t
        })
        .collect()
}

/// Which of a pixel's S samples a coverage draw decides: the coverage hashes' seed, S, the index of
/// the draw's first MSAA sample among the S, and its MSAA count.
#[derive(Clone, Copy, Debug)]
pub struct CoverageSamples {
    pub seed: u32,
    pub samples: u32,
    pub base: u32,
    pub msaa: u32,
}

impl TransparentPush {
    /// The push of a coverage draw of object `o` moved as `f` says, deciding the samples `c`.
    pub fn new(f: ForwardPush, o: &TransparentObject, c: CoverageSamples) -> Self {
        TransparentPush {
            object: f.object,
            time: f.time,
            lens: f.lens,
            jitter: f.jitter,
            segment: f.segment,
            segment_time: f.segment_time,
            tint: o.tint,
            coverage_seed: c.seed,
            samples: c.samples,
            sample_base: c.base,
            msaa: c.msaa,
            first_triangle: o.first_triangle,
            alpha_from_texture: o.alpha_from_texture as u32,
            texture_footprint: f.texture_footprint,
        }
    }
}

/// The colour attachments of the pass a [`TransparentDraws`] draws in, and the one it writes (the
/// others keep their contents): the forward pass' one target, or the OIT frame's three for
/// `stochastic/corrected` (`techniques/oit.rs`), which draws into the first.
#[derive(Clone, Copy, Debug)]
pub struct TransparentTargets {
    pub formats: &'static [vk::Format],
    pub written: usize,
}

impl TransparentTargets {
    /// The forward pass' colour target.
    pub const FORWARD: TransparentTargets = TransparentTargets { formats: &[COLOR_FORMAT], written: 0 };
}

/// Stochastic transparency on the forward path (module docs): the coverage and tint pipelines and
/// what they push per object.
pub struct TransparentDraws {
    coverage: Pipeline,
    tint: Pipeline,
    layout: PipelineLayout,
    shadows: Option<ShadowLookup>,
    objects: Vec<TransparentObject>,
    coverage_seed: u32,
    msaa: u32,
    /// S = MSAA × passes.
    samples: u32,
    _shaders: Vec<ShaderModule>,
}

/// Whether any object of `scene` has coverage below 1 (and needs a transparency method).
pub fn has_transparency(scene: &Scene) -> bool {
    scene.objects.iter().any(|o| !o.material.is_opaque())
}

impl TransparentDraws {
    /// For `scene`'s objects at `msaa` samples × `passes` passes, with the render seed `seed`, into
    /// `targets`; the covered samples' shading attenuated by `shadows`' maps when given.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        device: &Device,
        world: &GpuWorld,
        scene: &Scene,
        (msaa, passes): (u32, u32),
        seed: u64,
        shadows: Option<&ShadowMaps>,
        targets: TransparentTargets,
    ) -> Result<Self> {
        device.caps.require(
            Feature::GeometryShader,
            "stochastic transparency (the fragment stage reads gl_PrimitiveID to name the triangle)",
        )?;
        let lookup = shadows.map(ShadowLookup::of);
        let (shadow_axis, shadow_color) = lookup.map_or((Shadows::None, false), |l| (l.shadows, l.color));
        // The tint pass shades nothing: no shadow lookups, so no object-space outputs either.
        let vert = forward_vert(device, lookup.is_some())?;
        let tint_vert = ShaderModule::new(device, shaders::FORWARD_FORWARD_VERT)?;
        let coverage_frag = ShaderModule::new(
            device,
            shaders::TransparentFrag {
                transparency_pass: TransparencyPass::Coverage,
                shadows: shadow_axis,
                shadow_color,
            }
            .source(),
        )?;
        let tint_frag = ShaderModule::new(
            device,
            shaders::TransparentFrag {
                transparency_pass: TransparencyPass::Tint,
                shadows: Shadows::None,
                shadow_color: false,
            }
            .source(),
        )?;
        let layout = forward_layout(device, world, shadows, std::mem::size_of::<TransparentPush>())?;
        let (bindings, attributes) = vertex_input();
        let coverage_stages = [&vert, &coverage_frag];
        let tint_stages = [&tint_vert, &tint_frag];
        let desc = |name, stages, depth_write| GraphicsDesc {
            name,
            stages,
            vertex_bindings: &bindings,
            vertex_attributes: &attributes,
            color_formats: targets.formats,
            depth_format: Some(DEPTH_FORMAT),
            samples: msaa,
            sample_shading: None,
            faces: Faces::PerObject,
            // Reversed Z: nearer is greater. The tint pass passes only in front of the stored depth.
            depth_compare: vk::CompareOp::GREATER,
            depth_write,
            overestimate: false,
        };
        let written: Vec<bool> = (0..targets.formats.len()).map(|i| i == targets.written).collect();
        let coverage = Pipeline::graphics_written(
            device,
            &layout,
            &desc("forward transparency", &coverage_stages, true),
            ColorBlend::Replace,
            Some(&written),
        )?;
        let tint = Pipeline::graphics_written(
            device,
            &layout,
            &desc("forward transparency tint", &tint_stages, false),
            ColorBlend::Multiply,
            Some(&written),
        )?;
        let objects = transparent_objects(scene);
        Ok(TransparentDraws {
            coverage,
            tint,
            layout,
            shadows: lookup,
            objects,
            coverage_seed: coverage_seed(seed),
            msaa,
            samples: msaa * passes,
            _shaders: vec![vert, tint_vert, coverage_frag, tint_frag],
        })
    }

    fn push(&self, view: &GpuView, object: usize, pass: &PassSample, pass_index: u32) -> TransparentPush {
        let c = CoverageSamples {
            seed: self.coverage_seed,
            samples: self.samples,
            base: pass_index * self.msaa,
            msaa: self.msaa,
        };
        let f = ForwardPush::new(view, object, pass).with_passes(self.samples / self.msaa);
        TransparentPush::new(f, &self.objects[object], c)
    }

    fn is_transparent(&self, object: usize) -> bool {
        self.objects[object].transparent
    }

    /// The coverage draws (every transparent object), then the tint draws (the tinted ones), of pass
    /// `index` (its sample `pass`), each pipeline with its own layout and sets.
    pub(super) fn record(
        &self,
        ctx: &PassContext<'_>,
        inputs: &FrameInputs<'_>,
        pass: &PassSample,
        index: u32,
    ) {
        let (world, view) = (inputs.world, inputs.camera);
        let push = |i: usize| self.push(view, i, pass, index);
        ctx.bind_pipeline(&self.coverage);
        bind_shadows(ctx, &self.layout, self.shadows);
        let transparent = |i: usize| self.objects[i].transparent;
        world.record_object_draws(ctx, view, &self.coverage, &self.layout, transparent, push, |_| None);
        if self.objects.iter().any(|o| o.tinted) {
            ctx.device.begin_label(ctx.cmd, "transparency tint");
            ctx.bind_pipeline(&self.tint);
            let tinted = |i: usize| self.objects[i].tinted;
            world.record_object_draws(ctx, view, &self.tint, &self.layout, tinted, push, |_| None);
            ctx.device.end_label(ctx.cmd);
        }
    }
}

/// The forward path of every object: one [`PassSample`] per pass of the frame.
pub struct ForwardDraws {
    pipeline: ForwardPipeline,
    samples: Vec<PassSample>,
    /// Stochastic transparency, when the scene has coverage below 1.
    transparent: Option<TransparentDraws>,
}

impl ForwardDraws {
    /// Pass p drawn with `samples[p]`, at `msaa` samples; `scene`'s objects with coverage below 1
    /// by `method` with coverage seeded by `seed` (nothing more is built for an opaque scene); lights
    /// attenuated by `shadows`' maps when given.
    #[allow(clippy::too_many_arguments)]
    pub fn with_transparency(
        device: &Device,
        world: &GpuWorld,
        scene: &Scene,
        msaa: u32,
        samples: Vec<PassSample>,
        method: TransparencyMethod,
        seed: u64,
        shadows: Option<&ShadowMaps>,
    ) -> Result<Self> {
        let transparent = match method {
            _ if !has_transparency(scene) => None,
            TransparencyMethod::Stochastic => {
                let passes = samples.len() as u32;
                let targets = TransparentTargets::FORWARD;
                Some(TransparentDraws::new(device, world, scene, (msaa, passes), seed, shadows, targets)?)
            }
            // Several raster passes per frame pass: their own frame (`prepare_frame` picks `oit`).
            TransparencyMethod::StochasticCorrected
            | TransparencyMethod::DepthBased { .. }
            | TransparencyMethod::Peeling { .. } => {
                return Err(crate::error::Error::Unsupported(format!(
                    "transparency method `{method}` is rendered by the OIT frame (techniques/oit.rs), not \
                     the forward passes"
                )))
            }
        };
        let pipeline = ForwardPipeline::with_shadows(device, world, msaa, shadows)?;
        Ok(ForwardDraws { pipeline, samples, transparent })
    }

    /// The transparency method used, if the scene needs one.
    pub fn transparency(&self) -> Option<TransparencyMethod> {
        self.transparent.as_ref().map(|_| TransparencyMethod::Stochastic)
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
        let sample = (&self.samples[pass as usize], self.samples.len() as u32);
        match &self.transparent {
            None => self.pipeline.record_draws(ctx, inputs.world, inputs.camera, sample, |_| true),
            Some(t) => {
                let opaque = |i: usize| !t.is_transparent(i);
                self.pipeline.record_draws(ctx, inputs.world, inputs.camera, sample, opaque);
                t.record(ctx, inputs, sample.0, pass);
            }
        }
    }
}

/// `pinhole`'s and `accumulation`'s frame for `samples.len()` passes at `msaa` samples: the plain
/// forward frame ([`ForwardTechnique`]), or — only when the scene has transparency and
/// `ctx.settings.transparency` is alpha-corrected, depth-based or peeling, which need several raster
/// passes per frame pass — the order-independent transparency frame of [`super::oit`].
pub fn prepare_frame(
    ctx: &PrepareContext<'_>,
    msaa: u32,
    samples: Vec<PassSample>,
) -> Result<Box<dyn FrameTechnique>> {
    match ctx.settings.transparency {
        TransparencyMethod::Stochastic => {}
        _ if !has_transparency(ctx.scene) => {}
        method => return Ok(Box::new(super::oit::OitTechnique::new(ctx, msaa, samples, method)?)),
    }
    Ok(Box::new(ForwardTechnique::new(ctx, msaa, samples)?))
}

/// Every object on the forward path, one [`PassSample`] per pass: `pinhole` and `accumulation`.
pub struct ForwardTechnique {
    frame: MultipassFrame,
    // Dropped before the maps whose set layout its pipelines use.
    draws: ForwardDraws,
    /// The shadow-casting lights' maps, when the scene has any.
    shadows: Option<ShadowMaps>,
}

impl ForwardTechnique {
    /// `samples.len()` passes at `msaa` samples per pass, every object drawn; coverage below 1 by
    /// `ctx.settings.transparency`.
    pub fn new(ctx: &PrepareContext<'_>, msaa: u32, samples: Vec<PassSample>) -> Result<Self> {
        let passes = samples.len() as u32;
        let s = ctx.settings;
        let times: Vec<f32> = samples.iter().map(|p| p.time).collect();
        let shadows = ShadowMaps::new(ctx.device, ctx.world, ctx.scene, &s.shadows, &times, s.seed)?;
        let draws = ForwardDraws::with_transparency(
            ctx.device,
            ctx.world,
            ctx.scene,
            msaa,
            samples,
            s.transparency,
            s.seed,
            shadows.as_ref(),
        )?;
        let frame = MultipassFrame::new(ctx.device, ctx.world, ctx.camera.size(), msaa, passes, "forward")?;
        Ok(ForwardTechnique { frame, draws, shadows })
    }
}

impl FrameTechnique for ForwardTechnique {
    fn render(&mut self, inputs: &FrameInputs<'_>, frame: &mut FrameContext<'_>) -> Result<TechniqueFrame> {
        let draws: [&dyn PassDraws; 1] = [&self.draws];
        let image = self.frame.render(frame, inputs, &draws, self.shadows.as_ref())?;
        Ok(self.frame.technique_frame(image, None))
    }

    fn transparency(&self) -> Option<TransparencyMethod> {
        self.draws.transparency()
    }

    fn shadows(&self) -> Option<String> {
        self.shadows.as_ref().map(ShadowMaps::summary)
    }
}

/// What `forward/` expects of [`ForwardPipeline`]'s layout: sets 0 and 1, with shadows set 3 the
/// shadow maps' ([`super::shadow_maps::SHADOW_SET`]), [`ForwardPush`].
pub const SHADER_INTERFACES: &[crate::gpu::layout::ShaderInterface] = &[
    crate::gpu::layout::ShaderInterface::technique(
        &["forward/forward.vert", "forward/forward.frag"],
        None,
        Some(&super::shadow_maps::SHADOW_SET),
        Some(FORWARD_STRUCTS[0]),
    ),
    crate::gpu::layout::ShaderInterface::technique(
        &["forward/transparent.frag"],
        None,
        Some(&super::shadow_maps::SHADOW_SET),
        Some(FORWARD_STRUCTS[1]),
    ),
];
