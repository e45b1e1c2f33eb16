//! Views: where the scene is seen from and how it is projected — the camera, and any other eye a
//! technique needs (a light's shadow map). A view carries the scene in its own space at shutter open
//! and close ([`CameraSpaceScene`], built once per view and frame) so the planner, the GPU upload and
//! the techniques share one copy.

use glam::{Mat4, Vec2, Vec3};

use super::{CameraSpaceScene, Intrinsics, Scene};

/// How a view maps its space to pixels and depth.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Projection {
    /// The camera's thin lens (docs/MODEL.md "Thin lens"); an aperture of 0 is a pinhole perspective.
    ThinLens(Intrinsics),
    /// Orthographic along −Z, for a directional light: `half_extent` world units each side of the axis
    /// in x and y over `width × height` pixels, view depth in `[near, far]` (reversed Z like the camera).
    Orthographic { width: u32, height: u32, half_extent: Vec2, near: f32, far: f32 },
    /// A pinhole perspective along −Z, for a spot light or one face of a point light's cube: a
    /// view-space point `p` lands `pixel_scale · p.xy / z` pixels from the image centre (x right, y up,
    /// `z = −p.z`), the thin lens' projection without a lens; depth reversed Z in `[near, far]`.
    Perspective { width: u32, height: u32, pixel_scale: f32, near: f32, far: f32 },
}

impl Projection {
    /// Image size in pixels.
    pub fn size(&self) -> (u32, u32) {
        match *self {
            Projection::ThinLens(k) => (k.width as u32, k.height as u32),
            Projection::Orthographic { width, height, .. }
            | Projection::Perspective { width, height, .. } => (width, height),
        }
    }
    /// Near and far view depth.
    pub fn depth_range(&self) -> (f32, f32) {
        match *self {
            Projection::ThinLens(k) => (k.near, k.far),
            Projection::Orthographic { near, far, .. } | Projection::Perspective { near, far, .. } => {
                (near, far)
            }
        }
    }
}

/// One view of the scene.
#[derive(Clone, Debug)]
pub struct View {
    /// For debug labels and messages (`camera`, `light 0`).
    pub name: String,
    /// World → view space at shutter open `[0]` and close `[1]`.
    pub world_to_view: [Mat4; 2],
    pub projection: Projection,
    /// The scene in this view's space at both shutter ends (object → view transforms, lights).
    pub space: CameraSpaceScene,
}

impl View {
    /// The scene's camera for an image of `width × height`.
    pub fn camera(scene: &Scene, width: u32, height: u32) -> View {
        let c = &scene.camera;
        let world_to_view = [c.open.view_matrix(), c.pose_at_close().view_matrix()];
        View {
            name: "camera".into(),
            world_to_view,
            projection: Projection::ThinLens(c.intrinsics(width, height)),
            space: CameraSpaceScene::seen_from(scene, world_to_view),
        }
    }

    /// An orthographic view along `direction` (from the light into the scene) that frames every
    /// vertex of the scene at every motion key, for a directional light's `size × size` shadow map.
    /// `None` when the scene has no geometry or the direction is not finite and non-zero.
    pub fn directional_light(scene: &Scene, name: &str, direction: Vec3, size: u32) -> Option<View> {
        let dir = direction.try_normalize()?;
        let (centre, radius) = scene_bounds(scene)?;
        let up = if dir.y.abs() > 0.99 { Vec3::Z } else { Vec3::Y };
        let eye = centre - dir * (2.0 * radius);
        let m = Mat4::look_at_rh(eye, centre, up);
        let world_to_view = [m, m];
        Some(View {
            name: name.to_string(),
            world_to_view,
            projection: Projection::Orthographic {
                width: size,
                height: size,
                half_extent: Vec2::splat(radius),
                near: radius,
                far: 3.0 * radius,
            },
            space: CameraSpaceScene::seen_from(scene, world_to_view),
        })
    }

    /// A `size × size` perspective view from `position` looking along `direction` (up `up`), with
    /// `half_angle_deg` from the axis to the image's edge, its depth range framing every vertex of the
    /// scene at every motion key in front of it: a spot light's shadow map, or one face of a point
    /// light's ([`cube_face_of`]). `None` without geometry or for a degenerate direction.
    pub fn perspective_light(
        scene: &Scene,
        name: &str,
        position: Vec3,
        direction: Vec3,
        up: Vec3,
        half_angle_deg: f32,
        size: u32,
    ) -> Option<View> {
        let dir = direction.try_normalize()?;
        let (centre, radius) = scene_bounds(scene)?;
        let m = Mat4::look_at_rh(position, position + dir, up);
        let world_to_view = [m, m];
        // Everything lies within `radius` of `centre`: the far plane just past it, the near plane a
        // small fraction of the scene's size from the light (reversed-Z float depth keeps precision).
        let far = (position.distance(centre) + radius) * 1.01;
        let near = (far * 1e-4).max(1e-4);
        let pixel_scale = 0.5 * size as f32 / half_angle_deg.to_radians().tan();
        Some(View {
            name: name.to_string(),
            world_to_view,
            projection: Projection::Perspective { width: size, height: size, pixel_scale, near, far },
            space: CameraSpaceScene::seen_from(scene, world_to_view),
        })
    }

    /// Image size in pixels.
    pub fn size(&self) -> (u32, u32) {
        self.projection.size()
    }

    /// The thin-lens intrinsics of a camera view (None for other projections).
    pub fn intrinsics(&self) -> Option<Intrinsics> {
        match self.projection {
            Projection::ThinLens(k) => Some(k),
            _ => None,
        }
    }
}

/// The centre and radius of a sphere holding every vertex of `scene` at every transform key; `None`
/// without geometry (or with non-finite positions).
pub fn scene_bounds(scene: &Scene) -> Option<(Vec3, f32)> {
    let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    for o in &scene.objects {
        for &(_, m) in &o.transforms {
            for &p in &o.mesh.positions {
                let w = m.transform_point3(p);
                (lo, hi) = (lo.min(w), hi.max(w));
            }
        }
    }
    if !(lo.is_finite() && hi.is_finite()) {
        return None;
    }
    Some((0.5 * (lo + hi), (0.5 * (hi - lo).length()).max(1e-3)))
}

/// The six faces of a point light's cube map, in order +X, −X, +Y, −Y, +Z, −Z: the direction each
/// face looks along and its up vector (world space). Face `k` sees the points whose largest
/// coordinate (relative to the light) in absolute value is along its direction ([`cube_face_of`]).
pub const CUBE_FACES: [(Vec3, Vec3); 6] = [
    (Vec3::X, Vec3::NEG_Y),
    (Vec3::NEG_X, Vec3::NEG_Y),
    (Vec3::Y, Vec3::Z),
    (Vec3::NEG_Y, Vec3::NEG_Z),
    (Vec3::Z, Vec3::NEG_Y),
    (Vec3::NEG_Z, Vec3::NEG_Y),
];

/// The cube face (index into [`CUBE_FACES`]) that sees direction `d` from the light: its largest
/// coordinate in absolute value, ties to the earlier axis. `cube_face_of` in `common/shadow.glsl`.
pub fn cube_face_of(d: Vec3) -> usize {
    let a = d.abs();
    if a.x >= a.y && a.x >= a.z {
        if d.x >= 0.0 {
            0
        } else {
            1
        }
    } else if a.y >= a.z {
        if d.y >= 0.0 {
            2
        } else {
            3
        }
    } else if d.z >= 0.0 {
        4
    } else {
        5
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::builtin::builtin_scene;

    #[test]
    fn camera_view_is_the_camera_space_scene() {
        let scene = builtin_scene("default").expect("built-in").expect("loads");
        let v = View::camera(&scene, 64, 36);
        let cs = CameraSpaceScene::new(&scene);
        assert_eq!(v.space.objects, cs.objects);
        assert_eq!(v.space.lights, cs.lights);
        assert_eq!(v.size(), (64, 36));
    }

    #[test]
    fn directional_light_view_frames_every_vertex() {
        let scene = builtin_scene("default").expect("built-in").expect("loads");
        let v = View::directional_light(&scene, "sun", Vec3::new(-0.3, -1.0, -0.2), 128).expect("view");
        let Projection::Orthographic { half_extent, near, far, .. } = v.projection else { panic!() };
        for (o, motion) in scene.objects.iter().zip(&v.space.objects) {
            for &p in &o.mesh.positions {
                for q in motion.positions(p) {
                    assert!(
                        q.x.abs() <= half_extent.x * 1.0001 && q.y.abs() <= half_extent.y * 1.0001,
                        "{q}"
                    );
                    assert!(-q.z >= near * 0.9999 && -q.z <= far * 1.0001, "{q}");
                }
            }
        }
        assert!(View::directional_light(&scene, "bad", Vec3::ZERO, 8).is_none());
    }
}
