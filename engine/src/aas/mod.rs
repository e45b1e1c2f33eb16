//! Adaptive anisotropic shading (Vaidyanathan, Toth, Salvi, Boulos & Lefohn, "Adaptive Image Space
//! Shading for Motion and Defocus Blur", HPG 2012; `../shared/seeds/002_3da788667dc51ec5.txt`), the CPU
//! side, written before any GPU port (issue 14): how much a triangle's shading may be bandlimited given
//! the blur the camera applies to it, and the anisotropic screen-space grid that samples it.
//!
//! * [`spectrum`]: the cutoffs of the aperture (sharp disk, the paper's smooth lens), the shutter and
//!   the reconstruction filter — the constants of a camera;
//! * [`bounds`]: per triangle, the smallest circle of confusion, the smallest speed and the span of
//!   motion directions, and from them the oriented shading grid.
//!
//! Not yet here (issue 14): the grid plugged into decoupled shading ([`crate::decoupled`], which keys
//! samples by pixel cells for now) and into Liktor & Dachsbacher's compact cache; their GPU ports.

pub mod bounds;
pub mod spectrum;
