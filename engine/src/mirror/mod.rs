//! The CPU mirrors: each module here is the specification of one GPU technique's own math, written
//! first, property-tested, and then ported to GLSL. Its GPU host — the pipelines, buffers and passes
//! that run the port — lives under [`crate::techniques`], under the same name where the technique has
//! one file; tests compare the two through buffers read back or images.
//!
//! | mirror (CPU, here) | its GPU host | its shaders (`shaders-glsl/`) |
//! |---|---|---|
//! | [`bounds`]: the screen-space bounds over lens and shutter, the 5D inside test | [`crate::techniques::stochastic`] (its visibility core) and [`crate::techniques::compute_hull`] | `stochastic/` (`emit.glsl`, `inside.glsl`, `expand.comp`) |
//! | [`conservative`]: who dilates a conservative hull — the shader, or the rasterizer's overestimation (`VK_EXT_conservative_rasterization`) | the stochastic frame's coverage pipelines and texture-space pass 1's outer hull | `stochastic/emit.glsl`, `texture_space/atlas.geom` |
//! | [`texture_space`]: atlases, shading rates, culling, filtering | [`crate::techniques::texture_space`] (the probes) and the stochastic frame's texture-space shading stage | `texture_space/`, `stochastic/shade_texture_space.comp` |
//! | [`decoupled`]: shading points and the memoization cache | the stochastic frame's decoupled shading stage | `stochastic/shade_decoupled.comp` |
//! | [`aas`]: the blur spectrum and the anisotropic shading grids that key decoupled shading | the same stage (`shading=aas`, the grids computed here on the CPU and uploaded) | `stochastic/shade_decoupled.comp` |
//! | [`interleaved`]: interleaved deferred shading of virtual point lights | [`crate::techniques::interleaved`] | `interleaved/` |
//! | [`shadow_maps`]: which lights get which maps, the atlas layout, the lookup | [`crate::techniques::shadow_maps`] | `common/shadow.glsl` |
//!
//! What every technique and the CPU reference share — the scene model's shading
//! ([`crate::shading`]), the moving triangle and its intersector ([`crate::geometry`]), the sample
//! sets ([`crate::sampling`]) and stochastic coverage ([`crate::transparency`]) — is the model
//! itself, not one technique's mirror, and stays beside it.

pub mod aas;
pub mod bounds;
pub mod conservative;
pub mod decoupled;
pub mod interleaved;
pub mod shadow_maps;
pub mod texture_space;
