//! The dilation the geometry shader applies to every convex piece of a bound before rasterizing it
//! (`shaders-glsl/stochastic/emit.glsl`, mirrored here operation for operation): the Minkowski sum with
//! the box `[−h, h]²`. A sample may lie anywhere in its pixel's square and so may the rasterizer's own
//! sample points; with `h` = [`dilation_px`] every sample point of every pixel whose square meets the bound is
//! covered, so the fragment shader runs wherever a sample can hit.

use glam::Vec2;

/// Margin added to every dilation so samples exactly on an edge (top-left rule) stay inside.
pub const DILATE_MARGIN_PX: f32 = 1.0 / 64.0;

/// The box half-size the geometry shader dilates by for `msaa` samples per pixel. A bound point `q` in
/// pixel square `[c, c + 1]²` and a rasterizer sample point `c + o` of the same pixel differ by
/// `o − (q − c) ∈ [o − 1, o]²` per axis, so `max_i max(o_i, 1 − o_i)` suffices: with the Vulkan
/// standard sample locations 0.5 (1×), 0.75 (2×), 0.875 (4×), 0.9375 (8×); 1 for anything else.
pub fn dilation_px(msaa: u32, standard_sample_locations: bool) -> f32 {
    let h = match (standard_sample_locations, msaa) {
        (_, 1) => 0.5, // a single sample is always at the pixel centre
        (true, 2) => 0.75,
        (true, 4) => 0.875,
        (true, 8) => 0.9375,
        _ => 1.0,
    };
    h + DILATE_MARGIN_PX
}

/// Quadrant of direction `n`, counter-clockwise from +x; the box corner `(sign x, sign y)` supports
/// every direction in it.
fn quadrant(n: Vec2) -> usize {
    if n.x > 0.0 && n.y >= 0.0 {
        0
    } else if n.x <= 0.0 && n.y > 0.0 {
        1
    } else if n.x < 0.0 && n.y <= 0.0 {
        2
    } else {
        3
    }
}

fn box_corner(q: usize, h: f32) -> Vec2 {
    [Vec2::new(1.0, 1.0), Vec2::new(-1.0, 1.0), Vec2::new(-1.0, -1.0), Vec2::new(1.0, -1.0)][q] * h
}

/// `poly ⊕ [−h, h]²` for a convex polygon with positive shoelace area (or a point or a segment): each
/// vertex followed by the box corners its normal cone sweeps, in order. At most `poly.len() + 4` points.
pub fn dilate_box(poly: &[Vec2], h: f32) -> Vec<Vec2> {
    let n = poly.len();
    let mut out = Vec::with_capacity(n + 4);
    if n == 1 {
        out.extend((0..4).map(|q| poly[0] + box_corner(q, h)));
        return out;
    }
    let outward = |a: Vec2, b: Vec2| {
        let e = b - a;
        Vec2::new(e.y, -e.x)
    };
    for i in 0..n {
        let (prev, cur, next) = (poly[(i + n - 1) % n], poly[i], poly[(i + 1) % n]);
        let mut qa = quadrant(outward(prev, cur));
        let qb = quadrant(outward(cur, next));
        out.push(cur + box_corner(qa, h));
        for _ in 0..4 {
            if qa == qb {
                break;
            }
            qa = (qa + 1) & 3;
            out.push(cur + box_corner(qa, h));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mirror::bounds::{convex_contains, convex_hull, signed_area};
    use proptest::prelude::*;

    fn point() -> impl Strategy<Value = Vec2> {
        (-100.0f32..100.0, -100.0f32..100.0).prop_map(|(x, y)| Vec2::new(x, y))
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(2000))]
        /// Every point of the polygon moved by any offset in the box lies in the dilated polygon, which
        /// is convex, positively oriented and has at most n + 4 vertices.
        #[test]
        fn dilation_is_the_minkowski_sum_with_the_box(
            pts in prop::collection::vec(point(), 1..12),
            w in prop::collection::vec(0.0f32..1.0, 12),
            off in (-1.0f32..=1.0, -1.0f32..=1.0),
        ) {
            let poly = convex_hull(&pts);
            let d = dilate_box(&poly, 1.0 + DILATE_MARGIN_PX);
            prop_assert!(d.len() <= poly.len() + 4);
            let hull = convex_hull(&d);
            prop_assert!(signed_area(&hull) > 0.0);
            // A convex combination of the polygon's vertices, offset within the box.
            let total: f32 = w.iter().take(poly.len()).sum::<f32>().max(1e-6);
            let q = poly.iter().zip(&w).map(|(&p, &wi)| p * (wi / total)).sum::<Vec2>();
            let q = if w.iter().take(poly.len()).sum::<f32>() < 1e-6 { poly[0] } else { q };
            let p = q + Vec2::new(off.0, off.1);
            prop_assert!(convex_contains(&d, p, 1e-3), "{p} not in {d:?} (poly {poly:?})");
            // The emitted order is itself convex: every point is on the hull boundary or inside.
            for &x in &d {
                prop_assert!(convex_contains(&hull, x, 1e-3));
            }
        }
    }
}
