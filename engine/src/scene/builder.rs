//! Building a [`Scene`] in code, starting from the scene file's defaults, with a real camera's
//! terms (focal length, f-number, focus distance, shutter angle) beside the model's.
//!
//! Every constructor here gives what the scene file gives for a key left out, so a scene built in
//! code and the same scene written as a file are the same [`Scene`]; [`Scene::validate`] (which
//! every renderer calls first) refuses a built scene for the same things, with the same messages, as
//! the file loader refuses a file.
//!
//! ```
//! use shutter::glam::{Mat4, Vec3};
//! use shutter::scene::{builtin::builtin_mesh, Camera, Light, Material, Object, Scene};
//! # fn main() -> shutter::Result<()> {
//! let sphere = std::sync::Arc::new(builtin_mesh("sphere", None).expect("built-in")?);
//! let camera = Camera::looking_at(Vec3::new(0.0, 1.0, 6.0), Vec3::new(0.0, 0.5, 0.0))
//!     .with_lens(50.0, 2.0, 24.0) // a 50 mm lens at f/2 on a 24 mm high sensor
//!     .with_focus_distance(6.0);
//! let scene = Scene::new("in code", camera)
//!     .with_image(160, 90, 16, 1)
//!     .with_object(
//!         Object::new("ball", sphere, Mat4::from_translation(Vec3::new(-0.5, 0.5, 0.0)))
//!             .moving_to(Mat4::from_translation(Vec3::new(0.5, 0.5, 0.0)))
//!             .with_material(Material::diffuse(Vec3::new(0.8, 0.3, 0.2))),
//!     )
//!     .with_light(Light::Directional { direction: Vec3::new(-1.0, -1.0, -1.0), color: Vec3::ONE, shadows: false })
//!     .with_shutter_angle(180.0)?; // open for the first half of the frame's motion
//! scene.validate()?;
//! # Ok(())
//! # }
//! ```

use std::sync::Arc;

use glam::{Mat4, Vec3};

use super::file::{aperture_radius_of_lens, lerp_exact_ends, retime, vfov_deg_of_lens};
use super::validate::{num, Check};
use super::{Camera, CameraPose, Environment, ImageSettings, Light, Material, Mesh, Object, Scene};
use crate::error::Result;
use crate::sampling::{ApertureShape, ShutterCurve};

/// The height of a full-frame sensor (36 × 24 mm), millimetres.
pub const FULL_FRAME_HEIGHT_MM: f32 = 24.0;

impl Camera {
    /// The scene file's camera at `position` looking at `look_at`: +Y up, a 40° vertical field of
    /// view, a pinhole (aperture radius 0) focused at `look_at`'s distance, a disk aperture, a box
    /// shutter, near 0.05 and far 1000 (metres); not moving.
    pub fn looking_at(position: Vec3, look_at: Vec3) -> Camera {
        Camera {
            open: CameraPose { position, look_at, up: Vec3::Y },
            close: None,
            vfov_deg: 40.0,
            aperture_radius: 0.0,
            focus_distance: (look_at - position).length(),
            aperture: ApertureShape::Disk,
            shutter: ShutterCurve::default(),
            near: 0.05,
            far: 1000.0,
        }
    }

    /// The same camera moving over the shutter: at shutter close it is at `position` looking at
    /// `look_at` (with the same `up`).
    pub fn moving_to(self, position: Vec3, look_at: Vec3) -> Camera {
        let close = CameraPose { position, look_at, up: self.open.up };
        Camera { close: Some(close), ..self }
    }

    /// A real lens: focal length `focal_length_mm` at f-number `f_number` on a sensor
    /// `sensor_height_mm` high (24 for full frame, [`FULL_FRAME_HEIGHT_MM`]) — the field of view
    /// `2·atan(h / 2f)` and the lens radius `f / 2N` (in metres), as the scene file's
    /// `focal_length_mm`, `f_stop` and `sensor_height_mm` give them.
    pub fn with_lens(self, focal_length_mm: f32, f_number: f32, sensor_height_mm: f32) -> Camera {
        Camera {
            vfov_deg: vfov_deg_of_lens(focal_length_mm, sensor_height_mm),
            aperture_radius: aperture_radius_of_lens(focal_length_mm, f_number),
            ..self
        }
    }

    /// Focused at `distance` metres along the view axis.
    pub fn with_focus_distance(self, distance: f32) -> Camera {
        Camera { focus_distance: distance, ..self }
    }

    /// The model's lens radius A directly (metres; 0 is a pinhole).
    pub fn with_aperture_radius(self, radius: f32) -> Camera {
        Camera { aperture_radius: radius, ..self }
    }

    /// The model's vertical field of view directly, degrees.
    pub fn with_vfov_deg(self, vfov_deg: f32) -> Camera {
        Camera { vfov_deg, ..self }
    }
}

impl Material {
    /// The default material with albedo `albedo` (linear RGB): diffuse, opaque, two-sided.
    pub fn diffuse(albedo: Vec3) -> Material {
        Material { albedo, ..Material::default() }
    }
}

impl Object {
    /// `mesh` placed by `transform` (object → world), not moving, with the default material.
    pub fn new(name: impl Into<String>, mesh: Arc<Mesh>, transform: Mat4) -> Object {
        Object { name: name.into(), mesh, transforms: vec![(0.0, transform)], material: Material::default() }
    }

    /// The same object at `close` at shutter close (moving linearly from its first transform).
    pub fn moving_to(mut self, close: Mat4) -> Object {
        self.set_close(close);
        self
    }

    pub fn with_material(self, material: Material) -> Object {
        Object { material, ..self }
    }
}

impl Scene {
    /// An empty scene seen by `camera`: the scene file's `[image]` defaults (640 × 360, 16 samples
    /// per pixel, seed 1), no objects, no lights, the default environment.
    pub fn new(name: impl Into<String>, camera: Camera) -> Scene {
        Scene {
            name: name.into(),
            image: ImageSettings { width: 640, height: 360, spp: 16, seed: 1, display: Default::default() },
            camera,
            objects: Vec::new(),
            lights: Vec::new(),
            environment: Environment::default(),
        }
    }

    /// Renders `width × height` pixels with `spp` samples per pixel and `seed`.
    /// (The display transform stays as it was.)
    pub fn with_image(self, width: u32, height: u32, spp: u32, seed: u64) -> Scene {
        Scene { image: ImageSettings { width, height, spp, seed, display: self.image.display }, ..self }
    }

    /// PNG output exposed by `exposure_ev` stops and through `curve` ([`crate::tonemap`]).
    pub fn with_display(mut self, exposure_ev: f32, curve: crate::tonemap::ToneCurve) -> Scene {
        self.image.display = crate::tonemap::Display { exposure_ev, curve };
        self
    }

    pub fn with_object(mut self, object: Object) -> Scene {
        self.objects.push(object);
        self
    }

    pub fn with_light(mut self, light: Light) -> Scene {
        self.lights.push(light);
        self
    }

    pub fn with_environment(self, environment: Environment) -> Scene {
        Scene { environment, ..self }
    }

    /// A shutter open for `angle_deg / 360` of the frame, from its start (in (0, 360]): the camera's
    /// close pose and every object's transform keys are taken to describe the whole frame (0 its
    /// start, 1 its end) and the motion is cut to the part the shutter sees, exactly as the scene
    /// file's `shutter_angle_deg` does it. 360 changes nothing.
    pub fn with_shutter_angle(self, angle_deg: f32) -> Result<Scene> {
        let source = format!("scene `{}`", super::validate::printable(&self.name));
        let cx = Check { source: &source };
        cx.range(
            "camera.shutter_angle_deg",
            angle_deg,
            angle_deg > 0.0 && angle_deg <= 360.0,
            "in (0, 360]",
        )?;
        self.with_shutter_interval(0.0, angle_deg / 360.0)
    }

    /// A shutter open from `open` to `close`, fractions of the frame (0 ≤ open < close ≤ 1): the
    /// scene file's `shutter_interval`, as [`Scene::with_shutter_angle`] describes.
    pub fn with_shutter_interval(mut self, open: f32, close: f32) -> Result<Scene> {
        let source = format!("scene `{}`", super::validate::printable(&self.name));
        let cx = Check { source: &source };
        let field = "camera.shutter_interval";
        cx.finite(field, open)?;
        cx.finite(field, close)?;
        if !(0.0 <= open && open < close && close <= 1.0) {
            return Err(cx.err(
                field,
                format!(
                    "[{}, {}] is out of range: must be 0 ≤ open < close ≤ 1 (fractions of the frame)",
                    num(open),
                    num(close)
                ),
            ));
        }
        if let Some(end) = self.camera.close {
            let start = self.camera.open;
            let at = |s: f32| CameraPose {
                position: lerp_exact_ends(start.position, end.position, s),
                look_at: lerp_exact_ends(start.look_at, end.look_at, s),
                up: lerp_exact_ends(start.up, end.up, s),
            };
            self.camera.open = at(open);
            self.camera.close = Some(at(close));
        }
        for o in &mut self.objects {
            o.transforms = retime(std::mem::take(&mut o.transforms), (open, close));
        }
        Ok(self)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::file::parse_scene;

    /// A scene built in code equals the same scene written as a file, photographic terms included.
    #[test]
    fn built_scenes_equal_their_files() {
        let text = r#"
            name = "same"
            [image]
            width = 160
            height = 90
            spp = 8
            [camera]
            position = [0, 1, 6]
            look_at = [0, 0.5, 0]
            focal_length_mm = 50
            sensor_height_mm = 24
            f_stop = 2
            focus_distance = 5
            shutter_angle_deg = 180
            [camera.close]
            position = [0.2, 1, 6]
            [[object]]
            name = "ball"
            mesh = "sphere"
            [object.transform]
            translate = [-1, 0.5, 0]
            [object.transform_close]
            translate = [1, 0.5, 0]
            [[light]]
            type = "directional"
            direction = [-1, -1, -1]
            color = [1, 1, 1]
        "#;
        let file = parse_scene(text, std::path::Path::new("."), "same").expect("parses");
        let sphere = Arc::new(crate::scene::builtin::builtin_mesh("sphere", None).unwrap().unwrap());
        let built = Scene::new("same", {
            let c = Camera::looking_at(Vec3::new(0.0, 1.0, 6.0), Vec3::new(0.0, 0.5, 0.0))
                .with_lens(50.0, 2.0, 24.0)
                .with_focus_distance(5.0);
            c.moving_to(Vec3::new(0.2, 1.0, 6.0), Vec3::new(0.0, 0.5, 0.0))
        })
        .with_image(160, 90, 8, 1)
        .with_object(
            Object::new("ball", sphere, Mat4::from_translation(Vec3::new(-1.0, 0.5, 0.0)))
                .moving_to(Mat4::from_translation(Vec3::new(1.0, 0.5, 0.0))),
        )
        .with_light(Light::Directional {
            direction: Vec3::new(-1.0, -1.0, -1.0).normalize(),
            color: Vec3::ONE,
            shadows: false,
        })
        .with_shutter_angle(180.0)
        .expect("in range");
        built.validate().expect("valid");
        assert_eq!(built.camera, file.camera);
        assert_eq!(built.image, file.image);
        assert_eq!(built.lights, file.lights);
        assert_eq!(built.objects[0].transforms, file.objects[0].transforms);
        assert_eq!(built.content_hash(), file.content_hash());
    }

    /// What the file loader refuses, `validate` refuses in a built scene, in the same words.
    #[test]
    fn built_scenes_are_refused_like_files() {
        let camera = Camera::looking_at(Vec3::new(0.0, 1.0, 6.0), Vec3::ZERO);
        let e = Scene::new("bad", camera.clone().with_focus_distance(-1.0)).validate().unwrap_err();
        assert_eq!(
            e.to_string(),
            "scene error in scene `bad`: camera.focus_distance: -1 is out of range: must be > 0"
        );
        let e = Scene::new("bad", camera.clone()).with_shutter_angle(400.0).unwrap_err();
        assert!(e.to_string().contains("camera.shutter_angle_deg: 400 is out of range"), "{e}");
        let e = Scene::new("bad", camera).with_image(0, 90, 1, 1).validate().unwrap_err();
        assert!(e.to_string().contains("image.width"), "{e}");
    }
}
