//! Embedding Shutter in an engine: Shutter on the engine's Vulkan device, its frames recorded into
//! the engine's command buffers and ending in the engine's image, so the engine submits them with
//! its own work and composites the result without a readback.
//!
//! 1. **The device.** [`ExternalDevice`] lists the engine's handles (entry, instance, physical
//!    device, device, queue and its family) and what it enabled; `unsafe`
//!    [`ExternalDevice::into_device`] checks what Shutter needs against what was enabled and makes
//!    a [`Device`] that borrows the handles ([`Ownership::Borrowed`]: Shutter destroys nothing) or
//!    takes them ([`Ownership::Owned`]).
//! 2. **The scene.** [`EmbeddedScene::prepare`] uploads a [`Scene`] and builds a technique's
//!    pipelines and targets through a [`Renderer`] on that device. This is the one place Shutter
//!    submits to the engine's queue (and waits): the uploads.
//! 3. **Frames.** `unsafe` [`EmbeddedScene::record`] records one frame into the engine's command
//!    buffer, ending with a copy into the engine's image ([`FrameTarget`], with the access the
//!    engine left it in and the one it makes next), and returns a [`FrameToken`]. Nothing is
//!    submitted and nothing waited on; no pass reads back. The engine submits the command buffer;
//!    once its fence says the work is done it hands the token back ([`EmbeddedScene::retire`]),
//!    which is what lets Shutter reuse what the frame used. One frame of a scene is in flight at a
//!    time: recording the next before retiring the last is refused (prepare a second scene for a
//!    second frame in flight).
//!
//! Reading back stays available on the same device: [`Renderer::render`] renders and returns the
//! image on the CPU as for Shutter's own device. `docs/EMBEDDING.md` walks through a whole program
//! (the `embed_existing_device` sample).
//!
//! Frames that can be recorded this way: technique `stochastic` (its frame is one graph ending in
//! one image, [`crate::techniques::FrameContext::finish`]), with the geometry-shader hull (the
//! compute hull reads its counts back between two graphs) and not instrumented (its counters are
//! read on the CPU).

use std::any::Any;
use std::rc::Rc;
use std::sync::atomic::{AtomicU64, Ordering};

use ash::vk;

use crate::error::{Error, Result};
use crate::graph::Access;
use crate::scene::Scene;
use crate::techniques::{
    CallerFrame, CallerTarget, HullExpansion, PreparedFrame, RenderSettings, Renderer, Technique,
};
use crate::vk::{Device, DeviceShared, ImageDesc};
pub use crate::vk::{ExternalDevice, Ownership};

impl ExternalDevice {
    /// Shutter on this device: [`DeviceShared::from_external`], whose `# Safety` section is this
    /// function's contract.
    ///
    /// # Safety
    /// See [`DeviceShared::from_external`]: the handles are valid and related as described, what is
    /// listed as enabled was enabled, borrowed handles outlive every Shutter object made on the
    /// device, and the caller does not submit to the queue concurrently with Shutter's uploads.
    pub unsafe fn into_device(self) -> Result<Device> {
        // SAFETY: the caller's contract, passed on.
        unsafe { DeviceShared::from_external(self) }
    }
}

/// The techniques whose frames [`EmbeddedScene::record`] can record (one graph ending in one image):
/// those whose [`crate::techniques::TechniqueCapabilities::embeddable`] says so.
pub fn embeddable_techniques() -> impl Iterator<Item = Technique> {
    crate::techniques::registry::TECHNIQUES.iter().copied().filter(|t| t.info().capabilities.embeddable)
}

/// The engine's image a recorded frame ends in: the frame's linear RGBA result is copied into it
/// (a plain copy into `R32G32B32A32_SFLOAT`; a blit, which converts, into any other colour format
/// whose optimal tiling can be a blit destination, e.g. `R8G8B8A8_SRGB`).
#[derive(Clone, Copy, Debug)]
pub struct FrameTarget {
    /// A 2D colour image of the device, one mip level, one layer, optimal tiling, with
    /// `TRANSFER_DST` usage.
    pub image: vk::Image,
    pub format: vk::Format,
    /// Its size: the scene's render size ([`RenderSettings`]).
    pub width: u32,
    pub height: u32,
    /// The engine's last access to the image before the frame, in submission order on the queue
    /// (and its layout, vk-sync's for that access): what the copy into it waits for. `Nothing` when
    /// it has not been used (or its contents may go): layout `UNDEFINED`.
    pub before: Access,
    /// The access the engine makes next: the frame ends with the barrier to it and vk-sync's
    /// layout for it (`FragmentShaderReadSampledImageOrUniformTexelBuffer`: shader read-only, to
    /// composite; `TransferRead`: to copy it out; `Present`; `General`). `Nothing`: left as the copy
    /// wrote it (`TRANSFER_DST_OPTIMAL`, the engine places its own barrier).
    pub after: Access,
}

/// A frame recorded by [`EmbeddedScene::record`], until the engine says it has executed
/// ([`EmbeddedScene::retire`]).
#[derive(Debug)]
#[must_use = "hand the token back to EmbeddedScene::retire once the frame's submission has completed"]
pub struct FrameToken {
    scene: u64,
    frame: u64,
    passes: Vec<String>,
}

impl FrameToken {
    /// The frame's number in its scene, from 0.
    pub fn frame(&self) -> u64 {
        self.frame
    }
    /// The passes recorded, in order (a repeated pass once per iteration): the frame's graph as the
    /// command buffer holds it — no `readback` among them.
    pub fn passes(&self) -> &[String] {
        &self.passes
    }
}

/// A scene prepared on a device for frames recorded into the caller's command buffers.
pub struct EmbeddedScene {
    id: u64,
    device: Device,
    prepared: Option<PreparedFrame>,
    size: (u32, u32),
    recorded: u64,
    in_flight: Option<InFlight>,
}

/// What a recorded frame's commands use beyond the scene's own resources.
struct InFlight {
    frame: u64,
    retained: Vec<Rc<dyn Any>>,
}

impl EmbeddedScene {
    /// Uploads `scene` and builds `technique`'s pipelines and targets on `renderer`'s device, as
    /// [`Renderer::prepare`] does (the same checks: [`Scene::validate`], limits, memory), and
    /// refuses a technique or setting whose frame cannot be recorded for a caller
    /// ([`embeddable_techniques`]). Submits the uploads to the device's queue and waits for them.
    pub fn prepare(
        renderer: &mut Renderer,
        scene: &Scene,
        technique: Technique,
        settings: &RenderSettings,
    ) -> Result<Self> {
        if !technique.info().capabilities.embeddable {
            let names: Vec<&str> = embeddable_techniques().map(|t| t.name()).collect();
            return Err(Error::Unsupported(format!(
                "technique `{technique}` cannot be recorded into a caller's command buffer yet (its frame \
                 is not one graph ending in one image); embeddable: {}",
                names.join(", ")
            )));
        }
        let s = &settings.stochastic;
        if s.expansion == HullExpansion::Compute {
            return Err(Error::Unsupported(
                "the compute-expanded hull cannot be recorded into a caller's command buffer: it reads its \
                 vertex counts back between two graphs; use the geometry-shader hull"
                    .into(),
            ));
        }
        if s.instrumented {
            return Err(Error::Unsupported(
                "instrumented frames cannot be recorded into a caller's command buffer: their counters \
                 are read on the CPU after the frame"
                    .into(),
            ));
        }
        let prepared = renderer.prepare(scene, technique, settings)?;
        static SCENES: AtomicU64 = AtomicU64::new(0);
        Ok(EmbeddedScene {
            id: SCENES.fetch_add(1, Ordering::Relaxed),
            device: renderer.device().clone(),
            prepared: Some(prepared),
            size: (settings.width, settings.height),
            recorded: 0,
            in_flight: None,
        })
    }

    /// The render size (what a [`FrameTarget`] must be).
    pub fn size(&self) -> (u32, u32) {
        self.size
    }

    /// Whether a recorded frame awaits [`EmbeddedScene::retire`].
    pub fn frame_in_flight(&self) -> bool {
        self.in_flight.is_some()
    }

    /// Records one frame into `cmd`, its result copied into `target`, and returns its token. Nothing
    /// is submitted or waited on. Refused while the previous frame is not retired, for a target of
    /// another size, or of a format that cannot receive the copy; a validation message raised while
    /// recording is an error too ([`DeviceShared::check_validation`]).
    ///
    /// # Safety
    /// * `cmd` is a primary command buffer of this scene's device, in the recording state, from a
    ///   pool of the device's queue family; on `Err` it holds part of a frame: reset it, don't
    ///   submit it.
    /// * `target` describes its image truthfully (see [`FrameTarget`]), and the image stays alive
    ///   until the frame has executed. `target.before` covers every earlier access to the image that
    ///   is not otherwise ordered before this frame.
    /// * The caller submits `cmd` (once) to a queue of the device's queue family, after any command
    ///   buffer holding an earlier frame of this scene, and calls [`EmbeddedScene::retire`] with the
    ///   token only after that submission has completed (its fence signalled, say).
    /// * The scene, its [`Renderer`]'s device and everything the frame uses stay alive until then:
    ///   dropping the scene with a frame in flight leaks its GPU resources rather than free what the
    ///   GPU may still use.
    pub unsafe fn record(&mut self, cmd: vk::CommandBuffer, target: &FrameTarget) -> Result<FrameToken> {
        if let Some(f) = &self.in_flight {
            return Err(Error::Unsupported(format!(
                "frame {} of this scene is recorded but not retired: call EmbeddedScene::retire once its \
                 submission has completed before recording the next (one frame in flight per scene)",
                f.frame
            )));
        }
        let (w, h) = self.size;
        if (target.width, target.height) != (w, h) {
            return Err(Error::Unsupported(format!(
                "the target image is {}×{}; the scene renders {w}×{h}",
                target.width, target.height
            )));
        }
        self.check_target_format(target.format)?;
        let mut frame = CallerFrame {
            cmd,
            target: CallerTarget {
                image: target.image,
                desc: ImageDesc::new_2d(w, h, target.format, vk::ImageUsageFlags::TRANSFER_DST),
                before: target.before,
                after: target.after,
            },
            retained: Vec::new(),
            passes: Vec::new(),
            finished: false,
        };
        let prepared = self.prepared.as_mut().expect("only taken on drop");
        prepared.record_for_caller(&self.device, &mut frame)?;
        self.device.check_validation()?;
        let number = self.recorded;
        self.recorded += 1;
        self.in_flight = Some(InFlight { frame: number, retained: frame.retained });
        Ok(FrameToken { scene: self.id, frame: number, passes: frame.passes })
    }

    /// The frame of `token` has executed (the caller's fence for its submission signalled): what it
    /// used may be reused. Refuses a token of another scene.
    pub fn retire(&mut self, token: FrameToken) -> Result<()> {
        match &self.in_flight {
            Some(f) if token.scene == self.id && token.frame == f.frame => {
                self.in_flight = None;
                Ok(())
            }
            _ => Err(Error::Unsupported(format!(
                "frame token {} does not name this scene's frame in flight",
                token.frame
            ))),
        }
    }

    /// The frame's RGBA32F result is copied as it is into a target of the same format, otherwise
    /// blitted: the target's format must take it.
    fn check_target_format(&self, format: vk::Format) -> Result<()> {
        let d = &self.device;
        let features = |f: vk::Format| {
            // SAFETY: the physical device belongs to the instance.
            unsafe { d.instance.get_physical_device_format_properties(d.physical, f) }.optimal_tiling_features
        };
        let accum = vk::Format::R32G32B32A32_SFLOAT;
        let ok = if format == accum {
            features(format).contains(vk::FormatFeatureFlags::TRANSFER_DST)
        } else {
            features(format).contains(vk::FormatFeatureFlags::BLIT_DST)
                && features(accum).contains(vk::FormatFeatureFlags::BLIT_SRC)
        };
        if ok {
            return Ok(());
        }
        Err(Error::MissingFeature {
            device: d.caps.device_name.clone(),
            feature: format!("{format:?} as a copy or blit destination (optimal tiling)"),
            needed_by: "a frame target of that format (R32G32B32A32_SFLOAT takes a plain copy)".into(),
        })
    }
}

impl Drop for EmbeddedScene {
    fn drop(&mut self) {
        if let Some(f) = self.in_flight.take() {
            // The GPU may still run the frame: freeing its resources could corrupt it. Leaking them
            // is safe; the caller broke `record`'s contract.
            eprintln!(
                "warning: shutter::embed::EmbeddedScene dropped with frame {} not retired: its GPU \
                 resources are leaked",
                f.frame
            );
            std::mem::forget(f.retained);
            std::mem::forget(self.prepared.take());
        }
    }
}
