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
/// Largest scene file (TOML), bytes: a scene describes meshes and textures by path, so even a
/// thousand objects fit in a fraction of this. A bigger file is refused before it is read.
pub const MAX_SCENE_FILE_BYTES: u64 = 16 << 20;

/// Largest OBJ file, bytes (about 20 million triangles of text).
pub const MAX_OBJ_FILE_BYTES: u64 = 1 << 30;

/// Largest texture file (PNG), bytes.
pub const MAX_TEXTURE_FILE_BYTES: u64 = 256 << 20;

/// Largest image file `compare` and `convert` read (EXR or PNG), bytes: an 8192 × 8192 RGBA `f32`
/// EXR without compression is 1 GiB.
pub const MAX_IMAGE_FILE_BYTES: u64 = 2 << 30;

/// At most this many characters of one line of the input are quoted in an error message.
pub const MAX_QUOTED_LINE_CHARS: usize = 100;

/// Reads the file at `path` whole, refusing one larger than `max` bytes (named `limit_name`) before
/// reading it — and, for a file that grows or a device that reports no size, after `max + 1` bytes.
pub fn read_capped(path: &std::path::Path, max: u64, what: &str, limit_name: &str) -> crate::Result<Vec<u8>> {
    use std::io::Read;
    let too_big = |size: String| crate::Error::Limit {
        what: "file size",
        value: format!("{size} ({what} {})", path.display()),
        limit: format!("at most {} ({limit_name})", bytes_text(max)),
    };
    let file = std::fs::File::open(path).map_err(|e| crate::Error::io(path, e))?;
    let len = file.metadata().map(|m| m.len()).unwrap_or(0);
    if len > max {
        return Err(too_big(bytes_text(len)));
    }
    let mut bytes = Vec::with_capacity(len as usize);
    file.take(max + 1).read_to_end(&mut bytes).map_err(|e| crate::Error::io(path, e))?;
    if bytes.len() as u64 > max {
        return Err(too_big(format!("more than {}", bytes_text(max))));
    }
    Ok(bytes)
}

/// A byte count for people: `512 B`, `16.0 MiB`, `1.50 GiB`.
pub fn bytes_text(bytes: u64) -> String {
    const KIB: f64 = 1024.0;
    let b = bytes as f64;
    if b < KIB {
        format!("{bytes} B")
    } else if b < KIB * KIB {
        format!("{:.1} KiB", b / KIB)
    } else if b < KIB * KIB * KIB {
        format!("{:.1} MiB", b / (KIB * KIB))
    } else {
        format!("{:.2} GiB", b / (KIB * KIB * KIB))
    }
}

/// `message` (a parser's, which may quote the input) safe to print: every line cut to `max_chars`
/// characters (a 100 MB line of a hostile file stays out of the message), control characters
/// escaped (a raw escape sequence in the input does not reach the terminal).
pub fn quote_safely(message: &str, max_chars: usize) -> String {
    message
        .lines()
        .map(|line| {
            let mut out = String::new();
            for (chars, c) in line.chars().enumerate() {
                if chars == max_chars {
                    out.push_str(" […]");
                    break;
                }
                if c.is_control() && c != '\t' {
                    out.extend(c.escape_default());
                } else {
                    out.push(c);
                }
            }
            out
        })
        .collect::<Vec<_>>()
        .join("\n")
}

/// The environment variable that sets the memory Shutter may plan to use (bytes, or with a suffix
/// K, M, G: `8G`); default three quarters of the machine's physical memory.
pub const MEMORY_LIMIT_VAR: &str = "SHUTTER_MEMORY_LIMIT";

/// When the machine's memory cannot be read: 16 GiB.
const FALLBACK_MEMORY_BYTES: u64 = 16 << 30;

/// The memory a scene's load or a render may plan to use, bytes: [`MEMORY_LIMIT_VAR`] if set, else
/// three quarters of the machine's physical memory (`MemTotal` of `/proc/meminfo`), else 16 GiB.
/// Work whose estimate is larger is refused up front ([`check_memory`]) instead of aborting on an
/// allocation part-way.
pub fn memory_limit() -> crate::Result<u64> {
    if let Ok(value) = std::env::var(MEMORY_LIMIT_VAR) {
        let v = value.trim();
        let (digits, unit) = match v.char_indices().last() {
            Some((i, c)) if c.is_ascii_alphabetic() => (&v[..i], c.to_ascii_uppercase()),
            _ => (v, 'B'),
        };
        let scale: u64 = match unit {
            'B' => 1,
            'K' => 1 << 10,
            'M' => 1 << 20,
            'G' => 1 << 30,
            'T' => 1 << 40,
            _ => 0,
        };
        return match digits.parse::<u64>() {
            Ok(n) if n > 0 && scale > 0 => Ok(n.saturating_mul(scale)),
            _ => Err(crate::Error::Environment {
                name: MEMORY_LIMIT_VAR,
                value,
                expected: "a number of bytes > 0, optionally with K, M, G or T (e.g. 8G)",
            }),
        };
    }
    let total = std::fs::read_to_string("/proc/meminfo").ok().and_then(|text| {
        let line = text.lines().find(|l| l.starts_with("MemTotal:"))?;
        let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
        Some(kib * 1024)
    });
    Ok(total.map_or(FALLBACK_MEMORY_BYTES, |t| t / 4 * 3))
}

/// Refuses work estimated at `bytes` (for `what`, with how the figure arose in `detail`) when it
/// exceeds [`memory_limit`], with both figures.
pub fn check_memory(what: &str, bytes: u64, detail: &str) -> crate::Result<()> {
    let limit = memory_limit()?;
    if bytes <= limit {
        return Ok(());
    }
    let source = if std::env::var_os(MEMORY_LIMIT_VAR).is_some() {
        format!("set by {MEMORY_LIMIT_VAR}")
    } else {
        format!("3/4 of this machine's memory; {MEMORY_LIMIT_VAR} sets another")
    };
    Err(crate::Error::Limit {
        what: "memory",
        value: format!("about {} for {what} ({detail})", bytes_text(bytes)),
        limit: format!("at most {} ({source})", bytes_text(limit)),
    })
}
