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

/// Largest ratio far / near of a camera's clip distances. The GPU's reversed-Z depth is about
/// near / z, kept off 0 at the far plane by a floor a relative 2⁻²⁰ of view depth inside it
/// (`thin_lens_clip` in `shaders-glsl/common/camera.glsl`, [`crate::scene::Intrinsics::reversed_z`]),
/// about (near / far)·2⁻²⁰: at 10¹² that is 10⁻¹⁸, still a normal `f32` with its 24 bits, so depth
/// stays ordered over the whole range (a floor in the subnormals would lose them). 1 mm to 10⁹ m
/// ([`MAX_COORDINATE`]) fits.
pub const MAX_FAR_OVER_NEAR: f32 = 1e12;

/// Smallest camera near distance: with [`MAX_FAR_OVER_NEAR`] it keeps every clip-space depth of the
/// thin lens (and its far-plane floor, about near·2⁻²⁰) a normal `f32`.
pub const MIN_NEAR: f32 = 1e-9;

/// Largest magnitude of any coordinate of the scene, in scene units (metres): mesh vertices placed by
/// their object's transform at every key, and the camera's and lights' positions. The inside tests
/// (Möller–Trumbore on the GPU and in the reference) square lengths of cross products of edges, the
/// fourth power of a coordinate: at 10⁹ (edges up to 4·10⁹ in camera space) that is at most
/// 2.6·10³⁸, just inside `f32`; beyond it the reference drops triangles the rasterizers draw.
pub const MAX_COORDINATE: f32 = 1e9;

/// Largest value of any colour-like quantity of the scene: light colours, albedo, specular weight,
/// ambient and background. A point light's 1/d² is capped at 10⁸ (d² ≥ 10⁻⁸,
/// [`crate::shading::ShadingLight::incident`]) and the Blinn-Phong normalisation at about 400, so one
/// light reflects at most ~4·10²² and the sum over every light and sample stays far from `f32::MAX`
/// (two lights of colour 3·10³⁸ made Inf pixels in every technique).
pub const MAX_COLOR: f32 = 1e6;
