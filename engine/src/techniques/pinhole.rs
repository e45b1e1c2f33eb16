//! Technique `pinhole`: the scene at mid-shutter through the lens centre, one forward pass with MSAA
//! 4× where available. This is the "no effect" path every blur technique is compared with.

use glam::Vec2;

use super::forward::{ForwardTechnique, PassSample};
use super::{FrameTechnique, PrepareContext, TechniqueInfo};
use crate::error::Result;

/// The registry entry.
pub const INFO: TechniqueInfo = TechniqueInfo {
    name: "pinhole",
    summary: "one forward pass at mid-shutter through the lens centre, MSAA 4x: no blur",
    prepare,
};

fn prepare(ctx: &PrepareContext<'_>) -> Result<Box<dyn FrameTechnique>> {
    let msaa = ctx.device.caps.msaa_samples(PINHOLE_MSAA);
    Ok(Box::new(ForwardTechnique::new(ctx, msaa, pinhole_passes())?))
}

/// MSAA count the pinhole technique asks for (the device may offer less).
pub const PINHOLE_MSAA: u32 = 4;

/// The single pass: t = 0.5, lens centre, no jitter (MSAA provides the spatial samples).
pub fn pinhole_passes() -> Vec<PassSample> {
    vec![PassSample { time: 0.5, lens: Vec2::ZERO, jitter: Vec2::ZERO }]
}

/// Subpixel offset of pass `pass` of `passes` for objects a stochastic frame draws on the plain pinhole
/// path ([`crate::plan::Effects::Pinhole`]): the Hammersley point `((p + ½)/P, φ₂(p) + ½/2^⌈log₂P⌉)`,
/// centred and scaled to one MSAA sample's share of the pixel (`1/√msaa` wide), so the frame's
/// P passes × M MSAA samples antialias those objects with P·M distinct positions rather than the same
/// M in every pass. One pass: no offset.
pub fn pinhole_pass_jitter(pass: u32, passes: u32, msaa: u32) -> Vec2 {
    if passes <= 1 {
        return Vec2::ZERO;
    }
    let radical_inverse_2 = |i: u32| i.reverse_bits() as f32 / 4_294_967_296.0;
    let x = (pass as f32 + 0.5) / passes as f32;
    let y = radical_inverse_2(pass) + 0.5 / passes.next_power_of_two() as f32;
    (Vec2::new(x, y) - Vec2::splat(0.5)) / (msaa.max(1) as f32).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pass_jitter_is_stratified_within_one_msaa_cell() {
        assert_eq!(pinhole_pass_jitter(0, 1, 4), Vec2::ZERO);
        let j: Vec<Vec2> = (0..4).map(|p| pinhole_pass_jitter(p, 4, 4)).collect();
        for v in &j {
            assert!(v.x.abs() <= 0.25 && v.y.abs() <= 0.25, "{j:?}");
        }
        // One point per quadrant of the cell.
        let mut quadrants: Vec<(bool, bool)> = j.iter().map(|v| (v.x < 0.0, v.y < 0.0)).collect();
        quadrants.sort();
        quadrants.dedup();
        assert_eq!(quadrants.len(), 4, "{j:?}");
    }
}
