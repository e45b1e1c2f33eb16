//! Shadow maps on the GPU (docs/SHADOWS.md; the plan and the lookup math: [`crate::mirror::shadow_maps`]): every
//! shadow-casting light's faces rendered through the frame graph into one depth atlas — a light is a
//! second view ([`GpuView`]), drawn by the forward vertex stage — and, for tinted casters, a hue atlas;
//! and the descriptor set (set 3 of a receiving forward pipeline, set 4 of the stochastic shading
//! pass: `gpu::layout::SHADOW_SET_INDEX`) with which a receiving fragment stage reads
//! them (`shaders-glsl/common/shadow.glsl`).
//!
//! Per frame (or per pass when anything moves: the maps follow each pass' shutter time):
//!
//! 1. `shadow maps` (raster, the depth atlas cleared to 0): for each face and each of its sub-maps, the
//!    viewport set to its tile; opaque casters drawn depth-only, casters with coverage below 1 by
//!    `shadow/caster.frag`, which keeps the MSAA samples its stochastic coverage gives it (coverage
//!    `1 − max τ` for a transmittance τ = (1 − α)·tint).
//! 2. `shadow hues` (coloured maps only; raster, the hue atlas cleared to (1, 1, 1, 0), the depth atlas
//!    read-only): each tinted caster in front of the stored depth multiplies its hue `τ / max τ` into
//!    the samples it does not cover and raises alpha to its depth.
//!
//! Shaders: `shaders-glsl/shadow/caster.frag` with `forward/forward.vert`.

use ash::vk;
use glam::Vec2;

use super::forward::{
    transparent_objects, CoverageSamples, ForwardPush, PassSample, TransparentObject, TransparentPush,
};
use super::settings::{key, OptionKey};
use super::FrameInputs;
use crate::error::Result;
use crate::gpu::layout::{
    vertex_input, Binding, GpuShadowHeader, GpuShadowView, PROJECTION_ORTHOGRAPHIC, PROJECTION_PERSPECTIVE,
};
use crate::gpu::{object_view_records, GpuView, GpuWorld};
use crate::graph::{Access, FrameGraph, ImageHandle, Load, PassContext, ResourceHandle, Store, Tracked};
use crate::mirror::shadow_maps::{map_seed, FaceProjection, ShadowKind, ShadowPlan, ShadowSettings};
use crate::scene::Scene;
use crate::shaders;
use crate::shaders::axes::Shadows;
use crate::transparency::coverage_seed;
use crate::vk::{
    write_descriptors, Buffer, ColorBlend, DescriptorPool, DescriptorSetLayout, DescriptorWrite, Device,
    Faces, GraphicsDesc, Image, ImageDesc, Pipeline, PipelineLayout, Sampler, ShaderModule,
};

/// Depth atlas format (reversed Z, cleared to 0) and the hue atlas' (rgb hue product, a nearest
/// tinted depth: 32-bit so that depth compares as finely as the depth atlas').
pub const SHADOW_DEPTH_FORMAT: vk::Format = vk::Format::D32_SFLOAT;
pub const SHADOW_HUE_FORMAT: vk::Format = vk::Format::R32G32B32A32_SFLOAT;

const SAMPLER: vk::DescriptorType = vk::DescriptorType::COMBINED_IMAGE_SAMPLER;
const SSBO: vk::DescriptorType = vk::DescriptorType::STORAGE_BUFFER;

/// The receivers' set (`common/shadow.glsl`): set 3 of a forward pipeline, set 4 of the stochastic
/// shading pass.
pub const SHADOW_SET: [Binding; 4] = [
    Binding { binding: 0, ty: SAMPLER, block: "shadow_depth" },
    Binding { binding: 1, ty: SAMPLER, block: "shadow_color" },
    Binding { binding: 2, ty: SSBO, block: "ShadowInfo" },
    Binding { binding: 3, ty: SSBO, block: "ShadowObjectViews" },
];

/// The atlas handles of one graph.
#[derive(Clone, Copy, Debug)]
pub struct ShadowHandles {
    depth: ImageHandle,
    hue: Option<ImageHandle>,
}

/// The shadow maps' settings key (parsed by [`ShadowSettings`]' `FromStr`), read by every technique
/// that renders a scene's shadow-casting lights.
pub const KEYS: &[OptionKey] = &[key("shadow-map", "shadow maps", "SIZE[/SAMPLES[/PCF]] or off", "512/4/1")];

/// Every shadow-casting light's maps, their passes and the receivers' descriptor set.
pub struct ShadowMaps {
    plan: ShadowPlan,
    faces: Vec<GpuView>,
    origins: Vec<[u32; 2]>,
    casters: Vec<TransparentObject>,
    depth_atlas: Tracked<Image>,
    hue_atlas: Option<Tracked<Image>>,
    depth_only: Pipeline,
    coverage: Option<Pipeline>,
    hue: Option<Pipeline>,
    layout: PipelineLayout,
    set_layout: DescriptorSetLayout,
    set: vk::DescriptorSet,
    coverage_seed: u32,
    /// The shutter time of each pass when something moves (maps rendered per pass); empty: rendered
    /// once per frame, at mid-shutter.
    pass_times: Vec<f32>,
    _pool: DescriptorPool,
    _info: Buffer,
    _object_views: Buffer,
    _sampler: Sampler,
    _shaders: Vec<ShaderModule>,
}

impl ShadowMaps {
    /// The maps of `scene`'s shadow-casting lights with `settings` (`None` when no light casts
    /// shadows), for a frame of passes at shutter times `pass_times`, coverage seeded by `seed`.
    pub fn new(
        device: &Device,
        world: &GpuWorld,
        scene: &Scene,
        settings: &ShadowSettings,
        pass_times: &[f32],
        seed: u64,
    ) -> Result<Option<ShadowMaps>> {
        let Some(plan) = ShadowPlan::new(scene, settings, &device.caps.framebuffer_sample_counts)? else {
            return Ok(None);
        };
        let mut faces = Vec::new();
        let mut origins = Vec::new();
        let mut views = Vec::new();
        let mut header = GpuShadowHeader {
            counts: [plan.samples(), plan.msaa, plan.sub_maps, settings.pcf_radius],
            spaces: [0; 4],
            bias: [settings.depth_bias, 0.0, 0.0, 0.0],
            lights: [[0; 4]; crate::gpu::layout::MAX_LIGHTS],
        };
        let mut object_views = Vec::new();
        for (space, l) in plan.lights.iter().enumerate() {
            let (records, _) = object_view_records(&l.lookup);
            header.spaces[0] = records.len() as u32;
            object_views.extend(records);
            header.lights[l.light] = [1, faces.len() as u32, l.faces.len() as u32, space as u32];
            for f in &l.faces {
                let p = FaceProjection::of(&f.view);
                let kind = if p.orthographic { PROJECTION_ORTHOGRAPHIC } else { PROJECTION_PERSPECTIVE };
                views.push(GpuShadowView {
                    base_to_face: f.base_to_face.to_cols_array(),
                    projection: [kind, p.a, p.b, p.size],
                    depth: [p.near, p.far, f.origin[0] as f32, f.origin[1] as f32],
                });
                faces.push(GpuView::new(device, world, &f.view)?);
                origins.push(f.origin);
            }
        }
        if object_views.is_empty() {
            object_views.push(bytemuck::Zeroable::zeroed());
        }
        let mut info: Vec<u8> = bytemuck::bytes_of(&header).to_vec();
        info.extend_from_slice(bytemuck::cast_slice(&views));
        let info = Buffer::with_data(device, "shadow info", vk::BufferUsageFlags::STORAGE_BUFFER, &info)?;
        let object_views = Buffer::with_data(
            device,
            "shadow lookup object views",
            vk::BufferUsageFlags::STORAGE_BUFFER,
            &object_views,
        )?;

        let (w, h) = plan.atlas;
        let sampled = vk::ImageUsageFlags::SAMPLED;
        let depth_atlas = Tracked::new(Image::new(
            device,
            "shadow depth atlas",
            ImageDesc::new_2d(
                w,
                h,
                SHADOW_DEPTH_FORMAT,
                vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT | sampled,
            )
            .samples(plan.msaa),
        )?);
        let colored = plan.kind == ShadowKind::Colored;
        let hue_atlas = if colored {
            Some(Tracked::new(Image::new(
                device,
                "shadow hue atlas",
                ImageDesc::new_2d(w, h, SHADOW_HUE_FORMAT, vk::ImageUsageFlags::COLOR_ATTACHMENT | sampled)
                    .samples(plan.msaa),
            )?))
        } else {
            None
        };

        let sampler = Sampler::nearest_clamp(device, "shadow atlas")?;
        let set_layout = DescriptorSetLayout::from_table(
            device,
            "shadow set layout",
            &SHADOW_SET,
            vk::ShaderStageFlags::FRAGMENT | vk::ShaderStageFlags::COMPUTE,
        )?;
        let pool = DescriptorPool::for_tables(device, 1, &[(&SHADOW_SET, 1)])?;
        let set = pool.allocate(&set_layout)?;
        let mut writes = vec![
            DescriptorWrite::SampledImage { binding: 0, view: depth_atlas.view, sampler: sampler.raw },
            DescriptorWrite::storage_buffer(2, &info),
            DescriptorWrite::storage_buffer(3, &object_views),
        ];
        // Binding 1 is read only by the coloured lookup; without a hue atlas it names the depth atlas,
        // so that no binding of the set is left unwritten (lavapipe binds every one of them).
        let hue_view = hue_atlas.as_ref().map_or(depth_atlas.view, |h| h.view);
        writes.push(DescriptorWrite::SampledImage { binding: 1, view: hue_view, sampler: sampler.raw });
        write_descriptors(device, set, &writes);

        // The casters' pipelines: the forward vertex stage through each face's view.
        let vert = ShaderModule::new(device, shaders::FORWARD_FORWARD_VERT)?;
        let layout = world.pipeline_layout(
            device,
            &[],
            std::mem::size_of::<TransparentPush>() as u32,
            vk::ShaderStageFlags::VERTEX | vk::ShaderStageFlags::FRAGMENT,
        )?;
        let (bindings, attributes) = vertex_input();
        let desc =
            |name: &'static str, stages: &[&ShaderModule], color_formats: &[vk::Format], depth_write| {
                let d = GraphicsDesc {
                    name,
                    stages,
                    vertex_bindings: &bindings,
                    vertex_attributes: &attributes,
                    color_formats,
                    depth_format: Some(SHADOW_DEPTH_FORMAT),
                    samples: plan.msaa,
                    sample_shading: None,
                    // Every surface casts from both sides, as the reference's shadow rays see them.
                    faces: Faces::Both,
                    depth_compare: vk::CompareOp::GREATER,
                    depth_write,
                    overestimate: false,
                };
                let blend =
                    if color_formats.is_empty() { ColorBlend::Replace } else { ColorBlend::MultiplyMaxAlpha };
                Pipeline::graphics_blended(device, &layout, &d, blend)
            };
        let depth_only = desc("shadow depth", &[&vert], &[], true)?;
        let casters = transparent_objects(scene);
        let mut modules = vec![];
        let (mut coverage, mut hue) = (None, None);
        if plan.kind != ShadowKind::Plain {
            let source = |hue_pass| shaders::CasterFrag { hue_pass }.source();
            let cov_frag = ShaderModule::new(device, source(false))?;
            coverage = Some(desc("shadow caster coverage", &[&vert, &cov_frag], &[], true)?);
            modules.push(cov_frag);
            if colored {
                let hue_frag = ShaderModule::new(device, source(true))?;
                hue = Some(desc("shadow caster hue", &[&vert, &hue_frag], &[SHADOW_HUE_FORMAT], false)?);
                modules.push(hue_frag);
            }
        }
        modules.push(vert);
        let moving = crate::mirror::shadow_maps::casters_move(scene);
        Ok(Some(ShadowMaps {
            plan,
            faces,
            origins,
            casters,
            depth_atlas,
            hue_atlas,
            depth_only,
            coverage,
            hue,
            layout,
            set_layout,
            set,
            coverage_seed: coverage_seed(seed),
            pass_times: if moving { pass_times.to_vec() } else { vec![] },
            _pool: pool,
            _info: info,
            _object_views: object_views,
            _sampler: sampler,
            _shaders: modules,
        }))
    }

    /// The plan the maps follow.
    pub fn plan(&self) -> &ShadowPlan {
        &self.plan
    }

    /// One line for a render's report: the plan's summary and when the maps are rendered.
    pub fn summary(&self) -> String {
        let when = if self.per_pass() { "before every pass" } else { "once per frame" };
        format!("{}, rendered {when}", self.plan.summary())
    }

    /// Binds the receivers' set as set `index` of `layout`.
    pub fn bind(
        &self,
        ctx: &PassContext<'_>,
        bind_point: vk::PipelineBindPoint,
        layout: &PipelineLayout,
        index: u32,
    ) {
        ctx.bind_sets(bind_point, layout, index, &[self.set]);
    }

    /// Whether the maps are rendered before every pass (something moves) rather than once per frame.
    pub fn per_pass(&self) -> bool {
        !self.pass_times.is_empty()
    }

    /// The receivers' set and its layout.
    pub fn set(&self) -> vk::DescriptorSet {
        self.set
    }
    pub fn set_layout(&self) -> &DescriptorSetLayout {
        &self.set_layout
    }

    /// The receiving fragment stage's permutation: how it reads the depth atlas, and whether it
    /// reads the hue atlas.
    pub fn lookup(&self) -> (Shadows, bool) {
        let shadows = if self.plan.msaa > 1 { Shadows::Multisample } else { Shadows::Single };
        (shadows, self.plan.kind == ShadowKind::Colored)
    }

    /// Imports the atlases into `g`.
    pub fn import<'a>(&'a self, g: &mut FrameGraph<'a>) -> ShadowHandles {
        ShadowHandles {
            depth: g.import_image("shadow depth atlas", &self.depth_atlas),
            hue: self.hue_atlas.as_ref().map(|h| g.import_image("shadow hue atlas", h)),
        }
    }

    /// What a receiving raster pass reads.
    pub fn reads(h: ShadowHandles) -> Vec<(ResourceHandle, Access)> {
        Self::reads_as(h, Access::FragmentShaderReadSampledImageOrUniformTexelBuffer)
    }

    /// What a receiving pass reads, by `access` (a compute shading pass:
    /// `ComputeShaderReadSampledImageOrUniformTexelBuffer`).
    pub fn reads_as(h: ShadowHandles, access: Access) -> Vec<(ResourceHandle, Access)> {
        std::iter::once(h.depth).chain(h.hue).map(|i| (i.into(), access)).collect()
    }

    /// Adds the passes that render the maps once per frame, ahead of the frame's passes — when
    /// nothing moves (otherwise [`ShadowMaps::add_pass_passes`] does, per pass).
    pub fn add_frame_passes<'a>(
        &'a self,
        g: &mut FrameGraph<'a>,
        h: ShadowHandles,
        inputs: &FrameInputs<'a>,
    ) {
        if !self.per_pass() {
            self.add_passes(g, h, inputs, false);
        }
    }

    /// Inside the repeat of the frame's passes: the passes that render the maps at the shutter time
    /// of the iteration's pass — when something moves.
    pub fn add_pass_passes<'a>(&'a self, g: &mut FrameGraph<'a>, h: ShadowHandles, inputs: &FrameInputs<'a>) {
        if self.per_pass() {
            self.add_passes(g, h, inputs, true);
        }
    }

    /// The passes that render the maps: at mid-shutter, or (`per_pass`) at the time of the
    /// repeat's iteration's pass.
    fn add_passes<'a>(
        &'a self,
        g: &mut FrameGraph<'a>,
        h: ShadowHandles,
        inputs: &FrameInputs<'a>,
        per_pass: bool,
    ) {
        let inputs = *inputs;
        g.pass("shadow maps").depth(h.depth, Load::Clear(0.0), Store::Store).record(move |ctx| {
            let pass = if per_pass { ctx.iteration } else { 0 };
            self.record_casters(ctx, &inputs, pass, false);
            Ok(())
        });
        if let Some(hue) = h.hue {
            g.pass("shadow hues")
                .color(hue, Load::Clear([1.0, 1.0, 1.0, 0.0]), Store::Store)
                .depth_read_only(h.depth)
                .record(move |ctx| {
                    let pass = if per_pass { ctx.iteration } else { 0 };
                    self.record_casters(ctx, &inputs, pass, true);
                    Ok(())
                });
        }
    }

    /// Every face's tiles: the depth draws, or (`hues`) the tinted casters' hue draws.
    fn record_casters(&self, ctx: &PassContext<'_>, inputs: &FrameInputs<'_>, pass: u32, hues: bool) {
        let time = self.pass_times.get(pass as usize).copied().unwrap_or(0.5);
        let size = self.plan.settings.size;
        for (f, (view, origin)) in self.faces.iter().zip(&self.origins).enumerate() {
            let seed = map_seed(self.coverage_seed, f as u32, pass);
            for j in 0..self.plan.sub_maps {
                let (x, y) = (origin[0] + j * size, origin[1]);
                ctx.set_viewport(crate::vk::atlas_square(x, y, size));
                let samples = CoverageSamples {
                    seed,
                    samples: self.plan.samples(),
                    base: j * self.plan.msaa,
                    msaa: self.plan.msaa,
                };
                let sample = PassSample { time, lens: Vec2::ZERO, jitter: Vec2::ZERO };
                let push = |i: usize| {
                    TransparentPush::new(ForwardPush::new(view, i, &sample), &self.casters[i], samples)
                };
                let draw = |pipeline: &Pipeline, include: &dyn Fn(usize) -> bool| {
                    ctx.bind_pipeline(pipeline);
                    inputs.world.record_object_draws(
                        ctx,
                        view,
                        pipeline,
                        &self.layout,
                        include,
                        push,
                        |_| None,
                    );
                };
                if hues {
                    if let Some(p) = &self.hue {
                        draw(p, &|i| self.casters[i].tinted);
                    }
                } else {
                    draw(&self.depth_only, &|i| !self.casters[i].transparent);
                    if let Some(p) = &self.coverage {
                        draw(p, &|i| self.casters[i].transparent);
                    }
                }
            }
        }
    }
}

/// What `shadow/` expects of [`ShadowMaps`]' caster layout: sets 0 and 1, [`TransparentPush`].
pub const SHADER_INTERFACES: &[crate::gpu::layout::ShaderInterface] =
    &[crate::gpu::layout::ShaderInterface::technique(
        &["shadow/caster.frag"],
        None,
        None,
        Some(super::forward::FORWARD_STRUCTS[1]),
    )];
