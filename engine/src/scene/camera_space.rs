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

use glam::{DMat3, Mat3, Mat4, Vec3};

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
    /// Object-space normals → view space at each key: [`normal_matrices`] of `model_view`.
    pub normal_matrix: Vec<Mat3>,
}

impl ObjectMotion {
    /// The motion through `model_view` at `keys` (one matrix per key).
    pub fn new(keys: KeyTimes, model_view: Vec<Mat4>) -> ObjectMotion {
        assert_eq!(keys.times().len(), model_view.len(), "one model-view per key");
        let normal_matrix = normal_matrices(&model_view);
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

/// The matrices that carry an object's normals to view space at each of its keys: the cofactor matrix
/// of each key's upper 3×3 `M` (columns `c1 × c2, c2 × c0, c0 × c1`), which is `det(M)·M⁻ᵀ`, all
/// divided by one positive constant per object (its largest entry over the keys) so that huge or
/// tiny scales neither overflow nor underflow; computed in f64.
///
/// Why not the inverse-transpose: a key whose transform is singular (a scale passing through 0,
/// 0.5 → −0.5 over three keys) has none — it was NaN and poisoned every shaded point of the
/// neighbouring segments (the forward passes went black; the stochastic rasterizer and the reference
/// fell back to the faceted geometric normal). The cofactor matrix is defined and continuous there:
/// for a scale `s` along one axis its entries are linear in `s`, so interpolating it between keys is
/// exact for such a motion, and through `s = 0` the normal turns to the flattened surface's. It also
/// keeps the normal on the side of the winding (the geometric normal `(b − a) × (c − a)` is the
/// cofactor matrix times the object-space one) under a mirroring key (det < 0), as every technique
/// and the reference assume when they turn the normal to the side a ray or fragment sees; the
/// inverse-transpose pointed such an object's normals inwards and lit it from behind. The common
/// positive factor changes no direction and, shared by the keys, no interpolation.
pub fn normal_matrices(model_view: &[Mat4]) -> Vec<Mat3> {
    let cofactors: Vec<DMat3> = model_view
        .iter()
        .map(|m| {
            let m = DMat3::from_mat4(m.as_dmat4());
            DMat3::from_cols(m.y_axis.cross(m.z_axis), m.z_axis.cross(m.x_axis), m.x_axis.cross(m.y_axis))
        })
        .collect();
    let largest = cofactors
        .iter()
        .flat_map(|c| c.to_cols_array())
        .filter(|x| x.is_finite())
        .fold(0.0f64, |m, x| m.max(x.abs()));
    let scale = if largest > 0.0 { 1.0 / largest } else { 1.0 };
    cofactors.iter().map(|c| (*c * scale).as_mat3()).collect()
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

#[cfg(test)]
mod tests {
    use super::*;

    /// The normal matrices are finite at a singular key, turn normals to the side of the winding
    /// (the transformed triangle's geometric normal) under a mirroring key, and are the
    /// inverse-transpose's directions for an ordinary one.
    #[test]
    fn normal_matrices_are_defined_for_singular_and_mirroring_keys() {
        let (a, b, c) = (Vec3::new(0.2, -0.1, 0.3), Vec3::new(1.0, 0.2, -0.4), Vec3::new(-0.3, 0.9, 0.5));
        let face = (b - a).cross(c - a);
        let base = Mat4::from_translation(Vec3::new(0.5, -1.0, -4.0)) * Mat4::from_rotation_y(0.7);
        let keys: Vec<Mat4> = [0.5f32, 0.0, -0.5, 1e-30]
            .iter()
            .map(|&s| base * Mat4::from_scale(Vec3::new(s, 1.0, 2.0)))
            .collect();
        let n = normal_matrices(&keys);
        for (k, m) in keys.iter().enumerate() {
            assert!(n[k].to_cols_array().iter().all(|x| x.is_finite()), "key {k}: {:?}", n[k]);
            let geometric = (m.transform_point3(b) - m.transform_point3(a))
                .cross(m.transform_point3(c) - m.transform_point3(a));
            let mapped = n[k] * face;
            assert!(mapped.length() > 0.0, "key {k}: the face's normal vanished");
            let cos = mapped.dot(geometric) / (mapped.length() * geometric.length());
            if geometric.length() > 1e-6 {
                assert!(cos > 0.9999, "key {k}: the normal is off the winding's side (cos {cos})");
            }
        }
        let inverse_transpose = Mat3::from_mat4(keys[0]).inverse().transpose() * face;
        assert!((n[0] * face).normalize().dot(inverse_transpose.normalize()) > 0.99999);
        // The singular key's normal is the flattened surface's: along the squashed axis.
        let axis = base.transform_vector3(Vec3::X);
        assert!((n[1] * face).normalize().dot(axis).abs() > 0.99999);
    }
}
