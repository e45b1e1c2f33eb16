//! Technique `accumulation` (Haeberli & Akeley 1990; the thesis' baseline): P passes, each rendering the
//! whole scene with one (x, y, u, v, t) sample shared by every pixel, averaged. P = `spp`.
//!
//! The P samples are one stratified set (`sampling::stratified_samples`): subpixel offsets and lens
//! points multi-jittered over P, times jittered over P strata, the three permuted independently. Each
//! pass renders without MSAA so the pixel filter is exactly the box of docs/MODEL.md: S = P samples/pixel.
//!
//! Coverage below 1 and tints: stochastic transparency on the forward path (`forward.rs`): in pass p a
//! transparent fragment is kept iff sample p of its pixel's P is covered, the decision the reference
//! makes for the same sample — with [`accumulation_samples`] as every pixel's samples the two images
//! agree to rounding.

use glam::Vec2;

use super::forward::PassSample;
use super::{FrameTechnique, PrepareContext, TechniqueCapabilities, TechniqueInfo};
use crate::error::Result;
use crate::sampling::{stratified_samples, ApertureShape, Pcg32, Sample5, ShutterCurve};

/// The registry entry.
pub const INFO: TechniqueInfo = TechniqueInfo {
    name: "accumulation",
    summary: "P full-scene passes, one stratified (x, y, u, v, t) each, averaged (Haeberli & Akeley)",
    keys: &[super::forward::TRANSPARENCY_KEYS, super::shadow_maps::KEYS],
    required_features: &[],
    capabilities: TechniqueCapabilities { transparency: true, transparency_methods: true, embeddable: false },
    prepare,
};

fn prepare(ctx: &PrepareContext<'_>) -> Result<Box<dyn FrameTechnique>> {
    let c = &ctx.scene.camera;
    let s = ctx.settings;
    let passes = accumulation_passes(s.spp, s.seed, c.aperture, c.shutter);
    super::forward::prepare_frame(ctx, 1, passes)
}

/// The samples of `passes` passes with `seed`, in pass order, before the aperture shape and the
/// shutter curve: what the reference takes to render with the same samples
/// ([`crate::reference::render_reference_shared_samples`]; pass p is sample index p of every pixel,
/// stochastic coverage included).
pub fn accumulation_samples(passes: u32, seed: u64) -> Vec<Sample5> {
    stratified_samples(passes, &mut Pcg32::new(seed, 0xacc))
}

/// The passes for `passes` samples with `seed`, the aperture shape and the shutter curve applied.
pub fn accumulation_passes(
    passes: u32,
    seed: u64,
    aperture: ApertureShape,
    shutter: ShutterCurve,
) -> Vec<PassSample> {
    accumulation_samples(passes, seed)
        .into_iter()
        .map(|s| PassSample {
            time: shutter.warp(s.time),
            lens: aperture.map(s.lens),
            jitter: s.xy - Vec2::splat(0.5),
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn passes_are_stratified_and_deterministic() {
        let a = accumulation_passes(16, 3, ApertureShape::Disk, ShutterCurve::Box);
        assert_eq!(a, accumulation_passes(16, 3, ApertureShape::Disk, ShutterCurve::Box));
        let mut strata: Vec<usize> = a.iter().map(|p| (p.time * 16.0) as usize).collect();
        strata.sort();
        assert_eq!(strata, (0..16).collect::<Vec<_>>());
        assert!(a.iter().all(|p| p.lens.length() <= 1.0 && p.jitter.abs().max_element() <= 0.5));
    }
}
