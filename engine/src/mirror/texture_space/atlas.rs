//! Where an object's shading lives (Andersson et al. 2014, §3.1 and §3.1.3): its shading space — a
//! unique parameterisation of its surface — and the shading texture, a mip hierarchy laid out by hand
//! in one image, because a draw cannot choose the mip level it renders into per triangle.
//!
//! **Shading space.** An object's own uvs serve when no two triangles overlap in the uv plane
//! ([`shading_space_of`]), mapped from their bounding box onto the unit square (the shading texture
//! never wraps, so uvs past 1 — Spot's few, a texture tiled twice — are fine as long as they are
//! unique). A few overlapping triangles are tolerated ([`MAX_OVERLAPPING_FRACTION`] of them: Spot's
//! uvs fold over on 4 of its 5856 triangles, a flipped sliver) — their texels are shared, so each
//! may show the other's shading where they overlap, and the shading space says how many. Otherwise
//! (no uvs, many overlapping or degenerate uv triangles: mirrored halves, a tile repeated by reusing
//! its uvs) [`triangle_charts`] generates one chart per triangle: each triangle laid flat with its true shape
//! in its own cell of a square grid, with a gutter around it. Simple, and wasteful where triangles
//! differ much in size (every chart gets the same cell); a packer of triangle pairs or of larger
//! charts would shade fewer empty texels.
//!
//! **The mip atlas** ([`MipAtlas`]): level 0, `N × N`, at the left; levels 1, 2, … stacked in a
//! column to its right, each followed by a gutter so that a bilinear lookup near a level's edge never
//! reads the next one. A triangle renders into level k by scaling its shading coordinates by `N/2ᵏ`
//! and offsetting them by the level's corner ([`MipAtlas::transform`]).

use glam::{Vec2, Vec3};

use crate::error::{Error, Result};
use crate::scene::Mesh;

/// One object's shading texture layout.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MipAtlas {
    finest: u32,
    gutter: u32,
}

impl MipAtlas {
    /// A finest level of `finest × finest` texels (a power of two) and `gutter` texels between levels.
    pub fn new(finest: u32, gutter: u32) -> Result<Self> {
        if !finest.is_power_of_two() {
            return Err(Error::Limit {
                what: "shading texture size",
                value: finest.to_string(),
                limit: "a power of two".into(),
            });
        }
        Ok(MipAtlas { finest, gutter })
    }

    /// Level 0's side, texels.
    pub fn finest(&self) -> u32 {
        self.finest
    }

    /// Texels between levels.
    pub fn gutter(&self) -> u32 {
        self.gutter
    }

    /// Levels down to 1 × 1.
    pub fn levels(&self) -> u32 {
        self.finest.trailing_zeros() + 1
    }

    /// Level `level`'s rectangle `[x, y, side, side]` in texels.
    pub fn level_rect(&self, level: u32) -> [u32; 4] {
        let side = self.finest >> level;
        if level == 0 {
            return [0, 0, side, side];
        }
        let y: u32 = (1..level).map(|k| (self.finest >> k) + self.gutter).sum();
        [self.finest + self.gutter, y, side, side]
    }

    /// The whole image, `(width, height)` texels.
    pub fn size(&self) -> (u32, u32) {
        let last = self.level_rect(self.levels() - 1);
        let column = if self.levels() > 1 { last[1] + last[3] } else { 0 };
        let width =
            if self.levels() > 1 { self.finest + self.gutter + (self.finest >> 1) } else { self.finest };
        (width, self.finest.max(column))
    }

    /// Texels of the whole image times `bytes_per_texel`.
    pub fn bytes(&self, bytes_per_texel: u64) -> u64 {
        let (w, h) = self.size();
        w as u64 * h as u64 * bytes_per_texel
    }

    /// Shading coordinates `T ∈ [0, 1]²` to atlas texel coordinates in level `level`: `T·scale + offset`.
    pub fn transform(&self, level: u32) -> (Vec2, Vec2) {
        let [x, y, side, _] = self.level_rect(level);
        (Vec2::splat(side as f32), Vec2::new(x as f32, y as f32))
    }
}

/// Why an object's own uvs cannot be its shading space.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ChartReason {
    NoUvs,
    /// Triangles whose uv triangle has no area, or overlaps another's.
    Overlapping(usize),
}

/// An object's shading space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ShadingSpace {
    /// Its own uvs, no two triangles overlapping, mapped from their bounding box `[lo, hi]` onto the
    /// unit square ([`ShadingSpace::to_unit`]).
    OwnUvs { lo: Vec2, hi: Vec2, overlapping: usize },
    /// Generated per-triangle charts ([`triangle_charts`]), and why.
    Charts(ChartReason),
}

impl ShadingSpace {
    /// A uv of the object in the unit square of its shading space (own uvs only; charts are made there).
    pub fn to_unit(&self, uv: Vec2) -> Vec2 {
        match *self {
            ShadingSpace::OwnUvs { lo, hi, .. } => (uv - lo) / (hi - lo).max(Vec2::splat(f32::MIN_POSITIVE)),
            ShadingSpace::Charts(_) => uv,
        }
    }
}

impl std::fmt::Display for ShadingSpace {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ShadingSpace::OwnUvs { lo, hi, overlapping: 0 } => {
                write!(f, "its uvs (unique; [{lo}, {hi}] onto the unit square)")
            }
            ShadingSpace::OwnUvs { lo, hi, overlapping } => write!(
                f,
                "its uvs ([{lo}, {hi}] onto the unit square; {overlapping} triangles overlap others and share texels)"
            ),
            ShadingSpace::Charts(ChartReason::NoUvs) => f.write_str("generated per-triangle charts (no uvs)"),
            ShadingSpace::Charts(ChartReason::Overlapping(n)) => {
                write!(
                    f,
                    "generated per-triangle charts ({n} triangles overlap others in uv or have no uv area)"
                )
            }
        }
    }
}

/// The largest fraction of an object's triangles that may overlap others in uv for its uvs to stay its
/// shading space (0.1 %).
pub const MAX_OVERLAPPING_FRACTION: f64 = 1e-3;

/// The uv triangles of `mesh` (empty without uvs).
fn uv_triangles(mesh: &Mesh) -> Vec<[Vec2; 3]> {
    if mesh.uvs.is_empty() {
        return vec![];
    }
    mesh.indices.chunks_exact(3).map(|t| [0, 1, 2].map(|k| mesh.uvs[t[k] as usize])).collect()
}

/// Whether `mesh`'s uvs can be its shading space, and if not why.
pub fn shading_space_of(mesh: &Mesh) -> ShadingSpace {
    let tris = uv_triangles(mesh);
    if tris.is_empty() {
        return ShadingSpace::Charts(ChartReason::NoUvs);
    }
    let overlapping = uv_overlaps(&tris);
    if overlapping as f64 > MAX_OVERLAPPING_FRACTION * tris.len() as f64 {
        return ShadingSpace::Charts(ChartReason::Overlapping(overlapping));
    }
    let (lo, hi) = bounds(&tris);
    ShadingSpace::OwnUvs { lo, hi, overlapping }
}

/// The bounding box of 2D triangles.
fn bounds(tris: &[[Vec2; 3]]) -> (Vec2, Vec2) {
    tris.iter()
        .flatten()
        .fold((Vec2::splat(f32::INFINITY), Vec2::splat(f32::NEG_INFINITY)), |(l, h), &p| (l.min(p), h.max(p)))
}

/// Signed area ×2 of a 2D triangle.
fn area2(t: &[Vec2; 3]) -> f32 {
    (t[1] - t[0]).perp_dot(t[2] - t[0])
}

/// Whether the interiors of two 2D triangles overlap by more than `eps` along every separating axis
/// candidate (their edge normals): triangles sharing an edge or a vertex, or touching, do not.
fn interiors_overlap(a: &[Vec2; 3], b: &[Vec2; 3], eps: f32) -> bool {
    for t in [a, b] {
        for i in 0..3 {
            let axis = (t[(i + 1) % 3] - t[i]).perp();
            let project = |u: &[Vec2; 3]| {
                u.iter()
                    .map(|&p| axis.dot(p))
                    .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), d| (lo.min(d), hi.max(d)))
            };
            let ((a0, a1), (b0, b1)) = (project(a), project(b));
            let overlap = a1.min(b1) - a0.max(b0);
            if overlap <= eps * axis.length() {
                return false;
            }
        }
    }
    true
}

/// How many of `tris` (uv triangles) have no area or overlap another's interior, by a uniform grid
/// over their bounding boxes.
pub fn uv_overlaps(tris: &[[Vec2; 3]]) -> usize {
    if tris.is_empty() {
        return 0;
    }
    let (lo, hi) = bounds(tris);
    let extent = (hi - lo).max_element().max(1e-12);
    // Overlap tolerance: a millionth of the uv extent (rounding of shared edges).
    let eps = 1e-6 * extent;
    let mut bad = vec![false; tris.len()];
    for (i, t) in tris.iter().enumerate() {
        if area2(t).abs() <= eps * eps {
            bad[i] = true;
        }
    }
    // About one triangle per cell.
    let cells = (tris.len() as f32).sqrt().ceil().clamp(1.0, 1024.0) as usize;
    let cell_of = |p: Vec2| {
        let c = ((p - lo) / extent * cells as f32).floor();
        (c.x.clamp(0.0, (cells - 1) as f32) as usize, c.y.clamp(0.0, (cells - 1) as f32) as usize)
    };
    let mut grid: Vec<Vec<u32>> = vec![vec![]; cells * cells];
    for (i, t) in tris.iter().enumerate() {
        let (l, h) = t.iter().fold((t[0], t[0]), |(l, h), &p| (l.min(p), h.max(p)));
        let ((x0, y0), (x1, y1)) = (cell_of(l), cell_of(h));
        for y in y0..=y1 {
            for x in x0..=x1 {
                grid[y * cells + x].push(i as u32);
            }
        }
    }
    for cell in &grid {
        for (k, &i) in cell.iter().enumerate() {
            for &j in &cell[k + 1..] {
                let (i, j) = (i as usize, j as usize);
                if bad[i] && bad[j] {
                    continue;
                }
                if interiors_overlap(&tris[i], &tris[j], eps) {
                    bad[i] = true;
                    bad[j] = true;
                }
            }
        }
    }
    bad.iter().filter(|&&b| b).count()
}

/// Generated per-triangle charts: three shading coordinates per triangle (in index order), in the
/// unit square, each triangle alone in a cell of a `cells × cells` grid.
#[derive(Clone, Debug, PartialEq)]
pub struct Charts {
    pub uvs: Vec<Vec2>,
    pub cells: u32,
}

/// One chart per triangle of `mesh` for a finest level of `finest` texels with `gutter` texels kept
/// free around every chart inside its cell: the triangle with its true shape (longest edge along
/// the cell's bottom), scaled uniformly to fill the rest of the cell. A triangle without area gets a
/// point at its cell's centre.
pub fn triangle_charts(mesh: &Mesh, finest: u32, gutter: u32) -> Result<Charts> {
    let n = mesh.indices.len() / 3;
    let cells = (n as f64).sqrt().ceil().max(1.0) as u32;
    let cell = 1.0 / cells as f32;
    let margin = gutter as f32 / finest as f32;
    let inner = cell - 2.0 * margin;
    if inner <= 0.0 {
        return Err(Error::Limit {
            what: "shading texture size",
            value: format!("{finest} texels for {n} per-triangle charts with {gutter}-texel gutters"),
            limit: format!("more than {} texels per side", 2 * gutter * cells),
        });
    }
    let mut uvs = Vec::with_capacity(3 * n);
    for (k, t) in mesh.indices.chunks_exact(3).enumerate() {
        let origin =
            Vec2::new((k as u32 % cells) as f32, (k as u32 / cells) as f32) * cell + Vec2::splat(margin);
        let p: [Vec3; 3] = [0, 1, 2].map(|i| mesh.positions[t[i] as usize]);
        uvs.extend(lay_flat(p).map(|q| origin + q * inner));
    }
    Ok(Charts { uvs, cells })
}

/// A 3D triangle laid flat in the unit square: its longest edge along the bottom, the opposite vertex
/// above it, scaled uniformly so that the shape fits; the corners in the input order.
fn lay_flat(p: [Vec3; 3]) -> [Vec2; 3] {
    // The longest edge i → i + 1.
    let i = (0..3).max_by(|&a, &b| {
        let len = |k: usize| (p[(k + 1) % 3] - p[k]).length_squared();
        len(a).total_cmp(&len(b))
    });
    let i = i.unwrap_or(0);
    let (a, b, c) = (p[i], p[(i + 1) % 3], p[(i + 2) % 3]);
    let base = b - a;
    let len = base.length();
    let area2 = base.cross(c - a).length();
    let flat = len > 0.0 && area2 > 0.0 && len.is_finite();
    if !flat {
        return [Vec2::splat(0.5); 3];
    }
    let x_axis = base / len;
    let cx = (c - a).dot(x_axis);
    let cy = area2 / len;
    // In [0, len] × [0, cy] since the base is the longest edge (cx ∈ [0, len]).
    let scale = 1.0 / len.max(cy);
    let flat = [Vec2::ZERO, Vec2::new(len, 0.0) * scale, Vec2::new(cx, cy) * scale];
    let mut out = [Vec2::ZERO; 3];
    out[i] = flat[0];
    out[(i + 1) % 3] = flat[1];
    out[(i + 2) % 3] = flat[2];
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Pcg32;
    use crate::scene::builtin::builtin_mesh;

    #[test]
    fn levels_are_disjoint_inside_the_image_and_a_gutter_apart() {
        for (finest, gutter) in [(1u32, 0u32), (2, 1), (64, 2), (2048, 4)] {
            let atlas = MipAtlas::new(finest, gutter).unwrap();
            let (w, h) = atlas.size();
            let rects: Vec<[u32; 4]> = (0..atlas.levels()).map(|l| atlas.level_rect(l)).collect();
            assert_eq!(rects.last().unwrap()[2], 1, "down to 1×1");
            for (l, r) in rects.iter().enumerate() {
                assert_eq!(r[2], finest >> l);
                assert!(r[0] + r[2] <= w && r[1] + r[3] <= h, "{finest}/{gutter} level {l} {r:?} in {w}×{h}");
                for s in &rects[l + 1..] {
                    // Separated by at least the gutter along x or y.
                    let apart_x = r[0] + r[2] + gutter <= s[0] || s[0] + s[2] + gutter <= r[0];
                    let apart_y = r[1] + r[3] + gutter <= s[1] || s[1] + s[3] + gutter <= r[1];
                    assert!(apart_x || apart_y, "{finest}/{gutter}: {r:?} and {s:?}");
                }
            }
            let (scale, offset) = atlas.transform(1.min(atlas.levels() - 1));
            let r = atlas.level_rect(1.min(atlas.levels() - 1));
            assert_eq!(offset, Vec2::new(r[0] as f32, r[1] as f32));
            assert_eq!(offset + scale, Vec2::new((r[0] + r[2]) as f32, (r[1] + r[3]) as f32));
        }
        // The paper's 2048² finest level with 4-texel gutters: 3076 × 2087 texels (the column of
        // levels 1.. and their gutters is 2047 + 40 high), 25.7 MB at RGBA8.
        let atlas = MipAtlas::new(2048, 4).unwrap();
        assert_eq!(atlas.size(), (2048 + 4 + 1024, 2047 + 40));
        assert!(MipAtlas::new(1000, 2).is_err());
    }

    fn mesh(uvs: Vec<Vec2>, triangles: usize) -> Mesh {
        // Positions: any non-degenerate triangles (their shape is irrelevant to the uv checks).
        let mut positions = vec![];
        for k in 0..triangles {
            let o = Vec3::new(k as f32, 0.0, 0.0);
            positions.extend([o, o + Vec3::X, o + Vec3::Y]);
        }
        let indices = (0..3 * triangles as u32).collect();
        Mesh::new("test", positions, vec![], uvs, indices).unwrap()
    }

    #[test]
    fn overlaps_are_found_and_shared_edges_are_not_overlaps() {
        // Two triangles of a unit square sharing the diagonal: unique.
        let quad = vec![
            Vec2::new(0.0, 0.0),
            Vec2::new(1.0, 0.0),
            Vec2::new(1.0, 1.0),
            Vec2::new(0.0, 0.0),
            Vec2::new(1.0, 1.0),
            Vec2::new(0.0, 1.0),
        ];
        let unit = ShadingSpace::OwnUvs { lo: Vec2::ZERO, hi: Vec2::ONE, overlapping: 0 };
        assert_eq!(shading_space_of(&mesh(quad.clone(), 2)), unit);
        // Mirrored: the second triangle reuses the first's uvs.
        let mirrored: Vec<Vec2> = quad[..3].iter().chain(&quad[..3]).copied().collect();
        assert_eq!(shading_space_of(&mesh(mirrored, 2)), ShadingSpace::Charts(ChartReason::Overlapping(2)));
        // Past the unit square but unique: mapped back onto it.
        let wide: Vec<Vec2> = quad.iter().map(|&p| p * 2.0 - Vec2::ONE).collect();
        let space = shading_space_of(&mesh(wide, 2));
        assert_eq!(space, ShadingSpace::OwnUvs { lo: -Vec2::ONE, hi: Vec2::ONE, overlapping: 0 });
        assert_eq!(space.to_unit(Vec2::ZERO), Vec2::splat(0.5));
        assert_eq!(shading_space_of(&mesh(vec![], 2)), ShadingSpace::Charts(ChartReason::NoUvs));
        // A grid of many small disjoint triangles, plus one laid across a few of them.
        let mut rng = Pcg32::new(5, 5);
        let mut tris = vec![];
        let n = 40;
        for y in 0..n {
            for x in 0..n {
                let o = Vec2::new(x as f32, y as f32) / n as f32;
                let j = Vec2::new(rng.next_f32(), rng.next_f32()) * 0.1 / n as f32;
                tris.push([o + j, o + Vec2::new(0.8, 0.0) / n as f32, o + Vec2::new(0.0, 0.8) / n as f32]);
            }
        }
        assert_eq!(uv_overlaps(&tris), 0);
        tris.push([Vec2::new(0.1, 0.1), Vec2::new(0.3, 0.1), Vec2::new(0.1, 0.3)]);
        let bad = uv_overlaps(&tris);
        assert!(bad > 5, "{bad}");
    }

    /// The built-in meshes with uvs: which ones are their own shading space.
    #[test]
    fn builtin_shading_spaces() {
        let spot = builtin_mesh("spot", None).unwrap().unwrap();
        let space = shading_space_of(&spot);
        println!("spot: {space}");
        // A flipped sliver (triangle 4413) folds over three neighbours: 4 of 5856 triangles.
        assert!(matches!(space, ShadingSpace::OwnUvs { overlapping: 4, .. }), "{space:?}");
        let sphere = builtin_mesh("sphere", None).unwrap().unwrap();
        println!("sphere: {}", shading_space_of(&sphere));
    }

    /// Every chart lies in its own cell, a gutter from its edges, with the triangle's shape.
    #[test]
    fn charts_keep_shapes_and_gutters() {
        let spot = builtin_mesh("spot", None).unwrap().unwrap();
        let (finest, gutter) = (4096, 2);
        let charts = triangle_charts(&spot, finest, gutter).unwrap();
        let n = spot.indices.len() / 3;
        assert_eq!(charts.uvs.len(), 3 * n);
        let cell = 1.0 / charts.cells as f32;
        let margin = gutter as f32 / finest as f32;
        let tris: Vec<[Vec2; 3]> = charts.uvs.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
        for (k, t) in tris.iter().enumerate() {
            let lo = Vec2::new((k as u32 % charts.cells) as f32, (k as u32 / charts.cells) as f32) * cell;
            for &p in t {
                assert!(p.cmpge(lo + Vec2::splat(margin * 0.999)).all(), "chart {k} {p} below {lo}");
                assert!(p.cmple(lo + Vec2::splat(cell - margin * 0.999)).all(), "chart {k} {p}");
            }
            // Same shape: side ratios of the flat and 3D triangles agree.
            let tri = &spot.indices[3 * k..3 * k + 3];
            let p3: [Vec3; 3] = [0, 1, 2].map(|i| spot.positions[tri[i] as usize]);
            let l3 = [0, 1, 2].map(|i| (p3[(i + 1) % 3] - p3[i]).length());
            let l2 = [0, 1, 2].map(|i| (t[(i + 1) % 3] - t[i]).length());
            for i in 0..3 {
                let (r3, r2) = (l3[i] / l3[(i + 1) % 3], l2[i] / l2[(i + 1) % 3]);
                assert!((r3 - r2).abs() < 1e-3 * r3.max(1.0), "chart {k}: {l3:?} vs {l2:?}");
            }
        }
        assert_eq!(uv_overlaps(&tris), 0, "charts never overlap");
        assert!(triangle_charts(&spot, 64, 2).is_err(), "too small an atlas for so many charts is an error");
    }
}
