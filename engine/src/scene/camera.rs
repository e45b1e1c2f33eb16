//! The camera model of docs/MODEL.md, written once on the CPU: pinhole + thin lens + shutter.
//!
//! Camera space: right-handed, +Y up, the camera looks down −Z, a point in front has view depth
//! `z = −z_view > 0`. Pixel coordinates: x right, y **down**, origin at the top-left corner of the image,
//! pixel `(i, j)` covering `[i, i+1) × [j, j+1)`. "Tan space" is camera space divided by depth, y up.

use glam::{Mat4, Vec2, Vec3};

use crate::sampling::{ApertureShape, ShutterCurve};

/// Where the camera is at one instant.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraPose {
    pub position: Vec3,
    pub look_at: Vec3,
    pub up: Vec3,
}

impl CameraPose {
    /// World → camera space (right-handed, looking down −Z).
    pub fn view_matrix(&self) -> Mat4 {
        Mat4::look_at_rh(self.position, self.look_at, self.up)
    }
}

/// A thin-lens camera with a shutter. `close` is the pose at shutter close (None: not moving).
#[derive(Clone, Debug, PartialEq)]
pub struct Camera {
    pub open: CameraPose,
    pub close: Option<CameraPose>,
    /// Vertical field of view in degrees.
    pub vfov_deg: f32,
    /// Lens radius A in world units; 0 is a pinhole.
    pub aperture_radius: f32,
    /// Distance F of the plane in focus, along the view axis, in world units.
    pub focus_distance: f32,
    pub aperture: ApertureShape,
    pub shutter: ShutterCurve,
    /// Near and far clip distances (view depth). The GPU uses reversed Z between them.
    pub near: f32,
    pub far: f32,
}

/// Whether clip distances `near` and `far` keep the GPU's reversed-Z depth ordered: finite,
/// `MIN_NEAR ≤ near < far` and `far / near ≤ MAX_FAR_OVER_NEAR` ([`crate::limits`]). `Err` says what
/// is wrong, for the caller to put in context (the scene file and its key, or the scene's check).
pub fn check_depth_range(near: f32, far: f32) -> std::result::Result<(), String> {
    use crate::limits::{MAX_FAR_OVER_NEAR, MIN_NEAR};
    if !(near.is_finite() && near >= MIN_NEAR) {
        return Err(format!("near = {near} is out of range: must be finite and ≥ {MIN_NEAR:e} (MIN_NEAR)"));
    }
    if !(far.is_finite() && far > near) {
        return Err(format!("far = {far} is out of range: must be finite and > near ({near})"));
    }
    if far / near > MAX_FAR_OVER_NEAR {
        return Err(format!(
            "far / near = {:e} is out of range: must be ≤ {MAX_FAR_OVER_NEAR:e} (MAX_FAR_OVER_NEAR; \
             beyond it the GPU's 32-bit depth cannot keep surfaces near the far plane in order): raise \
             near or lower far",
            far / near
        ));
    }
    Ok(())
}

impl Camera {
    pub fn pose_at_close(&self) -> CameraPose {
        self.close.unwrap_or(self.open)
    }
    /// The camera's projection for an image of `width × height` pixels.
    pub fn intrinsics(&self, width: u32, height: u32) -> Intrinsics {
        Intrinsics {
            width: width as f32,
            height: height as f32,
            pixel_scale: pixel_scale(height, self.vfov_deg),
            aperture_radius: self.aperture_radius,
            focus_distance: self.focus_distance,
            aperture: self.aperture,
            near: self.near,
            far: self.far,
        }
    }
    pub fn has_defocus(&self) -> bool {
        self.aperture_radius > 0.0
    }
}

/// `s = (H/2) / tan(vfov/2)`: pixels per unit of tan space at depth 1 (docs/MODEL.md "Pinhole").
pub fn pixel_scale(height: u32, vfov_deg: f32) -> f32 {
    (height as f32 * 0.5) / (vfov_deg.to_radians() * 0.5).tan()
}

/// Signed circle of confusion in pixels, `φ(z) = A·s·(1/F − 1/z)` (docs/MODEL.md "Thin lens"; ATSS Eq. 1).
/// A point at depth z is displaced on screen by `φ(z)·(u, v)` for lens sample (u, v) (y up).
pub fn circle_of_confusion_px(z: f32, aperture_radius: f32, pixel_scale: f32, focus_distance: f32) -> f32 {
    aperture_radius * pixel_scale * (1.0 / focus_distance - 1.0 / z)
}

/// Everything needed to map camera space to pixels for one image size.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Intrinsics {
    pub width: f32,
    pub height: f32,
    pub pixel_scale: f32,
    pub aperture_radius: f32,
    pub focus_distance: f32,
    pub aperture: ApertureShape,
    pub near: f32,
    pub far: f32,
}

impl Intrinsics {
    pub fn circle_of_confusion_px(&self, z: f32) -> f32 {
        circle_of_confusion_px(z, self.aperture_radius, self.pixel_scale, self.focus_distance)
    }

    /// Lens point in camera space for a lens sample on the unit aperture (already mapped to the shape).
    pub fn lens_point(&self, lens: Vec2) -> Vec3 {
        (self.aperture_radius * lens).extend(0.0)
    }

    /// Pixel position → tan-space direction (x right, y up) of the pinhole ray.
    pub fn pixel_to_tan(&self, pixel: Vec2) -> Vec2 {
        Vec2::new(
            (pixel.x - 0.5 * self.width) / self.pixel_scale,
            -(pixel.y - 0.5 * self.height) / self.pixel_scale,
        )
    }

    /// The thin-lens primary ray through `pixel` from lens sample `lens` (unit aperture coordinates):
    /// it starts at the lens point and passes through the point where the pinhole ray through the same
    /// pixel meets the plane of focus `z = F` (docs/MODEL.md). Returns (origin, unit direction), camera space.
    pub fn primary_ray(&self, pixel: Vec2, lens: Vec2) -> (Vec3, Vec3) {
        let tan = self.pixel_to_tan(pixel);
        let origin = self.lens_point(lens);
        let focus_point =
            Vec3::new(tan.x * self.focus_distance, tan.y * self.focus_distance, -self.focus_distance);
        (origin, (focus_point - origin).normalize())
    }

    /// The reversed-Z depth the rasterizer stores for a point at view depth `z` in `[near, far]`:
    /// `near·(far − z) / ((far − near)·z)`, 1 at near and 0 at far, kept a relative 2⁻²⁰ of view depth
    /// inside both ends (a face exactly on either plane stays in the clip volume and passes the
    /// GREATER test against the cleared 0). The far end's floor is the depth of `far·(1 − 2⁻²⁰)`, about
    /// `near / (far − near)·2⁻²⁰`: an absolute floor of 2⁻²⁰ merged every depth beyond `near·2²⁰`. The
    /// mirror of `thin_lens_clip`'s `clip.z / clip.w` (`shaders-glsl/common/camera.glsl`), operation
    /// for operation.
    pub fn reversed_z(&self, z: f32) -> f32 {
        let (near, far) = (self.near, self.far);
        let mut clip_z = near * (far - z) / (far - near);
        if z >= near {
            clip_z = clip_z.min(z * (1.0 - 1.0 / 1048576.0));
        }
        if z <= far {
            clip_z = clip_z.max(z * (near / (far - near) * (1.0 / 1048576.0)));
        }
        clip_z / z
    }

    /// Where camera-space point `p` (depth `z = −p.z > 0`) lands in pixel coordinates when seen through
    /// lens sample `lens`: the pinhole projection displaced by `φ(z)·lens` (y up → pixel y down).
    /// This is exactly what the GPU vertex transform does (see `shaders-glsl/common/camera.glsl`).
    pub fn project(&self, p: Vec3, lens: Vec2) -> Vec2 {
        let z = -p.z;
        let l = self.aperture_radius * lens;
        // Ray from lens point L through P hits the focus plane at Q = L + (P − L)·F/z; its pixel is Q/F.
        let q = (p.truncate() - l) / z + l / self.focus_distance;
        Vec2::new(0.5 * self.width + self.pixel_scale * q.x, 0.5 * self.height - self.pixel_scale * q.y)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn intr(a: f32, f: f32) -> Intrinsics {
        Camera {
            open: CameraPose { position: Vec3::ZERO, look_at: -Vec3::Z, up: Vec3::Y },
            close: None,
            vfov_deg: 40.0,
            aperture_radius: a,
            focus_distance: f,
            aperture: ApertureShape::Disk,
            shutter: ShutterCurve::Box,
            near: 0.05,
            far: 100.0,
        }
        .intrinsics(320, 180)
    }

    /// The depth the forward passes store falls strictly with view depth over the whole range, at the
    /// largest far / near allowed (and at near = 1 mm, far = 10 km of issue 28): the old absolute floor
    /// of 2⁻²⁰ made every depth beyond near·2²⁰ equal.
    #[test]
    fn reversed_z_is_strictly_ordered_from_near_to_far() {
        for (near, far) in [(0.001f32, 10000.0f32), (1e-3, 1e9), (0.05, 1000.0), (1.0, 1.0001)] {
            assert!(check_depth_range(near, far).is_ok());
            let mut k = intr(0.0, 1.0);
            (k.near, k.far) = (near, far);
            let at_near = k.reversed_z(near);
            let at_far = k.reversed_z(far);
            assert!(at_near < 1.0 && at_near > 0.99, "{near}..{far}: depth at near {at_near}");
            assert!(at_far > 0.0 && at_far.is_normal(), "{near}..{far}: depth at far {at_far}");
            // View depths a relative 2^-17 apart (away from the guarded 2^-20 at each end) keep their
            // order; geometric steps cover every octave of the range.
            let step = 1.0 + 1.0 / 131072.0;
            let (mut z, mut last) = (near * (1.0 + 1.0 / 65536.0), f32::INFINITY);
            let mut count = 0u64;
            while z < far * (1.0 - 1.0 / 65536.0) {
                let d = k.reversed_z(z);
                assert!(d < last, "{near}..{far}: depth {d} at z = {z} is not below {last}");
                last = d;
                z *= step;
                count += 1;
            }
            assert!(count > 10 || far / near < 2.0, "{near}..{far}: {count} steps");
        }
        // The ratio beyond the limit is refused, with the limit named.
        assert!(check_depth_range(1e-3, 1e10).unwrap_err().contains("MAX_FAR_OVER_NEAR"));
        assert!(check_depth_range(0.0, 1.0).unwrap_err().contains("MIN_NEAR"));
        assert!(check_depth_range(1.0, f32::INFINITY).is_err());
    }

    #[test]
    fn pixel_scale_matches_definition() {
        // vfov 90° → tan(45°) = 1 → s = H/2.
        assert!((pixel_scale(180, 90.0) - 90.0).abs() < 1e-4);
    }

    #[test]
    fn coc_is_zero_at_focus_and_signed() {
        let k = intr(0.1, 5.0);
        assert!(k.circle_of_confusion_px(5.0).abs() < 1e-5);
        assert!(k.circle_of_confusion_px(2.0) < 0.0, "near points flip");
        assert!(k.circle_of_confusion_px(20.0) > 0.0);
        // Far limit: A·s/F.
        let far = k.circle_of_confusion_px(1e9);
        assert!((far - 0.1 * k.pixel_scale / 5.0).abs() < 1e-3);
    }

    #[test]
    fn coc_matches_thesis_view_space_disc() {
        // Thesis: disc of confusion in view space at depth z has radius (A/F)|z − F| world units; on
        // screen at depth z that is s·(A/F)|z − F| / z pixels = |φ(z)|.
        let k = intr(0.07, 3.0);
        for z in [0.5f32, 1.0, 2.9, 3.1, 8.0, 50.0] {
            let thesis = k.pixel_scale * (0.07 / 3.0) * (z - 3.0).abs() / z;
            assert!((thesis - k.circle_of_confusion_px(z).abs()).abs() < 1e-3 * thesis.max(1.0));
        }
    }

    proptest! {
        /// Independent derivation: intersect the primary ray with the plane z = −depth and check the
        /// displacement from the pinhole projection equals φ(z)·(u, v) (y flipped for pixels).
        #[test]
        fn lens_mapping_matches_ray_derivation(
            px in 0.0f32..320.0, py in 0.0f32..180.0, u in -1.0f32..1.0, v in -1.0f32..1.0,
            z in 0.3f32..60.0, a in 0.0f32..0.5, f in 0.5f32..20.0,
        ) {
            let k = intr(a, f);
            let (o, d) = k.primary_ray(Vec2::new(px, py), Vec2::new(u, v));
            let hit = o + d * ((-z - o.z) / d.z);
            // Pinhole projection of the hit point vs. the pixel the ray came from.
            let pin = k.project(hit, Vec2::ZERO);
            let phi = k.circle_of_confusion_px(z);
            let expect = Vec2::new(px - phi * u, py + phi * v);
            prop_assert!((pin - expect).length() < 2e-3 * (1.0 + phi.abs()), "{pin} vs {expect}");
            // And projecting the hit point through the same lens sample returns the pixel.
            let back = k.project(hit, Vec2::new(u, v));
            prop_assert!((back - Vec2::new(px, py)).length() < 2e-3 * (1.0 + phi.abs()));
        }

        #[test]
        fn focus_plane_points_are_sharp(px in 0.0f32..320.0, py in 0.0f32..180.0, u in -1.0f32..1.0, v in -1.0f32..1.0) {
            let k = intr(0.3, 4.0);
            let tan = k.pixel_to_tan(Vec2::new(px, py));
            let p = Vec3::new(tan.x * 4.0, tan.y * 4.0, -4.0);
            prop_assert!((k.project(p, Vec2::new(u, v)) - Vec2::new(px, py)).length() < 1e-3);
        }
    }
}
