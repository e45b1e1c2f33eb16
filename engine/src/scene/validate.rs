//! What a [`Scene`] must hold before anything renders it, checked in one place.
//!
//! The scene file ([`super::file`]) calls these checks as it resolves each part, so a file's error
//! names the field where the file wrote it; every renderer entry point ([`crate::techniques::Renderer`]
//! and [`crate::reference`]) calls [`Scene::validate`], so a scene built in code is refused for the
//! same things with the same messages (before, a `vfov_deg` of 0 built in code hung the GPU path and a
//! negative focus distance rendered a wrong image).
//!
//! Numbers in messages are printed by [`num`]: the shortest text that reads back to the same value,
//! in exponent form when very large or very small (`1e-45`, not 46 digits).

use glam::{Mat4, Vec3};

use super::{Camera, CameraPose, Environment, ImageSettings, Light, Material, Object, Scene};
use crate::error::{Error, Result};
use crate::limits::{MAX_IMAGE_DIMENSION, MAX_MOTION_KEYS, MAX_SPP};
use crate::sampling::ApertureShape;

/// The narrowest vertical field of view a scene may have, degrees.
pub const MIN_VFOV_DEG: f32 = 1e-3;

/// `x` as the shortest decimal text that reads back to the same `f32`; in exponent form (`3e38`,
/// `1e-45`) outside [1e-4, 1e9), where plain digits would run to dozens of places.
pub fn num(x: f32) -> String {
    let a = x.abs();
    if x == 0.0 || !x.is_finite() || (1e-4..1e9).contains(&a) {
        format!("{x}")
    } else {
        format!("{x:e}")
    }
}

/// [`num`] for an `f64` (a value as a scene file wrote it, before it became an `f32`).
pub fn num64(x: f64) -> String {
    let a = x.abs();
    if x == 0.0 || !x.is_finite() || (1e-4..1e9).contains(&a) {
        format!("{x}")
    } else {
        format!("{x:e}")
    }
}

/// A vector as `[x, y, z]`, each component by [`num`].
pub fn vec_text(v: Vec3) -> String {
    format!("[{}, {}, {}]", num(v.x), num(v.y), num(v.z))
}

/// `name` safe to print on a terminal: control characters (an ANSI escape's ESC, a carriage return,
/// a bell) written as Rust escapes (`\u{1b}`), everything else as it is. Scene and object names from
/// a file are stored this way, so no message or table prints a raw escape sequence.
pub fn printable(name: &str) -> String {
    if !name.chars().any(char::is_control) {
        return name.to_string();
    }
    name.chars()
        .map(|c| if c.is_control() { c.escape_default().to_string() } else { c.to_string() })
        .collect()
}

/// Errors naming the source (the scene file, or `scene `name`` for one built in code) and the field.
pub(crate) struct Check<'a> {
    pub source: &'a str,
}

impl Check<'_> {
    pub fn err(&self, field: &str, message: impl std::fmt::Display) -> Error {
        Error::scene(self.source, format!("{field}: {message}"))
    }
    pub fn finite(&self, field: &str, x: f32) -> Result<f32> {
        if x.is_finite() {
            Ok(x)
        } else {
            Err(self.err(field, format!("{} is not a finite number", num(x))))
        }
    }
    /// `x` finite and `ok`, else "… is out of range: must be `expected`".
    pub fn range(&self, field: &str, x: f32, ok: bool, expected: &str) -> Result<f32> {
        let x = self.finite(field, x)?;
        if ok {
            Ok(x)
        } else {
            Err(self.err(field, format!("{} is out of range: must be {expected}", num(x))))
        }
    }
    pub fn vec3(&self, field: &str, v: Vec3) -> Result<Vec3> {
        for (i, x) in v.to_array().iter().enumerate() {
            if !x.is_finite() {
                return Err(self.err(field, format!("component {i} is {}, not a finite number", num(*x))));
            }
        }
        Ok(v)
    }
    pub fn non_negative3(&self, field: &str, v: Vec3) -> Result<Vec3> {
        let v = self.vec3(field, v)?;
        if v.min_element() < 0.0 {
            return Err(self.err(field, format!("{} has a negative component", vec_text(v))));
        }
        Ok(v)
    }
    fn size(&self, what: &'static str, v: u32, max: u32, name: &str) -> Result<()> {
        if (1..=max).contains(&v) {
            Ok(())
        } else {
            Err(Error::Limit {
                what,
                value: v.to_string(),
                limit: format!("must be in 1..={max} ({name}) in {}", self.source),
            })
        }
    }

    /// `[image]`: sizes and samples in range.
    pub fn image(&self, i: &ImageSettings) -> Result<()> {
        self.size("image.width", i.width, MAX_IMAGE_DIMENSION, "MAX_IMAGE_DIMENSION")?;
        self.size("image.height", i.height, MAX_IMAGE_DIMENSION, "MAX_IMAGE_DIMENSION")?;
        self.size("image.spp", i.spp, MAX_SPP, "MAX_SPP")
    }

    /// A camera pose: finite, looking somewhere, `up` not along the view.
    pub fn pose(&self, field: &str, p: &CameraPose) -> Result<()> {
        let position = self.vec3(&format!("{field}.position"), p.position)?;
        let look_at = self.vec3(&format!("{field}.look_at"), p.look_at)?;
        let up = self.vec3(&format!("{field}.up"), p.up)?;
        let view = (look_at - position)
            .try_normalize()
            .ok_or_else(|| self.err(&format!("{field}.look_at"), "must differ from position"))?;
        let up = up.try_normalize().ok_or_else(|| self.err(&format!("{field}.up"), "must not be zero"))?;
        if view.cross(up).length() < 1e-4 {
            return Err(self.err(&format!("{field}.up"), "is parallel to the view direction"));
        }
        Ok(())
    }

    /// The lens and clip range; the poses by [`Check::pose`].
    pub fn camera(&self, c: &Camera) -> Result<()> {
        self.pose("camera", &c.open)?;
        if let Some(close) = &c.close {
            self.pose("camera.close", close)?;
        }
        // At least a thousandth of a degree (a 2,000 mm lens on a full-frame sensor sees 0.69°): below
        // about 1e-36° tan(vfov/2) underflows and the pixel scale is infinite (found by the fuzz test).
        let vfov = c.vfov_deg;
        self.range(
            "camera.vfov_deg",
            vfov,
            (MIN_VFOV_DEG..180.0).contains(&vfov),
            "in [0.001, 180) degrees",
        )?;
        let a = c.aperture_radius;
        self.range("camera.aperture_radius", a, a >= 0.0, "≥ 0")?;
        let f = c.focus_distance;
        self.range("camera.focus_distance", f, f > 0.0, "> 0")?;
        self.range("camera.near", c.near, c.near > 0.0, "> 0")?;
        self.range("camera.far", c.far, c.far > c.near, "> near")?;
        crate::scene::camera::check_depth_range(c.near, c.far).map_err(|e| self.err("camera.near/far", e))?;
        if let ApertureShape::Blades { blades, rotation_deg } = c.aperture {
            if blades < 3 {
                return Err(
                    self.err("camera.aperture.blades", format!("{blades} is out of range: must be ≥ 3"))
                );
            }
            self.finite("camera.aperture.rotation_deg", rotation_deg)?;
        }
        Ok(())
    }

    /// An object's transform keys: at least one, times from 0 strictly increasing to 1 (when there
    /// are several), at most [`MAX_MOTION_KEYS`], every matrix finite.
    pub fn transforms(&self, field: &str, keys: &[(f32, Mat4)]) -> Result<()> {
        let f = format!("{field}.transforms");
        if keys.is_empty() {
            return Err(self.err(&f, "an object needs at least one transform key (at time 0)"));
        }
        if keys.len() > MAX_MOTION_KEYS {
            return Err(
                self.err(&f, format!("{} keys; at most {MAX_MOTION_KEYS} (MAX_MOTION_KEYS)", keys.len()))
            );
        }
        if keys[0].0 != 0.0 {
            return Err(self.err(&f, format!("the first key is at time {}, not 0", num(keys[0].0))));
        }
        if keys.len() > 1 && keys[keys.len() - 1].0 != 1.0 {
            return Err(self.err(
                &f,
                format!("the last key is at time {}, not 1 (shutter close)", num(keys[keys.len() - 1].0)),
            ));
        }
        for (k, w) in keys.windows(2).enumerate() {
            // NaN times fail too.
            if w[1].0.partial_cmp(&w[0].0) != Some(std::cmp::Ordering::Greater) {
                return Err(self.err(
                    &f,
                    format!(
                        "key {} at time {} does not come after key {k} at {}",
                        k + 1,
                        num(w[1].0),
                        num(w[0].0)
                    ),
                ));
            }
        }
        if let Some(k) = keys.iter().position(|(_, m)| !m.is_finite()) {
            return Err(self.err(&f, format!("key {k} has a non-finite matrix")));
        }
        Ok(())
    }

    /// A material's values in range; `mirrored`: some transform key of its object has a negative
    /// determinant.
    pub fn material(&self, field: &str, m: &Material, mirrored: bool) -> Result<()> {
        self.non_negative3(&format!("{field}.albedo"), m.albedo)?;
        let s = m.specular;
        self.range(&format!("{field}.specular"), s, s >= 0.0, "≥ 0")?;
        let r = m.roughness;
        self.range(&format!("{field}.roughness"), r, r > 0.0 && r <= 1.0, "in (0, 1]")?;
        let a = m.alpha;
        self.range(&format!("{field}.alpha"), a, (0.0..=1.0).contains(&a), "in [0, 1]")?;
        if m.alpha_from_texture && m.texture.is_none() {
            return Err(self.err(&format!("{field}.alpha_from_texture"), "needs a texture"));
        }
        let tint = self.vec3(&format!("{field}.tint"), m.tint)?;
        if tint.min_element() < 0.0 || tint.max_element() > 1.0 {
            return Err(self.err(
                &format!("{field}.tint"),
                format!("{} is out of range: each component in [0, 1]", vec_text(tint)),
            ));
        }
        if m.one_sided && mirrored {
            return Err(self.err(
                &format!("{field}.one_sided"),
                "the object's transform mirrors it (a negative scale), which turns its faces inside out: \
                 one-sided culling would hide its outside; remove the mirroring or the one_sided key",
            ));
        }
        Ok(())
    }

    /// Object `i`: its transforms and material. Its mesh was checked when it was built
    /// ([`super::Mesh::new`]: finite vertices, valid indices).
    pub fn object(&self, i: usize, o: &Object) -> Result<()> {
        let field = object_field(i, &o.name);
        self.transforms(&field, &o.transforms)?;
        let mirrored = o.transforms.iter().any(|k| k.1.determinant() < 0.0);
        self.material(&format!("{field}.material"), &o.material, mirrored)?;
        // Checks of a mesh's values beyond finiteness (normals, extents) belong here, after the
        // transforms: see issue 28, item 6.
        Ok(())
    }

    /// Light `i`: finite, a non-zero direction, a colour ≥ 0, a spot's cone in range.
    pub fn light(&self, i: usize, l: &Light) -> Result<()> {
        let direction = |d: Vec3| -> Result<()> {
            let field = format!("light[{i}].direction");
            let d = self.vec3(&field, d)?;
            d.try_normalize().map(|_| ()).ok_or_else(|| self.err(&field, "must not be zero"))
        };
        let color = |c: Vec3| self.non_negative3(&format!("light[{i}].color"), c).map(|_| ());
        let position = |p: Vec3| self.vec3(&format!("light[{i}].position"), p).map(|_| ());
        match *l {
            Light::Directional { direction: d, color: c, .. } => {
                direction(d)?;
                color(c)?;
            }
            Light::Point { position: p, color: c, .. } => {
                position(p)?;
                color(c)?;
            }
            Light::Spot { position: p, direction: d, inner_deg, outer_deg, color: c, .. } => {
                self.spot_cone(i, inner_deg, outer_deg)?;
                position(p)?;
                direction(d)?;
                color(c)?;
            }
        }
        // Limits on a light's magnitude (colours whose sum overflows) belong here: issue 28, item 6.
        Ok(())
    }

    /// Light `i`'s cone: 0 ≤ inner ≤ outer ≤ 90 degrees, outer > 0.
    pub fn spot_cone(&self, i: usize, inner: f32, outer: f32) -> Result<()> {
        self.range(
            &format!("light[{i}].outer_angle_deg"),
            outer,
            outer > 0.0 && outer <= 90.0,
            "in (0, 90]",
        )?;
        self.range(
            &format!("light[{i}].inner_angle_deg"),
            inner,
            (0.0..=outer).contains(&inner),
            &format!("in [0, outer_angle_deg = {}]", num(outer)),
        )?;
        Ok(())
    }

    pub fn environment(&self, e: &Environment) -> Result<()> {
        self.non_negative3("environment.ambient", e.ambient)?;
        self.non_negative3("environment.background", e.background)?;
        Ok(())
    }
}

/// How messages name object `i`: `object[2] (`cow`)`, a long name cut at 64 characters.
pub(crate) fn object_field(i: usize, name: &str) -> String {
    let name = printable(name);
    match name.char_indices().nth(64) {
        Some((cut, _)) => format!("object[{i}] (`{}…`)", &name[..cut]),
        None => format!("object[{i}] (`{name}`)"),
    }
}

impl Scene {
    /// Checks everything the scene model promises a renderer — the image settings, a finite camera
    /// with a sane lens and clip range, every object's transform keys and material, every light and
    /// the environment — and returns the first problem as [`Error::Scene`] (or [`Error::Limit`] for
    /// `[image]`), worded as the scene file's loader words it. Every renderer calls it first; the
    /// loader calls the same checks, so a scene file and a scene built in code are refused alike.
    pub fn validate(&self) -> Result<()> {
        self.validate_as(&format!("scene `{}`", printable(&self.name)))
    }

    /// [`Scene::validate`] with errors naming `source`.
    pub(crate) fn validate_as(&self, source: &str) -> Result<()> {
        let cx = Check { source };
        cx.image(&self.image)?;
        cx.camera(&self.camera)?;
        for (i, o) in self.objects.iter().enumerate() {
            cx.object(i, o)?;
        }
        for (i, l) in self.lights.iter().enumerate() {
            cx.light(i, l)?;
        }
        cx.environment(&self.environment)?;
        // Coordinates and colours within the limits every technique agrees in (scene::extremes).
        super::extremes::check_scene(self)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_print_short_and_round_trip() {
        assert_eq!(num(1.0), "1");
        assert_eq!(num(0.5), "0.5");
        assert_eq!(num(1e-45), "1e-45");
        assert_eq!(num(3e38), "3e38");
        assert_eq!(num(-0.0), "-0");
        assert_eq!(num(f32::NAN), "NaN");
        assert_eq!(num(0.999_999_9), "0.9999999");
        for x in [1e-45f32, 3.4028235e38, 0.1, 123456.78, 1e-5, 7e9] {
            assert_eq!(num(x).parse::<f32>().unwrap(), x, "{}", num(x));
        }
        assert_eq!(num64(0.99999999), "0.99999999");
    }

    #[test]
    fn control_characters_are_escaped() {
        assert_eq!(printable("plain name"), "plain name");
        assert_eq!(printable("\u{1b}[31mred\u{7}"), "\\u{1b}[31mred\\u{7}");
        assert_eq!(printable("a\nb\r"), "a\\nb\\r");
    }
}
