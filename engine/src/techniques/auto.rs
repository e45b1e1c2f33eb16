//! Technique `auto`, the default: simulate only what the scene calls for. The effect planner
//! ([`crate::plan`]) gives every object a path; this file composes the paths' draws into one
//! multipass frame:
//!
//! * nothing to simulate anywhere → exactly the `pinhole` technique (same passes, same image, same
//!   cost);
//! * otherwise S = M × P samples per pixel: the still, sharp objects on the plain forward path
//!   ([`ForwardDraws`], one Hammersley sub-pixel offset per pass: [`pinhole_pass_jitter`]) and the
//!   others on the stochastic path, one shader permutation per effect set ([`StochasticDraws`]), drawn
//!   into the same MSAA targets with the same reversed-Z depth in every pass. Without a geometry
//!   shader the stochastic path takes the compute-expanded hull.

use super::forward::{ForwardDraws, ForwardTechnique, PassSample};
use super::multipass::{MultipassFrame, PassDraws};
use super::pinhole::{pinhole_pass_jitter, pinhole_passes, PINHOLE_MSAA};
use super::stochastic::{DebugOptions, StochasticDraws};
use super::{
    FrameContext, FrameInputs, FrameTechnique, HullExpansion, PrepareContext, TechniqueFrame, TechniqueInfo,
};
use crate::error::Result;
use crate::plan::{Effects, Plan};

/// The registry entry.
pub const INFO: TechniqueInfo = TechniqueInfo {
    name: "auto",
    summary: "the effect planner decides per object: pinhole, defocus-only, motion-only or both stochastic \
              permutations in one frame; nothing to simulate = pinhole",
    prepare,
};

fn prepare(ctx: &PrepareContext<'_>) -> Result<Box<dyn FrameTechnique>> {
    let plan = Plan::for_view(ctx.scene, ctx.camera, crate::plan::DEFAULT_THRESHOLD_PX);
    if !plan.needs_stochastic() {
        let msaa = ctx.device.caps.msaa_samples(PINHOLE_MSAA);
        let inner = ForwardTechnique::new(ctx, msaa, pinhole_passes())?;
        return Ok(Box::new(Auto { plan, path: AutoPath::Pinhole(Box::new(inner)) }));
    }
    let effects = plan.effects();
    let mut options = ctx.settings.stochastic;
    if !ctx.device.caps.geometry_shader {
        options.expansion = HullExpansion::Compute;
    }
    let stochastic = StochasticDraws::new(ctx, options, DebugOptions::default(), &effects)?;
    let (msaa, passes) = stochastic.msaa_and_passes();
    let plain = if effects.contains(&Effects::Pinhole) {
        let samples = (0..passes)
            .map(|p| PassSample { jitter: pinhole_pass_jitter(p, passes, msaa), ..pinhole_passes()[0] })
            .collect();
        let include = effects.iter().map(|&e| e == Effects::Pinhole).collect();
        Some(ForwardDraws::new(ctx.device, ctx.world, msaa, samples, include)?)
    } else {
        None
    };
    let frame = MultipassFrame::new(ctx.device, ctx.world, ctx.camera.size(), msaa, passes, "stochastic")?;
    Ok(Box::new(Auto { plan, path: AutoPath::Composed(Box::new(Composed { frame, plain, stochastic })) }))
}

enum AutoPath {
    /// Nothing to simulate: the `pinhole` technique itself.
    Pinhole(Box<ForwardTechnique>),
    /// The plain and the stochastic paths in one multipass frame.
    Composed(Box<Composed>),
}

struct Composed {
    frame: MultipassFrame,
    plain: Option<ForwardDraws>,
    stochastic: StochasticDraws,
}

struct Auto {
    plan: Plan,
    path: AutoPath,
}

impl FrameTechnique for Auto {
    fn render(&mut self, inputs: &FrameInputs<'_>, frame: &mut FrameContext<'_>) -> Result<TechniqueFrame> {
        match &mut self.path {
            AutoPath::Pinhole(t) => t.render(inputs, frame),
            AutoPath::Composed(c) => {
                let Composed { frame: passes, plain, stochastic } = &mut **c;
                stochastic.before_frame(inputs, frame)?;
                // The plain path first: at equal depth the first drawn wins (GREATER), as before.
                let mut draws: Vec<&dyn PassDraws> = Vec::with_capacity(2);
                if let Some(p) = plain.as_ref() {
                    draws.push(p);
                }
                draws.push(&*stochastic);
                let image = passes.render(frame, inputs, &draws)?;
                Ok(passes.technique_frame(image, stochastic.counters()?))
            }
        }
    }

    fn plan(&self) -> Option<&Plan> {
        Some(&self.plan)
    }
}
