//! Built-in procedural meshes and scenes, embedded in the binary so nothing needs files on disk.
//!
//! Meshes (all centred at the origin, outward counter-clockwise winding):
//! * `plane` — the square `[-1, 1]²` in XZ, normal +Y, uvs `(0,0)` at `(-1, -1)`; `detail` = quads per
//!   side (default 1, at most [`MAX_PLANE_DETAIL`]).
//! * `box` — the cube `[-1, 1]³`, flat-shaded faces (24 vertices), each face uv-mapped to `[0, 1]²`.
//! * `sphere` — a UV sphere of radius 1 with uvs; `detail` = longitudinal segments (default 48, half as
//!   many rings, 3..=[`MAX_SPHERE_DETAIL`]).
//! * `displaced-sphere` — an icosphere subdivided `detail` times (default 7: 327,680 triangles),
//!   radially displaced by a smooth deterministic noise of ±4 % of the radius; the high-poly benchmark
//!   mesh of the `focus-sweep` scene. No uvs.
//! * `spot` — Keenan Crane's Spot (public domain, `assets/spot/README.txt`), normalized to `[-1, 1]³`
//!   (largest half-extent 1), with uvs for the embedded texture (`texture = "spot"` in a scene file);
//!   `detail` = rounds of midpoint subdivision that keep the surface exactly (default 0: the embedded
//!   5,856 triangles; n gives 5,856·4ⁿ, at most [`MAX_SPOT_DETAIL`]), for a high-poly textured object.
//!
//! Textures: `spot` (Spot's, embedded PNG), `leaves` ([`leaves_texture`], generated: leaf shapes on
//! a transparent background, for alpha-tested cards) and `checker` ([`checker_texture`], generated:
//! a chess board's 8×8 squares).
//!
//! Scenes are TOML files in the repository's `scenes/` folder, embedded and parsed with
//! [`parse_scene`](super::file::parse_scene): see [`BUILTIN_SCENES`].

use std::collections::HashMap;
use std::path::Path;
use std::sync::{Arc, OnceLock};

use glam::{Vec2, Vec3};

use super::mesh::{parse_obj, Mesh};
use super::texture::{texture_from_png_bytes, Texture};
use super::Scene;
use crate::error::{Error, Result};

/// Names accepted by [`builtin_mesh`].
pub const BUILTIN_MESHES: &[&str] = &["plane", "box", "sphere", "displaced-sphere", "spot"];
/// Names accepted by [`builtin_scene`].
pub const BUILTIN_SCENES: &[&str] = &[
    "default",
    "static",
    "focus-sweep",
    "one-mover",
    "glass",
    "foliage",
    "smoke",
    "arena",
    "chess",
    "cornell",
    "interior",
];
/// Names of the built-in textures a scene file's `texture` may give instead of a PNG path.
pub const BUILTIN_TEXTURES: &[&str] = &["spot", "leaves", "checker"];

pub const MAX_PLANE_DETAIL: u32 = 1024;
pub const MAX_SPHERE_DETAIL: u32 = 4096;
/// 9 subdivisions = 5,242,880 triangles.
pub const MAX_ICOSPHERE_DETAIL: u32 = 9;
/// Default subdivision level of `displaced-sphere`: 20·4⁷ = 327,680 triangles (≥ 100k).
pub const DEFAULT_ICOSPHERE_DETAIL: u32 = 7;
/// 3 midpoint subdivisions of Spot = 5,856·4³ = 374,784 triangles.
pub const MAX_SPOT_DETAIL: u32 = 3;

const SPOT_OBJ: &[u8] = include_bytes!("../../../assets/spot/spot_triangulated.obj");
const SPOT_PNG: &[u8] = include_bytes!("../../../assets/spot/spot_texture.png");
/// The licence note that travels with Spot (public domain, Keenan Crane).
pub const SPOT_README: &str = include_str!("../../../assets/spot/README.txt");

const SCENE_DEFAULT: &str = include_str!("../../../scenes/default.toml");
const SCENE_STATIC: &str = include_str!("../../../scenes/static.toml");
const SCENE_FOCUS_SWEEP: &str = include_str!("../../../scenes/focus-sweep.toml");
const SCENE_ONE_MOVER: &str = include_str!("../../../scenes/one-mover.toml");
const SCENE_GLASS: &str = include_str!("../../../scenes/glass.toml");
const SCENE_FOLIAGE: &str = include_str!("../../../scenes/foliage.toml");
const SCENE_SMOKE: &str = include_str!("../../../scenes/smoke.toml");
const SCENE_ARENA: &str = include_str!("../../../scenes/arena.toml");
const SCENE_CHESS: &str = include_str!("../../../scenes/chess.toml");
const SCENE_CORNELL: &str = include_str!("../../../scenes/cornell.toml");
const SCENE_INTERIOR: &str = include_str!("../../../scenes/interior.toml");

/// A procedural or embedded mesh by name; `None` when `name` is not a built-in mesh. `detail` is the
/// tessellation level (ignored by `box`).
pub fn builtin_mesh(name: &str, detail: Option<u32>) -> Option<Result<Mesh>> {
    let mesh = match name {
        "plane" => plane(detail.unwrap_or(1)),
        "box" => unit_box(),
        "sphere" => uv_sphere(detail.unwrap_or(48)),
        "displaced-sphere" => displaced_sphere(detail.unwrap_or(DEFAULT_ICOSPHERE_DETAIL)),
        "spot" => spot(detail.unwrap_or(0)),
        _ => return None,
    };
    Some(mesh)
}

/// The embedded Spot texture (decoded once, shared).
pub fn spot_texture() -> Result<Arc<Texture>> {
    static SPOT: OnceLock<std::result::Result<Arc<Texture>, String>> = OnceLock::new();
    SPOT.get_or_init(|| {
        texture_from_png_bytes("spot", Path::new("<embedded spot_texture.png>"), SPOT_PNG)
            .map(Arc::new)
            .map_err(|e| e.to_string())
    })
    .clone()
    .map_err(|m| Error::scene("built-in texture `spot`", m))
}

/// Side of the generated [`leaves_texture`], texels.
pub const LEAVES_SIZE: u32 = 128;

/// The generated `leaves` texture: [`LEAVES_SIZE`]² texels of overlapping leaf shapes (pointed ellipses
/// with a lighter midrib, greens of several shades) on a fully transparent background — coverage for
/// alpha-tested foliage cards (`alpha_from_texture = true`). It tiles: leaves wrap around the edges.
/// Deterministic (a fixed [`crate::sampling::Pcg32`] stream), so scenes using it are reproducible.
pub fn leaves_texture() -> Arc<Texture> {
    static LEAVES: OnceLock<Arc<Texture>> = OnceLock::new();
    LEAVES
        .get_or_init(|| {
            let n = LEAVES_SIZE as usize;
            let mut rng = crate::sampling::Pcg32::new(0x1eaf, 7);
            let mut unit = || rng.next_u32() as f32 / 4_294_967_296.0;
            let mut rgba = vec![0u8; n * n * 4];
            for _ in 0..22 {
                let centre = Vec2::new(unit(), unit()) * n as f32;
                let angle = unit() * std::f32::consts::TAU;
                let (half_length, half_width) = (14.0 + 10.0 * unit(), 5.0 + 4.0 * unit());
                let shade = 0.55 + 0.45 * unit();
                let axis = Vec2::from_angle(angle);
                for y in 0..n {
                    for x in 0..n {
                        // Offset to the nearest copy of the centre (the texture tiles).
                        let mut d = Vec2::new(x as f32 + 0.5, y as f32 + 0.5) - centre;
                        d -= (d / n as f32).round() * n as f32;
                        let (u, v) = (d.dot(axis) / half_length, d.perp_dot(axis) / half_width);
                        // A pointed leaf: the width shrinks towards both tips.
                        if u.abs() >= 1.0 || v.abs() >= 1.0 - u * u {
                            continue;
                        }
                        let rib = if v.abs() < 0.12 { 1.25 } else { 1.0 };
                        let c = [0.18 * shade, 0.55 * shade * rib, 0.12 * shade]
                            .map(|c: f32| (c.min(1.0) * 255.0) as u8);
                        let i = 4 * (y * n + x);
                        rgba[i..i + 4].copy_from_slice(&[c[0], c[1], c[2], 255]);
                    }
                }
            }
            Arc::new(Texture::from_srgb_rgba8("leaves", LEAVES_SIZE, LEAVES_SIZE, rgba))
        })
        .clone()
}

/// Side of the generated [`checker_texture`], texels: 8 squares of 32 texels.
pub const CHECKER_SIZE: u32 = 256;
/// The `checker` texture's light and dark squares, sRGB: cream and a walnut brown.
pub const CHECKER_LIGHT: [u8; 3] = [236, 214, 176];
pub const CHECKER_DARK: [u8; 3] = [120, 78, 48];

/// The generated `checker` texture: [`CHECKER_SIZE`]² opaque texels of 8×8 squares, the square at
/// (column i, row j) [`CHECKER_LIGHT`] when i + j is even and [`CHECKER_DARK`] otherwise — a chess board
/// over uv `[0, 1]²` (on a `plane`, one square per eighth of its side). Deterministic.
pub fn checker_texture() -> Arc<Texture> {
    static CHECKER: OnceLock<Arc<Texture>> = OnceLock::new();
    CHECKER
        .get_or_init(|| {
            let n = CHECKER_SIZE as usize;
            let square = n / 8;
            let mut rgba = Vec::with_capacity(n * n * 4);
            for y in 0..n {
                for x in 0..n {
                    let c = if (x / square + y / square).is_multiple_of(2) {
                        CHECKER_LIGHT
                    } else {
                        CHECKER_DARK
                    };
                    rgba.extend_from_slice(&[c[0], c[1], c[2], 255]);
                }
            }
            Arc::new(Texture::from_srgb_rgba8("checker", CHECKER_SIZE, CHECKER_SIZE, rgba))
        })
        .clone()
}

/// A built-in texture by name (see [`BUILTIN_TEXTURES`]); `None` when there is no such texture.
pub fn builtin_texture(name: &str) -> Option<Result<Arc<Texture>>> {
    match name {
        "spot" => Some(spot_texture()),
        "leaves" => Some(Ok(leaves_texture())),
        "checker" => Some(Ok(checker_texture())),
        _ => None,
    }
}

/// A built-in scene by name (see [`BUILTIN_SCENES`]); `None` when there is no such scene.
pub fn builtin_scene(name: &str) -> Option<Result<Scene>> {
    let text = match name {
        "default" => SCENE_DEFAULT,
        "static" => SCENE_STATIC,
        "focus-sweep" => SCENE_FOCUS_SWEEP,
        "one-mover" => SCENE_ONE_MOVER,
        "glass" => SCENE_GLASS,
        "foliage" => SCENE_FOLIAGE,
        "smoke" => SCENE_SMOKE,
        "arena" => SCENE_ARENA,
        "chess" => SCENE_CHESS,
        "cornell" => SCENE_CORNELL,
        "interior" => SCENE_INTERIOR,
        _ => return None,
    };
    Some(super::file::parse_scene(text, Path::new("."), name))
}

fn detail_limit(what: &'static str, value: u32, lo: u32, hi: u32) -> Result<()> {
    if (lo..=hi).contains(&value) {
        Ok(())
    } else {
        Err(Error::Limit { what, value: value.to_string(), limit: format!("must be in {lo}..={hi}") })
    }
}

fn plane(n: u32) -> Result<Mesh> {
    detail_limit("plane detail", n, 1, MAX_PLANE_DETAIL)?;
    let mut positions = Vec::new();
    let mut uvs = Vec::new();
    for j in 0..=n {
        for i in 0..=n {
            let (u, v) = (i as f32 / n as f32, j as f32 / n as f32);
            positions.push(Vec3::new(-1.0 + 2.0 * u, 0.0, -1.0 + 2.0 * v));
            uvs.push(Vec2::new(u, v));
        }
    }
    let normals = vec![Vec3::Y; positions.len()];
    let row = n + 1;
    let mut indices = Vec::new();
    for j in 0..n {
        for i in 0..n {
            let a = j * row + i;
            let (b, c, d) = (a + row, a + 1, a + row + 1);
            // (b − a) = +Z, (c − a) = +X: +Z × +X = +Y.
            indices.extend_from_slice(&[a, b, c, c, b, d]);
        }
    }
    Mesh::new("built-in mesh `plane`", positions, normals, uvs, indices)
}

fn unit_box() -> Result<Mesh> {
    let (mut positions, mut normals, mut uvs, mut indices) = (vec![], vec![], vec![], vec![]);
    for axis in 0..3 {
        for sign in [1.0f32, -1.0] {
            let mut n = Vec3::ZERO;
            n[axis] = sign;
            // Tangents with u × v = n.
            let mut u = Vec3::ZERO;
            u[(axis + 1) % 3] = 1.0;
            let v = n.cross(u);
            let base = positions.len() as u32;
            for (cu, cv) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
                positions.push(n + cu * u + cv * v);
                normals.push(n);
                uvs.push(Vec2::new(0.5 + 0.5 * cu, 0.5 - 0.5 * cv));
            }
            indices.extend_from_slice(&[base, base + 1, base + 2, base, base + 2, base + 3]);
        }
    }
    Mesh::new("built-in mesh `box`", positions, normals, uvs, indices)
}

fn uv_sphere(segments: u32) -> Result<Mesh> {
    detail_limit("sphere detail", segments, 3, MAX_SPHERE_DETAIL)?;
    let rings = (segments / 2).max(2);
    let (mut positions, mut uvs) = (vec![], vec![]);
    for r in 0..=rings {
        let v = r as f32 / rings as f32;
        let theta = v * std::f32::consts::PI;
        for s in 0..=segments {
            let u = s as f32 / segments as f32;
            let phi = u * std::f32::consts::TAU;
            positions.push(Vec3::new(theta.sin() * phi.cos(), theta.cos(), -theta.sin() * phi.sin()));
            uvs.push(Vec2::new(u, v));
        }
    }
    let normals = positions.clone();
    let row = segments + 1;
    let mut indices = Vec::new();
    for r in 0..rings {
        for s in 0..segments {
            let a = r * row + s;
            let (b, c, d) = (a + row, a + 1, a + row + 1);
            // a is above b; c is a's neighbour in +φ (counter-clockwise seen from +Y).
            if r != 0 {
                indices.extend_from_slice(&[a, b, c]);
            }
            if r != rings - 1 {
                indices.extend_from_slice(&[c, b, d]);
            }
        }
    }
    Mesh::new("built-in mesh `sphere`", positions, normals, uvs, indices)
}

/// Spot after `rounds` of midpoint (1 → 4) subdivision. The surface is kept exactly: each new vertex is
/// the midpoint of an edge, shared by the edge's two triangles (keyed by the sorted vertex pair and
/// computed from the sorted pair, so it is bit-identical for both) with the edge's interpolated uv and
/// interpolated, renormalised normal. Vertices duplicated at uv seams give duplicated midpoints at the
/// same position, so the surface stays watertight where it was. Round 0 is the embedded mesh as is.
fn spot(rounds: u32) -> Result<Mesh> {
    detail_limit("spot detail", rounds, 0, MAX_SPOT_DETAIL)?;
    let base = parse_obj(SPOT_OBJ, "built-in mesh `spot`", true)?;
    if rounds == 0 {
        return Ok(base);
    }
    let skipped = base.stats.skipped_degenerate;
    let Mesh { mut positions, mut normals, mut uvs, mut indices, .. } = base;
    for _ in 0..rounds {
        let mut midpoints: HashMap<(u32, u32), u32> = HashMap::with_capacity(indices.len());
        let mut next = Vec::with_capacity(indices.len() * 4);
        for tri in indices.chunks_exact(3) {
            let mut midpoint = |a: u32, b: u32| -> u32 {
                let (a, b) = (a.min(b), a.max(b));
                *midpoints.entry((a, b)).or_insert_with(|| {
                    let (a, b) = (a as usize, b as usize);
                    positions.push((positions[a] + positions[b]) * 0.5);
                    normals.push(((normals[a] + normals[b]) * 0.5).normalize_or(normals[a]));
                    uvs.push((uvs[a] + uvs[b]) * 0.5);
                    positions.len() as u32 - 1
                })
            };
            let [a, b, c] = [tri[0], tri[1], tri[2]];
            let (ab, bc, ca) = (midpoint(a, b), midpoint(b, c), midpoint(c, a));
            // The corner triangles and the middle one, each with its parent's winding.
            next.extend_from_slice(&[a, ab, ca, ab, b, bc, ca, bc, c, ab, bc, ca]);
        }
        indices = next;
    }
    let mut mesh = Mesh::new("built-in mesh `spot`", positions, normals, uvs, indices)?;
    mesh.stats.skipped_degenerate += skipped;
    Ok(mesh)
}

/// Smooth deterministic noise on the unit sphere, in about [-1, 1]: a few sums of products of sines.
fn sphere_noise(p: Vec3) -> f32 {
    let a = (3.1 * p.x + 1.3).sin() * (2.7 * p.y + 0.4).sin() * (3.3 * p.z + 2.1).sin();
    let b = (7.3 * p.y + 0.9).sin() * (6.1 * p.z + 1.7).sin() * (5.9 * p.x + 0.2).sin();
    let c = (13.7 * p.z + 0.5).sin() * (12.9 * p.x + 2.3).sin() * (14.3 * p.y + 1.1).sin();
    0.55 * a + 0.3 * b + 0.15 * c
}

fn displaced_sphere(subdivisions: u32) -> Result<Mesh> {
    detail_limit("displaced-sphere detail", subdivisions, 0, MAX_ICOSPHERE_DETAIL)?;
    let (mut positions, mut indices) = icosahedron();
    for _ in 0..subdivisions {
        let mut midpoints: HashMap<(u32, u32), u32> = HashMap::with_capacity(indices.len());
        let mut next = Vec::with_capacity(indices.len() * 4);
        let mut midpoint = |a: u32, b: u32, positions: &mut Vec<Vec3>| -> u32 {
            let key = (a.min(b), a.max(b));
            *midpoints.entry(key).or_insert_with(|| {
                positions.push((positions[a as usize] + positions[b as usize]).normalize());
                positions.len() as u32 - 1
            })
        };
        for tri in indices.chunks_exact(3) {
            let [a, b, c] = [tri[0], tri[1], tri[2]];
            let ab = midpoint(a, b, &mut positions);
            let bc = midpoint(b, c, &mut positions);
            let ca = midpoint(c, a, &mut positions);
            next.extend_from_slice(&[a, ab, ca, ab, b, bc, ca, bc, c, ab, bc, ca]);
        }
        indices = next;
    }
    for p in &mut positions {
        *p *= 1.0 + 0.04 * sphere_noise(*p);
    }
    Mesh::new("built-in mesh `displaced-sphere`", positions, vec![], vec![], indices)
}

/// The regular icosahedron on the unit sphere: faces are the vertex triples at pairwise edge length,
/// oriented outward.
fn icosahedron() -> (Vec<Vec3>, Vec<u32>) {
    let t = (1.0 + 5.0f32.sqrt()) / 2.0;
    let mut v = Vec::new();
    for a in [-1.0f32, 1.0] {
        for b in [-t, t] {
            v.push(Vec3::new(0.0, a, b));
            v.push(Vec3::new(a, b, 0.0));
            v.push(Vec3::new(b, 0.0, a));
        }
    }
    let edge = 2.0f32;
    let is_edge = |i: usize, j: usize| ((v[i] - v[j]).length() - edge).abs() < 1e-3;
    let mut indices = Vec::new();
    for i in 0..12 {
        for j in i + 1..12 {
            for k in j + 1..12 {
                if is_edge(i, j) && is_edge(j, k) && is_edge(i, k) {
                    let n = (v[j] - v[i]).cross(v[k] - v[i]);
                    let tri = if n.dot(v[i] + v[j] + v[k]) > 0.0 { [i, j, k] } else { [i, k, j] };
                    indices.extend(tri.map(|x| x as u32));
                }
            }
        }
    }
    (v.into_iter().map(Vec3::normalize).collect(), indices)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn assert_outward(m: &Mesh, name: &str) {
        for tri in m.indices.chunks_exact(3) {
            let [a, b, c] = [0, 1, 2].map(|i| m.positions[tri[i] as usize]);
            let n = (b - a).cross(c - a);
            assert!(n.dot(a + b + c) > 0.0, "{name}: inward triangle {a} {b} {c}");
        }
    }

    /// One-sided materials need meshes wound with their fronts outward (`Material::one_sided`): every
    /// built-in mesh's triangles run counter-clockwise seen from the side their vertex normals point
    /// to — the geometric normal `(b − a) × (c − a)` agrees with the mean vertex normal — and the closed
    /// ones enclose a positive volume (the divergence theorem: outward normals).
    #[test]
    fn builtin_meshes_are_wound_front_side_out() {
        for name in BUILTIN_MESHES {
            let mesh = builtin_mesh(name, None).expect("known").expect("builds");
            let (mut agree, mut volume) = (0usize, 0.0f64);
            let n = mesh.indices.len() / 3;
            for t in mesh.indices.chunks_exact(3) {
                let [a, b, c] = [0, 1, 2].map(|k| mesh.positions[t[k] as usize]);
                let geometric = (b - a).cross(c - a);
                let vertex: Vec3 = t.iter().map(|&i| mesh.normals[i as usize]).sum();
                agree += (geometric.dot(vertex) > 0.0) as usize;
                volume += a.dot(b.cross(c)) as f64 / 6.0;
            }
            assert_eq!(agree, n, "`{name}`: {} of {n} triangles wound against their normals", n - agree);
            if *name != "plane" {
                assert!(volume > 0.0, "`{name}` encloses {volume}: wound inside out");
            }
        }
    }

    #[test]
    fn procedural_meshes_are_clean_and_outward() {
        for (name, detail) in [("box", None), ("sphere", Some(12)), ("displaced-sphere", Some(2))] {
            let m = builtin_mesh(name, detail).unwrap().unwrap();
            assert_eq!(m.stats.skipped_degenerate, 0, "{name}");
            assert_outward(&m, name);
        }
        let ico = builtin_mesh("displaced-sphere", Some(0)).unwrap().unwrap();
        assert_eq!(ico.triangle_count(), 20);
        let s = builtin_mesh("sphere", Some(12)).unwrap().unwrap();
        assert_eq!(s.triangle_count(), 2 * 12 * 6 - 2 * 12);
        assert!(s.positions.iter().zip(&s.normals).all(|(p, n)| (*p - *n).length() < 1e-5));
        let b = builtin_mesh("box", None).unwrap().unwrap();
        assert_eq!(b.triangle_count(), 12);
        assert_eq!(b.bounds(), (Vec3::splat(-1.0), Vec3::splat(1.0)));
    }

    #[test]
    fn plane_faces_up() {
        let m = builtin_mesh("plane", Some(4)).unwrap().unwrap();
        assert_eq!(m.triangle_count(), 32);
        for tri in m.indices.chunks_exact(3) {
            let [a, b, c] = [0, 1, 2].map(|i| m.positions[tri[i] as usize]);
            assert!((b - a).cross(c - a).normalize().dot(Vec3::Y) > 0.999);
        }
        assert!(m.uvs.iter().all(|uv| (0.0..=1.0).contains(&uv.x) && (0.0..=1.0).contains(&uv.y)));
    }

    #[test]
    fn displaced_sphere_default_is_high_poly_and_smooth() {
        let m = builtin_mesh("displaced-sphere", None).unwrap().unwrap();
        assert!(m.triangle_count() >= 100_000, "{}", m.triangle_count());
        let r: Vec<f32> = m.positions.iter().map(|p| p.length()).collect();
        let (lo, hi) = r.iter().fold((f32::MAX, f32::MIN), |(lo, hi), &x| (lo.min(x), hi.max(x)));
        assert!(lo > 0.94 && hi < 1.06 && hi - lo > 0.02, "{lo}..{hi}");
    }

    #[test]
    fn spot_is_embedded_normalized_and_textured() {
        let m = builtin_mesh("spot", None).unwrap().unwrap();
        assert_eq!(m.triangle_count(), 5856);
        assert!(m.has_uvs());
        let (lo, hi) = m.bounds();
        assert!((hi - lo).max_element() > 1.999 && lo.min_element() >= -1.0001 && hi.max_element() <= 1.0001);
        let t = spot_texture().unwrap();
        assert!(t.width > 0 && t.height > 0);
        assert!(SPOT_README.contains("public domain"));
    }

    fn surface_area(m: &Mesh) -> f64 {
        m.indices
            .chunks_exact(3)
            .map(|t| {
                let [a, b, c] = [0, 1, 2].map(|i| m.positions[t[i] as usize].as_dvec3());
                0.5 * (b - a).cross(c - a).length()
            })
            .sum()
    }

    /// Midpoint subdivision multiplies the triangles by 4 per round and keeps the surface: the same
    /// area and bounds, uvs inside the original's range, unit normals, nothing newly degenerate.
    #[test]
    fn spot_detail_subdivides_without_changing_the_surface() {
        let base = builtin_mesh("spot", None).unwrap().unwrap();
        let zero = builtin_mesh("spot", Some(0)).unwrap().unwrap();
        assert_eq!((zero.positions, zero.indices), (base.positions.clone(), base.indices.clone()));
        let area = surface_area(&base);
        let (uv_lo, uv_hi) =
            base.uvs.iter().fold((Vec2::MAX, Vec2::MIN), |(lo, hi), uv| (lo.min(*uv), hi.max(*uv)));
        for n in 1..=2u32 {
            let m = builtin_mesh("spot", Some(n)).unwrap().unwrap();
            assert_eq!(m.triangle_count(), 5856 * 4usize.pow(n), "detail {n}");
            // What the embedded mesh skips is carried over; subdividing skips nothing more.
            assert_eq!(m.stats.skipped_degenerate, base.stats.skipped_degenerate, "detail {n}");
            assert!(((surface_area(&m) - area) / area).abs() < 1e-4, "detail {n}: area {}", surface_area(&m));
            assert_eq!(m.bounds(), base.bounds(), "detail {n}");
            assert_eq!(
                m.positions[..base.positions.len()],
                base.positions[..],
                "detail {n}: old vertices moved"
            );
            assert!(m.uvs[base.uvs.len()..].iter().all(|uv| uv.cmpge(uv_lo).all() && uv.cmple(uv_hi).all()));
            assert!(m.normals.iter().all(|v| (v.length() - 1.0).abs() < 1e-4));
            assert!(m.has_uvs() && m.normals.len() == m.positions.len());
        }
        let e = builtin_mesh("spot", Some(MAX_SPOT_DETAIL + 1)).unwrap().unwrap_err().to_string();
        assert!(e.contains("spot detail"), "{e}");
    }

    #[test]
    fn checker_texture_is_eight_by_eight_squares() {
        let t = checker_texture();
        assert_eq!((t.width, t.height), (CHECKER_SIZE, CHECKER_SIZE));
        let n = CHECKER_SIZE as usize;
        let texel = |x: usize, y: usize| &t.srgb_rgba8[4 * (y * n + x)..4 * (y * n + x) + 4];
        let square = n / 8;
        for y in 0..n {
            for x in 0..n {
                let light = (x / square + y / square).is_multiple_of(2);
                let c = if light { CHECKER_LIGHT } else { CHECKER_DARK };
                assert_eq!(texel(x, y), [c[0], c[1], c[2], 255], "texel ({x}, {y})");
            }
        }
        // Light squares are clearly lighter, and the corners alternate like a board's.
        assert!(CHECKER_LIGHT.iter().zip(CHECKER_DARK).all(|(l, d)| *l > d + 60));
        assert_eq!(texel(0, 0), texel(n - 1, n - 1));
        assert_ne!(texel(0, 0), texel(n - 1, 0));
        assert!(Arc::ptr_eq(&t, &checker_texture()));
        assert!(builtin_texture("checker").unwrap().is_ok());
    }

    #[test]
    fn leaves_texture_is_cut_out_deterministic_and_tiles() {
        let t = leaves_texture();
        assert_eq!((t.width, t.height), (LEAVES_SIZE, LEAVES_SIZE));
        let alpha: Vec<u8> = t.srgb_rgba8.chunks_exact(4).map(|p| p[3]).collect();
        // Cut-out coverage: every texel fully in or fully out, and plenty of both.
        assert!(alpha.iter().all(|&a| a == 0 || a == 255));
        let covered = alpha.iter().filter(|&&a| a == 255).count() as f64 / alpha.len() as f64;
        assert!((0.2..0.8).contains(&covered), "{covered}");
        // Leaves wrap around: some leaf crosses each edge.
        let n = LEAVES_SIZE as usize;
        assert!((0..n).any(|y| alpha[y * n] == 255 && alpha[y * n + n - 1] == 255));
        assert!((0..n).any(|x| alpha[x] == 255 && alpha[(n - 1) * n + x] == 255));
        // Generated from a fixed stream: the same texels every time (and shared).
        assert!(Arc::ptr_eq(&t, &leaves_texture()));
        let sum: u64 = t.srgb_rgba8.iter().map(|&b| b as u64).sum();
        assert_eq!(sum, leaves_texture().srgb_rgba8.iter().map(|&b| b as u64).sum::<u64>());
        assert!(builtin_texture("leaves").unwrap().is_ok() && builtin_texture("bark").is_none());
    }

    /// Every built-in scene parses; the transparency scenes use what they are for.
    #[test]
    fn builtin_scenes_parse_and_the_transparency_ones_are_transparent() {
        for name in BUILTIN_SCENES {
            builtin_scene(name).unwrap().unwrap_or_else(|e| panic!("{name}: {e}"));
        }
        let scene = |n: &str| builtin_scene(n).unwrap().unwrap();
        let glass = scene("glass");
        assert!(
            glass.objects.iter().filter(|o| o.material.alpha < 1.0 && o.material.tint != Vec3::ONE).count()
                >= 3
        );
        assert!(glass.objects.iter().any(|o| o.material.alpha < 1.0 && o.is_moving()));
        let foliage = scene("foliage");
        assert!(foliage.objects.iter().any(|o| o.material.alpha_from_texture));
        assert!(foliage.lights.iter().any(|l| l.shadows()));
        let smoke = scene("smoke");
        assert!(smoke.objects.iter().filter(|o| o.material.alpha < 0.3).count() >= 30);
    }

    #[test]
    fn bad_names_and_details() {
        assert!(builtin_mesh("teapot", None).is_none());
        assert!(builtin_scene("nope").is_none());
        assert!(builtin_mesh("plane", Some(0)).unwrap().is_err());
        let e = builtin_mesh("displaced-sphere", Some(40)).unwrap().unwrap_err().to_string();
        assert!(e.contains("displaced-sphere detail"), "{e}");
    }
}
