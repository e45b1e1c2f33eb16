//! CPU mirror of the screen-space bounds and the 5D inside test of stochastic rasterization
//! (McGuire et al. HPG 2010; Toth & Linder 2008). A geometry shader will emit one of these bounds per
//! moving, defocused triangle; the fragment shader then runs [`sample_hit`] for every (x, y, u, v, t)
//! sample the bound covers. The CPU code is the specification and the test oracle for that port.
//!
//! # Model
//! A [`MovingTriangle`] ([`crate::geometry`], re-exported here) holds camera-space vertices at shutter
//! open and close; at time t each vertex is the linear interpolation (docs/MODEL.md "Shutter"). A point `p`
//! seen through lens sample `l` (unit disk) lands at pixel
//! [`Intrinsics::project`]`(p, l) = pinhole(p) + φ(z)·(l.x, −l.y)` with `φ(z) = A·s·(1/F − 1/z)`.
//!
//! # Why the convex hull bound is conservative
//! Every point of the triangle at any time is `P(b, t) = Σᵢ bᵢ((1−t)·vᵢ₀ + t·vᵢ₁)`, a convex
//! combination of the six end vertices, so the whole space-time triangle lies in the 3D polytope
//! `K = conv{vᵢⱼ}`. For a *fixed* lens sample `l` the map `p ↦ project(p, l)` is a projective map
//! (`(p.xy − A·l)/z + A·l/F`, then affine) whose denominator `z` is positive on `K` whenever it is
//! positive at the six vertices. A projective map with positive denominator sends convex combinations
//! to convex combinations (with weights reweighted by `z`), so `project(K, l) ⊆ conv{project(vᵢⱼ, l)}`
//! (in particular a linearly moving point traces a straight screen segment for each fixed lens). Each
//! `project(vᵢⱼ, l)` lies in the disc of radius `|φ(zᵢⱼ)|` around the pinhole projection of `vᵢⱼ`,
//! because the aperture (disk or blades) is inside the unit disk. Hence, for every lens sample and
//! every time, the triangle's image lies in `conv(⋃ discs)`, which lies in the hull of the
//! *circumscribed* regular `n`-gons of those discs (vertex radius `r / cos(π/n)`). Note the argument
//! never needs φ to be monotone along the motion or the screen path to be linear in t.
//!
//! The argument holds in real arithmetic; `f32` rounding of [`Intrinsics::project`] and of the hull
//! makes points fall outside by a few ulps of the pixel coordinates, so consumers test with a small
//! tolerance ([`ScreenBound::contains`]'s `tol`; the GPU port should pad by about a pixel).
//!
//! # Hard cases (McGuire et al.'s z = 0 crossing and clip-and-box; thesis §4.8 names the problem, its
//! answer is the view-space volumes of [`volumes`])
//! Let z range over the six end vertices (their convex hull contains every point at every time):
//! * all `z < near` or all `z > far` → [`ScreenBound::Culled`] (no point is ever in the depth range);
//! * otherwise some `z ≤ near` (behind the camera, or crossing the near plane during the shutter) →
//!   "clip and box" ([`clip_and_box`]): `K` clipped against `z ≥ near` (its vertices are among the end
//!   vertices in front and the intersections of the 15 vertex pairs with the plane), every point
//!   widened by its circle of confusion, boxed, and clamped to the viewport — a [`ScreenBound::Rect`]
//!   (the whole viewport when the box covers it, `Culled` when it misses it), the same for every kind;
//! * degenerate at **every** time → `Culled`. Being degenerate at both shutter ends is *not* enough:
//!   the area vector `cross(e₁(t), e₂(t))` is quadratic in t and its middle coefficient can be non-zero
//!   (see the `degenerate_at_both_ends_but_not_between` test);
//! * non-finite input → `Culled`; a non-finite projected point → the viewport.
//!
//! # Shapes ([`BoundKind`])
//! Every shape bounds `conv(⋃ D_m)` for the six end-vertex discs `D_m = disc(c_m, r_m)` (pinhole
//! projection, circle of confusion), which by the argument above holds the image for every lens sample
//! and time — so each is conservative by construction:
//! * [`BoundKind::ConvexHull`] (McGuire's space-time hull, extended to defocus with circumscribed
//!   octagons) and [`BoundKind::BoundingBox`] (its axis-aligned box);
//! * the thesis' shapes (Toth & Linder 2008, §4; **our reconstruction**, see [`shapes`]):
//!   parallel-edge triangle, 2D hexagon, variable-radius triangle, 3D hexagon, wedge, reduced wedge,
//!   and an adaptive choice among them ([`adaptive_kind`]). Their directions come from the mid-shutter
//!   triangle; when it is degenerate, and for wedges of moving triangles, they fall back to the
//!   convex hull. The wedges are a [`ScreenBound::Union`] of convex pieces.
//!
//! The hard cases above are handled first, identically for every kind.
//! `shaders-glsl/stochastic/bounds.glsl` (`compute_bound`) mirrors [`bound`] operation for operation
//! in `float` (the degenerate tests use documented `float` thresholds there).
//!
//! Also here: the 5D inside test [`sample_hit`] (the shared [`crate::geometry::intersect_triangle`] plus
//! the depth range); a Monte Carlo [`sample_test_efficiency_estimate`].
//! Not implemented: a tighter hull (instead of a box) of the clipped polytope, per-time-interval bounds
//! (interleaved/tiled time slices), and viewport clipping/culling of off-screen bounds.

pub mod cluster;
mod dilate;
mod hull;
mod inside;
pub mod shapes;
#[cfg(test)]
mod tests;
pub mod volumes;

pub use crate::geometry::{MovingTriangle, TriangleHit};
pub use dilate::{dilate_box, dilation_px, DILATE_MARGIN_PX};
pub use hull::{convex_contains, convex_hull, orient, signed_area};
pub use inside::{sample_hit, sample_test_efficiency_estimate};
pub use shapes::{
    adaptive_kind_of, hexagon_2d, parallel_edge_triangle, variable_radius_triangle, EndDiscs, MidTriangle,
    RADIUS_ROUND_UP,
};

use std::str::FromStr;

use glam::{Vec2, Vec3};

use crate::error::{Error, Result};
use crate::scene::camera::Intrinsics;

/// Sides of the regular polygon circumscribing each circle of confusion in [`BoundKind::ConvexHull`].
pub const DISC_SIDES: usize = 8;

/// Which screen-space bound to build; [`bound`] dispatches on it. The order is the order of
/// [`BoundKind::ALL`] and of [`BoundKind::id`] (the GLSL `kind` argument, `BOUND_*` in
/// `shaders-glsl/stochastic/bounds.glsl`). Shapes 2–7 are described in [`shapes`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum BoundKind {
    /// Axis-aligned box of the [`BoundKind::ConvexHull`] points.
    BoundingBox,
    /// The parallel-edge triangle with its corners cut by support lines ([`shapes::hexagon_2d`]).
    Hexagon2d,
    /// Support half-planes of the mid triangle's edge normals ([`shapes::parallel_edge_triangle`]).
    ParallelEdgeTriangle,
    /// Outer common tangents of per-vertex discs ([`shapes::variable_radius_triangle`]).
    VariableRadiusTriangle,
    /// The thesis' hexagonal prism around the discs of confusion ([`volumes`]), drawn as its pinhole
    /// image; still triangles whose prism lies in front of the near plane, else the convex hull.
    Hexagon3d,
    /// The thesis' triangular prism (the wedge, [`volumes`]), drawn as its pinhole image; the same
    /// fallback.
    Wedge,
    /// The thesis' reduced wedge: the wedge's silhouette — the very region [`BoundKind::Wedge`] draws
    /// (here every volume is drawn by its silhouette), kept as its own name for the thesis' table.
    ReducedWedge,
    /// McGuire'10 space-time convex hull of the six projected end vertices, each widened to a
    /// circumscribed [`DISC_SIDES`]-gon of its circle of confusion when the aperture is open.
    ConvexHull,
    /// Chosen per triangle from the blur radius, the motion and the triangle size ([`adaptive_kind`]).
    Adaptive,
}

impl BoundKind {
    pub const ALL: [BoundKind; 9] = [
        BoundKind::BoundingBox,
        BoundKind::Hexagon2d,
        BoundKind::ParallelEdgeTriangle,
        BoundKind::VariableRadiusTriangle,
        BoundKind::Hexagon3d,
        BoundKind::Wedge,
        BoundKind::ReducedWedge,
        BoundKind::ConvexHull,
        BoundKind::Adaptive,
    ];
    /// Command-line name.
    pub fn name(&self) -> &'static str {
        match self {
            BoundKind::BoundingBox => "bbox",
            BoundKind::Hexagon2d => "2d-hexagon",
            BoundKind::ParallelEdgeTriangle => "parallel-edge-triangle",
            BoundKind::VariableRadiusTriangle => "variable-radius-triangle",
            BoundKind::Hexagon3d => "3d-hexagon",
            BoundKind::Wedge => "wedge",
            BoundKind::ReducedWedge => "reduced-wedge",
            BoundKind::ConvexHull => "convex-hull",
            BoundKind::Adaptive => "adaptive",
        }
    }
    /// The GLSL `kind` argument of `compute_bound` (`BOUND_BBOX` = 0 … `BOUND_ADAPTIVE` = 8).
    pub fn id(&self) -> u32 {
        match self {
            BoundKind::BoundingBox => 0,
            BoundKind::Hexagon2d => 1,
            BoundKind::ParallelEdgeTriangle => 2,
            BoundKind::VariableRadiusTriangle => 3,
            BoundKind::Hexagon3d => 4,
            BoundKind::Wedge => 5,
            BoundKind::ReducedWedge => 6,
            BoundKind::ConvexHull => 7,
            BoundKind::Adaptive => 8,
        }
    }
}

impl std::fmt::Display for BoundKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for BoundKind {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        crate::error::parse_named(&BoundKind::ALL, |b| b.name(), "bound", s)
    }
}

/// A screen-space region (pixel coordinates, x right, y down) that contains the triangle's image for
/// every lens sample and shutter time — restricted to the viewport and the depth range `[near, far]`.
#[derive(Clone, Debug, PartialEq)]
pub enum ScreenBound {
    /// Convex polygon, counter-clockwise in (x, y) pixel coordinates (positive shoelace area; that is
    /// clockwise on a y-down screen), no repeated or collinear vertices. May have 1 or 2 vertices when
    /// the image degenerates to a point or segment (e.g. a static edge-on pinhole triangle).
    Polygon(Vec<Vec2>),
    /// Axis-aligned rectangle: a bounding box, or the whole viewport for the hard cases.
    Rect { min: Vec2, max: Vec2 },
    /// Union of convex pieces, each like a [`ScreenBound::Polygon`] (the wedge shapes). Pieces may
    /// overlap.
    Union(Vec<Vec<Vec2>>),
    /// Nothing to rasterize.
    Culled,
}

impl ScreenBound {
    /// The whole viewport of `k`.
    pub fn viewport(k: &Intrinsics) -> Self {
        ScreenBound::Rect { min: Vec2::ZERO, max: Vec2::new(k.width, k.height) }
    }
    pub fn is_viewport(&self, k: &Intrinsics) -> bool {
        *self == ScreenBound::viewport(k)
    }
    /// Is `p` inside the bound, widened by `tol` pixels?
    pub fn contains(&self, p: Vec2, tol: f32) -> bool {
        match self {
            ScreenBound::Polygon(poly) => convex_contains(poly, p, tol),
            ScreenBound::Rect { min, max } => {
                p.x >= min.x - tol && p.y >= min.y - tol && p.x <= max.x + tol && p.y <= max.y + tol
            }
            ScreenBound::Union(pieces) => pieces.iter().any(|poly| convex_contains(poly, p, tol)),
            ScreenBound::Culled => false,
        }
    }
    /// Area in square pixels (0 for `Culled` and for point/segment polygons). For a
    /// [`ScreenBound::Union`] it is the sum of the pieces' areas: an upper bound of the union's area
    /// (and what a rasterizer drawing each piece pays).
    pub fn area(&self) -> f64 {
        match self {
            ScreenBound::Polygon(poly) => signed_area(poly),
            ScreenBound::Rect { min, max } => ((max.x - min.x) as f64) * ((max.y - min.y) as f64),
            ScreenBound::Union(pieces) => pieces.iter().map(|poly| signed_area(poly)).sum(),
            ScreenBound::Culled => 0.0,
        }
    }
    /// Axis-aligned bounding box, `None` when culled.
    pub fn aabb(&self) -> Option<(Vec2, Vec2)> {
        match self {
            ScreenBound::Polygon(poly) => aabb(poly),
            ScreenBound::Rect { min, max } => Some((*min, *max)),
            ScreenBound::Union(pieces) => aabb(&pieces.concat()),
            ScreenBound::Culled => None,
        }
    }
    /// Total number of vertices (a rectangle has 4).
    pub fn vertex_count(&self) -> usize {
        match self {
            ScreenBound::Polygon(poly) => poly.len(),
            ScreenBound::Rect { .. } => 4,
            ScreenBound::Union(pieces) => pieces.iter().map(Vec::len).sum(),
            ScreenBound::Culled => 0,
        }
    }
    /// The convex CCW pieces as GLSL `compute_bound` writes them: none when culled, one per polygon or
    /// union piece, and for a rectangle the 4 corners `min, (max.x, min.y), max, (min.x, max.y)`.
    /// (`compute_bound` returns −1 instead of the pieces where [`ScreenBound::is_viewport`].)
    pub fn pieces(&self) -> Vec<Vec<Vec2>> {
        match self {
            ScreenBound::Polygon(poly) => vec![poly.clone()],
            ScreenBound::Rect { min, max } => {
                vec![vec![*min, Vec2::new(max.x, min.y), *max, Vec2::new(min.x, max.y)]]
            }
            ScreenBound::Union(pieces) => pieces.clone(),
            ScreenBound::Culled => Vec::new(),
        }
    }
}

fn aabb(points: &[Vec2]) -> Option<(Vec2, Vec2)> {
    let first = *points.first()?;
    Some(points.iter().fold((first, first), |(lo, hi), &p| (lo.min(p), hi.max(p))))
}

/// The screen-space bound of `tri` over the whole shutter and aperture (see the module docs for the
/// conservativeness argument and the hard cases). This is the specification of GLSL `compute_bound`
/// (`shaders-glsl/stochastic/bounds.glsl`).
pub fn bound(tri: &MovingTriangle, k: &Intrinsics, kind: BoundKind) -> ScreenBound {
    let verts = tri.end_vertices();
    if verts.iter().any(|v| !v.is_finite()) {
        return ScreenBound::Culled;
    }
    let z = verts.map(|v| -v.z);
    // Depth culling keeps a rounding margin: f32 interpolation (`at(t)`, barycentrics) can overshoot
    // the end vertices' depths by a few ulps of the coordinates.
    let m = 8.0 * f32::EPSILON * verts.iter().map(|v| v.abs().max_element()).fold(0.0, f32::max);
    if z.iter().all(|&z| z < k.near - m) || z.iter().all(|&z| z > k.far + m) || tri.is_degenerate() {
        return ScreenBound::Culled;
    }
    if z.iter().any(|&z| z <= k.near) {
        return clip_and_box(&verts, k, k.near - m);
    }
    let discs = EndDiscs::new(&verts, k);
    if !discs.is_finite() {
        return ScreenBound::viewport(k);
    }
    let kind = if kind == BoundKind::Adaptive { adaptive_kind_of(&discs) } else { kind };
    let shape = match kind {
        BoundKind::Hexagon2d => hexagon_2d(&discs).map(ScreenBound::Polygon),
        BoundKind::ParallelEdgeTriangle => parallel_edge_triangle(&discs).map(ScreenBound::Polygon),
        BoundKind::VariableRadiusTriangle => variable_radius_triangle(&discs).map(ScreenBound::Polygon),
        BoundKind::Hexagon3d => volume_silhouette(tri, k, volumes::VolumeShape::Hexagon),
        BoundKind::Wedge | BoundKind::ReducedWedge => volume_silhouette(tri, k, volumes::VolumeShape::Wedge),
        _ => None,
    };
    if let Some(shape) = shape {
        return shape;
    }
    // Hull-based kinds, and the fallback of the thesis shapes.
    let points = disc_polygon_points(&verts, k, DISC_SIDES);
    if points.iter().any(|p| !p.is_finite()) {
        return ScreenBound::viewport(k);
    }
    match kind {
        BoundKind::BoundingBox => match aabb(&points) {
            Some((min, max)) => ScreenBound::Rect { min, max },
            None => ScreenBound::Culled,
        },
        _ => ScreenBound::Polygon(convex_hull(&points)),
    }
}

/// The pinhole image of the thesis volume `shape` around a still triangle (`volumes::prism`): the
/// convex hull of its projected vertices, when the prism lies wholly in front of the near plane; `None`
/// otherwise (a moving triangle, a degenerate one, or a prism reaching the near plane: the caller
/// falls back to the convex hull). Mirrored by `bound_volume_` in bounds.glsl.
fn volume_silhouette(
    tri: &MovingTriangle,
    k: &Intrinsics,
    shape: volumes::VolumeShape,
) -> Option<ScreenBound> {
    if tri.v0 != tri.v1 {
        return None;
    }
    let v = volumes::prism(&tri.v0, k, shape)?;
    if !volumes::in_front_of_near(&v, k) {
        return None;
    }
    // Wholly in front of the near plane, the image is the hull of the projected vertices (a
    // non-finite projection makes it the viewport: fall back).
    match volumes::screen_region(&v, k) {
        b @ ScreenBound::Polygon(_) => Some(b),
        _ => None,
    }
}

/// The concrete kind [`BoundKind::Adaptive`] resolves to for `tri` (see [`shapes::adaptive_kind_of`]
/// for the policy). Meaningful where [`bound`] reaches the shapes (not culled, every `z > near`).
pub fn adaptive_kind(tri: &MovingTriangle, k: &Intrinsics) -> BoundKind {
    let discs = EndDiscs::new(&tri.end_vertices(), k);
    if discs.is_finite() {
        adaptive_kind_of(&discs)
    } else {
        BoundKind::ConvexHull
    }
}

/// Relative padding of the clip-and-box rectangle (64 ε of its largest coordinate before clamping).
pub const CLIP_PAD_EPS: f32 = 64.0 * f32::EPSILON;

/// "Clip and box" (McGuire et al. 2010's treatment of the z = 0 crossing; thesis §4.8.1 answers the
/// same problem with view-space volumes instead) for a triangle that reaches the near plane at some time: the end
/// vertices' hull `K` clipped to `z ≥ z_clip` (its vertices are among the end vertices in front and the
/// plane's intersections with the 15 segments between end vertices), each point widened by its circle
/// of confusion, boxed, and the box clamped to the viewport. Every visible point has view depth
/// ≥ near ≥ `z_clip`, so it lies in the clipped `K`, and the projective argument of the module docs
/// applies there (all depths positive). `Culled` when the box misses the viewport; the whole viewport
/// when `z_clip ≤ 0` or a projection is not finite. Mirrored by `bound_clip_and_box_` in bounds.glsl.
pub fn clip_and_box(verts: &[Vec3; 6], k: &Intrinsics, z_clip: f32) -> ScreenBound {
    if z_clip.is_nan() || z_clip <= 0.0 {
        return ScreenBound::viewport(k);
    }
    let mut points: Vec<Vec3> = verts.iter().copied().filter(|v| -v.z >= z_clip).collect();
    for a in 0..6 {
        for b in a + 1..6 {
            let (za, zb) = (-verts[a].z, -verts[b].z);
            if (za - z_clip) * (zb - z_clip) < 0.0 {
                let t = (z_clip - za) / (zb - za);
                let p = verts[a] + (verts[b] - verts[a]) * t;
                points.push(Vec3::new(p.x, p.y, -z_clip));
            }
        }
    }
    let (mut lo, mut hi) = (Vec2::splat(f32::INFINITY), Vec2::splat(f32::NEG_INFINITY));
    for p in &points {
        let c = k.project(*p, Vec2::ZERO);
        let r = k.circle_of_confusion_px(-p.z).abs() * shapes::RADIUS_ROUND_UP;
        lo = lo.min(c - Vec2::splat(r));
        hi = hi.max(c + Vec2::splat(r));
    }
    if !(lo.is_finite() && hi.is_finite()) {
        return ScreenBound::viewport(k);
    }
    // The plane intersections are rounded, and magnified by s/z_clip: pad relative to the magnitude.
    let pad = CLIP_PAD_EPS * lo.abs().max(hi.abs()).max_element();
    let lo = (lo - Vec2::splat(pad)).max(Vec2::ZERO);
    let hi = (hi + Vec2::splat(pad)).min(Vec2::new(k.width, k.height));
    if lo.x > hi.x || lo.y > hi.y {
        return ScreenBound::Culled;
    }
    ScreenBound::Rect { min: lo, max: hi }
}

/// The points whose convex hull is the [`BoundKind::ConvexHull`] bound: each end vertex's pinhole
/// projection, or, when the aperture is open, the [`DISC_SIDES`] corners of the regular polygon
/// circumscribing its circle of confusion. Requires every `z > 0`.
pub fn hull_points(verts: &[Vec3], k: &Intrinsics) -> Vec<Vec2> {
    disc_polygon_points(verts, k, DISC_SIDES)
}

/// Corners of the regular `sides`-gon circumscribing the unit circle, the first at angle π/`sides`.
pub fn circumscribed_corners(sides: usize) -> Vec<Vec2> {
    let n = sides;
    let circumscribe = 1.0 / (std::f32::consts::PI / n as f32).cos();
    (0..n)
        .map(|j| {
            let a = (j as f32 + 0.5) * std::f32::consts::TAU / n as f32;
            Vec2::new(a.cos(), a.sin()) * circumscribe
        })
        .collect()
}

/// Each end vertex's pinhole projection, or, when its circle of confusion is not a point, the corners
/// of the regular `sides`-gon circumscribing it ([`hull_points`] with 8 sides; the
/// [`BoundKind::Hexagon3d`] with 6: the triangle seen from the corners of a hexagon around the lens).
/// Requires every `z > 0`.
pub fn disc_polygon_points(verts: &[Vec3], k: &Intrinsics, sides: usize) -> Vec<Vec2> {
    let corners = circumscribed_corners(sides);
    let mut out = Vec::with_capacity(verts.len() * sides);
    for &v in verts {
        let c = k.project(v, Vec2::ZERO);
        let r = k.circle_of_confusion_px(-v.z).abs();
        if r > 0.0 {
            // Round the corner radius up a little so f32 rounding of the corners cannot cut the disc.
            let r = r * RADIUS_ROUND_UP;
            out.extend(corners.iter().map(|&d| c + d * r));
        } else {
            out.push(c);
        }
    }
    out
}
