//! The thesis' view-space bounding volumes (Toth & Linder, §4.3–4.5 and §4.8.2), as the thesis builds
//! them: closed volumes around the triangle's **discs of confusion** in view space, seen through the
//! pinhole camera. [`super::BoundKind::Hexagon3d`], [`super::BoundKind::Wedge`] and
//! [`super::BoundKind::ReducedWedge`] draw them (`super::bound`, `bound_volume_` in bounds.glsl).
//! Departure: the thesis emits the prism as geometry and lets the hardware clip it; we draw its
//! pinhole image — the convex hull of its projected vertices, the same region — when the prism lies
//! in front of the near plane, and the space-time convex hull otherwise.
//!
//! **Disc of confusion.** Through lens point `L` (unit aperture) a point at view depth `z` lands
//! `φ(z)·L` pixels from its pinhole projection; at depth `z` that is a lateral view-space offset of
//! `A·(z/F − 1)·L`. So the vertex `v` is seen through the lens wherever the pinhole sees the disc
//! centred at `v`, in the plane of constant depth, of radius `R(z) = A·|z − F|/F`. A point of the
//! triangle (a convex combination of the vertices, the offset affine in depth) lands where the pinhole
//! sees the same combination of disc points: every volume containing the three discs is a bound, its
//! pinhole image holding every pixel the triangle can cover through any lens point.
//!
//! **3D hexagon (§4.4).** In the triangle's plane: each edge moved outward until it touches the discs
//! (orthogonally projected to the plane they are ellipses), plus at each vertex an edge at the mean
//! angle of the two edges meeting there, touching the discs too; the six half-planes bound a hexagon,
//! which is then inflated along the triangle's normal by the largest distance of a disc point from the
//! plane: a hexagonal prism (12 vertices). Departure, as for the image-space shapes: each offset is the
//! support of all three discs in that direction (the thesis takes the edge's two endpoint discs and the
//! vertex's own disc), so a large disc at the third vertex cannot poke out; in ordinary cases it is the
//! same line.
//!
//! **Wedge (§4.5).** The same without the averaged corner edges: a triangular prism (6 vertices).
//!
//! **Reduced wedge (§4.5).** The wedge's silhouette from the eye: the same screen area with fewer
//! triangles, valid while the wedge lies in front of the near plane; otherwise (the lens reaching into
//! the wedge) the full wedge is drawn.
//!
//! Only still triangles (the thesis is defocus-only): a triangle that moves keeps the space-time hull
//! of the image-space bounds.

use glam::{Vec2, Vec3};

use super::hull::convex_hull;
use super::shapes::RADIUS_ROUND_UP;
use super::ScreenBound;
use crate::scene::Intrinsics;

/// Which volume.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum VolumeShape {
    /// Hexagonal prism: three edge and three corner half-planes.
    Hexagon,
    /// Triangular prism: the three edge half-planes.
    Wedge,
}

/// A convex view-space volume: the convex hull of `vertices` (the prism's bottom then top).
#[derive(Clone, Debug, PartialEq)]
pub struct Volume {
    pub vertices: Vec<Vec3>,
}

/// Radius of the disc of confusion at view depth `z` (view-space units), rounded up.
pub fn disc_radius(k: &Intrinsics, z: f32) -> f32 {
    k.aperture_radius * (z - k.focus_distance).abs() / k.focus_distance * RADIUS_ROUND_UP
}

/// Support of the disc at `v` of radius `r` (in the plane of constant depth) in unit direction `u`.
fn disc_support(v: Vec3, r: f32, u: Vec3) -> f32 {
    u.dot(v) + r * (1.0 - u.z * u.z).max(0.0).sqrt()
}

/// A triangle whose height over its longest edge is at most this is a sliver for the volumes: its
/// plane, from the cross product of two nearly parallel edges, is known to `f32` only roughly (the
/// heavy property run found a sliver of height/length 1e-4 whose computed plane was off by a tenth of a
/// radian), so [`prism`] declines it and the caller falls back to the convex hull. The thesis, too,
/// names slivers the wedge's worst case and points them to the other methods (§4.5).
pub const VOLUME_SLIVER: f32 = 1e-2;

/// The prism of `shape` around still triangle `tri` (view space) for the camera `k`; `None` for a
/// non-finite triangle or a sliver ([`VOLUME_SLIVER`]): the caller falls back to the convex hull.
pub fn prism(tri: &[Vec3; 3], k: &Intrinsics, shape: VolumeShape) -> Option<Volume> {
    let [a, b, c] = *tri;
    if !(a.is_finite() && b.is_finite() && c.is_finite()) {
        return None;
    }
    let n = (b - a).cross(c - a);
    let scale = (b - a).length().max((c - a).length()).max((c - b).length());
    let area2 = n.length();
    if area2.is_nan() || area2 <= VOLUME_SLIVER * scale * scale {
        return None;
    }
    let n = n.normalize();
    let r = tri.map(|v| disc_radius(k, -v.z));
    // Outward in-plane normals of the edges (i → j, the third vertex o inside).
    let edge_normal = |i: usize, j: usize, o: usize| {
        let m = (tri[j] - tri[i]).cross(n).normalize();
        if m.dot(tri[o] - tri[i]) > 0.0 {
            -m
        } else {
            m
        }
    };
    let m01 = edge_normal(0, 1, 2);
    let m12 = edge_normal(1, 2, 0);
    let m20 = edge_normal(2, 0, 1);
    let mut normals = vec![m01, m12, m20];
    if shape == VolumeShape::Hexagon {
        // The corner edges: the mean direction of the two edge normals meeting at each vertex.
        for (p, q) in [(m20, m01), (m01, m12), (m12, m20)] {
            if let Some(m) = (p + q).try_normalize() {
                normals.push(m);
            }
        }
    }
    // In-plane coordinates around the centroid.
    let centre = (a + b + c) / 3.0;
    let e1 = (b - a).normalize();
    let e2 = n.cross(e1);
    let rmax = r.iter().copied().fold(0.0f32, f32::max);
    let half = 4.0 * (scale + rmax) + 1e-6;
    let mut poly =
        vec![Vec2::new(-half, -half), Vec2::new(half, -half), Vec2::new(half, half), Vec2::new(-half, half)];
    for m in normals {
        // Half-plane m·x ≤ d with d the support of the three discs (plus a rounding pad).
        let d = (0..3).map(|i| disc_support(tri[i], r[i], m)).fold(f32::NEG_INFINITY, f32::max);
        let pad = 1e-5 * (d.abs() + scale + rmax);
        let m2 = Vec2::new(m.dot(e1), m.dot(e2));
        let d2 = d - m.dot(centre) + pad;
        poly = clip_half_plane(&poly, m2, d2);
        if poly.is_empty() {
            return None;
        }
    }
    // Inflate: a disc point (depth-plane offset, |d| ≤ r) lies r·|n projected off the z axis| from its
    // vertex's plane, and the vertex itself |n·(v − centre)| from the plane through the centroid (zero
    // but for rounding of n).
    let off_z = (1.0 - n.z * n.z).max(0.0).sqrt();
    let lift = (0..3).map(|i| n.dot(tri[i] - centre).abs() + r[i] * off_z).fold(0.0f32, f32::max);
    let lift = lift * RADIUS_ROUND_UP + 1e-6 * (scale + rmax);
    let lifted = |p: Vec2, s: f32| centre + e1 * p.x + e2 * p.y + n * (s * lift);
    let mut vertices: Vec<Vec3> = poly.iter().map(|&p| lifted(p, -1.0)).collect();
    vertices.extend(poly.iter().map(|&p| lifted(p, 1.0)));
    Some(Volume { vertices })
}

/// Sutherland–Hodgman: the part of convex polygon `poly` with `m·x ≤ d`.
fn clip_half_plane(poly: &[Vec2], m: Vec2, d: f32) -> Vec<Vec2> {
    let mut out = Vec::with_capacity(poly.len() + 1);
    for i in 0..poly.len() {
        let (p, q) = (poly[i], poly[(i + 1) % poly.len()]);
        let (fp, fq) = (m.dot(p) - d, m.dot(q) - d);
        if fp <= 0.0 {
            out.push(p);
        }
        if (fp < 0.0 && fq > 0.0) || (fp > 0.0 && fq < 0.0) {
            out.push(p + (q - p) * (fp / (fp - fq)));
        }
    }
    out
}

/// What the pinhole camera sees of `volume` in front of the near plane: the convex hull of the
/// projections of its vertices at depth ≥ near and of the near plane's intersections with the segments
/// between its vertices (the clipped volume's vertices are among them). `Culled` when nothing is in
/// front of the near plane. This is the region the rasterizer must cover; the reduced wedge's
/// silhouette is exactly this region for the wedge.
pub fn screen_region(volume: &Volume, k: &Intrinsics) -> ScreenBound {
    let v = &volume.vertices;
    let near = k.near;
    let mut points: Vec<Vec3> = v.iter().copied().filter(|p| -p.z >= near).collect();
    for i in 0..v.len() {
        for j in i + 1..v.len() {
            let (zi, zj) = (-v[i].z, -v[j].z);
            if (zi - near) * (zj - near) < 0.0 {
                let t = (near - zi) / (zj - zi);
                let p = v[i] + (v[j] - v[i]) * t;
                points.push(Vec3::new(p.x, p.y, -near));
            }
        }
    }
    if points.is_empty() {
        return ScreenBound::Culled;
    }
    let projected: Vec<Vec2> = points.iter().map(|&p| k.project(p, Vec2::ZERO)).collect();
    if projected.iter().any(|p| !p.is_finite()) {
        return ScreenBound::viewport(k);
    }
    ScreenBound::Polygon(convex_hull(&projected))
}

/// Is the whole volume in front of the near plane (the reduced wedge's silhouette is then drawable)?
pub fn in_front_of_near(volume: &Volume, k: &Intrinsics) -> bool {
    volume.vertices.iter().all(|p| -p.z > k.near)
}
