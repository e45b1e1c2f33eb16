//! Adaptive texture-space shading (Andersson, Hasselgren, Toth & Akenine-Möller, EG 2014), the CPU
//! side first: what the GPU passes will mirror (docs/ATSS.md says what exists and what does not yet).
//!
//! * [`atlas`]: an object's shading space (its own uvs when unique, else generated per-triangle
//!   charts) and its shading texture, a mip hierarchy laid out by hand in one image.
//! * [`rate`]: the per-triangle shading rate — the AAS grid spacing from the smallest circle of
//!   confusion, the footprint's minor radius at the vertices, the level `⌊log₂ r⌋` — and a measure of
//!   the paper's conjecture that the minimum over a triangle is at a vertex.
//! * [`cull`]: conservative frustum culling of a triangle over every lens point and shutter time.
//! * [`filter`]: the generalised Loviscach pre-filter over (x, y, u, v, t) and its per-sample scaling.

pub mod atlas;
pub mod cull;
pub mod filter;
pub mod rate;
