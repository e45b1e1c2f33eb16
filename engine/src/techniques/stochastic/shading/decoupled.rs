//! Decoupled shading (`stochastic/decoupled.glsl`): each hit takes the radiance of its key — (triangle,
//! side, lens-centre pixel cell at mid-shutter) — from a memoization cache, or shades the key's shading
//! point and stores it; or, deferred, from a hash table whose new points a dispatch of their own shades
//! between the per-pixel allocation and resolve dispatches ([`DecoupledPhase`]).

use ash::vk;
use bytemuck::{Pod, Zeroable};
use gpu_allocator::MemoryLocation;

use super::{ShadePush, ShadeVariant, ShadingStage};
use crate::error::{Error, Result};
use crate::gpu::layout::{shared_struct, ShaderInterface, SharedStruct};
use crate::graph::{Access, FrameGraph, ResourceHandle, Tracked};
use crate::shaders::{ShadeDecoupledComp, ShaderSource};
use crate::techniques::shadow_maps::ShadowHandles;
use crate::techniques::stochastic::layout::{STOCHASTIC_OBJECT_SET, STOCHASTIC_SET};
use crate::techniques::stochastic::options::StochasticOptions;
use crate::techniques::stochastic::CacheCounters;
use crate::techniques::{FrameInputs, PrepareContext};
use crate::vk::{write_descriptors, Buffer, DescriptorWrite, Device};

/// [`StochasticOptions::cache_entries`] by default.
pub const DEFAULT_CACHE_ENTRIES: u32 = 1 << 16;
/// The largest memoization cache (32 bytes an entry: 128 MiB).
pub const MAX_CACHE_ENTRIES: u32 = 1 << 22;
/// Bytes per entry of the memoization cache and of the deferred mode's hash table (`CacheEntry` in
/// `decoupled.glsl`).
pub const CACHE_ENTRY_BYTES: u64 = 32;
/// The deferred mode's queue (`DeferredQueue` in `decoupled.glsl`): its header's bytes, then 4 bytes
/// per hash-table entry; the shading dispatch's indirect arguments lie at this offset.
pub const DEFERRED_QUEUE_HEADER_BYTES: u64 = 32;
pub const DEFERRED_ARGS_OFFSET: u64 = 16;
/// The deferred mode's compact G-buffer: bytes per sample of a pass (its hash-table entry).
pub const DEFERRED_REF_BYTES: u64 = 4;
/// What an MSAA G-buffer would hold per sample for this engine's shading (`common/shading.glsl`'s
/// `shade` inputs): position and normal (3 × f32 each), albedo (3 × f32), specular and shininess
/// (f32 each), the shutter time (f32) — 48 bytes, without the visibility buffer's depth and triangle,
/// which both G-buffers share. The deferred mode's memory is compared with it
/// ([`DecoupledMemory`]).
pub const MSAA_GBUFFER_BYTES_PER_SAMPLE: u64 = 48;

/// The deferred mode's memory ([`super::super::StochasticDraws::decoupled_memory`]) against the MSAA G-buffer
/// of [`MSAA_GBUFFER_BYTES_PER_SAMPLE`] it replaces: both per sample of a pass (what is held at once).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DecoupledMemory {
    /// Pixels × samples per pass.
    pub samples: u64,
    /// The compact G-buffer.
    pub refs_bytes: u64,
    /// The hash table and its queue.
    pub table_bytes: u64,
}

impl DecoupledMemory {
    pub fn bytes_per_sample(&self) -> f64 {
        (self.refs_bytes + self.table_bytes) as f64 / self.samples.max(1) as f64
    }
    pub fn msaa_gbuffer_bytes(&self) -> u64 {
        self.samples * MSAA_GBUFFER_BYTES_PER_SAMPLE
    }
}

/// Push constants of `shade_decoupled.comp`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub(super) struct DecoupledPush {
    pub shade: ShadePush,
    /// Entries of the memoization cache or of the deferred mode's hash table.
    pub cache_entries: u32,
    /// The dispatch's phase ([`DecoupledPhase`]).
    pub decoupled_phase: u32,
}

/// For the reflection test.
const DECOUPLED_PUSH: SharedStruct =
    shared_struct!("Push", DecoupledPush, [shade, cache_entries, decoupled_phase]);

/// The dispatches of decoupled shading per object and pass (`DC_PHASE_*` in `decoupled.glsl`): the
/// memoization cache's one, or the deferred mode's four. (Every other stage has one dispatch, `Memo`.)
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u32)]
pub(in crate::techniques::stochastic) enum DecoupledPhase {
    Memo = 0,
    /// Per pixel: each sample's key found in or added to the hash table, its entry in the compact
    /// G-buffer.
    Allocate = 1,
    /// One invocation: the new entries' range and the next dispatch's indirect arguments.
    Args = 2,
    /// Indirect, one invocation per new entry: its shading point shaded.
    Shade = 3,
    /// Per pixel: each sample's radiance read from its entry (or shaded on the spot).
    Resolve = 4,
}

/// Decoupled shading's stage: its buffers (`decoupled.glsl`, set 3 bindings 8–11).
pub(super) struct Decoupled {
    /// The memoization cache or the deferred mode's hash table, cleared every frame.
    cache: Tracked<Buffer>,
    /// Every triangle's grid (frame numbering; vec4: axis, spacing along it, across it).
    grids: Buffer,
    /// The deferred mode's queue of new entries, with its shading dispatch's indirect arguments
    /// (cleared every frame), and its compact G-buffer: placeholders for the memoization cache.
    queue: Tracked<Buffer>,
    refs: Buffer,
    deferred: bool,
    cache_entries: u32,
}

impl Decoupled {
    /// Its buffers for `pass_samples` pixels × samples of a pass.
    pub fn new(ctx: &PrepareContext<'_>, options: &StochasticOptions, pass_samples: u64) -> Result<Self> {
        let device = ctx.device;
        let kind = options.shading.decoupled_grid().expect("a decoupled rate");
        // The memoization cache's seqlock relies on the order of plain (relaxed) atomics, which
        // llvmpipe's sequentially consistent atomics keep and a GPU's need not (decoupled.glsl): on
        // any other device it could return a half-written value, so it is refused there.
        if !options.shading.deferred() && !device.caps.is_lavapipe() {
            return Err(Error::Unsupported(format!(
                "--shading {}: the memoization cache is exact only where atomics are sequentially consistent (lavapipe); on {} use `{}-deferred`, whose hash table needs no ordering",
                options.shading.name(),
                device.caps.device_name,
                options.shading.name()
            )));
        }
        if !(1..=MAX_CACHE_ENTRIES).contains(&options.cache_entries) {
            return Err(Error::Unsupported(format!(
                "a decoupled shading cache of {} entries: 1 ..= {MAX_CACHE_ENTRIES}",
                options.cache_entries
            )));
        }
        let storage = vk::BufferUsageFlags::STORAGE_BUFFER;
        let cache = Tracked::new(Buffer::new(
            device,
            "decoupled shading cache",
            options.cache_entries as u64 * CACHE_ENTRY_BYTES,
            storage | vk::BufferUsageFlags::TRANSFER_DST,
            MemoryLocation::GpuOnly,
        )?);
        let (width, height) = ctx.camera.size();
        let intrinsics = ctx.scene.camera.intrinsics(width, height);
        let grids: Vec<[f32; 4]> =
            crate::mirror::decoupled::object_grids(ctx.scene, &ctx.camera.space, &intrinsics, kind)
                .iter()
                .map(|g| [g.axis.x, g.axis.y, g.along, g.across])
                .collect();
        let placeholder = [[1.0, 0.0, 1.0, 1.0]];
        let grids = Buffer::with_data(
            device,
            "decoupled grids",
            storage,
            if grids.is_empty() { &placeholder } else { &grids },
        )?;
        // The deferred mode's queue (its header, then an entry per table entry) and compact G-buffer
        // (an entry per pixel and sample of a pass); the memoization cache's pipelines name them
        // too, so it binds placeholders.
        let deferred = options.shading.deferred();
        let (queue_entries, refs) =
            if deferred { (options.cache_entries as u64, pass_samples) } else { (1, 1) };
        let queue = Tracked::new(Buffer::new(
            device,
            "decoupled deferred queue",
            DEFERRED_QUEUE_HEADER_BYTES + 4 * queue_entries,
            storage | vk::BufferUsageFlags::TRANSFER_DST | vk::BufferUsageFlags::INDIRECT_BUFFER,
            MemoryLocation::GpuOnly,
        )?);
        let refs = Buffer::new(
            device,
            "decoupled deferred G-buffer",
            refs * DEFERRED_REF_BYTES,
            storage,
            MemoryLocation::GpuOnly,
        )?;
        Ok(Decoupled { cache, grids, queue, refs, deferred, cache_entries: options.cache_entries })
    }
}

impl ShadingStage for Decoupled {
    fn shader(&self, v: ShadeVariant) -> ShaderSource {
        ShadeDecoupledComp {
            instrumented: v.instrumented,
            effects: v.effects,
            shadows: v.shadows,
            shadow_color: v.shadow_color,
            tints: v.tints,
        }
        .source()
    }

    fn write_sets(
        &self,
        device: &Device,
        technique_set: vk::DescriptorSet,
        _object_sets: &[vk::DescriptorSet],
    ) {
        write_descriptors(
            device,
            technique_set,
            &[
                DescriptorWrite::storage_buffer(8, &self.cache),
                DescriptorWrite::storage_buffer(9, &self.grids),
                DescriptorWrite::storage_buffer(10, &self.queue),
                DescriptorWrite::storage_buffer(11, &self.refs),
            ],
        );
    }

    /// The cache and queue cleared once a frame: every shading dispatch of every pass shares them.
    fn add_frame_passes<'a>(
        &'a self,
        g: &mut FrameGraph<'a>,
        _inputs: &FrameInputs<'a>,
        _shadows: Option<ShadowHandles>,
    ) -> Vec<(ResourceHandle, Access)> {
        let h = g.import_buffer("decoupled shading cache", &self.cache);
        let q = g.import_buffer("decoupled deferred queue", &self.queue);
        g.pass("clear decoupled cache")
            .overwrite(h, Access::TransferWrite)
            .overwrite(q, Access::TransferWrite)
            .record(move |ctx| {
                for b in [h, q] {
                    ctx.fill_buffer(b, 0);
                }
                Ok(())
            });
        let mut uses = Vec::new();
        for b in [h, q] {
            uses.push((b.into(), Access::ComputeShaderReadOther));
            uses.push((b.into(), Access::ComputeShaderWrite));
        }
        // The deferred shading dispatch's arguments, written by the dispatch before it.
        uses.push((q.into(), Access::IndirectBuffer));
        uses
    }

    /// The deferred mode: allocate, then shade the new entries, then resolve (module docs of
    /// decoupled.glsl); the memoization cache: one dispatch.
    fn phases(&self) -> &'static [DecoupledPhase] {
        if self.deferred {
            &[DecoupledPhase::Allocate, DecoupledPhase::Args, DecoupledPhase::Shade, DecoupledPhase::Resolve]
        } else {
            &[DecoupledPhase::Memo]
        }
    }

    fn push_size(&self) -> u32 {
        std::mem::size_of::<DecoupledPush>() as u32
    }

    fn push(&self, shade: ShadePush, phase: DecoupledPhase) -> Vec<u8> {
        bytemuck::bytes_of(&DecoupledPush {
            shade,
            cache_entries: self.cache_entries,
            decoupled_phase: phase as u32,
        })
        .to_vec()
    }

    fn indirect_args(&self) -> Option<vk::Buffer> {
        Some(self.queue.raw)
    }

    fn cache_counters(&self, raw: &[u32], samples: u64) -> Option<CacheCounters> {
        Some(CacheCounters {
            lookups: raw[4] as u64,
            hits: raw[5] as u64,
            evictions: raw[6] as u64,
            busy: raw[7] as u64,
            overflows: raw[8] as u64,
            memory: self.decoupled_memory(samples),
        })
    }

    fn decoupled_memory(&self, samples: u64) -> Option<DecoupledMemory> {
        self.deferred.then(|| DecoupledMemory {
            samples,
            refs_bytes: self.refs.size,
            table_bytes: self.cache.size + self.queue.size,
        })
    }
}

/// `shade_decoupled.comp`'s interface: sets 2 and 3 of the stochastic frame, [`DecoupledPush`], the shadow
/// maps as set 4.
pub(in crate::techniques::stochastic) const SHADER_INTERFACE: ShaderInterface = ShaderInterface::technique(
    &["stochastic/shade_decoupled.comp"],
    Some(&STOCHASTIC_OBJECT_SET),
    Some(&STOCHASTIC_SET),
    Some(DECOUPLED_PUSH),
)
.with_shadows(&crate::techniques::shadow_maps::SHADOW_SET);
