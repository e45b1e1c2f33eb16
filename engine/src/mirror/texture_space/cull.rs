//! Conservative frustum culling of pass 1 over the lens and the shutter: a triangle no sample of the
//! frame can hit — at any lens position, at any time — is not shaded into the atlas.
//!
//! Seen through lens point `L = R·(u, v, 0)` (`|u|, |v| ≤ 1`), a camera-space point `P` at view depth
//! `d = −P.z > 0` lands on the image at the tangent `P.xy/d + R·(u, v)·(1/F − 1/d)`
//! ([`Intrinsics::project`]). It lies left of the image's left edge `−tₓ` for every lens point iff
//! `P.x + tₓ·d + R·|d/F − 1| < 0` — a convex function of `P` below zero, so a convex set: when every
//! vertex of the triangle at every key time of its motion is in it, so is every point the triangle
//! sweeps over the shutter (vertices move linearly between keys in camera space, as every pass draws
//! them), and none of it reaches the image through any lens point. The same for the right, top and
//! bottom edges, and the linear near and far planes (the rasterizers clip there). The edges are
//! pushed out by a margin in pixels.
//!
//! Back faces of one-sided materials ([`crate::scene::Material::one_sided`]) are culled too, when no
//! lens point at no time sees the triangle's front ([`back_facing`]). The ATSS paper cites Munkberg &
//! Akenine-Möller's 2011 culling for motion blur and depth of field for this; that paper is not among
//! our seeds, so the test here is derived on its own (below) rather than taken from it.

use glam::Vec3;

use crate::geometry::back_facing_segment;
pub use crate::geometry::BACK_FACING_MARGIN;

use crate::scene::camera::Intrinsics;
use crate::scene::camera_space::ObjectMotion;
use crate::scene::Mesh;

/// Pixels the image's edges are pushed out by: a sample lies inside its pixel, and a pixel inside the
/// image, so one pixel keeps the test conservative against rounding.
pub const CULL_MARGIN_PX: f32 = 1.0;

/// Whether no point of the convex hull of `points` (camera space: a triangle's vertices at every key
/// time) is visible through any lens point of `intrinsics` (a thin lens of radius `R`; any aperture
/// shape inside the unit disk).
pub fn outside_frustum(intrinsics: &Intrinsics, points: &[Vec3], margin_px: f32) -> bool {
    let s = intrinsics.pixel_scale;
    let tx = (0.5 * intrinsics.width + margin_px) / s;
    let ty = (0.5 * intrinsics.height + margin_px) / s;
    let (r, f) = (intrinsics.aperture_radius, intrinsics.focus_distance);
    let lens = |p: Vec3| r * (-p.z / f - 1.0).abs();
    let all = |test: &dyn Fn(Vec3) -> bool| points.iter().all(|&p| test(p));
    all(&|p| -p.z < intrinsics.near)
        || all(&|p| -p.z > intrinsics.far)
        || all(&|p| p.x + tx * -p.z + lens(p) < 0.0)
        || all(&|p| -p.x + tx * -p.z + lens(p) < 0.0)
        || all(&|p| p.y + ty * -p.z + lens(p) < 0.0)
        || all(&|p| -p.y + ty * -p.z + lens(p) < 0.0)
}

/// Pass 1's verdict for a triangle at `points` ([`key_points`]): outside the frustum widened by the
/// lens ([`outside_frustum`], margin [`CULL_MARGIN_PX`]), or facing away from every lens point at every
/// time ([`back_facing`]) when its material is one-sided. `(frustum, back)`: which test culls it (the
/// frustum's first).
pub fn culled(intrinsics: &Intrinsics, one_sided: bool, points: &[Vec3]) -> (bool, bool) {
    let frustum = outside_frustum(intrinsics, points, CULL_MARGIN_PX);
    (frustum, !frustum && one_sided && back_facing(intrinsics.aperture_radius, points))
}

/// Triangle `t` of `mesh` at every key of `motion`, camera space: the points [`outside_frustum`]
/// takes (pass 1's geometry stage transforms the same vertices by the same key matrices).
pub fn key_points(mesh: &Mesh, motion: &ObjectMotion, t: usize) -> Vec<Vec3> {
    let corners = [0, 1, 2].map(|k| mesh.positions[mesh.indices[3 * t + k] as usize]);
    motion.model_view.iter().flat_map(|mv| corners.map(|p| mv.transform_point3(p))).collect()
}

/// Whether every camera ray through any lens point (a thin lens of radius `aperture_radius`, any
/// aperture inside the disk) at any time of the shutter meets the triangle from its back: `keys` holds
/// its camera-space vertices at each key of its motion, three per key, in [`key_points`]' order, and
/// it moves linearly between consecutive keys. [`back_facing_segment`] (derived there) in every key
/// segment, with [`BACK_FACING_MARGIN`].
pub fn back_facing(aperture_radius: f32, keys: &[Vec3]) -> bool {
    back_facing_by(aperture_radius, keys, BACK_FACING_MARGIN)
}

/// [`back_facing`] with relative margin `margin` (tests compare the GPU's verdicts at other margins).
pub fn back_facing_by(aperture_radius: f32, keys: &[Vec3], margin: f32) -> bool {
    let tris: Vec<[Vec3; 3]> = keys.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect();
    match tris.len() {
        0 => false,
        1 => back_facing_segment(aperture_radius, &tris[0], &tris[0], margin),
        _ => tris.windows(2).all(|w| back_facing_segment(aperture_radius, &w[0], &w[1], margin)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::{concentric_disk, ApertureShape, Pcg32};
    use glam::Vec2;

    fn intrinsics(aperture_radius: f32, focus_distance: f32) -> Intrinsics {
        Intrinsics {
            width: 160.0,
            height: 90.0,
            pixel_scale: crate::scene::camera::pixel_scale(90, 40.0),
            aperture_radius,
            focus_distance,
            aperture: ApertureShape::default(),
            near: 0.05,
            far: 40.0,
        }
    }

    /// A culled moving triangle is never seen: random points of it at random times through random lens
    /// points never project inside the image between the near and far planes. And culling is not
    /// vacuous: a good share of the random triangles is culled, and one straddling the view axis never is.
    #[test]
    fn culled_triangles_are_never_seen_through_any_lens_point_or_time() {
        let mut rng = Pcg32::new(0xc011, 3);
        let mut unit = || rng.next_u32() as f32 / 4_294_967_296.0;
        let (mut culled, mut kept) = (0, 0);
        for case in 0..4000 {
            let intr = intrinsics(if case % 2 == 0 { 0.3 * unit() } else { 0.0 }, 1.0 + 8.0 * unit());
            // A triangle moving linearly over the shutter, anywhere in a box around the frustum
            // (behind the camera and past the far plane too).
            let centre = Vec3::new(40.0 * unit() - 20.0, 24.0 * unit() - 12.0, 2.0 - 47.0 * unit());
            let mut point = || centre + 2.0 * Vec3::new(unit() - 0.5, unit() - 0.5, unit() - 0.5);
            let open: [Vec3; 3] = [point(), point(), point()];
            let shift = Vec3::new(2.0 * unit() - 1.0, 2.0 * unit() - 1.0, 2.0 * unit() - 1.0);
            let close = open.map(|p| p + shift);
            let keys: Vec<Vec3> = open.iter().chain(close.iter()).copied().collect();
            if !outside_frustum(&intr, &keys, CULL_MARGIN_PX) {
                kept += 1;
                continue;
            }
            culled += 1;
            for _ in 0..200 {
                let (t, a, b) = (unit(), unit(), unit());
                let (a, b) = if a + b > 1.0 { (1.0 - a, 1.0 - b) } else { (a, b) };
                let at = |k: usize| open[k] + (close[k] - open[k]) * t;
                let p = at(0) + (at(1) - at(0)) * a + (at(2) - at(0)) * b;
                let d = -p.z;
                if d < intr.near || d > intr.far {
                    continue;
                }
                let lens = concentric_disk(Vec2::new(unit(), unit()));
                let px = intr.project(p, lens);
                assert!(
                    px.x < 0.0 || px.y < 0.0 || px.x > intr.width || px.y > intr.height,
                    "case {case}: culled triangle {open:?} → {close:?} seen at {px} (t {t}, lens {lens})"
                );
            }
        }
        assert!(culled > 800 && kept > 800, "culled {culled}, kept {kept}");
        let intr = intrinsics(0.2, 4.0);
        let across = [Vec3::new(-0.5, -0.3, -3.0), Vec3::new(0.5, -0.3, -3.0), Vec3::new(0.0, 0.4, -3.0)];
        assert!(!outside_frustum(&intr, &across, CULL_MARGIN_PX));
    }

    /// The lens widens what is kept: a point just outside the pinhole frustum, out of focus, is seen
    /// through the lens' edge and must be kept; with a pinhole it is culled.
    #[test]
    fn defocus_keeps_what_the_lens_edge_sees() {
        let pinhole = intrinsics(0.0, 2.0);
        let s = pinhole.pixel_scale;
        let edge = (0.5 * pinhole.width + CULL_MARGIN_PX) / s;
        let d = 8.0;
        let x = d * (edge + 0.02);
        let tri = [Vec3::new(x, 0.0, -d), Vec3::new(x + 0.1, 0.0, -d), Vec3::new(x, 0.1, -d)];
        assert!(outside_frustum(&pinhole, &tri, CULL_MARGIN_PX));
        let lens = intrinsics(0.3, 2.0);
        assert!(!outside_frustum(&lens, &tri, CULL_MARGIN_PX));
        // Where the lens cannot reach it, it is culled again.
        let far_out = tri.map(|p| p + Vec3::new(10.0, 0.0, 0.0));
        assert!(outside_frustum(&lens, &far_out, CULL_MARGIN_PX));
    }

    /// A triangle culled as back-facing is never met from its front: random rays through random lens
    /// points at random times that hit it (the shared inside test) all see its back. And the test is
    /// not vacuous: a good share of random triangles is culled; and it is exact for a triangle at rest,
    /// up to the margin: just past the lens' edge it is kept, just inside it culled.
    #[test]
    fn back_facing_triangles_are_never_seen_from_the_front() {
        let mut rng = Pcg32::new(0xbacf, 5);
        let mut unit = || rng.next_u32() as f32 / 4_294_967_296.0;
        let (mut culled, mut kept, mut hits) = (0, 0, 0);
        for case in 0..3000 {
            let r = if case % 3 == 0 { 0.0 } else { 0.4 * unit() };
            let centre = Vec3::new(6.0 * unit() - 3.0, 6.0 * unit() - 3.0, -1.0 - 8.0 * unit());
            let mut point = || centre + 1.5 * Vec3::new(unit() - 0.5, unit() - 0.5, unit() - 0.5);
            let k0: [Vec3; 3] = [point(), point(), point()];
            // Two or three keys, each vertex moving on its own (the triangle turns and deforms).
            let key_count = 2 + case % 2;
            let mut keys: Vec<[Vec3; 3]> = vec![k0];
            for _ in 1..key_count {
                let prev = *keys.last().unwrap();
                let step = 0.6 * Vec3::new(unit() - 0.5, unit() - 0.5, unit() - 0.5);
                keys.push(prev.map(|v| v + step + 0.3 * Vec3::new(unit() - 0.5, unit() - 0.5, unit() - 0.5)));
            }
            let flat: Vec<Vec3> = keys.iter().flatten().copied().collect();
            if !back_facing(r, &flat) {
                kept += 1;
                continue;
            }
            culled += 1;
            for _ in 0..300 {
                let t = unit() * (key_count - 1) as f32;
                let j = (t as usize).min(key_count - 2);
                let s = t - j as f32;
                let tri = [0, 1, 2].map(|k| keys[j][k] + (keys[j + 1][k] - keys[j][k]) * s);
                let lens = r * concentric_disk(Vec2::new(unit(), unit()));
                let (a, b) = (unit(), unit());
                let (a, b) = if a + b > 1.0 { (1.0 - a, 1.0 - b) } else { (a, b) };
                let target = tri[0] + (tri[1] - tri[0]) * a + (tri[2] - tri[0]) * b;
                let o = lens.extend(0.0);
                if let Some(hit) = crate::geometry::intersect_triangle(&tri, o, (target - o).normalize()) {
                    hits += 1;
                    assert!(
                        hit.back,
                        "case {case}: culled {keys:?} seen from the front (t {t}, lens {lens})"
                    );
                }
            }
        }
        assert!(culled > 600 && kept > 600 && hits > 100_000, "culled {culled}, kept {kept}, hits {hits}");
        // At rest in the plane z = −1, wound so that its normal is −z: it faces away from the whole
        // lens plane z = 0, whatever the lens' size.
        let flat = [Vec3::new(0.0, 0.0, -1.0), Vec3::new(0.0, 1.0, -1.0), Vec3::new(1.0, 0.0, -1.0)];
        assert!(back_facing(0.0, &flat) && back_facing(5.0, &flat));
        // Tilted: its plane meets the lens plane, so a wide enough lens sees its front. n·(a − L) is
        // smallest at L = R·nxy/|nxy|, where it is n·a − R·|nxy|: zero at R = n·a / |nxy|.
        let tilted = [Vec3::new(0.5, 0.0, -1.0), Vec3::new(0.5, 1.0, -1.0), Vec3::new(1.5, 0.0, -2.0)];
        let n = (tilted[1] - tilted[0]).cross(tilted[2] - tilted[0]);
        let edge = n.dot(tilted[0]) / n.truncate().length();
        assert!(edge > 0.1, "{edge}");
        assert!(back_facing(0.99 * edge, &tilted) && !back_facing(1.01 * edge, &tilted));
    }
}
