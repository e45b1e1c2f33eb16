//! Technique `interleaved`: interleaved deferred shading of virtual point lights (Segovia, Iehl,
//! Mitanchey & Péroche 2006; docs/INTERLEAVED.md) for a scene's one-bounce indirect light
//! (`[environment] indirect = "one-bounce"`), on top of its direct light. The GPU port of
//! [`crate::mirror::interleaved`], which specifies every step; shaders in `shaders-glsl/interleaved/`.
//!
//! As a graph, one pass each, timestamped by name:
//! 1. `interleaved direct`: the forward pipeline's direct light (shadow maps included) through the
//!    pass' sample; `interleaved G-buffer`: position, normal, albedo (`gbuffer.frag`, the same draws);
//! 2. `interleaved pack` and `interleaved split`: position and normal into the padded layout, then
//!    split in one pass or two (block split, block translation: `permute.comp`; the pattern 1×1
//!    splits into itself and skips it, and the gather);
//! 3. `interleaved shade`: each split texel gathers its sub-buffer's VPL subset, scaled by `n·m`,
//!    through a cube shadow map per VPL ([`InterleavedOptions::vpl_maps`], the paper's SSM and the
//!    default: `interleaved VPL shadow maps` renders them first, one instanced draw per object over
//!    the faces its bounds reach) or, with `vpl_maps: None`, without VPL visibility (its SNSM);
//! 4. `interleaved gather`: the inverse permutation(s);
//! 5. `interleaved discontinuity` and 6. `interleaved blur` (both directions) unless the filter is off;
//! 7. `interleaved compose`: direct + albedo × filtered indirect, added to the frame with the pass'
//!    weight.
//!
//! A still pinhole scene is one such pass, through the pixel centres at mid-shutter. A scene with a
//! lens or motion repeats all seven steps for `spp` passes, each through one (subpixel, lens, time)
//! sample shared by every pixel — technique `accumulation`'s samples — and averages them
//! ([`crate::mirror::interleaved::frame_passes`]). A moving scene's VPLs are a set per pass, traced at its
//! time, and its VPL shadow maps are rendered in every pass; a still scene's are one set, its maps
//! rendered once.
//!
//! The VPLs are the reference's ([`crate::reference::virtual_point_lights`], traced on the CPU at
//! prepare time, uploaded): the CPU mirror with the same settings and no VPL visibility computes the
//! same image (with shadow maps, the mirror's exact shadow rays are what they approximate), but for the direct light's shadows (shadow maps here, exact rays there) and the f32
//! rounding between a rasterized and a ray-traced G-buffer. The pattern 1×1 without a filter is the
//! brute force: every pixel gathers every VPL. Opaque scenes only.

use ash::vk;
use bytemuck::{Pod, Zeroable};

use super::forward::{ForwardPipeline, ForwardPush, PassSample, FORWARD_STRUCTS};
use super::multipass::{accumulation_image, DEPTH_FORMAT};
use super::settings::{key, number, setting_error, OptionKey};
use super::shadow_maps::ShadowMaps;
use super::{
    FrameContext, FrameInputs, FrameTechnique, PrepareContext, TechniqueCapabilities, TechniqueFrame,
    TechniqueInfo,
};
use crate::error::{Error, Result};
use crate::gpu::layout::{shared_struct, vertex_input, Binding, SharedStruct, TECHNIQUE_SET_INDEX};
use crate::graph::{
    Access, BufferHandle, FrameGraph, ImageHandle, Load, PassContext, ResourceHandle, Store, Tracked,
};
use crate::mirror::interleaved::{Blur, Discontinuity, Edges, Layout, Pattern};
use crate::shaders;
use crate::vk::{
    write_descriptors, Buffer, DescriptorPool, DescriptorSetLayout, DescriptorWrite, Faces, GraphicsDesc,
    Image, ImageDesc, Pipeline, PipelineLayout, ShaderModule,
};
use gpu_allocator::MemoryLocation;

/// The registry entry.
pub const INFO: TechniqueInfo = TechniqueInfo {
    name: "interleaved",
    summary: "interleaved deferred shading of virtual point lights for one-bounce indirect light (Segovia et al. 2006): split G-buffer, per-sub-buffer VPL subsets, edge-aware blur",
    keys: &[KEYS, super::shadow_maps::KEYS],
    required_features: &[],
    capabilities: TechniqueCapabilities { transparency: false, transparency_methods: false, embeddable: false },
    prepare,
};

fn prepare(ctx: &PrepareContext<'_>) -> Result<Box<dyn FrameTechnique>> {
    Ok(Box::new(InterleavedTechnique::new(ctx)?))
}

/// How the split is done.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Split {
    /// One permutation.
    OnePass,
    /// Block splitting, then block translation (the paper's cache-friendly variant).
    #[default]
    TwoPass,
}

impl std::str::FromStr for Split {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        match s {
            "one" => Ok(Split::OnePass),
            "two" => Ok(Split::TwoPass),
            _ => Err(Error::Unsupported(format!("split `{s}`: one or two (passes)"))),
        }
    }
}

/// Technique `interleaved`'s settings keys ([`InterleavedOptions::set`] parses them).
pub const KEYS: &[OptionKey] = &[
    key("vpls", "interleaved", "photons", "256"),
    key("clamp", "interleaved", "the VPLs' clamp distance", "0.2"),
    key("pattern", "interleaved", "NxM", "8x6"),
    key("split", "interleaved", "one or two", "one"),
    key("block", "interleaved", "BxB patterns", "2x2"),
    key("filter", "interleaved", "none, plain, full or axis", "plain"),
    key("radius", "interleaved", "the filter's radius in texels", "3"),
    key("bilinear", "interleaved", "false, true (pairs lerped in the shader) or sampler", "true"),
    key("vpl-maps", "interleaved", "SIZE texels a face, or off", "16"),
];

/// Settings of technique `interleaved`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct InterleavedOptions {
    /// Photons traced from the lights ([`crate::reference::VplSettings::count`]).
    pub photons: u32,
    /// The VPLs' `1/d²` clamping distance, scene units (0: off).
    pub clamp: f32,
    pub pattern: Pattern,
    pub split: Split,
    /// The two-pass split's block, in patterns.
    pub block: (u32, u32),
    /// `None`: no filter.
    pub blur: Option<Blur>,
    /// With the blur's bilinear pairs: each pair fetched by the hardware's linear filter (a sampler
    /// over an image, the paper's trick) rather than two loads lerped in the shader.
    pub bilinear_sampler: bool,
    pub discontinuity: Discontinuity,
    /// The VPLs' visibility: `Some(size)`, a cube shadow map per VPL of `size`² texels per face (the
    /// paper's SSM; the default, 32²); `None`, none (its SNSM: every VPL lights every surface facing
    /// it, hidden or not, which leaves FLIP 0.11 on `cornell` whatever the other options, twice the
    /// maps' error).
    pub vpl_maps: Option<u32>,
}

/// The VPL shadow maps' depth bias: a receiver is lit when its distance from the VPL is at most the
/// map's times (1 + bias) plus bias (scene units) — the texels of a small map span a range of depths.
pub const VPL_SHADOW_BIAS: f32 = 0.05;

impl Default for InterleavedOptions {
    fn default() -> Self {
        InterleavedOptions {
            photons: 1024,
            clamp: 0.1,
            pattern: Pattern { n: 4, m: 4 },
            split: Split::TwoPass,
            block: (4, 4),
            blur: Some(Blur { radius: 4, bilinear: false, edges: Edges::Texel }),
            bilinear_sampler: false,
            discontinuity: Discontinuity::default(),
            vpl_maps: Some(32),
        }
    }
}

/// Set 3 of the compute passes (`interleaved/common.glsl`).
pub const INTERLEAVED_SET: [Binding; 14] = [
    Binding { binding: 0, ty: vk::DescriptorType::STORAGE_BUFFER, block: "Texels" },
    Binding { binding: 1, ty: vk::DescriptorType::STORAGE_BUFFER, block: "Vpls" },
    Binding { binding: 2, ty: vk::DescriptorType::STORAGE_BUFFER, block: "Flags" },
    Binding { binding: 3, ty: vk::DescriptorType::STORAGE_IMAGE, block: "g_position" },
    Binding { binding: 4, ty: vk::DescriptorType::STORAGE_IMAGE, block: "g_normal" },
    Binding { binding: 5, ty: vk::DescriptorType::STORAGE_IMAGE, block: "g_albedo" },
    Binding { binding: 6, ty: vk::DescriptorType::STORAGE_IMAGE, block: "g_direct" },
    Binding { binding: 7, ty: vk::DescriptorType::STORAGE_IMAGE, block: "result" },
    Binding { binding: 8, ty: vk::DescriptorType::COMBINED_IMAGE_SAMPLER, block: "vpl_maps" },
    Binding { binding: 9, ty: vk::DescriptorType::STORAGE_BUFFER, block: "VplFaces" },
    Binding { binding: 10, ty: vk::DescriptorType::COMBINED_IMAGE_SAMPLER, block: "blur_x_source" },
    Binding { binding: 11, ty: vk::DescriptorType::COMBINED_IMAGE_SAMPLER, block: "blur_y_source" },
    Binding { binding: 12, ty: vk::DescriptorType::STORAGE_IMAGE, block: "blur_mid" },
    Binding { binding: 13, ty: vk::DescriptorType::STORAGE_BUFFER, block: "VplFaceLists" },
];

/// Push constants of the compute passes (`Push` in `interleaved/common.glsl`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct InterleavedPush {
    pub width: u32,
    pub height: u32,
    pub padded_w: u32,
    pub padded_h: u32,
    pub n: u32,
    pub m: u32,
    pub block_w: u32,
    pub block_h: u32,
    pub sub_w: u32,
    pub sub_h: u32,
    pub src: u32,
    pub dst: u32,
    pub stride: u32,
    pub map: u32,
    pub pull: u32,
    pub vpl_first: u32,
    pub vpl_count: u32,
    pub clamp2: f32,
    pub radius: u32,
    pub axis: u32,
    pub edges: u32,
    pub bilinear: u32,
    pub normal_cos: f32,
    pub position_rel: f32,
    pub face_size: u32,
    pub atlas_cols: u32,
    pub far: f32,
    pub shadow_bias: f32,
    pub weight: f32,
}

/// Push constants of `vpl_shadow.vert` and `.frag`: one object's draw of every face of the pass' set.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct VplShadowPush {
    pub object: u32,
    /// The object's key segment holding the pass' time, and the time within it.
    pub segment: u32,
    pub segment_time: f32,
    /// The set's first face in `VplFaces`: 6 × its first VPL.
    pub first_face: u32,
    pub atlas_cols: u32,
    pub face_size: u32,
    /// The maps' far distance.
    pub far: f32,
    pub pad: u32,
    /// The atlas' size in texels.
    pub atlas_size: [f32; 2],
}

/// A VPL as `Vpls` holds it.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct GpuVpl {
    pub position: [f32; 4],
    pub normal: [f32; 4],
    pub flux: [f32; 4],
}

/// For the reflection test.
pub const INTERLEAVED_STRUCTS: &[SharedStruct] = &[
    shared_struct!(
        "Push",
        InterleavedPush,
        [
            width,
            height,
            padded_w,
            padded_h,
            n,
            m,
            block_w,
            block_h,
            sub_w,
            sub_h,
            src,
            dst,
            stride,
            map,
            pull,
            vpl_first,
            vpl_count,
            clamp2,
            radius,
            axis,
            edges,
            bilinear,
            normal_cos,
            position_rel,
            face_size,
            atlas_cols,
            far,
            shadow_bias,
            weight
        ]
    ),
    shared_struct!(
        "Push",
        VplShadowPush,
        [object, segment, segment_time, first_face, atlas_cols, face_size, far, pad, atlas_size]
    ),
    shared_struct!("Vpl", GpuVpl, [position, normal, flux]),
];

/// `MAP_*` of `permute.comp`.
const MAP_SPLIT: u32 = 0;
const MAP_BLOCK_SPLIT: u32 = 1;
const MAP_BLOCK_TRANSLATE: u32 = 2;

/// The G-buffer targets' format.
const GBUFFER_FORMAT: vk::Format = vk::Format::R32G32B32A32_SFLOAT;

/// Where each region of the texel buffer starts, in vec4s (`n` texels of the padded layout).
#[derive(Clone, Copy, Debug)]
struct Regions {
    packed: u32,
    split_tmp: u32,
    split: u32,
    shaded: u32,
    gather_tmp: u32,
    gathered: u32,
    blur_x: u32,
    blur_y: u32,
    total: u32,
}

impl Regions {
    fn new(n: u32) -> Regions {
        Regions {
            packed: 0,
            split_tmp: 2 * n,
            split: 4 * n,
            shaded: 6 * n,
            gather_tmp: 7 * n,
            gathered: 8 * n,
            blur_x: 9 * n,
            blur_y: 10 * n,
            total: 11 * n,
        }
    }
}

struct ComputePipelines {
    pack: Pipeline,
    permute: Pipeline,
    shade: Pipeline,
    discontinuity: Pipeline,
    blur: Pipeline,
    /// The blur's x and y passes with hardware-filtered pairs (`bilinear_sampler`).
    blur_sampled: Option<(Pipeline, Pipeline)>,
    compose: Pipeline,
    layout: PipelineLayout,
    set: vk::DescriptorSet,
    _set_layout: DescriptorSetLayout,
    _pool: DescriptorPool,
    _shaders: Vec<ShaderModule>,
}

/// The technique, prepared for one scene and settings.
pub struct InterleavedTechnique {
    options: InterleavedOptions,
    layout: Layout,
    regions: Regions,
    /// The frame's passes ([`crate::mirror::interleaved::frame_passes`]).
    passes: Vec<PassSample>,
    /// Each VPL set's first VPL and count in `Vpls`: one for a still scene, one per pass otherwise.
    vpl_sets: Vec<(u32, u32)>,
    direct: ForwardPipeline,
    gbuffer: Pipeline,
    gbuffer_layout: PipelineLayout,
    _gbuffer_shaders: Vec<ShaderModule>,
    compute: ComputePipelines,
    g_position: Tracked<Image>,
    g_normal: Tracked<Image>,
    g_albedo: Tracked<Image>,
    g_direct: Tracked<Image>,
    result: Tracked<Image>,
    texels: Tracked<Buffer>,
    flags: Tracked<Buffer>,
    /// The hardware-filtered blur's images (1×1 placeholders without it): the gathered light, and
    /// the x pass' result.
    blur_in: Tracked<Image>,
    blur_mid: Tracked<Image>,
    _blur_sampler: crate::vk::Sampler,
    _vpls: Buffer,
    /// The VPL shadow maps (a 1×1 placeholder without them), their faces' matrices and pipeline.
    vpl_atlas: Tracked<Image>,
    _vpl_faces_buffer: Buffer,
    _face_lists_buffer: Buffer,
    /// Per set and object (set-major), the `(count, first)` of its faces in `VplFaceLists`: the
    /// instances of its draw.
    face_ranges: Vec<(u32, u32)>,
    _vpl_sampler: crate::vk::Sampler,
    vpl_shadow: Option<(Pipeline, PipelineLayout, Vec<ShaderModule>)>,
    atlas_cols: u32,
    far: f32,
    /// The VPL shadow maps of a still scene are in the atlas (rendered by the first frame).
    maps_rendered: bool,
    // Dropped after the direct pipeline whose set layout it uses.
    shadows: Option<ShadowMaps>,
}

impl InterleavedTechnique {
    pub fn new(ctx: &PrepareContext<'_>) -> Result<Self> {
        let (device, world, scene, s) = (ctx.device, ctx.world, ctx.scene, ctx.settings);
        let options = s.interleaved;
        if super::forward::has_transparency(scene) {
            return Err(Error::Unsupported(
                "technique interleaved shades opaque surfaces only: the scene has alpha or tints".into(),
            ));
        }
        let passes = crate::mirror::interleaved::frame_passes(scene, s.spp, s.seed);
        let vpl_settings =
            crate::reference::VplSettings { count: options.photons, clamp: options.clamp, seed: s.seed };
        let sets = crate::mirror::interleaved::pass_vpls(scene, &vpl_settings, &passes)?;
        let mut vpl_sets = Vec::with_capacity(sets.len());
        let mut first = 0;
        for set in &sets {
            vpl_sets.push((first, set.len() as u32));
            first += set.len() as u32;
        }
        let largest_set = vpl_sets.iter().map(|s| s.1).max().unwrap_or(0);
        let vpls: Vec<crate::reference::VirtualPointLight> = sets.into_iter().flatten().collect();
        let (width, height) = (s.width, s.height);
        let layout = Layout::new(width, height, options.pattern, options.block)?;
        let texel_count = layout.width * layout.height;
        let regions = Regions::new(texel_count);

        let pass_times: Vec<f32> = passes.iter().map(|p| p.time).collect();
        let shadows = ShadowMaps::new(device, world, scene, &s.shadows, &pass_times, s.seed)?;
        // The direct light: the forward pipeline into an RGBA32F target (COLOR_FORMAT, GBUFFER_FORMAT).
        let direct = ForwardPipeline::with_shadows(device, world, 1, shadows.as_ref())?;

        // The G-buffer pipeline: forward.vert, gbuffer.frag, three targets.
        let vert = super::forward::forward_vert(device, false)?;
        let frag = ShaderModule::new(device, shaders::INTERLEAVED_GBUFFER_FRAG)?;
        let stages = vk::ShaderStageFlags::VERTEX | vk::ShaderStageFlags::FRAGMENT;
        let gbuffer_layout =
            world.pipeline_layout(device, &[], std::mem::size_of::<ForwardPush>() as u32, stages)?;
        let (bindings, attributes) = vertex_input();
        let gbuffer = Pipeline::graphics(
            device,
            &gbuffer_layout,
            &GraphicsDesc {
                name: "interleaved G-buffer",
                stages: &[&vert, &frag],
                vertex_bindings: &bindings,
                vertex_attributes: &attributes,
                color_formats: &[GBUFFER_FORMAT; 3],
                depth_format: Some(DEPTH_FORMAT),
                samples: 1,
                sample_shading: None,
                faces: Faces::PerObject,
                depth_compare: vk::CompareOp::GREATER,
                depth_write: true,
                overestimate: false,
            },
        )?;

        let target = |name: &str, format: vk::Format| -> Result<Tracked<Image>> {
            let usage = vk::ImageUsageFlags::COLOR_ATTACHMENT | vk::ImageUsageFlags::STORAGE;
            Ok(Tracked::new(Image::new(device, name, ImageDesc::new_2d(width, height, format, usage))?))
        };
        let g_position = target("interleaved position", GBUFFER_FORMAT)?;
        let g_normal = target("interleaved normal", GBUFFER_FORMAT)?;
        let g_albedo = target("interleaved albedo", GBUFFER_FORMAT)?;
        let g_direct = target("interleaved direct", GBUFFER_FORMAT)?;
        let result = Tracked::new(accumulation_image(device, "interleaved result", (width, height))?);
        let storage = vk::BufferUsageFlags::STORAGE_BUFFER;
        let texels = Tracked::new(Buffer::new(
            device,
            "interleaved texels",
            regions.total as u64 * 16,
            // A transfer source for the hardware-filtered blur's copy.
            storage | vk::BufferUsageFlags::TRANSFER_SRC,
            MemoryLocation::GpuOnly,
        )?);
        let flags = Tracked::new(Buffer::new(
            device,
            "interleaved discontinuities",
            (width * height) as u64 * 4,
            storage,
            MemoryLocation::GpuOnly,
        )?);
        let gpu_vpls: Vec<GpuVpl> = vpls
            .iter()
            .map(|v| GpuVpl {
                position: [v.position.x, v.position.y, v.position.z, 1.0],
                normal: [v.normal.x, v.normal.y, v.normal.z, 0.0],
                flux: [v.flux.x, v.flux.y, v.flux.z, 0.0],
            })
            .collect();
        let placeholder = [GpuVpl::default()];
        let vpl_buffer = Buffer::with_data(
            device,
            "interleaved VPLs",
            storage,
            if gpu_vpls.is_empty() { &placeholder } else { &gpu_vpls },
        )?;

        let sampled_blur = options.bilinear_sampler && options.blur.is_some_and(|b| b.bilinear);
        if options.bilinear_sampler && !sampled_blur {
            return Err(Error::Unsupported(
                "bilinear=sampler: the hardware-filtered pairs need a filter with bilinear pairs".into(),
            ));
        }
        if sampled_blur {
            device.caps.require(crate::vk::Feature::LinearFilterRgba32f, "interleaved bilinear=sampler")?;
        }
        let (bw, bh) = if sampled_blur { (width, height) } else { (1, 1) };
        let blur_image = |name: &str, usage: vk::ImageUsageFlags| -> Result<Tracked<Image>> {
            let usage = usage | vk::ImageUsageFlags::SAMPLED;
            Ok(Tracked::new(Image::new(device, name, ImageDesc::new_2d(bw, bh, GBUFFER_FORMAT, usage))?))
        };
        let blur_in = blur_image("interleaved blur source", vk::ImageUsageFlags::TRANSFER_DST)?;
        let blur_mid = blur_image("interleaved blur x", vk::ImageUsageFlags::STORAGE)?;
        let blur_sampler = crate::vk::Sampler::linear_unnormalized(device, "interleaved blur")?;

        let set_layout = DescriptorSetLayout::from_table(
            device,
            "interleaved set layout",
            &INTERLEAVED_SET,
            // The VPL maps' vertex stage reads the VPLs and their faces.
            vk::ShaderStageFlags::COMPUTE | vk::ShaderStageFlags::VERTEX,
        )?;
        let compute_layout = world.pipeline_layout(
            device,
            &[&world.empty_layout, &set_layout],
            std::mem::size_of::<InterleavedPush>() as u32,
            vk::ShaderStageFlags::COMPUTE,
        )?;
        // The VPL shadow maps: six 90° faces per VPL in camera space, distances over `far` (twice the
        // radius around the camera that holds the scene at mid-shutter, so any two points fit).
        let radius = ctx
            .camera
            .space
            .objects
            .iter()
            .zip(&scene.objects)
            .flat_map(|(m, o)| o.mesh.positions.iter().map(move |&p| m.positions(p)[0].length()))
            .fold(0.0f32, f32::max);
        let far = 2.0 * radius + 1.0;
        let face_size = options.vpl_maps.unwrap_or(0);
        if face_size > 4096 {
            return Err(Error::Unsupported(format!(
                "VPL shadow maps of {face_size}² texels a face: at most 4096"
            )));
        }
        // The atlas holds one set's maps (a moving scene's are re-rendered for each pass' set).
        let faces = if face_size > 0 { 6 * largest_set } else { 0 };
        let mut vpl_faces = Vec::with_capacity(6 * vpls.len());
        let axes =
            [glam::Vec3::X, -glam::Vec3::X, glam::Vec3::Y, -glam::Vec3::Y, glam::Vec3::Z, -glam::Vec3::Z];
        if face_size > 0 {
            let proj = glam::Mat4::perspective_rh(std::f32::consts::FRAC_PI_2, 1.0, 0.01, far);
            for v in &vpls {
                for (f, axis) in axes.iter().enumerate() {
                    let up = if f == 2 || f == 3 { glam::Vec3::Z } else { glam::Vec3::Y };
                    let view = glam::Mat4::look_at_rh(v.position, v.position + *axis, up);
                    vpl_faces.push((proj * view).to_cols_array_2d());
                }
            }
        }
        // Per set and object, the set's faces whose frustum the object can reach at the set's time:
        // a moving scene's maps are drawn for every pass, and drawing each object into all six faces
        // of every VPL made the maps cost ten times the rest of the frame on `cornell-blur`.
        let mut face_lists = Vec::new();
        let mut face_ranges = Vec::new();
        if face_size > 0 {
            for (set, &(first, count)) in vpl_sets.iter().enumerate() {
                let time = passes[set.min(passes.len() - 1)].time;
                for (motion, object) in ctx.camera.space.objects.iter().zip(&scene.objects) {
                    let bound = segment_bound(motion, &object.mesh.positions, time);
                    let start = face_lists.len() as u32;
                    for v in first..first + count {
                        let meets = faces_meeting_sphere(vpls[v as usize].position, bound);
                        let local = 6 * (v - first);
                        face_lists.extend((0..6).filter(|f| meets[*f as usize]).map(|f| local + f));
                    }
                    face_ranges.push((face_lists.len() as u32 - start, start));
                    if std::env::var("DBG_FACES").is_ok() && set == 0 {
                        eprintln!(
                            "object {} tris {} faces {} of {}",
                            object.name,
                            object.mesh.indices.len() / 3,
                            face_lists.len() as u32 - start,
                            6 * count
                        );
                    }
                }
            }
        }
        let atlas_cols = if faces > 0 { faces.min(8192 / face_size).max(1) } else { 1 };
        let atlas_rows = faces.div_ceil(atlas_cols).max(1);
        let (atlas_w, atlas_h) = ((atlas_cols * face_size).max(1), (atlas_rows * face_size).max(1));
        if atlas_h > 16384 {
            return Err(Error::Unsupported(format!(
                "{} VPL shadow maps of {face_size}² texels a face need an atlas {atlas_w}×{atlas_h}: fewer VPLs or smaller faces",
                vpls.len()
            )));
        }
        let vpl_atlas = Tracked::new(Image::new(
            device,
            "interleaved VPL shadow maps",
            ImageDesc::new_2d(
                atlas_w,
                atlas_h,
                DEPTH_FORMAT,
                vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT | vk::ImageUsageFlags::SAMPLED,
            ),
        )?);
        let identity = [glam::Mat4::IDENTITY.to_cols_array_2d()];
        let vpl_faces_buffer = Buffer::with_data(
            device,
            "interleaved VPL faces",
            storage,
            if vpl_faces.is_empty() { &identity } else { &vpl_faces },
        )?;
        let face_lists_buffer = Buffer::with_data(
            device,
            "interleaved VPL face lists",
            storage,
            if face_lists.is_empty() { &[0u32][..] } else { &face_lists },
        )?;
        let vpl_sampler = crate::vk::Sampler::nearest_clamp(device, "interleaved VPL shadow maps")?;
        let vpl_shadow = if face_size > 0 {
            // The faces' clip distances (vpl_shadow.vert) stand in for a viewport per face.
            device.caps.require(crate::vk::Feature::ClipDistance, "interleaved vpl-maps")?;
            let push_bytes = std::mem::size_of::<VplShadowPush>() as u32;
            let vert = ShaderModule::new(device, shaders::INTERLEAVED_VPL_SHADOW_VERT)?;
            let frag = ShaderModule::new(device, shaders::INTERLEAVED_VPL_SHADOW_FRAG)?;
            let layout =
                world.pipeline_layout(device, &[&world.empty_layout, &set_layout], push_bytes, stages)?;
            let pipeline = Pipeline::graphics(
                device,
                &layout,
                &GraphicsDesc {
                    name: "interleaved VPL shadow maps",
                    stages: &[&vert, &frag],
                    vertex_bindings: &bindings,
                    // The position only.
                    vertex_attributes: &attributes[..1],
                    color_formats: &[],
                    depth_format: Some(DEPTH_FORMAT),
                    samples: 1,
                    sample_shading: None,
                    // Both sides cast, as the reference's shadow rays see them.
                    faces: Faces::Both,
                    depth_compare: vk::CompareOp::LESS,
                    depth_write: true,
                    overestimate: false,
                },
            )?;
            Some((pipeline, layout, vec![vert, frag]))
        } else {
            None
        };

        let pool = DescriptorPool::for_tables(device, 1, &[(&INTERLEAVED_SET, 1)])?;

        let set = pool.allocate(&set_layout)?;
        write_descriptors(
            device,
            set,
            &[
                DescriptorWrite::storage_buffer(0, &texels),
                DescriptorWrite::storage_buffer(1, &vpl_buffer),
                DescriptorWrite::storage_buffer(2, &flags),
                DescriptorWrite::StorageImage { binding: 3, view: g_position.view },
                DescriptorWrite::StorageImage { binding: 4, view: g_normal.view },
                DescriptorWrite::StorageImage { binding: 5, view: g_albedo.view },
                DescriptorWrite::StorageImage { binding: 6, view: g_direct.view },
                DescriptorWrite::StorageImage { binding: 7, view: result.view },
                DescriptorWrite::SampledImage { binding: 8, view: vpl_atlas.view, sampler: vpl_sampler.raw },
                DescriptorWrite::storage_buffer(9, &vpl_faces_buffer),
                DescriptorWrite::SampledImage { binding: 10, view: blur_in.view, sampler: blur_sampler.raw },
                DescriptorWrite::SampledImage { binding: 11, view: blur_mid.view, sampler: blur_sampler.raw },
                DescriptorWrite::StorageImage { binding: 12, view: blur_mid.view },
                DescriptorWrite::storage_buffer(13, &face_lists_buffer),
            ],
        );
        let module = |src| ShaderModule::new(device, src);
        let shader_modules = vec![
            module(shaders::INTERLEAVED_PACK_COMP)?,
            module(shaders::INTERLEAVED_PERMUTE_COMP)?,
            module(if face_size > 0 {
                shaders::INTERLEAVED_SHADE_MAPS_COMP
            } else {
                shaders::INTERLEAVED_SHADE_COMP
            })?,
            module(shaders::INTERLEAVED_DISCONTINUITY_COMP)?,
            module(shaders::INTERLEAVED_BLUR_COMP)?,
            module(shaders::INTERLEAVED_COMPOSE_COMP)?,
            module(shaders::INTERLEAVED_BLUR_SAMPLED_X_COMP)?,
            module(shaders::INTERLEAVED_BLUR_SAMPLED_Y_COMP)?,
        ];
        let pipeline =
            |name: &str, i: usize| Pipeline::compute(device, name, &compute_layout, &shader_modules[i]);
        let compute = ComputePipelines {
            pack: pipeline("interleaved pack", 0)?,
            permute: pipeline("interleaved permute", 1)?,
            shade: pipeline("interleaved shade", 2)?,
            discontinuity: pipeline("interleaved discontinuity", 3)?,
            blur: pipeline("interleaved blur", 4)?,
            compose: pipeline("interleaved compose", 5)?,
            blur_sampled: if sampled_blur {
                Some((
                    pipeline("interleaved blur x (sampled)", 6)?,
                    pipeline("interleaved blur y (sampled)", 7)?,
                ))
            } else {
                None
            },
            layout: compute_layout,
            set,
            _set_layout: set_layout,
            _pool: pool,
            _shaders: shader_modules,
        };
        Ok(InterleavedTechnique {
            options,
            layout,
            regions,
            passes,
            vpl_sets,
            direct,
            gbuffer,
            gbuffer_layout,
            _gbuffer_shaders: vec![vert, frag],
            compute,
            g_position,
            g_normal,
            g_albedo,
            g_direct,
            result,
            texels,
            flags,
            blur_in,
            blur_mid,
            _blur_sampler: blur_sampler,
            _vpls: vpl_buffer,
            vpl_atlas,
            _vpl_faces_buffer: vpl_faces_buffer,
            _face_lists_buffer: face_lists_buffer,
            face_ranges,
            _vpl_sampler: vpl_sampler,
            vpl_shadow,
            atlas_cols,
            far,
            maps_rendered: false,
            shadows,
        })
    }

    /// The push constants every compute pass of pass `pass` starts from.
    fn push(&self, pass: u32) -> InterleavedPush {
        let (vpl_first, vpl_count) = self.vpl_set(pass);
        let l = &self.layout;
        let blur = self.options.blur.unwrap_or(Blur { radius: 0, bilinear: false, edges: Edges::Ignore });
        InterleavedPush {
            width: self.result.desc.width,
            height: self.result.desc.height,
            padded_w: l.width,
            padded_h: l.height,
            n: l.pattern.n,
            m: l.pattern.m,
            block_w: l.block.0,
            block_h: l.block.1,
            sub_w: l.sub.0,
            sub_h: l.sub.1,
            vpl_first,
            vpl_count,
            clamp2: self.options.clamp * self.options.clamp,
            radius: blur.radius,
            edges: match blur.edges {
                Edges::Ignore => 0,
                Edges::Texel => 1,
                Edges::Axis => 2,
            },
            bilinear: blur.bilinear as u32,
            normal_cos: self.options.discontinuity.normal_deg.to_radians().cos(),
            position_rel: self.options.discontinuity.position,
            face_size: self.options.vpl_maps.unwrap_or(0),
            atlas_cols: self.atlas_cols,
            far: self.far,
            shadow_bias: VPL_SHADOW_BIAS,
            weight: 1.0 / self.passes.len() as f32,
            ..Default::default()
        }
    }

    /// Pass `pass`' VPL set: its first VPL and count.
    fn vpl_set(&self, pass: u32) -> (u32, u32) {
        let sets = &self.vpl_sets;
        sets.get(pass as usize).or(sets.last()).copied().unwrap_or((0, 0))
    }

    /// Dispatches `pipeline` over `(w, h)` texels with `push`, after a barrier when `barrier`.
    fn dispatch(
        &self,
        ctx: &PassContext<'_>,
        pipeline: &Pipeline,
        push: InterleavedPush,
        (w, h): (u32, u32),
        barrier: bool,
    ) {
        if barrier {
            ctx.compute_write_barrier(
                vk::PipelineStageFlags2::COMPUTE_SHADER,
                vk::AccessFlags2::SHADER_STORAGE_READ | vk::AccessFlags2::SHADER_STORAGE_WRITE,
            );
        }
        let layout = &self.compute.layout;
        ctx.bind_pipeline(pipeline);
        ctx.bind_sets(vk::PipelineBindPoint::COMPUTE, layout, TECHNIQUE_SET_INDEX, &[self.compute.set]);
        ctx.push(layout, &push);
        ctx.dispatch(w.div_ceil(8), h.div_ceil(8), 1);
    }

    /// A permutation of the padded layout (`permute.comp`).
    fn permute(
        &self,
        ctx: &PassContext<'_>,
        (src, dst): (u32, u32),
        stride: u32,
        map: u32,
        pull: bool,
        barrier: bool,
    ) {
        let push = InterleavedPush { src, dst, stride, map, pull: pull as u32, ..self.push(ctx.iteration) };
        self.dispatch(ctx, &self.compute.permute, push, (self.layout.width, self.layout.height), barrier);
    }
}

impl FrameTechnique for InterleavedTechnique {
    fn render(&mut self, inputs: &FrameInputs<'_>, frame: &mut FrameContext<'_>) -> Result<TechniqueFrame> {
        let this = &*self;
        let mut g = frame.graph();
        let inputs = *inputs;
        let shadows = this.shadows.as_ref().map(|s| (s, s.import(&mut g)));
        if let Some((s, h)) = shadows {
            s.add_frame_passes(&mut g, h, &inputs);
        }
        let shadow_reads = shadows.map(|(_, h)| ShadowMaps::reads(h)).unwrap_or_default();
        let (w, h) = (this.result.desc.width, this.result.desc.height);
        let position = g.import_image("interleaved position", &this.g_position);
        let normal = g.import_image("interleaved normal", &this.g_normal);
        let albedo = g.import_image("interleaved albedo", &this.g_albedo);
        let direct = g.import_image("interleaved direct", &this.g_direct);
        let result = g.import_image("interleaved result", &this.result);
        let texels = g.import_buffer("interleaved texels", &this.texels);
        let flags = g.import_buffer("interleaved discontinuities", &this.flags);
        let atlas = g.import_image("interleaved VPL shadow maps", &this.vpl_atlas);
        let blur_in = g.import_image("interleaved blur source", &this.blur_in);
        let blur_mid = g.import_image("interleaved blur x", &this.blur_mid);
        let depth_desc = ImageDesc::new_2d(w, h, DEPTH_FORMAT, vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT);
        let depth = g.create_image("interleaved depth", depth_desc)?;
        let gdepth = g.create_image("interleaved G-buffer depth", depth_desc)?;
        // The VPL shadow maps depend on the VPLs and the scene: a still scene's are rendered on the
        // first frame only, then read from the atlas; a moving scene's, for each pass' set.
        let still_maps = this.vpl_sets.len() == 1;
        if still_maps && !this.maps_rendered {
            this.add_vpl_map_pass(&mut g, atlas, &inputs);
        }
        g.clear_color("interleaved clear", result, [0.0; 4]);
        g.repeat(this.passes.len() as u32, |g| {
            if let Some((s, h)) = shadows {
                s.add_pass_passes(g, h, &inputs);
            }
            if !still_maps {
                this.add_vpl_map_pass(g, atlas, &inputs);
            }
            this.add_pass(
                g,
                &inputs,
                &shadow_reads,
                PassImages {
                    position,
                    normal,
                    albedo,
                    direct,
                    result,
                    depth,
                    gdepth,
                    atlas,
                    blur_in,
                    blur_mid,
                },
                (texels, flags),
            );
            Ok(())
        })?;
        let readback = g.read_back(result)?;
        let mut out = frame.run(g)?;
        self.maps_rendered = true;
        Ok(TechniqueFrame {
            image: out.take_image(readback),
            passes: self.passes.len() as u32,
            msaa_samples: 1,
            counters: None,
            clusters: vec![],
        })
    }

    fn shadows(&self) -> Option<String> {
        self.shadows.as_ref().map(ShadowMaps::summary)
    }
}

/// The images one pass uses.
#[derive(Clone, Copy)]
struct PassImages {
    position: ImageHandle,
    normal: ImageHandle,
    albedo: ImageHandle,
    direct: ImageHandle,
    result: ImageHandle,
    depth: ImageHandle,
    gdepth: ImageHandle,
    atlas: ImageHandle,
    blur_in: ImageHandle,
    blur_mid: ImageHandle,
}

impl InterleavedTechnique {
    /// `interleaved VPL shadow maps` (when the technique has them): the cube maps of the VPL set of the
    /// repeat's pass (of the only set, outside the repeat), every object drawn for every face at the
    /// pass' time.
    fn add_vpl_map_pass<'a>(&'a self, g: &mut FrameGraph<'a>, atlas: ImageHandle, inputs: &FrameInputs<'a>) {
        let Some((pipeline, layout, _)) = self.vpl_shadow.as_ref() else { return };
        let inputs = *inputs;
        let size = self.options.vpl_maps.unwrap_or(1);
        let atlas_size = [self.vpl_atlas.desc.width as f32, self.vpl_atlas.desc.height as f32];
        g.pass("interleaved VPL shadow maps").depth(atlas, Load::Clear(1.0), Store::Store).record(
            move |ctx| {
                let (first, _) = self.vpl_set(ctx.iteration);
                let time = self.passes[(ctx.iteration as usize).min(self.passes.len() - 1)].time;
                ctx.bind_pipeline(pipeline);
                ctx.bind_sets(
                    vk::PipelineBindPoint::GRAPHICS,
                    layout,
                    TECHNIQUE_SET_INDEX,
                    &[self.compute.set],
                );
                // The graph's viewport spans the whole atlas: the vertex stage places each face in its
                // square.
                let push = |i: usize| {
                    let (segment, segment_time) = inputs.camera.segment_at(i, time);
                    VplShadowPush {
                        object: i as u32,
                        segment,
                        segment_time,
                        first_face: 6 * first,
                        atlas_cols: self.atlas_cols,
                        face_size: size,
                        far: self.far,
                        pad: 0,
                        atlas_size,
                    }
                };
                let set = (ctx.iteration as usize).min(self.vpl_sets.len() - 1);
                let objects = inputs.world.objects.len();
                let ranges = &self.face_ranges[set * objects..(set + 1) * objects];
                inputs.world.record_object_draws_instanced(
                    ctx,
                    inputs.camera,
                    (pipeline, layout),
                    |i| ranges[i].0 > 0,
                    push,
                    |_| None,
                    |i| ranges[i],
                );
                Ok(())
            },
        );
    }

    /// `interleaved blur` with hardware-filtered pairs, three graph passes under one name: the
    /// gathered light copied into an image, the x pass sampling it into `blur mid`, the y pass
    /// sampling that into the texel buffer's blurred region.
    fn add_sampled_blur<'a>(
        &'a self,
        g: &mut FrameGraph<'a>,
        im: &PassImages,
        (texels, flags): (BufferHandle, BufferHandle),
    ) {
        let Some((blur_x, blur_y)) = self.compute.blur_sampled.as_ref() else { return };
        let (r, (w, h)) = (self.regions, (self.result.desc.width, self.result.desc.height));
        let padded_w = self.layout.width;
        let blur_in = im.blur_in;
        g.pass("interleaved blur")
            .access(texels, Access::TransferRead)
            .overwrite(blur_in, Access::TransferWrite)
            .record(move |ctx| {
                let region = vk::BufferImageCopy::default()
                    .buffer_offset(r.gathered as u64 * 16)
                    .buffer_row_length(padded_w)
                    .image_subresource(vk::ImageSubresourceLayers {
                        aspect_mask: vk::ImageAspectFlags::COLOR,
                        mip_level: 0,
                        base_array_layer: 0,
                        layer_count: 1,
                    })
                    .image_extent(vk::Extent3D { width: w, height: h, depth: 1 });
                ctx.copy_buffer_to_image(texels, blur_in, &[region]);
                Ok(())
            });
        let sampled = Access::ComputeShaderReadSampledImageOrUniformTexelBuffer;
        g.pass("interleaved blur")
            .access(blur_in, sampled)
            .access(flags, Access::ComputeShaderReadOther)
            .overwrite(im.blur_mid, Access::ComputeShaderWrite)
            .record(move |ctx| {
                self.dispatch(ctx, blur_x, self.push(ctx.iteration), (w, h), false);
                Ok(())
            });
        g.pass("interleaved blur")
            .access(im.blur_mid, sampled)
            .access(flags, Access::ComputeShaderReadOther)
            .access(texels, Access::ComputeShaderWrite)
            .record(move |ctx| {
                let push = InterleavedPush { dst: r.blur_y, ..self.push(ctx.iteration) };
                self.dispatch(ctx, blur_y, push, (w, h), false);
                Ok(())
            });
    }

    /// The seven steps of one pass (module docs), inside the frame's repeat: the pass is
    /// `ctx.iteration`.
    fn add_pass<'a>(
        &'a self,
        g: &mut FrameGraph<'a>,
        inputs: &FrameInputs<'a>,
        shadow_reads: &[(ResourceHandle, Access)],
        im: PassImages,
        (texels, flags): (BufferHandle, BufferHandle),
    ) {
        let this = self;
        let inputs = *inputs;
        let (w, h) = (this.result.desc.width, this.result.desc.height);
        let sample = move |ctx: &PassContext<'_>| this.passes[ctx.iteration as usize];
        g.pass("interleaved direct")
            .color(im.direct, Load::Clear(inputs.world.background), Store::Store)
            .depth(im.depth, Load::Clear(0.0), Store::DontCare)
            .accesses(shadow_reads.iter().copied())
            .record(move |ctx| {
                let s = sample(ctx);
                // Textures over the whole pixel, as the G-buffer's (gbuffer.frag): this technique's
                // passes keep the hardware's footprint (its texture filtering is not issue 33's).
                this.direct.record_draws(ctx, inputs.world, inputs.camera, (&s, 1), |_| true);
                Ok(())
            });
        g.pass("interleaved G-buffer")
            .color(im.position, Load::Clear([0.0; 4]), Store::Store)
            .color(im.normal, Load::Clear([0.0; 4]), Store::Store)
            .color(im.albedo, Load::Clear([0.0; 4]), Store::Store)
            .depth(im.gdepth, Load::Clear(0.0), Store::DontCare)
            .record(move |ctx| {
                let s = sample(ctx);
                let push = |i: usize| ForwardPush::new(inputs.camera, i, &s);
                ctx.bind_pipeline(&this.gbuffer);
                let (pipeline, layout) = (&this.gbuffer, &this.gbuffer_layout);
                inputs.world.record_object_draws(
                    ctx,
                    inputs.camera,
                    pipeline,
                    layout,
                    |_| true,
                    push,
                    |_| None,
                );
                Ok(())
            });
        let r = this.regions;
        let padded = (this.layout.width, this.layout.height);
        let image_read = Access::ComputeShaderReadOther;
        let rw = |b: BufferHandle| {
            [(b.into(), Access::ComputeShaderReadOther), (b.into(), Access::ComputeShaderWrite)]
        };
        let reads = |imgs: &[ImageHandle]| imgs.iter().map(|&i| (i.into(), image_read)).collect::<Vec<_>>();
        g.pass("interleaved pack").accesses(reads(&[im.position, im.normal])).accesses(rw(texels)).record(
            move |ctx| {
                let push = InterleavedPush { dst: r.packed, ..this.push(ctx.iteration) };
                this.dispatch(ctx, &this.compute.pack, push, padded, false);
                Ok(())
            },
        );
        let split = this.options.split;
        // The pattern 1×1 (the brute force) splits into itself: no permutation, no gather.
        let identity = this.options.pattern == Pattern::ONE;
        let (shade_src, shade_dst) = if identity { (r.packed, r.gathered) } else { (r.split, r.shaded) };
        if !identity {
            g.pass("interleaved split").accesses(rw(texels)).record(move |ctx| {
                match split {
                    Split::OnePass => this.permute(ctx, (r.packed, r.split), 2, MAP_SPLIT, false, false),
                    Split::TwoPass => {
                        this.permute(ctx, (r.packed, r.split_tmp), 2, MAP_BLOCK_SPLIT, false, false);
                        this.permute(ctx, (r.split_tmp, r.split), 2, MAP_BLOCK_TRANSLATE, false, true);
                    }
                }
                Ok(())
            });
        }
        g.pass("interleaved shade")
            .accesses(rw(texels))
            .access(im.atlas, Access::ComputeShaderReadSampledImageOrUniformTexelBuffer)
            .record(move |ctx| {
                let push = InterleavedPush { src: shade_src, dst: shade_dst, ..this.push(ctx.iteration) };
                this.dispatch(ctx, &this.compute.shade, push, padded, false);
                Ok(())
            });
        if !identity {
            g.pass("interleaved gather").accesses(rw(texels)).record(move |ctx| {
                match split {
                    Split::OnePass => this.permute(ctx, (r.shaded, r.gathered), 1, MAP_SPLIT, true, false),
                    Split::TwoPass => {
                        this.permute(ctx, (r.shaded, r.gather_tmp), 1, MAP_BLOCK_TRANSLATE, true, false);
                        this.permute(ctx, (r.gather_tmp, r.gathered), 1, MAP_BLOCK_SPLIT, true, true);
                    }
                }
                Ok(())
            });
        }
        let filtered = if this.options.blur.is_some() {
            g.pass("interleaved discontinuity")
                .accesses(reads(&[im.position, im.normal]))
                .access(flags, Access::ComputeShaderWrite)
                .record(move |ctx| {
                    this.dispatch(ctx, &this.compute.discontinuity, this.push(ctx.iteration), (w, h), false);
                    Ok(())
                });
            if this.compute.blur_sampled.is_some() {
                this.add_sampled_blur(g, &im, (texels, flags));
            } else {
                g.pass("interleaved blur")
                    .accesses(rw(texels))
                    .access(flags, Access::ComputeShaderReadOther)
                    .record(move |ctx| {
                        let base = this.push(ctx.iteration);
                        let x = InterleavedPush { src: r.gathered, dst: r.blur_x, axis: 0, ..base };
                        this.dispatch(ctx, &this.compute.blur, x, (w, h), false);
                        let y = InterleavedPush { src: r.blur_x, dst: r.blur_y, axis: 1, ..base };
                        this.dispatch(ctx, &this.compute.blur, y, (w, h), true);
                        Ok(())
                    });
            }
            r.blur_y
        } else {
            r.gathered
        };
        g.pass("interleaved compose")
            .accesses(reads(&[im.position, im.albedo, im.direct]))
            .access(texels, Access::ComputeShaderReadOther)
            .access(im.result, Access::ComputeShaderReadWrite)
            .record(move |ctx| {
                let push = InterleavedPush { src: filtered, ..this.push(ctx.iteration) };
                this.dispatch(ctx, &this.compute.compose, push, (w, h), false);
                Ok(())
            });
    }
}

/// What `interleaved/` expects: the G-buffer fragment stage with [`ForwardPush`] (sets 0 and 1); the
/// VPL maps' vertex stage with set 3 [`INTERLEAVED_SET`] (the VPLs, their faces and face lists) and
/// [`VplShadowPush`]; the compute passes with set 3 and [`InterleavedPush`].
pub const SHADER_INTERFACES: &[crate::gpu::layout::ShaderInterface] = &[
    crate::gpu::layout::ShaderInterface::technique(
        &["interleaved/gbuffer.frag"],
        None,
        None,
        Some(FORWARD_STRUCTS[0]),
    ),
    crate::gpu::layout::ShaderInterface::technique(
        &["interleaved/vpl_shadow.vert", "interleaved/vpl_shadow.frag"],
        None,
        Some(&INTERLEAVED_SET),
        Some(INTERLEAVED_STRUCTS[1]),
    ),
    crate::gpu::layout::ShaderInterface::technique(
        &[
            "interleaved/pack.comp",
            "interleaved/permute.comp",
            "interleaved/shade.comp",
            "interleaved/shade_maps.comp",
            "interleaved/discontinuity.comp",
            "interleaved/blur.comp",
            "interleaved/compose.comp",
            "interleaved/blur_sampled_x.comp",
            "interleaved/blur_sampled_y.comp",
        ],
        None,
        Some(&INTERLEAVED_SET),
        Some(INTERLEAVED_STRUCTS[0]),
    ),
];

/// A sphere holding every position of an object's vertices `positions` (object space) within the key
/// segment of `motion` that holds shutter time `t`: positions move linearly within a segment, so the
/// sphere around both of its keys' positions holds them at every time between.
fn segment_bound(motion: &crate::scene::ObjectMotion, positions: &[glam::Vec3], t: f32) -> (glam::Vec3, f32) {
    let (j, _) = motion.keys.locate(t);
    let keys = [motion.model_view[j], motion.model_view[(j + 1).min(motion.model_view.len() - 1)]];
    let points = || positions.iter().flat_map(|&p| keys.iter().map(move |m| m.transform_point3(p)));
    let (lo, hi) = points()
        .fold((glam::Vec3::splat(f32::MAX), glam::Vec3::splat(f32::MIN)), |(lo, hi), p| {
            (lo.min(p), hi.max(p))
        });
    if lo.x > hi.x {
        return (glam::Vec3::ZERO, -1.0);
    }
    let centre = 0.5 * (lo + hi);
    let radius = points().map(|p| p.distance(centre)).fold(0.0f32, f32::max);
    (centre, radius)
}

/// Which of a VPL's six 90° cube faces (+x, −x, +y, −y, +z, −z, the order of `VplFaces`) a sphere
/// can reach: face `a` holds the points `d` (from the VPL) with `d·a ≥ |d·b|` for both other axes `b`,
/// four half-spaces through the VPL with normals `(a ± b)/√2`. A sphere meets the face only if its
/// centre lies within its radius of each half-space. Conservative (a sphere near a frustum's edge
/// outside it is kept), never dropping a face the sphere reaches; the radius is widened by a relative
/// 1e-4 so that rounding cannot drop one either. A negative radius (an empty object) meets none.
fn faces_meeting_sphere(vpl: glam::Vec3, (centre, radius): (glam::Vec3, f32)) -> [bool; 6] {
    if radius < 0.0 {
        return [false; 6];
    }
    let d = centre - vpl;
    let r = radius * (1.0 + 1e-4) + 1e-6 * d.length();
    let within = |a: f32, b: f32| (a - b.abs()) * std::f32::consts::FRAC_1_SQRT_2 >= -r;
    let axis = |f: usize| {
        let (i, sign) = (f / 2, if f.is_multiple_of(2) { 1.0 } else { -1.0 });
        let a = sign * d[i];
        let (b, c) = (d[(i + 1) % 3], d[(i + 2) % 3]);
        within(a, b) && within(a, c)
    };
    std::array::from_fn(axis)
}

impl InterleavedOptions {
    /// Sets one of technique `interleaved`'s keys ([`KEYS`]); `Ok(false)` when `key` is not one of them.
    pub fn set(&mut self, key: &str, value: &str) -> Result<bool> {
        match key {
            "vpls" => self.photons = number(key, value)?,
            "clamp" => self.clamp = number(key, value)?,
            "pattern" => self.pattern = value.parse()?,
            "split" => self.split = value.parse()?,
            "block" => {
                let b: Pattern = value.parse()?;
                self.block = (b.n, b.m);
            }
            "filter" => {
                let radius = self.blur.map_or(self.pattern.n.max(self.pattern.m), |b| b.radius);
                let bilinear = self.blur.is_some_and(|b| b.bilinear);
                self.blur = Edges::of_filter(value)?.map(|edges| Blur { radius, bilinear, edges });
            }
            "radius" => match &mut self.blur {
                Some(b) => b.radius = number(key, value)?,
                None => return Err(setting_error(key, value, "a radius without a filter (filter=none)")),
            },
            "vpl-maps" => {
                self.vpl_maps = match value {
                    "off" => None,
                    v => Some(number(key, v)?),
                }
            }
            "bilinear" => match &mut self.blur {
                Some(b) => {
                    (b.bilinear, self.bilinear_sampler) = match value {
                        "false" => (false, false),
                        "true" | "pairs" => (true, false),
                        "sampler" => (true, true),
                        _ => return Err(setting_error(
                            key,
                            value,
                            "false, true (pairs lerped in the shader) or sampler (pairs fetched by the hardware's linear filter)",
                        )),
                    }
                }
                None => return Err(setting_error(key, value, "bilinear pairs without a filter (filter=none)")),
            },
            _ => return Ok(false),
        }
        Ok(true)
    }
}

#[cfg(test)]
mod face_culling_tests {
    use super::faces_meeting_sphere;
    use glam::Vec3;
    use proptest::prelude::*;

    /// The face a direction falls in, as `vpl_shadow.vert`'s clip distances decide (`|x|, |y| ≤ w`
    /// of the face's projection): the largest component's axis and sign.
    fn faces_of(d: Vec3) -> Vec<usize> {
        (0..6)
            .filter(|&f: &usize| {
                let (i, sign) = (f / 2, if f.is_multiple_of(2) { 1.0 } else { -1.0 });
                let a = sign * d[i];
                a >= d[(i + 1) % 3].abs() && a >= d[(i + 2) % 3].abs()
            })
            .collect()
    }

    proptest! {
        /// Every point of the sphere lies in a face the test keeps.
        #[test]
        fn no_face_a_point_of_the_sphere_reaches_is_dropped(
            vpl in prop::array::uniform3(-3.0f32..3.0),
            centre in prop::array::uniform3(-3.0f32..3.0),
            radius in 0.0f32..2.0,
            dir in prop::array::uniform3(-1.0f32..1.0),
            along in 0.0f32..=1.0,
        ) {
            let (vpl, centre, dir) = (Vec3::from(vpl), Vec3::from(centre), Vec3::from(dir));
            prop_assume!(dir.length() > 1e-3);
            let point = centre + dir.normalize() * radius * along;
            let kept = faces_meeting_sphere(vpl, (centre, radius));
            for f in faces_of(point - vpl) {
                prop_assert!(kept[f], "face {f} of a point of the sphere dropped: {kept:?}");
            }
        }
    }

    #[test]
    fn a_small_sphere_far_along_an_axis_meets_one_face_and_one_around_the_vpl_all() {
        let kept = faces_meeting_sphere(Vec3::ZERO, (Vec3::new(0.0, 0.0, -5.0), 0.5));
        assert_eq!(kept, [false, false, false, false, false, true]);
        assert_eq!(faces_meeting_sphere(Vec3::ZERO, (Vec3::new(0.1, 0.0, 0.0), 0.5)), [true; 6]);
        assert_eq!(faces_meeting_sphere(Vec3::ZERO, (Vec3::ZERO, -1.0)), [false; 6]);
    }
}
