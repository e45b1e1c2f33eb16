//! The image-space bound shapes, built from the six end-vertex discs.
//!
//! These were reconstructed from the thesis' shape names (Toth & Linder 2008, §4) before its text was
//! at hand. Read against it (§4.4–4.6): the **parallel-edge triangle**, **2D
//! hexagon** and **variable-radius triangle** follow the thesis, with one generalisation — every
//! offset is the support of all the discs, where the thesis takes the discs at the edge's endpoints —
//! and they extend over the shutter through the six end discs. The thesis' **3D hexagon**, **wedge**
//! and **reduced wedge** are view-space prisms, defined in `super::volumes` (the reconstructions that
//! carried those names here are gone). Every shape bounds `conv(⋃ D_m)`, the convex hull of the six discs
//! `D_m = disc(c_m, r_m)` (pinhole projection and circle of confusion of end vertex m, open 0..2, close
//! 3..5), which contains the triangle's image for every lens sample and time (module docs of
//! [`super`]). So each shape is conservative by construction, whatever the directions it uses.
//!
//! * **Support function** `h(n) = max_m (n·c_m + r_m)` for a unit `n`; the support half-plane
//!   `{x : n·x ≤ h(n)}` contains every disc.
//! * **Mid triangle**: `p_i = (c_i + c_{i+3}) / 2`, reordered counter-clockwise; it only supplies
//!   directions (edge normals `n_i`, directions `e_i`). When it is degenerate
//!   (`|2·area| ≤ MID_DEGENERATE_EPS · longest edge²`) the thesis shapes return `None` and
//!   [`super::bound`] falls back to the space-time convex hull.
//! * **Parallel-edge triangle**: the support half-planes of the three outward edge normals.
//! * **2D hexagon**: the parallel-edge triangle with each corner cut by the support half-plane of the
//!   corner's normal `normalize(n_a + n_b)` (a cut only removes its own corner: the cut line is a
//!   support line, and each triangle edge touches the discs between the two corners).
//! * **Variable-radius triangle**: per edge, the outer common tangent of discs around `p_i`, `p_j` whose
//!   radii `R_i = max(r_i, r_{i+3}) + |c_{i+3} − c_i| / 2` enclose both end discs of a vertex (how the
//!   shape extends over the shutter); offsets are the support over all six true discs. Nested circles
//!   (`|β| ≥ 1`) use the edge normal; diverging edges (normals not positively spanning) fall back to the
//!   parallel-edge triangle.
//! * The **3D hexagon**, **wedge** and **reduced wedge** are the thesis' view-space volumes
//!   (`super::volumes`), drawn by `super::bound` as their pinhole images.
//!
//! Numerics: everything is `f32`, in coordinates relative to the mid triangle's centroid (smaller
//! numbers, better-conditioned line intersections), operation for operation as in
//! `shaders-glsl/stochastic/bounds.glsl`. Each candidate polygon goes through [`convex_hull`], which
//! orders it CCW and drops repeated or collinear vertices. A shape with a non-finite vertex returns
//! `None` (convex-hull fallback).

use glam::{Vec2, Vec3};

use super::{convex_hull, orient, BoundKind};
use crate::scene::camera::Intrinsics;

/// Relative round-up of every disc radius, so `f32` rounding of derived points cannot cut a disc.
pub const RADIUS_ROUND_UP: f32 = 1.0 + 4.0 * f32::EPSILON;
/// The mid triangle is degenerate when `|2·area| ≤ MID_DEGENERATE_EPS · (longest edge)²` (`f64` on the
/// CPU, `float` in GLSL: `float` rounding of `2·area` is ≈ 2.4e-7·L², well below this threshold).
pub const MID_DEGENERATE_EPS: f64 = 1e-5;
/// A triangle is still (wedge shapes allowed) when no centre moves and no radius changes by more than
/// this many pixels between shutter open and close.
pub const STILL_EPS_PX: f32 = 1e-3;
/// Adaptive policy: motion above `max(r_max, ADAPTIVE_MOTION_MIN_PX)` selects the convex hull.
pub const ADAPTIVE_MOTION_MIN_PX: f32 = 0.5;
/// Adaptive policy: `r_max ≤ ADAPTIVE_SMALL_BLUR · inradius` selects the parallel-edge triangle.
pub const ADAPTIVE_SMALL_BLUR: f32 = 0.25;

/// The six end-vertex discs: pinhole projection `centre[m]` and circle-of-confusion radius
/// `radius[m] = |φ(z_m)|·RADIUS_ROUND_UP` of end vertex m (open 0..2, close 3..5). Requires `z > 0`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EndDiscs {
    pub centre: [Vec2; 6],
    pub radius: [f32; 6],
}

impl EndDiscs {
    pub fn new(verts: &[Vec3; 6], k: &Intrinsics) -> Self {
        EndDiscs {
            centre: verts.map(|v| k.project(v, Vec2::ZERO)),
            radius: verts.map(|v| k.circle_of_confusion_px(-v.z).abs() * RADIUS_ROUND_UP),
        }
    }
    pub fn is_finite(&self) -> bool {
        self.centre.iter().all(|c| c.is_finite()) && self.radius.iter().all(|r| r.is_finite())
    }
    /// Largest circle of confusion `r_max` in pixels.
    pub fn max_radius(&self) -> f32 {
        self.radius.iter().fold(0.0, |a, &r| a.max(r))
    }
    /// Largest screen motion of a vertex centre between open and close, `max_i |c_{i+3} − c_i|`.
    pub fn motion_px(&self) -> f32 {
        (0..3).fold(0.0, |a, i| a.max((self.centre[i + 3] - self.centre[i]).length()))
    }
    /// Centres and radii equal at open and close within [`STILL_EPS_PX`].
    pub fn is_still(&self) -> bool {
        (0..3).all(|i| {
            (self.centre[i + 3] - self.centre[i]).length() <= STILL_EPS_PX
                && (self.radius[i + 3] - self.radius[i]).abs() <= STILL_EPS_PX
        })
    }
}

/// The discs in coordinates relative to `origin`.
struct Local {
    origin: Vec2,
    c: [Vec2; 6],
    r: [f32; 6],
}

impl Local {
    /// `h(n) = max_m (n·c_m + r_m)`, in the same order as the GLSL.
    fn support(&self, n: Vec2) -> f32 {
        let mut h = n.dot(self.c[0]) + self.r[0];
        for m in 1..6 {
            h = h.max(n.dot(self.c[m]) + self.r[m]);
        }
        h
    }
}

/// The mid-shutter triangle `p_i = (c_i + c_{i+3}) / 2`, counter-clockwise, in coordinates relative to
/// its centroid `origin`. Slot `i` holds original vertex `vertex[i]`; edge `i` runs from slot `i` to
/// slot `i + 1` with unit direction `dir[i]`, length `len[i]` and outward normal `normal[i]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MidTriangle {
    pub origin: Vec2,
    pub p: [Vec2; 3],
    pub vertex: [usize; 3],
    pub dir: [Vec2; 3],
    pub normal: [Vec2; 3],
    pub len: [f32; 3],
    /// Twice the area (`f32`, positive).
    pub area2: f32,
}

impl MidTriangle {
    /// `None` when degenerate (see [`MID_DEGENERATE_EPS`]).
    pub fn new(d: &EndDiscs) -> Option<Self> {
        let abs = [0, 1, 2].map(|i| (d.centre[i] + d.centre[i + 3]) * 0.5);
        let origin = (abs[0] + abs[1] + abs[2]) / 3.0;
        let mut p = abs.map(|q| q - origin);
        let area2 = orient(p[0], p[1], p[2]);
        let l2 = [(0, 1), (1, 2), (2, 0)]
            .map(|(i, j)| (p[j] - p[i]).as_dvec2().length_squared())
            .into_iter()
            .fold(0.0, f64::max);
        // Also rejects NaN.
        if area2.abs().partial_cmp(&(MID_DEGENERATE_EPS * l2)) != Some(std::cmp::Ordering::Greater) {
            return None;
        }
        let mut vertex = [0, 1, 2];
        if area2 < 0.0 {
            p.swap(1, 2);
            vertex.swap(1, 2);
        }
        let (mut dir, mut normal, mut len) = ([Vec2::ZERO; 3], [Vec2::ZERO; 3], [0.0; 3]);
        for i in 0..3 {
            let d = p[(i + 1) % 3] - p[i];
            len[i] = d.length();
            dir[i] = d / len[i];
            // Counter-clockwise: the interior is on the left of `dir`, the outward normal on its right.
            normal[i] = Vec2::new(dir[i].y, -dir[i].x);
        }
        let area2 = (p[1] - p[0]).perp_dot(p[2] - p[0]);
        Some(MidTriangle { origin, p, vertex, dir, normal, len, area2 })
    }
    /// Inradius `2·area / perimeter` in pixels.
    pub fn inradius(&self) -> f32 {
        self.area2 / (self.len[0] + self.len[1] + self.len[2])
    }
    pub fn longest_edge(&self) -> f32 {
        self.len[0].max(self.len[1]).max(self.len[2])
    }
    fn local(&self, d: &EndDiscs) -> Local {
        Local { origin: self.origin, c: d.centre.map(|c| c - self.origin), r: d.radius }
    }
}

/// The line `n·x = h` (`n` unit).
#[derive(Clone, Copy, Debug)]
struct Line {
    n: Vec2,
    h: f32,
}

/// Intersection of two lines, walking along line `a` from its foot point `a.n·a.h`: the result lies on
/// both lines up to `ε·|x|` even when they are nearly parallel (Cramer's rule would be off by
/// `ε·|h| / sin(angle)` across them). `cross(a.n, b.n)` is positive for the CCW pairs used here.
fn intersect(a: Line, b: Line) -> Vec2 {
    let foot = a.n * a.h;
    let along = Vec2::new(-a.n.y, a.n.x);
    let t = (b.h - b.n.dot(foot)) / b.n.dot(along);
    foot + along * t
}

/// Triangle of three lines given CCW by normal: corner `i` is where line `i − 1` meets line `i`.
fn triangle_of(lines: &[Line; 3]) -> [Vec2; 3] {
    [0, 1, 2].map(|i| intersect(lines[(i + 2) % 3], lines[i]))
}

/// Back to absolute coordinates, then [`convex_hull`]; `None` if a point is not finite.
fn finish(local: &Local, points: &[Vec2]) -> Option<Vec<Vec2>> {
    let abs: Vec<Vec2> = points.iter().map(|&q| q + local.origin).collect();
    abs.iter().all(|q| q.is_finite()).then(|| convex_hull(&abs))
}

fn edge_lines(m: &MidTriangle, l: &Local) -> [Line; 3] {
    m.normal.map(|n| Line { n, h: l.support(n) })
}

/// Parallel-edge triangle: the support half-planes of the mid triangle's outward edge normals.
pub fn parallel_edge_triangle(d: &EndDiscs) -> Option<Vec<Vec2>> {
    let m = MidTriangle::new(d)?;
    let l = m.local(d);
    finish(&l, &triangle_of(&edge_lines(&m, &l)))
}

/// 2D hexagon: the parallel-edge triangle with each corner cut by the support line of the corner's
/// normal `normalize(n_a + n_b)`. At most 6 vertices.
pub fn hexagon_2d(d: &EndDiscs) -> Option<Vec<Vec2>> {
    let m = MidTriangle::new(d)?;
    let l = m.local(d);
    let lines = edge_lines(&m, &l);
    let corners = triangle_of(&lines);
    let mut out = Vec::with_capacity(6);
    for i in 0..3 {
        let (a, b) = (lines[(i + 2) % 3], lines[i]);
        let n = (a.n + b.n).normalize();
        let cut = Line { n, h: l.support(n) };
        if n.dot(corners[i]) > cut.h {
            out.push(intersect(a, cut)); // on the incoming edge's line
            out.push(intersect(cut, b)); // on the outgoing edge's line
        } else {
            out.push(corners[i]);
        }
    }
    finish(&l, &out)
}

/// Normals of the variable-radius triangle's edges (slot order of `m`): the outer common tangent of
/// the discs of radius `R_i = max(r_i, r_{i+3}) + |c_{i+3} − c_i| / 2` around the mid vertices, or the
/// edge normal for nested circles (`|β| ≥ 1`).
pub fn variable_radius_normals(d: &EndDiscs, m: &MidTriangle) -> [Vec2; 3] {
    // R for original vertex i: one disc around p_i enclosing both of its end discs.
    let big_r =
        [0, 1, 2].map(|i| d.radius[i].max(d.radius[i + 3]) + 0.5 * (d.centre[i + 3] - d.centre[i]).length());
    [0, 1, 2].map(|i| {
        let (a, b) = (m.vertex[i], m.vertex[(i + 1) % 3]);
        let beta = (big_r[a] - big_r[b]) / m.len[i];
        if beta.abs() >= 1.0 {
            m.normal[i] // nested circles: no outer common tangent
        } else {
            // n·e = β makes n·p_a + R_a = n·p_b + R_b: the line touches both discs from outside.
            m.normal[i] * (1.0 - beta * beta).sqrt() + m.dir[i] * beta
        }
    })
}

/// Do three CCW-ordered normals positively span the plane (so their half-planes bound a triangle)?
pub fn positively_span(n: &[Vec2; 3]) -> bool {
    (0..3).all(|i| n[i].perp_dot(n[(i + 1) % 3]) > 0.0)
}

/// Variable-radius triangle: the support half-planes of [`variable_radius_normals`] (offsets over all
/// six true discs). Falls back to the parallel-edge triangle when the normals do not positively span
/// the plane (diverging edges: the half-planes are unbounded).
pub fn variable_radius_triangle(d: &EndDiscs) -> Option<Vec<Vec2>> {
    let m = MidTriangle::new(d)?;
    let l = m.local(d);
    let normals = variable_radius_normals(d, &m);
    if !positively_span(&normals) {
        return finish(&l, &triangle_of(&edge_lines(&m, &l)));
    }
    finish(&l, &triangle_of(&normals.map(|n| Line { n, h: l.support(n) })))
}

/// The adaptive policy (thesis §4.7 chooses per triangle; this policy is ours, set from the measured
/// sample test efficiency in docs/STOCHASTIC.md): blur small against the inradius, and no motion beyond
/// it → [`BoundKind::ParallelEdgeTriangle`] (3 vertices; the octagon hull's corners are 8 % wider than
/// its discs, the triangle's edges are not); everything else — motion, blur comparable to or larger
/// than the triangle, a degenerate mid triangle → [`BoundKind::ConvexHull`], which measured tightest
/// there (the 2D and 3D hexagons and the triangles were looser on both built-in scenes).
pub fn adaptive_kind_of(d: &EndDiscs) -> BoundKind {
    let Some(m) = MidTriangle::new(d) else { return BoundKind::ConvexHull };
    let rmax = d.max_radius();
    if d.motion_px() > rmax.max(ADAPTIVE_MOTION_MIN_PX) {
        BoundKind::ConvexHull
    } else if rmax <= ADAPTIVE_SMALL_BLUR * m.inradius() {
        BoundKind::ParallelEdgeTriangle
    } else {
        BoundKind::ConvexHull
    }
}
