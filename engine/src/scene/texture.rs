//! Albedo textures: decoded to linear RGB, with a mip chain for the GPU and bilinear lookup for the
//! CPU reference (which supersamples, so it filters the texture by integrating over the pixel). The
//! alpha channel is kept as it is stored (linear, not sRGB-decoded — `R8G8B8A8_SRGB` decodes colour
//! only): a material with `alpha_from_texture` takes its coverage from it.

use std::path::Path;

use glam::{Vec2, Vec3};

use crate::error::{Error, Result};

/// Largest accepted texture side, in texels.
pub const MAX_TEXTURE_DIMENSION: u32 = 16384;

/// A linear-RGB texture (decoded from sRGB) with its full mip chain, level 0 first.
#[derive(Clone, Debug)]
pub struct Texture {
    pub name: String,
    /// Level 0 size.
    pub width: u32,
    pub height: u32,
    /// The original 8-bit sRGB RGBA texels of level 0 (uploaded as `R8G8B8A8_SRGB`).
    pub srgb_rgba8: Vec<u8>,
    /// Linear RGB texels of level 0, row-major, top row first (v = 0 at the top, OBJ uv flipped on load).
    pub linear: Vec<Vec3>,
}

/// sRGB transfer function, decode.
pub fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// sRGB transfer function, encode.
pub fn linear_to_srgb(c: f32) -> f32 {
    let c = c.clamp(0.0, 1.0);
    if c <= 0.0031308 {
        c * 12.92
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    }
}

impl Texture {
    /// From 8-bit sRGB RGBA texels (row-major, top row first).
    pub fn from_srgb_rgba8(name: &str, width: u32, height: u32, srgb_rgba8: Vec<u8>) -> Texture {
        let lut: Vec<f32> = (0..256).map(|i| srgb_to_linear(i as f32 / 255.0)).collect();
        let linear = srgb_rgba8
            .chunks_exact(4)
            .map(|p| Vec3::new(lut[p[0] as usize], lut[p[1] as usize], lut[p[2] as usize]))
            .collect();
        Texture { name: name.to_string(), width, height, srgb_rgba8, linear }
    }

    /// Number of mip levels down to 1×1.
    pub fn mip_levels(&self) -> u32 {
        32 - self.width.max(self.height).max(1).leading_zeros()
    }

    /// Bilinear lookup of level 0 with repeat addressing. `uv` follows Vulkan's convention: (0,0) is
    /// the top-left corner of the first texel row.
    pub fn sample_bilinear(&self, uv: Vec2) -> Vec3 {
        let ([i00, i10, i01, i11], fx, fy) = self.bilinear_footprint(uv);
        let texel = |i: usize| self.linear[i];
        let top = texel(i00).lerp(texel(i10), fx);
        let bottom = texel(i01).lerp(texel(i11), fx);
        top.lerp(bottom, fy)
    }

    /// Bilinear lookup of level 0's alpha channel (linear, `a / 255`), addressed as
    /// [`Texture::sample_bilinear`].
    pub fn sample_alpha_bilinear(&self, uv: Vec2) -> f32 {
        let ([i00, i10, i01, i11], fx, fy) = self.bilinear_footprint(uv);
        let alpha = |i: usize| self.srgb_rgba8[4 * i + 3] as f32 * (1.0 / 255.0);
        let top = alpha(i00) + (alpha(i10) - alpha(i00)) * fx;
        let bottom = alpha(i01) + (alpha(i11) - alpha(i01)) * fx;
        top + (bottom - top) * fy
    }

    /// The four texel indices (top-left, top-right, bottom-left, bottom-right) and the weights of a
    /// bilinear lookup at `uv` with repeat addressing.
    fn bilinear_footprint(&self, uv: Vec2) -> ([usize; 4], f32, f32) {
        let (w, h) = (self.width as i64, self.height as i64);
        let x = uv.x * self.width as f32 - 0.5;
        let y = uv.y * self.height as f32 - 0.5;
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let index = |xi: i64, yi: i64| -> usize {
            let xi = xi.rem_euclid(w) as usize;
            let yi = yi.rem_euclid(h) as usize;
            yi * self.width as usize + xi
        };
        let (xi, yi) = (x0 as i64, y0 as i64);
        ([index(xi, yi), index(xi + 1, yi), index(xi, yi + 1), index(xi + 1, yi + 1)], fx, fy)
    }
}

/// Loads a PNG texture (any bit depth/colour type; converted to 8-bit sRGB RGBA). Errors name the path.
pub fn load_texture(path: &Path) -> Result<Texture> {
    let bytes = crate::limits::read_capped(
        path,
        crate::limits::MAX_TEXTURE_FILE_BYTES,
        "texture",
        "MAX_TEXTURE_FILE_BYTES",
    )?;
    texture_from_png_bytes(&path.display().to_string(), path, &bytes)
}

/// Decodes PNG bytes into a texture called `name`; `path` is what errors name.
pub fn texture_from_png_bytes(name: &str, path: &Path, bytes: &[u8]) -> Result<Texture> {
    let image_error = |message: String| Error::Image { path: path.to_path_buf(), message };
    let reader = || image::ImageReader::with_format(std::io::Cursor::new(bytes), image::ImageFormat::Png);
    // The size first, from the header: the decoder's own refusal says only "Image size exceeds limit".
    let (w, h) = reader().into_dimensions().map_err(|e| image_error(format!("cannot decode PNG: {e}")))?;
    if w > MAX_TEXTURE_DIMENSION || h > MAX_TEXTURE_DIMENSION {
        return Err(image_error(format!(
            "the texture is {w}×{h} texels; at most {MAX_TEXTURE_DIMENSION}×{MAX_TEXTURE_DIMENSION} \
             (MAX_TEXTURE_DIMENSION)"
        )));
    }
    let mut reader = reader();
    let mut limits = image::Limits::default();
    limits.max_image_width = Some(MAX_TEXTURE_DIMENSION);
    limits.max_image_height = Some(MAX_TEXTURE_DIMENSION);
    // Room for the largest texture at 16 bits per channel (the default, 512 MiB, is a quarter of it).
    limits.max_alloc = Some(MAX_TEXTURE_DIMENSION as u64 * MAX_TEXTURE_DIMENSION as u64 * 8);
    reader.limits(limits);
    let decoded = reader.decode().map_err(|e| image_error(format!("cannot decode PNG: {e}")))?;
    let rgba = decoded.to_rgba8();
    let (width, height) = rgba.dimensions();
    if width == 0 || height == 0 {
        return Err(image_error("texture has zero size".into()));
    }
    Ok(Texture::from_srgb_rgba8(name, width, height, rgba.into_raw()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_round_trip() {
        for i in 0..=255 {
            let c = i as f32 / 255.0;
            assert!((linear_to_srgb(srgb_to_linear(c)) - c).abs() < 1e-5);
        }
    }

    #[test]
    fn bilinear_hits_texel_centres_and_wraps() {
        let t = Texture::from_srgb_rgba8("t", 2, 1, vec![255, 255, 255, 255, 0, 0, 0, 255]);
        assert!((t.sample_bilinear(Vec2::new(0.25, 0.5)).x - 1.0).abs() < 1e-6);
        assert!(t.sample_bilinear(Vec2::new(0.75, 0.5)).x.abs() < 1e-6);
        assert!((t.sample_bilinear(Vec2::new(1.25, 0.5)).x - 1.0).abs() < 1e-6, "repeat");
        assert!((t.sample_bilinear(Vec2::new(0.5, 0.5)).x - 0.5).abs() < 1e-6);
        assert_eq!(t.mip_levels(), 2);
    }

    #[test]
    fn alpha_is_linear_and_bilinear() {
        // sRGB 128 decodes to about 0.216; alpha 128 stays 128/255.
        let t = Texture::from_srgb_rgba8("t", 2, 1, vec![128, 128, 128, 128, 0, 0, 0, 0]);
        assert!((t.sample_alpha_bilinear(Vec2::new(0.25, 0.5)) - 128.0 / 255.0).abs() < 1e-6);
        assert_eq!(t.sample_alpha_bilinear(Vec2::new(0.75, 0.5)), 0.0);
        assert!((t.sample_alpha_bilinear(Vec2::new(0.5, 0.5)) - 64.0 / 255.0).abs() < 1e-6);
        assert!((t.sample_alpha_bilinear(Vec2::new(1.25, 0.5)) - 128.0 / 255.0).abs() < 1e-6, "repeat");
    }

    fn temp_path(tag: &str) -> std::path::PathBuf {
        std::env::temp_dir().join(format!(
            "shutter-tex-{}-{}-{tag}.png",
            std::process::id(),
            std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_nanos())
        ))
    }

    #[test]
    fn png_round_trip_and_bad_files() {
        let path = temp_path("ok");
        let img = image::RgbaImage::from_raw(2, 1, vec![255, 0, 0, 255, 0, 0, 255, 255]).unwrap();
        img.save_with_format(&path, image::ImageFormat::Png).unwrap();
        let t = load_texture(&path).unwrap();
        assert_eq!((t.width, t.height), (2, 1));
        assert_eq!(t.linear[0], Vec3::new(1.0, 0.0, 0.0));
        assert_eq!(t.linear[1], Vec3::new(0.0, 0.0, 1.0));

        // Truncated PNG: header intact, data cut.
        let bytes = std::fs::read(&path).unwrap();
        std::fs::write(&path, &bytes[..bytes.len() / 2]).unwrap();
        let e = load_texture(&path).unwrap_err().to_string();
        assert!(e.contains(&path.display().to_string()), "{e}");
        std::fs::write(&path, b"definitely not a png").unwrap();
        assert!(load_texture(&path).is_err());
        let _ = std::fs::remove_file(&path);

        let missing = temp_path("missing");
        let e = load_texture(&missing).unwrap_err().to_string();
        assert!(e.contains(&missing.display().to_string()), "{e}");
    }
}
