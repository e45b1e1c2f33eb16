//! 2D convex hull by Andrew's monotone chain.
//!
//! Robust to duplicate and collinear input points: orientation tests are evaluated in `f64` (the
//! products of two `f32` differences are exact there up to one rounding), collinear points on the hull
//! boundary are dropped, and duplicates collapse. Non-finite points are ignored.
//!
//! Orientation convention: the result is **counter-clockwise in the (x, y) coordinates given** — the
//! usual positive-shoelace orientation. In pixel coordinates (y down) that is clockwise *on screen*, but
//! every test in this module only relies on `cross(b − a, p − a) ≥ 0` for interior points `p` of an
//! edge `a → b`.

use glam::Vec2;

/// `cross(b − a, c − a)` in `f64`: > 0 when `a → b → c` turns counter-clockwise (x right, y up sense).
pub fn orient(a: Vec2, b: Vec2, c: Vec2) -> f64 {
    let (ax, ay) = (a.x as f64, a.y as f64);
    let (bx, by) = (b.x as f64 - ax, b.y as f64 - ay);
    let (cx, cy) = (c.x as f64 - ax, c.y as f64 - ay);
    bx * cy - by * cx
}

/// Convex hull of `points`, counter-clockwise, no repeated vertices, no collinear vertices.
///
/// Returns 0 points for empty input, 1 point when all points coincide, 2 points (a segment) when they
/// are all collinear, otherwise a polygon with ≥ 3 vertices starting at the lexicographically smallest
/// point.
pub fn convex_hull(points: &[Vec2]) -> Vec<Vec2> {
    let mut pts: Vec<Vec2> = points.iter().copied().filter(|p| p.is_finite()).collect();
    pts.sort_by(|a, b| a.x.total_cmp(&b.x).then(a.y.total_cmp(&b.y)));
    pts.dedup();
    if pts.len() <= 2 {
        return pts;
    }
    let mut hull: Vec<Vec2> = Vec::with_capacity(2 * pts.len());
    // Lower chain, left to right.
    for &p in &pts {
        while hull.len() >= 2 && orient(hull[hull.len() - 2], hull[hull.len() - 1], p) <= 0.0 {
            hull.pop();
        }
        hull.push(p);
    }
    // Upper chain, right to left.
    let lower_len = hull.len() + 1;
    for &p in pts.iter().rev().skip(1) {
        while hull.len() >= lower_len && orient(hull[hull.len() - 2], hull[hull.len() - 1], p) <= 0.0 {
            hull.pop();
        }
        hull.push(p);
    }
    hull.pop(); // the first point again
    if hull.len() == 2 && hull[0] == hull[1] {
        hull.pop();
    }
    hull
}

/// Signed area (shoelace) of a polygon: positive for counter-clockwise.
pub fn signed_area(poly: &[Vec2]) -> f64 {
    if poly.len() < 3 {
        return 0.0;
    }
    let mut a = 0.0f64;
    for i in 0..poly.len() {
        let p = poly[i];
        let q = poly[(i + 1) % poly.len()];
        a += p.x as f64 * q.y as f64 - q.x as f64 * p.y as f64;
    }
    0.5 * a
}

/// Is `p` within distance `tol` of the convex CCW polygon `poly` (as returned by [`convex_hull`])?
/// For ≥ 3 vertices every edge's half-plane is widened by `tol` (a slightly larger, mitred polygon);
/// a 2-vertex hull is a segment and a 1-vertex hull a point.
pub fn convex_contains(poly: &[Vec2], p: Vec2, tol: f32) -> bool {
    let tol = tol.max(0.0) as f64;
    match poly.len() {
        0 => false,
        1 => (p - poly[0]).length() as f64 <= tol,
        2 => segment_distance(poly[0], poly[1], p) <= tol,
        n => (0..n).all(|i| {
            let a = poly[i];
            let b = poly[(i + 1) % n];
            let len = (b - a).as_dvec2().length();
            // Signed distance of p to the edge's line, positive inside.
            orient(a, b, p) >= -tol * len
        }),
    }
}

fn segment_distance(a: Vec2, b: Vec2, p: Vec2) -> f64 {
    let (a, b, p) = (a.as_dvec2(), b.as_dvec2(), p.as_dvec2());
    let ab = b - a;
    let l2 = ab.length_squared();
    let s = if l2 > 0.0 { ((p - a).dot(ab) / l2).clamp(0.0, 1.0) } else { 0.0 };
    (a + ab * s - p).length()
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn square_with_interior_duplicate_and_collinear_points() {
        let pts = [
            Vec2::new(0.0, 0.0),
            Vec2::new(1.0, 0.0),
            Vec2::new(0.5, 0.0), // collinear on an edge
            Vec2::new(1.0, 1.0),
            Vec2::new(0.0, 1.0),
            Vec2::new(0.0, 1.0), // duplicate
            Vec2::new(0.5, 0.5), // interior
            Vec2::new(0.0, 0.5), // collinear on an edge
        ];
        let h = convex_hull(&pts);
        assert_eq!(h.len(), 4, "{h:?}");
        assert!(signed_area(&h) > 0.99 && signed_area(&h) < 1.01);
        assert_eq!(h[0], Vec2::ZERO);
    }

    #[test]
    fn degenerate_inputs() {
        assert!(convex_hull(&[]).is_empty());
        let p = Vec2::new(3.0, -2.0);
        assert_eq!(convex_hull(&[p, p, p]), vec![p]);
        let line: Vec<Vec2> = (0..7).map(|i| Vec2::new(i as f32, 2.0 * i as f32)).collect();
        let h = convex_hull(&line);
        assert_eq!(h, vec![line[0], line[6]]);
        assert!(convex_contains(&h, Vec2::new(3.0, 6.0), 1e-4));
        assert!(!convex_contains(&h, Vec2::new(7.5, 15.0), 1e-4), "beyond the segment's end");
        assert!(convex_hull(&[Vec2::NAN, p]) == vec![p]);
    }

    proptest! {
        #![proptest_config(ProptestConfig { failure_persistence: None, ..ProptestConfig::with_cases(2000) })]
        #[test]
        fn hull_is_convex_ccw_and_contains_all(
            raw in prop::collection::vec((-1000i32..1000, -1000i32..1000), 1..40),
            scale in prop_oneof![Just(1.0f32), Just(1e-3f32), Just(37.5f32)],
            collinear in any::<bool>(),
        ) {
            // Integer grids produce many duplicates and exactly collinear triples.
            let pts: Vec<Vec2> = raw
                .iter()
                .map(|&(x, y)| {
                    let y = if collinear { x / 2 } else { y };
                    Vec2::new(x as f32, y as f32) * scale
                })
                .collect();
            let h = convex_hull(&pts);
            prop_assert!(!h.is_empty());
            for p in &h {
                prop_assert!(pts.contains(p), "hull vertex {p} not an input point");
            }
            if h.len() >= 3 {
                prop_assert!(signed_area(&h) > 0.0);
                for i in 0..h.len() {
                    let (a, b, c) = (h[i], h[(i + 1) % h.len()], h[(i + 2) % h.len()]);
                    prop_assert!(orient(a, b, c) > 0.0, "not strictly convex at {b}");
                }
            }
            let tol = 1e-4 * scale * 1000.0;
            for &p in &pts {
                prop_assert!(convex_contains(&h, p, tol), "{p} outside {h:?}");
            }
        }
    }
}
