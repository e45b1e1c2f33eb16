//! The exact rates: every hit shaded from its own sample (per sample), or once per (triangle, side)
//! group of the pixel (per pixel, the reference's `ShadingRate::PerPixel`). Nothing to bind or prepare
//! beyond what the shading pass binds.

use bytemuck::{Pod, Zeroable};

use super::{DecoupledPhase, ShadePush, ShadeVariant, ShadingStage};
use crate::gpu::layout::{shared_struct, ShaderInterface, SharedStruct};
use crate::shaders::{ShadeExactComp, ShaderSource};
use crate::techniques::stochastic::layout::{STOCHASTIC_OBJECT_SET, STOCHASTIC_SET};
use crate::techniques::stochastic::ShadingRate;

/// Push constants of `shade_exact.comp`: the shading stages' common fields only.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub(super) struct ExactPush {
    pub shade: ShadePush,
}

/// For the reflection test.
const EXACT_PUSH: SharedStruct = shared_struct!("Push", ExactPush, [shade]);

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

    fn push_size(&self) -> u32 {
        std::mem::size_of::<ExactPush>() as u32
    }

    fn push(&self, shade: ShadePush, _phase: DecoupledPhase) -> Vec<u8> {
        bytemuck::bytes_of(&ExactPush { shade }).to_vec()
    }
}

/// `shade_exact.comp`'s interface: sets 2 and 3 of the stochastic frame, [`ExactPush`], the shadow maps as
/// set 4.
pub(in crate::techniques::stochastic) const SHADER_INTERFACE: ShaderInterface = ShaderInterface::technique(
    &["stochastic/shade_exact.comp"],
    Some(&STOCHASTIC_OBJECT_SET),
    Some(&STOCHASTIC_SET),
    Some(EXACT_PUSH),
)
.with_shadows(&crate::techniques::shadow_maps::SHADOW_SET);
