//! Technique `stochastic`: stochastic rasterization of motion blur and depth of field on the conventional
//! pipeline (McGuire, Enderton, Shirley & Luebke, HPG 2010; Toth & Linder 2008).
//!
//! S samples per pixel are split into P = S / M passes of M MSAA samples. In every pass each triangle
//! goes through a geometry shader that replaces it by a conservative screen-space bound of everywhere
//! it can land over the lens and the shutter (`bounds`, selectable per draw, mirrored on the CPU in
//! [`crate::bounds`]), dilated by a pixel box; for every pixel the bound touches, the fragment shader
//! runs the 5D inside test of each of the pass' samples — the ray from the sample's lens point through
//! its (x, y) against the triangle at the sample's time — writes the hits to `gl_SampleMask` and the
//! hit depth to `gl_FragDepth`, and shades per pixel or per sample ([`ShadingRate`]). The passes are
//! resolved and averaged by the multipass frame ([`super::multipass::MultipassFrame`]).
//!
//! The (x, y, u, v, t) samples are those of the CPU reference ([`SampleTile`]: 64×64 pixels × S
//! stratified samples, aperture shape and shutter curve applied here, never in the shaders), so at
//! equal S and seed the two estimate the pixel integral with the very same samples.
//! Shaders: `shaders-glsl/stochastic/`.

use ash::vk;
use bytemuck::{Pod, Zeroable};
use gpu_allocator::MemoryLocation;

use super::compute_hull::{ComputeHull, HullExpansion, INITIAL_VERTICES_PER_TRIANGLE};
use super::multipass::{FrameUse, MultipassFrame, PassDraws, COLOR_FORMAT, DEPTH_FORMAT};
use super::{FrameContext, FrameInputs, FrameTechnique, PrepareContext, TechniqueFrame, TechniqueInfo};
use crate::bounds::BoundKind;
use crate::error::{Error, Result};
use crate::gpu::layout::{
    shared_struct, vertex_input, Binding, SharedStruct, FRAME_SET_INDEX, OBJECT_SET_INDEX,
    TECHNIQUE_SET_INDEX,
};
use crate::gpu::{GpuView, GpuWorld};
use crate::graph::{Access, FrameGraph, PassContext, ResourceHandle, Tracked};
use crate::plan::Effects;
use crate::sampling::{ApertureShape, SampleTile, ShutterCurve, SAMPLE_TILE_SIZE};
use crate::shaders::{self, axes, StochasticFrag, StochasticGeom};
use crate::vk::{
    write_descriptors, Buffer, DescriptorPool, DescriptorSetLayout, DescriptorWrite, Feature, GraphicsDesc,
    Pipeline, PipelineLayout, ShaderModule,
};

/// The registry entry.
pub const INFO: TechniqueInfo = TechniqueInfo {
    name: "stochastic",
    summary: "stochastic rasterization: a conservative bound per triangle, the 5D inside test per sample, \
              gl_SampleMask (McGuire et al. 2010; Toth & Linder 2008)",
    prepare,
};

fn prepare(ctx: &PrepareContext<'_>) -> Result<Box<dyn FrameTechnique>> {
    let effects = vec![Effects::Both; ctx.scene.objects.len()];
    Ok(Box::new(StochasticTechnique::new(ctx, ctx.settings.stochastic, DebugOptions::default(), &effects)?))
}

pub use crate::limits::MAX_STOCHASTIC_SPP;

/// How often the fragment shader shades.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum ShadingRate {
    /// Once per pixel and pass from the nearest covered sample (MSAA-like); every covered sample takes
    /// that sample's colour and depth.
    #[default]
    PerPixel,
    /// Once per covered sample (`sampleRateShading`), each with its own hit, time, lens and depth.
    PerSample,
}

impl ShadingRate {
    pub const ALL: [ShadingRate; 2] = [ShadingRate::PerPixel, ShadingRate::PerSample];
    pub fn name(&self) -> &'static str {
        match self {
            ShadingRate::PerPixel => "per-pixel",
            ShadingRate::PerSample => "per-sample",
        }
    }
}

impl std::str::FromStr for ShadingRate {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        ShadingRate::ALL.into_iter().find(|r| r.name() == s).ok_or_else(|| {
            Error::Unsupported(format!("unknown shading rate `{s}`; available: per-pixel, per-sample"))
        })
    }
}

/// Settings of the `stochastic` technique.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StochasticOptions {
    pub bound: BoundKind,
    pub shading: ShadingRate,
    /// Count samples tested / hit and shading invocations with atomics (slower).
    pub instrumented: bool,
    /// MSAA samples per pass M (S = M × passes): `None` takes the largest the device supports that
    /// divides S ([`split_samples`]); `Some(m)` forces m (a hardware experiment: fewer, cheaper MSAA
    /// passes against more passes).
    pub msaa: Option<u32>,
    /// Geometry shader or compute-expanded hull ([`HullExpansion`]).
    pub expansion: HullExpansion,
}

impl Default for StochasticOptions {
    fn default() -> Self {
        StochasticOptions {
            bound: DEFAULT_BOUND,
            shading: ShadingRate::PerPixel,
            instrumented: false,
            msaa: None,
            expansion: HullExpansion::GeometryShader,
        }
    }
}

const DEFAULT_BOUND: BoundKind = BoundKind::Adaptive;

/// Counters of an instrumented render, summed over all passes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SampleCounters {
    /// Fragment shader invocations (pixels × passes the bounds touched).
    pub fragments: u64,
    /// (x, y, u, v, t) samples run through the inside test.
    pub samples_tested: u64,
    /// Samples the inside test accepted (before the depth test).
    pub samples_hit: u64,
    /// Invocations that shaded (per pixel: fragments with a hit; per sample: hits).
    pub shading_invocations: u64,
}

impl SampleCounters {
    /// Sample test efficiency: hits / tested (McGuire et al. 2010).
    pub fn sample_test_efficiency(&self) -> f64 {
        if self.samples_tested == 0 {
            0.0
        } else {
            self.samples_hit as f64 / self.samples_tested as f64
        }
    }
}

/// Push constants of the stochastic pipelines (`stochastic/push.glsl`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct StochasticPush {
    pub object: u32,
    pub bound: u32,
    pub pass_index: u32,
    pub spp: u32,
    pub msaa: u32,
    pub footprint: f32,
    pub dilate: f32,
}

/// Push constants of `triangles.comp`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct TrianglesPush {
    pub object: u32,
    pub triangle_count: u32,
}

/// Set 2 of the stochastic rasterizer, per object: the view's triangles and the compute-expanded hull.
pub const STOCHASTIC_OBJECT_SET: [Binding; 3] = [
    Binding { binding: 0, ty: vk::DescriptorType::STORAGE_BUFFER, block: "Triangles" },
    Binding { binding: 1, ty: vk::DescriptorType::STORAGE_BUFFER, block: "Hull" },
    Binding { binding: 2, ty: vk::DescriptorType::STORAGE_BUFFER, block: "HullTriangles" },
];

/// Set 3 of the stochastic rasterizer: the sample tile, counters, bound debug output, hull counts.
pub const STOCHASTIC_SET: [Binding; 5] = [
    Binding { binding: 0, ty: vk::DescriptorType::STORAGE_BUFFER, block: "SamplesXyLens" },
    Binding { binding: 1, ty: vk::DescriptorType::STORAGE_BUFFER, block: "SamplesTime" },
    Binding { binding: 2, ty: vk::DescriptorType::STORAGE_BUFFER, block: "Counters" },
    Binding { binding: 3, ty: vk::DescriptorType::STORAGE_BUFFER, block: "BoundDebug" },
    Binding { binding: 4, ty: vk::DescriptorType::STORAGE_BUFFER, block: "HullCounts" },
];

/// For the reflection test.
pub const STOCHASTIC_STRUCTS: &[SharedStruct] = &[
    shared_struct!("Push", StochasticPush, [object, bound, pass_index, spp, msaa, footprint, dilate]),
    shared_struct!("Push", TrianglesPush, [object, triangle_count]),
];

/// MSAA samples per pass and passes for `spp` samples per pixel: `forced` when given (it must be a
/// count of the device dividing S), else [`split_samples`].
pub fn msaa_and_passes(spp: u32, forced: Option<u32>, supported: &[u32]) -> Result<(u32, u32)> {
    match forced {
        None => Ok(split_samples(spp, supported)),
        Some(m) if supported.contains(&m) && spp.is_multiple_of(m) => Ok((m, spp / m)),
        Some(m) => Err(Error::Unsupported(format!(
            "{m}x MSAA per pass for S = {spp}: it must divide S and be one of the device's counts {supported:?}"
        ))),
    }
}

/// Splits S samples per pixel into passes of M MSAA samples: the largest count the device supports
/// (up to 8) that divides S.
pub fn split_samples(spp: u32, supported: &[u32]) -> (u32, u32) {
    let msaa =
        [8, 4, 2, 1].into_iter().find(|&m| spp.is_multiple_of(m) && supported.contains(&m)).unwrap_or(1);
    (msaa, spp / msaa)
}

/// The sample tile as the fragment shader reads it: (x, y, lens u, lens v) and time per sample.
pub fn gpu_samples(
    spp: u32,
    seed: u64,
    aperture: ApertureShape,
    shutter: ShutterCurve,
) -> (Vec<[f32; 4]>, Vec<f32>) {
    let tile = SampleTile::new(spp, SAMPLE_TILE_SIZE, seed);
    let n = (SAMPLE_TILE_SIZE * SAMPLE_TILE_SIZE * spp) as usize;
    let (mut xy_lens, mut time) = (Vec::with_capacity(n), Vec::with_capacity(n));
    for y in 0..SAMPLE_TILE_SIZE {
        for x in 0..SAMPLE_TILE_SIZE {
            for s in tile.pixel(x, y) {
                let lens = aperture.map(s.lens);
                xy_lens.push([s.xy.x, s.xy.y, lens.x, lens.y]);
                time.push(shutter.warp(s.time));
            }
        }
    }
    (xy_lens, time)
}

impl ShadingRate {
    fn axis(self) -> axes::Shading {
        match self {
            ShadingRate::PerPixel => axes::Shading::PerPixel,
            ShadingRate::PerSample => axes::Shading::PerSample,
        }
    }
}

/// Bytes per camera-space triangle record (`triangles.comp`): 3 vertices × xyz at open and close.
const TRIANGLE_RECORD_BYTES: u64 = 18 * 4;

/// Extra knobs for tests: the geometry shader's debug output of every triangle's bound.
#[derive(Clone, Copy, Debug, Default)]
pub struct DebugOptions {
    /// Capacity, in triangles, of the bound debug buffer (0 = off).
    pub bound_debug_triangles: u32,
    /// Initial hull buffer capacity per triangle of the compute expansion (None: the default; a tiny
    /// value exercises the overflow path).
    pub hull_vertices_per_triangle: Option<u32>,
}

/// Floats per triangle in the bound debug buffer (see `stochastic.geom`).
pub const BOUND_DEBUG_STRIDE: usize = 8 + 2 * 48;

/// The stochastic path of a set of objects: pipelines (one shader permutation per effect path in
/// use), the sample tile, the view's camera-space triangles, counters.
///
/// Every object takes one path ([`Effects`]): `object_effects[i]`; objects on [`Effects::Pinhole`]
/// are not drawn here (`auto` draws them with the plain forward path in the same passes).
pub struct StochasticDraws {
    pipelines: Vec<(Effects, Pipeline)>,
    object_effects: Vec<Effects>,
    layout: PipelineLayout,
    push_stages: vk::ShaderStageFlags,
    /// Set 2 per object ([`STOCHASTIC_OBJECT_SET`]).
    object_sets: Vec<vk::DescriptorSet>,
    /// Set 3 ([`STOCHASTIC_SET`]).
    technique_set: vk::DescriptorSet,
    options: StochasticOptions,
    spp: u32,
    msaa: u32,
    passes: u32,
    /// Box half-size of the bound dilation ([`crate::bounds::dilation_px`]).
    dilate: f32,
    counters: Tracked<Buffer>,
    bound_debug: Option<Tracked<Buffer>>,
    /// The camera view's triangles at shutter open and close, per object (`triangles.comp`).
    triangles: Vec<Tracked<Buffer>>,
    triangles_pipeline: Pipeline,
    triangles_layout: PipelineLayout,
    /// The compute-expanded hull's buffers and pipelines ([`HullExpansion::Compute`]).
    hull: Option<ComputeHull>,
    /// Vertices of each object's expanded hull this frame (compute expansion).
    hull_counts: Vec<u32>,
    _samples: [Buffer; 2],
    _pool: DescriptorPool,
    _set_layouts: [DescriptorSetLayout; 2],
    _shaders: Vec<ShaderModule>,
}

impl StochasticDraws {
    /// The path for `object_effects` (one per object of the world) at the settings' samples per pixel
    /// and seed, through the scene camera's aperture shape and shutter curve.
    pub fn new(
        ctx: &PrepareContext<'_>,
        options: StochasticOptions,
        debug: DebugOptions,
        object_effects: &[Effects],
    ) -> Result<Self> {
        let (device, world) = (ctx.device, ctx.world);
        let (spp, seed) = (ctx.settings.spp, ctx.settings.seed);
        let (aperture, shutter) = (ctx.scene.camera.aperture, ctx.scene.camera.shutter);
        let caps = &device.caps;
        if object_effects.len() != world.objects.len() {
            return Err(Error::Unsupported(format!(
                "{} object paths for {} objects",
                object_effects.len(),
                world.objects.len()
            )));
        }
        let mut paths: Vec<Effects> = object_effects.iter().copied().filter(|e| e.is_stochastic()).collect();
        paths.sort();
        paths.dedup();
        if options.expansion == HullExpansion::GeometryShader {
            caps.require(
                Feature::GeometryShader,
                "technique `stochastic` with the geometry-shader hull (--hull compute needs none)",
            )?;
        }
        if options.shading == ShadingRate::PerSample {
            caps.require(Feature::SampleRateShading, "technique `stochastic --shading per-sample`")?;
        }
        if options.instrumented {
            caps.require(Feature::FragmentStoresAndAtomics, "instrumented `stochastic` (sample counters)")?;
        }
        let compute = options.expansion == HullExpansion::Compute;
        if compute && debug.bound_debug_triangles > 0 {
            return Err(Error::Unsupported(
                "the bound debug output exists for the geometry-shader hull only".into(),
            ));
        }
        if debug.bound_debug_triangles > 0 {
            caps.require(Feature::VertexPipelineStoresAndAtomics, "the bound debug output")?;
            if paths.iter().any(|&e| e != Effects::Both) {
                return Err(Error::Unsupported(
                    "the bound debug output exists for the defocus+motion path only".into(),
                ));
            }
        }
        if spp == 0 || spp > MAX_STOCHASTIC_SPP {
            return Err(Error::Limit {
                what: "spp",
                value: spp.to_string(),
                limit: format!("1..={MAX_STOCHASTIC_SPP} for technique `stochastic`"),
            });
        }
        let (msaa, passes) = msaa_and_passes(spp, options.msaa, &caps.framebuffer_sample_counts)?;

        let object_set_layout = DescriptorSetLayout::from_table(
            device,
            "stochastic object set layout",
            &STOCHASTIC_OBJECT_SET,
            vk::ShaderStageFlags::ALL_GRAPHICS | vk::ShaderStageFlags::COMPUTE,
        )?;
        let technique_set_layout = DescriptorSetLayout::from_table(
            device,
            "stochastic set layout",
            &STOCHASTIC_SET,
            vk::ShaderStageFlags::ALL_GRAPHICS | vk::ShaderStageFlags::COMPUTE,
        )?;
        let sets = [&object_set_layout, &technique_set_layout];
        let comp = ShaderModule::new(device, shaders::STOCHASTIC_TRIANGLES_COMP)?;
        let triangles_layout = world.pipeline_layout(
            device,
            &sets,
            std::mem::size_of::<TrianglesPush>() as u32,
            vk::ShaderStageFlags::COMPUTE,
        )?;
        let triangles_pipeline =
            Pipeline::compute(device, "camera-space triangles", &triangles_layout, &comp)?;
        // The geometry stage is named only where the device has one.
        let mut push_stages = vk::ShaderStageFlags::VERTEX | vk::ShaderStageFlags::FRAGMENT;
        if caps.geometry_shader {
            push_stages |= vk::ShaderStageFlags::GEOMETRY;
        }
        let layout = world.pipeline_layout(
            device,
            &sets,
            std::mem::size_of::<StochasticPush>() as u32,
            push_stages,
        )?;
        let (bindings, attributes) = vertex_input();
        let vert = ShaderModule::new(device, shaders::STOCHASTIC_STOCHASTIC_VERT)?;
        let hull_vert = ShaderModule::new(device, shaders::STOCHASTIC_HULL_VERT)?;
        let mut shader_modules = vec![];
        let mut pipelines = Vec::with_capacity(paths.len());
        for &effects in &paths {
            let frag = StochasticFrag {
                hull: options.expansion.axis(),
                shading: options.shading.axis(),
                instrumented: options.instrumented,
                effects: effects.shader_axis(),
            };
            let frag = ShaderModule::new(device, frag.source())?;
            let (first, geom) = if compute {
                (&hull_vert, None)
            } else {
                let geom = StochasticGeom {
                    bound_debug: debug.bound_debug_triangles > 0,
                    effects: effects.shader_axis(),
                };
                (&vert, Some(ShaderModule::new(device, geom.source())?))
            };
            let stages: Vec<&ShaderModule> =
                [Some(first), geom.as_ref(), Some(&frag)].into_iter().flatten().collect();
            let pipeline = Pipeline::graphics(
                device,
                &layout,
                &GraphicsDesc {
                    name: &format!("stochastic ({}, {} hull)", effects.name(), options.expansion.name()),
                    stages: &stages,
                    vertex_bindings: if compute { &[] } else { &bindings },
                    vertex_attributes: if compute { &[] } else { &attributes[..1] },
                    color_formats: &[COLOR_FORMAT],
                    depth_format: Some(DEPTH_FORMAT),
                    samples: msaa,
                    sample_shading: (options.shading == ShadingRate::PerSample).then_some(1.0),
                    cull_mode: vk::CullModeFlags::NONE,
                    front_face: vk::FrontFace::COUNTER_CLOCKWISE,
                    depth_compare: vk::CompareOp::GREATER,
                    depth_write: true,
                },
            )?;
            pipelines.push((effects, pipeline));
            shader_modules.extend(geom);
            shader_modules.push(frag);
        }
        shader_modules.extend([vert, hull_vert, comp]);

        let storage = vk::BufferUsageFlags::STORAGE_BUFFER;
        let (xy_lens, time) = gpu_samples(spp, seed, aperture, shutter);
        let samples = [
            Buffer::with_data(device, "stochastic samples (xy, lens)", storage, &xy_lens)?,
            Buffer::with_data(device, "stochastic samples (time)", storage, &time)?,
        ];
        let counters = Tracked::new(Buffer::with_data(device, "stochastic counters", storage, &[0u32; 4])?);
        let bound_debug = if debug.bound_debug_triangles > 0 {
            let len = debug.bound_debug_triangles as usize * BOUND_DEBUG_STRIDE;
            Some(Tracked::new(Buffer::with_data(device, "bound debug", storage, &vec![0f32; len])?))
        } else {
            None
        };

        let n_objects = world.objects.len() as u32;
        let pool = DescriptorPool::for_tables(
            device,
            n_objects + 1,
            &[(&STOCHASTIC_OBJECT_SET, n_objects), (&STOCHASTIC_SET, 1)],
        )?;
        let technique_set = pool.allocate(&technique_set_layout)?;
        let mut writes = vec![
            DescriptorWrite::storage_buffer(0, &samples[0]),
            DescriptorWrite::storage_buffer(1, &samples[1]),
            DescriptorWrite::storage_buffer(2, &counters),
        ];
        if let Some(b) = &bound_debug {
            writes.push(DescriptorWrite::storage_buffer(3, b));
        }
        write_descriptors(device, technique_set, &writes);
        let mut object_sets = Vec::with_capacity(world.objects.len());
        let mut triangles = Vec::with_capacity(world.objects.len());
        for o in &world.objects {
            let bytes = (o.index_count as u64 / 3).max(1) * TRIANGLE_RECORD_BYTES;
            let t = Buffer::new(
                device,
                &format!("camera-space triangles:{}", o.name),
                bytes,
                storage,
                MemoryLocation::GpuOnly,
            )?;
            let set = pool.allocate(&object_set_layout)?;
            write_descriptors(device, set, &[DescriptorWrite::storage_buffer(0, &t)]);
            object_sets.push(set);
            triangles.push(Tracked::new(t));
        }
        let hull = if compute {
            Some(ComputeHull::new(
                device,
                world,
                &paths,
                &sets,
                &object_sets,
                technique_set,
                debug.hull_vertices_per_triangle.unwrap_or(INITIAL_VERTICES_PER_TRIANGLE),
            )?)
        } else {
            None
        };
        Ok(StochasticDraws {
            pipelines,
            object_effects: object_effects.to_vec(),
            layout,
            push_stages,
            object_sets,
            technique_set,
            options,
            spp,
            msaa,
            passes,
            dilate: crate::bounds::dilation_px(msaa, caps.standard_sample_locations),
            counters,
            bound_debug,
            triangles,
            triangles_pipeline,
            triangles_layout,
            hull,
            hull_counts: vec![0; world.objects.len()],
            _samples: samples,
            _pool: pool,
            _set_layouts: [object_set_layout, technique_set_layout],
            _shaders: shader_modules,
        })
    }

    /// MSAA samples per pass and number of passes.
    pub fn msaa_and_passes(&self) -> (u32, u32) {
        (self.msaa, self.passes)
    }

    /// The counters of the last frame (instrumented renders only).
    pub fn counters(&self) -> Result<Option<SampleCounters>> {
        if !self.options.instrumented {
            return Ok(None);
        }
        let raw = self.counters.read_u32s(4)?;
        Ok(Some(SampleCounters {
            samples_tested: raw[0] as u64,
            samples_hit: raw[1] as u64,
            shading_invocations: raw[2] as u64,
            fragments: raw[3] as u64,
        }))
    }

    /// The compute-expanded hull's buffer capacity and this frame's vertex count per object (None
    /// behind the geometry shader).
    pub fn hull_usage(&self) -> Option<(Vec<u32>, Vec<u32>)> {
        self.hull.as_ref().map(|h| (h.capacity().to_vec(), self.hull_counts.clone()))
    }

    /// The geometry shader's debug output of the last frame: per triangle of the first object,
    /// `BOUND_DEBUG_STRIDE` floats (empty without [`DebugOptions::bound_debug_triangles`]).
    pub fn bound_debug(&self) -> Result<Vec<f32>> {
        let Some(b) = &self.bound_debug else { return Ok(vec![]) };
        Ok(b.mapped()?.chunks_exact(4).map(|c| f32::from_ne_bytes([c[0], c[1], c[2], c[3]])).collect())
    }

    fn is_drawn(&self, i: usize) -> bool {
        self.object_effects[i].is_stochastic()
    }

    /// The camera-space triangles of every object on the path, once per frame (they do not depend on
    /// the pass): a compute pass per view (thesis §9.6: the fragment stage reads one record per
    /// fragment instead of transforming three vertices twice).
    fn add_triangles_pass<'a>(&'a self, g: &mut FrameGraph<'a>, inputs: &FrameInputs<'a>) {
        let mut drawn = Vec::new();
        let mut handles = Vec::new();
        for (i, t) in self.triangles.iter().enumerate() {
            if self.is_drawn(i) && inputs.world.objects[i].index_count >= 3 {
                handles.push(g.import_buffer("camera-space triangles", t));
                drawn.push(i);
            }
        }
        let mut pass = g.pass("triangles");
        for h in handles {
            pass = pass.overwrite(h, Access::ComputeShaderWrite);
        }
        let (world, view) = (inputs.world, inputs.camera);
        pass.record(move |ctx| {
            self.record_triangles(ctx, world, view, &drawn);
            Ok(())
        });
    }

    fn record_triangles(&self, ctx: &PassContext<'_>, world: &GpuWorld, view: &GpuView, objects: &[usize]) {
        let (d, cmd) = (ctx.device, ctx.cmd);
        let bind = vk::PipelineBindPoint::COMPUTE;
        let layout = self.triangles_layout.raw;
        unsafe {
            d.raw.cmd_bind_pipeline(cmd, bind, self.triangles_pipeline.raw);
            d.raw.cmd_bind_descriptor_sets(cmd, bind, layout, FRAME_SET_INDEX, &[view.frame_set], &[]);
            for &i in objects {
                let o = &world.objects[i];
                let sets = [o.set, self.object_sets[i]];
                d.raw.cmd_bind_descriptor_sets(cmd, bind, layout, OBJECT_SET_INDEX, &sets, &[]);
                let push = TrianglesPush { object: i as u32, triangle_count: o.triangle_count() };
                d.raw.cmd_push_constants(
                    cmd,
                    layout,
                    vk::ShaderStageFlags::COMPUTE,
                    0,
                    bytemuck::bytes_of(&push),
                );
                d.raw.cmd_dispatch(cmd, o.triangle_count().div_ceil(64), 1, 1);
            }
        }
    }
}

impl PassDraws for StochasticDraws {
    fn before_frame(&mut self, inputs: &FrameInputs<'_>, frame: &mut FrameContext<'_>) -> Result<()> {
        self.counters.get_mut().write(&[0u32; 4])?;
        if self.hull.is_none() {
            return Ok(());
        }
        // The compute-expanded hull: triangles and expansion in a graph of their own, its counts read
        // back; an overflowed buffer grows and the expansion runs again, so no bound is ever dropped.
        loop {
            let hull = self.hull.as_mut().expect("checked");
            hull.reset_counts()?;
            {
                let this = &*self;
                let hull = this.hull.as_ref().expect("checked");
                let mut g = frame.graph();
                this.add_triangles_pass(&mut g, inputs);
                hull.add_expand_pass(
                    &mut g,
                    inputs,
                    (&this.triangles, &this.object_sets, this.technique_set),
                    &this.object_effects,
                    this.options.bound.id(),
                    this.dilate,
                );
                frame.run(g)?;
            }
            let device = frame.device().clone();
            let hull = self.hull.as_mut().expect("checked");
            if !hull.grow_overflowed(&device, inputs.world, &self.object_sets)? {
                self.hull_counts = hull.counts()?;
                return Ok(());
            }
        }
    }

    fn add_frame_passes<'a>(&'a self, g: &mut FrameGraph<'a>, inputs: &FrameInputs<'a>) -> Result<FrameUse> {
        let mut used = FrameUse::default();
        if self.hull.is_none() {
            self.add_triangles_pass(g, inputs);
        }
        for (i, t) in self.triangles.iter().enumerate() {
            if self.is_drawn(i) {
                let h = g.import_buffer("camera-space triangles", t);
                used.pass_accesses.push((h.into(), Access::FragmentShaderReadOther));
            }
        }
        if let Some(hull) = &self.hull {
            for (i, [vertices, sources]) in hull.buffers().iter().enumerate() {
                if self.is_drawn(i) {
                    for (name, b) in [("hull", vertices), ("hull triangles", sources)] {
                        let h: ResourceHandle = g.import_buffer(name, b).into();
                        used.pass_accesses.push((h, Access::VertexShaderReadOther));
                    }
                }
            }
        }
        if self.options.instrumented {
            let h = g.import_buffer("stochastic counters", &self.counters);
            // Atomics read and write.
            used.pass_accesses.push((h.into(), Access::FragmentShaderReadOther));
            used.pass_accesses.push((h.into(), Access::FragmentShaderWrite));
            used.host_reads.push(h);
        }
        if let Some(b) = &self.bound_debug {
            let h = g.import_buffer("bound debug", b);
            used.pass_accesses.push((h.into(), Access::GeometryShaderWrite));
            used.host_reads.push(h);
        }
        Ok(used)
    }

    fn record(&self, ctx: &mut PassContext<'_>, inputs: &FrameInputs<'_>, pass: u32) {
        let (d, cmd) = (ctx.device, ctx.cmd);
        let bind = vk::PipelineBindPoint::GRAPHICS;
        let push = |i: usize| StochasticPush {
            object: i as u32,
            bound: self.options.bound.id(),
            pass_index: pass,
            spp: self.spp,
            msaa: self.msaa,
            footprint: 1.0 / (self.spp as f32).sqrt(),
            dilate: self.dilate,
        };
        let world = inputs.world;
        for (effects, pipeline) in &self.pipelines {
            unsafe {
                d.raw.cmd_bind_pipeline(cmd, bind, pipeline.raw);
                d.raw.cmd_bind_descriptor_sets(
                    cmd,
                    bind,
                    self.layout.raw,
                    TECHNIQUE_SET_INDEX,
                    &[self.technique_set],
                    &[],
                );
            }
            let include = |i: usize| self.object_effects[i] == *effects;
            if self.hull.is_none() {
                world.record_object_draws(
                    d,
                    cmd,
                    inputs.camera,
                    &self.layout,
                    self.push_stages,
                    include,
                    push,
                    |i| Some(self.object_sets[i]),
                );
                continue;
            }
            // Compute-expanded hull: each object's triangle list, no vertex input.
            unsafe {
                d.raw.cmd_bind_descriptor_sets(
                    cmd,
                    bind,
                    self.layout.raw,
                    FRAME_SET_INDEX,
                    &[inputs.camera.frame_set],
                    &[],
                );
                for (i, o) in world.objects.iter().enumerate() {
                    if !include(i) || self.hull_counts[i] == 0 {
                        continue;
                    }
                    d.raw.cmd_push_constants(
                        cmd,
                        self.layout.raw,
                        self.push_stages,
                        0,
                        bytemuck::bytes_of(&push(i)),
                    );
                    let sets = [o.set, self.object_sets[i]];
                    d.raw.cmd_bind_descriptor_sets(cmd, bind, self.layout.raw, OBJECT_SET_INDEX, &sets, &[]);
                    d.raw.cmd_draw(cmd, self.hull_counts[i], 1, 0, 0);
                }
            }
        }
    }
}

/// Technique `stochastic`: every object on the stochastic path simulating both effects, in the
/// multipass frame.
pub struct StochasticTechnique {
    frame: MultipassFrame,
    draws: StochasticDraws,
}

impl StochasticTechnique {
    /// The technique for the objects' paths `object_effects` (technique `stochastic`: all `Both`).
    pub fn new(
        ctx: &PrepareContext<'_>,
        options: StochasticOptions,
        debug: DebugOptions,
        object_effects: &[Effects],
    ) -> Result<Self> {
        let draws = StochasticDraws::new(ctx, options, debug, object_effects)?;
        let (msaa, passes) = draws.msaa_and_passes();
        let frame =
            MultipassFrame::new(ctx.device, ctx.world, ctx.camera.size(), msaa, passes, "stochastic")?;
        Ok(StochasticTechnique { frame, draws })
    }

    /// The stochastic path (for its diagnostics: bound debug output, hull usage).
    pub fn draws(&self) -> &StochasticDraws {
        &self.draws
    }
}

impl FrameTechnique for StochasticTechnique {
    fn render(&mut self, inputs: &FrameInputs<'_>, frame: &mut FrameContext<'_>) -> Result<TechniqueFrame> {
        self.draws.before_frame(inputs, frame)?;
        let draws: [&dyn PassDraws; 1] = [&self.draws];
        let image = self.frame.render(frame, inputs, &draws)?;
        Ok(self.frame.technique_frame(image, self.draws.counters()?))
    }
}

/// What the stochastic rasterizer's shaders expect of the layouts [`StochasticDraws::new`] builds:
/// sets 2 and 3 from [`STOCHASTIC_OBJECT_SET`] and [`STOCHASTIC_SET`], and [`StochasticPush`] for the
/// raster pipelines (`hull.vert` pushes nothing), [`TrianglesPush`] for `triangles.comp`. Also
/// `expand.comp`'s: [`ComputeHull`] builds its pipeline with these two sets' layouts (handed over
/// here; it writes the hull bindings of set 2 and the counts' binding of set 3) and
/// [`super::compute_hull::ExpandPush`].
pub const SHADER_INTERFACES: &[crate::gpu::layout::ShaderInterface] = &[
    crate::gpu::layout::ShaderInterface::technique(
        &[
            "stochastic/stochastic.vert",
            "stochastic/stochastic.geom",
            "stochastic/hull.vert",
            "stochastic/stochastic.frag",
        ],
        Some(&STOCHASTIC_OBJECT_SET),
        Some(&STOCHASTIC_SET),
        Some(STOCHASTIC_STRUCTS[0]),
    ),
    crate::gpu::layout::ShaderInterface::technique(
        &["stochastic/triangles.comp"],
        Some(&STOCHASTIC_OBJECT_SET),
        Some(&STOCHASTIC_SET),
        Some(STOCHASTIC_STRUCTS[1]),
    ),
    crate::gpu::layout::ShaderInterface::technique(
        &["stochastic/expand.comp"],
        Some(&STOCHASTIC_OBJECT_SET),
        Some(&STOCHASTIC_SET),
        Some(super::compute_hull::EXPAND_STRUCTS[0]),
    ),
];
