//! Image-comparison metrics: RMSE, PSNR and FLIP of a test image against a reference.
//!
//! RMSE and PSNR are computed on linear RGB clamped to [0, 1] (alpha is ignored): without the clamp a few
//! HDR outliers (fireflies, light sources) would dominate the mean. FLIP is LDR-FLIP (Andersson et al.
//! 2020, via NVIDIA's implementation in the `nv-flip` crate) on the 8-bit sRGB encodings of both images
//! ([`crate::image_io::to_srgb8`]) at [`FLIP_PIXELS_PER_DEGREE`].

use std::fmt;
use std::path::Path;

use crate::error::{Error, Result};
use crate::image::LinearImage;
use crate::image_io::{to_srgb8, write_png};

/// FLIP's default viewing condition: a 0.7 m wide 3840-pixel monitor seen from 0.7 m.
pub const FLIP_PIXELS_PER_DEGREE: f32 = 67.02;

/// How far a test image is from the reference.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImageMetrics {
    /// Root-mean-square error over the RGB channels of linear values clamped to [0, 1]. NaN if either
    /// image holds a NaN.
    pub rmse: f64,
    /// `20·log10(1 / rmse)` in dB; `f64::INFINITY` for identical (clamped) images.
    pub psnr: f64,
    /// Mean of the LDR-FLIP error map, in [0, 1]; 0 for identical sRGB encodings.
    pub flip: f64,
}

impl fmt::Display for ImageMetrics {
    /// `RMSE 0.012345  PSNR 38.17 dB  FLIP 0.04567` (PSNR prints `inf` for identical images).
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "RMSE {:.6}  PSNR {:.2} dB  FLIP {:.5}", self.rmse, self.psnr, self.flip)
    }
}

fn check_sizes(reference: &LinearImage, test: &LinearImage) -> Result<()> {
    for (what, img) in [("reference", reference), ("test", test)] {
        if img.pixels.len() != img.width as usize * img.height as usize {
            return Err(Error::Unsupported(format!(
                "{what} image claims {}×{} but holds {} pixels",
                img.width,
                img.height,
                img.pixels.len()
            )));
        }
    }
    if (reference.width, reference.height) != (test.width, test.height) {
        return Err(Error::Unsupported(format!(
            "cannot compare images of different sizes: reference is {}×{}, test is {}×{}",
            reference.width, reference.height, test.width, test.height
        )));
    }
    if reference.pixels.is_empty() {
        return Err(Error::Unsupported("cannot compare empty (0-pixel) images".into()));
    }
    Ok(())
}

/// RMSE over the RGB channels of linear values clamped to [0, 1]; sizes must already match.
fn rmse_clamped(reference: &LinearImage, test: &LinearImage) -> f64 {
    let sum: f64 = reference
        .pixels
        .iter()
        .zip(&test.pixels)
        .map(|(r, t)| {
            (0..3)
                .map(|c| {
                    let d = r[c].clamp(0.0, 1.0) as f64 - t[c].clamp(0.0, 1.0) as f64;
                    d * d
                })
                .sum::<f64>()
        })
        .sum();
    (sum / (3 * reference.pixels.len()) as f64).sqrt()
}

/// Runs LDR-FLIP; sizes must already match and be non-zero.
fn flip_raw(reference: &LinearImage, test: &LinearImage) -> (nv_flip::FlipImageFloat, f64) {
    let (w, h) = (reference.width, reference.height);
    let r = nv_flip::FlipImageRgb8::with_data(w, h, &to_srgb8(reference));
    let t = nv_flip::FlipImageRgb8::with_data(w, h, &to_srgb8(test));
    let map = nv_flip::flip(r, t, FLIP_PIXELS_PER_DEGREE);
    let values = map.to_vec();
    let mean = values.iter().map(|&v| v as f64).sum::<f64>() / values.len() as f64;
    (map, mean)
}

/// Compares `test` against `reference`: RMSE, PSNR and mean FLIP (see the module docs).
///
/// Errors when the sizes differ (naming both) or the images are empty.
pub fn compare(reference: &LinearImage, test: &LinearImage) -> Result<ImageMetrics> {
    check_sizes(reference, test)?;
    let rmse = rmse_clamped(reference, test);
    let psnr = if rmse == 0.0 { f64::INFINITY } else { 20.0 * (1.0 / rmse).log10() };
    let (_, flip) = flip_raw(reference, test);
    Ok(ImageMetrics { rmse, psnr, flip })
}

/// The per-pixel LDR-FLIP error map (each pixel's error in [0, 1] in R, G and B; alpha 1) and its mean.
pub fn flip_error_map(reference: &LinearImage, test: &LinearImage) -> Result<(LinearImage, f64)> {
    check_sizes(reference, test)?;
    let (map, mean) = flip_raw(reference, test);
    let pixels = map.to_vec().into_iter().map(|e| [e, e, e, 1.0]).collect();
    Ok((LinearImage { width: reference.width, height: reference.height, pixels }, mean))
}

/// Writes the FLIP error map, colour-mapped with FLIP's magma LUT, as an 8-bit sRGB PNG; returns the mean
/// FLIP error.
pub fn write_flip_diff_png(
    path: impl AsRef<Path>,
    reference: &LinearImage,
    test: &LinearImage,
) -> Result<f64> {
    check_sizes(reference, test)?;
    let (map, mean) = flip_raw(reference, test);
    let rgb = map.apply_color_lut(&nv_flip::magma_lut()).to_vec();
    // The LUT's bytes are sRGB codes; decode them so that write_png re-encodes them exactly.
    let lut: Vec<f32> = (0..256).map(|v| crate::scene::texture::srgb_to_linear(v as f32 / 255.0)).collect();
    let pixels = rgb
        .chunks_exact(3)
        .map(|c| [lut[c[0] as usize], lut[c[1] as usize], lut[c[2] as usize], 1.0])
        .collect();
    write_png(path, &LinearImage { width: reference.width, height: reference.height, pixels })?;
    Ok(mean)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn constant(width: u32, height: u32, v: f32) -> LinearImage {
        LinearImage { width, height, pixels: vec![[v, v, v, 1.0]; (width * height) as usize] }
    }

    fn scene_like(width: u32, height: u32) -> LinearImage {
        let mut img = LinearImage::new(width, height);
        for y in 0..height {
            for x in 0..width {
                let fx = x as f32 / width as f32;
                let fy = y as f32 / height as f32;
                let check = if (x / 8 + y / 8) % 2 == 0 { 0.6 } else { 0.2 };
                img.set(x, y, [check * fx + 0.05, check * (1.0 - fy) + 0.05, 0.3 * fx * fy + 0.1, 1.0]);
            }
        }
        img
    }

    /// Deterministic uniform noise in [-amplitude, amplitude] added to every colour channel.
    fn add_noise(img: &LinearImage, amplitude: f32, seed: u64) -> LinearImage {
        let mut state = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 40) as f32 / (1u64 << 24) as f32 * 2.0 - 1.0
        };
        let pixels = img
            .pixels
            .iter()
            .map(|p| [p[0] + amplitude * next(), p[1] + amplitude * next(), p[2] + amplitude * next(), p[3]])
            .collect();
        LinearImage { width: img.width, height: img.height, pixels }
    }

    #[test]
    fn identical_images_are_perfect() {
        let img = scene_like(48, 32);
        let m = compare(&img, &img).unwrap();
        assert_eq!(m.rmse, 0.0);
        assert_eq!(m.psnr, f64::INFINITY);
        assert_eq!(m.flip, 0.0);
        let text = m.to_string();
        assert!(text.contains("PSNR inf dB"), "{text}");
    }

    #[test]
    fn known_rmse_and_psnr() {
        let m = compare(&constant(16, 16, 0.5), &constant(16, 16, 0.6)).unwrap();
        assert!((m.rmse - 0.1).abs() < 1e-6, "{m:?}");
        assert!((m.psnr - 20.0).abs() < 1e-4, "{m:?}");
        assert!(m.flip > 0.0 && m.flip < 1.0, "{m:?}");
    }

    #[test]
    fn rmse_clamps_hdr_and_ignores_alpha() {
        let reference = constant(4, 4, 1.0);
        let mut test = constant(4, 4, 1000.0);
        test.pixels.iter_mut().for_each(|p| p[3] = 0.0);
        let m = compare(&reference, &test).unwrap();
        assert_eq!(m.rmse, 0.0);
        assert_eq!(m.flip, 0.0);
    }

    #[test]
    fn flip_grows_with_noise() {
        let reference = scene_like(64, 64);
        let flips: Vec<f64> = [0.01, 0.05, 0.2]
            .iter()
            .map(|&a| compare(&reference, &add_noise(&reference, a, 7)).unwrap().flip)
            .collect();
        assert!(flips[0] > 0.0, "{flips:?}");
        assert!(flips[0] < flips[1] && flips[1] < flips[2], "{flips:?}");
        assert!(flips[2] < 1.0, "{flips:?}");
    }

    #[test]
    fn size_mismatch_errors_naming_both_sizes() {
        let err = compare(&constant(4, 3, 0.5), &constant(3, 4, 0.5)).unwrap_err().to_string();
        assert!(err.contains("4×3") && err.contains("3×4"), "{err}");
        assert!(flip_error_map(&constant(4, 3, 0.5), &constant(4, 4, 0.5)).is_err());
        assert!(compare(&constant(0, 0, 0.5), &constant(0, 0, 0.5)).is_err());
    }

    #[test]
    fn error_map_mean_matches_compare_and_diff_png_writes() {
        let reference = scene_like(32, 24);
        let test = add_noise(&reference, 0.1, 3);
        let (map, mean) = flip_error_map(&reference, &test).unwrap();
        assert_eq!((map.width, map.height), (32, 24));
        assert!(map.pixels.iter().all(|p| (0.0..=1.0).contains(&p[0])));
        assert_eq!(mean, compare(&reference, &test).unwrap().flip);
        let path = std::env::temp_dir().join(format!("shutter-metrics-{}-diff.png", std::process::id()));
        let written_mean = write_flip_diff_png(&path, &reference, &test).unwrap();
        let back = crate::image_io::load_image(&path).unwrap();
        std::fs::remove_file(&path).ok();
        assert_eq!(written_mean, mean);
        assert_eq!((back.width, back.height), (32, 24));
        // Magma is not grey: the colour map was applied.
        assert!(back.pixels.iter().any(|p| p[0] != p[2]));
    }
}
