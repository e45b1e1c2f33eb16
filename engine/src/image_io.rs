//! Image files: linear OpenEXR and sRGB-encoded PNG, in and out of [`LinearImage`].
//!
//! EXR holds linear light as written (RGBA, 32-bit float, lossless). PNG holds 8-bit sRGB: writing clamps
//! each linear colour channel to [0, 1], sRGB-encodes it and rounds to the nearest code; alpha is stored
//! linearly. [`load_image`] recognises the format by the file's leading bytes, not by its name.

use std::io::Cursor;
use std::path::Path;

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

/// Writes `image` as an OpenEXR file: linear RGBA, 32-bit float per channel, lossless.
pub fn write_exr(path: impl AsRef<Path>, image: &LinearImage) -> Result<()> {
    use exr::prelude::{Image, SpecificChannels, Vec2, WritableImage};
    let path = path.as_ref();
    check_size(path, image)?;
    let width = image.width as usize;
    let channels = SpecificChannels::rgba(|Vec2(x, y): Vec2<usize>| {
        let p = image.pixels[y * width + x];
        (p[0], p[1], p[2], p[3])
    });
    let exr_image = Image::from_channels((width, image.height as usize), channels);
    let mut bytes = Vec::new();
    exr_image
        .write()
        .to_buffered(Cursor::new(&mut bytes))
        .map_err(|e| image_error(path, format!("cannot encode EXR: {e}")))?;
    std::fs::write(path, bytes).map_err(|e| Error::io(path, e))
}

/// Writes `image` as an 8-bit sRGB PNG.
///
/// Colour is clamped to [0, 1], sRGB-encoded and rounded to the nearest code (see [`to_srgb8`]). The file
/// is RGB when every alpha is 1, RGBA (alpha stored linearly) otherwise.
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
    std::fs::write(path, bytes).map_err(|e| Error::io(path, e))
}

/// Writes `image` in the format named by the path's extension (`.exr` or `.png`, case-insensitive).
pub fn save_image(path: impl AsRef<Path>, image: &LinearImage) -> Result<()> {
    let path = path.as_ref();
    let ext = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
    match ext.as_deref() {
        Some("exr") => write_exr(path, image),
        Some("png") => write_png(path, image),
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

/// Reads an EXR (linear, first RGBA layer, full resolution; missing alpha reads as 1) or a PNG (8- or
/// 16-bit, grey / grey+alpha / RGB / RGBA; colour sRGB-decoded to linear, alpha taken as linear).
///
/// The format is recognised from the file's contents. Every error names the path.
pub fn load_image(path: impl AsRef<Path>) -> Result<LinearImage> {
    let path = path.as_ref();
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
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

    #[test]
    fn writing_a_malformed_image_errors() {
        let bad = LinearImage { width: 3, height: 3, pixels: vec![[0.0; 4]; 4] };
        assert!(write_png(temp_path("bad.png"), &bad).is_err());
        assert!(write_exr(temp_path("bad.exr"), &bad).is_err());
    }
}
