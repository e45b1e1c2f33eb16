//! Shadow maps (issue 12, docs/SHADOWS.md): which lights get one, of which kind, seen from which
//! views, laid out where in the atlas — and the lookup math, the CPU mirror of
//! `shaders-glsl/common/shadow.glsl`. The GPU side (pipelines, atlas, passes) is
//! [`crate::techniques::shadow_maps`].
//!
//! * **Kinds** ([`ShadowKind`]), chosen from the casters (every object casts): all opaque → a
//!   **plain** depth map (one sample per texel) filtered by PCF; some coverage below 1 → a
//!   **stochastic shadow map** (Enderton et al. 2011: the casters drawn with stochastic transparency,
//!   depth only, S depth samples per texel; the lookup compares against all S of each filter tap); some
//!   tinted → a **coloured stochastic shadow map** (after McGuire & Enderton 2011: a second atlas of
//!   transmitted colour; see [`ShadowKind::Colored`] for how ours departs from the paper).
//! * **Views**: a directional light sees the scene orthographically along its direction
//!   ([`View::directional_light`]); a spot light through a perspective of its outer cone; a point light
//!   (and a spot light wider than [`SPOT_CUBE_DEG`]) through the six faces of a cube
//!   ([`CUBE_FACES`]). Each light has one **lookup space** (its view, or for a cube the light's
//!   position with the world's axes) in which the receiver's position is found, and `base_to_face`
//!   maps it into each rendered face.
//! * **Atlas**: every face of every light is `sub_maps` tiles of `size × size` side by side, each
//!   multisampled `msaa` times, so a texel holds `S = msaa × sub_maps` depth samples.
//! * **Lookup** ([`FaceProjection::lookup`]): nothing moves the receiver across the map. The filter
//!   is a box of `2r + 1` texels centred on the receiver's exact map position, over the map read as
//!   piecewise constant texels: (2r + 2)² taps, the outer ones weighted by their overlap (bilinear
//!   PCF at r = 0), so its centre is the receiver's whatever r. Each depth sample of each tap is
//!   compared with the **receiver's own plane** (its geometric normal) where the light's ray through
//!   that sample's position crosses it ([`FaceProjection::plane_depth`]), less `depth_bias` texels
//!   of slack: a planar receiver never shadows itself at any slope, and an occluder shadows exactly
//!   the taps it stands in front of.
//! * **Time**: a map is rendered at each pass' shutter time when anything moves, else once per frame.

use glam::{Mat4, Vec2, Vec3};

use crate::error::{Error, Result};
use crate::scene::view::CUBE_FACES;
use crate::scene::{Light, Projection, Scene, View};

/// A spot light whose outer half-angle exceeds this many degrees is mapped through a cube like a
/// point light (one perspective that wide wastes most of its texels at the edges).
pub const SPOT_CUBE_DEG: f32 = 60.0;

/// The default depth slack, in texels at the receiver: the comparison is with the receiver's own
/// plane at each sample, so this only has to cover rounding (and the sample positions of a device
/// without the standard ones), not the slope.
pub const DEPTH_BIAS: f32 = 0.1;

/// The largest atlas side (texels), within every device's image limit we target (lavapipe: 16384).
pub const MAX_ATLAS: u32 = 16384;

/// Shadow-map settings (`--shadow-map`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShadowSettings {
    /// false (`off`): shadow-casting lights are rendered unshadowed — to price what shadows cost
    /// against the reference, which always traces them.
    pub enabled: bool,
    /// Texels per side of each face.
    pub size: u32,
    /// Depth samples per texel S of a stochastic (or coloured) map; a plain map has one.
    pub samples: u32,
    /// PCF radius r: the lookup averages a box of 2r + 1 texels a side centred on the receiver.
    pub pcf_radius: u32,
    /// Depth slack of the comparison with the receiver's plane, in texels at the receiver.
    pub depth_bias: f32,
}

impl Default for ShadowSettings {
    fn default() -> Self {
        ShadowSettings { enabled: true, size: 1024, samples: 4, pcf_radius: 1, depth_bias: DEPTH_BIAS }
    }
}

impl ShadowSettings {
    /// Checks the settings' ranges.
    pub fn validate(&self) -> Result<()> {
        let bad = |what: &str, value: String, limit: &str| {
            Err(Error::Limit { what: "shadow map", value: format!("{what} {value}"), limit: limit.into() })
        };
        if !(8..=8192).contains(&self.size) {
            return bad("size", self.size.to_string(), "8 to 8192 texels per side");
        }
        if !(1..=256).contains(&self.samples) {
            return bad("samples", self.samples.to_string(), "1 to 256 per texel");
        }
        if self.pcf_radius > 8 {
            return bad("PCF radius", self.pcf_radius.to_string(), "0 to 8 texels");
        }
        if !(self.depth_bias.is_finite() && self.depth_bias >= 0.0) {
            return bad("depth bias", self.depth_bias.to_string(), "finite and ≥ 0");
        }
        Ok(())
    }
}

impl std::str::FromStr for ShadowSettings {
    type Err = Error;
    /// `SIZE[/SAMPLES[/PCF]]`, e.g. `1024`, `512/16`, `2048/4/2`; or `off`.
    fn from_str(s: &str) -> Result<Self> {
        let mut out = ShadowSettings::default();
        if s.trim() == "off" {
            out.enabled = false;
            return Ok(out);
        }
        let parts: Vec<&str> = s.split('/').collect();
        let number = |p: &str, what: &str| {
            p.trim().parse::<u32>().map_err(|_| {
                Error::Unsupported(format!(
                    "shadow map `{s}`: {what} `{p}` is not a whole number (expected SIZE[/SAMPLES[/PCF]], \
                     e.g. 1024/4/1, or off)"
                ))
            })
        };
        if parts.len() > 3 || parts.iter().any(|p| p.trim().is_empty()) {
            return Err(Error::Unsupported(format!(
                "shadow map `{s}`: expected SIZE[/SAMPLES[/PCF]], e.g. 1024/4/1, or off"
            )));
        }
        out.size = number(parts[0], "size")?;
        if let Some(p) = parts.get(1) {
            out.samples = number(p, "samples")?;
        }
        if let Some(p) = parts.get(2) {
            out.pcf_radius = number(p, "PCF radius")?;
        }
        out.validate()?;
        Ok(out)
    }
}

impl std::fmt::Display for ShadowSettings {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if !self.enabled {
            return f.write_str("off");
        }
        write!(f, "{}/{}/{}", self.size, self.samples, self.pcf_radius)
    }
}

/// What the shadow maps of a scene hold (module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ShadowKind {
    /// Every caster opaque: one depth per texel, PCF.
    Plain,
    /// Some caster with coverage below 1, none tinted: S stochastic depths per texel.
    Stochastic,
    /// Some tinted caster: S stochastic depths and, per sample, the product of the hues of the tinted
    /// casters in front of it and the depth of the nearest of them. A caster of transmittance τ per
    /// channel blocks a sample with probability `1 − max τ` and tints the rest by its hue `τ / max τ`,
    /// so each sample's expected light is exactly τ for a receiver behind it. **Departure from McGuire
    /// & Enderton (2011)**: their colour map is one colour per texel; ours is per sample, with the
    /// nearest tinted depth, so a receiver in front of every tinted caster of a sample (a directly lit
    /// pane) is not tinted by them; a receiver *between* two tinted casters of one sample still takes
    /// the hue of the one behind it — the remaining bias (docs/SHADOWS.md).
    Colored,
}

impl ShadowKind {
    /// The kind `scene`'s casters need.
    pub fn for_scene(scene: &Scene) -> ShadowKind {
        let transparent = |o: &&crate::scene::Object| !o.material.is_opaque();
        if scene.objects.iter().filter(transparent).any(|o| o.material.tint != Vec3::ONE) {
            ShadowKind::Colored
        } else if scene.objects.iter().any(|o| !o.material.is_opaque()) {
            ShadowKind::Stochastic
        } else {
            ShadowKind::Plain
        }
    }
    pub fn name(self) -> &'static str {
        match self {
            ShadowKind::Plain => "plain",
            ShadowKind::Stochastic => "stochastic",
            ShadowKind::Colored => "coloured stochastic",
        }
    }
}

/// One rendered face of a light's shadow map.
#[derive(Clone, Debug)]
pub struct ShadowFace {
    pub view: View,
    /// The light's lookup space → this face's view space.
    pub base_to_face: Mat4,
    /// Atlas texel of its first sub-map's tile (the others follow to the right).
    pub origin: [u32; 2],
}

/// One shadow-casting light.
#[derive(Clone, Debug)]
pub struct LightShadow {
    /// Index in the scene's lights.
    pub light: usize,
    /// The space the receiver's position is found in (a face's view, or a cube's centre).
    pub lookup: View,
    /// One face, or six for a cube.
    pub faces: Vec<ShadowFace>,
}

/// Every shadow-casting light's maps and the atlas holding them.
#[derive(Clone, Debug)]
pub struct ShadowPlan {
    pub kind: ShadowKind,
    pub settings: ShadowSettings,
    /// MSAA samples per sub-map and sub-maps per face: `msaa × sub_maps = S` (1 × 1 for a plain map).
    pub msaa: u32,
    pub sub_maps: u32,
    pub lights: Vec<LightShadow>,
    /// Atlas size in texels.
    pub atlas: (u32, u32),
}

impl ShadowPlan {
    /// Depth samples per texel S.
    pub fn samples(&self) -> u32 {
        self.msaa * self.sub_maps
    }
    /// One line for a render's report: kind, faces, resolution, S, filter.
    pub fn summary(&self) -> String {
        let r = 2 * self.settings.pcf_radius + 1;
        format!(
            "{} maps: {} face(s) of {}², S = {} ({}× MSAA × {} tile(s)), PCF {r}×{r}, atlas {}×{}",
            self.kind.name(),
            self.face_count(),
            self.settings.size,
            self.samples(),
            self.msaa,
            self.sub_maps,
            self.atlas.0,
            self.atlas.1
        )
    }

    /// Faces over all lights.
    pub fn face_count(&self) -> usize {
        self.lights.iter().map(|l| l.faces.len()).sum()
    }

    /// The maps `scene` needs with `settings`, multisampling each tile at the largest of
    /// `msaa_counts` (the device's) that divides S (`None` when no light casts shadows).
    pub fn new(scene: &Scene, settings: &ShadowSettings, msaa_counts: &[u32]) -> Result<Option<ShadowPlan>> {
        settings.validate()?;
        if !settings.enabled || !scene.lights.iter().any(|l| l.shadows()) {
            return Ok(None);
        }
        // No triangle anywhere: nothing casts a shadow and nothing receives one (the image is the
        // background, as the reference's); no map is needed, and none could frame the scene.
        if scene.objects.iter().all(|o| o.mesh.indices.is_empty()) {
            return Ok(None);
        }
        let kind = ShadowKind::for_scene(scene);
        let samples = if kind == ShadowKind::Plain { 1 } else { settings.samples };
        let msaa =
            msaa_counts.iter().copied().filter(|&m| m <= samples && samples % m == 0).max().unwrap_or(1);
        let sub_maps = samples / msaa;
        let size = settings.size;
        let mut lights = Vec::new();
        for (i, light) in scene.lights.iter().enumerate() {
            if !light.shadows() {
                continue;
            }
            let name = format!("light {i} shadow");
            let none = || {
                Error::Unsupported(format!(
                    "light[{i}] casts shadows, but no shadow map frames it (a scene without geometry, or a \
                     zero direction)"
                ))
            };
            let (lookup, faces) = match *light {
                Light::Directional { direction, .. } => {
                    let v = View::directional_light(scene, &name, direction, size).ok_or_else(none)?;
                    (v.clone(), vec![(v, Mat4::IDENTITY)])
                }
                Light::Spot { position, direction, outer_deg, .. } if outer_deg <= SPOT_CUBE_DEG => {
                    let up = if direction.normalize_or_zero().y.abs() > 0.99 { Vec3::Z } else { Vec3::Y };
                    let half = outer_deg.max(1.0);
                    let v = View::perspective_light(scene, &name, position, direction, up, half, size)
                        .ok_or_else(none)?;
                    (v.clone(), vec![(v, Mat4::IDENTITY)])
                }
                Light::Spot { position, .. } | Light::Point { position, .. } => {
                    cube_views(scene, &name, position, size).ok_or_else(none)?
                }
            };
            lights.push((i, lookup, faces));
        }
        // Faces in rows: each face is `sub_maps` tiles wide.
        let face_w = sub_maps * size;
        let faces: usize = lights.iter().map(|(_, _, f)| f.len()).sum();
        let per_row = ((MAX_ATLAS / face_w.max(1)) as usize).clamp(1, faces.max(1));
        // As square as the faces allow: rows × per_row ≥ faces with per_row ≈ √faces·(size / face_w).
        let per_row = per_row.min(((faces as f64).sqrt().ceil() as usize).max(1));
        let rows = faces.div_ceil(per_row);
        let atlas = (per_row as u32 * face_w, rows as u32 * size);
        if face_w > MAX_ATLAS || atlas.1 > MAX_ATLAS {
            return Err(Error::Limit {
                what: "shadow atlas",
                value: format!(
                    "{} × {} texels ({faces} faces of {sub_maps} tiles of {size}²)",
                    atlas.0, atlas.1
                ),
                limit: format!(
                    "at most {MAX_ATLAS} per side: lower the map size or its samples (--shadow-map)"
                ),
            });
        }
        let mut next = 0usize;
        let lights = lights
            .into_iter()
            .map(|(light, lookup, faces)| LightShadow {
                light,
                lookup,
                faces: faces
                    .into_iter()
                    .map(|(view, base_to_face)| {
                        let (row, col) = (next / per_row, next % per_row);
                        next += 1;
                        ShadowFace { view, base_to_face, origin: [col as u32 * face_w, row as u32 * size] }
                    })
                    .collect(),
            })
            .collect();
        Ok(Some(ShadowPlan { kind, settings: *settings, msaa, sub_maps, lights, atlas }))
    }
}

/// A point light's lookup space (its position, the world's axes) and its six faces.
fn cube_views(scene: &Scene, name: &str, position: Vec3, size: u32) -> Option<(View, Vec<(View, Mat4)>)> {
    let faces: Vec<(View, Mat4)> = CUBE_FACES
        .iter()
        .enumerate()
        .map(|(k, &(dir, up))| {
            let v =
                View::perspective_light(scene, &format!("{name} face {k}"), position, dir, up, 45.0, size)?;
            // world_to_view = R · T(−position), so base (= T(−position)) → face is R.
            let base_to_face = v.world_to_view[0] * Mat4::from_translation(position);
            Some((v, base_to_face))
        })
        .collect::<Option<_>>()?;
    let base = Mat4::from_translation(-position);
    let mut lookup = faces[0].0.clone();
    lookup.name = format!("{name} lookup");
    lookup.world_to_view = [base, base];
    lookup.space = crate::scene::CameraSpaceScene::seen_from(scene, [base, base]);
    Some((lookup, faces))
}

/// Whether anything in `scene` moves in the world over the shutter (lights do not): then shadow maps
/// change with time — rendered per pass on the forward path; the stochastic frame, whose samples each
/// have their own time, has no maps for that yet.
pub fn casters_move(scene: &Scene) -> bool {
    scene.objects.iter().any(|o| o.transforms.iter().any(|&(_, m)| m != o.transforms[0].1))
}

/// What the lookup needs of one face's projection (`ShadowView` in `common/shadow.glsl`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FaceProjection {
    pub orthographic: bool,
    /// Orthographic: half extents x, y; perspective: pixel scale in x (and y unused).
    pub a: f32,
    pub b: f32,
    pub size: f32,
    pub near: f32,
    pub far: f32,
}

impl FaceProjection {
    pub fn of(view: &View) -> FaceProjection {
        match view.projection {
            Projection::Orthographic { width, half_extent, near, far, .. } => FaceProjection {
                orthographic: true,
                a: half_extent.x,
                b: half_extent.y,
                size: width as f32,
                near,
                far,
            },
            Projection::Perspective { width, pixel_scale, near, far, .. } => {
                FaceProjection { orthographic: false, a: pixel_scale, b: 0.0, size: width as f32, near, far }
            }
            Projection::ThinLens(k) => FaceProjection {
                orthographic: false,
                a: k.pixel_scale,
                b: 0.0,
                size: k.width,
                near: k.near,
                far: k.far,
            },
        }
    }

    /// Pixel position (x right, y down) and view depth of view-space point `q`.
    pub fn project(&self, q: Vec3) -> (Vec2, f32) {
        let z = -q.z;
        let pixel = if self.orthographic {
            Vec2::new(0.5 * self.size * (1.0 + q.x / self.a), 0.5 * self.size * (1.0 - q.y / self.b))
        } else {
            Vec2::new(0.5 * self.size + self.a * q.x / z, 0.5 * self.size - self.a * q.y / z)
        };
        (pixel, z)
    }

    /// The reversed-Z depth the rasterizer stores for view depth `z` (`orthographic_clip` and
    /// `perspective_clip` in `common/camera.glsl`, after the divide).
    pub fn stored_depth(&self, z: f32) -> f32 {
        let (n, f) = (self.near, self.far);
        if self.orthographic {
            (f - z) / (f - n)
        } else {
            n * (f - z) / ((f - n) * z)
        }
    }

    /// View depth of a stored reversed-Z depth: the inverse of [`FaceProjection::stored_depth`]
    /// (`shadow_linear_depth` in `common/shadow.glsl`).
    pub fn linear_depth(&self, d: f32) -> f32 {
        let (n, f) = (self.near, self.far);
        if self.orthographic {
            f - d * (f - n)
        } else {
            n * f / (d * (f - n) + n)
        }
    }

    /// One texel's width at view depth `z`, in view units.
    pub fn texel(&self, z: f32) -> f32 {
        if self.orthographic {
            2.0 * self.a / self.size
        } else {
            z / self.a
        }
    }
}

/// Below this cosine between a receiver's plane and the light's rays, the plane counts as parallel to
/// them ([`FaceProjection::plane_depth`]): a bound on its slope, so the depth stays finite.
pub const MIN_PLANE_COS: f32 = 1e-4;

/// Where the rasterizer takes sample `k` of `msaa` within a texel (x right, y down, in texels): the
/// standard sample locations for 1, 2, 4 and 8 samples; the centre for other counts (whose
/// locations the lookup does not know; the depth slack has to cover those).
pub fn sample_position(msaa: u32, k: u32) -> Vec2 {
    const TWO: [[f32; 2]; 2] = [[0.75, 0.75], [0.25, 0.25]];
    const FOUR: [[f32; 2]; 4] = [[0.375, 0.125], [0.875, 0.375], [0.125, 0.625], [0.625, 0.875]];
    const EIGHT: [[f32; 2]; 8] = [
        [0.5625, 0.3125],
        [0.4375, 0.6875],
        [0.8125, 0.5625],
        [0.3125, 0.1875],
        [0.1875, 0.8125],
        [0.0625, 0.4375],
        [0.6875, 0.9375],
        [0.9375, 0.0625],
    ];
    let table: &[[f32; 2]] = match msaa {
        2 => &TWO,
        4 => &FOUR,
        8 => &EIGHT,
        _ => &[[0.5, 0.5]],
    };
    Vec2::from(table[k as usize % table.len()])
}

/// The PCF filter along one axis, at map coordinate `x` (texels) with radius `r`: a box of `2r + 1`
/// texels centred on `x` over the map read as constant within each texel. Returns its first texel
/// and the fraction `f` of that texel outside the box: the 2r + 2 taps from there weigh `1 − f`,
/// 1 (2r times) and `f` ([`pcf_weight`]), in all 2r + 1, and their centres average to `x`.
pub fn pcf_axis(x: f32, r: u32) -> (i32, f32) {
    let lo = x - (r as f32 + 0.5);
    let first = lo.floor();
    (first as i32, lo - first)
}

/// The weight of tap `k` (0 to 2r + 1) of the filter [`pcf_axis`] returned `f` for.
pub fn pcf_weight(k: u32, r: u32, f: f32) -> f32 {
    if k == 0 {
        1.0 - f
    } else if k == 2 * r + 1 {
        f
    } else {
        1.0
    }
}

impl FaceProjection {
    /// View depth, along the light's ray through map position `t` (texels, x right, y down), of the
    /// plane through view-space point `q` with normal `m` (either orientation, any length; zero: the
    /// plane facing the light); infinite where that ray does not meet the plane in front of the
    /// light. A plane within [`MIN_PLANE_COS`] of the rays is tilted to that bound.
    pub fn plane_depth(&self, q: Vec3, m: Vec3, t: Vec2) -> f32 {
        if self.orthographic {
            let m = m.try_normalize().unwrap_or(Vec3::Z);
            let m = if m.z < 0.0 { -m } else { m };
            let x = (2.0 * t.x / self.size - 1.0) * self.a;
            let y = (1.0 - 2.0 * t.y / self.size) * self.b;
            -q.z + (m.x * (x - q.x) + m.y * (y - q.y)) / m.z.max(MIN_PLANE_COS)
        } else {
            let m = m.try_normalize().unwrap_or(-q);
            // Facing the light (the origin): m·q ≤ 0, so the ray meets the plane where m·d < 0.
            let m = if m.dot(q) > 0.0 { -m } else { m };
            let d = Vec3::new((t.x - 0.5 * self.size) / self.a, -(t.y - 0.5 * self.size) / self.a, -1.0);
            let den = m.dot(d);
            if den < -MIN_PLANE_COS * d.length() {
                m.dot(q) / den
            } else {
                f32::INFINITY
            }
        }
    }

    /// The plane through view-space point `q` with normal `m` (as [`FaceProjection::plane_depth`])
    /// in the depth the rasterizer stores ([`FaceProjection::stored_depth`]), which for a plane is
    /// an affine function of the map position in both projections (the reversed-Z depth is affine in
    /// `1/z`, and `1/z` of a plane is affine along the rays): `q`'s map position, its stored depth
    /// and the gradient per texel. Agrees with `stored_depth(plane_depth(..))` wherever the ray
    /// meets the plane in front of the light; beyond, it falls below the stored depth of any
    /// point, as an infinitely far plane would.
    pub fn stored_plane(&self, q: Vec3, m: Vec3) -> (Vec2, f32, Vec2) {
        let (pixel, z) = self.project(q);
        let (n, f) = (self.near, self.far);
        let gradient = if self.orthographic {
            let m = m.try_normalize().unwrap_or(Vec3::Z);
            let m = if m.z < 0.0 { -m } else { m };
            // z = z_q + (m.x·ΔX + m.y·ΔY)/m.z with ΔX = 2a/size and ΔY = −2b/size per texel.
            Vec2::new(-m.x * 2.0 * self.a / self.size, m.y * 2.0 * self.b / self.size)
                / (m.z.max(MIN_PLANE_COS) * (f - n))
        } else {
            let m = m.try_normalize().unwrap_or(-q);
            let m = if m.dot(q) > 0.0 { -m } else { m };
            // 1/z = m·d(t) / m·q with d(t) = ((t.x − size/2)/a, −(t.y − size/2)/a, −1).
            let mq = m.dot(q).min(-MIN_PLANE_COS * q.length());
            Vec2::new(m.x, -m.y) * (n * f / ((f - n) * self.a * mq))
        };
        (pixel, self.stored_depth(z), gradient)
    }

    /// How much the stored depth changes per view unit at view depth `z` (its magnitude).
    pub fn stored_per_view(&self, z: f32) -> f32 {
        let (n, f) = (self.near, self.far);
        if self.orthographic {
            1.0 / (f - n)
        } else {
            n * f / ((f - n) * z * z)
        }
    }

    /// The fraction of the light the map lets through to a receiver at view-space point `q` of a
    /// surface with geometric normal `m` (`shadow_light` in `common/shadow.glsl`, one sub-map of
    /// `msaa` samples per texel): over the PCF taps around its map position ([`pcf_axis`]), the
    /// weighted fraction of depth samples that are not nearer the light than the receiver's plane at
    /// that sample's position ([`FaceProjection::stored_plane`]) — where the plane recedes beyond the
    /// receiver, than the receiver itself — less `depth_bias` texels. The plane is what keeps a
    /// surface from shadowing itself where it comes nearer the light than the receiver; where it
    /// recedes, the receiver's own depth suffices, and a surface behind the receiver but in front
    /// of its plane's extension (a wall standing on a grazing-lit ground) does not shadow it. The
    /// comparisons are in stored (reversed-Z: nearer is larger) depth, where the plane is affine.
    /// `depth(texel, k)` is the stored depth of sample k of a texel (`None`: nothing drawn there);
    /// taps past the map's edge read its edge texels.
    pub fn lookup(
        &self,
        q: Vec3,
        m: Vec3,
        r: u32,
        msaa: u32,
        depth_bias: f32,
        depth: impl Fn([i32; 2], u32) -> Option<f32>,
    ) -> f32 {
        let (pixel, d_q, gradient) = self.stored_plane(q, m);
        let z = -q.z;
        let slack = depth_bias * self.texel(z) * self.stored_per_view(z);
        let (fx, wx) = pcf_axis(pixel.x, r);
        let (fy, wy) = pcf_axis(pixel.y, r);
        let last = self.size as i32 - 1;
        let (mut lit, mut total) = (0.0, 0.0);
        for k in 0..msaa {
            let s = sample_position(msaa, k);
            for j in 0..2 * r + 2 {
                for i in 0..2 * r + 2 {
                    let w = pcf_weight(i, r, wx) * pcf_weight(j, r, wy);
                    if w <= 0.0 {
                        continue;
                    }
                    let t = [(fx + i as i32).clamp(0, last), (fy + j as i32).clamp(0, last)];
                    let at = Vec2::new(t[0] as f32, t[1] as f32) + s;
                    let bound = (d_q + gradient.dot(at - pixel)).max(d_q) + slack;
                    total += w;
                    if !matches!(depth(t, k), Some(d) if d > bound) {
                        lit += w;
                    }
                }
            }
        }
        lit / total
    }
}

/// The seed of one light face's coverage decisions in pass `pass` (0 when maps are rendered once):
/// different faces and passes draw independent masks.
pub fn map_seed(coverage_seed: u32, face: u32, pass: u32) -> u32 {
    use crate::transparency::hash32;
    hash32(coverage_seed ^ hash32(face.wrapping_mul(0x9e37_79b9) ^ hash32(pass ^ 0x5f35_6495)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::builtin::builtin_scene;
    use crate::scene::view::cube_face_of;
    use proptest::prelude::*;

    fn lit_scene(light: Light) -> Scene {
        let mut s = builtin_scene("default").expect("built-in").expect("parses");
        s.lights = vec![light];
        s
    }

    #[test]
    fn settings_parse_and_refuse_bad_values() {
        let s: ShadowSettings = "512/16/2".parse().unwrap();
        assert_eq!((s.size, s.samples, s.pcf_radius), (512, 16, 2));
        assert_eq!("256".parse::<ShadowSettings>().unwrap().size, 256);
        for bad in ["", "0", "abc", "512/0", "512/4/99", "1/2/3/4", "512//1", "99999"] {
            assert!(bad.parse::<ShadowSettings>().is_err(), "{bad}");
        }
        assert_eq!(
            ShadowSettings::default().to_string().parse::<ShadowSettings>().unwrap(),
            ShadowSettings::default()
        );
    }

    #[test]
    fn the_kind_follows_the_casters() {
        let mut s = lit_scene(Light::Directional { direction: -Vec3::Y, color: Vec3::ONE, shadows: true });
        assert_eq!(ShadowKind::for_scene(&s), ShadowKind::Plain);
        // A tint on an opaque surface changes nothing.
        s.objects[0].material.tint = Vec3::new(1.0, 0.5, 0.5);
        assert_eq!(ShadowKind::for_scene(&s), ShadowKind::Plain);
        s.objects[1].material.alpha = 0.5;
        assert_eq!(ShadowKind::for_scene(&s), ShadowKind::Stochastic);
        s.objects[0].material.alpha = 0.5;
        assert_eq!(ShadowKind::for_scene(&s), ShadowKind::Colored);
    }

    #[test]
    fn plans_one_face_per_light_or_six_for_a_cube_in_one_atlas() {
        let mut s =
            lit_scene(Light::Point { position: Vec3::new(0.0, 3.0, 0.0), color: Vec3::ONE, shadows: true });
        s.lights.push(Light::Directional { direction: -Vec3::Y, color: Vec3::ONE, shadows: true });
        s.lights.push(Light::Directional { direction: Vec3::X, color: Vec3::ONE, shadows: false });
        s.lights.push(Light::Spot {
            position: Vec3::new(0.0, 3.0, 2.0),
            direction: -Vec3::Y,
            inner_deg: 10.0,
            outer_deg: 25.0,
            color: Vec3::ONE,
            shadows: true,
        });
        s.objects[0].material.alpha = 0.5;
        let settings = ShadowSettings { size: 64, samples: 8, ..ShadowSettings::default() };
        let plan = ShadowPlan::new(&s, &settings, &[1, 4]).unwrap().expect("shadows");
        assert_eq!((plan.kind, plan.msaa, plan.sub_maps, plan.samples()), (ShadowKind::Stochastic, 4, 2, 8));
        assert_eq!(
            plan.lights.iter().map(|l| (l.light, l.faces.len())).collect::<Vec<_>>(),
            [(0, 6), (1, 1), (3, 1)]
        );
        // Tiles are disjoint and inside the atlas.
        let mut tiles = vec![];
        for f in plan.lights.iter().flat_map(|l| &l.faces) {
            for j in 0..plan.sub_maps {
                let (x, y) = (f.origin[0] + j * 64, f.origin[1]);
                assert!(x + 64 <= plan.atlas.0 && y + 64 <= plan.atlas.1);
                tiles.push((x, y));
            }
        }
        let n = tiles.len();
        tiles.sort();
        tiles.dedup();
        assert_eq!(tiles.len(), n);
        // Shadows off, or no shadow-casting light: no plan.
        let off = ShadowSettings { enabled: false, ..settings };
        assert!(ShadowPlan::new(&s, &off, &[1, 4]).unwrap().is_none());
        s.lights.retain(|l| !l.shadows());
        assert!(ShadowPlan::new(&s, &settings, &[1, 4]).unwrap().is_none());
    }

    #[test]
    fn an_atlas_too_large_is_refused() {
        let s =
            lit_scene(Light::Point { position: Vec3::new(0.0, 3.0, 0.0), color: Vec3::ONE, shadows: true });
        let mut s2 = s.clone();
        s2.objects[0].material.alpha = 0.5;
        let settings = ShadowSettings { size: 8192, samples: 16, ..ShadowSettings::default() };
        let e = ShadowPlan::new(&s2, &settings, &[1, 4]).unwrap_err().to_string();
        assert!(e.contains("shadow atlas") && e.contains("--shadow-map"), "{e}");
    }

    fn projections() -> [FaceProjection; 2] {
        [
            FaceProjection { orthographic: true, a: 3.0, b: 3.0, size: 256.0, near: 0.05, far: 20.0 },
            FaceProjection { orthographic: false, a: 128.0, b: 0.0, size: 256.0, near: 0.05, far: 20.0 },
        ]
    }

    /// The view-space point on the light's ray through map position `t` at view depth `z`.
    fn unproject(p: &FaceProjection, t: Vec2, z: f32) -> Vec3 {
        if p.orthographic {
            Vec3::new((2.0 * t.x / p.size - 1.0) * p.a, (1.0 - 2.0 * t.y / p.size) * p.b, -z)
        } else {
            Vec3::new((t.x - 0.5 * p.size) / p.a * z, -(t.y - 0.5 * p.size) / p.a * z, -z)
        }
    }

    /// A plane tilted `tilt` radians from facing the light, about an axis across the map at `turn`
    /// radians, through the point of map position `t` at depth `z`: (point, normal).
    fn tilted_plane(p: &FaceProjection, t: Vec2, z: f32, tilt: f32, turn: f32) -> (Vec3, Vec3) {
        let q = unproject(p, t, z);
        let towards = if p.orthographic { Vec3::Z } else { -q.normalize() };
        let axis = towards.any_orthonormal_vector();
        let axis = glam::Quat::from_axis_angle(towards, turn) * axis;
        (q, glam::Quat::from_axis_angle(axis, tilt) * towards)
    }

    /// No acne: a plane the map holds, seen as a receiver at any of its points, is lit, at any
    /// slope up to 85°, for both projections, any PCF radius, one sample or four per texel. The map
    /// is the plane as the rasterizer stores it: its depth at each sample's position, found from
    /// three other points of it (another rounding of the same plane).
    #[test]
    fn a_plane_never_shadows_itself() {
        for p in projections() {
            for (tilt_deg, turn_deg) in
                [(0.0f32, 0.0f32), (30.0, 10.0), (60.0, 100.0), (80.0, 45.0), (85.0, 200.0)]
            {
                let (q0, m) = tilted_plane(
                    &p,
                    Vec2::new(131.3, 117.8),
                    5.0,
                    tilt_deg.to_radians(),
                    turn_deg.to_radians(),
                );
                let (u, v) = (m.any_orthonormal_vector(), m.cross(m.any_orthonormal_vector()));
                let (a, b, c) = (q0 + 0.7 * u, q0 - 0.4 * u + 0.5 * v, q0 - 0.3 * v);
                let stored_normal = (b - a).cross(c - a);
                for msaa in [1u32, 4] {
                    let map = |t: [i32; 2], k: u32| {
                        let at = Vec2::new(t[0] as f32, t[1] as f32) + sample_position(msaa, k);
                        let z = p.plane_depth(a, stored_normal, at);
                        z.is_finite().then(|| p.stored_depth(z))
                    };
                    for r in 0..3 {
                        for step in 0..25 {
                            let s = step as f32 * 0.0371;
                            let q = q0 + s * u - 0.6 * s * v;
                            let lit = p.lookup(q, m, r, msaa, DEPTH_BIAS, map);
                            assert_eq!(
                                lit, 1.0,
                                "ortho {} tilt {tilt_deg}° msaa {msaa} r {r} at {q}",
                                p.orthographic
                            );
                        }
                    }
                }
            }
        }
    }

    /// A concave corner under a grazing light: a receiver on a plane 85° from facing the light, with
    /// a surface just behind it (a wall it meets) filling the map where the plane recedes, stays lit.
    #[test]
    fn a_surface_behind_the_receiver_does_not_shadow_it() {
        for p in projections() {
            let (q, m) = tilted_plane(&p, Vec2::new(120.4, 130.7), 5.0, 85f32.to_radians(), 0.3);
            let (_, z) = p.project(q);
            let behind = z + 0.3 * p.texel(z);
            let map = |t: [i32; 2], k: u32| {
                let at = Vec2::new(t[0] as f32, t[1] as f32) + sample_position(4, k);
                Some(p.stored_depth(p.plane_depth(q, m, at).min(behind)))
            };
            for r in 0..3 {
                assert_eq!(p.lookup(q, m, r, 4, DEPTH_BIAS, map), 1.0, "ortho {} r {r}", p.orthographic);
            }
        }
    }

    /// The PCF filter does not move a shadow's edge: across the straight edge of an occluder, on a
    /// receiver tilted 40° from the light, the integral of the light through the lookup equals that
    /// of a sharp step at the map's own edge (the texel boundary nearest the occluder's edge), for
    /// PCF radius 0, 1, 2 and 3.
    #[test]
    fn the_filter_does_not_move_a_shadow_edge() {
        for p in projections() {
            for edge in [100.2f32, 100.5, 100.9] {
                let (q0, m) = tilted_plane(&p, Vec2::new(100.0, 120.0), 5.0, 40f32.to_radians(), 0.0);
                // The occluder, at depth 1, covers the samples left of `edge`.
                let occluder = p.stored_depth(1.0);
                let map =
                    |t: [i32; 2], k: u32| (t[0] as f32 + sample_position(1, k).x < edge).then_some(occluder);
                let map_edge = (edge - 0.5).ceil();
                for r in 0..4 {
                    // Receivers along the map's x, on the plane.
                    let (mut light, mut step_light, n) = (0.0f64, 0.0f64, 4000);
                    for i in 0..n {
                        let x = 90.0 + 20.0 * (i as f32 + 0.5) / n as f32;
                        let t = Vec2::new(x, 120.0);
                        let z = p.plane_depth(q0, m, t);
                        let q = unproject(&p, t, z);
                        assert!((p.project(q).0 - t).length() < 1e-3);
                        light += p.lookup(q, m, r, 1, DEPTH_BIAS, map) as f64;
                        step_light += if x >= map_edge { 1.0 } else { 0.0 };
                    }
                    let moved = (light - step_light) * 20.0 / n as f64;
                    assert!(
                        moved.abs() < 0.01,
                        "ortho {} edge {edge} r {r}: the edge moved {moved} texels",
                        p.orthographic
                    );
                }
            }
        }
    }

    proptest! {
        /// The stored depth of a point linearises back to its view depth, in both projections.
        #[test]
        fn stored_depth_linearises_back(z in 0.05f32..50.0, ortho in any::<bool>()) {
            let p = FaceProjection { orthographic: ortho, a: 300.0, b: 3.0, size: 512.0, near: 0.05, far: 50.0 };
            let back = p.linear_depth(p.stored_depth(z));
            prop_assert!((back - z).abs() <= 2e-3 * z.max(1.0), "{} vs {}", back, z);
        }

        /// The plane's depth along the ray through a map position is that of the plane's point
        /// there, for planes up to 80° from facing the light.
        #[test]
        fn plane_depth_is_the_planes(ortho in any::<bool>(), t in prop::array::uniform2(20.0f32..236.0),
                                     tilt in 0.0f32..80.0, turn in 0.0f32..360.0, s in prop::array::uniform2(-1.0f32..1.0)) {
            let p = projections()[if ortho { 0 } else { 1 }];
            let (q, m) = tilted_plane(&p, Vec2::from(t), 5.0, tilt.to_radians(), turn.to_radians());
            let u = m.any_orthonormal_vector();
            let point = q + 0.5 * s[0] * u + 0.5 * s[1] * m.cross(u);
            let (at, z) = p.project(point);
            prop_assume!(z > 0.5 && at.x.abs() < 1e4 && at.y.abs() < 1e4);
            let got = p.plane_depth(q, m, at);
            prop_assert!((got - z).abs() < 1e-3 * z.max(1.0), "{} vs {}", got, z);
            prop_assert!((p.plane_depth(q, -3.0 * m, at) - got).abs() < 1e-3 * z.max(1.0), "either orientation");
        }

        /// The plane in stored depth is the stored depth of the plane, wherever the ray meets it.
        #[test]
        fn stored_plane_is_the_planes(ortho in any::<bool>(), t in prop::array::uniform2(20.0f32..236.0),
                                      tilt in 0.0f32..80.0, turn in 0.0f32..360.0, at in prop::array::uniform2(-8.0f32..8.0)) {
            let p = projections()[if ortho { 0 } else { 1 }];
            let (q, m) = tilted_plane(&p, Vec2::from(t), 5.0, tilt.to_radians(), turn.to_radians());
            let (pixel, d, gradient) = p.stored_plane(q, m);
            let at = pixel + Vec2::from(at);
            let z = p.plane_depth(q, m, at);
            prop_assume!(z.is_finite() && z > p.near && z < p.far);
            let want = p.stored_depth(z);
            let got = d + gradient.dot(at - pixel);
            prop_assert!((got - want).abs() <= 1e-4 * want.abs().max(1e-3), "{} vs {}", got, want);
        }

        /// The PCF filter is a box of 2r + 1 texels centred on the receiver: its weights sum to
        /// 2r + 1 and the taps' centres average to the receiver's position.
        #[test]
        fn the_filter_is_centred(x in -10.0f32..300.0, r in 0u32..5) {
            let (first, f) = pcf_axis(x, r);
            let (mut sum, mut moment) = (0.0f64, 0.0f64);
            for k in 0..2 * r + 2 {
                let w = pcf_weight(k, r, f) as f64;
                prop_assert!(w >= 0.0);
                sum += w;
                moment += w * (first as f64 + k as f64 + 0.5);
            }
            prop_assert!((sum - (2 * r + 1) as f64).abs() < 1e-5);
            prop_assert!((moment / sum - x as f64).abs() < 1e-4, "{} vs {}", moment / sum, x);
        }

        /// The face `cube_face_of` picks sees the point: its projection lands inside the face, in front
        /// of it, and the face's own view of the world point is `base_to_face` of its lookup position.
        #[test]
        fn cube_faces_see_their_points(d in prop::array::uniform3(-1.0f32..1.0)) {
            let d = Vec3::from(d);
            prop_assume!(d.length() > 1e-3);
            let light = Vec3::new(0.2, 2.5, -0.3);
            let s = lit_scene(Light::Point { position: light, color: Vec3::ONE, shadows: true });
            let (lookup, faces) = cube_views(&s, "l", light, 64).expect("views");
            let world = light + d * 1.7;
            let base = lookup.world_to_view[0].transform_point3(world);
            let k = cube_face_of(base);
            let (face, base_to_face) = &faces[k];
            let q = base_to_face.transform_point3(base);
            let direct = face.world_to_view[0].transform_point3(world);
            prop_assert!((q - direct).length() < 1e-4, "{} vs {}", q, direct);
            let (pixel, z) = FaceProjection::of(face).project(q);
            prop_assert!(z > 0.0);
            prop_assert!(pixel.x >= -1e-3 && pixel.x <= 64.001 && pixel.y >= -1e-3 && pixel.y <= 64.001, "{}", pixel);
        }
    }
}
