//! Adaptive texture-space shading's pass 2: each hit looks its radiance up in its object's shading
//! atlas, which pass 1 (`techniques/texture_space.rs`, [`AtlasPasses`]) shades before the frame's
//! repeat — per sample, or once per (triangle, side) group of the pixel.

use ash::vk;
use bytemuck::{Pod, Zeroable};

use super::{DecoupledPhase, ShadePush, ShadeVariant, ShadingStage};
use crate::error::Result;
use crate::gpu::layout::Binding;
use crate::gpu::layout::{shared_struct, ShaderInterface, SharedStruct};
use crate::graph::{Access, FrameGraph, ResourceHandle};
use crate::shaders::{ShadeTextureSpaceComp, ShaderSource};
use crate::techniques::shadow_maps::{ShadowHandles, ShadowMaps};
use crate::techniques::stochastic::layout::{STOCHASTIC_OBJECT_SET, STOCHASTIC_SET};
use crate::techniques::stochastic::options::{ShadingRate, StochasticOptions};
use crate::techniques::stochastic::{TEXTURE_SPACE_FINEST, TEXTURE_SPACE_GUTTER};
use crate::techniques::texture_space::{self, AtlasPasses};
use crate::techniques::{FrameInputs, PrepareContext};
use crate::vk::{write_descriptors, DescriptorWrite, Device, Sampler};

/// Push constants of `shade_texture_space.comp`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub(super) struct TextureSpacePush {
    pub shade: ShadePush,
    /// The object's atlas layout ([`crate::mirror::texture_space::atlas::MipAtlas`]): level 0's side and the
    /// gutter (0 for the background).
    pub atlas_finest: u32,
    pub atlas_gutter: u32,
}

/// For the reflection test.
const TEXTURE_SPACE_PUSH: SharedStruct =
    shared_struct!("Push", TextureSpacePush, [shade, atlas_finest, atlas_gutter]);

pub(super) struct TextureSpaceLookup {
    per_sample: bool,
    /// Pass 1 and the sampler its atlases are read with.
    atlas: AtlasPasses,
    sampler: Sampler,
}

impl TextureSpaceLookup {
    /// Pass 1's atlases, shaded with the shadow maps (still casters).
    pub fn new(
        ctx: &PrepareContext<'_>,
        options: &StochasticOptions,
        shadows: Option<&ShadowMaps>,
    ) -> Result<Self> {
        let layout =
            crate::mirror::texture_space::atlas::MipAtlas::new(TEXTURE_SPACE_FINEST, TEXTURE_SPACE_GUTTER)?;
        let atlas = AtlasPasses::new(
            ctx,
            layout,
            texture_space::AtlasSize::Fitted,
            Some(texture_space::BILINEAR_HULL_TEXELS),
            texture_space::ATLAS_FORMAT,
            options.instrumented,
            shadows,
        )?;
        let sampler = Sampler::nearest_clamp(ctx.device, "texture-space atlas")?;
        let per_sample = options.shading == ShadingRate::TextureSpace;
        Ok(TextureSpaceLookup { per_sample, atlas, sampler })
    }
}

impl ShadingStage for TextureSpaceLookup {
    /// Lookups shade nothing: the shadow maps are pass 1's, so `v`'s shadow axes do not apply.
    fn shader(&self, v: ShadeVariant) -> ShaderSource {
        ShadeTextureSpaceComp {
            per_sample: self.per_sample,
            instrumented: v.instrumented,
            effects: v.effects,
            tints: v.tints,
        }
        .source()
    }

    fn object_bindings(&self) -> &'static [Binding] {
        &STOCHASTIC_OBJECT_SET
    }

    /// Set 2, bindings 5–7: each object's atlas, levels and shading coordinates.
    fn write_sets(
        &self,
        device: &Device,
        _technique_set: vk::DescriptorSet,
        object_sets: &[vk::DescriptorSet],
    ) {
        for (i, &set) in object_sets.iter().enumerate() {
            if let Some((image, levels, coords)) = self.atlas.object_resources(i) {
                write_descriptors(
                    device,
                    set,
                    &[
                        DescriptorWrite::SampledImage {
                            binding: 5,
                            view: image.view,
                            sampler: self.sampler.raw,
                        },
                        DescriptorWrite::storage_buffer(6, levels),
                        DescriptorWrite::storage_buffer(7, coords),
                    ],
                );
            }
        }
    }

    fn before_frame(&mut self) -> Result<()> {
        self.atlas.reset_counters()
    }

    /// Pass 1 of every object; the lookups read each atlas and its levels.
    fn add_frame_passes<'a>(
        &'a self,
        g: &mut FrameGraph<'a>,
        inputs: &FrameInputs<'a>,
        shadows: Option<ShadowHandles>,
    ) -> Vec<(ResourceHandle, Access)> {
        let mut uses = Vec::new();
        for h in self.atlas.add_passes(g, inputs, shadows).into_iter().flatten() {
            uses.push((h.color.into(), Access::ComputeShaderReadSampledImageOrUniformTexelBuffer));
            uses.push((h.levels.into(), Access::ComputeShaderReadOther));
        }
        uses
    }

    fn push_size(&self) -> u32 {
        std::mem::size_of::<TextureSpacePush>() as u32
    }

    fn push(&self, shade: ShadePush, _phase: DecoupledPhase) -> Vec<u8> {
        let atlas = self.atlas.object_atlas(shade.object as usize);
        bytemuck::bytes_of(&TextureSpacePush {
            shade,
            atlas_finest: atlas.map_or(0, |a| a.finest()),
            atlas_gutter: atlas.map_or(0, |a| a.gutter()),
        })
        .to_vec()
    }

    fn atlas_texels(&self) -> Result<Option<(u64, u64)>> {
        self.atlas.counters()
    }
}

/// `shade_texture_space.comp`'s interface: sets 2 and 3 of the stochastic frame, [`TextureSpacePush`] (no
/// shadow maps: pass 1 shaded with them).
pub(in crate::techniques::stochastic) const SHADER_INTERFACE: ShaderInterface = ShaderInterface::technique(
    &["stochastic/shade_texture_space.comp"],
    Some(&STOCHASTIC_OBJECT_SET),
    Some(&STOCHASTIC_SET),
    Some(TEXTURE_SPACE_PUSH),
);
