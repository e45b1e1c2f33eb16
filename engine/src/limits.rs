//! Size and sample-count limits, in one place, so that the scene file ([`crate::scene::file`]), the CPU
//! reference ([`crate::reference`]) and the GPU techniques ([`crate::techniques`]) cannot drift apart.
//! The techniques are stricter where a device or a technique needs it: the image size is also clamped
//! to the device's `maxImageDimension2D`, and `stochastic` takes at most [`MAX_STOCHASTIC_SPP`].

/// Largest image width or height, in pixels: an 8192 × 8192 frame is already 1 GiB as a linear
/// RGBA `f32` image ([`crate::image::LinearImage`], what the reference renders and readbacks land in).
pub const MAX_IMAGE_DIMENSION: u32 = 8192;

/// Largest samples per pixel (2¹⁶): a 1D stratum of the sample sets is then 2⁻¹⁶ wide, which still
/// leaves at least 8 of an `f32`'s 24 significand bits for the jitter inside it
/// (`sampling::stratum_value`).
pub const MAX_SPP: u32 = 65536;

/// Largest S the stochastic technique accepts (the sample tile is 64·64·S·20 bytes: 84 MB at 1024).
pub const MAX_STOCHASTIC_SPP: u32 = 1024;

/// Most transform keys an object's motion may have (the scene file's `motion_keys` and
/// `[[object.transform_key]]` together, plus the shutter ends): each key adds a camera-space copy of
/// every triangle for the stochastic rasterizer and a bounding-volume hierarchy for the reference.
pub const MAX_MOTION_KEYS: usize = 64;
