//! The exact rates: every hit shaded from its own sample (per sample), or once per (triangle, side)
//! group of the pixel (per pixel, the reference's `ShadingRate::PerPixel`). Nothing to bind or prepare
//! beyond what the shading pass binds.

use super::{ShadeVariant, ShadingStage};
use crate::shaders::{ShadeExactComp, ShaderSource};
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
