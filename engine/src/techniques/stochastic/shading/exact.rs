//! The exact rates: every hit shaded from its own sample (per sample), or once per (triangle, side)
//! group of the pixel (per pixel, the reference's `ShadingRate::PerPixel`). Nothing to bind or prepare
//! beyond what the shading pass binds.

use super::{ShadeVariant, ShadingStage};
use crate::gpu::layout::ShaderInterface;
use crate::shaders::{ShadeExactComp, ShaderSource};
use crate::techniques::stochastic::layout::{STOCHASTIC_OBJECT_SET, STOCHASTIC_SET, STOCHASTIC_STRUCTS};
use crate::techniques::stochastic::ShadingRate;

pub(super) struct Exact {
    per_sample: bool,
}

impl Exact {
    pub fn new(rate: ShadingRate) -> Self {
        Exact { per_sample: rate == ShadingRate::PerSample }
    }
}

impl ShadingStage for Exact {
    fn shader(&self, v: ShadeVariant) -> ShaderSource {
        ShadeExactComp {
            per_sample: self.per_sample,
            instrumented: v.instrumented,
            effects: v.effects,
            shadows: v.shadows,
            shadow_color: v.shadow_color,
            tints: v.tints,
        }
        .source()
    }
}

/// `shade_exact.comp`'s interface: sets 2 and 3 of the stochastic frame, [`StochasticPush`], the shadow maps
/// as set 4.
pub(in crate::techniques::stochastic) const SHADER_INTERFACE: ShaderInterface = ShaderInterface::technique(
    &["stochastic/shade_exact.comp"],
    Some(&STOCHASTIC_OBJECT_SET),
    Some(&STOCHASTIC_SET),
    Some(STOCHASTIC_STRUCTS[0]),
)
.with_shadows(&crate::techniques::shadow_maps::SHADOW_SET);
