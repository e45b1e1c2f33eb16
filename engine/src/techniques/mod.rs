//! Techniques: each estimates the pixel integral its own way over the same world and views.
//!
//! - `auto` (the default): the effect planner ([`crate::plan`]) decides per object; with nothing to
//!   simulate it is `pinhole`, otherwise the stochastic frame with each object on the shader
//!   permutation of its effects (the still, sharp ones on the `still` permutation)
//! - `pinhole`: one pass at mid-shutter through the lens centre (no effect), MSAA 4×
//! - `accumulation`: P full-scene passes, one (x,y,u,v,t) each, averaged
//! - `stochastic`: stochastic rasterization, visibility first: S samples per pixel, each its own
//!   (x,y,u,v,t), tested per triangle inside a conservative bound into a per-sample visibility buffer,
//!   then shaded (`stochastic.rs`)
//!
//! A technique is one file (plus one shader folder) exposing a [`TechniqueInfo`], listed once in
//! [`registry`]. Its `prepare` function builds a [`FrameTechnique`] — pipelines and persistent
//! targets for one scene and settings — whose [`FrameTechnique::render`] builds the frame's graph(s)
//! ([`crate::graph`]) over the [`FrameInputs`] and runs them through the [`FrameContext`]. The frame
//! loop, barriers, timestamps and submissions live in the graph executor.
//!
//! [`Renderer`] owns what outlives a frame (the device, the command recorder) and renders a [`Scene`]
//! with a [`Technique`] into a [`RenderOutput`].

pub mod accumulation;
pub(crate) mod auto;
pub mod compute_hull;
pub mod forward;
pub mod graph_probe;
pub mod interleaved;
pub mod multipass;
pub mod oit;
pub(crate) mod pinhole;
pub mod registry;
pub(crate) mod report;
pub mod settings;
pub mod shadow_maps;
pub mod stochastic;
pub mod texture_space;

use std::any::Any;
use std::rc::Rc;
use std::str::FromStr;
use std::time::Instant;

pub use crate::sampling::PassSample;
pub use compute_hull::HullExpansion;
pub use registry::Technique;
pub use stochastic::{
    BoundChoice, Clusters, Intervals, ObjectBoundPolicy, SampleCounters, ShadingRate, StochasticOptions,
};

use crate::error::{Error, Result};
use crate::gpu::{GpuView, GpuWorld};
use crate::graph::{FrameGraph, GraphResult, ImageHandle, TransientPool};
use crate::image::LinearImage;
use crate::limits::{MAX_IMAGE_DIMENSION, MAX_SPP, MAX_STOCHASTIC_SPP};
use crate::mirror::shadow_maps::ShadowSettings;
use crate::plan::Plan;
use crate::scene::{Scene, View};
use crate::transparency::TransparencyMethod;
use crate::vk::{CommandRecorder, Device, Feature, PassTimings};

impl FromStr for Technique {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        registry::TECHNIQUES.iter().copied().find(|t| t.name() == s).ok_or_else(|| {
            Error::Unsupported(format!(
                "unknown technique `{s}`; available: {}",
                registry::TECHNIQUES.iter().map(|t| t.name()).collect::<Vec<_>>().join(", ")
            ))
        })
    }
}

/// What to render: image size, samples and seed (defaults come from the scene's `[image]`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RenderSettings {
    pub width: u32,
    pub height: u32,
    /// Samples per pixel S: passes for `accumulation`, MSAA samples × passes for `stochastic`; ignored
    /// by `pinhole` (MSAA 4×).
    pub spp: u32,
    pub seed: u64,
    /// Settings of technique `stochastic` (ignored by the others).
    pub stochastic: StochasticOptions,
    /// How `pinhole` and `accumulation` render coverage below 1 and tints (unused by an opaque
    /// scene).
    pub transparency: TransparencyMethod,
    /// The shadow maps of shadow-casting lights (unused without any).
    pub shadows: ShadowSettings,
    /// Settings of technique `interleaved` (ignored by the others).
    pub interleaved: interleaved::InterleavedOptions,
}

impl RenderSettings {
    /// `width × height`, `spp` samples per pixel, `seed`; default technique options.
    pub fn new(width: u32, height: u32, spp: u32, seed: u64) -> Self {
        RenderSettings {
            width,
            height,
            spp,
            seed,
            stochastic: StochasticOptions::default(),
            transparency: TransparencyMethod::default(),
            shadows: ShadowSettings::default(),
            interleaved: Default::default(),
        }
    }
    /// The same with these `stochastic` options.
    pub fn with_stochastic(self, stochastic: StochasticOptions) -> Self {
        RenderSettings { stochastic, ..self }
    }
    pub fn from_scene(scene: &Scene) -> Self {
        let i = scene.image;
        RenderSettings::new(i.width, i.height, i.spp, i.seed)
    }
}

/// Counters of one render.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RenderStats {
    pub passes: u32,
    pub msaa_samples: u32,
    pub triangles: usize,
    /// CPU time to record and submit, and wait for, the frame (ms), upload excluded.
    pub cpu_frame_ms: f64,
    /// CPU time the whole process spent during the frame (ms, every thread: on lavapipe the driver's
    /// rasterizer threads too), steadier than `cpu_frame_ms` on a shared machine.
    pub process_cpu_ms: f64,
    /// CPU time to upload the scene (ms).
    pub upload_ms: f64,
    /// Sample counters of an instrumented `stochastic` (or stochastic `auto`) render.
    pub counters: Option<SampleCounters>,
    /// Triangles per cluster of each object's cluster bounds (0: one bound per triangle) of a
    /// `stochastic` (or stochastic `auto`) render; empty otherwise.
    pub clusters: Vec<u32>,
    /// The effect plan of an `auto` render.
    pub plan: Option<Plan>,
    /// The method that rendered coverage below 1 and tints; `None` for an opaque scene.
    pub transparency: Option<TransparencyMethod>,
    /// The shadow maps rendered ([`crate::mirror::shadow_maps::ShadowPlan::summary`], and whether per pass);
    /// `None` without shadow-casting lights.
    pub shadows: Option<String>,
    /// The stochastic frame's coverage path (`visibility`, `mask`, ...), as the device resolved it.
    pub coverage: Option<stochastic::Coverage>,
    /// The device's pipeline statistics over the frame: an instrumented frame
    /// (`StochasticOptions::instrumented`, any technique) on a device with `pipelineStatisticsQuery`.
    pub pipeline_statistics: Option<crate::vk::PipelineStatistics>,
}

/// An image with how it was made.
#[derive(Clone, Debug)]
pub struct RenderOutput {
    pub image: LinearImage,
    /// GPU time per named pass, summed over repeats.
    pub timings: PassTimings,
    pub stats: RenderStats,
}

/// A technique as the registry lists it: everything the engine and the CLI know of it comes from
/// here — its name, the settings keys it reads, the device features it cannot run without, what it
/// can render — so adding a technique touches no `match` elsewhere.
pub struct TechniqueInfo {
    /// The name on the command line and in reports.
    pub name: &'static str,
    /// One line for `--help` and the docs.
    pub summary: &'static str,
    /// The groups of settings keys it reads besides the frame's own ([`settings::FRAME_KEYS`]), each
    /// group declared by the options that parse it ([`RenderSettings::set`]).
    pub keys: &'static [&'static [settings::OptionKey]],
    /// Device features every frame of it needs, each with what needs it. [`Renderer::prepare`]
    /// refuses a device that lacks any, naming them; features only some settings need are checked
    /// where those settings are read.
    pub required_features: &'static [(Feature, &'static str)],
    /// What it can render and how its frame can be used.
    pub capabilities: TechniqueCapabilities,
    /// Builds the technique's pipelines and targets for one scene and settings.
    pub prepare: fn(&PrepareContext<'_>) -> Result<Box<dyn FrameTechnique>>,
}

/// What a technique can render, and where its frame can go: the checks before a frame read these,
/// never a list of technique names.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TechniqueCapabilities {
    /// Coverage below 1 and tints, by stochastic transparency (docs/TRANSPARENCY.md); without it a
    /// scene with transparency is refused.
    pub transparency: bool,
    /// Besides stochastic transparency, the order-independent methods of `techniques/oit.rs`
    /// (alpha-corrected and depth-based stochastic transparency, depth peeling).
    pub transparency_methods: bool,
    /// Its frame is one graph ending in one image, so it can be recorded into a caller's command
    /// buffer (`crate::embed`).
    pub embeddable: bool,
}

impl TechniqueInfo {
    /// Every settings key it reads, the frame's first.
    pub fn option_keys(&self) -> impl Iterator<Item = &'static settings::OptionKey> {
        settings::FRAME_KEYS.iter().chain(self.keys.iter().flat_map(|g| g.iter()))
    }

    /// Whether it reads settings key `key`.
    pub fn reads_key(&self, key: &str) -> bool {
        self.option_keys().any(|k| k.key == key)
    }

    /// Every required feature `caps` lacks, all named in one error.
    pub fn check_features(&self, caps: &crate::vk::Capabilities) -> Result<()> {
        let missing: Vec<String> = self
            .required_features
            .iter()
            .filter(|(f, _)| !caps.has(*f))
            .map(|(f, why)| format!("{} ({why})", f.vulkan_name()))
            .collect();
        if missing.is_empty() {
            return Ok(());
        }
        Err(Error::MissingFeature {
            device: caps.device_name.clone(),
            feature: missing.join(", "),
            needed_by: format!("technique `{}`", self.name),
        })
    }
}

/// What a technique gets to prepare itself for a scene: the device, the uploaded world, the camera
/// view (CPU, with the scene in camera space) and the settings.
pub struct PrepareContext<'p> {
    pub device: &'p Device,
    pub scene: &'p Scene,
    pub world: &'p GpuWorld,
    pub camera: &'p View,
    pub settings: &'p RenderSettings,
}

/// What a prepared technique reads each frame.
#[derive(Clone, Copy)]
pub struct FrameInputs<'f> {
    pub world: &'f GpuWorld,
    pub camera: &'f GpuView,
}

/// One frame's result from a technique (timings are collected by the [`FrameContext`]).
pub struct TechniqueFrame {
    pub image: LinearImage,
    pub passes: u32,
    pub msaa_samples: u32,
    pub counters: Option<SampleCounters>,
    /// Stochastic rasterization: triangles per cluster of each object's cluster bounds (0: one bound
    /// per triangle); empty for other techniques.
    pub clusters: Vec<u32>,
}

/// A technique prepared for one scene and settings: it owns its pipelines and persistent targets.
/// `Any` so tests and tools can reach a concrete technique's diagnostics.
pub trait FrameTechnique: Any {
    /// Renders one frame: builds the frame's graph(s) and runs them with `frame`.
    fn render(&mut self, inputs: &FrameInputs<'_>, frame: &mut FrameContext<'_>) -> Result<TechniqueFrame>;
    /// The effect plan behind the technique's choices, if it made any (`auto`).
    fn plan(&self) -> Option<&Plan> {
        None
    }
    /// The method rendering the scene's coverage below 1 and tints, if it has any.
    fn transparency(&self) -> Option<TransparencyMethod> {
        None
    }
    /// The shadow maps it renders, if any (one line).
    fn shadows(&self) -> Option<String> {
        None
    }
    /// The stochastic frame's coverage path as the device resolved it, if it has one.
    fn coverage(&self) -> Option<stochastic::Coverage> {
        None
    }
}

/// Runs a technique's graphs: the one place frames are submitted ([`FrameGraph::execute`]), with the
/// GPU timings of every graph of the frame collected — or, for a caller embedding Shutter, recorded
/// into the caller's command buffer ([`FrameGraph::record_into`], `crate::embed`).
pub struct FrameContext<'f> {
    device: &'f Device,
    submission: Submission<'f>,
    pool: Rc<TransientPool>,
    timings: PassTimings,
    /// Show the progress of graphs that take several submissions ([`Renderer::show_progress`]).
    progress: bool,
    /// The device's pipeline statistics over the frame's graphs (an instrumented frame on a device
    /// that has them).
    statistics: Option<crate::vk::StatisticsQuery>,
}

/// Where a frame's graphs go.
enum Submission<'f> {
    /// Submitted through Shutter's recorder and waited on (every frame Shutter renders itself).
    Own(&'f mut CommandRecorder),
    /// Recorded into a caller's command buffer, which the caller submits.
    Caller(&'f mut CallerFrame),
}

/// A frame recorded for a caller (`crate::embed`): its command buffer, the image the result goes
/// to, and what the recorded commands use that must outlive them.
pub(crate) struct CallerFrame {
    pub cmd: ash::vk::CommandBuffer,
    pub target: CallerTarget,
    /// Transient resources of the recorded graphs.
    pub retained: Vec<Rc<dyn Any>>,
    /// The passes recorded, in order.
    pub passes: Vec<String>,
    /// Whether the frame's result went to the target ([`FrameContext::finish`]).
    pub finished: bool,
}

/// The caller's image a recorded frame ends in.
#[derive(Clone, Copy, Debug)]
pub(crate) struct CallerTarget {
    pub image: ash::vk::Image,
    pub desc: crate::vk::ImageDesc,
    /// The caller's last access before the frame (what the copy into it waits for).
    pub before: crate::graph::Access,
    /// The access the caller makes next (the frame ends with the barrier and layout it needs).
    pub after: crate::graph::Access,
}

impl FrameContext<'_> {
    pub fn device(&self) -> &Device {
        self.device
    }
    /// An empty graph whose transient resources come from the frame's pool.
    pub fn graph<'a>(&self) -> FrameGraph<'a> {
        FrameGraph::new(self.device, self.pool.clone())
    }
    /// Executes `graph` (recording, submitting and waiting) and adds its timings to the frame's. In
    /// a frame recorded for a caller, records it into the caller's command buffer instead (a graph
    /// that reads back is refused there) and returns no timings or images.
    pub fn run(&mut self, graph: FrameGraph<'_>) -> Result<GraphResult> {
        match &mut self.submission {
            Submission::Own(recorder) => {
                let result = graph.execute_counting(
                    recorder,
                    self.progress.then_some("render"),
                    self.statistics.as_mut(),
                )?;
                self.timings.add(&result.timings);
                Ok(result)
            }
            Submission::Caller(frame) => {
                let recorded = graph.record_into(frame.cmd)?;
                frame.retained.extend(recorded.retained);
                frame.passes.extend(recorded.passes);
                Ok(GraphResult::empty())
            }
        }
    }

    /// Runs the frame's last graph, `graph`, whose `image` (RGBA32F, `TRANSFER_SRC` usage) holds
    /// the frame's result: read back into the returned image — or, in a frame recorded for a
    /// caller, copied into the caller's image, which the frame then hands over with the access the
    /// caller asked for; the returned image is then empty (0 × 0), the result being on the GPU.
    /// A technique whose frame ends here can be embedded (`crate::embed`).
    pub fn finish(&mut self, mut graph: FrameGraph<'_>, image: ImageHandle) -> Result<LinearImage> {
        let target = match &self.submission {
            Submission::Own(_) => None,
            Submission::Caller(frame) => Some(frame.target),
        };
        let Some(target) = target else {
            let readback = graph.read_back(image)?;
            return Ok(self.run(graph)?.take_image(readback));
        };
        // SAFETY: the embedding caller vouched for the image (`embed::FrameTarget`) for as long as
        // the recorded frame executes; the wrapper destroys nothing.
        let borrowed = unsafe { crate::vk::Image::borrowed(self.device, target.image, target.desc) };
        let before = crate::graph::ResourceState::after_access(target.before, true);
        let h = graph.import_external_image("caller's image", borrowed, before);
        graph.copy_image("copy to the caller's image", image, h)?;
        if target.after != crate::graph::Access::Nothing {
            graph.pass("hand over to the caller").access(h, target.after).barrier_only();
        }
        self.run(graph)?;
        if let Submission::Caller(frame) = &mut self.submission {
            frame.finished = true;
        }
        Ok(LinearImage::new(0, 0))
    }
}

/// Renders scenes on one device.
pub struct Renderer {
    device: Device,
    recorder: CommandRecorder,
    progress: bool,
}

impl Renderer {
    pub fn new(device: Device) -> Result<Self> {
        let recorder = CommandRecorder::new(&device, "shutter frame")?;
        Ok(Renderer { device, recorder, progress: false })
    }

    /// Show the progress of frames that take more than one submission (many passes) on stderr
    /// ([`crate::progress`]); off by default, for callers that report progress of their own.
    pub fn show_progress(&mut self, on: bool) {
        self.progress = on;
    }

    pub fn device(&self) -> &Device {
        &self.device
    }

    /// Validates `settings` against the engine's and the device's limits.
    pub fn check_settings(&self, settings: &RenderSettings) -> Result<()> {
        let max_dim = MAX_IMAGE_DIMENSION.min(self.device.caps.max_image_dimension_2d);
        for (what, v) in [("width", settings.width), ("height", settings.height)] {
            if v == 0 || v > max_dim {
                return Err(Error::Limit {
                    what,
                    value: v.to_string(),
                    limit: format!("1..={max_dim} pixels"),
                });
            }
        }
        if settings.spp == 0 || settings.spp > MAX_SPP {
            return Err(Error::Limit {
                what: "spp",
                value: settings.spp.to_string(),
                limit: format!("1..={MAX_SPP}"),
            });
        }
        Ok(())
    }

    /// Renders `scene` with `technique`.
    pub fn render(
        &mut self,
        scene: &Scene,
        technique: Technique,
        settings: &RenderSettings,
    ) -> Result<RenderOutput> {
        let mut frames = self.render_frames(scene, technique, settings, 1)?;
        Ok(frames.pop().expect("one frame"))
    }

    /// Renders `scene` `frames` times with one upload and one set of pipelines (for benchmarks: the
    /// first frame pays for lazy shader compilation on some drivers, lavapipe included). Returns every
    /// frame's output; `upload_ms` is reported on each.
    pub fn render_frames(
        &mut self,
        scene: &Scene,
        technique: Technique,
        settings: &RenderSettings,
        frames: usize,
    ) -> Result<Vec<RenderOutput>> {
        let mut prepared = self.prepare(scene, technique, settings)?;
        (0..frames).map(|_| self.render_prepared(&mut prepared)).collect()
    }

    /// Uploads `scene` and builds `technique`'s pipelines and targets (and, for `auto`, its plan):
    /// everything a frame needs, so several configurations can be rendered interleaved frame by frame
    /// ([`Renderer::render_prepared`]) — how `shutter bench` measures ratios in one run.
    pub fn prepare(
        &mut self,
        scene: &Scene,
        technique: Technique,
        settings: &RenderSettings,
    ) -> Result<PreparedFrame> {
        technique.info().check_features(&self.device.caps)?;
        check_transparency_supported(scene, technique)?;
        check_transparency_method(scene, technique, settings.transparency)?;
        scene.validate()?;
        let (bytes, detail) = memory_estimate(scene, technique, settings);
        crate::limits::check_memory(&format!("`{}`", technique.name()), bytes, &detail)?;
        self.prepare_with(scene, settings, technique.info().prepare)
    }

    /// [`Renderer::prepare`] with any technique: `prepare` builds it from the uploaded world and
    /// camera (how a technique outside the registry, or a test's, is rendered).
    pub fn prepare_with(
        &mut self,
        scene: &Scene,
        settings: &RenderSettings,
        prepare: impl FnOnce(&PrepareContext<'_>) -> Result<Box<dyn FrameTechnique>>,
    ) -> Result<PreparedFrame> {
        self.check_settings(settings)?;
        scene.validate()?;
        let t0 = Instant::now();
        let world = GpuWorld::upload(&self.device, &mut self.recorder, scene)?;
        // The one camera-space build of the frame: the plan, the GPU view and the techniques share it.
        let camera = View::camera(scene, settings.width, settings.height);
        let camera_gpu = GpuView::new(&self.device, &world, &camera)?;
        let upload_ms = t0.elapsed().as_secs_f64() * 1e3;
        let technique = prepare(&PrepareContext {
            device: &self.device,
            scene,
            world: &world,
            camera: &camera,
            settings,
        })?;
        Ok(PreparedFrame {
            technique,
            pool: Rc::new(TransientPool::default()),
            camera: camera_gpu,
            world,
            triangles: scene.triangle_count(),
            upload_ms,
            statistics: settings.stochastic.instrumented.then(|| {
                use crate::vk::MeshStatistics;
                let caps = &self.device.caps;
                let expansion = settings.stochastic.expansion;
                let mesh = match (expansion.is_mesh(), caps.mesh_shader_queries) {
                    (false, _) => MeshStatistics::NoMeshDraws,
                    (true, false) => MeshStatistics::Uncounted,
                    (true, true) => MeshStatistics::Counted { task: expansion == HullExpansion::MeshTask },
                };
                crate::vk::statistic_flags(caps.geometry_shader, mesh)
            }),
        })
    }

    /// Runs `f` with the prepared technique, its frame inputs and a frame context — for work beyond
    /// one [`FrameTechnique::render`] (a technique's own extra graphs, tests of the graph).
    pub fn run_with<R>(
        &mut self,
        prepared: &mut PreparedFrame,
        f: impl FnOnce(&mut dyn FrameTechnique, &FrameInputs<'_>, &mut FrameContext<'_>) -> Result<R>,
    ) -> Result<R> {
        let statistics = match prepared.statistics {
            Some(flags) if self.device.caps.pipeline_statistics => {
                Some(crate::vk::StatisticsQuery::new(&self.device, flags)?)
            }
            _ => None,
        };
        let mut frame = FrameContext {
            device: &self.device,
            submission: Submission::Own(&mut self.recorder),
            pool: prepared.pool.clone(),
            timings: PassTimings::default(),
            progress: self.progress,
            statistics,
        };
        let inputs = FrameInputs { world: &prepared.world, camera: &prepared.camera };
        let out = f(prepared.technique.as_mut(), &inputs, &mut frame)?;
        self.device.check_validation()?;
        Ok(out)
    }

    /// Renders one frame of a prepared scene and technique.
    pub fn render_prepared(&mut self, prepared: &mut PreparedFrame) -> Result<RenderOutput> {
        let t1 = Instant::now();
        let p1 = cpu_time::ProcessTime::now();
        let (out, timings, pipeline_statistics) = self.run_with(prepared, |technique, inputs, frame| {
            let out = technique.render(inputs, frame)?;
            Ok((out, std::mem::take(&mut frame.timings), frame.statistics.as_ref().map(|q| q.total())))
        })?;
        let cpu_frame_ms = t1.elapsed().as_secs_f64() * 1e3;
        let process_cpu_ms = p1.elapsed().as_secs_f64() * 1e3;
        Ok(RenderOutput {
            image: out.image,
            timings,
            stats: RenderStats {
                passes: out.passes,
                msaa_samples: out.msaa_samples,
                triangles: prepared.triangles,
                cpu_frame_ms,
                process_cpu_ms,
                upload_ms: prepared.upload_ms,
                counters: out.counters,
                clusters: out.clusters,
                plan: prepared.technique.plan().cloned(),
                transparency: prepared.technique.transparency(),
                shadows: prepared.technique.shadows(),
                coverage: prepared.technique.coverage(),
                pipeline_statistics,
            },
        })
    }
}

/// Host bytes per triangle of a rasterizing technique (`pinhole`, `accumulation`, `interleaved`):
/// its upload and camera-space copies. With [`STOCHASTIC_BYTES_PER_TRIANGLE`] from the peak RSS of
/// `shutter render` on lavapipe (where device memory is host memory) of a 1,046,528-triangle sphere at
/// 32×18, S = 4: `pinhole` 231 MB above the loaded scene, `stochastic` 896 MB (docs/hard-cases/input.md).
const RASTER_BYTES_PER_TRIANGLE: u64 = 250;
/// Host bytes per triangle of the stochastic frame (`stochastic`, `auto`): bounds, clusters and
/// camera-space copies per motion key.
const STOCHASTIC_BYTES_PER_TRIANGLE: u64 = 900;
/// Bytes per pixel of targets and readbacks (RGBA32F accumulation, resolve, readback, MSAA depth).
const BYTES_PER_PIXEL: u64 = 64;

/// What rendering `scene` with `technique` will allocate (host memory, and device memory where the
/// device is the CPU), bytes, and how the figure arose — checked before any upload
/// ([`crate::limits::check_memory`]), so a scene too big is refused with the figure. The stochastic
/// frame adds its sample tile (64 × 64 × S × 20 bytes).
pub fn memory_estimate(scene: &Scene, technique: Technique, settings: &RenderSettings) -> (u64, String) {
    let triangles = scene.triangle_count() as u64;
    let stochastic = technique != Technique::PINHOLE
        && technique != Technique::ACCUMULATION
        && technique != Technique::INTERLEAVED;
    let per_triangle = if stochastic { STOCHASTIC_BYTES_PER_TRIANGLE } else { RASTER_BYTES_PER_TRIANGLE };
    let pixels = settings.width as u64 * settings.height as u64;
    let tile = if stochastic { 64 * 64 * settings.spp.min(MAX_STOCHASTIC_SPP) as u64 * 20 } else { 0 };
    let textures: u64 = scene
        .objects
        .iter()
        .filter_map(|o| o.material.texture.as_ref())
        .map(|t| t.width as u64 * t.height as u64 * 32)
        .sum();
    let meshes: u64 = scene.objects.iter().map(|o| o.mesh.heap_bytes()).sum();
    let bytes = meshes
        .saturating_add(triangles.saturating_mul(per_triangle))
        .saturating_add(pixels.saturating_mul(BYTES_PER_PIXEL))
        .saturating_add(tile)
        .saturating_add(textures);
    (bytes, format!("{triangles} triangles, {pixels} pixels, S = {}", settings.spp))
}

/// A scene on the device with one technique's pipelines and targets ([`Renderer::prepare`]).
pub struct PreparedFrame {
    // Dropped in this order: the technique's descriptor sets and transient targets before the views
    // and the world whose buffers they name.
    technique: Box<dyn FrameTechnique>,
    pool: Rc<TransientPool>,
    camera: GpuView,
    world: GpuWorld,
    triangles: usize,
    upload_ms: f64,
    /// The pipeline statistics an instrumented frame counts ([`crate::vk::statistic_flags`]).
    statistics: Option<ash::vk::QueryPipelineStatisticFlags>,
}

impl PreparedFrame {
    /// Records one frame into `frame`'s command buffer, the result into its target (`crate::embed`
    /// drives it and holds what it returns until the caller retires the frame). Refused for a
    /// technique whose frame does not end in [`FrameContext::finish`].
    pub(crate) fn record_for_caller(&mut self, device: &Device, frame: &mut CallerFrame) -> Result<()> {
        let mut context = FrameContext {
            device,
            submission: Submission::Caller(frame),
            pool: self.pool.clone(),
            timings: PassTimings::default(),
            progress: false,
            statistics: None,
        };
        let inputs = FrameInputs { world: &self.world, camera: &self.camera };
        self.technique.render(&inputs, &mut context)?;
        drop(context);
        if !frame.finished {
            return Err(Error::Unsupported(
                "this technique's frame does not end in one image Shutter can copy into a caller's image \
                 (FrameContext::finish); embed technique `stochastic`"
                    .into(),
            ));
        }
        Ok(())
    }

    /// The prepared technique (downcast with `as &dyn Any` to reach a concrete one's diagnostics).
    pub fn technique(&self) -> &dyn FrameTechnique {
        self.technique.as_ref()
    }
    /// The concrete technique, if it is a `T`.
    pub fn technique_as<T: FrameTechnique>(&self) -> Option<&T> {
        let any: &dyn Any = self.technique.as_ref();
        any.downcast_ref::<T>()
    }
}

/// Which path Shutter takes on a device for one hardware feature (`shutter probe`).
#[derive(Clone, Debug, PartialEq, Eq, serde::Serialize)]
pub struct FeaturePath {
    pub feature: String,
    pub available: bool,
    pub path: String,
}

/// The path taken for each feature the techniques can use, and what forces the alternative.
pub fn feature_paths(caps: &crate::vk::Capabilities) -> Vec<FeaturePath> {
    let counts = &caps.framebuffer_sample_counts;
    let stochastic_coverage = stochastic::Coverage::Device.resolve_for(caps, false);
    let f = |feature: &str, available: bool, path: String| FeaturePath {
        feature: feature.into(),
        available,
        path,
    };
    vec![
        f(
            "geometryShader",
            caps.geometry_shader,
            if caps.geometry_shader {
                "stochastic/auto expand each triangle's bound in a geometry shader (default; --hull compute: \
                 a compute pass expands them once per frame)"
                    .into()
            } else {
                "no geometry shader: auto takes the compute-expanded hull; stochastic needs --hull compute".into()
            },
        ),
        f(
            "MSAA",
            counts.len() > 1,
            format!(
                "counts {counts:?}; pinhole and accumulation use {}x; stochastic's mask coverage path \
                 tests its samples on an MSAA target of the largest count dividing S (the visibility path \
                 uses none)",
                caps.msaa_samples(pinhole::PINHOLE_MSAA)
            ),
        ),
        f("stochastic coverage", stochastic_coverage.is_ok(), match &stochastic_coverage {
            Ok((c, why)) => format!("`--set coverage=device` (the default) takes `{}`: {why}", c.name()),
            Err(e) => format!("none: {e}"),
        }),
        f(
            "sampleRateShading",
            caps.sample_rate_shading,
            if caps.sample_rate_shading {
                "stochastic `coverage=mask`: the inside test runs once per MSAA sample (exact)".into()
            } else {
                "stochastic's mask path tests once per fragment (`mask-per-fragment`: nearest sample's depth)"
                    .into()
            },
        ),
        f("stochastic bound", true, {
            let (kind, why) = stochastic::device_bound(caps);
            format!("`--bound device` (the default) draws `{}`: {why}", kind.name())
        }),
        f(
            "fragmentStoresAndAtomics",
            caps.fragment_stores_and_atomics,
            if caps.fragment_stores_and_atomics {
                "stochastic coverage writes its visibility buffer; sample counters (--instrumented)".into()
            } else {
                "stochastic takes the mask coverage path (no counters, no tints)".into()
            },
        ),
        f(
            "shaderBufferInt64Atomics",
            caps.buffer_int64_atomics,
            if caps.buffer_int64_atomics {
                "stochastic visibility: one 64-bit atomicMax of (depth, object, triangle) per hit sample".into()
            } else {
                "stochastic takes the mask coverage path (MSAA depth test; decoupled rates refused)".into()
            },
        ),
        f(
            "VK_EXT_mesh_shader",
            caps.mesh_shader,
            if caps.mesh_shader {
                format!(
                    "stochastic `--hull mesh`: a mesh shader bounds each triangle (bit-identical to gs; up to {} \
                     triangles per object)",
                    caps.max_mesh_work_group_total_count
                )
            } else {
                "absent: stochastic `--hull mesh` is refused (gs or compute)".into()
            },
        ),
        f(
            "VK_EXT_mesh_shader taskShader",
            caps.task_shader,
            if caps.task_shader {
                "stochastic `--hull mesh-task`: a task shader culls each cluster's off-image and back-facing \
                 triangles ahead of the mesh shader (bit-identical to gs)"
                    .into()
            } else {
                "absent: stochastic `--hull mesh-task` is refused (mesh, gs or compute)".into()
            },
        ),
        f(
            "standard sample locations",
            caps.standard_sample_locations,
            format!(
                "pinhole/accumulation MSAA at the standard locations; stochastic's shader dilation of its bounds \
                 is {:.4} px (one sample at the pixel centre; {})",
                crate::mirror::bounds::dilation_px(1, caps.standard_sample_locations),
                if caps.standard_sample_locations { "from the standard locations" } else { "half-pixel box: locations unknown" }
            ),
        ),
        f("VK_EXT_conservative_rasterization", caps.conservative_rasterization, {
            use crate::mirror::conservative::{choose, Need};
            let over = caps.overestimation();
            let bounds = choose(
                Need::PixelsTouched { raster_samples: 1, standard_sample_locations: caps.standard_sample_locations },
                over,
            );
            let hull = choose(Need::CentresWithin { h: texture_space::BILINEAR_HULL_TEXELS }, over);
            format!(
                "{}: stochastic bounds use {}; texture-space pass 1's outer hull uses {}",
                match over {
                    Some(o) => format!("overestimation {} px", o.primitive_px),
                    None if caps.disabled.iter().any(|d| d == "conservative-rasterization") => "disabled".into(),
                    None => "absent".into(),
                },
                bounds.describe(),
                hull.describe()
            )
        }),
        f(
            "timestamps",
            caps.timestamps,
            if caps.timestamps {
                format!("GPU pass times from timestamp queries ({} ns/tick)", caps.timestamp_period_ns)
            } else {
                "no GPU timings (reported as 0)".into()
            },
        ),
        f(
            "pipelineStatisticsQuery",
            caps.pipeline_statistics,
            if caps.pipeline_statistics {
                "instrumented frames (--instrumented, bench/matrix --counters) report the device's \
                 pipeline statistics beside Shutter's counters"
                    .into()
            } else {
                "Shutter's own counters only".into()
            },
        ),
    ]
}

/// Every shader interface the techniques declare (`SHADER_INTERFACES` beside the code that builds each
/// pipeline): what each stage file under `shaders-glsl/` expects of its pipeline layout. The
/// reflection test (`engine/src/gpu/layout_tests.rs`) checks the compiled shaders against them.
pub fn shader_interfaces() -> impl Iterator<Item = &'static crate::gpu::layout::ShaderInterface> {
    [
        forward::SHADER_INTERFACES,
        stochastic::SHADER_INTERFACES,
        multipass::SHADER_INTERFACES,
        graph_probe::SHADER_INTERFACES,
        shadow_maps::SHADER_INTERFACES,
        oit::SHADER_INTERFACES,
        texture_space::SHADER_INTERFACES,
        interleaved::SHADER_INTERFACES,
    ]
    .into_iter()
    .flatten()
}

/// Techniques that render coverage below 1 and tints (stochastic transparency, `--transparency`).
pub const TRANSPARENCY_TECHNIQUES: &str = "pinhole, accumulation, stochastic and auto";

/// Refuses coverage below 1 for `technique` unless it renders it: `pinhole`, `accumulation`,
/// `stochastic` (coverage in its coverage pass, tints in its tint pass) and `auto` do.
pub fn check_transparency_supported(scene: &Scene, technique: Technique) -> Result<()> {
    if technique.info().capabilities.transparency {
        return Ok(());
    }
    check_opaque(scene, &format!("technique `{technique}`"))
}

/// Refuses a transparency method `technique` does not have, for a scene with transparency: depth-based
/// stochastic transparency and depth peeling (`techniques/oit.rs`) are frames of `pinhole` and
/// `accumulation` only; `stochastic` and `auto` render stochastic transparency.
pub fn check_transparency_method(
    scene: &Scene,
    technique: Technique,
    method: TransparencyMethod,
) -> Result<()> {
    let has_transparency = forward::has_transparency(scene);
    if !has_transparency
        || method == TransparencyMethod::Stochastic
        || technique.info().capabilities.transparency_methods
    {
        return Ok(());
    }
    let with_methods: Vec<&str> = registry::TECHNIQUES
        .iter()
        .filter(|t| t.info().capabilities.transparency_methods)
        .map(|t| t.name())
        .collect();
    Err(Error::Unsupported(format!(
        "technique `{technique}` renders transparency by stochastic transparency only (--transparency \
         stochastic), not `{method}`: alpha-corrected and depth-based stochastic transparency and depth peeling \
         are rendered by {}",
        with_methods.join(" and ")
    )))
}

/// Every object opaque (coverage 1, no texture alpha), or an error saying that `who` renders opaque
/// surfaces only and which techniques render transparency.
pub fn check_opaque(scene: &Scene, who: &str) -> Result<()> {
    for o in &scene.objects {
        let m = &o.material;
        let what = if m.alpha < 1.0 {
            let tint =
                if m.tint != glam::Vec3::ONE { format!(" and tint {}", m.tint) } else { String::new() };
            format!("has alpha {} < 1{tint}", m.alpha)
        } else if m.alpha_from_texture {
            "takes alpha from its texture (alpha_from_texture)".to_string()
        } else {
            continue;
        };
        return Err(Error::Unsupported(format!(
            "object `{}` {what}: {who} renders opaque surfaces only; stochastic transparency \
             (--transparency stochastic) renders it in {TRANSPARENCY_TECHNIQUES} (the CPU reference \
             renders it too)",
            o.name,
        )));
    }
    Ok(())
}

#[cfg(test)]
mod opaque_check_tests {
    use glam::Vec3;

    use super::check_opaque;
    use crate::scene::builtin::builtin_scene;
    use crate::scene::Light;

    #[test]
    fn transparency_is_refused_with_the_reason() {
        let base = builtin_scene("static").expect("built-in").expect("parses");
        let check = |s: &crate::scene::Scene| check_opaque(s, "this technique");
        assert!(check(&base).is_ok());
        let refused = |edit: &dyn Fn(&mut crate::scene::Scene)| {
            let mut s = base.clone();
            edit(&mut s);
            check(&s).map(|_| ()).unwrap_err().to_string()
        };
        let e = refused(&|s| s.objects[0].material.alpha = 0.5);
        assert!(e.contains("alpha 0.5"), "{e}");
        let e = refused(&|s| {
            s.objects[0].material.alpha = 0.5;
            s.objects[0].material.tint = Vec3::new(1.0, 0.5, 0.5);
        });
        assert!(e.contains("tint"), "{e}");
        let e = refused(&|s| s.objects[0].material.alpha_from_texture = true);
        assert!(e.contains("alpha_from_texture"), "{e}");
        assert!(
            e.contains("pinhole, accumulation, stochastic and auto") && e.contains("CPU reference"),
            "{e}"
        );
        // An opaque tinted surface (tint irrelevant) and lights, with shadows or not, are fine.
        let mut ok = base.clone();
        ok.objects[0].material.tint = Vec3::new(0.5, 0.5, 1.0);
        ok.lights.push(Light::Spot {
            position: Vec3::Y,
            direction: -Vec3::Y,
            inner_deg: 10.0,
            outer_deg: 20.0,
            color: Vec3::ONE,
            shadows: true,
        });
        assert!(check(&ok).is_ok());
    }
}
