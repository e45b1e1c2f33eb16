//! Order-independent transparency with more than one raster pass per frame pass, for `pinhole` and
//! `accumulation` (`--transparency stochastic/corrected`, `depth-based`, `depth-based/uncorrected`,
//! `peeling/K`; docs/TRANSPARENCY.md). [`super::forward::prepare_frame`] gives those techniques this
//! frame when the scene has transparency and one of these methods is chosen, and the plain forward
//! frame otherwise.
//!
//! Per frame pass (one [`PassSample`] each, M MSAA samples), as a graph, after `clear accumulation`:
//!
//! * `oit opaque` (raster): the opaque objects with the forward pipeline into an MSAA colour and depth
//!   target, both kept (the later passes read them per sample).
//! * **Depth-based stochastic transparency** (Enderton, Sintorn, Shirley & Luebke 2011, the
//!   depth-based variant):
//!   1. `oit stochastic depth` (raster, depth only): every transparent surface writes its depth to
//!      the samples its stochastic coverage mask keeps — the very mask of `--transparency
//!      stochastic` (`common/coverage.glsl`: sample `pass × M + j` of the pixel's S = M × passes,
//!      stratified per pixel) — so the M depths are M draws of the deep shadow function from the eye.
//!   2. `oit layers` (raster, the opaque depth as a read-only attachment): every transparent fragment
//!      in front of the opaque surface adds `vis(z)·α·C` and `vis(z)·α` (additive blending; per
//!      channel, with tints as below), `vis(z)` the fraction of the pixel's M stochastic depths not nearer than it; then, in the same
//!      rendering, every transparent fragment multiplies `(1 − α)·T` into the total transmittance
//!      (multiplicative blending: exact, order independent). Shading once per fragment.
//!   3. `oit composite` (compute): per pixel, the means over its M samples of `C_opaque·T`, of the
//!      layer sum, of its weight and of `1 − T`, added with weight 1/P into four frame totals; after
//!      the last pass, `oit composite finish` adds the layer sum `L` behind which nothing remains:
//!      with alpha correction `L = ΣL·Σ(1 − T)/Σweight` (Enderton's normalisation), without it `ΣL`.
//! * **Alpha-corrected stochastic transparency** (Enderton et al. 2011, the alpha correction of plain
//!   ST): `oit stochastic` (raster, the opaque depth loaded and written) draws first the total
//!   transmittance as above — `Π (1 − α)·T` per channel and `Π (1 − α)` in alpha, in front of the
//!   opaque depth alone — then the forward path's own stochastic coverage and tint draws
//!   ([`TransparentDraws`], the same masks as `--transparency stochastic`) into the layer sum only
//!   (the other attachments write-masked: `independentBlend`): each sample ends with the colour of
//!   its nearest covered transparent surface times the tints in front of it, and alpha 1, or 0 where
//!   it stops at no transparent surface. `oit composite` then adds `C_opaque·T` (exact, per sample)
//!   and sums the layer colour, its count (the weight) and the exact total alpha `1 − Π (1 − α)`; the
//!   finish rescales the colour by total alpha ÷ count, over the frame's S samples. Tints do not enter
//!   the normaliser: whether a sample stops at a transparent surface does not depend on them, so its
//!   expected count is the untinted total alpha; they are in the sampled colour and the exact
//!   transmittance behind.
//! * **Depth peeling** (K layers), per sample: K times `oit peel` (raster: of the transparent surfaces
//!   in front of the opaque depth and strictly behind the previous layer's depth, the nearest writes
//!   α·C and (1 − α)·T) then `oit peel under` (compute: the layer composited under the ones before it,
//!   per sample, in a storage buffer); the last one adds the opaque colour behind the remaining
//!   transmittance and accumulates. Exact where a sample has at most K transparent layers in front of
//!   its opaque surface; deeper layers are left out (the truncation: the K nearest over the opaque
//!   surface). With MSAA the peel pipeline shades per sample (sample-rate shading), so every sample
//!   peels its own layers.
//!
//! **Tints in depth-based ST.** The layer sum needs `vis_c(z) = Π_{z_j nearer than z} (1 − α_j)·T_j,c`
//! per channel c. One stochastic depth map estimates only the `Π (1 − α_j)` part. A surface stops
//! channel c with probability `a_c = 1 − (1 − α)·T_c` (it covers, or it does not and its tint absorbs),
//! so a stochastic depth map drawn with coverage `a_c` estimates `vis_c` exactly in expectation. A
//! scene with a tinted transparent object therefore draws three stochastic depth maps (one per
//! channel, masks from the same key, so the channels' masks are nested rather than independent), an
//! untinted one a single map with α — where `T_c = 1`, `a_c` is α itself and the mask is
//! `stochastic`'s. The alpha correction's weights use `a_c` too: `Σ vis_c·a_c` has the exact value
//! `1 − T_c` (T_c the total transmittance), where `Σ vis·α` would not with tints. This departs from
//! the paper, which has no coloured transmission. The price: a tint's absorption is sampled (a
//! surface that transmits little of a channel mostly occludes in that channel's map), where
//! `stochastic` multiplies tints exactly, so in a strongly absorbed channel depth-based ST can be the
//! noisier of the two (tests/tests/oit.rs measures it; over a pixel's channels it stays below).
//!
//! **Departures from the paper, on purpose.** The stochastic depth maps hold transparent surfaces
//! only, not the opaque depth: a fragment's contribution is already cut per sample by the opaque
//! depth test of the layers pass, and counting opaque samples in `vis` too would cut it twice at the
//! edge of an opaque object. The stochastic depth written is the fragment's centre depth on every
//! sample it keeps (the layers pass compares that same centre depth, so a surface never occludes
//! itself; a relative 2⁻²⁰ tolerance absorbs the neighbouring triangle of a flat mesh). The alpha
//! correction's ratio is formed once per frame from the sums over all S = M × P samples, not per pass:
//! with one sample per pass (`accumulation`) a per-pass ratio is a ratio of one-sample estimates, and
//! its bias (0.07 on the test panes at S = 16, measured) does not average away over the passes; the
//! frame's ratio has the bias of an S-sample ratio (≤ 0.0011 there).

use ash::vk;
use bytemuck::{Pod, Zeroable};

use super::forward::{
    forward_vert, transparent_objects, CoverageSamples, ForwardPipeline, ForwardPush, PassSample,
    TransparentDraws, TransparentObject, TransparentPush, TransparentTargets,
};
use super::multipass::{accumulation_image, COLOR_FORMAT, DEPTH_FORMAT};
use super::shadow_maps::ShadowMaps;
use super::{FrameContext, FrameInputs, FrameTechnique, PrepareContext, TechniqueFrame};
use crate::error::{Error, Result};
use crate::gpu::layout::{shared_struct, vertex_input, Binding, SharedStruct, TECHNIQUE_SET_INDEX};
use crate::gpu::{GpuView, GpuWorld};
use crate::graph::ResourceHandle;
use crate::graph::{Access, ImageHandle, Load, PassContext, Store, Tracked};
use crate::image::LinearImage;
use crate::shaders;
use crate::shaders::axes::Shadows;
use crate::transparency::{coverage_seed, TransparencyMethod, MAX_PEELING_LAYERS};
use crate::vk::{
    write_descriptors, Buffer, ColorBlend, DescriptorPool, DescriptorSetLayout, DescriptorWrite, Device,
    Faces, Feature, GraphicsDesc, Image, ImageDesc, Pipeline, PipelineLayout, Sampler, ShaderModule,
};

/// The format of the sums, the transmittance and the peeled layers: 32-bit floats, so that a sum
/// over many faint particles and a product of many transmittances round like the f32 closed form.
pub const OIT_FORMAT: vk::Format = vk::Format::R32G32B32A32_SFLOAT;

/// Push constants of the OIT draws (`oit/draw.glsl`): [`ForwardPush`]'s members first
/// (`forward.vert` reads them), then coverage (as `TransparentPush`), the stochastic depth channel,
/// the number of depth maps and the peeled layer.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct OitPush {
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
    /// Stochastic depth: 0–2 the channel whose effective coverage `1 − (1 − α)·T_c` decides, 3 α.
    pub channel: u32,
    /// Layers pass: 1 or 3 stochastic depth maps.
    pub depth_maps: u32,
    /// Peeling: the layer being peeled (0: the nearest).
    pub layer: u32,
    /// [`ForwardPush::texture_footprint`].
    pub texture_footprint: f32,
}

/// Push constants of `oit/depth_composite.comp`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct DepthCompositePush {
    /// 1 / passes.
    pub weight: f32,
    pub msaa: u32,
    /// Enderton's alpha correction: 0 none; [`CORRECTION_PER_CHANNEL`] (depth-based); or
    /// [`CORRECTION_STOCHASTIC`] (alpha-corrected ST).
    pub alpha_correction: u32,
    /// 1: after the last pass, add the (corrected) layer sum of the frame.
    pub finish: u32,
}

/// [`DepthCompositePush::alpha_correction`] of depth-based ST: the layer weights (`vis·a_c` per
/// channel) are rescaled to the absorbed fraction `1 − T_c` per channel.
pub const CORRECTION_PER_CHANNEL: u32 = 1;
/// [`DepthCompositePush::alpha_correction`] of alpha-corrected ST: the layer sum's alpha counts the
/// samples that stopped at a transparent surface, which is rescaled to the exact total alpha
/// `1 − Π (1 − α)` (the transmittance's alpha channel) in every channel.
pub const CORRECTION_STOCHASTIC: u32 = 2;

/// Push constants of `oit/peel_under.comp`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct PeelUnderPush {
    /// 1 / passes.
    pub weight: f32,
    pub msaa: u32,
    /// The layer just peeled (0: the accumulators start from it).
    pub layer: u32,
    /// 1: the last layer (composite over the opaque colour and accumulate).
    pub last: u32,
}

/// For the reflection test.
pub const OIT_STRUCTS: &[SharedStruct] = &[
    shared_struct!(
        "Push",
        OitPush,
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
            channel,
            depth_maps,
            layer,
            texture_footprint
        ]
    ),
    shared_struct!("Push", DepthCompositePush, [weight, msaa, alpha_correction, finish]),
    shared_struct!("Push", PeelUnderPush, [weight, msaa, layer, last]),
];

const SAMPLED: vk::DescriptorType = vk::DescriptorType::COMBINED_IMAGE_SAMPLER;
const fn binding(binding: u32, ty: vk::DescriptorType, block: &'static str) -> Binding {
    Binding { binding, ty, block }
}

/// Set 3 of `oit/layers.frag`: the stochastic depth maps (one per channel; an untinted scene binds its
/// one map three times).
pub const LAYERS_SET: [Binding; 3] = [
    binding(0, SAMPLED, "stochastic_depth_r"),
    binding(1, SAMPLED, "stochastic_depth_g"),
    binding(2, SAMPLED, "stochastic_depth_b"),
];

/// Set 3 of `oit/peel.frag`.
pub const PEEL_SET: [Binding; 2] =
    [binding(0, SAMPLED, "opaque_depth"), binding(1, SAMPLED, "previous_depth")];

/// Set 3 of `oit/depth_composite.comp`.
pub const DEPTH_COMPOSITE_SET: [Binding; 8] = [
    binding(0, SAMPLED, "opaque_color"),
    binding(1, SAMPLED, "layer_sum"),
    binding(2, SAMPLED, "layer_weight"),
    binding(3, SAMPLED, "total_transmittance"),
    binding(4, vk::DescriptorType::STORAGE_IMAGE, "accum"),
    binding(5, vk::DescriptorType::STORAGE_IMAGE, "sum_total"),
    binding(6, vk::DescriptorType::STORAGE_IMAGE, "weight_total"),
    binding(7, vk::DescriptorType::STORAGE_IMAGE, "absorbed_total"),
];

/// Set 3 of `oit/peel_under.comp`.
pub const PEEL_UNDER_SET: [Binding; 5] = [
    binding(0, SAMPLED, "layer_color"),
    binding(1, SAMPLED, "layer_transmittance"),
    binding(2, SAMPLED, "opaque_color"),
    binding(3, vk::DescriptorType::STORAGE_BUFFER, "PeelAccumulators"),
    binding(4, vk::DescriptorType::STORAGE_IMAGE, "accum"),
];

/// A persistent `size` image of `msaa` samples.
fn target(
    device: &Device,
    name: &str,
    (width, height): (u32, u32),
    format: vk::Format,
    msaa: u32,
    usage: vk::ImageUsageFlags,
) -> Result<Tracked<Image>> {
    Ok(Tracked::new(Image::new(device, name, ImageDesc::new_2d(width, height, format, usage).samples(msaa))?))
}

/// A compute pipeline of the OIT frame with set 3 from `table`.
struct ComputeStep {
    pipeline: Pipeline,
    layout: PipelineLayout,
    set: vk::DescriptorSet,
    _set_layout: DescriptorSetLayout,
    _shader: ShaderModule,
}

impl ComputeStep {
    fn new<P>(
        device: &Device,
        world: &GpuWorld,
        pool: &DescriptorPool,
        name: &str,
        source: shaders::ShaderSource,
        table: &[Binding],
        writes: &[DescriptorWrite],
    ) -> Result<Self> {
        let shader = ShaderModule::new(device, source)?;
        let set_layout = DescriptorSetLayout::from_table(
            device,
            &format!("{name} set layout"),
            table,
            vk::ShaderStageFlags::COMPUTE,
        )?;
        let layout = world.pipeline_layout(
            device,
            &[&world.empty_layout, &set_layout],
            std::mem::size_of::<P>() as u32,
            vk::ShaderStageFlags::COMPUTE,
        )?;
        let pipeline = Pipeline::compute(device, name, &layout, &shader)?;
        let set = pool.allocate(&set_layout)?;
        write_descriptors(device, set, writes);
        Ok(ComputeStep { pipeline, layout, set, _set_layout: set_layout, _shader: shader })
    }

    /// One invocation per pixel of a `width × height` image.
    fn record<P: Pod>(&self, ctx: &PassContext<'_>, push: &P, (width, height): (u32, u32)) {
        ctx.bind_pipeline(&self.pipeline);
        ctx.bind_sets(vk::PipelineBindPoint::COMPUTE, &self.layout, TECHNIQUE_SET_INDEX, &[self.set]);
        ctx.push(&self.layout, push);
        ctx.dispatch(width.div_ceil(8), height.div_ceil(8), 1);
    }
}

/// How the layers pass fills the layer sum and its weight (module docs).
enum LayerDraws {
    /// Depth-based ST: the stochastic depth maps, then every transparent fragment adds `vis·α·C`.
    DepthBased {
        stochastic_depth: Pipeline,
        layers: Pipeline,
        layers_set: vk::DescriptorSet,
        /// One stochastic depth map, or one per channel when a transparent object is tinted.
        depth_maps: Vec<Tracked<Image>>,
        /// Kept only so that it outlives its set (boxed: the variant stays near the other's size).
        _layers_set_layout: Box<DescriptorSetLayout>,
    },
    /// Alpha-corrected ST: the forward path's coverage and tint draws into the layer sum, against
    /// the opaque depth, after the transmittance draws.
    Stochastic(Box<TransparentDraws>),
}

/// The frames that composite a layer sum over the opaque colour behind the exact transmittance —
/// depth-based ST and alpha-corrected ST — their pipelines and targets (module docs).
struct Composited {
    /// [`DepthCompositePush::alpha_correction`].
    correction: u32,
    draws: LayerDraws,
    transmittance: Pipeline,
    draw_layout: PipelineLayout,
    composite: ComputeStep,
    layer_sum: Tracked<Image>,
    layer_weight: Tracked<Image>,
    total_transmittance: Tracked<Image>,
    /// The frame's sums (means over each pass' samples, weighted 1/P) of the layer sum, its weight and
    /// the absorbed fraction 1 − T, from which the last step forms the alpha correction's ratio.
    totals: [Tracked<Image>; 3],
    _shaders: Vec<ShaderModule>,
}

/// Depth peeling's pipelines and targets (module docs).
struct Peeling {
    layers: u32,
    peel: Pipeline,
    peel_layout: PipelineLayout,
    /// Set 3 when peeling into depth target `i`: the other one is the previous layer's.
    peel_sets: [vk::DescriptorSet; 2],
    under: ComputeStep,
    depth: [Tracked<Image>; 2],
    layer_color: Tracked<Image>,
    layer_transmittance: Tracked<Image>,
    accumulators: Tracked<Buffer>,
    _peel_set_layout: DescriptorSetLayout,
    _shaders: Vec<ShaderModule>,
}

enum OitPath {
    Composited(Box<Composited>),
    Peeling(Box<Peeling>),
}

/// The OIT frame of `pinhole` and `accumulation` (module docs).
pub struct OitTechnique {
    method: TransparencyMethod,
    size: (u32, u32),
    msaa: u32,
    samples: Vec<PassSample>,
    objects: Vec<TransparentObject>,
    coverage_seed: u32,
    opaque: ForwardPipeline,
    opaque_color: Tracked<Image>,
    opaque_depth: Tracked<Image>,
    accum: Tracked<Image>,
    path: OitPath,
    // Sets die with the pool; the pool and the sampler outlive nothing that names them.
    _pool: DescriptorPool,
    _sampler: Sampler,
    /// The shadow-casting lights' maps; last, so dropped after the pipelines whose layouts name its
    /// set layout.
    shadows: Option<ShadowMaps>,
}

impl OitTechnique {
    /// `samples.len()` passes at `msaa` samples per pass, the scene's transparency by `method`
    /// (depth-based or peeling).
    pub fn new(
        ctx: &PrepareContext<'_>,
        msaa: u32,
        samples: Vec<PassSample>,
        method: TransparencyMethod,
    ) -> Result<Self> {
        let (device, world) = (ctx.device, ctx.world);
        let size = ctx.camera.size();
        let sampled = vk::ImageUsageFlags::SAMPLED;
        let color_usage = vk::ImageUsageFlags::COLOR_ATTACHMENT | sampled;
        let depth_usage = vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT | sampled;
        let opaque_color = target(device, "oit opaque color", size, COLOR_FORMAT, msaa, color_usage)?;
        let opaque_depth = target(device, "oit opaque depth", size, DEPTH_FORMAT, msaa, depth_usage)?;
        let accum = Tracked::new(accumulation_image(device, "accumulation", size)?);
        let sampler = Sampler::nearest_clamp(device, "oit pass images")?;
        let objects = transparent_objects(ctx.scene);
        let multisampled = msaa > 1;
        // Shadow maps (docs/SHADOWS.md): rendered before the passes (per pass when something moves),
        // read by the opaque pass and by the shading draws (layers, peel) as set 4.
        let times: Vec<f32> = samples.iter().map(|p| p.time).collect();
        let shadows =
            ShadowMaps::new(device, world, ctx.scene, &ctx.settings.shadows, &times, ctx.settings.seed)?;
        let (shadow_axis, shadow_color) = shadows.as_ref().map_or((Shadows::None, false), |m| m.lookup());
        let vert = || forward_vert(device, false);
        // The shading draws' vertex stage: with the object-space outputs the shadow lookup reads.
        let receiver_vert = || forward_vert(device, shadows.is_some());
        // Sets 2 (empty) and 3 (the pipeline's own), and 4 the shadow maps when there are any.
        let draw_layout_with = |set3: &DescriptorSetLayout| {
            let sets: Vec<&DescriptorSetLayout> = [&world.empty_layout, set3]
                .into_iter()
                .chain(shadows.as_ref().map(ShadowMaps::set_layout))
                .collect();
            world.pipeline_layout(
                device,
                &sets,
                std::mem::size_of::<OitPush>() as u32,
                vk::ShaderStageFlags::VERTEX | vk::ShaderStageFlags::FRAGMENT,
            )
        };
        let (bindings, attributes) = vertex_input();
        let sampled_image = |binding, image: &Image| DescriptorWrite::SampledImage {
            binding,
            view: image.view,
            sampler: sampler.raw,
        };
        let (pool, path) = match method {
            TransparencyMethod::Stochastic => {
                return Err(Error::Unsupported(
                    "stochastic transparency is drawn by the forward passes (forward.rs), not the OIT frame"
                        .into(),
                ))
            }
            TransparencyMethod::StochasticCorrected | TransparencyMethod::DepthBased { .. } => {
                let what = match method {
                    TransparencyMethod::StochasticCorrected => "alpha-corrected stochastic transparency",
                    _ => "depth-based stochastic transparency",
                };
                device.caps.require(
                    Feature::GeometryShader,
                    &format!("{what} (the fragment stage reads gl_PrimitiveID to name the triangle)"),
                )?;
                let layer_sum = target(device, "oit layer sum", size, OIT_FORMAT, msaa, color_usage)?;
                let layer_weight = target(device, "oit layer weight", size, OIT_FORMAT, msaa, color_usage)?;
                let total_transmittance =
                    target(device, "oit total transmittance", size, OIT_FORMAT, msaa, color_usage)?;
                let total = |name| Ok::<_, Error>(Tracked::new(accumulation_image(device, name, size)?));
                let totals =
                    [total("oit sum total")?, total("oit weight total")?, total("oit absorbed total")?];
                let pool =
                    DescriptorPool::for_tables(device, 2, &[(&LAYERS_SET, 1), (&DEPTH_COMPOSITE_SET, 1)])?;
                let v = vert()?;
                let transmittance_frag = ShaderModule::new(device, shaders::OIT_TRANSMITTANCE_FRAG)?;
                let three = [OIT_FORMAT; 3];
                let raster = |layout: &PipelineLayout,
                              name: &str,
                              stages: &[&ShaderModule],
                              color_formats: &[vk::Format],
                              depth_write: bool,
                              blend: ColorBlend| {
                    let desc = GraphicsDesc {
                        name,
                        stages,
                        vertex_bindings: &bindings,
                        vertex_attributes: &attributes,
                        color_formats,
                        depth_format: Some(DEPTH_FORMAT),
                        samples: msaa,
                        sample_shading: None,
                        // One-sided materials' back faces culled, as the forward pipeline.
                        faces: Faces::PerObject,
                        // Reversed Z: nearer is greater.
                        depth_compare: vk::CompareOp::GREATER,
                        depth_write,
                        overestimate: false,
                    };
                    Pipeline::graphics_blended(device, layout, &desc, blend)
                };
                let mut shader_modules = vec![];
                let (correction, draws, draw_layout) = match method {
                    TransparencyMethod::DepthBased { alpha_correction } => {
                        let tinted = objects.iter().any(|o| o.tinted);
                        let maps = if tinted { 3 } else { 1 };
                        let depth_maps = (0..maps)
                            .map(|c| {
                                target(
                                    device,
                                    &format!("stochastic depth {c}"),
                                    size,
                                    DEPTH_FORMAT,
                                    msaa,
                                    depth_usage,
                                )
                            })
                            .collect::<Result<Vec<_>>>()?;
                        let layers_set_layout = DescriptorSetLayout::from_table(
                            device,
                            "oit layers set layout",
                            &LAYERS_SET,
                            vk::ShaderStageFlags::FRAGMENT,
                        )?;
                        let layers_set = pool.allocate(&layers_set_layout)?;
                        let map = |c: usize| &*depth_maps[c.min(maps - 1)];
                        write_descriptors(
                            device,
                            layers_set,
                            &[0, 1, 2].map(|c| sampled_image(c as u32, map(c))),
                        );
                        let draw_layout = draw_layout_with(&layers_set_layout)?;
                        let rv = receiver_vert()?;
                        let depth_frag = ShaderModule::new(device, shaders::OIT_STOCHASTIC_DEPTH_FRAG)?;
                        let layers_frag = ShaderModule::new(
                            device,
                            shaders::LayersFrag { shadows: shadow_axis, shadow_color, multisampled }.source(),
                        )?;
                        let stochastic_depth = raster(
                            &draw_layout,
                            "oit stochastic depth",
                            &[&v, &depth_frag],
                            &[],
                            true,
                            ColorBlend::Replace,
                        )?;
                        let layers = raster(
                            &draw_layout,
                            "oit layers",
                            &[&rv, &layers_frag],
                            &three,
                            false,
                            ColorBlend::Add,
                        )?;
                        shader_modules.extend([rv, depth_frag, layers_frag]);
                        let correction = if alpha_correction { CORRECTION_PER_CHANNEL } else { 0 };
                        let draws = LayerDraws::DepthBased {
                            stochastic_depth,
                            layers,
                            layers_set,
                            depth_maps,
                            _layers_set_layout: Box::new(layers_set_layout),
                        };
                        (correction, draws, draw_layout)
                    }
                    _ => {
                        // The forward path's stochastic transparency, into the layer sum only.
                        let targets = TransparentTargets { formats: &[OIT_FORMAT; 3], written: 0 };
                        let passes = samples.len() as u32;
                        let st = TransparentDraws::new(
                            device,
                            world,
                            ctx.scene,
                            (msaa, passes),
                            ctx.settings.seed,
                            shadows.as_ref(),
                            targets,
                        )?;
                        let draw_layout = draw_layout_with(&world.empty_layout)?;
                        (CORRECTION_STOCHASTIC, LayerDraws::Stochastic(Box::new(st)), draw_layout)
                    }
                };
                let transmittance = raster(
                    &draw_layout,
                    "oit transmittance",
                    &[&v, &transmittance_frag],
                    &three,
                    false,
                    ColorBlend::Multiply,
                )?;
                shader_modules.extend([v, transmittance_frag]);
                let composite = ComputeStep::new::<DepthCompositePush>(
                    device,
                    world,
                    &pool,
                    "oit composite",
                    shaders::DepthCompositeComp { multisampled }.source(),
                    &DEPTH_COMPOSITE_SET,
                    &[
                        sampled_image(0, &opaque_color),
                        sampled_image(1, &layer_sum),
                        sampled_image(2, &layer_weight),
                        sampled_image(3, &total_transmittance),
                        DescriptorWrite::StorageImage { binding: 4, view: accum.view },
                        DescriptorWrite::StorageImage { binding: 5, view: totals[0].view },
                        DescriptorWrite::StorageImage { binding: 6, view: totals[1].view },
                        DescriptorWrite::StorageImage { binding: 7, view: totals[2].view },
                    ],
                )?;
                let path = Composited {
                    correction,
                    draws,
                    transmittance,
                    draw_layout,
                    composite,
                    layer_sum,
                    layer_weight,
                    total_transmittance,
                    totals,
                    _shaders: shader_modules,
                };
                (pool, OitPath::Composited(Box::new(path)))
            }
            TransparencyMethod::Peeling { layers } => {
                if layers == 0 || layers > MAX_PEELING_LAYERS {
                    return Err(Error::Limit {
                        what: "peeling layers",
                        value: layers.to_string(),
                        limit: format!("1..={MAX_PEELING_LAYERS}"),
                    });
                }
                if multisampled {
                    device.caps.require(
                        Feature::SampleRateShading,
                        "depth peeling with MSAA (every sample peels its own layers)",
                    )?;
                }
                let peel_depth =
                    |i| target(device, &format!("peel depth {i}"), size, DEPTH_FORMAT, msaa, depth_usage);
                let depth = [peel_depth(0)?, peel_depth(1)?];
                let layer_color = target(device, "peel layer color", size, OIT_FORMAT, msaa, color_usage)?;
                let layer_transmittance =
                    target(device, "peel layer transmittance", size, OIT_FORMAT, msaa, color_usage)?;
                // Two vec4 per sample: the colour composited so far and the transmittance left.
                let bytes = size.0 as u64 * size.1 as u64 * msaa as u64 * 32;
                let accumulators = Tracked::new(Buffer::new(
                    device,
                    "peel accumulators",
                    bytes,
                    vk::BufferUsageFlags::STORAGE_BUFFER,
                    gpu_allocator::MemoryLocation::GpuOnly,
                )?);
                let pool = DescriptorPool::for_tables(device, 3, &[(&PEEL_SET, 2), (&PEEL_UNDER_SET, 1)])?;
                let peel_set_layout = DescriptorSetLayout::from_table(
                    device,
                    "oit peel set layout",
                    &PEEL_SET,
                    vk::ShaderStageFlags::FRAGMENT,
                )?;
                let peel_sets = [pool.allocate(&peel_set_layout)?, pool.allocate(&peel_set_layout)?];
                for (i, &set) in peel_sets.iter().enumerate() {
                    write_descriptors(
                        device,
                        set,
                        &[sampled_image(0, &opaque_depth), sampled_image(1, &depth[1 - i])],
                    );
                }
                let peel_layout = draw_layout_with(&peel_set_layout)?;
                let v = receiver_vert()?;
                let peel_frag = ShaderModule::new(
                    device,
                    shaders::PeelFrag { shadows: shadow_axis, shadow_color, multisampled }.source(),
                )?;
                let peel = Pipeline::graphics(
                    device,
                    &peel_layout,
                    &GraphicsDesc {
                        name: "oit peel",
                        stages: &[&v, &peel_frag],
                        vertex_bindings: &bindings,
                        vertex_attributes: &attributes,
                        color_formats: &[OIT_FORMAT; 2],
                        depth_format: Some(DEPTH_FORMAT),
                        samples: msaa,
                        // Per sample: each sample compares its own depths and keeps its own nearest.
                        sample_shading: multisampled.then_some(1.0),
                        faces: Faces::PerObject,
                        depth_compare: vk::CompareOp::GREATER,
                        depth_write: true,
                        overestimate: false,
                    },
                )?;
                let under = ComputeStep::new::<PeelUnderPush>(
                    device,
                    world,
                    &pool,
                    "oit peel under",
                    shaders::PeelUnderComp { multisampled }.source(),
                    &PEEL_UNDER_SET,
                    &[
                        sampled_image(0, &layer_color),
                        sampled_image(1, &layer_transmittance),
                        sampled_image(2, &opaque_color),
                        DescriptorWrite::storage_buffer(3, &accumulators),
                        DescriptorWrite::StorageImage { binding: 4, view: accum.view },
                    ],
                )?;
                let path = Peeling {
                    layers,
                    peel,
                    peel_layout,
                    peel_sets,
                    under,
                    depth,
                    layer_color,
                    layer_transmittance,
                    accumulators,
                    _peel_set_layout: peel_set_layout,
                    _shaders: vec![v, peel_frag],
                };
                (pool, OitPath::Peeling(Box::new(path)))
            }
        };
        Ok(OitTechnique {
            method,
            size,
            msaa,
            samples,
            objects,
            coverage_seed: coverage_seed(ctx.settings.seed),
            opaque: ForwardPipeline::with_shadows(device, world, msaa, shadows.as_ref())?,
            opaque_color,
            opaque_depth,
            accum,
            path,
            _pool: pool,
            _sampler: sampler,
            shadows,
        })
    }

    /// What every OIT draw of `object` pushes in pass `pass`.
    fn push(&self, view: &GpuView, object: usize, pass: u32) -> OitPush {
        let c = CoverageSamples {
            seed: self.coverage_seed,
            samples: self.msaa * self.samples.len() as u32,
            base: pass * self.msaa,
            msaa: self.msaa,
        };
        let passes = self.samples.len() as u32;
        let f = ForwardPush::new(view, object, &self.samples[pass as usize]).with_passes(passes);
        let t = TransparentPush::new(f, &self.objects[object], c);
        OitPush {
            object: t.object,
            time: t.time,
            lens: t.lens,
            jitter: t.jitter,
            segment: t.segment,
            segment_time: t.segment_time,
            tint: t.tint,
            coverage_seed: t.coverage_seed,
            samples: t.samples,
            sample_base: t.sample_base,
            msaa: t.msaa,
            first_triangle: t.first_triangle,
            alpha_from_texture: t.alpha_from_texture,
            texture_footprint: t.texture_footprint,
            channel: 3,
            depth_maps: 1,
            layer: 0,
        }
    }

    /// Draws the transparent objects with `pipeline` (layout `layout`, set 3 `set` when given), each
    /// with its [`OitPush`] for the pass as `edit` changes it.
    fn draw_transparent(
        &self,
        ctx: &PassContext<'_>,
        inputs: &FrameInputs<'_>,
        pipeline: &Pipeline,
        layout: &PipelineLayout,
        set: Option<vk::DescriptorSet>,
        edit: impl Fn(&mut OitPush),
    ) {
        let bind = vk::PipelineBindPoint::GRAPHICS;
        ctx.bind_pipeline(pipeline);
        if let Some(set) = set {
            ctx.bind_sets(bind, layout, TECHNIQUE_SET_INDEX, &[set]);
        }
        if let Some(maps) = &self.shadows {
            maps.bind(ctx, bind, layout, crate::gpu::layout::SHADOW_SET_INDEX);
        }
        let push = |i: usize| {
            let mut p = self.push(inputs.camera, i, ctx.iteration);
            edit(&mut p);
            p
        };
        inputs.world.record_object_draws(
            ctx,
            inputs.camera,
            pipeline,
            layout,
            |i| self.objects[i].transparent,
            push,
            |_| None,
        );
    }

    /// The total transmittance draws of the layers or stochastic pass (debug label `oit transmittance`).
    fn draw_transmittance(&self, ctx: &PassContext<'_>, inputs: &FrameInputs<'_>, db: &Composited) {
        ctx.device.begin_label(ctx.cmd, "oit transmittance");
        self.draw_transparent(ctx, inputs, &db.transmittance, &db.draw_layout, None, |_| {});
        ctx.device.end_label(ctx.cmd);
    }

    /// The frame's graph: the passes of the module docs, then the read-back.
    fn render_frame<'a>(
        &'a self,
        frame: &mut FrameContext<'_>,
        inputs: &FrameInputs<'a>,
    ) -> Result<LinearImage> {
        let mut g = frame.graph();
        let accum = g.import_image("accumulation", &self.accum);
        let opaque_color = g.import_image("oit opaque color", &self.opaque_color);
        let opaque_depth = g.import_image("oit opaque depth", &self.opaque_depth);
        let background = inputs.world.background;
        let weight = 1.0 / self.samples.len().max(1) as f32;
        let (msaa, size) = (self.msaa, self.size);
        let inputs = *inputs;
        let sampled_fragment = Access::FragmentShaderReadSampledImageOrUniformTexelBuffer;
        let sampled_compute = Access::ComputeShaderReadSampledImageOrUniformTexelBuffer;
        g.clear_color("clear accumulation", accum, [0.0; 4]);
        let shadows = self.shadows.as_ref().map(|s| (s, s.import(&mut g)));
        if let Some((s, h)) = shadows {
            s.add_frame_passes(&mut g, h, &inputs);
        }
        let shadow_reads = shadows.map(|(_, h)| ShadowMaps::reads(h)).unwrap_or_default();
        let shadow_reads = &shadow_reads;
        // Before each pass' draws: its shadow maps, when something moves.
        let per_pass_shadows = move |g: &mut crate::graph::FrameGraph<'a>| {
            if let Some((s, h)) = shadows {
                s.add_pass_passes(g, h, &inputs);
            }
        };
        match &self.path {
            OitPath::Composited(db) => {
                let maps: Vec<ImageHandle> = match &db.draws {
                    LayerDraws::DepthBased { depth_maps, .. } => depth_maps
                        .iter()
                        .enumerate()
                        .map(|(c, m)| g.import_image(&format!("stochastic depth {c}"), m))
                        .collect(),
                    LayerDraws::Stochastic(_) => vec![],
                };
                let sum = g.import_image("oit layer sum", &db.layer_sum);
                let weights = g.import_image("oit layer weight", &db.layer_weight);
                let transmittance = g.import_image("oit total transmittance", &db.total_transmittance);
                let totals = [0, 1, 2].map(|i| g.import_image(&format!("oit total {i}"), &db.totals[i]));
                for t in totals {
                    g.clear_color("clear oit total", t, [0.0; 4]);
                }
                let composite =
                    DepthCompositePush { weight, msaa, alpha_correction: db.correction, finish: 0 };
                // `oit composite` after each pass, `finish` 1 once after the last. Every image the
                // pipeline binds is declared, so that each is in its layout.
                let composite_pass = move |g: &mut crate::graph::FrameGraph<'a>, name: &str, finish: u32| {
                    let push = DepthCompositePush { finish, ..composite };
                    g.pass(name)
                        .access(opaque_color, sampled_compute)
                        .access(sum, sampled_compute)
                        .access(weights, sampled_compute)
                        .access(transmittance, sampled_compute)
                        .access(accum, Access::ComputeShaderReadWrite)
                        .accesses(totals.map(|t| (t.into(), Access::ComputeShaderReadWrite)))
                        .record(move |ctx| {
                            db.composite.record(ctx, &push, size);
                            Ok(())
                        });
                };
                let depth_maps = maps.len() as u32;
                g.repeat(self.samples.len() as u32, |g| {
                    per_pass_shadows(g);
                    self.opaque_pass(g, &inputs, opaque_color, opaque_depth, background, shadow_reads);
                    match &db.draws {
                        LayerDraws::DepthBased { stochastic_depth, layers, layers_set, .. } => {
                            for (c, &map) in maps.iter().enumerate() {
                                let channel = if depth_maps == 3 { c as u32 } else { 3 };
                                g.pass("oit stochastic depth")
                                    .depth(map, Load::Clear(0.0), Store::Store)
                                    .record(move |ctx| {
                                        self.draw_transparent(
                                            ctx,
                                            &inputs,
                                            stochastic_depth,
                                            &db.draw_layout,
                                            None,
                                            |p| p.channel = channel,
                                        );
                                        Ok(())
                                    });
                            }
                            let mut pass = g
                                .pass("oit layers")
                                .color(sum, Load::Clear([0.0; 4]), Store::Store)
                                .color(weights, Load::Clear([0.0; 4]), Store::Store)
                                .color(transmittance, Load::Clear([1.0; 4]), Store::Store)
                                .depth_read_only(opaque_depth)
                                .accesses(shadow_reads.iter().copied());
                            for &map in &maps {
                                pass = pass.access(map, sampled_fragment);
                            }
                            pass.record(move |ctx| {
                                let set = Some(*layers_set);
                                self.draw_transparent(ctx, &inputs, layers, &db.draw_layout, set, |p| {
                                    p.depth_maps = depth_maps
                                });
                                self.draw_transmittance(ctx, &inputs, db);
                                Ok(())
                            });
                        }
                        LayerDraws::Stochastic(st) => {
                            // The transmittance first, against the opaque depth alone; then the
                            // stochastic coverage draws write their depth over it.
                            g.pass("oit stochastic")
                                .color(sum, Load::Clear([0.0; 4]), Store::Store)
                                .color(weights, Load::Clear([0.0; 4]), Store::Store)
                                .color(transmittance, Load::Clear([1.0; 4]), Store::Store)
                                .depth(opaque_depth, Load::Load, Store::DontCare)
                                .accesses(shadow_reads.iter().copied())
                                .record(move |ctx| {
                                    self.draw_transmittance(ctx, &inputs, db);
                                    let index = ctx.iteration;
                                    let pass = &self.samples[index as usize];
                                    st.record(ctx, &inputs, pass, index);
                                    Ok(())
                                });
                        }
                    };
                    composite_pass(g, "oit composite", 0);
                    Ok(())
                })?;
                composite_pass(&mut g, "oit composite finish", 1);
            }
            OitPath::Peeling(p) => {
                let depth = [
                    g.import_image("peel depth 0", &p.depth[0]),
                    g.import_image("peel depth 1", &p.depth[1]),
                ];
                let layer_color = g.import_image("peel layer color", &p.layer_color);
                let layer_transmittance = g.import_image("peel layer transmittance", &p.layer_transmittance);
                let accumulators = g.import_buffer("peel accumulators", &p.accumulators);
                g.repeat(self.samples.len() as u32, |g| {
                    per_pass_shadows(g);
                    self.opaque_pass(g, &inputs, opaque_color, opaque_depth, background, shadow_reads);
                    for layer in 0..p.layers {
                        let (current, previous) = (layer as usize % 2, 1 - layer as usize % 2);
                        g.pass("oit peel")
                            .color(layer_color, Load::Clear([0.0; 4]), Store::Store)
                            .color(layer_transmittance, Load::Clear([1.0; 4]), Store::Store)
                            .depth(depth[current], Load::Clear(0.0), Store::Store)
                            .access(opaque_depth, sampled_fragment)
                            // Layer 0 does not read it, but its pipeline binds it.
                            .access(depth[previous], sampled_fragment)
                            .accesses(shadow_reads.iter().copied())
                            .record(move |ctx| {
                                let set = Some(p.peel_sets[current]);
                                self.draw_transparent(ctx, &inputs, &p.peel, &p.peel_layout, set, |push| {
                                    push.layer = layer
                                });
                                Ok(())
                            });
                        let push =
                            PeelUnderPush { weight, msaa, layer, last: (layer + 1 == p.layers) as u32 };
                        // Every layer's pass declares the opaque colour and the accumulation image,
                        // which the pipeline binds, though only the last one reads and writes them.
                        g.pass("oit peel under")
                            .access(layer_color, sampled_compute)
                            .access(layer_transmittance, sampled_compute)
                            .access(opaque_color, sampled_compute)
                            .access(accumulators, Access::ComputeShaderReadWrite)
                            .access(accum, Access::ComputeShaderReadWrite)
                            .record(move |ctx| {
                                p.under.record(ctx, &push, size);
                                Ok(())
                            });
                    }
                    Ok(())
                })?;
            }
        }
        let readback = g.read_back(accum)?;
        let mut result = frame.run(g)?;
        Ok(result.take_image(readback))
    }

    /// The opaque objects into the opaque colour and depth (both kept for the passes after it).
    fn opaque_pass<'a>(
        &'a self,
        g: &mut crate::graph::FrameGraph<'a>,
        inputs: &FrameInputs<'a>,
        color: ImageHandle,
        depth: ImageHandle,
        background: [f32; 4],
        shadow_reads: &[(ResourceHandle, Access)],
    ) {
        let inputs = *inputs;
        g.pass("oit opaque")
            .color(color, Load::Clear(background), Store::Store)
            .depth(depth, Load::Clear(0.0), Store::Store)
            .accesses(shadow_reads.iter().copied())
            .record(move |ctx| {
                let pass = (&self.samples[ctx.iteration as usize], self.samples.len() as u32);
                let opaque = |i: usize| !self.objects[i].transparent;
                self.opaque.record_draws(ctx, inputs.world, inputs.camera, pass, opaque);
                Ok(())
            });
    }
}

impl FrameTechnique for OitTechnique {
    fn render(&mut self, inputs: &FrameInputs<'_>, frame: &mut FrameContext<'_>) -> Result<TechniqueFrame> {
        let image = self.render_frame(frame, inputs)?;
        Ok(TechniqueFrame {
            image,
            passes: self.samples.len() as u32,
            msaa_samples: self.msaa,
            counters: None,
            clusters: vec![],
        })
    }

    fn transparency(&self) -> Option<TransparencyMethod> {
        Some(self.method)
    }

    fn shadows(&self) -> Option<String> {
        self.shadows.as_ref().map(ShadowMaps::summary)
    }
}

/// What `oit/` expects of its pipelines' layouts: sets 0 and 1, set 3 per pipeline, the pushes above.
pub const SHADER_INTERFACES: &[crate::gpu::layout::ShaderInterface] = &[
    crate::gpu::layout::ShaderInterface::technique(
        &["oit/stochastic_depth.frag", "oit/transmittance.frag"],
        None,
        None,
        Some(OIT_STRUCTS[0]),
    ),
    crate::gpu::layout::ShaderInterface::technique(
        &["oit/layers.frag"],
        None,
        Some(&LAYERS_SET),
        Some(OIT_STRUCTS[0]),
    )
    .with_shadows(&super::shadow_maps::SHADOW_SET),
    crate::gpu::layout::ShaderInterface::technique(
        &["oit/peel.frag"],
        None,
        Some(&PEEL_SET),
        Some(OIT_STRUCTS[0]),
    )
    .with_shadows(&super::shadow_maps::SHADOW_SET),
    crate::gpu::layout::ShaderInterface::technique(
        &["oit/depth_composite.comp"],
        None,
        Some(&DEPTH_COMPOSITE_SET),
        Some(OIT_STRUCTS[1]),
    ),
    crate::gpu::layout::ShaderInterface::technique(
        &["oit/peel_under.comp"],
        None,
        Some(&PEEL_UNDER_SET),
        Some(OIT_STRUCTS[2]),
    ),
];
