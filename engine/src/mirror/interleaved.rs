//! Interleaved deferred shading of many lights (Segovia, Iehl, Mitanchey & Péroche, Graphics Hardware
//! 2006; docs/INTERLEAVED.md) — the CPU mirror of its pipeline, the specification a GPU port must
//! match operation for operation.
//!
//! Each pixel of an `n × m` pattern shades its own subset of the virtual point lights, and the pattern's
//! subsets are mixed back by a filter that stops at discontinuities:
//! 1. **G-buffer** ([`crate::reference::gbuffer`]): per pixel, position, normal, albedo and the direct
//!    light.
//! 2. **Splitting** ([`Layout`]): texel `(x, y)` goes to sub-buffer `(x mod n, y mod m)` at
//!    `(x / n, y / m)`; the sub-buffers tile a buffer of the (padded) image's size. In one pass
//!    ([`split_one_pass`]), or in two ([`split_two_pass`]): each block of `bw × bh` texels is split into
//!    its `n × m` sub-blocks in place, then whole sub-blocks are moved to their sub-buffers — the
//!    paper's cache-friendly variant. Both give the same buffer (tested).
//! 3. **Shading**: sub-buffer `k = j·n + i` gathers the VPLs whose index is `k` modulo `n·m`, its
//!    light scaled by `n·m`, so that the pattern's mean is the estimate with every VPL.
//! 4. **Gathering**: the inverse permutation ([`gather_one_pass`], [`gather_two_pass`]).
//! 5. **Discontinuity buffer** ([`discontinuities`]): a texel is flagged when one of its three positive
//!    neighbours `(x+1, y)`, `(x, y+1)`, `(x+1, y+1)` differs from it: normals more than a threshold
//!    angle apart, positions farther apart than a threshold share of the view depth, or one of them is
//!    background.
//! 6. **Edge-aware separable Gaussian** ([`blur`], horizontal then vertical): from each texel, the
//!    kernel extends in each direction until it would cross a flagged texel's edge. A flag on texel `a`
//!    closes the edge between `a` and `a + 1`, so a flagged texel blends only towards `−x` (`−y`), as
//!    the paper's two cases say. The **bilinear variant** fetches the kernel's texels in pairs, one
//!    fetch at the weighted position between them (what hardware bilinear filtering gives): a pair
//!    counts only when both of its texels are reachable. The paper tests the flags bilinearly at the
//!    pair's position; ours checks the edges crossed up to the pair's far texel, the same
//!    "sufficient" rule, stated exactly.
//! 7. **Compose**: direct light plus the albedo times the filtered indirect light (albedo after the
//!    filter, so textures are not blurred).
//!
//! The brute-force baseline is the pattern 1 × 1 without a filter: every texel gathers every VPL.
//!
//! **Depth of field and motion: by accumulation** ([`frame_passes`], [`render_frame`]). A scene with a
//! lens or motion is rendered as P = `spp` whole interleaved frames, each through one
//! (subpixel, lens, time) sample shared by every pixel — the samples of technique `accumulation` —
//! and averaged: each pass' G-buffer holds what the camera sees through its sample (so a G-buffer
//! texel is one sample of its pixel, never a mix of surfaces), and the filter works within a pass.
//! The VPLs of a still scene are one set, traced at mid-shutter, lighting every pass; a moving scene
//! gets a set per pass, traced at the pass' time with a seed of its own ([`pass_vpls`]). A still
//! pinhole scene keeps the single pass through the pixel centres.

use glam::{Vec2, Vec3};

use crate::error::{Error, Result};
use crate::image::LinearImage;
use crate::reference::gbuffer::{render_gbuffer_at, GBuffer, GBufferScene};
use crate::reference::{virtual_point_lights_at, VirtualPointLight, VplSettings};
use crate::sampling::PassSample;
use crate::scene::camera_space::CameraSpaceScene;
use crate::scene::Scene;
use crate::techniques::accumulation::accumulation_passes;

/// An `n × m` interleaving pattern.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Pattern {
    pub n: u32,
    pub m: u32,
}

/// The largest pattern side.
pub const MAX_PATTERN: u32 = 16;

impl Pattern {
    pub const ONE: Pattern = Pattern { n: 1, m: 1 };
    pub fn sub_buffers(&self) -> u32 {
        self.n * self.m
    }
    pub fn name(&self) -> String {
        format!("{}x{}", self.n, self.m)
    }
}

impl std::str::FromStr for Pattern {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        let bad = || {
            Error::Unsupported(format!("pattern `{s}`: NxM with 1 ≤ N, M ≤ {MAX_PATTERN} (e.g. 4x4, 8x6)"))
        };
        let (n, m) = s.split_once('x').ok_or_else(bad)?;
        let (n, m): (u32, u32) = (n.parse().map_err(|_| bad())?, m.parse().map_err(|_| bad())?);
        if !(1..=MAX_PATTERN).contains(&n) || !(1..=MAX_PATTERN).contains(&m) {
            return Err(bad());
        }
        Ok(Pattern { n, m })
    }
}

/// Where each texel of a `width × height` image goes in the split buffer: the image padded to whole
/// blocks of `block` texels (each a whole number of patterns), every sub-buffer `sub` texels.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Layout {
    pub pattern: Pattern,
    /// The two-pass split's block, texels (multiples of the pattern's sides).
    pub block: (u32, u32),
    /// The padded size: whole blocks.
    pub width: u32,
    pub height: u32,
    /// Each sub-buffer's size: `(width / n, height / m)`.
    pub sub: (u32, u32),
}

impl Layout {
    /// The layout of an image of `width × height` for `pattern`, with blocks of `block` patterns
    /// (`(1, 1)`: blocks of one pattern).
    pub fn new(width: u32, height: u32, pattern: Pattern, block: (u32, u32)) -> Result<Self> {
        if block.0 == 0 || block.1 == 0 || block.0 > 64 || block.1 > 64 {
            return Err(Error::Unsupported(format!(
                "split block of {}x{} patterns: 1 to 64 each",
                block.0, block.1
            )));
        }
        let (bw, bh) = (block.0 * pattern.n, block.1 * pattern.m);
        let (w, h) = (width.div_ceil(bw) * bw, height.div_ceil(bh) * bh);
        Ok(Layout { pattern, block: (bw, bh), width: w, height: h, sub: (w / pattern.n, h / pattern.m) })
    }

    /// Texel `(x, y)`'s sub-buffer index `j·n + i`.
    pub fn sub_buffer(&self, x: u32, y: u32) -> u32 {
        (y % self.pattern.m) * self.pattern.n + x % self.pattern.n
    }

    /// Texel `(x, y)`'s position in the split buffer.
    pub fn split(&self, x: u32, y: u32) -> (u32, u32) {
        let (n, m) = (self.pattern.n, self.pattern.m);
        ((x % n) * self.sub.0 + x / n, (y % m) * self.sub.1 + y / m)
    }

    /// The inverse of [`Layout::split`].
    pub fn unsplit(&self, u: u32, v: u32) -> (u32, u32) {
        let (n, m) = (self.pattern.n, self.pattern.m);
        let (i, j) = (u / self.sub.0, v / self.sub.1);
        ((u % self.sub.0) * n + i, (v % self.sub.1) * m + j)
    }

    /// Pass 1 of the two-pass split: texel `(x, y)`'s position after its block is split in place.
    pub fn block_split(&self, x: u32, y: u32) -> (u32, u32) {
        let (n, m) = (self.pattern.n, self.pattern.m);
        let (bw, bh) = self.block;
        let (lx, ly) = (x % bw, y % bh);
        (x - lx + (lx % n) * (bw / n) + lx / n, y - ly + (ly % m) * (bh / m) + ly / m)
    }

    /// Pass 2: a texel's position after its sub-block is moved to its sub-buffer (from its position
    /// after pass 1).
    pub fn block_translate(&self, x: u32, y: u32) -> (u32, u32) {
        let (bw, bh) = self.block;
        let (sw, sh) = (bw / self.pattern.n, bh / self.pattern.m);
        let (bx, by) = (x / bw, y / bh);
        let (lx, ly) = (x % bw, y % bh);
        let (i, j) = (lx / sw, ly / sh);
        (i * self.sub.0 + bx * sw + lx % sw, j * self.sub.1 + by * sh + ly % sh)
    }
}

/// Splits `src` (`layout.width × layout.height`, row-major) in one pass.
pub fn split_one_pass<T: Copy + Default>(layout: &Layout, src: &[T]) -> Vec<T> {
    permute(layout, src, |x, y| layout.split(x, y))
}

/// Splits `src` in two passes: block splitting, then block translation.
pub fn split_two_pass<T: Copy + Default>(layout: &Layout, src: &[T]) -> Vec<T> {
    let blocks = permute(layout, src, |x, y| layout.block_split(x, y));
    permute(layout, &blocks, |x, y| layout.block_translate(x, y))
}

/// The inverse of [`split_one_pass`].
pub fn gather_one_pass<T: Copy + Default>(layout: &Layout, src: &[T]) -> Vec<T> {
    permute(layout, src, |u, v| layout.unsplit(u, v))
}

/// The inverse of [`split_two_pass`]: the translation undone, then the blocks gathered.
pub fn gather_two_pass<T: Copy + Default>(layout: &Layout, src: &[T]) -> Vec<T> {
    // Destination of each texel of the split buffer, inverting each pass by scattering.
    let mut back_translate = vec![(0, 0); (layout.width * layout.height) as usize];
    let mut back_split = back_translate.clone();
    for y in 0..layout.height {
        for x in 0..layout.width {
            let (u, v) = layout.block_translate(x, y);
            back_translate[(v * layout.width + u) as usize] = (x, y);
            let (u, v) = layout.block_split(x, y);
            back_split[(v * layout.width + u) as usize] = (x, y);
        }
    }
    let blocks = permute(layout, src, |u, v| back_translate[(v * layout.width + u) as usize]);
    permute(layout, &blocks, |u, v| back_split[(v * layout.width + u) as usize])
}

/// `dst[to(x, y)] = src[(x, y)]` over the layout's texels.
fn permute<T: Copy + Default>(layout: &Layout, src: &[T], to: impl Fn(u32, u32) -> (u32, u32)) -> Vec<T> {
    let w = layout.width;
    let mut dst = vec![T::default(); src.len()];
    for y in 0..layout.height {
        for x in 0..w {
            let (u, v) = to(x, y);
            dst[(v * w + u) as usize] = src[(y * w + x) as usize];
        }
    }
    dst
}

/// Thresholds of the discontinuity buffer.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Discontinuity {
    /// Normals further apart than this angle, degrees.
    pub normal_deg: f32,
    /// Positions further apart than this share of the texel's view depth.
    pub position: f32,
}

impl Default for Discontinuity {
    fn default() -> Self {
        Discontinuity { normal_deg: 25.0, position: 0.05 }
    }
}

/// Bits of a texel's discontinuities: it differs from `(x+1, y)`, from `(x, y+1)`, from `(x+1, y+1)`.
pub const DIFFERS_X: u8 = 1;
pub const DIFFERS_Y: u8 = 2;
pub const DIFFERS_XY: u8 = 4;

/// The discontinuity buffer of `g` (module docs, step 5): per texel, which of its three positive
/// neighbours inside the image differ from it ([`DIFFERS_X`], …); the paper's flag is "any".
pub fn discontinuities(g: &GBuffer, t: &Discontinuity) -> Vec<u8> {
    let (w, h) = (g.width, g.height);
    let cos = t.normal_deg.to_radians().cos();
    let differs = |a: usize, b: usize| match (g.texels[a], g.texels[b]) {
        (None, None) => false,
        (Some(p), Some(q)) => {
            let depth = (-p.position.z).abs().max(1e-6);
            p.normal.dot(q.normal) < cos || (p.position - q.position).length() > t.position * depth
        }
        _ => true,
    };
    let mut flags = vec![0u8; (w * h) as usize];
    for y in 0..h {
        for x in 0..w {
            let i = (y * w + x) as usize;
            for (bit, (dx, dy)) in [(DIFFERS_X, (1, 0)), (DIFFERS_Y, (0, 1)), (DIFFERS_XY, (1, 1))] {
                let (nx, ny) = (x + dx, y + dy);
                if nx < w && ny < h && differs(i, (ny * w + nx) as usize) {
                    flags[i] |= bit;
                }
            }
        }
    }
    flags
}

/// Which edges between neighbouring texels the blur does not cross.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Edges {
    /// None: the plain Gaussian, the ablation that leaks light across edges.
    Ignore,
    /// The paper's: every edge leaving a texel towards `+x` or `+y` whose discontinuity flag is set
    /// (any of its three positive neighbours differs). Texels along an edge of the image are then cut
    /// off in both directions and keep their sub-buffer's noise.
    Texel,
    /// Per axis (our departure, from the same buffer's bits): the edge towards `+x` is closed when
    /// that neighbour differs ([`DIFFERS_X`]), towards `+y` likewise ([`DIFFERS_Y`]), so a texel
    /// along a silhouette still blends with its neighbours along it.
    Axis,
}

impl Edges {
    /// The filter named on the command line (`--filter`, `filter=`): `none` (no blur, `None`),
    /// `plain`, `full` (the paper's rule) or `axis`.
    pub fn of_filter(name: &str) -> Result<Option<Edges>> {
        match name {
            "none" => Ok(None),
            "plain" => Ok(Some(Edges::Ignore)),
            "full" => Ok(Some(Edges::Texel)),
            "axis" => Ok(Some(Edges::Axis)),
            _ => Err(Error::Unsupported(format!("filter `{name}`: none, plain, full or axis"))),
        }
    }
}

impl std::str::FromStr for Edges {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        match s {
            "ignore" => Ok(Edges::Ignore),
            "texel" => Ok(Edges::Texel),
            "axis" => Ok(Edges::Axis),
            _ => Err(Error::Unsupported(format!("edges `{s}`: ignore, texel (the paper's) or axis"))),
        }
    }
}

/// The blur's settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Blur {
    /// Kernel radius, texels (the kernel is `2r + 1` wide).
    pub radius: u32,
    /// Fetch the kernel's texels in pairs at their weighted position (hardware bilinear filtering).
    pub bilinear: bool,
    /// Which edges it stops at.
    pub edges: Edges,
}

/// The Gaussian weights of offsets `0 ..= radius`, σ = radius / 2.
pub fn gaussian_weights(radius: u32) -> Vec<f32> {
    let sigma = (radius as f32 / 2.0).max(0.5);
    (0..=radius).map(|k| (-((k * k) as f32) / (2.0 * sigma * sigma)).exp()).collect()
}

/// The edge-aware separable Gaussian of `values` (`w × h`) with the discontinuity buffer `flags`
/// (module docs, step 6): horizontal, then vertical.
pub fn blur(values: &[Vec3], flags: &[u8], w: u32, h: u32, b: &Blur) -> Vec<Vec3> {
    let weights = gaussian_weights(b.radius);
    let horizontal = blur_1d(values, flags, w, h, b, &weights, (1, 0));
    blur_1d(&horizontal, flags, w, h, b, &weights, (0, 1))
}

fn blur_1d(
    values: &[Vec3],
    flags: &[u8],
    w: u32,
    h: u32,
    b: &Blur,
    weights: &[f32],
    axis: (u32, u32),
) -> Vec<Vec3> {
    let len = if axis.0 == 1 { w } else { h } as i64;
    let mut out = vec![Vec3::ZERO; values.len()];
    for y in 0..h {
        for x in 0..w {
            let at = |k: i64| -> usize {
                if axis.0 == 1 {
                    (y * w) as usize + k as usize
                } else {
                    (k as u32 * w + x) as usize
                }
            };
            let c = if axis.0 == 1 { x } else { y } as i64;
            // Whether the edge from texel k towards + along this axis is closed.
            let along = if axis.0 == 1 { DIFFERS_X } else { DIFFERS_Y };
            let flagged = |k: i64| match b.edges {
                Edges::Ignore => false,
                Edges::Texel => flags[at(k)] != 0,
                Edges::Axis => flags[at(k)] & along != 0,
            };
            let (mut sum, mut weight) = (weights[0] * values[at(c)], weights[0]);
            for dir in [1i64, -1] {
                // Texel c + dir·k is reachable when no edge between c and it is closed: going +, the
                // flags of c … c+k−1; going −, those of c−k … c−1.
                let mut reachable = Vec::with_capacity(weights.len());
                reachable.push(true);
                for k in 1..weights.len() as i64 {
                    let p = c + dir * k;
                    let edge = if dir > 0 { p - 1 } else { p };
                    let ok = (0..len).contains(&p) && reachable[k as usize - 1] && !flagged(edge);
                    reachable.push(ok);
                }
                if b.bilinear {
                    // Pairs (k, k+1) from k = 1: one fetch at their weighted position; a lone last
                    // texel (of the kernel, or before the image's border) on its own.
                    let mut k = 1;
                    while k < weights.len() {
                        let pair = k + 1 < weights.len() && (0..len).contains(&(c + dir * (k as i64 + 1)));
                        if pair && reachable[k + 1] {
                            let (wa, wb) = (weights[k], weights[k + 1]);
                            let f = wb / (wa + wb);
                            let (a, bv) =
                                (values[at(c + dir * k as i64)], values[at(c + dir * (k + 1) as i64)]);
                            sum += (wa + wb) * a.lerp(bv, f);
                            weight += wa + wb;
                        } else if !pair && reachable[k] {
                            sum += weights[k] * values[at(c + dir * k as i64)];
                            weight += weights[k];
                        } else {
                            break;
                        }
                        k += 2;
                    }
                } else {
                    for k in 1..weights.len() {
                        if !reachable[k] {
                            break;
                        }
                        sum += weights[k] * values[at(c + dir * k as i64)];
                        weight += weights[k];
                    }
                }
            }
            out[at(c)] = sum / weight;
        }
    }
    out
}

/// How the interleaved image is made (module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct InterleavedSettings {
    pub pattern: Pattern,
    /// The two-pass split's block, in patterns.
    pub block: (u32, u32),
    /// `None`: no filter (the structured-noise ablation).
    pub blur: Option<Blur>,
    pub discontinuity: Discontinuity,
    /// The VPLs' `1/d²` clamping distance (0: off).
    pub clamp: f32,
    /// Shadow rays to the VPLs (the paper's SSM) or none (its SNSM).
    pub visibility: bool,
}

/// The image of interleaved deferred shading of `vpls` on the G-buffer scene `gs` (module docs), and
/// the filtered indirect light before the albedo (`None` for the background).
pub fn render(
    gs: &GBufferScene<'_>,
    vpls: &[VirtualPointLight],
    s: &InterleavedSettings,
) -> Result<LinearImage> {
    let g = &gs.gbuffer;
    let layout = Layout::new(g.width, g.height, s.pattern, s.block)?;
    // The G-buffer's texel indices, padded (u32::MAX: padding), split as the GPU splits the buffer.
    let mut index = vec![u32::MAX; (layout.width * layout.height) as usize];
    for y in 0..g.height {
        for x in 0..g.width {
            index[(y * layout.width + x) as usize] = y * g.width + x;
        }
    }
    let split = split_two_pass(&layout, &index);
    // Each sub-buffer's VPL subset.
    let k = s.pattern.sub_buffers() as usize;
    let subsets: Vec<Vec<VirtualPointLight>> =
        (0..k).map(|sb| vpls.iter().skip(sb).step_by(k).copied().collect()).collect();
    let scale = k as f32;
    let mut shaded = vec![Vec3::ZERO; split.len()];
    for (u, (&texel, out)) in split.iter().zip(shaded.iter_mut()).enumerate() {
        if texel == u32::MAX {
            continue;
        }
        let (sx, sy) = ((u as u32) % layout.width, (u as u32) / layout.width);
        let sb = (sy / layout.sub.1) * s.pattern.n + sx / layout.sub.0;
        *out = scale * gs.gather(texel as usize, &subsets[sb as usize], s.clamp, s.visibility);
    }
    let gathered = gather_two_pass(&layout, &shaded);
    // Back to the image's own size.
    let mut indirect = vec![Vec3::ZERO; (g.width * g.height) as usize];
    for y in 0..g.height {
        for x in 0..g.width {
            indirect[(y * g.width + x) as usize] = gathered[(y * layout.width + x) as usize];
        }
    }
    if let Some(b) = &s.blur {
        let flags = discontinuities(g, &s.discontinuity);
        indirect = blur(&indirect, &flags, g.width, g.height, b);
    }
    let mut image = LinearImage::new(g.width, g.height);
    for y in 0..g.height {
        for x in 0..g.width {
            let i = (y * g.width + x) as usize;
            let c = match g.texels[i] {
                Some(t) => t.direct + t.albedo * indirect[i],
                None => g.background,
            };
            image.set(x, y, [c.x, c.y, c.z, 1.0]);
        }
    }
    Ok(image)
}

/// The passes of an interleaved frame of `scene` (module docs): one through the pixel centres at
/// mid-shutter and the lens centre when the scene has neither a lens nor motion; otherwise `spp` passes
/// with the samples of technique `accumulation` (seed `seed`).
pub fn frame_passes(scene: &Scene, spp: u32, seed: u64) -> Vec<PassSample> {
    let c = &scene.camera;
    if c.aperture_radius == 0.0 && CameraSpaceScene::new(scene).is_still() {
        return vec![PassSample { time: 0.5, lens: Vec2::ZERO, jitter: Vec2::ZERO }];
    }
    accumulation_passes(spp.max(1), seed, c.aperture, c.shutter)
}

/// The VPL sets that light `passes` (module docs): for a still scene one set, traced at mid-shutter;
/// for a moving one a set per pass, traced at its time, the photons of pass `p` seeded by
/// [`pass_vpl_seed`].
pub fn pass_vpls(
    scene: &Scene,
    s: &VplSettings,
    passes: &[PassSample],
) -> Result<Vec<Vec<VirtualPointLight>>> {
    if CameraSpaceScene::new(scene).is_still() {
        return Ok(vec![virtual_point_lights_at(scene, s, 0.5)?]);
    }
    passes
        .iter()
        .enumerate()
        .map(|(p, pass)| {
            let v = VplSettings { seed: pass_vpl_seed(s.seed, p as u32), ..*s };
            virtual_point_lights_at(scene, &v, pass.time)
        })
        .collect()
}

/// The photon seed of pass `pass` of a moving scene: independent photons per pass, so the passes
/// average the VPLs' noise as well as the blur.
pub fn pass_vpl_seed(seed: u64, pass: u32) -> u64 {
    seed ^ (pass as u64 + 1).wrapping_mul(0x9e37_79b9_7f4a_7c15)
}

/// The image of an interleaved frame (module docs): every pass of `passes` rendered by [`render`] on
/// its own G-buffer with its VPL set (`vpl_sets[p]`, or the only one), accumulated with weight `1/P`
/// in pass order as the GPU adds them.
pub fn render_frame(
    scene: &Scene,
    (width, height): (u32, u32),
    passes: &[PassSample],
    vpl_sets: &[Vec<VirtualPointLight>],
    s: &InterleavedSettings,
) -> Result<LinearImage> {
    let weight = 1.0 / passes.len().max(1) as f32;
    let mut sum = LinearImage::new(width, height);
    for (p, sample) in passes.iter().enumerate() {
        let gs = render_gbuffer_at(scene, width, height, sample)?;
        let vpls = vpl_sets.get(p).or(vpl_sets.last()).map_or(&[][..], |v| &v[..]);
        let image = render(&gs, vpls, s)?;
        for (acc, v) in sum.pixels.iter_mut().zip(&image.pixels) {
            for c in 0..4 {
                acc[c] += weight * v[c];
            }
        }
    }
    Ok(sum)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #![proptest_config(ProptestConfig { failure_persistence: None, ..ProptestConfig::with_cases(256) })]
        /// Splitting is a permutation that puts texel (x, y) in sub-buffer (x mod n, y mod m) at
        /// (x / n, y / m); the two-pass split gives the same buffer as the one-pass split for any
        /// block, and gathering undoes either.
        #[test]
        fn two_pass_split_is_the_one_pass_split(
            w in 1u32..70, h in 1u32..50, n in 1u32..9, m in 1u32..9, bx in 1u32..5, by in 1u32..5,
        ) {
            let layout = Layout::new(w, h, Pattern { n, m }, (bx, by)).unwrap();
            prop_assert_eq!(layout.width % (bx * n), 0);
            prop_assert!(layout.width >= w && layout.height >= h);
            let src: Vec<u32> = (0..layout.width * layout.height).collect();
            let one = split_one_pass(&layout, &src);
            let two = split_two_pass(&layout, &src);
            prop_assert_eq!(&one, &two);
            let mut seen = one.clone();
            seen.sort_unstable();
            prop_assert_eq!(&seen, &src);
            for (u, &t) in one.iter().enumerate() {
                let (x, y) = (t % layout.width, t / layout.width);
                let (su, sv) = (u as u32 % layout.width, u as u32 / layout.width);
                prop_assert_eq!((su / layout.sub.0, sv / layout.sub.1), (x % n, y % m));
                prop_assert_eq!((su % layout.sub.0, sv % layout.sub.1), (x / n, y / m));
                prop_assert_eq!(layout.sub_buffer(x, y), (sv / layout.sub.1) * n + su / layout.sub.0);
                prop_assert_eq!(layout.unsplit(su, sv), (x, y));
            }
            prop_assert_eq!(&gather_one_pass(&layout, &one), &src);
            prop_assert_eq!(&gather_two_pass(&layout, &two), &src);
        }

        /// Without flags the blur is the plain separable Gaussian (bilinear pairs included: the same
        /// weights), it keeps constants, and a flag never lets light cross its edge.
        #[test]
        fn the_blur_is_gaussian_and_stops_at_edges(
            w in 3u32..24, h in 3u32..16, r in 1u32..6, edge in 1u32..22, bilinear in any::<bool>(), axis in any::<bool>(),
        ) {
            let edges = if axis { Edges::Axis } else { Edges::Texel };
            let edge = edge % (w - 1);
            let values: Vec<Vec3> = (0..w * h).map(|i| Vec3::splat(((i * 7919) % 13) as f32)).collect();
            let none = vec![0u8; (w * h) as usize];
            let plain = blur(&values, &none, w, h, &Blur { radius: r, bilinear: false, edges });
            let pairs = blur(&values, &none, w, h, &Blur { radius: r, bilinear, edges });
            for (a, b) in plain.iter().zip(&pairs) {
                prop_assert!((*a - *b).abs().max_element() < 1e-4, "{a} {b}");
            }
            let ones = vec![Vec3::ONE; (w * h) as usize];
            for v in blur(&ones, &none, w, h, &Blur { radius: r, bilinear, edges }) {
                prop_assert!((v - Vec3::ONE).abs().max_element() < 1e-5);
            }
            // A wall of flags at column `edge`: light left of it stays left, right of it right.
            let flags: Vec<u8> = (0..w * h).map(|i| if i % w == edge { DIFFERS_X | DIFFERS_XY } else { 0 }).collect();
            let left: Vec<Vec3> = (0..w * h).map(|i| if i % w <= edge { Vec3::ONE } else { Vec3::ZERO }).collect();
            let out = blur(&left, &flags, w, h, &Blur { radius: r, bilinear, edges });
            for (i, v) in out.iter().enumerate() {
                let expected = if i as u32 % w <= edge { 1.0 } else { 0.0 };
                prop_assert!((v.x - expected).abs() < 1e-5, "texel {} of {}: {}", i as u32 % w, w, v.x);
            }
            // Without edges it leaks.
            let leaky = blur(&left, &flags, w, h, &Blur { radius: r, bilinear, edges: Edges::Ignore });
            prop_assert!(leaky[(edge + 1) as usize].x > 0.0);
        }
    }

    /// On the built-in `cornell` (80×60, 256 photons clamped at 0.1, VPL shadow rays), against the brute
    /// force (every texel gathering every VPL): the block size of the split changes nothing;
    /// unfiltered interleaving keeps the image's mean (each subset stands for all VPLs) but is noisy;
    /// the paper's edge-aware filter beats the plain Gaussian in FLIP but leaves the texels along edges
    /// unfiltered; stopping per axis filters them too and beats both beside discontinuities.
    #[test]
    fn the_edge_aware_filter_comes_closest_to_brute_force() {
        let scene = crate::scene::builtin::builtin_scene("cornell").unwrap().unwrap();
        let vpls = crate::reference::virtual_point_lights(
            &scene,
            &crate::reference::VplSettings { count: 256, clamp: 0.0, seed: 1 },
        )
        .unwrap();
        let gs = crate::reference::gbuffer::render_gbuffer(&scene, 80, 60).unwrap();
        let settings = |pattern: &str, blur: Option<Blur>, block: (u32, u32)| InterleavedSettings {
            pattern: pattern.parse().unwrap(),
            block,
            blur,
            discontinuity: Discontinuity::default(),
            clamp: 0.1,
            visibility: true,
        };
        let brute = render(&gs, &vpls, &settings("1x1", None, (1, 1))).unwrap();
        let brute_blocks = render(&gs, &vpls, &settings("1x1", None, (8, 4))).unwrap();
        assert_eq!(brute.pixels, brute_blocks.pixels);
        let mean = |img: &LinearImage| img.pixels.iter().map(|p| (p[0] + p[1] + p[2]) as f64).sum::<f64>();
        let full = Blur { radius: 4, bilinear: false, edges: Edges::Texel };
        let none = render(&gs, &vpls, &settings("4x4", None, (2, 2))).unwrap();
        let other_block = render(&gs, &vpls, &settings("4x4", None, (1, 3))).unwrap();
        assert_eq!(none.pixels, other_block.pixels);
        let plain = render(&gs, &vpls, &settings("4x4", Some(Blur { edges: Edges::Ignore, ..full }), (2, 2)))
            .unwrap();
        let axis =
            render(&gs, &vpls, &settings("4x4", Some(Blur { edges: Edges::Axis, ..full }), (2, 2))).unwrap();
        let edges = render(&gs, &vpls, &settings("4x4", Some(full), (2, 2))).unwrap();
        let pairs =
            render(&gs, &vpls, &settings("4x4", Some(Blur { bilinear: true, ..full }), (2, 2))).unwrap();
        let m = |img: &LinearImage| crate::metrics::compare(&brute, img).unwrap();
        let (m_none, m_plain, m_edges, m_pairs) = (m(&none), m(&plain), m(&edges), m(&pairs));
        println!(
            "against brute force: none RMSE {:.4} FLIP {:.4}; plain {:.4} {:.4}; edge-aware {:.4} {:.4}; bilinear {:.4} {:.4}",
            m_none.rmse, m_none.flip, m_plain.rmse, m_plain.flip, m_edges.rmse, m_edges.flip, m_pairs.rmse, m_pairs.flip
        );
        assert!((mean(&none) / mean(&brute) - 1.0).abs() < 0.03, "{} against {}", mean(&none), mean(&brute));
        assert!(m_edges.rmse < 0.7 * m_none.rmse && m_pairs.rmse < 0.7 * m_none.rmse);
        assert!(m_edges.flip < m_plain.flip && m_edges.flip < m_none.flip && m_pairs.flip < m_plain.flip);
        // Where the leaks are: the texels beside a discontinuity (flagged, or the positive neighbour of
        // one). The plain Gaussian smooths the noise of flat regions as well, but carries light across
        // edges.
        let flags = discontinuities(&gs.gbuffer, &Discontinuity::default());
        let beside = |x: u32, y: u32| {
            let f = |x: u32, y: u32| flags[(y * 80 + x) as usize] != 0;
            f(x, y) || (x > 0 && f(x - 1, y)) || (y > 0 && f(x, y - 1)) || (x > 0 && y > 0 && f(x - 1, y - 1))
        };
        let edge_rmse = |img: &LinearImage| {
            let (mut sum, mut n) = (0.0f64, 0usize);
            for y in 0..60 {
                for x in 0..80 {
                    if beside(x, y) {
                        let (a, b) = (brute.get(x, y), img.get(x, y));
                        sum += (0..3).map(|c| ((a[c] - b[c]) as f64).powi(2)).sum::<f64>() / 3.0;
                        n += 1;
                    }
                }
            }
            (sum / n as f64).sqrt()
        };
        let (e_plain, e_edges, e_axis) = (edge_rmse(&plain), edge_rmse(&edges), edge_rmse(&axis));
        let m_axis = m(&axis);
        println!(
            "beside discontinuities: plain RMSE {e_plain:.4}, paper's {e_edges:.4}, per axis {e_axis:.4}; per axis overall RMSE {:.4} FLIP {:.4}",
            m_axis.rmse, m_axis.flip
        );
        assert!(e_axis < e_edges && e_axis < e_plain, "{e_axis} against {e_edges} and {e_plain}");
        assert!(m_axis.rmse < m_plain.rmse && m_axis.flip < m_plain.flip);
    }

    #[test]
    fn patterns_parse_and_refuse() {
        assert_eq!("8x6".parse::<Pattern>().unwrap(), Pattern { n: 8, m: 6 });
        for bad in ["8", "0x4", "4x17", "ax4", "4x4x4"] {
            assert!(bad.parse::<Pattern>().is_err(), "{bad}");
        }
    }

    #[test]
    fn filters_parse_and_refuse() {
        assert_eq!(Edges::of_filter("none").unwrap(), None);
        assert_eq!(Edges::of_filter("full").unwrap(), Some(Edges::Texel));
        assert_eq!(Edges::of_filter("plain").unwrap(), Some(Edges::Ignore));
        assert_eq!(Edges::of_filter("axis").unwrap(), Some(Edges::Axis));
        let e = Edges::of_filter("gauss").unwrap_err().to_string();
        assert!(e.contains("none, plain, full or axis"), "{e}");
    }
}
