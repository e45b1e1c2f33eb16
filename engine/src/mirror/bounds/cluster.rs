//! Cluster bounds: the CPU mirror of `shaders-glsl/stochastic/clusters.comp` and of
//! `sample_sees_cluster` in `stochastic.frag` (`techniques::stochastic::Clusters`). A cluster of
//! triangles gets one screen bound, the union of its triangles' [`BoundKind::BoundingBox`] bounds, for
//! the rasterizer; and, per sample, a cheap test of whether the sample can see the cluster at all, so
//! the fragment stage tests the cluster's triangles only for those samples. Through lens point L a
//! camera-space point lands at its lens-centre (pinhole) pixel position moved by `φ(z)·(L.x, −L.y)`
//! ([`Intrinsics::project`]) with φ increasing in depth: the cluster's pinhole box of its vertices
//! (the projection of a moving triangle stays inside that of its end vertices), moved by the range of
//! φ over its depths, holds every point it has for that lens. Both must be conservative: every sample
//! the inside test says hits one of the triangles passes (property-tested in `bounds/tests.rs`).

use glam::{Vec2, Vec4};

use super::{bound, BoundKind, MovingTriangle};
use crate::geometry::{back_facing_segment, BACK_FACING_MARGIN};
use crate::scene::Intrinsics;

/// A cluster's bounds over one key segment (its triangles' end vertices).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ClusterBound {
    /// Screen box (pixels) holding every triangle's `bbox` bound; `None` when all are culled.
    pub screen: Option<(Vec2, Vec2)>,
    /// Lens-centre pixel box of the vertices (x0, y0, x1, y1).
    pub pinhole: Vec4,
    /// φ at the nearest and farthest vertex; `None` when a vertex is at or behind the near plane
    /// (every sample must be tested).
    pub phi: Option<(f32, f32)>,
}

/// The cluster bound of `tris` (as `clusters.comp`; a triangle whose bound is the viewport makes the
/// screen box the viewport). `one_sided`: the triangles' material is one-sided, and those facing away
/// from every lens point over their motion ([`crate::geometry::back_facing_segment`]) are left out as
/// culled ones are — no sample can hit them from the front.
pub fn cluster_bound(tris: &[MovingTriangle], k: &Intrinsics, one_sided: bool) -> ClusterBound {
    let (mut lo, mut hi) = (Vec2::INFINITY, Vec2::NEG_INFINITY);
    let (mut pin_lo, mut pin_hi) = (Vec2::INFINITY, Vec2::NEG_INFINITY);
    let (mut z_lo, mut z_hi) = (f32::INFINITY, f32::NEG_INFINITY);
    let mut viewport = false;
    for tri in tris {
        let b = bound(tri, k, BoundKind::BoundingBox);
        let Some((l, h)) = b.aabb() else { continue };
        if one_sided && back_facing_segment(k.aperture_radius, &tri.v0, &tri.v1, BACK_FACING_MARGIN) {
            continue;
        }
        viewport |= b.is_viewport(k);
        (lo, hi) = (lo.min(l), hi.max(h));
        for v in tri.end_vertices() {
            let z = -v.z;
            (z_lo, z_hi) = (z_lo.min(z), z_hi.max(z));
            let p = Vec2::new(
                0.5 * k.width + k.pixel_scale * (v.x / z),
                0.5 * k.height - k.pixel_scale * (v.y / z),
            );
            (pin_lo, pin_hi) = (pin_lo.min(p), pin_hi.max(p));
        }
    }
    if viewport {
        (lo, hi) = (Vec2::ZERO, Vec2::new(k.width, k.height));
    }
    let bounded = z_lo > k.near && pin_lo.abs().max(pin_hi.abs()).max_element() < 1e30;
    ClusterBound {
        screen: (lo.x <= hi.x).then_some((lo, hi)),
        pinhole: Vec4::new(pin_lo.x, pin_lo.y, pin_hi.x, pin_hi.y),
        phi: bounded.then(|| (k.circle_of_confusion_px(z_lo), k.circle_of_confusion_px(z_hi))),
    }
}

/// Can the sample at pixel position `q` through lens point `lens` (unit aperture coordinates) see the
/// cluster? `sample_sees_cluster` in `stochastic.frag`, with its padding (0.01 px + 1e-4 relative).
pub fn sample_sees_cluster(c: &ClusterBound, q: Vec2, lens: Vec2) -> bool {
    let Some((phi_lo, phi_hi)) = c.phi else { return true };
    let l = Vec2::new(lens.x, -lens.y);
    let (a, b) = (phi_lo * l, phi_hi * l);
    let lo = Vec2::new(c.pinhole.x, c.pinhole.y) + a.min(b);
    let hi = Vec2::new(c.pinhole.z, c.pinhole.w) + a.max(b);
    let pad = Vec2::splat(0.01) + 1e-4 * lo.abs().max(hi.abs());
    q.cmpge(lo - pad).all() && q.cmple(hi + pad).all()
}

/// The order in which `mesh`'s triangles form clusters: sorted along a Morton (Z-order) curve through
/// their centroids in object space (10 bits per axis over the mesh's box), so consecutive triangles of
/// the order are neighbours whatever order the file stored them in. The clusters are runs of this
/// order; the triangles keep their own indices (the visibility payload, and so the image, does not
/// depend on it). Ties keep the stored order.
pub fn cluster_order(mesh: &crate::scene::Mesh) -> Vec<u32> {
    let tris: Vec<glam::Vec3> = mesh
        .indices
        .chunks_exact(3)
        .map(|t| {
            (mesh.positions[t[0] as usize] + mesh.positions[t[1] as usize] + mesh.positions[t[2] as usize])
                / 3.0
        })
        .collect();
    let (lo, hi) =
        tris.iter().fold((glam::Vec3::INFINITY, glam::Vec3::NEG_INFINITY), |(l, h), &c| (l.min(c), h.max(c)));
    let scale = 1023.0 / (hi - lo).max(glam::Vec3::splat(1e-30));
    let spread = |v: u32| -> u64 {
        // The 10 bits of v at every third bit.
        let mut x = v as u64 & 0x3ff;
        x = (x | (x << 16)) & 0x0300_00ff;
        x = (x | (x << 8)) & 0x0300_f00f;
        x = (x | (x << 4)) & 0x030c_30c3;
        (x | (x << 2)) & 0x0924_9249
    };
    let code = |c: glam::Vec3| {
        let q = ((c - lo) * scale).clamp(glam::Vec3::ZERO, glam::Vec3::splat(1023.0));
        spread(q.x as u32) | (spread(q.y as u32) << 1) | (spread(q.z as u32) << 2)
    };
    let mut order: Vec<u32> = (0..tris.len() as u32).collect();
    order.sort_by_key(|&i| code(tris[i as usize]));
    order
}
