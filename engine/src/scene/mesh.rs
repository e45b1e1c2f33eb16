//! Triangle meshes: indexed positions, smooth normals and optional UVs, cleaned on construction.

use glam::{Vec2, Vec3};

use crate::error::{Error, Result};

/// What cleaning did to a mesh. Degenerate triangles are skipped and counted, never fatal.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct MeshStats {
    /// Triangles dropped because two of their vertex indices were equal, two positions coincided, or
    /// their area was zero (collinear vertices).
    pub skipped_degenerate: usize,
}

/// An indexed triangle mesh in object space.
#[derive(Clone, Debug, Default)]
pub struct Mesh {
    pub positions: Vec<Vec3>,
    /// Unit vertex normals (computed when the source has none).
    pub normals: Vec<Vec3>,
    /// Per-vertex texture coordinates; empty when the mesh has none.
    pub uvs: Vec<Vec2>,
    pub indices: Vec<u32>,
    pub stats: MeshStats,
}

impl Mesh {
    /// Builds a mesh, validating it: every coordinate finite (NaN/Inf is an error naming the vertex),
    /// indices in range, degenerate triangles skipped and counted. `normals` may be empty: smooth
    /// area-weighted normals are then computed. `context` names the source in error messages.
    pub fn new(
        context: &str,
        positions: Vec<Vec3>,
        normals: Vec<Vec3>,
        uvs: Vec<Vec2>,
        indices: Vec<u32>,
    ) -> Result<Mesh> {
        if !indices.len().is_multiple_of(3) {
            return Err(Error::scene(
                context,
                format!("index count {} is not a multiple of 3", indices.len()),
            ));
        }
        if let Some(i) = positions.iter().position(|p| !p.is_finite()) {
            return Err(Error::scene(
                context,
                format!("vertex {i} has a non-finite position {}", positions[i]),
            ));
        }
        if !normals.is_empty() && normals.len() != positions.len() {
            return Err(Error::scene(context, "normal count differs from position count"));
        }
        if !uvs.is_empty() && uvs.len() != positions.len() {
            return Err(Error::scene(context, "uv count differs from position count"));
        }
        if let Some(i) = uvs.iter().position(|p| !p.is_finite()) {
            return Err(Error::scene(context, format!("vertex {i} has a non-finite uv {}", uvs[i])));
        }
        if let Some(&bad) = indices.iter().find(|&&i| i as usize >= positions.len()) {
            return Err(Error::scene(
                context,
                format!("index {bad} out of range ({} vertices)", positions.len()),
            ));
        }
        let mut kept = Vec::with_capacity(indices.len());
        let mut stats = MeshStats::default();
        for tri in indices.chunks_exact(3) {
            let [a, b, c] = [tri[0], tri[1], tri[2]];
            let (pa, pb, pc) = (positions[a as usize], positions[b as usize], positions[c as usize]);
            let area2 = (pb - pa).cross(pc - pa).length();
            let scale = (pb - pa).length().max((pc - pa).length()).max(f32::MIN_POSITIVE);
            if a == b || b == c || a == c || pa == pb || pb == pc || pa == pc || area2 <= 1e-7 * scale * scale
            {
                stats.skipped_degenerate += 1;
                continue;
            }
            kept.extend_from_slice(tri);
        }
        let normals =
            if normals.is_empty() || normals.iter().any(|n| !n.is_finite() || n.length_squared() < 1e-12) {
                smooth_normals(&positions, &kept)
            } else {
                normals.into_iter().map(|n| n.normalize()).collect()
            };
        Ok(Mesh { positions, normals, uvs, indices: kept, stats })
    }

    pub fn triangle_count(&self) -> usize {
        self.indices.len() / 3
    }

    pub fn has_uvs(&self) -> bool {
        !self.uvs.is_empty()
    }

    /// Object-space axis-aligned bounds (min, max).
    pub fn bounds(&self) -> (Vec3, Vec3) {
        self.positions
            .iter()
            .fold((Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)), |(lo, hi), p| (lo.min(*p), hi.max(*p)))
    }
}

/// Area-weighted vertex normals (a vertex with no non-degenerate triangle gets +Y).
pub fn smooth_normals(positions: &[Vec3], indices: &[u32]) -> Vec<Vec3> {
    let mut n = vec![Vec3::ZERO; positions.len()];
    for tri in indices.chunks_exact(3) {
        let (a, b, c) = (tri[0] as usize, tri[1] as usize, tri[2] as usize);
        let face = (positions[b] - positions[a]).cross(positions[c] - positions[a]);
        n[a] += face;
        n[b] += face;
        n[c] += face;
    }
    n.into_iter().map(|v| v.try_normalize().unwrap_or(Vec3::Y)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn degenerate_triangles_are_skipped_and_counted() {
        let p = vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::X * 2.0, Vec3::ZERO];
        // ok, duplicate index, collinear, coincident positions (0 and 4)
        let idx = vec![0, 1, 2, 0, 0, 1, 0, 1, 3, 0, 4, 1];
        let m = Mesh::new("t", p, vec![], vec![], idx).unwrap();
        assert_eq!(m.triangle_count(), 1);
        assert_eq!(m.stats.skipped_degenerate, 3);
        assert!((m.normals[0] - Vec3::Z).length() < 1e-6);
    }

    #[test]
    fn non_finite_vertex_is_an_error() {
        let p = vec![Vec3::ZERO, Vec3::new(f32::NAN, 0.0, 0.0), Vec3::Y];
        let e = Mesh::new("bad.obj", p, vec![], vec![], vec![0, 1, 2]).unwrap_err().to_string();
        assert!(e.contains("bad.obj") && e.contains("vertex 1"), "{e}");
        let p = vec![Vec3::ZERO, Vec3::new(0.0, f32::INFINITY, 0.0), Vec3::Y];
        assert!(Mesh::new("x", p, vec![], vec![], vec![0, 1, 2]).is_err());
    }

    #[test]
    fn out_of_range_index_is_an_error() {
        let e = Mesh::new("m", vec![Vec3::ZERO; 3], vec![], vec![], vec![0, 1, 7]).unwrap_err();
        assert!(e.to_string().contains("out of range"));
    }
}
