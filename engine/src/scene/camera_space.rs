//! The scene in camera space at shutter open and close — the form every technique and the CPU
//! reference consume, so they all move geometry the same way.
//!
//! DESIGN.md "Shutter": a vertex's camera-space position at time t is the *linear interpolation* of its
//! camera-space positions at t = 0 and t = 1 (so clip-space positions are linear in t, as McGuire'10,
//! AAS and ATSS assume). Normals and light directions are interpolated the same way and renormalised;
//! point-light positions are interpolated. Both the camera and the objects may move; only their
//! combination (model-view) matters.

use glam::{Mat3, Mat4, Vec3};

use super::{Light, Scene};
use crate::shading::ShadingLight;

/// An object's model-view transform at shutter open `[0]` and close `[1]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ObjectMotion {
    pub model_view: [Mat4; 2],
    /// Inverse-transpose of the upper 3×3 of `model_view`, for normals.
    pub normal_matrix: [Mat3; 2],
}

impl ObjectMotion {
    pub fn is_moving(&self) -> bool {
        self.model_view[0] != self.model_view[1]
    }
    /// Camera-space position of object-space point `p` at both shutter ends.
    pub fn positions(&self, p: Vec3) -> [Vec3; 2] {
        [self.model_view[0].transform_point3(p), self.model_view[1].transform_point3(p)]
    }
    /// Camera-space (unnormalised) normal at both shutter ends.
    pub fn normals(&self, n: Vec3) -> [Vec3; 2] {
        [self.normal_matrix[0] * n, self.normal_matrix[1] * n]
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
                let mv = [views[0] * o.transform_open, views[1] * o.transform_at_close()];
                ObjectMotion {
                    model_view: mv,
                    normal_matrix: [
                        Mat3::from_mat4(mv[0]).inverse().transpose(),
                        Mat3::from_mat4(mv[1]).inverse().transpose(),
                    ],
                }
            })
            .collect();
        let lights = scene
            .lights
            .iter()
            .map(|l| match *l {
                Light::Directional { direction, color } => CameraSpaceLight::Directional {
                    to_light: [
                        views[0].transform_vector3(-direction).normalize_or_zero(),
                        views[1].transform_vector3(-direction).normalize_or_zero(),
                    ],
                    color,
                },
                Light::Point { position, color } => CameraSpaceLight::Point {
                    position: [views[0].transform_point3(position), views[1].transform_point3(position)],
                    color,
                },
            })
            .collect();
        CameraSpaceScene { objects, lights }
    }

    /// All lights at shutter time `t`.
    pub fn lights_at(&self, t: f32) -> Vec<ShadingLight> {
        self.lights.iter().map(|l| l.at(t)).collect()
    }
}
