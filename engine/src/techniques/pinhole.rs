//! Technique `pinhole`: the scene at mid-shutter through the lens centre, one forward pass with MSAA
//! 4× where available. This is the "no effect" path every blur technique is compared with.

use glam::Vec2;

use super::forward::PassSample;
use super::{FrameTechnique, PrepareContext, TechniqueCapabilities, TechniqueInfo};
use crate::error::Result;

/// The registry entry.
pub const INFO: TechniqueInfo = TechniqueInfo {
    name: "pinhole",
    summary: "one forward pass at mid-shutter through the lens centre, MSAA 4x: no blur",
    keys: &[super::forward::TRANSPARENCY_KEYS, super::shadow_maps::KEYS],
    required_features: &[],
    capabilities: TechniqueCapabilities { transparency: true, transparency_methods: true, embeddable: false },
    prepare,
};

fn prepare(ctx: &PrepareContext<'_>) -> Result<Box<dyn FrameTechnique>> {
    let msaa = ctx.device.caps.msaa_samples(PINHOLE_MSAA);
    super::forward::prepare_frame(ctx, msaa, pinhole_passes())
}

/// MSAA count the pinhole technique asks for (the device may offer less).
pub const PINHOLE_MSAA: u32 = 4;

/// The single pass: t = 0.5, lens centre, no jitter (MSAA provides the spatial samples).
pub fn pinhole_passes() -> Vec<PassSample> {
    vec![PassSample { time: 0.5, lens: Vec2::ZERO, jitter: Vec2::ZERO }]
}
