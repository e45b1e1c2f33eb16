//! Per-triangle frequency bounds and the anisotropic shading grid (Vaidyanathan et al. 2012, §3.2–3.4).
//!
//! What blurs a triangle over a frame, from its vertices' screen positions at the lens centre:
//! * the smallest circle of confusion `φ_min` over its vertices at every motion key (0 when they lie
//!   on both sides of the focus plane: defocus then bounds nothing);
//! * the screen velocities `µᵢ` of its vertices, pixels per shutter interval, one per vertex and key
//!   segment (the displacement over the segment divided by its duration) — the paper notes that
//!   velocities are not constant under perspective and bounds with those at both ends of the shutter;
//!   we take the segments' mean velocities, the paper's cheaper variant, also named there (§3.5);
//! * the smallest speed `|µ_min|`: the distance from the origin to the convex hull of the `µᵢ` (every
//!   point of the triangle at every time moves with a velocity in it); 0 when the hull holds the origin;
//! * the span of motion directions `θ̂` of the hull, centred on `ê_µ` (`half_span` each side).
//!
//! From them and the filters' cutoffs ([`super::spectrum`]): `r = min(Ω_A / φ_min, Ω_R)` bounds the
//! spectrum of aperture and reconstruction together; each velocity in the span smears the shutter's
//! spectrum into a band of half-width `w = Ω_S / |µ_min|` across its direction, and their union is the
//! paper's hourglass. The grid is the box, aligned to `ê_µ`, around the hourglass clipped to the disk of
//! radius `r`: `2r` across the motion; along it, twice the largest `|ω·ê_µ|` over that region. A band at
//! angle `θ` from `ê_µ` meets the disk where `ω·ê_µ ≤ w cos θ + √(r² − w²) sin θ = r cos(θ − α)`,
//! `α = acos(w/r)`; over `θ ∈ [0, θ̂/2]` that is `r cos(α − θ̂/2)` while `θ̂/2 < α`, else `r`. (This is our
//! derivation of the paper's Eqs. 8–9, whose typeset form we could not read unambiguously.) Shading
//! points are spaced by the inverse of the box's sides: `1/d_µ` along the motion, `1/d_⊥` across.

use glam::Vec2;

use super::spectrum::RECONSTRUCTION_CUTOFF;
use crate::scene::camera_space::ObjectMotion;
use crate::scene::{Intrinsics, Mesh};

/// What blurs one triangle over a frame (module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TriangleBlur {
    /// Smallest circle-of-confusion radius over the vertices and keys, pixels.
    pub min_coc_px: f32,
    /// Smallest screen speed over the triangle and the shutter, pixels per shutter interval.
    pub min_speed_px: f32,
    /// The centre of the span of motion directions (unit; +x when there is no motion).
    pub direction: Vec2,
    /// Half the span of motion directions, radians, in `[0, π]`.
    pub half_span: f32,
}

/// The cutoffs the grid is built from: aperture, cycles per lens radius (`None`: not radially
/// symmetric, defocus not used); shutter, cycles per shutter interval.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cutoffs {
    pub aperture: Option<f64>,
    pub shutter: f64,
}

/// An anisotropic shading grid in screen space: spacing `along` the unit direction `axis` and `across`
/// it, pixels (both ≥ the pixel grid's 1).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShadingGrid {
    pub axis: Vec2,
    pub along: f32,
    pub across: f32,
}

/// The smallest distance from the origin to the convex hull of `points`: 0 when the hull holds it.
pub fn min_speed(points: &[Vec2]) -> f32 {
    let hull = convex_hull(points);
    match hull.len() {
        0 => 0.0,
        1 => hull[0].length(),
        2 => segment_distance(hull[0], hull[1]),
        n => {
            // Counter-clockwise: the origin is inside when it is left of (or on) every edge.
            let inside = (0..n).all(|i| hull[i].perp_dot(hull[(i + 1) % n]) >= 0.0);
            if inside {
                0.0
            } else {
                (0..n).map(|i| segment_distance(hull[i], hull[(i + 1) % n])).fold(f32::INFINITY, f32::min)
            }
        }
    }
}

/// Distance from the origin to the segment `a`–`b`.
fn segment_distance(a: Vec2, b: Vec2) -> f32 {
    let d = b - a;
    let len2 = d.length_squared();
    let t = if len2 > 0.0 { (-a.dot(d) / len2).clamp(0.0, 1.0) } else { 0.0 };
    (a + d * t).length()
}

/// Andrew's monotone chain: the hull's vertices counter-clockwise, collinear points dropped.
fn convex_hull(points: &[Vec2]) -> Vec<Vec2> {
    let mut p: Vec<Vec2> = points.iter().copied().filter(|v| v.is_finite()).collect();
    p.sort_by(|a, b| a.x.total_cmp(&b.x).then(a.y.total_cmp(&b.y)));
    p.dedup();
    if p.len() < 3 {
        return p;
    }
    let cross = |o: Vec2, a: Vec2, b: Vec2| (a - o).perp_dot(b - o);
    let mut hull: Vec<Vec2> = Vec::with_capacity(2 * p.len());
    for pass in 0..2 {
        let start = hull.len();
        let iter: Box<dyn Iterator<Item = &Vec2>> =
            if pass == 0 { Box::new(p.iter()) } else { Box::new(p.iter().rev()) };
        for &q in iter {
            while hull.len() >= start + 2 && cross(hull[hull.len() - 2], hull[hull.len() - 1], q) <= 0.0 {
                hull.pop();
            }
            hull.push(q);
        }
        hull.pop();
    }
    hull
}

/// The centre direction and half-width (radians) of the smallest arc holding the directions of every
/// non-zero point; `(+x, 0)` without any, half-width π when they surround the origin.
pub fn direction_span(points: &[Vec2]) -> (Vec2, f32) {
    let mut angles: Vec<f32> =
        points.iter().filter(|v| v.length_squared() > 0.0 && v.is_finite()).map(|v| v.y.atan2(v.x)).collect();
    if angles.is_empty() {
        return (Vec2::X, 0.0);
    }
    angles.sort_by(f32::total_cmp);
    // The largest gap between consecutive directions (around the circle) is what the arc leaves out.
    let tau = std::f32::consts::TAU;
    let n = angles.len();
    let (mut gap, mut after) = (angles[0] + tau - angles[n - 1], 0usize);
    for i in 1..n {
        let g = angles[i] - angles[i - 1];
        if g > gap {
            gap = g;
            after = i;
        }
    }
    let half = 0.5 * (tau - gap);
    let centre = angles[after] + half;
    (Vec2::new(centre.cos(), centre.sin()), half.min(std::f32::consts::PI))
}

/// The blur of a triangle from its vertices' lens-centre screen positions at each motion key
/// (`keys[k]` at time `times[k]`, increasing from 0 to 1; one key for a triangle at rest) and their
/// circles of confusion, pixels (signed, `Intrinsics::circle_of_confusion_px`).
pub fn triangle_blur(keys: &[[Vec2; 3]], times: &[f32], coc_px: &[[f32; 3]]) -> TriangleBlur {
    let signs = coc_px.iter().flatten();
    let straddles = signs.clone().any(|&c| c <= 0.0) && signs.clone().any(|&c| c >= 0.0);
    let min_coc_px =
        if straddles { 0.0 } else { coc_px.iter().flatten().map(|c| c.abs()).fold(f32::INFINITY, f32::min) };
    let mut velocities: Vec<Vec2> = vec![];
    for (w, t) in keys.windows(2).zip(times.windows(2)) {
        let dt = t[1] - t[0];
        if dt > 0.0 {
            velocities.extend((0..3).map(|i| (w[1][i] - w[0][i]) / dt));
        }
    }
    if velocities.is_empty() {
        return TriangleBlur { min_coc_px, min_speed_px: 0.0, direction: Vec2::X, half_span: 0.0 };
    }
    let (direction, half_span) = direction_span(&velocities);
    TriangleBlur { min_coc_px, min_speed_px: min_speed(&velocities), direction, half_span }
}

/// The anisotropic shading grid for a triangle blurred by `blur` (module docs).
pub fn shading_grid(blur: &TriangleBlur, cutoffs: &Cutoffs) -> ShadingGrid {
    let omega_r = RECONSTRUCTION_CUTOFF as f32;
    let r = match cutoffs.aperture {
        Some(a) if blur.min_coc_px > 0.0 => (a as f32 / blur.min_coc_px).min(omega_r),
        _ => omega_r,
    };
    let extent_along = if blur.min_speed_px > 0.0 {
        let w = cutoffs.shutter as f32 / blur.min_speed_px;
        if w >= r {
            r
        } else {
            let alpha = (w / r).acos();
            if blur.half_span >= alpha {
                r
            } else {
                r * (alpha - blur.half_span).cos()
            }
        }
    } else {
        r
    };
    ShadingGrid {
        axis: blur.direction,
        along: (1.0 / (2.0 * extent_along)).max(1.0),
        across: (1.0 / (2.0 * r)).max(1.0),
    }
}

/// The grid of every triangle of `mesh` moved by `motion` and seen through `intrinsics`, for a camera
/// whose filters cut off at `cutoffs`; `isotropic` leaves the motion out (AAS for defocus only, the
/// issue's ablation). A triangle with a vertex at or before the near plane at some key gets the pixel
/// grid: its screen positions, and so its blur, are unbounded.
pub fn triangle_grids(
    intrinsics: &Intrinsics,
    mesh: &Mesh,
    motion: &ObjectMotion,
    cutoffs: &Cutoffs,
    isotropic: bool,
) -> Vec<ShadingGrid> {
    let times = motion.keys.times();
    mesh.indices
        .chunks_exact(3)
        .map(|t| {
            let mut keys = Vec::with_capacity(times.len());
            let mut coc = Vec::with_capacity(times.len());
            for mv in &motion.model_view {
                let p = [0, 1, 2].map(|k| mv.transform_point3(mesh.positions[t[k] as usize]));
                if p.iter().any(|v| -v.z <= intrinsics.near || v.z.is_nan()) {
                    return crate::mirror::decoupled::PIXEL_GRID;
                }
                keys.push(p.map(|v| intrinsics.project(v, Vec2::ZERO)));
                coc.push(p.map(|v| intrinsics.circle_of_confusion_px(-v.z)));
            }
            let mut blur = triangle_blur(&keys, times, &coc);
            if isotropic {
                blur.min_speed_px = 0.0;
            }
            shading_grid(&blur, cutoffs)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Pcg32;

    fn random_points(rng: &mut Pcg32, n: usize, spread: f32, shift: Vec2) -> Vec<Vec2> {
        (0..n).map(|_| shift + spread * Vec2::new(rng.next_f32() - 0.5, rng.next_f32() - 0.5)).collect()
    }

    /// The smallest speed is the distance to the hull: no convex combination of the points comes
    /// closer to the origin, one comes within a small tolerance; 0 exactly when some triangle of the
    /// points holds the origin. The direction span holds every point's direction.
    #[test]
    fn min_speed_and_span_bound_every_velocity() {
        let mut rng = Pcg32::new(0xaa5, 1);
        for case in 0..2000 {
            let n = 1 + case % 7;
            let shift = 20.0 * Vec2::new(rng.next_f32() - 0.5, rng.next_f32() - 0.5);
            let spread = 1.0 + 10.0 * rng.next_f32();
            let pts = random_points(&mut rng, n, spread, shift);
            let m = min_speed(&pts);
            let mut closest = f32::INFINITY;
            for _ in 0..400 {
                let w: Vec<f32> = (0..n).map(|_| -rng.next_f32().max(1e-9).ln()).collect();
                let sum: f32 = w.iter().sum();
                let p: Vec2 = pts.iter().zip(&w).map(|(p, w)| *p * (w / sum)).sum();
                assert!(p.length() >= m - 1e-3 * (1.0 + m), "case {case}: {p} inside {m}");
                closest = closest.min(p.length());
            }
            for (i, a) in pts.iter().enumerate() {
                closest = closest.min(a.length());
                for b in &pts[i + 1..] {
                    closest = closest.min(segment_distance(*a, *b));
                }
            }
            let contains = (0..n).any(|i| {
                (i + 1..n).any(|j| {
                    (j + 1..n).any(|k| {
                        let (a, b, c) = (pts[i], pts[j], pts[k]);
                        let s = [a.perp_dot(b), b.perp_dot(c), c.perp_dot(a)];
                        s.iter().all(|&x| x >= 0.0) || s.iter().all(|&x| x <= 0.0)
                    })
                })
            });
            if contains {
                assert_eq!(m, 0.0, "case {case}: the points surround the origin");
            } else {
                assert!((m - closest).abs() <= 1e-3 * (1.0 + m), "case {case}: {m} vs {closest}");
            }
            let (centre, half) = direction_span(&pts);
            for p in pts.iter().filter(|p| p.length() > 0.0) {
                let cos = p.normalize().dot(centre);
                assert!(cos >= half.cos() - 1e-5, "case {case}: {p} at cos {cos} outside ±{half}");
            }
        }
        assert_eq!(min_speed(&[]), 0.0);
        let (up, half) = direction_span(&[Vec2::new(0.0, 2.0)]);
        assert!((up - Vec2::Y).length() < 1e-6 && half == 0.0, "{up} {half}");
    }

    /// The grid's box holds the bounded spectrum: random frequencies inside the disk of radius r and
    /// inside some velocity's band (the hourglass) lie within the box's half-extent along the motion.
    /// Without motion the grid is square, `max(φ / (2 Ω_A), 1)` (ATSS's rule for Ω_A = 1); motion only
    /// ever coarsens the spacing along it; more blur never shades more densely.
    #[test]
    fn the_grid_box_holds_the_hourglass_and_coarsens_with_blur() {
        let cut = Cutoffs { aperture: Some(1.0), shutter: 0.9 };
        let still = TriangleBlur { min_coc_px: 12.0, min_speed_px: 0.0, direction: Vec2::X, half_span: 0.0 };
        let g = shading_grid(&still, &cut);
        assert_eq!((g.along, g.across), (6.0, 6.0));
        let sharp = TriangleBlur { min_coc_px: 0.5, ..still };
        assert_eq!(shading_grid(&sharp, &cut).across, 1.0);
        let mut rng = Pcg32::new(0x9d1, 2);
        for case in 0..3000 {
            let blur = TriangleBlur {
                min_coc_px: 10.0 * rng.next_f32(),
                min_speed_px: 40.0 * rng.next_f32(),
                direction: Vec2::from_angle(std::f32::consts::TAU * rng.next_f32()),
                half_span: std::f32::consts::PI * rng.next_f32().powi(2),
            };
            let g = shading_grid(&blur, &cut);
            assert!(g.along >= g.across - 1e-5 && g.across >= 1.0, "case {case}: {g:?}");
            // The box's half-extents in frequency: 1/(2 spacing), unless clamped to the pixel grid.
            let r = 1.0 / (2.0 * g.across);
            let half_along = 1.0 / (2.0 * g.along);
            if g.along > 1.0 && g.across > 1.0 && blur.min_speed_px > 0.0 {
                let w = cut.shutter as f32 / blur.min_speed_px;
                for _ in 0..200 {
                    let theta = blur.half_span * (2.0 * rng.next_f32() - 1.0);
                    let e = Vec2::from_angle(theta).rotate(blur.direction);
                    // A point of the band |ω·e| ≤ w inside the disk |ω| ≤ r.
                    let along_e = w.min(r) * (2.0 * rng.next_f32() - 1.0);
                    let room = (r * r - along_e * along_e).max(0.0).sqrt();
                    let across_e = room * (2.0 * rng.next_f32() - 1.0);
                    let omega = e * along_e + e.perp() * across_e;
                    assert!(
                        omega.dot(blur.direction).abs() <= half_along * (1.0 + 1e-4) + 1e-6,
                        "case {case}: {omega} beyond {half_along} ({blur:?})"
                    );
                }
            }
            let more = TriangleBlur {
                min_coc_px: blur.min_coc_px * 1.5,
                min_speed_px: blur.min_speed_px * 1.5,
                ..blur
            };
            let h = shading_grid(&more, &cut);
            assert!(h.along >= g.along - 1e-4 && h.across >= g.across - 1e-4, "case {case}: {g:?} → {h:?}");
        }
    }

    /// From screen positions: a triangle translating 30 px right over the shutter has speed 30, span 0,
    /// direction +x; one spinning about a vertex inside it has speed 0; depths on both sides of the focus
    /// plane (signed CoC of both signs) bound no defocus.
    #[test]
    fn triangle_blur_from_keys() {
        let tri = [Vec2::new(10.0, 10.0), Vec2::new(20.0, 10.0), Vec2::new(10.0, 20.0)];
        let moved = tri.map(|p| p + Vec2::new(30.0, 0.0));
        let b = triangle_blur(&[tri, moved], &[0.0, 1.0], &[[2.0, 3.0, 4.0], [2.0, 3.0, 5.0]]);
        assert!((b.min_speed_px - 30.0).abs() < 1e-4 && b.half_span.abs() < 1e-6, "{b:?}");
        assert!((b.direction - Vec2::X).length() < 1e-6 && b.min_coc_px == 2.0);
        let c = Vec2::new(13.0, 13.0);
        let spun = tri.map(|p| c + (p - c).perp());
        let s = triangle_blur(&[tri, spun], &[0.0, 1.0], &[[-1.0, 2.0, 3.0]; 2]);
        assert_eq!((s.min_speed_px, s.min_coc_px), (0.0, 0.0));
        let still = triangle_blur(&[tri], &[0.0], &[[3.0; 3]]);
        assert_eq!((still.min_speed_px, still.half_span), (0.0, 0.0));
    }

    /// Grids from a mesh and its motion: a square sliding sideways in focus gets cells stretched along
    /// the slide, one pixel across it; at rest, pixels; behind the camera at a key, pixels.
    #[test]
    fn triangle_grids_follow_the_motion() {
        use crate::geometry::KeyTimes;
        use crate::sampling::ApertureShape;
        use glam::{Mat4, Vec3};
        let k = Intrinsics {
            width: 160.0,
            height: 90.0,
            pixel_scale: crate::scene::camera::pixel_scale(90, 40.0),
            aperture_radius: 0.0,
            focus_distance: 4.0,
            aperture: ApertureShape::Disk,
            near: 0.05,
            far: 100.0,
        };
        let mesh = crate::scene::builtin::builtin_mesh("plane", None).unwrap().unwrap();
        let cut = Cutoffs { aperture: Some(0.95), shutter: 0.85 };
        let at = |x: f32| Mat4::from_translation(Vec3::new(x, 0.0, -4.0)) * Mat4::from_rotation_x(1.57);
        let sliding = ObjectMotion::new(KeyTimes::new(vec![0.0, 1.0]).unwrap(), vec![at(-0.5), at(0.5)]);
        for g in triangle_grids(&k, &mesh, &sliding, &cut, false) {
            assert!(g.axis.x.abs() > 0.999 && g.along > 10.0 && g.across == 1.0, "{g:?}");
        }
        for g in triangle_grids(&k, &mesh, &sliding, &cut, true) {
            assert_eq!((g.along, g.across), (1.0, 1.0), "isotropic, in focus: pixels");
        }
        let still = ObjectMotion::new(KeyTimes::new(vec![0.0, 1.0]).unwrap(), vec![at(0.0), at(0.0)]);
        assert!(triangle_grids(&k, &mesh, &still, &cut, false)
            .iter()
            .all(|g| (g.along, g.across) == (1.0, 1.0)));
        let behind = ObjectMotion::new(
            KeyTimes::new(vec![0.0, 1.0]).unwrap(),
            vec![at(0.0), Mat4::from_translation(Vec3::new(0.0, 0.0, 8.0)) * at(0.0)],
        );
        assert!(triangle_grids(&k, &mesh, &behind, &cut, false)
            .iter()
            .all(|g| *g == crate::mirror::decoupled::PIXEL_GRID));
    }
}
