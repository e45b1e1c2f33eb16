//! The coverage paths of the stochastic frame, and the mask path's targets and resolve.
//!
//! Both paths find, for every pixel and sample of a pass, the nearest hit of the 5D inside test over
//! the same bounds and samples (`stochastic/coverage_draw.glsl`), and both leave it in the visibility
//! buffer (`stochastic/visibility.glsl`) for the shading stages, which do not know which path ran:
//!
//! * [`Coverage::Visibility`] (`stochastic.frag`): an attachment-less pass whose fragment stage keeps
//!   each hit by one 64-bit `atomicMax` of (depth, payload). Needs 64-bit buffer atomics and fragment
//!   stores.
//! * [`Coverage::Mask`] (`mask.frag`, McGuire et al. 2010 as published): a multisampled target of M
//!   samples per pixel, M the pass' samples — S = M × passes, as the thesis counts. The fragment stage
//!   writes which samples the triangle covers to `gl_SampleMask`, its depth to `gl_FragDepth`, its
//!   payload to an R32_UINT colour attachment, and the hardware's per-sample depth test keeps the
//!   nearest. A compute resolve (`mask_resolve.comp`) writes target and depth into the visibility
//!   buffer with plain stores. Needs 64-bit shader integers (the shading stages read 64-bit words),
//!   no atomics.
//!   - [`MaskRate::Sample`]: sample-rate shading — one invocation per covered sample, each writing
//!     its own depth: the same image as the visibility path (exact against the same-sample reference).
//!   - [`MaskRate::Fragment`]: one invocation per pixel, one depth (the nearest covered sample's) for
//!     every sample it covers, as the published pixel shader: a sample of this triangle may lose to (or
//!     win over) another triangle that lies between that depth and its own. The approximation is
//!     measured on the hard-case matrix (docs/HARDWARE.md).
//!
//! The published path shades in the coverage pass, once per pixel; ours shades afterwards, from the
//! visibility buffer, for the reasons the visibility path does (`docs/STOCHASTIC.md`): the mask path
//! differs from it only in how the nearest hit is found. Cluster bounds (many triangles per fragment)
//! stay on the visibility path: a mask fragment names one triangle.

use ash::vk;

use crate::error::{Error, Result};
use crate::gpu::layout::TECHNIQUE_SET_INDEX;
use crate::gpu::GpuWorld;
use crate::graph::{Access, BufferHandle, FrameGraph, ImageHandle, Tracked};
use crate::shaders;
use crate::vk::{
    write_descriptors, Capabilities, DescriptorSetLayout, DescriptorWrite, Device, Feature, Image, ImageDesc,
    Pipeline, PipelineLayout, Sampler, ShaderModule,
};

/// How the coverage pass finds each sample's nearest hit (module docs).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Coverage {
    /// The device's: [`Coverage::Visibility`] where it has 64-bit buffer atomics and fragment stores,
    /// else [`Coverage::Mask`] — per sample where it has sample-rate shading, else per fragment
    /// ([`Coverage::resolve`]).
    #[default]
    Device,
    Visibility,
    Mask(MaskRate),
}

/// How often the mask path's fragment stage runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum MaskRate {
    /// Once per covered sample (sample-rate shading), each with its own depth: exact.
    Sample,
    /// Once per pixel, one depth for its covered samples: the published cheap mode, approximate.
    Fragment,
}

impl Coverage {
    /// Every choice, by name.
    pub const NAMED: [Coverage; 4] = [
        Coverage::Device,
        Coverage::Visibility,
        Coverage::Mask(MaskRate::Sample),
        Coverage::Mask(MaskRate::Fragment),
    ];

    pub fn name(&self) -> &'static str {
        match self {
            Coverage::Device => "device",
            Coverage::Visibility => "visibility",
            Coverage::Mask(MaskRate::Sample) => "mask",
            Coverage::Mask(MaskRate::Fragment) => "mask-per-fragment",
        }
    }

    /// The path this choice takes on a device with `caps` (never [`Coverage::Device`]), or the refusal
    /// naming what the device lacks; [`Coverage::Device`] as [`Coverage::resolve_for`] without fixed
    /// cluster bounds.
    pub fn resolve(&self, caps: &Capabilities) -> Result<Coverage> {
        self.resolve_for(caps, false).map(|(path, _)| path)
    }

    /// [`Coverage::resolve`] with why: [`Coverage::Device`] takes the exact path the driver's
    /// calibration found faster ([`crate::calibration::device_coverage`], `shutter calibrate`) where
    /// the device can take it (and, for the mask path, `fixed_clusters` — cluster bounds asked for by
    /// number, which only the visibility path draws — is false); else the first of visibility, mask,
    /// mask-per-fragment the device has the features for (`device_path`).
    pub fn resolve_for(&self, caps: &Capabilities, fixed_clusters: bool) -> Result<(Coverage, String)> {
        let missing = |path: Coverage| -> Vec<(Feature, &'static str)> {
            let needs: &[(Feature, &'static str)] = match path {
                Coverage::Visibility | Coverage::Device => &[
                    (Feature::FragmentStoresAndAtomics, "the visibility buffer's coverage atomics"),
                    (Feature::BufferInt64Atomics, "the visibility buffer's 64-bit atomicMax"),
                ],
                Coverage::Mask(MaskRate::Sample) => &[
                    (Feature::ShaderInt64, "the shading stages' 64-bit visibility words"),
                    (Feature::SampleRateShading, "one fragment invocation per sample"),
                ],
                Coverage::Mask(MaskRate::Fragment) => {
                    &[(Feature::ShaderInt64, "the shading stages' 64-bit visibility words")]
                }
            };
            needs.iter().copied().filter(|(f, _)| !caps.has(*f)).collect()
        };
        let refuse = |path: Coverage, lacks: Vec<(Feature, &str)>| Error::MissingFeature {
            device: caps.device_name.clone(),
            feature: lacks
                .iter()
                .map(|(f, why)| format!("{} ({why})", f.vulkan_name()))
                .collect::<Vec<_>>()
                .join(", "),
            needed_by: format!("technique `stochastic` with coverage `{}`", path.name()),
        };
        match self {
            Coverage::Device => {
                let calibrated = crate::calibration::device_coverage(caps);
                device_path(&|path| missing(path).is_empty(), calibrated, fixed_clusters).ok_or_else(|| {
                    refuse(Coverage::Mask(MaskRate::Fragment), missing(Coverage::Mask(MaskRate::Fragment)))
                })
            }
            path => {
                let lacks = missing(*path);
                if lacks.is_empty() {
                    Ok((*path, "chosen".into()))
                } else {
                    Err(refuse(*path, lacks))
                }
            }
        }
    }

    /// The mask path's rate (None on the visibility path).
    pub fn mask_rate(&self) -> Option<MaskRate> {
        match self {
            Coverage::Mask(rate) => Some(*rate),
            _ => None,
        }
    }
}

impl std::str::FromStr for Coverage {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        crate::error::parse_named(&Coverage::NAMED, |c| c.name(), "coverage path", s)
    }
}

/// [`Coverage::Device`]'s path, and why: `calibrated` (a path and where it was measured) where
/// `available` says the device can take it and it can draw what was asked (`fixed_clusters` rules out
/// the mask path); else the first available of visibility, mask per sample, mask per fragment; None
/// where none is.
pub fn device_path(
    available: &dyn Fn(Coverage) -> bool,
    calibrated: Option<(Coverage, String)>,
    fixed_clusters: bool,
) -> Option<(Coverage, String)> {
    let mut passed_over = String::new();
    if let Some((path, why)) = calibrated {
        let draws = path.mask_rate().is_none() || !fixed_clusters;
        if available(path) && draws {
            return Some((path, why));
        }
        passed_over = format!(
            " (calibrated `{}` passed over: {})",
            path.name(),
            if draws {
                "the device lacks its features"
            } else {
                "fixed cluster bounds need the visibility path"
            }
        );
    }
    let order = [Coverage::Visibility, Coverage::Mask(MaskRate::Sample), Coverage::Mask(MaskRate::Fragment)];
    order.into_iter().find(|&p| available(p)).map(|p| {
        let why = match p {
            Coverage::Visibility => "the device has the visibility buffer's 64-bit atomics",
            Coverage::Mask(MaskRate::Sample) => "no 64-bit buffer atomics; sample-rate shading",
            _ => "no 64-bit buffer atomics, no sample-rate shading",
        };
        (p, format!("{why}{passed_over}"))
    })
}

/// The mask target's formats: the payload (`triangle << 1 | back`) and the depth.
pub const MASK_PAYLOAD_FORMAT: vk::Format = vk::Format::R32_UINT;
pub const MASK_DEPTH_FORMAT: vk::Format = vk::Format::D32_SFLOAT;
/// `gl_FragDepth` = view depth × this (`mask.frag`): a power of two, so the float depth attachment
/// holds the view depth's own significand and compares as the visibility buffer's depths do.
pub const MASK_DEPTH_SCALE: f32 = 1.0 / 4_294_967_296.0;

/// The MSAA counts the mask target can have on a device: those of its colour and depth
/// framebuffers (`caps`, after `--disable msaa-N`) that both formats also support as sampled,
/// multisampled images; 1 always.
pub fn mask_sample_counts(device: &Device) -> Vec<u32> {
    let format_counts = |format: vk::Format, usage: vk::ImageUsageFlags| -> vk::SampleCountFlags {
        unsafe {
            device.instance.get_physical_device_image_format_properties(
                device.physical,
                format,
                vk::ImageType::TYPE_2D,
                vk::ImageTiling::OPTIMAL,
                usage | vk::ImageUsageFlags::SAMPLED,
                vk::ImageCreateFlags::empty(),
            )
        }
        .map(|p| p.sample_counts)
        .unwrap_or(vk::SampleCountFlags::TYPE_1)
    };
    let payload = format_counts(MASK_PAYLOAD_FORMAT, vk::ImageUsageFlags::COLOR_ATTACHMENT);
    let depth = format_counts(MASK_DEPTH_FORMAT, vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT);
    let mut counts = vec![1];
    counts.extend(device.caps.framebuffer_sample_counts.iter().copied().filter(|&n| {
        let flag = vk::SampleCountFlags::from_raw(n);
        n > 1 && payload.contains(flag) && depth.contains(flag)
    }));
    counts.sort_unstable();
    counts.dedup();
    counts
}

/// Samples per pass M and passes P of the mask path for S = `spp`: M an MSAA count of `counts` that
/// divides S — the largest, or `forced` (`per-pass`, an experiment) — and fits the visibility buffer
/// of `pixels` × M samples of `bytes` each (the visibility word, and the tint's with tints) in `max_bytes`.
pub fn mask_samples_per_pass(
    spp: u32,
    forced: Option<u32>,
    counts: &[u32],
    pixels: u64,
    bytes: u64,
    max_bytes: u64,
) -> Result<(u32, u32)> {
    let fits = |m: u32| pixels * m as u64 * bytes <= max_bytes;
    let usable = |m: u32| m > 0 && counts.contains(&m) && spp.is_multiple_of(m);
    match forced {
        Some(m) if usable(m) && fits(m) => Ok((m, spp / m)),
        Some(m) if usable(m) => Err(Error::Limit {
            what: "samples per pass",
            value: m.to_string(),
            limit: format!("per-sample buffers of {pixels} pixels × M × {bytes} bytes within {max_bytes} bytes"),
        }),
        Some(m) => Err(Error::Unsupported(format!(
            "{m} samples per pass on the mask coverage path for S = {spp}: an MSAA count of the device ({counts:?}) that divides S"
        ))),
        None => counts
            .iter()
            .rev()
            .copied()
            .find(|&m| usable(m) && fits(m))
            .map(|m| (m, spp / m))
            .ok_or_else(|| Error::Limit {
                what: "image size",
                value: format!("{pixels} pixels"),
                limit: format!("a visibility buffer of one sample per pixel within {max_bytes} bytes"),
            }),
    }
}

/// The resolve's push constants (`mask_resolve.comp`).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct MaskResolvePush {
    pub width: u32,
    pub height: u32,
    pub per_pass: u32,
}

/// The mask path's multisampled target and its resolve into the visibility buffer. The target's
/// images are bound in set 3 (bindings 12 and 13) for the resolve.
pub(super) struct MaskTarget {
    pub samples: u32,
    payload: Tracked<Image>,
    depth: Tracked<Image>,
    resolve: Pipeline,
    layout: PipelineLayout,
    size: (u32, u32),
    _shader: ShaderModule,
    _sampler: Sampler,
}

/// The graph handles of the target.
#[derive(Clone, Copy)]
pub(super) struct MaskHandles {
    pub payload: ImageHandle,
    pub depth: ImageHandle,
}

impl MaskTarget {
    /// The target of `samples` samples per pixel for an image of `size`, its images written into set 3
    /// (`technique_set`).
    pub fn new(
        device: &Device,
        world: &GpuWorld,
        samples: u32,
        size: (u32, u32),
        sets: &[&DescriptorSetLayout],
        technique_set: vk::DescriptorSet,
    ) -> Result<Self> {
        let sampled = vk::ImageUsageFlags::SAMPLED;
        let image = |name: &str, format, usage| -> Result<Tracked<Image>> {
            let desc = ImageDesc::new_2d(size.0, size.1, format, usage | sampled).samples(samples);
            Ok(Tracked::new(Image::new(device, name, desc)?))
        };
        let payload = image("mask payload", MASK_PAYLOAD_FORMAT, vk::ImageUsageFlags::COLOR_ATTACHMENT)?;
        let depth = image("mask depth", MASK_DEPTH_FORMAT, vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT)?;
        let sampler = Sampler::nearest_clamp(device, "mask target")?;
        write_descriptors(
            device,
            technique_set,
            &[
                DescriptorWrite::SampledImage { binding: 12, view: payload.view, sampler: sampler.raw },
                DescriptorWrite::SampledImage { binding: 13, view: depth.view, sampler: sampler.raw },
            ],
        );
        let resolve = shaders::MaskResolveComp { single_sample_target: samples == 1 };
        let shader = ShaderModule::new(device, resolve.source())?;
        let layout = world.pipeline_layout(
            device,
            sets,
            std::mem::size_of::<MaskResolvePush>() as u32,
            vk::ShaderStageFlags::COMPUTE,
        )?;
        let resolve = Pipeline::compute(device, "mask resolve", &layout, &shader)?;
        Ok(MaskTarget { samples, payload, depth, resolve, layout, size, _shader: shader, _sampler: sampler })
    }

    pub fn import<'a>(&'a self, g: &mut FrameGraph<'a>) -> MaskHandles {
        MaskHandles {
            payload: g.import_image("mask payload", &self.payload),
            depth: g.import_image("mask depth", &self.depth),
        }
    }

    /// The resolve of one pass: target and depth into the visibility buffer (every word written).
    pub fn add_resolve_pass<'a>(
        &'a self,
        g: &mut FrameGraph<'a>,
        h: MaskHandles,
        visibility: BufferHandle,
        technique_set: vk::DescriptorSet,
    ) {
        let sampled = Access::ComputeShaderReadSampledImageOrUniformTexelBuffer;
        let (width, height) = self.size;
        let push = MaskResolvePush { width, height, per_pass: self.samples };
        g.pass("mask resolve")
            .access(h.payload, sampled)
            .access(h.depth, sampled)
            .overwrite(visibility, Access::ComputeShaderWrite)
            .record(move |ctx| {
                ctx.bind_pipeline(&self.resolve);
                ctx.bind_sets(
                    vk::PipelineBindPoint::COMPUTE,
                    &self.layout,
                    TECHNIQUE_SET_INDEX,
                    &[technique_set],
                );
                ctx.push(&self.layout, &push);
                ctx.dispatch(width.div_ceil(8), height.div_ceil(8), 1);
                Ok(())
            });
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_device_path_is_the_calibrated_one_where_the_device_can_take_it() {
        let (vis, mask, frag) =
            (Coverage::Visibility, Coverage::Mask(MaskRate::Sample), Coverage::Mask(MaskRate::Fragment));
        let all = |_: Coverage| true;
        let no_atomics = |p: Coverage| p != vis;
        let bare = |p: Coverage| p == frag;
        let measured = |p: Coverage| Some((p, "measured".to_string()));
        // Uncalibrated: by features.
        assert_eq!(device_path(&all, None, false).unwrap().0, vis);
        assert_eq!(device_path(&no_atomics, None, false).unwrap().0, mask);
        assert_eq!(device_path(&bare, None, false).unwrap().0, frag);
        assert!(device_path(&|_| false, None, false).is_none());
        // Calibrated mask on a device with both: the mask path, with the calibration's reason.
        assert_eq!(device_path(&all, measured(mask), false), measured(mask));
        assert_eq!(device_path(&all, measured(vis), false), measured(vis));
        // Fixed cluster bounds only draw on the visibility path; a device without the calibrated
        // path's features falls back by features; each says why.
        let (p, why) = device_path(&all, measured(mask), true).unwrap();
        assert!(p == vis && why.contains("cluster"), "{p:?} {why}");
        let (p, why) = device_path(&no_atomics, measured(vis), false).unwrap();
        assert!(p == mask && why.contains("passed over"), "{p:?} {why}");
    }

    #[test]
    fn the_mask_path_takes_the_largest_msaa_count_that_divides_s() {
        let counts = [1, 2, 4, 8];
        let big = u64::MAX;
        assert_eq!(mask_samples_per_pass(16, None, &counts, 100, 8, big).unwrap(), (8, 2));
        assert_eq!(mask_samples_per_pass(4, None, &counts, 100, 8, big).unwrap(), (4, 1));
        assert_eq!(mask_samples_per_pass(1, None, &counts, 100, 8, big).unwrap(), (1, 1));
        // lavapipe: 1 and 4.
        assert_eq!(mask_samples_per_pass(16, None, &[1, 4], 100, 8, big).unwrap(), (4, 4));
        assert_eq!(mask_samples_per_pass(2, None, &[1, 4], 100, 8, big).unwrap(), (1, 2));
        // Forced: a count of the device that divides S, or a clear refusal.
        assert_eq!(mask_samples_per_pass(16, Some(2), &counts, 100, 8, big).unwrap(), (2, 8));
        assert!(mask_samples_per_pass(16, Some(2), &[1, 4], 100, 8, big).is_err());
        assert!(mask_samples_per_pass(4, Some(8), &counts, 100, 8, big).is_err());
        // The visibility buffer's budget: 100 pixels × 4 words fits 3,200 bytes, × 8 does not.
        assert_eq!(mask_samples_per_pass(16, None, &counts, 100, 8, 3200).unwrap(), (4, 4));
        assert!(mask_samples_per_pass(16, None, &counts, 100, 8, 799).is_err());
    }

    #[test]
    fn the_depth_scale_is_exact_both_ways() {
        for z in [1e-3f32, 0.1, 1.0, 3.7, 1234.5678, 1e6, 4.0e9] {
            let d = z * MASK_DEPTH_SCALE;
            assert!(d < 1.0 && d > 0.0);
            assert_eq!((d * 4_294_967_296.0).to_bits(), z.to_bits(), "{z}");
        }
        // Orders as the view depths do, bit for bit (neighbouring floats stay neighbours).
        let z = 2.5f32;
        let next = f32::from_bits(z.to_bits() + 1);
        assert!(z * MASK_DEPTH_SCALE < next * MASK_DEPTH_SCALE);
    }

    #[test]
    fn coverage_names_round_trip() {
        for c in Coverage::NAMED {
            assert_eq!(c.name().parse::<Coverage>().unwrap(), c);
        }
        assert!("msaa".parse::<Coverage>().is_err());
    }
}
