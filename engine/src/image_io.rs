//! Image files: linear OpenEXR and sRGB-encoded PNG, in and out of [`LinearImage`].
//!
//! EXR holds linear light as written (RGBA, 32-bit float, lossless, scan lines in increasing order, so
//! the same image always gives the same bytes). PNG holds 8-bit sRGB: writing clamps each linear colour
//! channel to [0, 1], sRGB-encodes it and rounds to the nearest code; alpha is stored linearly.
//! [`load_image`] recognises the format by the file's leading bytes, not by its name.
//!
//! Writing is all or nothing: the file is encoded in memory, written to a temporary file beside the
//! target, synced and renamed over it ([`write_file_atomically`]), so a full disk or a crash never
//! leaves a truncated image nor destroys the previous one. [`check_image_output`] checks a path
//! (extension, folder, permission) before any rendering starts.

use std::fs::File;
use std::io::{Cursor, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use crate::error::{Error, Result};
use crate::image::LinearImage;
use crate::scene::texture::{linear_to_srgb, srgb_to_linear};

/// The file extensions [`save_image`] understands.
pub const SUPPORTED_EXTENSIONS: &[&str] = &["exr", "png"];

const EXR_MAGIC: [u8; 4] = [0x76, 0x2f, 0x31, 0x01];
const PNG_MAGIC: [u8; 8] = [0x89, b'P', b'N', b'G', 0x0d, 0x0a, 0x1a, 0x0a];

fn image_error(path: &Path, message: impl Into<String>) -> Error {
    Error::Image { path: path.to_path_buf(), message: message.into() }
}

/// Encodes a linear value to an 8-bit sRGB code: clamped to [0, 1], rounded to nearest (NaN → 0).
fn encode_srgb8(linear: f32) -> u8 {
    let v = (linear_to_srgb(linear) * 255.0).round();
    if v.is_nan() {
        0
    } else {
        v.clamp(0.0, 255.0) as u8
    }
}

/// Encodes a linear alpha to 8 bits: clamped to [0, 1], rounded to nearest (NaN → 0).
fn encode_alpha8(alpha: f32) -> u8 {
    let v = (alpha.clamp(0.0, 1.0) * 255.0).round();
    if v.is_nan() {
        0
    } else {
        v as u8
    }
}

/// The image's colour as tightly packed 8-bit sRGB RGB, row-major, top row first (alpha dropped).
///
/// Each linear channel is clamped to [0, 1], sRGB-encoded and rounded to the nearest code; NaN maps to 0.
pub fn to_srgb8(image: &LinearImage) -> Vec<u8> {
    image.pixels.iter().flat_map(|p| [encode_srgb8(p[0]), encode_srgb8(p[1]), encode_srgb8(p[2])]).collect()
}

fn check_size(path: &Path, image: &LinearImage) -> Result<()> {
    let expected = image.width as usize * image.height as usize;
    if image.width == 0 || image.height == 0 || image.pixels.len() != expected {
        return Err(image_error(
            path,
            format!(
                "cannot write a {}×{} image holding {} pixels (need a non-empty image with width × height pixels)",
                image.width,
                image.height,
                image.pixels.len()
            ),
        ));
    }
    Ok(())
}

fn output_error(path: &Path, message: impl Into<String>) -> Error {
    Error::Output { path: path.to_path_buf(), message: message.into() }
}

/// The folder a file at `path` lands in (`.` for a bare file name).
fn parent_dir(path: &Path) -> &Path {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    }
}

/// A fresh name beside `path` for the temporary file of an atomic write: hidden, with the process id
/// and a counter, so concurrent writers (threads or processes) never share one.
fn temp_sibling(path: &Path) -> PathBuf {
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let n = COUNTER.fetch_add(1, Ordering::Relaxed);
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_else(|| "output".into());
    parent_dir(path).join(format!(".{name}.{}-{n}.tmp", std::process::id()))
}

/// Checks that a file can be written at `path` before any work is done: its folder exists, is a
/// folder and lets us create a file (probed by creating and removing one), and `path` is neither a
/// folder nor a read-only file. The error names the path and what is wrong.
pub fn check_output_file(path: impl AsRef<Path>) -> Result<()> {
    let path = path.as_ref();
    if path.file_name().is_none() {
        return Err(output_error(path, "the path names no file"));
    }
    if path.is_dir() {
        return Err(output_error(path, "it is a folder; give a file name"));
    }
    // A device or a pipe (itself or behind a link) is written through, not replaced: it needs no new
    // file in its folder (`/dev` is not ours to write in), only to be writable.
    match Target::of(path)? {
        Target::File => {}
        Target::Stream(kind) => {
            if kind == "character device" {
                // Opening a character device is harmless (no truncation); a pipe is not opened here,
                // which would wait for a reader.
                std::fs::OpenOptions::new()
                    .write(true)
                    .open(path)
                    .map_err(|e| output_error(path, format!("cannot open the {kind} for writing: {e}")))?;
            }
            return Ok(());
        }
    }
    let dir = parent_dir(path);
    match std::fs::metadata(dir) {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            return Err(output_error(path, format!("the folder `{}` does not exist", dir.display())));
        }
        Err(e) => return Err(output_error(path, format!("cannot read the folder `{}`: {e}", dir.display()))),
        Ok(m) if !m.is_dir() => {
            return Err(output_error(path, format!("`{}` is not a folder", dir.display())));
        }
        Ok(_) => {}
    }
    if std::fs::metadata(path).is_ok_and(|m| m.permissions().readonly()) {
        return Err(output_error(path, "the file exists and is read-only"));
    }
    let probe = temp_sibling(path);
    match std::fs::OpenOptions::new().write(true).create_new(true).open(&probe) {
        Ok(file) => {
            drop(file);
            let _ = std::fs::remove_file(&probe);
            Ok(())
        }
        Err(e) => Err(output_error(path, format!("cannot create a file in `{}`: {e}", dir.display()))),
    }
}

/// [`check_output_file`] for an image: also that the extension is one [`save_image`] writes.
pub fn check_image_output(path: impl AsRef<Path>) -> Result<()> {
    let path = path.as_ref();
    output_format(path)?;
    check_output_file(path)
}

/// What an output path names, through any symbolic link.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Target {
    /// A regular file, or nothing yet: written atomically.
    File,
    /// A character device (`/dev/null`, a terminal) or a named pipe: written through, in place, as a
    /// shell's `>` would — replacing it by a regular file would destroy the node.
    Stream(&'static str),
}

impl Target {
    /// What `path` names; a block device, a socket or anything else that is neither a file nor a
    /// stream is refused (an image written over a disk is never what was meant).
    fn of(path: &Path) -> Result<Target> {
        let Ok(meta) = std::fs::metadata(path) else { return Ok(Target::File) };
        if meta.is_file() {
            return Ok(Target::File);
        }
        #[cfg(unix)]
        {
            use std::os::unix::fs::FileTypeExt;
            let t = meta.file_type();
            if t.is_char_device() {
                return Ok(Target::Stream("character device"));
            }
            if t.is_fifo() {
                return Ok(Target::Stream("named pipe"));
            }
            let kind = if t.is_block_device() {
                "a block device"
            } else if t.is_socket() {
                "a socket"
            } else if t.is_dir() {
                "a folder"
            } else {
                "not a regular file"
            };
            return Err(output_error(
                path,
                format!("it is {kind}; Shutter writes regular files, character devices and named pipes"),
            ));
        }
        #[allow(unreachable_code)]
        Err(output_error(path, "it is not a regular file"))
    }
}

/// Writes `bytes` to `path` all or nothing: into a temporary file beside it, synced, then renamed over
/// it. On any failure (a full disk, a lost permission) the temporary file is removed and a previous
/// file at `path` is left as it was; the error names `path`. A previous file's permissions are kept,
/// and a symbolic link at `path` is written through (its target replaced, the link kept), as an
/// in-place write would. A character device or a named pipe (at `path` or behind its link) is
/// written into in place — it cannot be replaced without destroying it — and a block device or a
/// socket is refused.
pub fn write_file_atomically(path: impl AsRef<Path>, bytes: &[u8]) -> Result<()> {
    write_atomically_with(path.as_ref(), |file| file.write_all(bytes))
}

/// [`write_file_atomically`] with the writing done by `write` into the open temporary file (tests
/// inject a writer that fails part-way).
pub(crate) fn write_atomically_with(
    path: &Path,
    write: impl FnOnce(&mut File) -> std::io::Result<()>,
) -> Result<()> {
    // Through a symbolic link to what it names (a dangling one: to where it points).
    let resolved;
    let path = match std::fs::symlink_metadata(path) {
        Ok(m) if m.file_type().is_symlink() => {
            resolved = std::fs::canonicalize(path)
                .or_else(|_| std::fs::read_link(path).map(|to| parent_dir(path).join(to)));
            resolved.as_deref().map_err(|e| output_error(path, format!("cannot follow the link: {e}")))?
        }
        _ => path,
    };
    if let Target::Stream(kind) = Target::of(path)? {
        let mut stream = std::fs::OpenOptions::new()
            .write(true)
            .open(path)
            .map_err(|e| output_error(path, format!("cannot open the {kind} for writing: {e}")))?;
        return write(&mut stream)
            .and_then(|()| stream.flush())
            .map_err(|e| output_error(path, format!("writing into the {kind} failed: {e}")));
    }
    let permissions = std::fs::metadata(path).ok().map(|m| m.permissions());
    let temp = temp_sibling(path);
    let mut file = std::fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(&temp)
        .map_err(|e| output_error(path, format!("cannot create `{}`: {e}", temp.display())))?;
    let written = write(&mut file)
        .and_then(|()| permissions.map_or(Ok(()), |p| file.set_permissions(p)))
        .and_then(|()| file.sync_all());
    drop(file);
    let renamed = written.and_then(|()| std::fs::rename(&temp, path));
    if let Err(e) = renamed {
        let _ = std::fs::remove_file(&temp);
        return Err(output_error(
            path,
            format!("{e}; nothing was written (a previous file is left as it was)"),
        ));
    }
    Ok(())
}

/// The EXR encoding: lossless ZIP over blocks of 16 scan lines (zlib after a byte predictor; rendered
/// f32 images come out at about half their raw size, where RLE saved nothing — small enough for the
/// expected images `shutter check` keeps in the repository), scan lines stored in increasing order.
/// The order makes the bytes a function of the pixels: with `Unspecified` the encoder writes chunks
/// as its threads finish them.
const EXR_ENCODING: exr::prelude::Encoding = exr::prelude::Encoding {
    compression: exr::prelude::Compression::ZIP16,
    blocks: exr::prelude::Blocks::ScanLines,
    line_order: exr::prelude::LineOrder::Increasing,
};

/// `image` encoded as OpenEXR (see [`write_exr`]); the same pixels always give the same bytes.
pub fn encode_exr(image: &LinearImage) -> Result<Vec<u8>> {
    encode_exr_naming(Path::new("(EXR in memory)"), image)
}

/// [`encode_exr`] with errors naming `path`.
fn encode_exr_naming(path: &Path, image: &LinearImage) -> Result<Vec<u8>> {
    use exr::prelude::{Image, SpecificChannels, Vec2, WritableImage};
    check_size(path, image)?;
    let width = image.width as usize;
    let channels = SpecificChannels::rgba(|Vec2(x, y): Vec2<usize>| {
        let p = image.pixels[y * width + x];
        (p[0], p[1], p[2], p[3])
    });
    let exr_image = Image::from_encoded_channels((width, image.height as usize), EXR_ENCODING, channels);
    let mut bytes = Vec::new();
    exr_image
        .write()
        .to_buffered(Cursor::new(&mut bytes))
        .map_err(|e| image_error(path, format!("cannot encode EXR: {e}")))?;
    Ok(bytes)
}

/// Writes `image` as an OpenEXR file: linear RGBA, 32-bit float per channel, lossless, byte-identical
/// for identical pixels; all or nothing ([`write_file_atomically`]).
pub fn write_exr(path: impl AsRef<Path>, image: &LinearImage) -> Result<()> {
    let path = path.as_ref();
    let bytes = encode_exr_naming(path, image)?;
    write_file_atomically(path, &bytes)
}

/// Writes `image` as an 8-bit sRGB PNG.
///
/// Colour is clamped to [0, 1], sRGB-encoded and rounded to the nearest code (see [`to_srgb8`]). The file
/// is RGB when every alpha is 1, RGBA (alpha stored linearly) otherwise. All or nothing
/// ([`write_file_atomically`]).
pub fn write_png(path: impl AsRef<Path>, image: &LinearImage) -> Result<()> {
    let path = path.as_ref();
    check_size(path, image)?;
    let opaque = image.pixels.iter().all(|p| p[3] == 1.0);
    let (data, color) = if opaque {
        (to_srgb8(image), image::ExtendedColorType::Rgb8)
    } else {
        let data = image
            .pixels
            .iter()
            .flat_map(|p| [encode_srgb8(p[0]), encode_srgb8(p[1]), encode_srgb8(p[2]), encode_alpha8(p[3])])
            .collect();
        (data, image::ExtendedColorType::Rgba8)
    };
    let mut bytes = Vec::new();
    {
        use image::ImageEncoder;
        image::codecs::png::PngEncoder::new(&mut bytes)
            .write_image(&data, image.width, image.height, color)
            .map_err(|e| image_error(path, format!("cannot encode PNG: {e}")))?;
    }
    write_file_atomically(path, &bytes)
}

/// The image formats [`save_image`] writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum OutputFormat {
    Exr,
    Png,
}

/// The format named by the path's extension, case-insensitive; an error lists the supported ones.
fn output_format(path: &Path) -> Result<OutputFormat> {
    let ext = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
    match ext.as_deref() {
        Some("exr") => Ok(OutputFormat::Exr),
        Some("png") => Ok(OutputFormat::Png),
        other => Err(image_error(
            path,
            format!(
                "unsupported image extension {}; supported extensions: {}",
                other.map_or_else(|| "(none)".to_string(), |e| format!("`.{e}`")),
                SUPPORTED_EXTENSIONS.iter().map(|e| format!(".{e}")).collect::<Vec<_>>().join(", ")
            ),
        )),
    }
}

/// Writes `image` in the format named by the path's extension (`.exr` or `.png`, case-insensitive), all
/// or nothing ([`write_file_atomically`]).
pub fn save_image(path: impl AsRef<Path>, image: &LinearImage) -> Result<()> {
    save_image_displayed(path, image, &crate::tonemap::Display::LINEAR)
}

/// [`save_image`] for a person to look at: a PNG through `display` (exposure, then tone curve, then the
/// sRGB encoding of [`write_png`]); an EXR linear as rendered, whatever `display` says.
pub fn save_image_displayed(
    path: impl AsRef<Path>,
    image: &LinearImage,
    display: &crate::tonemap::Display,
) -> Result<()> {
    let path = path.as_ref();
    match output_format(path)? {
        OutputFormat::Exr => write_exr(path, image),
        OutputFormat::Png if display.is_linear() => write_png(path, image),
        OutputFormat::Png => write_png(path, &display.apply(image)),
    }
}

/// Reads an EXR (linear, first RGBA layer, full resolution; missing alpha reads as 1) or a PNG (8- or
/// 16-bit, grey / grey+alpha / RGB / RGBA; colour sRGB-decoded to linear, alpha taken as linear).
///
/// The format is recognised from the file's contents. Every error names the path.
pub fn load_image(path: impl AsRef<Path>) -> Result<LinearImage> {
    let path = path.as_ref();
    let bytes = crate::limits::read_capped(
        path,
        crate::limits::MAX_IMAGE_FILE_BYTES,
        "image file",
        "MAX_IMAGE_FILE_BYTES",
    )?;
    if bytes.starts_with(&EXR_MAGIC) {
        decode_exr(path, bytes)
    } else if bytes.starts_with(&PNG_MAGIC) {
        decode_png(path, &bytes)
    } else {
        Err(image_error(path, "not an OpenEXR or PNG file (unrecognised leading bytes)"))
    }
}

fn decode_exr(path: &Path, bytes: Vec<u8>) -> Result<LinearImage> {
    use exr::prelude::{read, ReadChannels, ReadLayers, RgbaChannels, Vec2};
    let decoded = read()
        .no_deep_data()
        .largest_resolution_level()
        .rgba_channels(
            |resolution: Vec2<usize>, _: &RgbaChannels| {
                LinearImage::new(resolution.width() as u32, resolution.height() as u32)
            },
            |image: &mut LinearImage, Vec2(x, y): Vec2<usize>, (r, g, b, a): (f32, f32, f32, f32)| {
                image.set(x as u32, y as u32, [r, g, b, a]);
            },
        )
        .first_valid_layer()
        .all_attributes()
        .from_buffered(Cursor::new(bytes))
        .map_err(|e| image_error(path, format!("cannot decode EXR: {e}")))?;
    Ok(decoded.layer_data.channel_data.pixels)
}

fn decode_png(path: &Path, bytes: &[u8]) -> Result<LinearImage> {
    let decoded = image::load_from_memory_with_format(bytes, image::ImageFormat::Png)
        .map_err(|e| image_error(path, format!("cannot decode PNG: {e}")))?;
    let (width, height) = (decoded.width(), decoded.height());
    let pixels: Vec<[f32; 4]> = if decoded.color().bytes_per_pixel() / decoded.color().channel_count() > 1 {
        decoded
            .into_rgba16()
            .pixels()
            .map(|p| {
                let c = |v: u16| srgb_to_linear(v as f32 / 65535.0);
                [c(p[0]), c(p[1]), c(p[2]), p[3] as f32 / 65535.0]
            })
            .collect()
    } else {
        let lut: Vec<f32> = (0..256).map(|v| srgb_to_linear(v as f32 / 255.0)).collect();
        decoded
            .into_rgba8()
            .pixels()
            .map(|p| [lut[p[0] as usize], lut[p[1] as usize], lut[p[2] as usize], p[3] as f32 / 255.0])
            .collect()
    };
    Ok(LinearImage { width, height, pixels })
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::PathBuf;
    use std::sync::atomic::{AtomicU32, Ordering};

    fn temp_path(name: &str) -> PathBuf {
        static COUNTER: AtomicU32 = AtomicU32::new(0);
        let n = COUNTER.fetch_add(1, Ordering::Relaxed);
        std::env::temp_dir().join(format!("shutter-image-io-{}-{n}-{name}", std::process::id()))
    }

    fn test_image(width: u32, height: u32, hdr: bool) -> LinearImage {
        let mut img = LinearImage::new(width, height);
        for y in 0..height {
            for x in 0..width {
                let fx = x as f32 / width as f32;
                let fy = y as f32 / height as f32;
                let scale = if hdr { 7.5 } else { 1.0 };
                img.set(x, y, [fx * scale, fy, (fx * fy).sqrt() * 0.9 + 0.01, 1.0]);
            }
        }
        img
    }

    #[test]
    fn exr_round_trip_is_exact() {
        let mut img = test_image(13, 7, true);
        img.set(3, 2, [1e-7, 65504.0, 123.456, 0.25]);
        let path = temp_path("rt.exr");
        write_exr(&path, &img).unwrap();
        let back = load_image(&path).unwrap();
        std::fs::remove_file(&path).ok();
        assert_eq!(back, img);
    }

    fn check_png_round_trip(img: &LinearImage) {
        let path = temp_path("rt.png");
        save_image(&path, img).unwrap();
        let back = load_image(&path).unwrap();
        std::fs::remove_file(&path).ok();
        assert_eq!((back.width, back.height), (img.width, img.height));
        for (a, b) in img.pixels.iter().zip(&back.pixels) {
            for c in 0..3 {
                let (sa, sb) = (linear_to_srgb(a[c]), linear_to_srgb(b[c]));
                assert!((sa - sb).abs() <= 1.0 / 255.0 + 1e-6, "{a:?} vs {b:?}");
            }
            assert!((a[3].clamp(0.0, 1.0) - b[3]).abs() <= 0.5 / 255.0 + 1e-6, "{a:?} vs {b:?}");
        }
    }

    #[test]
    fn png_round_trip_within_one_code() {
        check_png_round_trip(&test_image(17, 9, false));
        // HDR values clamp; a translucent image goes through the RGBA path.
        check_png_round_trip(&test_image(5, 4, true));
        let mut translucent = test_image(6, 3, false);
        translucent.set(1, 1, [0.2, 0.3, 0.4, 0.5]);
        translucent.set(2, 1, [0.0, 0.0, 0.0, 0.0]);
        check_png_round_trip(&translucent);
    }

    #[test]
    fn png_quantisation_rounds_to_nearest() {
        // sRGB code 128 decodes to ~0.2158605; a hair above or below must still encode to 128.
        let l = srgb_to_linear(128.0 / 255.0);
        let mut img = LinearImage::new(3, 1);
        img.set(0, 0, [l, l * 1.001, l * 0.999, 1.0]);
        img.set(1, 0, [-1.0, 2.0, f32::NAN, 1.0]);
        assert_eq!(&to_srgb8(&img)[..6], &[128, 128, 128, 0, 255, 0]);
    }

    #[test]
    fn loads_grey_and_16_bit_png() {
        let path = temp_path("grey16.png");
        let grey = image::ImageBuffer::<image::Luma<u16>, _>::from_raw(2, 1, vec![0u16, 65535]).unwrap();
        grey.save_with_format(&path, image::ImageFormat::Png).unwrap();
        let back = load_image(&path).unwrap();
        assert_eq!(back.pixels, vec![[0.0, 0.0, 0.0, 1.0], [1.0, 1.0, 1.0, 1.0]]);
        let grey8 = image::GrayImage::from_raw(2, 1, vec![128u8, 255]).unwrap();
        grey8.save_with_format(&path, image::ImageFormat::Png).unwrap();
        let back = load_image(&path).unwrap();
        std::fs::remove_file(&path).ok();
        let l = srgb_to_linear(128.0 / 255.0);
        assert_eq!(back.pixels[0], [l, l, l, 1.0]);
    }

    #[test]
    fn save_with_bad_extension_errors() {
        let img = test_image(2, 2, false);
        for name in ["out.jpg", "out"] {
            let path = temp_path(name);
            let err = save_image(&path, &img).unwrap_err().to_string();
            assert!(err.contains(".exr") && err.contains(".png"), "{err}");
            assert!(err.contains(&path.display().to_string()), "{err}");
            assert!(!path.exists());
        }
        let upper = temp_path("OUT.PNG");
        save_image(&upper, &img).unwrap();
        std::fs::remove_file(&upper).ok();
    }

    #[test]
    fn load_missing_file_errors_naming_path() {
        let path = temp_path("missing.exr");
        let err = load_image(&path).unwrap_err();
        assert!(matches!(err, Error::Io { .. }));
        assert!(err.to_string().contains(&path.display().to_string()), "{err}");
    }

    #[test]
    fn load_corrupt_files_error_naming_path() {
        let garbage: Vec<u8> = (0..200u32).map(|i| (i.wrapping_mul(2654435761) >> 13) as u8).collect();
        let mut truncated_png = PNG_MAGIC.to_vec();
        truncated_png.extend_from_slice(&garbage[..20]);
        let mut truncated_exr = EXR_MAGIC.to_vec();
        truncated_exr.extend_from_slice(&garbage[..20]);
        for (name, bytes) in
            [("garbage.png", garbage), ("bad.png", truncated_png), ("bad.exr", truncated_exr)]
        {
            let path = temp_path(name);
            std::fs::write(&path, &bytes).unwrap();
            let err = load_image(&path).unwrap_err();
            std::fs::remove_file(&path).ok();
            assert!(matches!(err, Error::Image { .. }), "{err}");
            assert!(err.to_string().contains(&path.display().to_string()), "{err}");
        }
    }

    /// A fresh, empty folder for one test.
    fn temp_dir(name: &str) -> PathBuf {
        let dir = temp_path(name);
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    fn noisy_image(width: u32, height: u32) -> LinearImage {
        let mut img = LinearImage::new(width, height);
        let mut state = 0x9e37_79b9_u32;
        for y in 0..height {
            for x in 0..width {
                let mut next = || {
                    state ^= state << 13;
                    state ^= state >> 17;
                    state ^= state << 5;
                    (state >> 8) as f32 / (1 << 24) as f32
                };
                img.set(x, y, [next() * 4.0, next(), (x + y) as f32 * 0.01, 1.0]);
            }
        }
        img
    }

    #[test]
    fn exr_bytes_are_identical_across_runs_with_increasing_line_order() {
        // Big enough for the encoder to compress chunks on several threads.
        let img = noisy_image(320, 240);
        let dir = temp_dir("exr-determinism");
        let files: Vec<Vec<u8>> = (0..5)
            .map(|i| {
                let path = dir.join(format!("run{i}.exr"));
                write_exr(&path, &img).unwrap();
                std::fs::read(&path).unwrap()
            })
            .collect();
        std::fs::remove_dir_all(&dir).ok();
        for (i, f) in files.iter().enumerate() {
            assert!(f == &files[0], "run {i}'s EXR differs from run 0's");
        }
        assert_eq!(encode_exr(&img).unwrap(), files[0]);
        let meta = exr::meta::MetaData::read_from_buffered(Cursor::new(&files[0]), false).unwrap();
        assert_eq!(meta.headers[0].line_order, exr::meta::attribute::LineOrder::Increasing);
        assert_eq!(meta.headers[0].blocks, exr::meta::BlockDescription::ScanLines);
        assert_eq!(load_image_bytes(&files[0]), img);
    }

    fn load_image_bytes(bytes: &[u8]) -> LinearImage {
        decode_exr(Path::new("bytes"), bytes.to_vec()).unwrap()
    }

    #[test]
    fn exr_keeps_values_beyond_half_float() {
        let mut img = test_image(4, 2, true);
        img.set(1, 1, [65504.0 * 4.0, 1.0e9, 70000.5, 1.0]);
        assert_eq!(load_image_bytes(&encode_exr(&img).unwrap()), img);
    }

    /// A `Write` that accepts `budget` bytes, then fails as a full disk does.
    struct FullDisk<'a> {
        inner: &'a mut File,
        budget: usize,
    }

    impl Write for FullDisk<'_> {
        fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
            if self.budget == 0 {
                return Err(std::io::Error::from_raw_os_error(28)); // ENOSPC
            }
            let n = buf.len().min(self.budget);
            self.budget -= n;
            self.inner.write(&buf[..n])
        }
        fn flush(&mut self) -> std::io::Result<()> {
            self.inner.flush()
        }
    }

    #[test]
    fn a_full_disk_keeps_the_old_file_and_leaves_no_partial_file() {
        let dir = temp_dir("full-disk");
        let old = noisy_image(16, 8);
        let new = noisy_image(64, 32);
        for ext in ["exr", "png"] {
            let path = dir.join(format!("image.{ext}"));
            save_image(&path, &old).unwrap();
            let before = std::fs::read(&path).unwrap();
            let bytes = match ext {
                "exr" => encode_exr(&new).unwrap(),
                _ => {
                    let scratch = dir.join("scratch.png");
                    write_png(&scratch, &new).unwrap();
                    let b = std::fs::read(&scratch).unwrap();
                    std::fs::remove_file(&scratch).unwrap();
                    b
                }
            };
            let err = write_atomically_with(&path, |f| FullDisk { inner: f, budget: 100 }.write_all(&bytes))
                .unwrap_err();
            let msg = err.to_string();
            assert!(matches!(err, Error::Output { .. }), "{msg}");
            assert!(msg.contains(&path.display().to_string()) && msg.contains("os error 28"), "{msg}");
            assert!(msg.contains("left as it was"), "{msg}");
            assert_eq!(std::fs::read(&path).unwrap(), before, "the old .{ext} was touched");
            assert_eq!(load_image(&path).unwrap().width, old.width);
            // A failed first write leaves no file at all.
            let fresh = dir.join(format!("fresh.{ext}"));
            assert!(write_atomically_with(&fresh, |f| FullDisk { inner: f, budget: 0 }.write_all(&bytes))
                .is_err());
            assert!(!fresh.exists());
        }
        let left: Vec<_> = std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().file_name()).collect();
        std::fs::remove_dir_all(&dir).ok();
        assert_eq!(left.len(), 2, "temporary files left behind: {left:?}");
    }

    #[test]
    fn a_successful_write_replaces_the_old_file() {
        let dir = temp_dir("replace");
        let path = dir.join("a.exr");
        save_image(&path, &noisy_image(8, 8)).unwrap();
        let new = noisy_image(12, 4);
        save_image(&path, &new).unwrap();
        let back = load_image(&path).unwrap();
        let left = std::fs::read_dir(&dir).unwrap().count();
        std::fs::remove_dir_all(&dir).ok();
        assert_eq!(back, new);
        assert_eq!(left, 1);
    }

    /// Replacing keeps what an in-place write keeps: the old file's permissions, and a symbolic link
    /// (written through to its target).
    #[cfg(unix)]
    #[test]
    fn a_replaced_file_keeps_its_permissions_and_links() {
        use std::os::unix::fs::PermissionsExt;
        let dir = temp_dir("keep");
        let target = dir.join("target.png");
        save_image(&target, &noisy_image(4, 4)).unwrap();
        std::fs::set_permissions(&target, std::fs::Permissions::from_mode(0o640)).unwrap();
        let link = dir.join("link.png");
        std::os::unix::fs::symlink("target.png", &link).unwrap();
        save_image(&link, &noisy_image(6, 2)).unwrap();
        let is_link = std::fs::symlink_metadata(&link).unwrap().file_type().is_symlink();
        let mode = std::fs::metadata(&target).unwrap().permissions().mode() & 0o777;
        let back = load_image(&target).unwrap();
        let left = std::fs::read_dir(&dir).unwrap().count();
        std::fs::remove_dir_all(&dir).ok();
        assert!(is_link, "the link was replaced by a file");
        assert_eq!(mode, 0o640);
        assert_eq!((back.width, back.height), (6, 2));
        assert_eq!(left, 2, "a temporary file left behind");
    }

    /// Issue 28, item 13: an output that is a named pipe, or a link to a character device, is written
    /// through — the node stays what it was (before, the atomic rename replaced it by a regular file:
    /// as root, `--out` through a link to `/dev/null` replaced `/dev/null`) — and a socket is refused,
    /// before and at writing, and left alone.
    #[cfg(unix)]
    #[test]
    fn devices_and_pipes_are_written_through_not_replaced() {
        use std::os::unix::fs::FileTypeExt;
        let dir = temp_dir("nodes");
        let img = noisy_image(5, 3);
        let fifo = dir.join("pipe.png");
        let made = std::process::Command::new("mkfifo").arg(&fifo).status().map(|s| s.success());
        if made.unwrap_or(false) {
            // The read end opened first, non-blocking (O_NONBLOCK), so the writer finds a reader and
            // nothing waits; the small image fits the pipe's buffer.
            let drain = |fifo: &Path| {
                use std::os::unix::fs::OpenOptionsExt;
                std::fs::OpenOptions::new().read(true).custom_flags(0o4000).open(fifo).unwrap()
            };
            let read_all = |mut r: File| {
                use std::io::Read;
                let mut got = vec![];
                let _ = r.read_to_end(&mut got);
                got
            };
            let reader = drain(&fifo);
            check_image_output(&fifo).unwrap();
            save_image(&fifo, &img).unwrap();
            assert!(std::fs::symlink_metadata(&fifo).unwrap().file_type().is_fifo(), "the pipe was replaced");
            let got = read_all(reader);
            assert!(got.starts_with(&PNG_MAGIC), "the reader got {} bytes, not a PNG", got.len());
            // Through a link as well.
            let link = dir.join("to-pipe.png");
            std::os::unix::fs::symlink(&fifo, &link).unwrap();
            let reader = drain(&fifo);
            save_image(&link, &img).unwrap();
            assert!(std::fs::symlink_metadata(&fifo).unwrap().file_type().is_fifo());
            assert!(std::fs::symlink_metadata(&link).unwrap().file_type().is_symlink());
            assert!(read_all(reader).starts_with(&PNG_MAGIC));
        }
        let null = dir.join("null.exr");
        std::os::unix::fs::symlink("/dev/null", &null).unwrap();
        check_image_output(&null).unwrap();
        save_image(&null, &img).unwrap();
        assert!(std::fs::metadata("/dev/null").unwrap().file_type().is_char_device(), "/dev/null replaced");
        assert!(std::fs::symlink_metadata(&null).unwrap().file_type().is_symlink());
        let socket = dir.join("socket.png");
        let _listener = std::os::unix::net::UnixListener::bind(&socket).unwrap();
        for e in [check_image_output(&socket).unwrap_err(), save_image(&socket, &img).unwrap_err()] {
            assert!(e.to_string().contains("it is a socket"), "{e}");
        }
        assert!(std::fs::symlink_metadata(&socket).unwrap().file_type().is_socket());
        let left: Vec<_> = std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().file_name()).collect();
        std::fs::remove_dir_all(&dir).ok();
        assert!(left.iter().all(|n| !n.to_string_lossy().ends_with(".tmp")), "{left:?}");
    }

    #[test]
    fn bad_output_paths_are_refused_before_any_work() {
        let dir = temp_dir("bad-out");
        let missing = dir.join("no-such-folder").join("x.png");
        let err = check_image_output(&missing).unwrap_err().to_string();
        assert!(err.contains("does not exist") && err.contains("no-such-folder"), "{err}");
        let err = check_image_output(dir.join("x.jpg")).unwrap_err().to_string();
        assert!(err.contains(".exr") && err.contains(".png"), "{err}");
        let folder = dir.join("folder.png");
        std::fs::create_dir(&folder).unwrap();
        let err = check_image_output(&folder).unwrap_err().to_string();
        assert!(err.contains("folder"), "{err}");
        let file = dir.join("file");
        std::fs::write(&file, b"x").unwrap();
        let err = check_image_output(file.join("x.exr")).unwrap_err().to_string();
        assert!(err.contains("is not a folder"), "{err}");
        let readonly = dir.join("readonly.exr");
        std::fs::write(&readonly, b"x").unwrap();
        let mut perms = std::fs::metadata(&readonly).unwrap().permissions();
        perms.set_readonly(true);
        std::fs::set_permissions(&readonly, perms).unwrap();
        let err = check_image_output(&readonly).unwrap_err().to_string();
        assert!(err.contains("read-only"), "{err}");
        check_image_output(dir.join("ok.EXR")).unwrap();
        check_output_file(dir.join("notes.md")).unwrap();
        // A folder we may not write into (unless we are root, whom permissions do not stop).
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            let locked = dir.join("locked");
            std::fs::create_dir(&locked).unwrap();
            std::fs::set_permissions(&locked, std::fs::Permissions::from_mode(0o555)).unwrap();
            let root = std::fs::write(locked.join("probe"), b"").is_ok();
            if !root {
                let err = check_image_output(locked.join("x.png")).unwrap_err().to_string();
                assert!(err.contains("cannot create a file in") && err.contains("locked"), "{err}");
            }
            std::fs::set_permissions(&locked, std::fs::Permissions::from_mode(0o755)).unwrap();
        }
        let left: Vec<_> = std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().file_name()).collect();
        std::fs::remove_dir_all(&dir).ok();
        assert!(left.iter().all(|n| !n.to_string_lossy().ends_with(".tmp")), "{left:?}");
    }

    #[test]
    fn writing_a_malformed_image_errors() {
        let bad = LinearImage { width: 3, height: 3, pixels: vec![[0.0; 4]; 4] };
        assert!(write_png(temp_path("bad.png"), &bad).is_err());
        assert!(write_exr(temp_path("bad.exr"), &bad).is_err());
    }
}
