//! Decoupled shading (Ragan-Kelley, Lehtinen, Chen, Doggett & Durand, "Decoupled Sampling for
//! Graphics Pipelines", TOG 2011): visibility per sample, shading per *shading point* — a cell of a
//! screen-space grid laid over each triangle as the lens centre sees it at mid-shutter — so the samples
//! that land in one cell of one triangle, whatever their lens point and time, share one shading
//! (`--shading decoupled`, `shaders-glsl/stochastic/decoupled.glsl`, which mirrors this operation for
//! operation; the reference mirrors the shading, `ReferenceShading::Decoupled`).
//!
//! A sample that hits triangle `T` at barycentrics `w` (at its own time and lens point) names the
//! surface point that moves with `T`: at mid-shutter it is `w · T(½)`, whose lens-centre projection
//! falls in the pixel-grid cell `c` (cells are pixels). The sample's **key** is (its triangle, the side
//! its ray sees, `c`). The key's **shading point** is where the lens-centre ray through `c`'s centre
//! meets `T(½)`'s plane, moved to the nearest point of `T(½)` when outside it (the paper clamps shading
//! points to the primitive); it is shaded at mid-shutter, seen from the lens centre, on the sample's
//! side. The shading is a function of the key alone, so any cache of it — of any size, with any
//! replacement, under any race — changes how often it is computed, never a pixel.
//!
//! A sample whose point is behind the camera at mid-shutter, or whose cell lies outside
//! [`CELL_RANGE`], has no key: it is shaded at its own hit, as per-sample shading does.

use glam::{IVec2, Vec2, Vec3};

use crate::mirror::aas::bounds::ShadingGrid;
use crate::scene::Intrinsics;

/// Which screen-space grid cells the keys: the pixel grid (Ragan-Kelley's decoupled sampling), or the
/// AAS grid per triangle ([`crate::mirror::aas::bounds::shading_grid`]: oriented along the motion and stretched
/// by the blur), or AAS for defocus only (the isotropic ablation).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum GridKind {
    #[default]
    Pixel,
    Aas,
    AasIsotropic,
}

/// The deferred mode's hash table (`--shading decoupled-deferred`, `decoupled.glsl`): a key looks for
/// its entry, or an empty one to claim, in at most this many consecutive entries from its hash (linear
/// probing); past them it overflows and its samples are shaded on the spot.
pub const DEFERRED_PROBES: u32 = 16;

/// Every triangle's grid of `kind` (the scene's triangle numbering: objects in order), for the camera
/// space `space` of `scene` seen through `intrinsics`.
pub fn object_grids(
    scene: &crate::scene::Scene,
    space: &crate::scene::CameraSpaceScene,
    intrinsics: &Intrinsics,
    kind: GridKind,
) -> Vec<ShadingGrid> {
    if kind == GridKind::Pixel {
        return vec![PIXEL_GRID; scene.triangle_count()];
    }
    // The cutoffs are numerical transforms: computed once, and only for the AAS grids.
    let cutoffs = crate::mirror::aas::spectrum::camera_cutoffs(scene.camera.aperture, scene.camera.shutter);
    let isotropic = kind == GridKind::AasIsotropic;
    scene
        .objects
        .iter()
        .zip(&space.objects)
        .flat_map(|(o, motion)| {
            crate::mirror::aas::bounds::triangle_grids(intrinsics, &o.mesh, motion, &cutoffs, isotropic)
        })
        .collect()
}

/// The pixel grid.
pub const PIXEL_GRID: ShadingGrid = ShadingGrid { axis: Vec2::X, along: 1.0, across: 1.0 };

/// A screen point `q` (pixels) in grid coordinates: along the axis and across it, in cells.
pub fn to_grid(grid: &ShadingGrid, q: Vec2) -> Vec2 {
    Vec2::new(q.dot(grid.axis) / grid.along, q.dot(grid.axis.perp()) / grid.across)
}

/// A grid point back on the screen (pixels).
pub fn from_grid(grid: &ShadingGrid, g: Vec2) -> Vec2 {
    grid.axis * (g.x * grid.along) + grid.axis.perp() * (g.y * grid.across)
}

/// Cells a key can name: `|x|, |y| <` this (16 bits each in the GPU's 64-bit key, 0 and all-ones
/// reserved).
pub const CELL_RANGE: i32 = 32767;

/// A sample's key as the GPU packs it (`dc_key` in `decoupled.glsl`): the visibility payload
/// (`triangle << 1 | back`, the frame's triangle numbering, the reference's) above the cell, each
/// coordinate offset by 32768 into 16 bits.
pub fn key(triangle: u32, back: bool, cell: IVec2) -> u64 {
    let payload = (triangle << 1) | back as u32;
    let cells = ((cell.x + 32768) as u32 & 0xffff) | (((cell.y + 32768) as u32 & 0xffff) << 16);
    ((payload as u64) << 32) | cells as u64
}

/// A sample's decoupled shading point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShadingPoint {
    /// The grid cell, `None` when the sample has no key (shaded at its own hit).
    pub cell: Option<IVec2>,
    /// Barycentrics of the point to shade on the triangle at mid-shutter.
    pub barycentrics: Vec3,
}

/// The barycentrics of the point of triangle `p` nearest to `q` (a point of its plane, given by its
/// plane barycentrics `w`): `w` itself when inside, else the nearest point of the nearest edge
/// (Ericson, Real-Time Collision Detection §5.1.5, by Voronoi regions).
pub fn clamp_to_triangle(p: &[Vec3; 3], w: Vec3) -> Vec3 {
    if w.x >= 0.0 && w.y >= 0.0 && w.z >= 0.0 {
        return w;
    }
    let q = w.x * p[0] + w.y * p[1] + w.z * p[2];
    let (a, b, c) = (p[0], p[1], p[2]);
    let (ab, ac, ap) = (b - a, c - a, q - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return Vec3::X;
    }
    let bp = q - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return Vec3::Y;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let v = d1 / (d1 - d3);
        return Vec3::new(1.0 - v, v, 0.0);
    }
    let cp = q - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return Vec3::Z;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = d2 / (d2 - d6);
        return Vec3::new(1.0 - w, 0.0, w);
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return Vec3::new(0.0, 1.0 - w, w);
    }
    // Inside by rounding.
    let denom = 1.0 / (va + vb + vc);
    let (v, w) = (vb * denom, vc * denom);
    Vec3::new(1.0 - v - w, v, w)
}

/// The decoupled shading point of a sample that hit the triangle `mid` (camera space at mid-shutter)
/// at barycentrics `w`, its cells those of `grid` (module docs; [`PIXEL_GRID`]: pixels).
pub fn shading_point(intrinsics: &Intrinsics, mid: &[Vec3; 3], w: Vec3, grid: &ShadingGrid) -> ShadingPoint {
    let own = ShadingPoint { cell: None, barycentrics: w };
    let point = w.x * mid[0] + w.y * mid[1] + w.z * mid[2];
    // In front of the lens (NaN is not).
    if (-point.z).partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
        return own;
    }
    let q = intrinsics.project(point, Vec2::ZERO);
    let cell = to_grid(grid, q).floor();
    if !(cell.x.abs() < CELL_RANGE as f32 && cell.y.abs() < CELL_RANGE as f32) {
        return own;
    }
    let (o, d) = intrinsics.primary_ray(from_grid(grid, cell + Vec2::splat(0.5)), Vec2::ZERO);
    let barycentrics = match crate::geometry::plane_barycentrics(mid, o, d) {
        // Met in front of the lens: the cell centre's point of the plane, clamped to the triangle.
        Some(b) if -(b.x * mid[0] + b.y * mid[1] + b.z * mid[2]).z > 0.0 => clamp_to_triangle(mid, b),
        // Seen edge-on or from behind through the cell centre: the sample's own point stands for it
        // (still one value per key: the first of the cell's samples would differ — so no key).
        _ => return own,
    };
    ShadingPoint { cell: Some(cell.as_ivec2()), barycentrics }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::{ApertureShape, Pcg32};

    fn intrinsics() -> Intrinsics {
        Intrinsics {
            width: 64.0,
            height: 48.0,
            pixel_scale: crate::scene::camera::pixel_scale(48, 45.0),
            aperture_radius: 0.1,
            focus_distance: 3.0,
            aperture: ApertureShape::default(),
            near: 0.05,
            far: 100.0,
        }
    }

    fn random_triangle(rng: &mut Pcg32) -> [Vec3; 3] {
        let centre =
            Vec3::new(2.0 * rng.next_f32() - 1.0, 2.0 * rng.next_f32() - 1.0, -2.0 - 4.0 * rng.next_f32());
        [0; 3].map(|_| centre + Vec3::new(rng.next_f32() - 0.5, rng.next_f32() - 0.5, rng.next_f32() - 0.5))
    }

    /// Clamping: inside points are kept; outside ones go to the nearest point of the triangle — no
    /// random point of the triangle is nearer.
    #[test]
    fn clamping_finds_the_nearest_point_of_the_triangle() {
        let mut rng = Pcg32::new(0xdec, 1);
        for case in 0..2000 {
            let p = random_triangle(&mut rng);
            let w = Vec3::new(3.0 * rng.next_f32() - 1.0, 3.0 * rng.next_f32() - 1.0, 0.0);
            let w = Vec3::new(w.x, w.y, 1.0 - w.x - w.y);
            let q = w.x * p[0] + w.y * p[1] + w.z * p[2];
            let c = clamp_to_triangle(&p, w);
            assert!(c.min_element() >= -1e-5 && (c.element_sum() - 1.0).abs() < 1e-4, "case {case}: {c}");
            let at = c.x * p[0] + c.y * p[1] + c.z * p[2];
            if w.min_element() >= 0.0 {
                assert_eq!(c, w);
            }
            for _ in 0..200 {
                let (a, b) = (rng.next_f32(), rng.next_f32());
                let (a, b) = if a + b > 1.0 { (1.0 - a, 1.0 - b) } else { (a, b) };
                let r = p[0] + (p[1] - p[0]) * a + (p[2] - p[0]) * b;
                assert!(at.distance(q) <= r.distance(q) + 1e-4, "case {case}: {at} vs {r} for {q}");
            }
        }
    }

    /// Shading points: two samples of one triangle whose mid-shutter points fall in one cell get the
    /// same point; a shading point whose cell centre is on the triangle projects onto the centre; every
    /// shading point is on the triangle.
    #[test]
    fn samples_in_one_cell_share_a_point_on_the_triangle() {
        let k = intrinsics();
        let mut rng = Pcg32::new(0xdec, 2);
        let (mut centred, mut shared) = (0, 0);
        for case in 0..2000 {
            let tri = random_triangle(&mut rng);
            let mut seen: Vec<(IVec2, Vec3)> = vec![];
            for _ in 0..64 {
                let (a, b) = (rng.next_f32(), rng.next_f32());
                let (a, b) = if a + b > 1.0 { (1.0 - a, 1.0 - b) } else { (a, b) };
                let w = Vec3::new(1.0 - a - b, a, b);
                let sp = shading_point(&k, &tri, w, &PIXEL_GRID);
                let Some(cell) = sp.cell else { continue };
                let c = sp.barycentrics;
                assert!(c.min_element() >= -1e-5 && (c.element_sum() - 1.0).abs() < 1e-4, "case {case}: {c}");
                let point = w.x * tri[0] + w.y * tri[1] + w.z * tri[2];
                assert_eq!(cell, k.project(point, Vec2::ZERO).floor().as_ivec2());
                if c.min_element() > 1e-4 {
                    let at = c.x * tri[0] + c.y * tri[1] + c.z * tri[2];
                    let q = k.project(at, Vec2::ZERO);
                    assert!((q - (cell.as_vec2() + 0.5)).length() < 1e-2, "case {case}: {q} for cell {cell}");
                    centred += 1;
                }
                match seen.iter().find(|s| s.0 == cell) {
                    Some(s) => {
                        assert_eq!(s.1, c, "case {case}: cell {cell} has two points");
                        shared += 1;
                    }
                    None => seen.push((cell, c)),
                }
            }
        }
        assert!(centred > 10_000 && shared > 10_000, "centred {centred}, shared {shared}");
    }
}
