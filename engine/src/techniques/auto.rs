//! Technique `auto`, the default: simulate only what the scene calls for. The effect planner
//! ([`crate::plan`]) gives every object a path; this file composes the paths' draws into one
//! multipass frame:
//!
//! * nothing to simulate anywhere → exactly the `pinhole` technique (same passes, same image, same
//!   cost);
//! * otherwise every object on the stochastic path with one shader permutation per effect set
//!   ([`StochasticTechnique`]): the still, sharp objects with the `still` permutation (bounded and tested
//!   at mid-shutter through the lens centre: no blur, but the very same samples), the others with the
//!   defocus-only, motion-only or full one; all meet in one visibility buffer, so occlusion between
//!   paths is per sample. Without a geometry shader the stochastic path takes the compute-expanded
//!   hull;
//! * blur to simulate in a scene with what the stochastic frame does not render yet (shadow maps of
//!   moving casters: [`Plan::auto_frame`]), or tints on a device without a geometry shader (the tint
//!   pass draws behind it) → the `accumulation` technique, which renders all of it with the blur, S
//!   passes.

use super::accumulation::accumulation_passes;
use super::forward::ForwardTechnique;
use super::pinhole::{pinhole_passes, PINHOLE_MSAA};
use super::stochastic::{DebugOptions, StochasticTechnique};
use super::{
    FrameContext, FrameInputs, FrameTechnique, HullExpansion, PrepareContext, TechniqueCapabilities,
    TechniqueFrame, TechniqueInfo,
};
use crate::error::Result;
use crate::plan::{AutoFrame, Plan};

/// The registry entry.
pub const INFO: TechniqueInfo = TechniqueInfo {
    name: "auto",
    summary: "the effect planner decides per object: pinhole, defocus-only, motion-only or both stochastic \
              permutations in one frame; nothing to simulate = pinhole",
    // The pinhole path reads the forward frame's keys, the stochastic path the stochastic frame's; the
    // stochastic frame checks its features when the plan takes it.
    keys: &[super::forward::TRANSPARENCY_KEYS, super::stochastic::KEYS, super::shadow_maps::KEYS],
    required_features: &[],
    capabilities: TechniqueCapabilities {
        transparency: true,
        transparency_methods: false,
        embeddable: false,
    },
    prepare,
};

fn prepare(ctx: &PrepareContext<'_>) -> Result<Box<dyn FrameTechnique>> {
    let plan = Plan::for_view(ctx.scene, ctx.camera, crate::plan::DEFAULT_THRESHOLD_PX);
    let mut frame = plan.auto_frame().0;
    if frame == AutoFrame::Stochastic && plan.tinted_objects > 0 && !ctx.device.caps.geometry_shader {
        frame = AutoFrame::Accumulation;
    }
    match frame {
        AutoFrame::Pinhole => {
            let msaa = ctx.device.caps.msaa_samples(PINHOLE_MSAA);
            let inner = ForwardTechnique::new(ctx, msaa, pinhole_passes())?;
            return Ok(Box::new(Auto { plan, path: AutoPath::Pinhole(Box::new(inner)) }));
        }
        AutoFrame::Accumulation => {
            let (c, s) = (&ctx.scene.camera, ctx.settings);
            let passes = accumulation_passes(s.spp, s.seed, c.aperture, c.shutter);
            let inner = ForwardTechnique::new(ctx, 1, passes)?;
            return Ok(Box::new(Auto { plan, path: AutoPath::Pinhole(Box::new(inner)) }));
        }
        AutoFrame::Stochastic => {}
    }
    let effects = plan.effects();
    let mut options = ctx.settings.stochastic;
    if !ctx.device.caps.geometry_shader {
        options.expansion = HullExpansion::Compute;
    }
    let stochastic = StochasticTechnique::planned(ctx, options, DebugOptions::default(), &plan, &effects)?;
    Ok(Box::new(Auto { plan, path: AutoPath::Stochastic(Box::new(stochastic)) }))
}

enum AutoPath {
    /// Nothing to simulate: the `pinhole` technique itself; or blur with what only the forward path
    /// renders: the `accumulation` technique itself.
    Pinhole(Box<ForwardTechnique>),
    /// Every object on the stochastic path, each with its planned permutation.
    Stochastic(Box<StochasticTechnique>),
}

struct Auto {
    plan: Plan,
    path: AutoPath,
}

impl FrameTechnique for Auto {
    fn render(&mut self, inputs: &FrameInputs<'_>, frame: &mut FrameContext<'_>) -> Result<TechniqueFrame> {
        match &mut self.path {
            AutoPath::Pinhole(t) => t.render(inputs, frame),
            AutoPath::Stochastic(s) => s.render(inputs, frame),
        }
    }

    fn plan(&self) -> Option<&Plan> {
        Some(&self.plan)
    }

    fn transparency(&self) -> Option<crate::transparency::TransparencyMethod> {
        match &self.path {
            AutoPath::Pinhole(t) => t.transparency(),
            AutoPath::Stochastic(s) => s.transparency(),
        }
    }

    fn shadows(&self) -> Option<String> {
        match &self.path {
            AutoPath::Pinhole(t) => t.shadows(),
            AutoPath::Stochastic(s) => s.shadows(),
        }
    }

    fn coverage(&self) -> Option<super::stochastic::Coverage> {
        match &self.path {
            AutoPath::Pinhole(_) => None,
            AutoPath::Stochastic(s) => s.coverage(),
        }
    }
}
