//! The scene in camera space at its motion keys — the form every technique and the CPU reference
//! consume, so they all move geometry the same way.
//!
//! docs/MODEL.md "Shutter": between two motion keys, a vertex's camera-space position at time t is the
//! *linear interpolation* of its camera-space positions at the keys (so clip-space positions are
//! piecewise linear in t, and linear within a key segment as McGuire'10, AAS and ATSS assume). Normals
//! are interpolated the same way and renormalised. An object's keys are the shutter ends plus its own
//! transform keys ([`super::Object::transforms`]); with only the ends it moves linearly over the whole
//! shutter. The camera moves linearly in camera space: a world point's camera-space position is the
//! interpolation of its positions seen from the open and close poses, so an object's model-view at an
//! interior key is `lerp(view_open, view_close, t) · model(t)` (an affine map, exactly what the
//! interpolation of a still point gives), and lights — which have no keys — are interpolated between
//! the ends alike (a spot's position like a point light's, its axis like a directional light's
//! direction, renormalised).

use glam::{Mat3, Mat4, Vec3};

use super::{Light, Scene};
use crate::geometry::KeyTimes;
use crate::shading::ShadingLight;

/// An object's model-view transforms at its motion keys.
#[derive(Clone, Debug, PartialEq)]
pub struct ObjectMotion {
    /// The keys' shutter times (at least 0 and 1).
    pub keys: KeyTimes,
    /// Object → view space at each key.
    pub model_view: Vec<Mat4>,
    /// Inverse-transpose of the upper 3×3 of `model_view`, for normals.
    pub normal_matrix: Vec<Mat3>,
}

impl ObjectMotion {
    /// The motion through `model_view` at `keys` (one matrix per key).
    pub fn new(keys: KeyTimes, model_view: Vec<Mat4>) -> ObjectMotion {
        assert_eq!(keys.times().len(), model_view.len(), "one model-view per key");
        let normal_matrix = model_view.iter().map(|m| Mat3::from_mat4(*m).inverse().transpose()).collect();
        ObjectMotion { keys, model_view, normal_matrix }
    }
    pub fn is_moving(&self) -> bool {
        self.model_view.iter().any(|m| *m != self.model_view[0])
    }
    /// Key segments (keys − 1).
    pub fn segments(&self) -> usize {
        self.keys.segments()
    }
    /// Camera-space position of object-space point `p` at every key.
    pub fn positions(&self, p: Vec3) -> Vec<Vec3> {
        self.model_view.iter().map(|m| m.transform_point3(p)).collect()
    }
    /// Camera-space (unnormalised) normal at every key.
    pub fn normals(&self, n: Vec3) -> Vec<Vec3> {
        self.normal_matrix.iter().map(|m| *m * n).collect()
    }
}

/// A light in camera space at shutter open `[0]` and close `[1]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum CameraSpaceLight {
    /// Unit direction towards the light at each end.
    Directional {
        to_light: [Vec3; 2],
        color: Vec3,
    },
    Point {
        position: [Vec3; 2],
        color: Vec3,
    },
    /// Position and unit axis (from the light into the scene) at each end; the cone's cosines.
    Spot {
        position: [Vec3; 2],
        axis: [Vec3; 2],
        cos_inner: f32,
        cos_outer: f32,
        color: Vec3,
    },
}

impl CameraSpaceLight {
    /// The light at shutter time `t`.
    pub fn at(&self, t: f32) -> ShadingLight {
        match *self {
            CameraSpaceLight::Directional { to_light, color } => ShadingLight::Directional {
                to_light: to_light[0].lerp(to_light[1], t).normalize_or_zero(),
                color,
            },
            CameraSpaceLight::Point { position, color } => {
                ShadingLight::Point { position: position[0].lerp(position[1], t), color }
            }
            CameraSpaceLight::Spot { position, axis, cos_inner, cos_outer, color } => ShadingLight::Spot {
                position: position[0].lerp(position[1], t),
                axis: axis[0].lerp(axis[1], t).normalize_or_zero(),
                cos_inner,
                cos_outer,
                color,
            },
        }
    }
}

/// The whole scene in camera space at both shutter ends.
#[derive(Clone, Debug)]
pub struct CameraSpaceScene {
    pub objects: Vec<ObjectMotion>,
    pub lights: Vec<CameraSpaceLight>,
}

impl CameraSpaceScene {
    /// The scene seen from its camera.
    pub fn new(scene: &Scene) -> Self {
        CameraSpaceScene::seen_from(
            scene,
            [scene.camera.open.view_matrix(), scene.camera.pose_at_close().view_matrix()],
        )
    }

    /// The scene in the space of any view whose world → view transform is `views[0]` at shutter
    /// open and `views[1]` at close (a light's view for a shadow map; [`super::View`]).
    pub fn seen_from(scene: &Scene, views: [Mat4; 2]) -> Self {
        let objects = scene
            .objects
            .iter()
            .map(|o| {
                // The ends, and the object's interior keys (validated by the scene file; a key outside
                // (0, 1) or out of order is skipped here rather than trusted).
                let mut times = vec![0.0f32];
                let mut model_view = vec![views[0] * o.transform_open()];
                for &(t, m) in &o.transforms[1..] {
                    if t > *times.last().expect("one") && t < 1.0 {
                        let view = views[0] + (views[1] - views[0]) * t;
                        times.push(t);
                        model_view.push(view * m);
                    }
                }
                times.push(1.0);
                model_view.push(views[1] * o.transform_at_close());
                let keys = KeyTimes::new(times).expect("increasing times from 0 to 1");
                ObjectMotion::new(keys, model_view)
            })
            .collect();
        let lights = scene
            .lights
            .iter()
            .map(|l| match *l {
                Light::Directional { direction, color, .. } => CameraSpaceLight::Directional {
                    to_light: [
                        views[0].transform_vector3(-direction).normalize_or_zero(),
                        views[1].transform_vector3(-direction).normalize_or_zero(),
                    ],
                    color,
                },
                Light::Point { position, color, .. } => CameraSpaceLight::Point {
                    position: [views[0].transform_point3(position), views[1].transform_point3(position)],
                    color,
                },
                Light::Spot { position, direction, inner_deg, outer_deg, color, .. } => {
                    CameraSpaceLight::Spot {
                        position: [views[0].transform_point3(position), views[1].transform_point3(position)],
                        axis: [
                            views[0].transform_vector3(direction).normalize_or_zero(),
                            views[1].transform_vector3(direction).normalize_or_zero(),
                        ],
                        cos_inner: inner_deg.to_radians().cos(),
                        cos_outer: outer_deg.to_radians().cos(),
                        color,
                    }
                }
            })
            .collect();
        CameraSpaceScene { objects, lights }
    }

    /// All lights at shutter time `t`.
    /// Whether nothing moves in camera space over the shutter: no object, no light (the camera's
    /// motion moves both).
    pub fn is_still(&self) -> bool {
        !self.objects.iter().any(|o| o.is_moving()) && self.lights.iter().all(|l| l.at(0.0) == l.at(1.0))
    }

    pub fn lights_at(&self, t: f32) -> Vec<ShadingLight> {
        self.lights.iter().map(|l| l.at(t)).collect()
    }
}
