//! Triangle meshes: indexed positions, smooth normals and optional UVs, cleaned on construction.

use std::path::Path;

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
        // Given normals are directions of any finite length: normalised in f64, where neither 3e38
        // (whose f32 length overflows, so `normalize` made it 0 and the GPU shaded it black while the
        // reference fell back to the face) nor 1e-30 loses them. A zero or non-finite one takes the
        // vertex's area-weighted face normal, as a mesh without normals has everywhere.
        let normals = if normals.is_empty() {
            smooth_normals(&positions, &kept)
        } else {
            let unit: Vec<Option<Vec3>> = normals
                .iter()
                .map(|n| {
                    let d = n.as_dvec3();
                    let len = d.length();
                    (n.is_finite() && len > 0.0).then(|| (d / len).as_vec3())
                })
                .collect();
            let smooth = unit.iter().any(Option::is_none).then(|| smooth_normals(&positions, &kept));
            unit.iter()
                .enumerate()
                .map(|(i, n)| n.unwrap_or_else(|| smooth.as_ref().expect("computed when one is missing")[i]))
                .collect()
        };
        Ok(Mesh { positions, normals, uvs, indices: kept, stats })
    }

    /// Bytes its arrays hold (what a scene's load adds up against [`crate::limits::memory_limit`]).
    pub fn heap_bytes(&self) -> u64 {
        (self.positions.len() * 12 + self.normals.len() * 12 + self.uvs.len() * 8 + self.indices.len() * 4)
            as u64
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

    /// A reduced copy keeping about `fraction` of the triangles (in (0, 1]; 1 returns the mesh
    /// unchanged), for studies of time against geometric detail (`simplify` in scene files).
    ///
    /// Edge collapses by meshoptimizer's simplifier (`meshopt_simplifyWithAttributes`): the triangle
    /// count is the target, and the error bound is meshoptimizer's own measure (quadric distance relative
    /// to the mesh's extent, with normals and uvs weighed in), left at 1 so that it does not stop the
    /// reduction early; the simplifier may still stop above the target where collapses would break the
    /// topology. Collapses only remove vertices, so every kept vertex keeps its position, normal and uv
    /// (the result lies within the original's bounds and stays textured the same way, uv seams
    /// included). Unreferenced vertices are then dropped (kept in order of first use) and the result is
    /// rebuilt through [`Mesh::new`], so it is cleaned like any other mesh; `stats` adds the triangles
    /// it skips to those the original skipped. Deterministic.
    pub fn simplified(&self, fraction: f32) -> Result<Mesh> {
        if !(fraction > 0.0 && fraction <= 1.0) {
            return Err(Error::scene(
                "mesh simplification",
                format!("fraction {fraction} is out of range: must be in (0, 1]"),
            ));
        }
        if fraction == 1.0 || self.indices.is_empty() {
            return Ok(self.clone());
        }
        let n = self.positions.len();
        // The fields are public: check what Mesh::new guarantees before handing them to C++.
        if let Some(&bad) = self.indices.iter().find(|&&i| i as usize >= n) {
            return Err(Error::scene(
                "mesh simplification",
                format!("index {bad} out of range ({n} vertices)"),
            ));
        }
        let has_normals = self.normals.len() == n;
        let has_uvs = self.uvs.len() == n;
        let target_triangles = ((self.triangle_count() as f64 * fraction as f64).round() as usize).max(1);
        let positions: Vec<[f32; 3]> = self.positions.iter().map(|p| p.to_array()).collect();
        let vertices = meshopt::VertexDataAdapter::new(bytemuck::cast_slice(&positions), 12, 0)
            .map_err(|e| Error::scene("mesh simplification", e.to_string()))?;
        // Per-vertex attributes weighed into the collapse cost (relative to positions, which the
        // simplifier measures relative to the mesh's extent): the normal, then the uv.
        let mut weights = vec![];
        if has_normals {
            weights.extend([0.5; 3]);
        }
        if has_uvs {
            weights.extend([1.0; 2]);
        }
        let stride = weights.len();
        let mut attributes = Vec::with_capacity(n * stride);
        for i in 0..n {
            if has_normals {
                attributes.extend_from_slice(&self.normals[i].to_array());
            }
            if has_uvs {
                attributes.extend_from_slice(&self.uvs[i].to_array());
            }
        }
        let indices = meshopt::simplify::simplify_with_attributes_and_locks(
            &self.indices,
            &vertices,
            &attributes,
            &weights,
            stride * std::mem::size_of::<f32>(),
            &vec![false; n],
            target_triangles * 3,
            1.0,
            meshopt::SimplifyOptions::None,
            None,
        );
        // Compact: new vertex numbers in order of first use.
        let mut remap = vec![u32::MAX; self.positions.len()];
        let (mut positions, mut normals, mut uvs) = (vec![], vec![], vec![]);
        let indices: Vec<u32> = indices
            .iter()
            .map(|&i| {
                let i = i as usize;
                if remap[i] == u32::MAX {
                    remap[i] = positions.len() as u32;
                    positions.push(self.positions[i]);
                    if has_normals {
                        normals.push(self.normals[i]);
                    }
                    if has_uvs {
                        uvs.push(self.uvs[i]);
                    }
                }
                remap[i]
            })
            .collect();
        let mut mesh = Mesh::new("simplified mesh", positions, normals, uvs, indices)?;
        mesh.stats.skipped_degenerate += self.stats.skipped_degenerate;
        Ok(mesh)
    }
}

/// Loads a Wavefront OBJ file as one mesh (all its groups merged). See [`parse_obj`].
pub fn load_obj(path: &Path, normalize: bool) -> Result<Mesh> {
    let bytes = crate::limits::read_capped(
        path,
        crate::limits::MAX_OBJ_FILE_BYTES,
        "OBJ file",
        "MAX_OBJ_FILE_BYTES",
    )?;
    parse_obj(&bytes, &path.display().to_string(), normalize)
}

/// Parses OBJ text (faces triangulated as fans, one index per vertex; materials ignored). All groups
/// are merged into one mesh; normals are kept only when every group has them (else smooth normals are
/// computed), uvs only when every group has them. OBJ's v = 0 is the bottom of the image, so uvs are
/// flipped to Vulkan's convention (`uv.y = 1 − v`). `normalize` recentres the mesh on its bounding-box
/// centre and scales it uniformly so the largest half-extent is 1 (it fits in `[-1, 1]³`). `context`
/// names the source in errors; a file without any triangle is an error.
pub fn parse_obj(bytes: &[u8], context: &str, normalize: bool) -> Result<Mesh> {
    let options =
        tobj::LoadOptions { single_index: true, triangulate: true, ignore_points: true, ignore_lines: true };
    let mut reader = std::io::BufReader::new(bytes);
    let (models, _materials) = tobj::load_obj_buf(&mut reader, &options, |_| {
        // Materials are described in the scene file, not in MTL files.
        Ok((Vec::new(), Default::default()))
    })
    .map_err(|e| Error::scene(context, format!("cannot parse OBJ: {e}")))?;
    if models.iter().all(|m| m.mesh.indices.is_empty()) {
        return Err(Error::scene(context, "OBJ contains no faces"));
    }
    let all_normals = models.iter().all(|m| !m.mesh.normals.is_empty());
    let all_uvs = models.iter().all(|m| !m.mesh.texcoords.is_empty());
    let (mut positions, mut normals, mut uvs, mut indices) = (vec![], vec![], vec![], vec![]);
    for model in &models {
        let m = &model.mesh;
        let base = positions.len() as u32;
        let count = m.positions.len() / 3;
        positions.extend(m.positions.chunks_exact(3).map(|p| Vec3::new(p[0], p[1], p[2])));
        if all_normals {
            if m.normals.len() != m.positions.len() {
                return Err(Error::scene(
                    context,
                    format!("group `{}` has a normal count mismatch", model.name),
                ));
            }
            normals.extend(m.normals.chunks_exact(3).map(|n| Vec3::new(n[0], n[1], n[2])));
        }
        if all_uvs {
            if m.texcoords.len() / 2 != count {
                return Err(Error::scene(context, format!("group `{}` has a uv count mismatch", model.name)));
            }
            uvs.extend(m.texcoords.chunks_exact(2).map(|t| Vec2::new(t[0], 1.0 - t[1])));
        }
        indices.extend(m.indices.iter().map(|&i| base + i));
    }
    if normalize {
        if let Some(i) = positions.iter().position(|p| !p.is_finite()) {
            return Err(Error::scene(
                context,
                format!("vertex {i} has a non-finite position {}", positions[i]),
            ));
        }
        let (lo, hi) = positions
            .iter()
            .fold((Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)), |(lo, hi), p| (lo.min(*p), hi.max(*p)));
        // In f64: an extent from −3e38 to 3e38 overflows f32 (it was reported as "zero extent").
        let (lo, hi) = (lo.as_dvec3(), hi.as_dvec3());
        let centre = 0.5 * (lo + hi);
        let half = 0.5 * (hi - lo).max_element();
        if half <= 0.0 {
            return Err(Error::scene(
                context,
                "cannot normalize a mesh of zero extent (all its vertices coincide)",
            ));
        }
        for p in &mut positions {
            *p = ((p.as_dvec3() - centre) / half).as_vec3();
        }
    }
    Mesh::new(context, positions, normals, uvs, indices)
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

    /// Normals of any finite length are directions (3e38 overflowed f32's length and became 0; tiny
    /// ones were replaced); a zero or non-finite normal takes its vertex's face normal, the others stay.
    #[test]
    fn extreme_normals_are_normalised_and_bad_ones_fall_back_to_the_face() {
        let p = vec![Vec3::ZERO, Vec3::X, Vec3::Y];
        let n = vec![Vec3::new(3e38, 0.0, 3e38), Vec3::new(0.0, 1e-30, 0.0), Vec3::ZERO];
        let m = Mesh::new("t", p.clone(), n, vec![], vec![0, 1, 2]).unwrap();
        let h = std::f32::consts::FRAC_1_SQRT_2;
        assert!((m.normals[0] - Vec3::new(h, 0.0, h)).length() < 1e-6, "{}", m.normals[0]);
        assert!((m.normals[1] - Vec3::Y).length() < 1e-6, "{}", m.normals[1]);
        assert!((m.normals[2] - Vec3::Z).length() < 1e-6, "{}", m.normals[2]);
        let n = vec![Vec3::new(f32::NAN, 0.0, 1.0), Vec3::X, Vec3::new(f32::INFINITY, 0.0, 0.0)];
        let m = Mesh::new("t", p, n, vec![], vec![0, 1, 2]).unwrap();
        assert_eq!(m.normals, vec![Vec3::Z, Vec3::X, Vec3::Z]);
    }

    #[test]
    fn non_finite_vertex_is_an_error() {
        let p = vec![Vec3::ZERO, Vec3::new(f32::NAN, 0.0, 0.0), Vec3::Y];
        let e = Mesh::new("bad.obj", p, vec![], vec![], vec![0, 1, 2]).unwrap_err().to_string();
        assert!(e.contains("bad.obj") && e.contains("vertex 1"), "{e}");
        let p = vec![Vec3::ZERO, Vec3::new(0.0, f32::INFINITY, 0.0), Vec3::Y];
        assert!(Mesh::new("x", p, vec![], vec![], vec![0, 1, 2]).is_err());
    }

    fn spot() -> Mesh {
        crate::scene::builtin::builtin_mesh("spot", None).unwrap().unwrap()
    }

    #[test]
    fn simplify_halves_spot_within_its_bounds_and_keeps_uvs() {
        let full = spot();
        assert_eq!(full.triangle_count(), 5856);
        let half = full.simplified(0.5).unwrap();
        let ratio = half.triangle_count() as f64 / full.triangle_count() as f64;
        assert!((0.35..=0.65).contains(&ratio), "{} triangles ({ratio:.3})", half.triangle_count());
        assert!(half.positions.len() < full.positions.len());
        let ((lo, hi), (sl, sh)) = (full.bounds(), half.bounds());
        assert!(sl.cmpge(lo - 1e-6).all() && sh.cmple(hi + 1e-6).all(), "{sl}..{sh} vs {lo}..{hi}");
        // Compacted: every vertex is used; each kept vertex is an original one with its uv and normal.
        let mut used = vec![false; half.positions.len()];
        half.indices.iter().for_each(|&i| used[i as usize] = true);
        assert!(used.iter().all(|&u| u));
        assert!(half.has_uvs() && half.uvs.len() == half.positions.len());
        for i in 0..half.positions.len() {
            let found = (0..full.positions.len()).any(|j| {
                full.positions[j] == half.positions[i]
                    && full.uvs[j] == half.uvs[i]
                    && (full.normals[j] - half.normals[i]).length() < 1e-6 // renormalized by Mesh::new
            });
            assert!(found, "vertex {i} is not an original vertex with its attributes");
        }
        assert_eq!(half.stats.skipped_degenerate, full.stats.skipped_degenerate);
        // Smaller fractions keep fewer triangles.
        let sixteenth = full.simplified(0.0625).unwrap();
        assert!(sixteenth.triangle_count() < half.triangle_count() / 4, "{}", sixteenth.triangle_count());
    }

    #[test]
    fn simplify_one_is_identity_and_simplify_is_deterministic() {
        let full = spot();
        let same = full.simplified(1.0).unwrap();
        assert_eq!(
            (&same.positions, &same.normals, &same.uvs, &same.indices, same.stats),
            (&full.positions, &full.normals, &full.uvs, &full.indices, full.stats)
        );
        let (a, b) = (full.simplified(0.3).unwrap(), full.simplified(0.3).unwrap());
        assert_eq!(
            (&a.positions, &a.normals, &a.uvs, &a.indices),
            (&b.positions, &b.normals, &b.uvs, &b.indices)
        );
        // A mesh without uvs stays without.
        let quad = Mesh::new(
            "quad",
            vec![Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y],
            vec![],
            vec![],
            vec![0, 1, 2, 0, 2, 3],
        )
        .unwrap();
        let q = quad.simplified(0.5).unwrap();
        assert!(!q.has_uvs() && q.normals.len() == q.positions.len());
    }

    #[test]
    fn simplify_rejects_fractions_outside_0_1() {
        let m = Mesh::new("t", vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![], vec![], vec![0, 1, 2]).unwrap();
        for f in [0.0, -1.0, 1.5, f32::NAN, f32::INFINITY] {
            let e = m.simplified(f).unwrap_err().to_string();
            assert!(e.contains("(0, 1]"), "{f}: {e}");
        }
    }

    #[test]
    fn out_of_range_index_is_an_error() {
        let e = Mesh::new("m", vec![Vec3::ZERO; 3], vec![], vec![], vec![0, 1, 7]).unwrap_err();
        assert!(e.to_string().contains("out of range"));
    }

    fn temp_file(tag: &str, contents: &[u8]) -> std::path::PathBuf {
        let path = std::env::temp_dir().join(format!(
            "shutter-mesh-{}-{}-{tag}.obj",
            std::process::id(),
            std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_nanos())
        ));
        std::fs::write(&path, contents).unwrap();
        path
    }

    #[test]
    fn obj_quad_is_triangulated_with_flipped_uvs() {
        let text = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nf 1/1 2/2 3/3 4/4\n";
        let m = parse_obj(text.as_bytes(), "quad.obj", false).unwrap();
        assert_eq!(m.triangle_count(), 2);
        assert!(m.has_uvs());
        // Vertex at y = 0 had v = 0 (bottom of the image) → uv.y = 1 (Vulkan: bottom row).
        let i = m.positions.iter().position(|p| *p == Vec3::ZERO).unwrap();
        assert_eq!(m.uvs[i], Vec2::new(0.0, 1.0));
        assert!(m.normals.iter().all(|n| (*n - Vec3::Z).length() < 1e-6));
    }

    #[test]
    fn obj_normalize_fits_unit_box() {
        let text = "v 10 10 10\nv 14 10 10\nv 10 12 10\nf 1 2 3\n";
        let m = parse_obj(text.as_bytes(), "t.obj", true).unwrap();
        let (lo, hi) = m.bounds();
        assert!((lo - Vec3::new(-1.0, -0.5, 0.0)).length() < 1e-6, "{lo}");
        assert!((hi - Vec3::new(1.0, 0.5, 0.0)).length() < 1e-6, "{hi}");
    }

    #[test]
    fn obj_degenerate_triangles_are_skipped_and_counted() {
        // One good triangle, one zero-area (collinear) and one with a repeated vertex.
        let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 2 0 0\nf 1 2 3\nf 1 2 4\nf 1 1 3\n";
        let path = temp_file("degenerate", text.as_bytes());
        let m = load_obj(&path, false).unwrap();
        let _ = std::fs::remove_file(&path);
        assert_eq!(m.triangle_count(), 1);
        assert_eq!(m.stats.skipped_degenerate, 2);
    }

    #[test]
    fn obj_bad_input_is_an_error_naming_the_file() {
        let path = temp_file("inf", b"v inf 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
        let e = load_obj(&path, false).unwrap_err().to_string();
        assert!(e.contains(&path.display().to_string()) && e.contains("non-finite"), "{e}");
        assert!(load_obj(&path, true).is_err(), "normalize must not hide the inf");
        let _ = std::fs::remove_file(&path);

        let garbage: Vec<u8> = (0..4096u32).map(|i| (i.wrapping_mul(2654435761) >> 13) as u8).collect();
        let path = temp_file("garbage", &garbage);
        let e = load_obj(&path, false).unwrap_err().to_string();
        assert!(e.contains(&path.display().to_string()), "{e}");
        let _ = std::fs::remove_file(&path);

        let missing = std::env::temp_dir().join("shutter-definitely-missing-mesh.obj");
        let e = load_obj(&missing, false).unwrap_err().to_string();
        assert!(e.contains("shutter-definitely-missing-mesh.obj"), "{e}");
        assert!(parse_obj(b"f 1 2 3\n", "oob.obj", false).is_err());
        assert!(parse_obj(b"# nothing\n", "empty.obj", false).is_err());
    }
}
