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
//! resolved and averaged by [`super::targets::PassTargets`].
//!
//! The (x, y, u, v, t) samples are those of the CPU reference ([`SampleTile`]: 64×64 pixels × S
//! stratified samples, aperture shape and shutter curve applied here, never in the shaders), so at
//! equal S and seed the two estimate the pixel integral with the very same samples.
//! Shaders: `shaders-glsl/stochastic/`.

use ash::vk;
use gpu_allocator::MemoryLocation;

use super::compute_hull::{ComputeHull, HullExpansion, INITIAL_VERTICES_PER_TRIANGLE};
use super::forward::{ForwardPipeline, PassSample};
use super::gpu_scene::GpuScene;
use super::targets::{PassTargets, COLOR_FORMAT, DEPTH_FORMAT};
use crate::bounds::BoundKind;
use crate::error::{Error, Result};
use crate::image::LinearImage;
use crate::plan::Effects;
use crate::sampling::{ApertureShape, SampleTile, ShutterCurve, SAMPLE_TILE_SIZE};
use crate::shaders::{self, ShaderSource};
use crate::vk::{
    as_bytes, write_descriptors, Buffer, CommandRecorder, DescriptorPool, DescriptorSetLayout,
    DescriptorWrite, Device, Feature, GpuTimer, GraphicsDesc, PassTimings, Pipeline, PipelineLayout,
    ShaderModule,
};

/// Largest S the stochastic technique accepts (the sample tile is 64·64·S·20 bytes: 84 MB at 1024).
pub const MAX_STOCHASTIC_SPP: u32 = 1024;

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

#[repr(C)]
#[derive(Clone, Copy)]
struct StochasticPush {
    object: u32,
    bound: u32,
    pass_index: u32,
    spp: u32,
    msaa: u32,
    footprint: f32,
    dilate: f32,
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

/// The fragment shader permutation for a shading rate, instrumentation and effect path.
fn fragment_shader(shading: ShadingRate, instrumented: bool, effects: Effects) -> ShaderSource {
    use shaders::*;
    use Effects::*;
    use ShadingRate::*;
    match (shading, instrumented, effects) {
        (PerPixel, false, Both | Pinhole) => STOCHASTIC_STOCHASTIC_FRAG,
        (PerPixel, false, Defocus) => STOCHASTIC_STOCHASTIC_FRAG_DEFOCUS,
        (PerPixel, false, Motion) => STOCHASTIC_STOCHASTIC_FRAG_MOTION,
        (PerPixel, true, Both | Pinhole) => STOCHASTIC_STOCHASTIC_FRAG_INSTRUMENTED,
        (PerPixel, true, Defocus) => STOCHASTIC_STOCHASTIC_FRAG_INSTRUMENTED_DEFOCUS,
        (PerPixel, true, Motion) => STOCHASTIC_STOCHASTIC_FRAG_INSTRUMENTED_MOTION,
        (PerSample, false, Both | Pinhole) => STOCHASTIC_STOCHASTIC_FRAG_PER_SAMPLE,
        (PerSample, false, Defocus) => STOCHASTIC_STOCHASTIC_FRAG_PER_SAMPLE_DEFOCUS,
        (PerSample, false, Motion) => STOCHASTIC_STOCHASTIC_FRAG_PER_SAMPLE_MOTION,
        (PerSample, true, Both | Pinhole) => STOCHASTIC_STOCHASTIC_FRAG_PER_SAMPLE_INSTRUMENTED,
        (PerSample, true, Defocus) => STOCHASTIC_STOCHASTIC_FRAG_PER_SAMPLE_INSTRUMENTED_DEFOCUS,
        (PerSample, true, Motion) => STOCHASTIC_STOCHASTIC_FRAG_PER_SAMPLE_INSTRUMENTED_MOTION,
    }
}

/// The geometry shader permutation for an effect path (the bound debug output exists for `Both`).
fn geometry_shader(effects: Effects, bound_debug: bool) -> ShaderSource {
    match (effects, bound_debug) {
        (_, true) => shaders::STOCHASTIC_STOCHASTIC_GEOM_BOUND_DEBUG,
        (Effects::Defocus, false) => shaders::STOCHASTIC_STOCHASTIC_GEOM_DEFOCUS,
        (Effects::Motion, false) => shaders::STOCHASTIC_STOCHASTIC_GEOM_MOTION,
        (Effects::Both | Effects::Pinhole, false) => shaders::STOCHASTIC_STOCHASTIC_GEOM,
    }
}

/// Pipelines, sample buffers and per-object descriptor sets of the stochastic rasterizer.
///
/// Every object takes one path ([`Effects`], from [`crate::plan`] for technique `auto`, `Both` for
/// technique `stochastic`): one stochastic pipeline per effect permutation in use, and the plain
/// forward pipeline (mid-shutter, lens centre) for `Pinhole` objects, drawn into the same
/// multisampled targets with the same reversed-Z depth in every pass.
pub struct StochasticRenderer {
    targets: PassTargets,
    pipelines: Vec<(Effects, Pipeline)>,
    plain: Option<ForwardPipeline>,
    object_effects: Vec<Effects>,
    layout: PipelineLayout,
    object_sets: Vec<vk::DescriptorSet>,
    sample_set: vk::DescriptorSet,
    options: StochasticOptions,
    spp: u32,
    passes: u32,
    /// Box half-size of the bound dilation ([`crate::bounds::dilation_px`]).
    dilate: f32,
    counters: Buffer,
    bound_debug: Buffer,
    /// The compute-expanded hull's buffers and pipelines ([`HullExpansion::Compute`]).
    hull: Option<ComputeHull>,
    /// Vertices of each object's expanded hull this frame (compute expansion).
    hull_counts: Vec<u32>,
    _samples: [Buffer; 2],
    _pool: DescriptorPool,
    _set_layouts: [DescriptorSetLayout; 2],
    triangles_pipeline: Pipeline,
    triangles_layout: PipelineLayout,
    _triangles: Vec<Buffer>,
    _shaders: Vec<ShaderModule>,
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

impl StochasticRenderer {
    /// `object_effects[i]` is object i's path (one per object of `scene`).
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        device: &Device,
        scene: &GpuScene,
        spp: u32,
        seed: u64,
        aperture: ApertureShape,
        shutter: ShutterCurve,
        options: StochasticOptions,
        debug: DebugOptions,
        object_effects: &[Effects],
    ) -> Result<Self> {
        let caps = &device.caps;
        if object_effects.len() != scene.objects.len() {
            return Err(Error::Unsupported(format!(
                "{} object paths for {} objects",
                object_effects.len(),
                scene.objects.len()
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
        }
        if spp == 0 || spp > MAX_STOCHASTIC_SPP {
            return Err(Error::Limit {
                what: "spp",
                value: spp.to_string(),
                limit: format!("1..={MAX_STOCHASTIC_SPP} for technique `stochastic`"),
            });
        }
        let (msaa, passes) = match options.msaa {
            None => split_samples(spp, &caps.framebuffer_sample_counts),
            Some(m) if caps.framebuffer_sample_counts.contains(&m) && spp.is_multiple_of(m) => (m, spp / m),
            Some(m) => {
                return Err(Error::Unsupported(format!(
                "{m}x MSAA per pass for S = {spp}: it must divide S and be one of the device's counts {:?}",
                caps.framebuffer_sample_counts
            )))
            }
        };

        if debug.bound_debug_triangles > 0 && paths.iter().any(|&e| e != Effects::Both) {
            return Err(Error::Unsupported(
                "the bound debug output exists for the defocus+motion path only".into(),
            ));
        }
        let vert = ShaderModule::new(device, shaders::STOCHASTIC_STOCHASTIC_VERT)?;
        let frag_stage = vk::ShaderStageFlags::FRAGMENT;
        let geometry_stages = vk::ShaderStageFlags::FRAGMENT | vk::ShaderStageFlags::COMPUTE;
        let geometry_layout = DescriptorSetLayout::new(
            device,
            "stochastic geometry set layout",
            &[
                (0, vk::DescriptorType::STORAGE_BUFFER, geometry_stages),
                (1, vk::DescriptorType::STORAGE_BUFFER, geometry_stages),
                (2, vk::DescriptorType::STORAGE_BUFFER, geometry_stages),
                // The compute-expanded hull: its triangle list and the per-object vertex counts.
                (
                    3,
                    vk::DescriptorType::STORAGE_BUFFER,
                    vk::ShaderStageFlags::COMPUTE | vk::ShaderStageFlags::VERTEX,
                ),
                (4, vk::DescriptorType::STORAGE_BUFFER, vk::ShaderStageFlags::COMPUTE),
                (
                    5,
                    vk::DescriptorType::STORAGE_BUFFER,
                    vk::ShaderStageFlags::COMPUTE | vk::ShaderStageFlags::VERTEX,
                ),
            ],
        )?;
        let comp = ShaderModule::new(device, shaders::STOCHASTIC_TRIANGLES_COMP)?;
        let triangles_layout = PipelineLayout::new(
            device,
            &[&scene.frame_layout, &geometry_layout],
            8,
            vk::ShaderStageFlags::COMPUTE,
        )?;
        let triangles_pipeline =
            Pipeline::compute(device, "camera-space triangles", &triangles_layout, &comp)?;
        let sample_layout = DescriptorSetLayout::new(
            device,
            "stochastic sample set layout",
            &[
                (0, vk::DescriptorType::STORAGE_BUFFER, frag_stage),
                (1, vk::DescriptorType::STORAGE_BUFFER, frag_stage),
                (2, vk::DescriptorType::STORAGE_BUFFER, frag_stage),
                (3, vk::DescriptorType::STORAGE_BUFFER, vk::ShaderStageFlags::GEOMETRY),
            ],
        )?;
        let layout = PipelineLayout::new(
            device,
            &[&scene.frame_layout, &scene.material_layout, &geometry_layout, &sample_layout],
            std::mem::size_of::<StochasticPush>() as u32,
            vk::ShaderStageFlags::VERTEX | vk::ShaderStageFlags::GEOMETRY | vk::ShaderStageFlags::FRAGMENT,
        )?;
        let (bindings, attributes) = GpuScene::vertex_input();
        let mut shader_modules = vec![vert];
        let mut pipelines = Vec::with_capacity(paths.len());
        let hull_vert = ShaderModule::new(device, shaders::STOCHASTIC_HULL_VERT)?;
        for &effects in &paths {
            let per_sample = options.shading == ShadingRate::PerSample;
            let (first, geom, frag) = if compute {
                let frag = ShaderModule::new(
                    device,
                    super::compute_hull::fragment_shader(per_sample, options.instrumented, effects),
                )?;
                (&hull_vert, None, frag)
            } else {
                let geom =
                    ShaderModule::new(device, geometry_shader(effects, debug.bound_debug_triangles > 0))?;
                let frag = ShaderModule::new(
                    device,
                    fragment_shader(options.shading, options.instrumented, effects),
                )?;
                (&shader_modules[0], Some(geom), frag)
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
        shader_modules.push(hull_vert);
        let plain = if object_effects.contains(&Effects::Pinhole) {
            Some(ForwardPipeline::new(device, scene, msaa)?)
        } else {
            None
        };

        let storage = vk::BufferUsageFlags::STORAGE_BUFFER;
        let (xy_lens, time) = gpu_samples(spp, seed, aperture, shutter);
        let samples = [
            Buffer::with_data(device, "stochastic samples (xy, lens)", storage, &xy_lens)?,
            Buffer::with_data(device, "stochastic samples (time)", storage, &time)?,
        ];
        let counters = Buffer::with_data(device, "stochastic counters", storage, &[0u32; 4])?;
        let debug_len = (debug.bound_debug_triangles as usize * BOUND_DEBUG_STRIDE).max(1);
        let bound_debug = Buffer::with_data(device, "bound debug", storage, &vec![0f32; debug_len])?;

        let n_objects = scene.objects.len() as u32;
        let pool = DescriptorPool::new(
            device,
            n_objects + 1,
            &[(vk::DescriptorType::STORAGE_BUFFER, 6 * n_objects + 4)],
        )?;
        let sample_set = pool.allocate(&sample_layout)?;
        let buffer = |binding, b: &Buffer| DescriptorWrite::Buffer {
            binding,
            ty: vk::DescriptorType::STORAGE_BUFFER,
            buffer: b.raw,
        };
        write_descriptors(
            device,
            sample_set,
            &[buffer(0, &samples[0]), buffer(1, &samples[1]), buffer(2, &counters), buffer(3, &bound_debug)],
        );
        let mut object_sets = Vec::with_capacity(scene.objects.len());
        let mut triangles = Vec::with_capacity(scene.objects.len());
        for o in &scene.objects {
            let bytes = (o.index_count as u64 / 3).max(1) * TRIANGLE_RECORD_BYTES;
            let t = Buffer::new(
                device,
                &format!("camera-space triangles:{}", o.name),
                bytes,
                storage,
                MemoryLocation::GpuOnly,
            )?;
            let set = pool.allocate(&geometry_layout)?;
            write_descriptors(device, set, &[buffer(0, &o.vertices), buffer(1, &o.indices), buffer(2, &t)]);
            object_sets.push(set);
            triangles.push(t);
        }
        let hull = if compute {
            Some(ComputeHull::new(
                device,
                scene,
                &paths,
                &geometry_layout,
                &object_sets,
                debug.hull_vertices_per_triangle.unwrap_or(INITIAL_VERTICES_PER_TRIANGLE),
            )?)
        } else {
            None
        };
        let targets = PassTargets::new(device, scene.width, scene.height, msaa)?;
        shader_modules.push(comp);
        Ok(StochasticRenderer {
            targets,
            pipelines,
            plain,
            object_effects: object_effects.to_vec(),
            layout,
            object_sets,
            sample_set,
            options,
            spp,
            passes,
            dilate: crate::bounds::dilation_px(msaa, caps.standard_sample_locations),
            counters,
            bound_debug,
            hull,
            hull_counts: vec![0; scene.objects.len()],
            _samples: samples,
            _pool: pool,
            _set_layouts: [geometry_layout, sample_layout],
            triangles_pipeline,
            triangles_layout,
            _triangles: triangles,
            _shaders: shader_modules,
        })
    }

    /// MSAA samples per pass and number of passes.
    pub fn msaa_and_passes(&self) -> (u32, u32) {
        (self.targets.samples(), self.passes)
    }

    /// Renders all passes and reads the averaged image back; with `instrumented`, also the counters.
    pub fn render(
        &mut self,
        device: &Device,
        rec: &mut CommandRecorder,
        scene: &GpuScene,
    ) -> Result<(LinearImage, PassTimings, Option<SampleCounters>)> {
        self.counters.write(&[0u32; 4])?;
        let mut timer = GpuTimer::new(device, 2)?;
        let mut pre = loop {
            if let Some(h) = &mut self.hull {
                h.reset_counts()?;
            }
            let this = &*self;
            rec.submit(|d, cmd| {
                timer.reset(cmd);
                let t = timer.begin(cmd, "triangles");
                this.record_triangles(d, cmd, scene);
                timer.end(cmd, t);
                if let Some(h) = &this.hull {
                    let t = timer.begin(cmd, "expand");
                    h.record_expand(
                        d,
                        cmd,
                        scene,
                        &this.object_sets,
                        &this.object_effects,
                        this.options.bound.id(),
                        this.dilate,
                    );
                    // The passes' vertex shaders read the hulls (in later submissions). Inside the timed
                    // scope: a driver may defer the dispatches' work to the barrier (lavapipe does).
                    crate::vk::memory_barrier(
                        d,
                        cmd,
                        (vk::PipelineStageFlags2::COMPUTE_SHADER, vk::AccessFlags2::SHADER_STORAGE_WRITE),
                        (vk::PipelineStageFlags2::VERTEX_SHADER, vk::AccessFlags2::SHADER_STORAGE_READ),
                    );
                    timer.end(cmd, t);
                }
                Ok(())
            })?;
            let timings = timer.results()?;
            match &mut self.hull {
                None => break timings,
                Some(h) => {
                    // An overflowed buffer grows and the expansion runs again: no bound is dropped.
                    if !h.grow_overflowed(device, scene, &self.object_sets)? {
                        self.hull_counts = h.counts()?;
                        break timings;
                    }
                }
            }
        };
        let this = &*self;
        let mut draw =
            |d: &Device, cmd: vk::CommandBuffer, pass: usize| this.record_draws(d, cmd, scene, pass as u32);
        let (image, timings) = this.targets.render(
            device,
            rec,
            scene.background,
            this.passes as usize,
            "stochastic",
            &mut draw,
        )?;
        pre.passes.extend(timings.passes);
        let timings = pre;
        let counters = if self.options.instrumented {
            let raw: Vec<u32> = self.counters.mapped()?[..16]
                .chunks_exact(4)
                .map(|c| u32::from_ne_bytes([c[0], c[1], c[2], c[3]]))
                .collect();
            Some(SampleCounters {
                samples_tested: raw[0] as u64,
                samples_hit: raw[1] as u64,
                shading_invocations: raw[2] as u64,
                fragments: raw[3] as u64,
            })
        } else {
            None
        };
        Ok((image, timings, counters))
    }

    /// The compute-expanded hull's buffer capacity and this frame's vertex count per object (None
    /// behind the geometry shader).
    pub fn hull_usage(&self) -> Option<(Vec<u32>, Vec<u32>)> {
        self.hull.as_ref().map(|h| (h.capacity().to_vec(), self.hull_counts.clone()))
    }

    /// The geometry shader's debug output: per triangle of the first object, `BOUND_DEBUG_STRIDE` floats.
    pub fn bound_debug(&self) -> Result<Vec<f32>> {
        Ok(self
            .bound_debug
            .mapped()?
            .chunks_exact(4)
            .map(|c| f32::from_ne_bytes([c[0], c[1], c[2], c[3]]))
            .collect())
    }

    /// Camera-space triangles of every object (once per frame: they do not depend on the pass).
    fn record_triangles(&self, d: &Device, cmd: vk::CommandBuffer, scene: &GpuScene) {
        d.begin_label(cmd, "camera-space triangles");
        unsafe {
            d.raw.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::COMPUTE, self.triangles_pipeline.raw);
            d.raw.cmd_bind_descriptor_sets(
                cmd,
                vk::PipelineBindPoint::COMPUTE,
                self.triangles_layout.raw,
                0,
                &[scene.frame_set],
                &[],
            );
            for (i, o) in scene.objects.iter().enumerate() {
                let count = o.index_count / 3;
                if count == 0 || !self.object_effects[i].is_stochastic() {
                    continue;
                }
                d.raw.cmd_bind_descriptor_sets(
                    cmd,
                    vk::PipelineBindPoint::COMPUTE,
                    self.triangles_layout.raw,
                    1,
                    &[self.object_sets[i]],
                    &[],
                );
                let push = [i as u32, count];
                d.raw.cmd_push_constants(
                    cmd,
                    self.triangles_layout.raw,
                    vk::ShaderStageFlags::COMPUTE,
                    0,
                    as_bytes(&push),
                );
                d.raw.cmd_dispatch(cmd, count.div_ceil(64), 1, 1);
            }
        }
        // The expansion (same submission) and later submissions' fragment shaders read the records
        // (barrier scopes span submission order).
        crate::vk::memory_barrier(
            d,
            cmd,
            (vk::PipelineStageFlags2::COMPUTE_SHADER, vk::AccessFlags2::SHADER_STORAGE_WRITE),
            (
                vk::PipelineStageFlags2::COMPUTE_SHADER | vk::PipelineStageFlags2::FRAGMENT_SHADER,
                vk::AccessFlags2::SHADER_STORAGE_READ,
            ),
        );
        d.end_label(cmd);
    }

    fn record_draws(&self, d: &Device, cmd: vk::CommandBuffer, scene: &GpuScene, pass: u32) {
        let stages =
            vk::ShaderStageFlags::VERTEX | vk::ShaderStageFlags::GEOMETRY | vk::ShaderStageFlags::FRAGMENT;
        let bind = vk::PipelineBindPoint::GRAPHICS;
        if let Some(plain) = &self.plain {
            let pinhole = PassSample {
                jitter: super::pinhole::pinhole_pass_jitter(pass, self.passes, self.targets.samples()),
                ..super::pinhole::pinhole_passes()[0]
            };
            plain.record_draws(d, cmd, scene, &pinhole, |i| self.object_effects[i] == Effects::Pinhole);
        }
        let push = |i: usize| StochasticPush {
            object: i as u32,
            bound: self.options.bound.id(),
            pass_index: pass,
            spp: self.spp,
            msaa: self.targets.samples(),
            footprint: 1.0 / (self.spp as f32).sqrt(),
            dilate: self.dilate,
        };
        for (effects, pipeline) in &self.pipelines {
            unsafe {
                d.raw.cmd_bind_pipeline(cmd, bind, pipeline.raw);
                d.raw.cmd_bind_descriptor_sets(cmd, bind, self.layout.raw, 3, &[self.sample_set], &[]);
            }
            let include = |i: usize| self.object_effects[i] == *effects;
            if self.hull.is_none() {
                scene.record_object_draws(d, cmd, &self.layout, stages, include, push, |i| {
                    Some(self.object_sets[i])
                });
                continue;
            }
            // Compute-expanded hull: each object's triangle list, no vertex input.
            unsafe {
                d.raw.cmd_bind_descriptor_sets(cmd, bind, self.layout.raw, 0, &[scene.frame_set], &[]);
                for (i, o) in scene.objects.iter().enumerate() {
                    if !include(i) || self.hull_counts[i] == 0 {
                        continue;
                    }
                    d.raw.cmd_push_constants(cmd, self.layout.raw, stages, 0, as_bytes(&push(i)));
                    d.raw.cmd_bind_descriptor_sets(
                        cmd,
                        bind,
                        self.layout.raw,
                        1,
                        &[o.material_set, self.object_sets[i]],
                        &[],
                    );
                    d.raw.cmd_draw(cmd, self.hull_counts[i], 1, 0, 0);
                }
            }
        }
    }
}
