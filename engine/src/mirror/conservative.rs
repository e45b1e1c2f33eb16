//! Who dilates a conservative hull: the shader alone, or the rasterizer's overestimation
//! (`VK_EXT_conservative_rasterization`) with the shader adding only what the rasterizer does not.
//!
//! Two passes need every fragment a shape can reach, and get it by drawing a dilated shape:
//!
//! * the stochastic bounds ([`super::bounds`]): every pixel whose square meets the bound must get a
//!   fragment that tests its samples, and on the mask path every rasterizer sample of it must be
//!   covered (`gl_SampleMask` only clears bits). Without the extension the shader dilates by the box
//!   [`super::bounds::dilation_px`], which reaches each of the pixel's rasterizer sample points;
//! * the texture-space atlas' outer hull (the "conservative" sub-pass of pass 1): every texel whose
//!   centre lies within a box of half-size `h` texels of the chart triangle
//!   (`BILINEAR_HULL_TEXELS` = 1: the texels a bilinear lookup inside it reads). Without the extension
//!   the shader emits the Minkowski sum with that box and the rasterizer samples texel centres.
//!
//! With the extension in overestimation mode the rasterizer generates a fragment, with every sample
//! covered, for each pixel whose closed square meets the primitive (and may add a little more:
//! `primitiveOverestimationSize`). A pixel square meets `P` exactly when its centre lies in
//! `P ⊕ [−½, ½]²`, so the rasterizer already does half a pixel of box dilation, and the shader keeps
//! only the rest:
//!
//! * bounds: nothing but [`DILATE_MARGIN_PX`] (every pixel the bound touches is generated, all its
//!   samples covered, whatever the MSAA count or sample locations; the margin keeps a point- or
//!   segment-shaped bound a polygon, which the rasterizer must not cull as degenerate);
//! * atlas hull: `h − ½` (+ the margin), for `h ≥ ½`; a smaller `h` stays in the shader, where the
//!   rasterizer's half pixel would over-cover.
//!
//! `extraPrimitiveOverestimationSize` is left at 0 on purpose: the rasterizer moves each *edge* out by
//! it, which contains the Minkowski sum with a disc, not with a box, so replacing a box of half-size
//! `s` would need `s·√2` and over-cover corners' neighbours; the box stays in the shader, exact, and
//! needs no device limit. [`choose`] is the selection, [`Overestimation::covers`] and
//! [`covered_at_points`] the two rasterizers' coverage rules the tests hold it to.

use glam::Vec2;

use super::bounds::{dilate_box, dilation_px, DILATE_MARGIN_PX};

/// The device's overestimation, from `VkPhysicalDeviceConservativeRasterizationPropertiesEXT`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Overestimation {
    /// `primitiveOverestimationSize`: how far the rasterizer may move each edge out on its own, px.
    pub primitive_px: f32,
    /// `maxExtraPrimitiveOverestimationSize` (reported; Shutter asks for no extra).
    pub max_extra_px: f32,
    /// `degenerateTrianglesRasterized` (reported; the shader's margin keeps every shape a polygon).
    pub degenerate_triangles_rasterized: bool,
}

/// What a pass needs covered.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Need {
    /// The stochastic bound: every rasterizer sample of every pixel whose square meets the bound, with
    /// `raster_samples` samples per pixel (1: the visibility path; M: the mask target).
    PixelsTouched { raster_samples: u32, standard_sample_locations: bool },
    /// The atlas' outer hull: every texel whose centre lies within the box of half-size `h` of the
    /// triangle.
    CentresWithin { h: f32 },
}

/// Who dilates, and by how much the shader still does.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Dilation {
    /// The shader dilates by the box of half-size `box_px`; ordinary rasterization.
    Shader { box_px: f32 },
    /// The rasterizer overestimates (extra 0) and the shader dilates by `box_px` first.
    Rasterizer { box_px: f32 },
}

impl Dilation {
    /// The box half-size the shader dilates by (the pipelines' `dilate` / `hull_texels`).
    pub fn shader_box_px(self) -> f32 {
        match self {
            Dilation::Shader { box_px } | Dilation::Rasterizer { box_px } => box_px,
        }
    }

    /// Whether the pipeline rasterizes in overestimation mode.
    pub fn overestimate(self) -> bool {
        matches!(self, Dilation::Rasterizer { .. })
    }

    /// One line for `probe` and reports.
    pub fn describe(self) -> String {
        match self {
            Dilation::Shader { box_px } => format!("shader dilation by a {box_px:.4} px box"),
            Dilation::Rasterizer { box_px } => {
                format!("the rasterizer's overestimation after a {box_px:.4} px box in the shader")
            }
        }
    }
}

/// The dilation for `need` on a device with `overestimation` (`None`: no extension, or disabled).
pub fn choose(need: Need, overestimation: Option<Overestimation>) -> Dilation {
    match (need, overestimation) {
        (Need::PixelsTouched { raster_samples, standard_sample_locations }, None) => {
            Dilation::Shader { box_px: dilation_px(raster_samples, standard_sample_locations) }
        }
        (Need::PixelsTouched { .. }, Some(_)) => Dilation::Rasterizer { box_px: DILATE_MARGIN_PX },
        (Need::CentresWithin { h }, Some(_)) if h >= 0.5 => {
            Dilation::Rasterizer { box_px: h - 0.5 + DILATE_MARGIN_PX }
        }
        (Need::CentresWithin { h }, _) => Dilation::Shader { box_px: h },
    }
}

impl Overestimation {
    /// The overestimating rasterizer's rule: pixel `(px, py)` (square `[px, px + 1] × [py, py + 1]`)
    /// gets a fragment, every sample covered, when its closed square meets the convex polygon `poly`
    /// (positive area, or a point or a segment) moved out by `primitive_px` — tested here without that
    /// margin when `strict`, the least any implementation covers.
    pub fn covers(&self, poly: &[Vec2], px: i32, py: i32, strict: bool) -> bool {
        let grow = if strict { 0.0 } else { self.primitive_px };
        square_meets_convex(poly, Vec2::new(px as f32, py as f32), grow)
    }
}

/// The ordinary rasterizer's rule: the points `pixel + offsets[i]` that lie in the convex polygon
/// `poly` (closed: the top-left rule is what [`DILATE_MARGIN_PX`] absorbs).
pub fn covered_at_points(poly: &[Vec2], px: i32, py: i32, offsets: &[Vec2]) -> Vec<bool> {
    let corner = Vec2::new(px as f32, py as f32);
    offsets.iter().map(|&o| super::bounds::convex_contains(poly, corner + o, 0.0)).collect()
}

/// Whether the closed unit square at `corner` meets the convex polygon `poly` grown by `grow` along
/// every separating direction (separating-axis test over the square's two axes and `poly`'s edge
/// normals, which decides it exactly for convex shapes).
fn square_meets_convex(poly: &[Vec2], corner: Vec2, grow: f32) -> bool {
    let square = [corner, corner + Vec2::X, corner + Vec2::ONE, corner + Vec2::Y];
    let mut axes = vec![Vec2::X, Vec2::Y];
    if poly.len() >= 2 {
        for i in 0..poly.len() {
            let e = poly[(i + 1) % poly.len()] - poly[i];
            if e.length_squared() > 0.0 {
                axes.push(Vec2::new(e.y, -e.x).normalize());
            }
        }
    }
    axes.iter().all(|&a| {
        let span = |pts: &[Vec2]| {
            pts.iter().fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), p| {
                (lo.min(a.dot(*p)), hi.max(a.dot(*p)))
            })
        };
        let (p0, p1) = span(poly);
        let (s0, s1) = span(&square);
        p0 - grow <= s1 && s0 <= p1 + grow
    })
}

/// `poly` as the shader emits it under `dilation` (its box), before the rasterizer sees it.
pub fn emitted(poly: &[Vec2], dilation: Dilation) -> Vec<Vec2> {
    dilate_box(poly, dilation.shader_box_px())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mirror::bounds::convex_hull;
    use proptest::prelude::*;

    const DEVICE: Overestimation = Overestimation {
        primitive_px: 1.0 / 256.0,
        max_extra_px: 0.75,
        degenerate_triangles_rasterized: false,
    };

    /// The Vulkan standard sample locations per pixel (the shader path's rasterizer samples).
    fn standard_offsets(m: u32) -> Vec<Vec2> {
        let table: &[(f32, f32)] = match m {
            1 => &[(0.5, 0.5)],
            2 => &[(0.75, 0.75), (0.25, 0.25)],
            4 => &[(0.375, 0.125), (0.875, 0.375), (0.125, 0.625), (0.625, 0.875)],
            8 => &[
                (0.5625, 0.3125),
                (0.4375, 0.6875),
                (0.8125, 0.5625),
                (0.3125, 0.1875),
                (0.1875, 0.8125),
                (0.0625, 0.4375),
                (0.6875, 0.9375),
                (0.9375, 0.0625),
            ],
            _ => unreachable!(),
        };
        table.iter().map(|&(x, y)| Vec2::new(x, y)).collect()
    }

    fn point() -> impl Strategy<Value = Vec2> {
        (-20.0f32..20.0, -20.0f32..20.0).prop_map(|(x, y)| Vec2::new(x, y))
    }

    /// A point of `poly` (a convex combination of its vertices).
    fn inside(poly: &[Vec2], w: &[f32]) -> Vec2 {
        let total: f32 = w.iter().take(poly.len()).sum();
        if total < 1e-6 {
            return poly[0];
        }
        poly.iter().zip(w).map(|(&p, &wi)| p * (wi / total)).sum()
    }

    #[test]
    fn without_the_extension_the_shader_dilates_as_before() {
        for m in [1, 2, 4, 8] {
            let need = Need::PixelsTouched { raster_samples: m, standard_sample_locations: true };
            assert_eq!(choose(need, None), Dilation::Shader { box_px: dilation_px(m, true) });
            assert!(!choose(need, None).overestimate());
        }
        assert_eq!(choose(Need::CentresWithin { h: 1.0 }, None), Dilation::Shader { box_px: 1.0 });
    }

    #[test]
    fn with_the_extension_the_rasterizer_takes_half_a_pixel() {
        let need = Need::PixelsTouched { raster_samples: 4, standard_sample_locations: false };
        assert_eq!(choose(need, Some(DEVICE)), Dilation::Rasterizer { box_px: DILATE_MARGIN_PX });
        assert_eq!(
            choose(Need::CentresWithin { h: 1.0 }, Some(DEVICE)),
            Dilation::Rasterizer { box_px: 0.5 + DILATE_MARGIN_PX }
        );
        // Less than the rasterizer's own half pixel: the shader keeps it.
        assert_eq!(choose(Need::CentresWithin { h: 0.25 }, Some(DEVICE)), Dilation::Shader { box_px: 0.25 });
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(3000))]
        /// Every rasterizer sample of every pixel a bound touches is covered, by either dilation, on
        /// every MSAA count; the overestimating rasterizer is taken at its strictest (no margin of its
        /// own).
        #[test]
        fn both_dilations_cover_every_sample_of_every_touched_pixel(
            pts in prop::collection::vec(point(), 1..8),
            w in prop::collection::vec(0.0f32..1.0, 8),
            off in (0.0f32..=1.0, 0.0f32..=1.0),
            m in prop::sample::select(vec![1u32, 2, 4, 8]),
        ) {
            let bound = convex_hull(&pts);
            // A pixel whose square holds a point of the bound.
            let q = inside(&bound, &w);
            // The pixel holding it, or its left/lower neighbour where q lies on their shared edge.
            let pick = |v: f32, o: f32| if o < 0.5 && v == v.floor() { v as i32 - 1 } else { v.floor() as i32 };
            let (px, py) = (pick(q.x, off.0), pick(q.y, off.1));
            let need = Need::PixelsTouched { raster_samples: m, standard_sample_locations: true };
            let shader = choose(need, None);
            let covered = covered_at_points(&emitted(&bound, shader), px, py, &standard_offsets(m));
            prop_assert!(covered.iter().all(|&c| c), "shader path misses a sample of ({px}, {py}): {covered:?}");
            let raster = choose(need, Some(DEVICE));
            prop_assert!(DEVICE.covers(&emitted(&bound, raster), px, py, true));
        }

        /// The atlas hull: every texel whose centre lies within the box of half-size h of the triangle
        /// gets a fragment by either dilation; and the rasterizer's never reaches a texel whose centre
        /// lies more than the margin (and its own overestimation) beyond that box.
        #[test]
        fn both_dilations_cover_the_atlas_hull_and_no_more_than_it(
            tri in prop::collection::vec(point(), 3),
            w in prop::collection::vec(0.0f32..1.0, 3),
            d in (-1.0f32..=1.0, -1.0f32..=1.0),
            h in 0.5f32..2.0,
            probe in point(),
        ) {
            let tri = convex_hull(&tri);
            let need = Need::CentresWithin { h };
            // A texel whose centre is within h of a point of the triangle.
            let c = inside(&tri, &w) + Vec2::new(d.0, d.1) * h;
            let (tx, ty) = ((c.x - 0.5).round() as i32, (c.y - 0.5).round() as i32);
            let centre = Vec2::new(tx as f32 + 0.5, ty as f32 + 0.5);
            let within = crate::mirror::bounds::convex_contains(&dilate_box(&tri, h), centre, 0.0);
            if within {
                let shader = choose(need, None);
                prop_assert!(covered_at_points(&emitted(&tri, shader), tx, ty, &standard_offsets(1))[0]);
                let raster = choose(need, Some(DEVICE));
                prop_assert!(DEVICE.covers(&emitted(&tri, raster), tx, ty, true));
            }
            // Tightness: a texel centre outside the box of h + margin + the device's own margin
            // (times √2 for the corners) is never generated.
            let (ux, uy) = (probe.x.floor() as i32, probe.y.floor() as i32);
            let far = h + DILATE_MARGIN_PX + DEVICE.primitive_px * std::f32::consts::SQRT_2 + 1e-3;
            let ucentre = Vec2::new(ux as f32 + 0.5, uy as f32 + 0.5);
            if !crate::mirror::bounds::convex_contains(&dilate_box(&tri, far), ucentre, 0.0) {
                prop_assert!(!DEVICE.covers(&emitted(&tri, choose(need, Some(DEVICE))), ux, uy, false));
            }
        }
    }
}
