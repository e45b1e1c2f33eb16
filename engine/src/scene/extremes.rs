//! The one rule for numeric extremes in a scene (issue 28): every coordinate and colour-like value is
//! finite and within a documented limit ([`crate::limits`]: [`MAX_COORDINATE`], [`MAX_COLOR`],
//! [`crate::limits::MAX_FAR_OVER_NEAR`]), or the scene is refused with a message naming the object, light or key.
//! Beyond those limits the techniques stop agreeing: a triangle at ±10¹⁸ overflowed the reference's
//! inside test (squared cross products) and vanished there while the rasterizers drew it, and two lights
//! of colour 3·10³⁸ summed to Inf in every technique. Normals are the exception that is repaired rather
//! than refused: [`super::Mesh::new`] normalises them in f64 (a normal of 3·10³⁸ is a direction), and
//! a zero or non-finite one takes the vertex's area-weighted face normal.
//!
//! The scene file refuses through [`check_scene`] after loading; the library's entry points (the GPU
//! renderer's `prepare` and the CPU reference) call it too, so a scene built in code is refused alike.

use glam::{DVec3, Mat4, Vec3};

use super::{Camera, Environment, Light, Material, Object, Scene};
use crate::error::{Error, Result};
use crate::limits::{MAX_COLOR, MAX_COORDINATE};

/// Every check of this module over `scene`: the first problem as [`Error::Scene`], its context naming
/// the part of the scene (`object `name``, `light 2`, `camera`, `environment`).
pub fn check_scene(scene: &Scene) -> Result<()> {
    check_camera(&scene.camera).map_err(|m| Error::scene("camera", m))?;
    for object in &scene.objects {
        let context = || format!("object `{}`", object.name);
        check_object_extent(object).map_err(|m| Error::scene(context(), m))?;
        check_material(&object.material).map_err(|m| Error::scene(context(), m))?;
    }
    for (i, light) in scene.lights.iter().enumerate() {
        check_light(light).map_err(|m| Error::scene(format!("light {i}"), m))?;
    }
    check_environment(&scene.environment).map_err(|m| Error::scene("environment", m))
}

fn coordinate_problem(what: &str, v: Vec3) -> std::result::Result<(), String> {
    let m = v.abs().max_element();
    if v.is_finite() && m <= MAX_COORDINATE {
        Ok(())
    } else {
        Err(format!(
            "{what} {v} is out of range: every coordinate must be finite and within ±{MAX_COORDINATE:e} \
             (MAX_COORDINATE, scene units)"
        ))
    }
}

fn color_problem(what: &str, v: Vec3) -> std::result::Result<(), String> {
    if v.is_finite() && v.min_element() >= 0.0 && v.max_element() <= MAX_COLOR {
        Ok(())
    } else {
        Err(format!("{what} {v} is out of range: each channel must be in [0, {MAX_COLOR:e}] (MAX_COLOR)"))
    }
}

/// The camera's positions and look-at points at both shutter ends, and its clip distances
/// ([`super::camera::check_depth_range`], [`crate::limits::MAX_FAR_OVER_NEAR`]).
pub fn check_camera(camera: &Camera) -> std::result::Result<(), String> {
    for (end, pose) in [("open", camera.open), ("close", camera.pose_at_close())] {
        coordinate_problem(&format!("position at shutter {end}"), pose.position)?;
        coordinate_problem(&format!("look_at at shutter {end}"), pose.look_at)?;
    }
    super::camera::check_depth_range(camera.near, camera.far)
}

/// Every vertex of `object`'s mesh placed by each of its transform keys lies within
/// ±[`MAX_COORDINATE`]: the corners of the mesh's bounding box through each key's matrix, in f64
/// (an affine map keeps the vertices inside the image of the box).
pub fn check_object_extent(object: &Object) -> std::result::Result<(), String> {
    let mesh = &object.mesh;
    if mesh.positions.is_empty() {
        return Ok(());
    }
    let (lo, hi) = mesh.bounds();
    coordinate_problem("a mesh vertex", lo)?;
    coordinate_problem("a mesh vertex", hi)?;
    for (i, &(time, m)) in object.transforms.iter().enumerate() {
        if !m.is_finite() {
            return Err(format!("transform key {i} (time {time}) is not finite"));
        }
        let largest =
            corners(lo, hi).iter().map(|&c| transform(m, c).abs().max_element()).fold(0.0, f64::max);
        if largest > MAX_COORDINATE as f64 {
            return Err(format!(
                "at transform key {i} (time {time}) a vertex reaches {largest:.3e}: every coordinate must \
                 be within ±{MAX_COORDINATE:e} (MAX_COORDINATE, scene units)"
            ));
        }
    }
    Ok(())
}

fn corners(lo: Vec3, hi: Vec3) -> [DVec3; 8] {
    std::array::from_fn(|k| {
        DVec3::new(
            if k & 1 == 0 { lo.x } else { hi.x } as f64,
            if k & 2 == 0 { lo.y } else { hi.y } as f64,
            if k & 4 == 0 { lo.z } else { hi.z } as f64,
        )
    })
}

fn transform(m: Mat4, p: DVec3) -> DVec3 {
    m.as_dmat4().transform_point3(p)
}

/// A material's albedo and specular weight within [0, [`MAX_COLOR`]].
pub fn check_material(material: &Material) -> std::result::Result<(), String> {
    color_problem("albedo", material.albedo)?;
    color_problem("specular", Vec3::splat(material.specular))
}

/// A light's colour within [0, [`MAX_COLOR`]], its position within ±[`MAX_COORDINATE`] and its
/// direction finite and not zero.
pub fn check_light(light: &Light) -> std::result::Result<(), String> {
    let (color, position, direction) = match *light {
        Light::Directional { direction, color, .. } => (color, None, Some(direction)),
        Light::Point { position, color, .. } => (color, Some(position), None),
        Light::Spot { position, direction, color, .. } => (color, Some(position), Some(direction)),
    };
    color_problem("colour", color)?;
    if let Some(p) = position {
        coordinate_problem("position", p)?;
    }
    match direction {
        Some(d) if !(d.is_finite() && d.length_squared() > 0.0) => {
            Err(format!("direction {d} must be finite and not zero"))
        }
        _ => Ok(()),
    }
}

/// Ambient and background within [0, [`MAX_COLOR`]].
pub fn check_environment(environment: &Environment) -> std::result::Result<(), String> {
    color_problem("ambient", environment.ambient)?;
    color_problem("background", environment.background)
}

#[cfg(test)]
mod tests {
    use std::sync::Arc;

    use super::*;
    use crate::scene::builtin::builtin_scene;
    use crate::scene::Mesh;

    fn scene() -> Scene {
        builtin_scene("default").expect("known").expect("builds")
    }

    #[test]
    fn the_builtin_scenes_pass() {
        for name in crate::scene::builtin::BUILTIN_SCENES {
            let s = builtin_scene(name).expect("known").expect("builds");
            check_scene(&s).unwrap_or_else(|e| panic!("{name}: {e}"));
        }
    }

    #[test]
    fn extremes_are_refused_naming_the_part() {
        let mut s = scene();
        let far = Mesh::new(
            "far",
            vec![Vec3::new(-1e18, 0.0, -5.0), Vec3::new(1e18, 0.0, -5.0), Vec3::new(0.0, 1e18, -5.0)],
            vec![],
            vec![],
            vec![0, 1, 2],
        )
        .unwrap();
        s.objects[0].mesh = Arc::new(far);
        let e = check_scene(&s).unwrap_err().to_string();
        assert!(
            e.contains(&format!("object `{}`", s.objects[0].name)) && e.contains("MAX_COORDINATE"),
            "{e}"
        );

        // A unit mesh scaled past the limit by its close key.
        let mut s = scene();
        let open = s.objects[0].transform_open();
        s.objects[0].set_close(open * Mat4::from_scale(Vec3::splat(1e12)));
        let e = check_scene(&s).unwrap_err().to_string();
        assert!(e.contains("transform key 1") && e.contains("MAX_COORDINATE"), "{e}");

        let mut s = scene();
        s.lights = vec![
            Light::Point { position: Vec3::Y, color: Vec3::splat(3e38), shadows: false },
            Light::Point { position: Vec3::Y, color: Vec3::splat(3e38), shadows: false },
        ];
        let e = check_scene(&s).unwrap_err().to_string();
        assert!(e.contains("light 0") && e.contains("MAX_COLOR"), "{e}");

        let mut s = scene();
        s.objects[1].material.albedo = Vec3::new(1.0, f32::NAN, 0.0);
        assert!(check_scene(&s).unwrap_err().to_string().contains("albedo"));

        let mut s = scene();
        s.environment.background = Vec3::splat(-1.0);
        assert!(check_scene(&s).unwrap_err().to_string().contains("background"));

        let mut s = scene();
        s.camera.open.position = Vec3::new(0.0, 2e9, 0.0);
        assert!(check_scene(&s).unwrap_err().to_string().contains("camera"));
        let mut s = scene();
        (s.camera.near, s.camera.far) = (1e-3, 1e10);
        assert!(check_scene(&s).unwrap_err().to_string().contains("MAX_FAR_OVER_NEAR"));
    }
}
