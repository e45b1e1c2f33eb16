//! Adaptive texture-space shading (Andersson et al. 2014; docs/ATSS.md), on the GPU — so far its
//! first pieces, as probes outside the registry (their frames are black; their results are read back
//! for tests):
//!
//! * [`ShadingRates`]: the per-triangle shading rate (`shaders-glsl/texture_space/rate.glsl`, the
//!   port of [`crate::mirror::texture_space::rate`]) by a compute pass over every triangle of every object at
//!   mid-shutter (or its shading times, for an object that turns in camera space), so that tests
//!   compare it with the CPU mirror;
//! * [`ShadingAtlas`]: pass 1 — every object shaded into its own mip atlas at each triangle's level
//!   (`atlas.geom` computes the rate as above and places the triangle), in the "shade" sub-pass, then
//!   the "conservative" sub-pass adds each triangle's outer hull behind it by the depth trick (the
//!   paper's Figures 6–8), or not (the ablation).

use ash::vk;
use bytemuck::{Pod, Zeroable};
use glam::Vec2;

use super::{FrameContext, FrameInputs, FrameTechnique, PrepareContext, TechniqueFrame};
use crate::error::Result;
use crate::gpu::layout::{
    shared_struct, Binding, SharedStruct, FRAME_SET_INDEX, OBJECT_SET_INDEX, TECHNIQUE_SET_INDEX,
};
use crate::graph::{Access, Tracked};
use crate::graph::{Load, Store};
use crate::image::LinearImage;
use crate::mirror::conservative::{self, Dilation, Need};
use crate::mirror::texture_space::atlas::{shading_space_of, triangle_charts, MipAtlas, ShadingSpace};
use crate::shaders;
use crate::vk::{
    write_descriptors, Buffer, DescriptorPool, DescriptorSetLayout, DescriptorWrite, Pipeline,
    PipelineLayout, ShaderModule,
};
use crate::vk::{Faces, Feature, GraphicsDesc, Image, ImageDesc};

/// Set 3 of `levels.comp`.
pub const LEVELS_SET: [Binding; 2] = [
    Binding { binding: 0, ty: vk::DescriptorType::STORAGE_BUFFER, block: "ShadingCoords" },
    Binding { binding: 1, ty: vk::DescriptorType::STORAGE_BUFFER, block: "Levels" },
];

/// Set 3 of the atlas passes: [`LEVELS_SET`] and the texel counters of instrumented frames
/// (`atlas.frag`, INSTRUMENTED).
pub const ATLAS_SET: [Binding; 3] = [
    LEVELS_SET[0],
    LEVELS_SET[1],
    Binding { binding: 2, ty: vk::DescriptorType::STORAGE_BUFFER, block: "AtlasCounters" },
];

/// Push constants of `levels.comp`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct LevelsPush {
    pub triangle_count: u32,
    /// The object's key segment holding mid-shutter (its `ObjectViews` index) and the time within it.
    pub segment: u32,
    pub segment_time: f32,
    /// Levels of the object's atlas.
    pub level_count: u32,
    /// The object's key segments (`ObjectViews` indices) and its shading times
    /// ([`crate::mirror::texture_space::rate::shading_time_count`]): the rate over several times.
    pub segment_first: u32,
    pub segment_count: u32,
    pub shading_times: u32,
}

/// For the reflection test.
pub const TEXTURE_SPACE_STRUCTS: &[SharedStruct] = &[
    shared_struct!(
        "Push",
        LevelsPush,
        [triangle_count, segment, segment_time, level_count, segment_first, segment_count, shading_times]
    ),
    shared_struct!(
        "Push",
        AtlasPush,
        [
            object,
            segment,
            segment_time,
            finest,
            gutter,
            level_count,
            hull_texels,
            time,
            atlas_width,
            atlas_height,
            segment_first,
            segment_count,
            one_sided,
            shading_times
        ]
    ),
];

/// Push constants of the atlas passes (`texture_space/atlas_push.glsl`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct AtlasPush {
    pub object: u32,
    pub segment: u32,
    pub segment_time: f32,
    pub finest: u32,
    pub gutter: u32,
    pub level_count: u32,
    /// Half-size of the box the conservative sub-pass dilates each triangle by, texels.
    pub hull_texels: f32,
    /// Mid-shutter, the lights' time.
    pub time: f32,
    pub atlas_width: u32,
    pub atlas_height: u32,
    /// The object's key segments (culling over the shutter).
    pub segment_first: u32,
    pub segment_count: u32,
    /// 1: the material is one-sided, pass 1 culls back faces too.
    pub one_sided: u32,
    /// [`crate::mirror::texture_space::rate::shading_time_count`]: 1 shades at mid-shutter (`segment`,
    /// `segment_time`, `time`), more at each of those times over the shutter (`atlas.frag`).
    pub shading_times: u32,
}

/// The shading coordinates of every corner of `mesh` (3 per triangle, index order) in texels of a
/// `finest²` level 0: its own uvs mapped onto the unit square, or generated charts with `gutter`
/// texels around each.
fn shading_coords(mesh: &crate::scene::Mesh, finest: u32, gutter: u32) -> Result<(ShadingSpace, Vec<Vec2>)> {
    let space = shading_space_of(mesh);
    Ok((space, coords_in(mesh, space, finest, gutter)?))
}

/// [`shading_coords`] in a shading space already found.
fn coords_in(mesh: &crate::scene::Mesh, space: ShadingSpace, finest: u32, gutter: u32) -> Result<Vec<Vec2>> {
    let unit: Vec<Vec2> = match space {
        ShadingSpace::OwnUvs { .. } => {
            mesh.indices.iter().map(|&i| space.to_unit(mesh.uvs[i as usize])).collect()
        }
        ShadingSpace::Charts(_) => triangle_charts(mesh, finest, gutter)?.uvs,
    };
    Ok(unit.iter().map(|&t| t * finest as f32).collect())
}

/// The set layout of `table` ([`LEVELS_SET`] or [`ATLAS_SET`]) for `stages`, a pipeline layout with
/// it as set 3 (and `shadows` as set 4) and `P` as push constants, and a pool with one such set per
/// object of the scene.
fn levels_layouts<P>(
    ctx: &PrepareContext<'_>,
    name: &str,
    table: &[Binding],
    stages: vk::ShaderStageFlags,
    shadows: Option<&DescriptorSetLayout>,
) -> Result<(DescriptorSetLayout, PipelineLayout, DescriptorPool)> {
    let (device, world) = (ctx.device, ctx.world);
    let set_layout = DescriptorSetLayout::from_table(device, &format!("{name} set layout"), table, stages)?;
    let mut sets = vec![&world.empty_layout, &set_layout];
    sets.extend(shadows);
    let layout = world.pipeline_layout(device, &sets, std::mem::size_of::<P>() as u32, stages)?;
    let n = (ctx.scene.objects.len() as u32).max(1);
    let pool = DescriptorPool::for_tables(device, n, &[(table, n)])?;
    Ok((set_layout, layout, pool))
}

/// A probe's frame: black (its results are read back instead), one pass, no MSAA.
fn probe_frame((w, h): (u32, u32)) -> TechniqueFrame {
    TechniqueFrame {
        image: LinearImage::new(w, h),
        passes: 1,
        msaa_samples: 1,
        counters: None,
        clusters: vec![],
    }
}

/// One triangle's shading rate as the GPU computed it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GpuLevel {
    /// Smallest footprint minor radius over the vertices, texels of level 0.
    pub radius_texels: f32,
    pub spacing_px: f32,
    pub level: u32,
    /// Whether any vertex had a footprint.
    pub valid: bool,
    /// Pass 1 only: whether it was culled (no sample can hit it: `texture_space::cull`).
    pub culled: bool,
}

/// Per object: its shading space, the per-corner shading coordinates (texels of level 0), the
/// buffers of both (`LEVELS_SET`: `levels.comp` and the atlas passes read the coordinates and write
/// one level record per triangle) and the set that binds them.
struct ObjectShading {
    name: String,
    space: ShadingSpace,
    coords: Vec<Vec2>,
    triangles: u32,
    /// [`crate::mirror::texture_space::rate::shading_time_count`] of the object's motion in the prepared view.
    shading_times: u32,
    set: vk::DescriptorSet,
    coords_buffer: Buffer,
    levels: Tracked<Buffer>,
}

impl ObjectShading {
    /// Object `o`'s with its shading `space` and per-corner `coords`, its set from `pool` (with the
    /// atlas passes' texel `counters` at binding 2: [`ATLAS_SET`]).
    fn new(
        device: &crate::vk::Device,
        pool: &DescriptorPool,
        set_layout: &DescriptorSetLayout,
        o: &crate::scene::Object,
        motion: &crate::scene::camera_space::ObjectMotion,
        (space, coords): (ShadingSpace, Vec<Vec2>),
        counters: Option<&Buffer>,
    ) -> Result<Self> {
        let triangles = o.mesh.indices.len() / 3;
        let storage = vk::BufferUsageFlags::STORAGE_BUFFER;
        let flat: Vec<[f32; 2]> = coords.iter().map(|c| c.to_array()).collect();
        let coords_buffer = Buffer::with_data(device, &format!("shading coords:{}", o.name), storage, &flat)?;
        let levels = Tracked::new(Buffer::with_data(
            device,
            &format!("shading levels:{}", o.name),
            storage,
            &vec![[0f32; 4]; triangles],
        )?);
        let set = pool.allocate(set_layout)?;
        let mut writes = vec![
            DescriptorWrite::storage_buffer(0, &coords_buffer),
            DescriptorWrite::storage_buffer(1, &levels),
        ];
        if let Some(c) = counters {
            writes.push(DescriptorWrite::storage_buffer(2, c));
        }
        write_descriptors(device, set, &writes);
        Ok(ObjectShading {
            name: o.name.clone(),
            space,
            coords,
            triangles: triangles as u32,
            shading_times: crate::mirror::texture_space::rate::shading_time_count(motion),
            set,
            coords_buffer,
            levels,
        })
    }

    /// The level records of the last frame (after a host read of the levels buffer).
    fn read_levels(&self) -> Result<Vec<GpuLevel>> {
        let raw = self.levels.mapped()?;
        let floats: Vec<f32> =
            raw.chunks_exact(4).map(|c| f32::from_ne_bytes([c[0], c[1], c[2], c[3]])).collect();
        Ok(floats
            .chunks_exact(4)
            .map(|v| GpuLevel {
                radius_texels: v[0],
                spacing_px: v[1],
                level: v[2] as u32,
                valid: v[3] > 0.5,
                culled: v[3] > 1.5,
            })
            .collect())
    }
}

/// Runs `levels.comp` over every object with triangles (module docs).
pub struct ShadingRates {
    atlas: MipAtlas,
    objects: Vec<Option<ObjectShading>>,
    pipeline: Pipeline,
    layout: PipelineLayout,
    /// Per object (None: no triangles): the last frame's levels.
    pub results: Vec<Option<Vec<GpuLevel>>>,
    size: (u32, u32),
    _set_layout: DescriptorSetLayout,
    _pool: DescriptorPool,
    _shader: ShaderModule,
}

impl ShadingRates {
    /// For every object of the scene, an atlas of `finest²` texels at level 0 (a power of two).
    pub fn new(ctx: &PrepareContext<'_>, finest: u32) -> Result<Self> {
        let device = ctx.device;
        let atlas = MipAtlas::new(finest, 0)?;
        let (set_layout, layout, pool) = levels_layouts::<LevelsPush>(
            ctx,
            "shading rate",
            &LEVELS_SET,
            vk::ShaderStageFlags::COMPUTE,
            None,
        )?;
        let shader = ShaderModule::new(device, shaders::TEXTURE_SPACE_LEVELS_COMP)?;
        let pipeline = Pipeline::compute(device, "texture-space shading rates", &layout, &shader)?;
        let objects = ctx
            .scene
            .objects
            .iter()
            .zip(&ctx.camera.space.objects)
            .map(|(o, motion)| match o.mesh.indices.is_empty() {
                true => Ok(None),
                false => {
                    let coords = shading_coords(&o.mesh, finest, CHART_GUTTER)?;
                    ObjectShading::new(device, &pool, &set_layout, o, motion, coords, None).map(Some)
                }
            })
            .collect::<Result<Vec<_>>>()?;
        Ok(ShadingRates {
            atlas,
            objects,
            pipeline,
            layout,
            results: vec![],
            size: ctx.camera.size(),
            _set_layout: set_layout,
            _pool: pool,
            _shader: shader,
        })
    }

    /// Object `i`'s shading space and per-corner shading coordinates (texels of level 0), as the GPU
    /// got them; None for an object without triangles.
    pub fn object(&self, i: usize) -> Option<(ShadingSpace, &[Vec2])> {
        self.objects[i].as_ref().map(|o| (o.space, o.coords.as_slice()))
    }

    /// Levels of the objects' atlases.
    pub fn levels(&self) -> u32 {
        self.atlas.levels()
    }
}

impl FrameTechnique for ShadingRates {
    fn render(&mut self, inputs: &FrameInputs<'_>, frame: &mut FrameContext<'_>) -> Result<TechniqueFrame> {
        let this = &*self;
        let (world, view) = (inputs.world, inputs.camera);
        let mut g = frame.graph();
        let mut handles = vec![];
        for (i, o) in this.objects.iter().enumerate() {
            if let Some(o) = o {
                handles.push((i, g.import_buffer("shading rates", &o.levels)));
            }
        }
        let mut pass = g.pass("texture-space shading rates");
        for &(_, h) in &handles {
            pass = pass.overwrite(h, Access::ComputeShaderWrite);
        }
        let level_count = this.levels();
        pass.record(move |ctx| {
            let (layout, bind) = (&this.layout, vk::PipelineBindPoint::COMPUTE);
            ctx.bind_pipeline(&this.pipeline);
            ctx.bind_sets(bind, layout, FRAME_SET_INDEX, &[view.frame_set]);
            for (i, o) in this.objects.iter().enumerate() {
                let Some(o) = o else { continue };
                let object = &world.objects[i];
                ctx.bind_sets(bind, layout, OBJECT_SET_INDEX, &[object.set]);
                ctx.bind_sets(bind, layout, TECHNIQUE_SET_INDEX, &[o.set]);
                let (segment, segment_time) = view.segment_at(i, 0.5);
                let (segment_first, segment_count) = view.segments(i);
                let push = LevelsPush {
                    triangle_count: object.triangle_count(),
                    segment,
                    segment_time,
                    level_count,
                    segment_first,
                    segment_count,
                    shading_times: o.shading_times,
                };
                ctx.push(layout, &push);
                ctx.dispatch(object.triangle_count().div_ceil(64), 1, 1);
            }
            Ok(())
        });
        for &(_, h) in &handles {
            g.host_read(h);
        }
        frame.run(g)?;
        let mut results = vec![None; this.objects.len()];
        for (i, o) in this.objects.iter().enumerate() {
            let Some(o) = o else { continue };
            results[i] = Some(o.read_levels()?);
        }
        self.results = results;
        Ok(probe_frame(self.size))
    }
}

/// What `texture_space/` expects of its layouts.
pub const SHADER_INTERFACES: &[crate::gpu::layout::ShaderInterface] = &[
    crate::gpu::layout::ShaderInterface::technique(
        &["texture_space/levels.comp"],
        None,
        Some(&LEVELS_SET),
        Some(TEXTURE_SPACE_STRUCTS[0]),
    ),
    crate::gpu::layout::ShaderInterface::technique(
        &["texture_space/atlas.vert", "texture_space/atlas.geom", "texture_space/atlas.frag"],
        None,
        Some(&ATLAS_SET),
        Some(TEXTURE_SPACE_STRUCTS[1]),
    )
    .with_shadows(&super::shadow_maps::SHADOW_SET),
];

/// The conservative sub-pass' dilation that covers every texel of a bilinear lookup inside a
/// triangle: a whole texel. The paper's outer hull (half a texel: the texels whose square the triangle
/// touches) leaves the lookups near an edge reading a texel whose square it misses — with weight up
/// to ½ — which `tests/tests/texture_space.rs` counts; a departure on purpose.
pub const BILINEAR_HULL_TEXELS: f32 = 1.0;

/// The atlas' colour format in the stochastic frame: f32. Half floats halve pass 1's clears and
/// fetches (one light on llvmpipe: 24 ms instead of 45) but raised `glass`'s FLIP at S = 16 from
/// 0.0196 to 0.0207 in `texture_space_error_is_close_to_per_sample_shading`, which is not understood
/// yet (docs/ATSS.md); [`AtlasPasses::new`] takes the format.
pub const ATLAS_FORMAT: vk::Format = vk::Format::R32G32B32A32_SFLOAT;
/// The probe's: f32, so that the read-back texels are the shaded values exactly.
pub const PROBE_ATLAS_FORMAT: vk::Format = vk::Format::R32G32B32A32_SFLOAT;
/// Depth of the atlas' depth trick.
pub const ATLAS_DEPTH_FORMAT: vk::Format = vk::Format::D32_SFLOAT;

/// One object's atlas and its depth, with its shading coordinates and levels.
struct AtlasObject {
    /// This object's layout ([`AtlasSize`]).
    atlas: MipAtlas,
    shading: ObjectShading,
    color: Tracked<Image>,
    depth: Tracked<Image>,
}

/// What pass 1 left for one object.
#[derive(Clone, Debug)]
pub struct AtlasResult {
    pub name: String,
    pub space: ShadingSpace,
    /// Per corner, shading coordinates in texels of level 0.
    pub coords: Vec<Vec2>,
    /// Per triangle, the level the geometry stage chose.
    pub levels: Vec<GpuLevel>,
    /// The atlas: shaded texels with alpha 1 (shade sub-pass) or 0.5 (conservative), 0 elsewhere.
    pub image: LinearImage,
}

/// Pass 1 of adaptive texture-space shading for every object (module docs): the pipelines, each
/// object's atlas, depth, shading coordinates and levels.
pub struct AtlasPasses {
    /// The conservative sub-pass' box half-size in texels (None: no conservative sub-pass).
    hull_texels: Option<f32>,
    /// Who dilates that hull ([`crate::mirror::conservative::choose`]): the geometry stage alone by
    /// `hull_texels`, or the rasterizer's overestimation after `hull_texels − ½` in the geometry stage.
    pub hull_dilation: Option<Dilation>,
    objects: Vec<Option<AtlasObject>>,
    /// Texels the shade and the conservative sub-passes wrote this frame, over all objects (atomics
    /// of `atlas.frag`; counted only when instrumented).
    counters: Tracked<Buffer>,
    instrumented: bool,
    /// The shadow maps' receiver set (set 4), when the scene's lights cast shadows.
    shadow_set: Option<vk::DescriptorSet>,
    shade: Pipeline,
    hull: Pipeline,
    layout: PipelineLayout,
    _set_layout: DescriptorSetLayout,
    _pool: DescriptorPool,
    _shaders: Vec<ShaderModule>,
}

/// How large each object's atlas is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AtlasSize {
    /// Every object's the given layout (the probes: tests compare texels at known sizes).
    Fixed,
    /// Level 0 at most the given layout's, halved once per level that the object's triangles do not
    /// need at the view's shading times ([`crate::mirror::texture_space::rate::fitted_level`] on the CPU at
    /// prepare time: triangles over at most [`FITTED_COARSER_AREA`] of its pixels may ask for finer;
    /// never below [`MIN_FITTED_FINEST`]): the texels a frame clears and the memory follow the
    /// object's size on screen and its blur. A triangle that asks for a finer level than the atlas
    /// has — those few, one the GPU rounds a level finer than the CPU (a radius within f32 rounding
    /// of a power of two), generated charts re-laid at the smaller size — is clamped to level 0:
    /// shaded coarser, never misplaced.
    Fitted,
}

/// The share of an object's pixels [`AtlasSize::Fitted`] may shade coarser than the rate asks
/// ([`crate::mirror::texture_space::rate::fitted_level`]).
pub const FITTED_COARSER_AREA: f64 = 0.01;

/// The smallest level 0 [`AtlasSize::Fitted`] gives an object, texels.
pub const MIN_FITTED_FINEST: u32 = 16;

/// Texels around each generated per-triangle chart (objects without usable uvs of their own).
const CHART_GUTTER: u32 = 2;

/// Object `i`'s atlas layout, shading space and per-corner shading coordinates (texels of its
/// level 0) for `size` at most `largest` (None: no triangles). Fitted: `largest` halved once per level
/// [`crate::mirror::texture_space::rate::fitted_level`] finds unneeded in `view`; generated charts that do not
/// fit the smaller atlas are laid at the next size up.
pub fn object_atlas_layout(
    scene: &crate::scene::Scene,
    view: &crate::scene::view::View,
    i: usize,
    largest: MipAtlas,
    size: AtlasSize,
) -> Result<Option<(MipAtlas, ShadingSpace, Vec<Vec2>)>> {
    let o = &scene.objects[i];
    if o.mesh.indices.is_empty() {
        return Ok(None);
    }
    let (space, coords) = shading_coords(&o.mesh, largest.finest(), CHART_GUTTER)?;
    let skip = match (size, view.intrinsics()) {
        (AtlasSize::Fitted, Some(intrinsics)) => crate::mirror::texture_space::rate::fitted_level(
            &intrinsics,
            &o.mesh,
            &view.space.objects[i],
            &coords,
            largest.levels(),
            FITTED_COARSER_AREA,
            o.material.one_sided,
        )
        // No triangle with a footprint: nothing of it can be seen; the smallest atlas.
        .unwrap_or(largest.levels() - 1),
        _ => 0,
    };
    let mut finest = (largest.finest() >> skip).max(MIN_FITTED_FINEST).min(largest.finest());
    if finest == largest.finest() {
        return Ok(Some((largest, space, coords)));
    }
    loop {
        match coords_in(&o.mesh, space, finest, CHART_GUTTER) {
            Ok(coords) => return Ok(Some((MipAtlas::new(finest, largest.gutter())?, space, coords))),
            // Generated charts that fit the larger atlas may not fit a smaller one.
            Err(_) if finest < largest.finest() => finest *= 2,
            Err(e) => return Err(e),
        }
    }
}

/// One object's texture-space atlas as `shutter plan --atlases` prints it (CPU only).
#[derive(Clone, Debug)]
pub struct AtlasPlan {
    pub object: String,
    pub triangles: usize,
    /// The layout and shading space, or why there is none (charts that do not fit).
    pub layout: std::result::Result<(MipAtlas, ShadingSpace), String>,
    /// Triangles pass 1 culls outside the frustum ([`crate::mirror::texture_space::cull::outside_frustum`]).
    pub culled: usize,
    /// Triangles pass 1 culls as back-facing at every lens point and time (one-sided materials,
    /// [`crate::mirror::texture_space::cull::back_facing`]), of those inside the frustum; `None` for a
    /// two-sided material, whose back faces are never culled.
    pub back_facing: Option<usize>,
    /// The texels the shade sub-pass covers, estimated on the CPU: the area of every kept triangle in
    /// its level ([`crate::mirror::texture_space::rate::triangle_level_over_shutter`], the fitted layout's
    /// coordinates), without the conservative sub-pass' gutters. Where it comes from: shaded texels per
    /// object, which the GPU's counters only give for the whole frame.
    pub texels: f64,
    /// How many times pass 1 shades each of them ([`crate::mirror::texture_space::rate::shading_time_count`]:
    /// 1, mid-shutter, unless the object turns in camera space within the shutter).
    pub shading_times: u32,
}

impl AtlasPlan {
    /// Bytes of the object's atlas and its depth ([`ATLAS_FORMAT`], [`ATLAS_DEPTH_FORMAT`]).
    pub fn bytes(&self) -> u64 {
        self.layout.as_ref().map_or(0, |(a, _)| a.bytes(16 + 4))
    }
}

/// What `--shading texture-space` gives every object of `scene` seen by `view` (the stochastic
/// frame's layouts: fitted, at most `largest`).
pub fn plan_atlases(
    scene: &crate::scene::Scene,
    view: &crate::scene::view::View,
    largest: MipAtlas,
) -> Vec<AtlasPlan> {
    use crate::mirror::texture_space::cull::{culled, key_points};
    (0..scene.objects.len())
        .map(|i| {
            let o = &scene.objects[i];
            let fitted = object_atlas_layout(scene, view, i, largest, AtlasSize::Fitted);
            let (mut frustum, mut back, mut texels) = (0, 0, 0.0);
            let times = crate::mirror::texture_space::rate::shading_time_count(&view.space.objects[i]);
            if let Some(intrinsics) = view.intrinsics() {
                let motion = &view.space.objects[i];
                for t in 0..o.mesh.indices.len() / 3 {
                    let points = key_points(&o.mesh, motion, t);
                    let (f, b) = culled(&intrinsics, o.material.one_sided, &points);
                    frustum += f as usize;
                    back += b as usize;
                    let Ok(Some((atlas, _, coords))) = &fitted else { continue };
                    if f || b {
                        continue;
                    }
                    let tex = [0, 1, 2].map(|k| coords[3 * t + k]);
                    let rate = crate::mirror::texture_space::rate::triangle_level_over_shutter;
                    if let Some((c, _)) = rate(&intrinsics, &o.mesh, motion, t, tex, atlas.levels(), times) {
                        let scale = 1.0 / (1u64 << c.level) as f64;
                        let (e1, e2) = (tex[1] - tex[0], tex[2] - tex[0]);
                        texels += 0.5 * (e1.perp_dot(e2) as f64).abs() * scale * scale;
                    }
                }
            }
            let layout = match fitted {
                Ok(Some((atlas, space, _))) => Ok((atlas, space)),
                Ok(None) => Err("no triangles".into()),
                Err(e) => Err(e.to_string()),
            };
            AtlasPlan {
                object: o.name.clone(),
                triangles: o.mesh.indices.len() / 3,
                layout,
                culled: frustum,
                back_facing: o.material.one_sided.then_some(back),
                texels,
                shading_times: times,
            }
        })
        .collect()
}

/// One object's pass-1 outputs in a frame graph.
#[derive(Clone, Copy)]
pub struct AtlasHandles {
    pub color: crate::graph::ImageHandle,
    pub levels: crate::graph::BufferHandle,
}

impl AtlasPasses {
    /// Every object into an atlas of `atlas`'s layout (or, [`AtlasSize::Fitted`], at most that);
    /// with `hull_texels`, the conservative sub-pass
    /// after the shade sub-pass, each triangle dilated by a box of that half-size in texels — 1.0
    /// ([`BILINEAR_HULL_TEXELS`]) covers every texel a bilinear lookup inside the triangle reads, 0.5
    /// only those whose square the triangle touches (the paper's outer hull); without it, the
    /// no-gutter ablation.
    pub fn new(
        ctx: &PrepareContext<'_>,
        atlas: MipAtlas,
        size: AtlasSize,
        hull_texels: Option<f32>,
        format: vk::Format,
        instrumented: bool,
        shadows: Option<&super::shadow_maps::ShadowMaps>,
    ) -> Result<Self> {
        let device = ctx.device;
        let caps = &device.caps;
        caps.require(
            Feature::GeometryShader,
            "texture-space shading (pass 1 places triangles in its geometry stage)",
        )?;
        caps.require(
            Feature::VertexPipelineStoresAndAtomics,
            "texture-space shading (pass 1's geometry stage records each triangle's level)",
        )?;
        let (width, height) = atlas.size();
        if width.max(height) > caps.max_image_dimension_2d {
            return Err(crate::error::Error::Limit {
                what: "shading atlas",
                value: format!("{width}×{height} texels"),
                limit: format!(
                    "{} texels per side on this device (maxImageDimension2D)",
                    caps.max_image_dimension_2d
                ),
            });
        }
        let stages =
            vk::ShaderStageFlags::VERTEX | vk::ShaderStageFlags::GEOMETRY | vk::ShaderStageFlags::FRAGMENT;
        let (set_layout, layout, pool) = levels_layouts::<AtlasPush>(
            ctx,
            "shading atlas",
            &ATLAS_SET,
            stages,
            shadows.map(|m| m.set_layout()),
        )?;
        let (shadow_axis, shadow_color) =
            shadows.map_or((shaders::axes::Shadows::None, false), |m| m.lookup());
        let counters = Tracked::new(Buffer::with_data(
            device,
            "atlas counters",
            vk::BufferUsageFlags::STORAGE_BUFFER,
            &[0u32; 2],
        )?);
        let hull_dilation =
            hull_texels.map(|h| conservative::choose(Need::CentresWithin { h }, caps.overestimation()));
        let overestimate_hull = hull_dilation.is_some_and(Dilation::overestimate);
        let vert = ShaderModule::new(device, shaders::TEXTURE_SPACE_ATLAS_VERT)?;
        let mut modules = vec![];
        let mut pipeline = |conservative: bool| -> Result<Pipeline> {
            let geom = ShaderModule::new(
                device,
                shaders::AtlasGeom { shadow_receiver: shadows.is_some(), conservative }.source(),
            )?;
            let frag = ShaderModule::new(
                device,
                shaders::AtlasFrag { instrumented, shadows: shadow_axis, shadow_color, conservative }
                    .source(),
            )?;
            let name = if conservative { "atlas conservative" } else { "atlas shade" };
            let p = Pipeline::graphics(
                device,
                &layout,
                &GraphicsDesc {
                    name,
                    stages: &[&vert, &geom, &frag],
                    vertex_bindings: &[],
                    vertex_attributes: &[],
                    color_formats: &[format],
                    depth_format: Some(ATLAS_DEPTH_FORMAT),
                    samples: 1,
                    sample_shading: None,
                    faces: Faces::Both,
                    depth_compare: vk::CompareOp::LESS,
                    depth_write: true,
                    overestimate: conservative && overestimate_hull,
                },
            )?;
            modules.extend([geom, frag]);
            Ok(p)
        };
        let shade = pipeline(false)?;
        let hull = pipeline(true)?;
        modules.push(vert);
        let mut objects = Vec::with_capacity(ctx.scene.objects.len());
        for (i, o) in ctx.scene.objects.iter().enumerate() {
            let Some((atlas, space, coords)) = object_atlas_layout(ctx.scene, ctx.camera, i, atlas, size)?
            else {
                objects.push(None);
                continue;
            };
            let motion = &ctx.camera.space.objects[i];
            let shading =
                ObjectShading::new(device, &pool, &set_layout, o, motion, (space, coords), Some(&counters))?;
            let (width, height) = atlas.size();
            let usage = vk::ImageUsageFlags::COLOR_ATTACHMENT
                | vk::ImageUsageFlags::TRANSFER_SRC
                | vk::ImageUsageFlags::SAMPLED;
            let color = Tracked::new(Image::new(
                device,
                &format!("shading atlas:{}", o.name),
                ImageDesc::new_2d(width, height, format, usage),
            )?);
            let depth = Tracked::new(Image::new(
                device,
                &format!("shading atlas depth:{}", o.name),
                ImageDesc::new_2d(
                    width,
                    height,
                    ATLAS_DEPTH_FORMAT,
                    vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT,
                ),
            )?);
            objects.push(Some(AtlasObject { atlas, shading, color, depth }));
        }
        Ok(AtlasPasses {
            hull_texels,
            hull_dilation,
            objects,
            counters,
            instrumented,
            shadow_set: shadows.map(|m| m.set()),
            shade,
            hull,
            layout,
            _set_layout: set_layout,
            _pool: pool,
            _shaders: modules,
        })
    }

    /// Zeroes the texel counters (before an instrumented frame).
    pub fn reset_counters(&mut self) -> Result<()> {
        self.counters.get_mut().write(&[0u32; 2])
    }

    /// Texels the shade and the conservative sub-passes wrote in the last frame, over all objects
    /// (instrumented only; after a host read of [`AtlasPasses::counters_buffer`]).
    pub fn counters(&self) -> Result<Option<(u64, u64)>> {
        if !self.instrumented {
            return Ok(None);
        }
        let raw = self.counters.read_u32s(2)?;
        Ok(Some((raw[0] as u64, raw[1] as u64)))
    }

    /// The counters' buffer, for a host read at the end of the frame (instrumented only).
    pub fn counters_buffer(&self) -> Option<&Tracked<Buffer>> {
        self.instrumented.then_some(&self.counters)
    }

    /// Object `i`'s atlas layout (None: an object without triangles).
    pub fn object_atlas(&self, i: usize) -> Option<MipAtlas> {
        self.objects.get(i)?.as_ref().map(|o| o.atlas)
    }

    /// Object `i`'s atlas image, levels buffer and per-corner shading coordinates buffer (None: an
    /// object without triangles).
    pub fn object_resources(&self, i: usize) -> Option<(&Image, &Buffer, &Buffer)> {
        self.objects[i].as_ref().map(|o| (&*o.color, &*o.shading.levels, &o.shading.coords_buffer))
    }

    /// Pass 1 of every object into `g` (the shade sub-pass, then the conservative one when set);
    /// per object its atlas and levels.
    /// With shadow maps (those [`AtlasPasses::new`] took), `shadows` are their handles in `g`.
    pub fn add_passes<'a>(
        &'a self,
        g: &mut crate::graph::FrameGraph<'a>,
        inputs: &FrameInputs<'a>,
        shadows: Option<super::shadow_maps::ShadowHandles>,
    ) -> Vec<Option<AtlasHandles>> {
        let (world, view) = (inputs.world, inputs.camera);
        let counters = self.counters_buffer().map(|c| g.import_buffer("atlas counters", c));
        // What both sub-passes read besides their own: the shadow maps, and the counters' atomics.
        let mut shared = shadows.map(super::shadow_maps::ShadowMaps::reads).unwrap_or_default();
        if let Some(c) = counters {
            shared.extend([
                (c.into(), Access::FragmentShaderReadOther),
                (c.into(), Access::FragmentShaderWrite),
            ]);
        }
        let mut out = Vec::with_capacity(self.objects.len());
        for (i, o) in self.objects.iter().enumerate() {
            let Some(o) = o else {
                out.push(None);
                continue;
            };
            let color = g.import_image("shading atlas", &o.color);
            let depth = g.import_image("shading atlas depth", &o.depth);
            let levels = g.import_buffer("atlas levels", &o.shading.levels);
            g.pass("atlas shade")
                .color(color, Load::Clear([0.0; 4]), Store::Store)
                .depth(depth, Load::Clear(1.0), Store::Store)
                .overwrite(levels, Access::GeometryShaderWrite)
                .accesses(shared.iter().copied())
                .record(move |ctx| {
                    self.record(ctx, world, view, i, &self.shade);
                    Ok(())
                });
            if self.hull_texels.is_some() {
                g.pass("atlas conservative")
                    .color(color, Load::Load, Store::Store)
                    .depth(depth, Load::Load, Store::DontCare)
                    .access(levels, Access::GeometryShaderReadOther)
                    .accesses(shared.iter().copied())
                    .record(move |ctx| {
                        self.record(ctx, world, view, i, &self.hull);
                        Ok(())
                    });
            }
            out.push(Some(AtlasHandles { color, levels }));
        }
        if let Some(c) = counters {
            g.host_read(c);
        }
        out
    }

    /// Draws object `i`'s triangles with `pipeline` inside its atlas pass.
    fn record(
        &self,
        ctx: &crate::graph::PassContext<'_>,
        world: &crate::gpu::GpuWorld,
        view: &crate::gpu::GpuView,
        i: usize,
        pipeline: &Pipeline,
    ) {
        let Some(o) = &self.objects[i] else { return };
        let (layout, bind) = (&self.layout, vk::PipelineBindPoint::GRAPHICS);
        let (width, height) = o.atlas.size();
        let (segment, segment_time) = view.segment_at(i, 0.5);
        let (segment_first, segment_count) = view.segments(i);
        let push = AtlasPush {
            object: i as u32,
            segment,
            segment_time,
            finest: o.atlas.finest(),
            gutter: o.atlas.gutter(),
            level_count: o.atlas.levels(),
            hull_texels: self.hull_dilation.map_or(0.0, Dilation::shader_box_px),
            time: 0.5,
            atlas_width: width,
            atlas_height: height,
            segment_first,
            segment_count,
            one_sided: world.objects[i].one_sided as u32,
            shading_times: o.shading.shading_times,
        };
        ctx.bind_pipeline(pipeline);
        ctx.bind_sets(bind, layout, FRAME_SET_INDEX, &[view.frame_set]);
        ctx.bind_sets(bind, layout, OBJECT_SET_INDEX, &[world.objects[i].set]);
        ctx.bind_sets(bind, layout, TECHNIQUE_SET_INDEX, &[o.shading.set]);
        if let Some(set) = self.shadow_set {
            ctx.bind_sets(bind, layout, crate::gpu::layout::SHADOW_SET_INDEX, &[set]);
        }
        ctx.push(layout, &push);
        ctx.draw(3 * o.shading.triangles, 1);
    }
}

/// Pass 1 as a probe (module docs): every object's atlas and levels read back after each frame.
pub struct ShadingAtlas {
    passes: AtlasPasses,
    /// Per object (None: no triangles): the last frame's atlas.
    pub results: Vec<Option<AtlasResult>>,
    /// The last frame's texel counters over all objects: shade sub-pass, conservative sub-pass.
    pub texels: (u64, u64),
    size: (u32, u32),
}

impl ShadingAtlas {
    /// [`AtlasPasses::new`] for every object of the scene.
    pub fn new(ctx: &PrepareContext<'_>, atlas: MipAtlas, hull_texels: Option<f32>) -> Result<Self> {
        Ok(ShadingAtlas {
            passes: AtlasPasses::new(
                ctx,
                atlas,
                AtlasSize::Fixed,
                hull_texels,
                PROBE_ATLAS_FORMAT,
                true,
                None,
            )?,
            results: vec![],
            texels: (0, 0),
            size: ctx.camera.size(),
        })
    }
}

impl FrameTechnique for ShadingAtlas {
    fn render(&mut self, inputs: &FrameInputs<'_>, frame: &mut FrameContext<'_>) -> Result<TechniqueFrame> {
        self.passes.reset_counters()?;
        let passes = &self.passes;
        let mut g = frame.graph();
        let handles = passes.add_passes(&mut g, inputs, None);
        let mut readbacks = vec![];
        for (i, h) in handles.iter().enumerate() {
            let Some(h) = h else { continue };
            g.host_read(h.levels);
            readbacks.push((i, g.read_back(h.color)?));
        }
        let mut result = frame.run(g)?;
        let mut results = vec![None; passes.objects.len()];
        for (i, r) in readbacks {
            let o = &passes.objects[i].as_ref().expect("read back").shading;
            let levels = o.read_levels()?;
            results[i] = Some(AtlasResult {
                name: o.name.clone(),
                space: o.space,
                coords: o.coords.clone(),
                levels,
                image: result.take_image(r),
            });
        }
        self.results = results;
        self.texels = self.passes.counters()?.expect("instrumented");
        Ok(probe_frame(self.size))
    }
}
