//! Adaptive anisotropic shading (Vaidyanathan, Toth, Salvi, Boulos & Lefohn, "Adaptive Image Space
//! Shading for Motion and Defocus Blur", HPG 2012), the CPU
//! side, written before any GPU port (issue 14): how much a triangle's shading may be bandlimited given
//! the blur the camera applies to it, and the anisotropic screen-space grid that samples it.
//!
//! * [`spectrum`]: the cutoffs of the aperture (sharp disk, the paper's smooth lens), the shutter and
//!   the reconstruction filter — the constants of a camera;
//! * [`bounds`]: per triangle, the smallest circle of confusion, the smallest speed and the span of
//!   motion directions, and from them the oriented shading grid.
//!
//! The grid keys decoupled shading's samples in `--shading aas` and `aas-isotropic`
//! ([`crate::mirror::decoupled::object_grids`], computed on the CPU per frame and uploaded; the GPU only reads
//! it). Not yet here (issue 14): a GPU port of the bounds, and the grid in Liktor & Dachsbacher's
//! deferred variant.

pub mod bounds;
pub mod spectrum;
