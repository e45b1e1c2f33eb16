//! Techniques: each estimates the pixel integral its own way from the same [`GpuScene`].
//!
//! - `auto` (the default): the effect planner ([`crate::plan`]) decides per object; with nothing to
//!   simulate it is `pinhole`, otherwise `stochastic` with each object on the shader permutation of
//!   its effects and the still, sharp objects on the plain pipeline in the same targets
//! - `pinhole`: one pass at mid-shutter through the lens centre (no effect), MSAA 4×
//! - `accumulation`: P full-scene passes, one (x,y,u,v,t) each, averaged
//! - `stochastic`: stochastic rasterization, S = M MSAA samples × P passes per pixel, each sample its
//!   own (x,y,u,v,t), tested per triangle inside a conservative bound (`stochastic.rs`)
//!
//! [`Renderer`] owns the device-side state that outlives a frame (the command recorder) and renders a
//! [`Scene`] with a [`Technique`] into a [`RenderOutput`].

pub mod accumulation;
pub mod compute_hull;
pub mod forward;
pub mod gpu_scene;
pub mod pinhole;
pub mod stochastic;
pub mod targets;

use std::str::FromStr;
use std::time::Instant;

pub use compute_hull::HullExpansion;
pub use forward::PassSample;
pub use gpu_scene::GpuScene;
pub use stochastic::{SampleCounters, ShadingRate, StochasticOptions};

use crate::error::{Error, Result};
use crate::image::LinearImage;
use crate::plan::{Effects, Plan};
use crate::scene::file::{MAX_IMAGE_DIMENSION, MAX_SPP};
use crate::scene::Scene;
use crate::vk::{CommandRecorder, Device, PassTimings};

/// A way of estimating the pixel integral on the GPU.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Technique {
    Auto,
    Pinhole,
    Accumulation,
    Stochastic,
}

impl Technique {
    pub const ALL: &'static [Technique] =
        &[Technique::Auto, Technique::Pinhole, Technique::Accumulation, Technique::Stochastic];
    pub fn name(&self) -> &'static str {
        match self {
            Technique::Auto => "auto",
            Technique::Pinhole => "pinhole",
            Technique::Accumulation => "accumulation",
            Technique::Stochastic => "stochastic",
        }
    }
}

impl FromStr for Technique {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        Technique::ALL.iter().copied().find(|t| t.name() == s).ok_or_else(|| {
            Error::Unsupported(format!(
                "unknown technique `{s}`; available: {}",
                Technique::ALL.iter().map(|t| t.name()).collect::<Vec<_>>().join(", ")
            ))
        })
    }
}

/// What to render: image size, samples and seed (defaults come from the scene's `[image]`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RenderSettings {
    pub width: u32,
    pub height: u32,
    /// Samples per pixel S: passes for `accumulation`, MSAA samples × passes for `stochastic`; ignored
    /// by `pinhole` (MSAA 4×).
    pub spp: u32,
    pub seed: u64,
    /// Settings of technique `stochastic` (ignored by the others).
    pub stochastic: StochasticOptions,
}

impl RenderSettings {
    /// `width × height`, `spp` samples per pixel, `seed`; default technique options.
    pub fn new(width: u32, height: u32, spp: u32, seed: u64) -> Self {
        RenderSettings { width, height, spp, seed, stochastic: StochasticOptions::default() }
    }
    /// The same with these `stochastic` options.
    pub fn with_stochastic(self, stochastic: StochasticOptions) -> Self {
        RenderSettings { stochastic, ..self }
    }
    pub fn from_scene(scene: &Scene) -> Self {
        let i = scene.image;
        RenderSettings {
            width: i.width,
            height: i.height,
            spp: i.spp,
            seed: i.seed,
            stochastic: StochasticOptions::default(),
        }
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
    /// CPU time to upload the scene (ms).
    pub upload_ms: f64,
    /// Sample counters of an instrumented `stochastic` (or stochastic `auto`) render.
    pub counters: Option<SampleCounters>,
    /// The effect plan of an `auto` render.
    pub plan: Option<Plan>,
}

/// An image with how it was made.
#[derive(Clone, Debug)]
pub struct RenderOutput {
    pub image: LinearImage,
    /// GPU time per named pass, summed over repeats.
    pub timings: PassTimings,
    pub stats: RenderStats,
}

/// Renders scenes on one device.
pub struct Renderer {
    device: Device,
    recorder: CommandRecorder,
}

impl Renderer {
    pub fn new(device: Device) -> Result<Self> {
        let recorder = CommandRecorder::new(&device, "shutter frame")?;
        Ok(Renderer { device, recorder })
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
        self.check_settings(settings)?;
        if let Some(o) = scene.objects.iter().find(|o| o.material.alpha < 1.0) {
            return Err(Error::Unsupported(format!(
                "object `{}` has alpha {} < 1: technique `{}` renders opaque surfaces only (the CPU reference \
                 renders alpha as stochastic coverage)",
                o.name,
                o.material.alpha,
                technique.name()
            )));
        }
        let t0 = Instant::now();
        let gpu_scene =
            GpuScene::upload(&self.device, &mut self.recorder, scene, settings.width, settings.height)?;
        let upload_ms = t0.elapsed().as_secs_f64() * 1e3;
        let c = &scene.camera;
        let plan = (technique == Technique::Auto).then(|| Plan::new(scene, settings.width, settings.height));
        // `auto` takes the compute-expanded hull where there is no geometry shader.
        let mut options = settings.stochastic;
        if technique == Technique::Auto && !self.device.caps.geometry_shader {
            options.expansion = HullExpansion::Compute;
        }
        let stochastic = |effects: &[Effects]| -> Result<Frame> {
            Ok(Frame::Stochastic(Box::new(stochastic::StochasticRenderer::new(
                &self.device,
                &gpu_scene,
                settings.spp,
                settings.seed,
                c.aperture,
                c.shutter,
                options,
                Default::default(),
                effects,
            )?)))
        };
        let pinhole = || -> Result<Frame> {
            let msaa = self.device.caps.msaa_samples(pinhole::PINHOLE_MSAA);
            Ok(Frame::Forward(
                Box::new(forward::ForwardRenderer::new(&self.device, &gpu_scene, msaa)?),
                pinhole::pinhole_passes(),
            ))
        };
        let frame = match technique {
            Technique::Auto => match &plan {
                Some(p) if p.needs_stochastic() => stochastic(&p.effects())?,
                _ => pinhole()?,
            },
            Technique::Pinhole => pinhole()?,
            Technique::Stochastic => stochastic(&vec![Effects::Both; scene.objects.len()])?,
            Technique::Accumulation => Frame::Forward(
                Box::new(forward::ForwardRenderer::new(&self.device, &gpu_scene, 1)?),
                accumulation::accumulation_passes(settings.spp, settings.seed, c.aperture, c.shutter),
            ),
        };
        Ok(PreparedFrame { frame, gpu_scene, triangles: scene.triangle_count(), upload_ms, plan })
    }

    /// Renders one frame of a prepared scene and technique.
    pub fn render_prepared(&mut self, prepared: &mut PreparedFrame) -> Result<RenderOutput> {
        let t1 = Instant::now();
        let gpu_scene = &prepared.gpu_scene;
        let (image, timings, passes, msaa, counters) = match &mut prepared.frame {
            Frame::Forward(fr, passes) => {
                let (image, timings) = fr.render(&self.device, &mut self.recorder, gpu_scene, passes)?;
                (image, timings, passes.len() as u32, fr.samples(), None)
            }
            Frame::Stochastic(sr) => {
                let (msaa, passes) = sr.msaa_and_passes();
                let (image, timings, counters) = sr.render(&self.device, &mut self.recorder, gpu_scene)?;
                (image, timings, passes, msaa, counters)
            }
        };
        let cpu_frame_ms = t1.elapsed().as_secs_f64() * 1e3;
        self.device.check_validation()?;
        Ok(RenderOutput {
            image,
            timings,
            stats: RenderStats {
                passes,
                msaa_samples: msaa,
                triangles: prepared.triangles,
                cpu_frame_ms,
                upload_ms: prepared.upload_ms,
                counters,
                plan: prepared.plan.clone(),
            },
        })
    }
}

enum Frame {
    Forward(Box<forward::ForwardRenderer>, Vec<PassSample>),
    Stochastic(Box<stochastic::StochasticRenderer>),
}

/// A scene on the device with one technique's pipelines and targets ([`Renderer::prepare`]).
pub struct PreparedFrame {
    // Declared before the scene: the renderers' descriptor sets refer to its buffers.
    frame: Frame,
    gpu_scene: GpuScene,
    triangles: usize,
    upload_ms: f64,
    plan: Option<Plan>,
}

/// Which path Shutter takes on a device for one hardware feature (`shutter probe`).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct FeaturePath {
    pub feature: String,
    pub available: bool,
    pub path: String,
}

/// The path taken for each feature the techniques can use, and what forces the alternative.
pub fn feature_paths(caps: &crate::vk::Capabilities) -> Vec<FeaturePath> {
    let counts = &caps.framebuffer_sample_counts;
    let f = |feature: &str, available: bool, path: String| FeaturePath {
        feature: feature.into(),
        available,
        path,
    };
    let split = |s: u32| {
        let (m, p) = stochastic::split_samples(s, counts);
        format!("S={s} → {p} pass(es) × {m}x")
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
                "counts {counts:?}; stochastic splits S into passes of the largest count dividing S ({}, {}); \
                 force with --msaa M; pinhole uses {}x",
                split(16),
                split(64),
                caps.msaa_samples(pinhole::PINHOLE_MSAA)
            ),
        ),
        f(
            "sampleRateShading",
            caps.sample_rate_shading,
            if caps.sample_rate_shading {
                "default per-pixel shading (one invocation loops over the pass' samples and writes the mask); \
                 --shading per-sample runs one invocation per sample"
                    .into()
            } else {
                "per-pixel shading only (mask loop); --shading per-sample is refused".into()
            },
        ),
        f(
            "fragmentStoresAndAtomics",
            caps.fragment_stores_and_atomics,
            if caps.fragment_stores_and_atomics {
                "sample counters available (--instrumented)".into()
            } else {
                "no sample counters".into()
            },
        ),
        f(
            "standard sample locations",
            caps.standard_sample_locations,
            format!(
                "bound dilation {:.4} px at 4x ({})",
                crate::bounds::dilation_px(4, caps.standard_sample_locations),
                if caps.standard_sample_locations { "from the standard locations" } else { "half-pixel box: locations unknown" }
            ),
        ),
        f(
            "VK_EXT_conservative_rasterization",
            caps.conservative_rasterization,
            if caps.conservative_rasterization {
                "present but unused: the bounds are dilated by the exact pixel box in the shader (an \
                 extension path is not implemented: no device with the extension was available to test it)"
                    .into()
            } else {
                "absent: bounds are dilated by the exact pixel box in the shader".into()
            },
        ),
        f(
            "timestamps",
            caps.timestamps,
            if caps.timestamps {
                format!("GPU pass times from timestamp queries ({} ns/tick)", caps.timestamp_period_ns)
            } else {
                "no GPU timings (reported as 0)".into()
            },
        ),
    ]
}
