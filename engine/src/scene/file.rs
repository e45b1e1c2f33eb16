//! Scene files: TOML (+ OBJ meshes + PNG textures) → a resolved [`Scene`].
//!
//! Paths inside a scene file are relative to the file's folder. Unknown keys are errors naming the
//! key, and every value is validated (finite, in range; a vector or colour exactly three numbers) with
//! an error naming the file and the field.
//!
//! ```toml
//! name = "optional"             # default: the file stem (or the built-in's name)
//!
//! [image]                       # all optional; limits in crate::limits
//! width = 640                   # 1..=8192 (MAX_IMAGE_DIMENSION)
//! height = 360                  # 1..=8192
//! spp = 16                      # 1..=65536 (MAX_SPP)
//! seed = 1                      # ≥ 0
//! exposure = 0.0                # PNG output only: stops (×2^EV) before the tone curve, |EV| ≤ 64
//! tone = "clip"                 # PNG output only: "clip" (above 1 is white), "reinhard" (x / (1 + x)),
//!                               # "aces" (a filmic curve); EXR and every metric stay linear
//!
//! [camera]                      # required
//! position = [0, 1, 6]          # required
//! look_at = [0, 0.5, 0]         # required, ≠ position
//! up = [0, 1, 0]                # default +Y; not parallel to the view direction
//! vfov_deg = 40                 # in [0.001, 180)
//! aperture_radius = 0.0         # lens radius A in scene units (metres), ≥ 0 (0 = pinhole)
//! focus_distance = 6.0          # F > 0, metres along the view axis; default |look_at − position|
//! near = 0.05                   # 1e-9 ≤ near < far (MIN_NEAR)
//! far = 1000                    # far ≤ 1e12 · near (MAX_FAR_OVER_NEAR: the GPU's depth stays ordered)
//! aperture = { shape = "disk" } # or { shape = "blades", blades = 6, rotation_deg = 0 } (blades ≥ 3),
//!                               # or { shape = "smooth-disk" }: transmission falling off smoothly to 0
//!                               # at aperture_radius from 9/11 of it (the AAS paper's smooth lens)
//! shutter = "box"               # or "tent"
//!
//! [camera.close]                # optional: pose at shutter close; each key defaults to the open value
//! position = [0.05, 1, 6]
//! look_at = [0.05, 0.5, 0]
//! up = [0, 1, 0]
//! ```
//!
//! Scene units are **metres**. The camera may instead be given in the terms of a real camera (Blender,
//! Unreal, pbrt), each key in place of the one it stands for — giving both of a pair is an error:
//!
//! ```toml
//! [camera]
//! focal_length_mm = 50          # instead of vfov_deg: vfov = 2·atan(sensor height / (2·focal length))
//! sensor_width_mm = 36          # default 36 (full frame); the sensor has [image]'s aspect ratio, so its
//!                               # height is width × height / width of [image] (kept if --size changes it)
//! # sensor_height_mm = 24       # or the height itself (not both)
//! f_stop = 2.8                  # instead of aperture_radius: A = focal length / (2·f_stop), in metres
//!                               # (50 mm at f/2.8: A = 0.00893); needs focal_length_mm
//! shutter_angle_deg = 180       # the shutter is open for this part of the frame, from its start
//! # shutter_interval = [0.25, 0.75]  # or open and close as fractions of the frame, 0 ≤ open < close ≤ 1
//! ```
//!
//! With `shutter_angle_deg` or `shutter_interval`, `[camera.close]` and every object's
//! `transform_close`, `transform_key` times and `motion_keys` describe the whole frame (0 = its start,
//! 1 = its end, as pbrt's transform times) and the motion is cut to the part the shutter sees: the
//! camera's position, look_at and up, and each object's transform between its keys, taken linearly in
//! frame time (`motion_keys` are spread over the open shutter). `shutter_angle_deg = 360` is the same
//! scene as none. For a camera that stands still or moves without turning (position and look_at
//! shifted alike) this is exactly the model's camera-space motion over the frame, cut; for one that
//! turns it is an approximation of it.
//!
//! ```toml
//! [[object]]                    # any number
//! name = "spot"                 # default "object<i>" (i counts from 0)
//! mesh = "spot"                 # built-in: plane, box, sphere, displaced-sphere, spot — or an .obj path
//! detail = 3                    # optional tessellation level of procedural meshes; for `spot`,
//!                               # rounds of midpoint subdivision (0..=3, default 0: 5,856 triangles)
//! normalize = false             # OBJ only: fit into [-1, 1]³ centred at the origin
//! simplify = 0.5                # optional, in (0, 1]: keep about this fraction of the triangles
//!                               # (meshoptimizer's simplifier, see Mesh::simplified; default 1 = all)
//! [object.transform]            # optional; matrix T · Rz · Ry · Rx · S
//! translate = [0, 0, 0]
//! rotate_deg = [0, 0, 0]        # degrees about X, then Y, then Z
//! scale = 1.0                   # a number or [x, y, z]; no component 0
//! [object.transform_close]      # optional: same keys, the transform at shutter close
//! motion_keys = 8               # optional, 2..=64 (MAX_MOTION_KEYS), needs transform_close: the motion
//!                               # sampled at this many evenly spaced times, translate, rotate_deg and
//!                               # scale each interpolated linearly, so a rotation turns instead of
//!                               # collapsing through its centre (default 2: linear in camera space)
//! [[object.transform_key]]      # optional, any number (not with motion_keys): a key between the ends
//! time = 0.5                    # in (0, 1), increasing from key to key
//! translate = [0, 0, 0]         # rotate_deg, scale as in [object.transform]
//! [object.material]             # optional
//! albedo = [0.8, 0.8, 0.8]      # linear RGB in [0, 1e6]; default 0.8, or 1 when there is a texture
//! texture = "spot.png"          # PNG path, or a built-in: "spot" (Spot's), "leaves" (generated
//!                               # foliage), "checker" (generated 8×8 chess board squares)
//! specular = 0.0                # ≥ 0
//! roughness = 0.5               # in (0, 1]
//! alpha = 1.0                   # coverage, in [0, 1] (1 = opaque)
//! alpha_from_texture = false    # true: coverage = alpha × the texture's alpha channel (needs texture)
//! tint = [1, 1, 1]              # transmission of the uncovered part, each in [0, 1]: the surface
//!                               # composites as alpha·C + (1 − alpha)·tint·behind (docs/TRANSPARENCY.md)
//! one_sided = false             # true: camera rays see only the front (counter-clockwise on the
//!                               # image); the back is culled, shadows come from both sides
//!
//! [[light]]                     # any number
//! type = "directional"          # direction = [x, y, z] (from the light into the scene), color = [r, g, b]
//! # type = "point"              # position = [x, y, z], color = [r, g, b] (falls off with 1/d²)
//! # type = "spot"               # position, direction (the cone's axis, into the scene), color (1/d²),
//!                               # inner_angle_deg, outer_angle_deg: cone half-angles, 0 ≤ inner ≤
//!                               # outer ≤ 90, full light inside inner, none outside outer, a
//!                               # smoothstep of cos θ between (crate::shading)
//! shadows = false               # any type: true = surfaces in between attenuate the light by their
//!                               # transmittance (the CPU reference; GPU techniques refuse it for now)
//!
//! [environment]                 # optional
//! ambient = [0.05, 0.05, 0.05]
//! background = [0, 0, 0]
//! indirect = "none"             # or "one-bounce": the direct lights' light reflected diffusely once
//!                               # more (scene::Indirect; the CPU reference; GPU techniques ignore it
//!                               # for now and say so)
//! ```
//!
//! Numeric extremes follow one rule (`scene::extremes`): every vertex placed by every transform key,
//! and the camera's and lights' positions, within ±1e9 scene units (MAX_COORDINATE); light colours,
//! albedo, specular, ambient and background in [0, 1e6] (MAX_COLOR); beyond them the techniques stop
//! agreeing, so the file is refused naming the object or light. OBJ normals of any finite length are
//! directions (normalised in f64); a zero or non-finite one takes its vertex's face normal.
//!
//! Meshes and textures referenced by several objects are loaded once and shared (a mesh per distinct
//! `mesh`, `detail`, `normalize` and `simplify`).

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use glam::{Mat4, Vec3};
use serde::Deserialize;

use super::builtin::{builtin_mesh, builtin_scene, builtin_texture, BUILTIN_MESHES, BUILTIN_SCENES};
use super::mesh::{load_obj, Mesh};
use super::texture::{load_texture, Texture};
use super::{Camera, CameraPose, Environment, ImageSettings, Light, Material, Object, Scene};
use crate::error::{Error, Result};
use crate::sampling::{ApertureShape, ShutterCurve};

use super::validate::{num, num64, object_field, printable, vec_text, Check};
use crate::limits::{quote_safely, MAX_IMAGE_DIMENSION, MAX_MOTION_KEYS, MAX_SPP};

/// A vector or colour `[x, y, z]` as the file wrote it: the first three numbers and how many there
/// were, so that [`Ctx::vec3`] — the one place every vector passes — refuses any other length naming
/// the field (serde's own `[f32; 3]` stops reading after three and ignores the rest).
#[derive(Clone, Copy, Debug)]
struct V3 {
    xyz: [f32; 3],
    len: usize,
}

impl From<[f32; 3]> for V3 {
    fn from(xyz: [f32; 3]) -> Self {
        V3 { xyz, len: 3 }
    }
}

/// One number of a vector (an integer or a float); anything else is "expected a number".
struct Number(f32);

impl<'de> Deserialize<'de> for Number {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
        d.deserialize_any(NumberVisitor).map(Number)
    }
}

struct NumberVisitor;

impl serde::de::Visitor<'_> for NumberVisitor {
    type Value = f32;
    fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        f.write_str("a number")
    }
    fn visit_f64<E>(self, x: f64) -> std::result::Result<f32, E> {
        Ok(x as f32)
    }
    fn visit_i64<E>(self, x: i64) -> std::result::Result<f32, E> {
        Ok(x as f32)
    }
    fn visit_u64<E>(self, x: u64) -> std::result::Result<f32, E> {
        Ok(x as f32)
    }
}

/// Reads every element of an array of numbers: the first three and the count.
fn read_v3<'de, A: serde::de::SeqAccess<'de>>(mut seq: A) -> std::result::Result<V3, A::Error> {
    let mut v = V3 { xyz: [0.0; 3], len: 0 };
    while let Some(Number(x)) = seq.next_element()? {
        if v.len < 3 {
            v.xyz[v.len] = x;
        }
        v.len += 1;
    }
    Ok(v)
}

impl<'de> Deserialize<'de> for V3 {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
        struct Visitor;
        impl<'de> serde::de::Visitor<'de> for Visitor {
            type Value = V3;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("an array of 3 numbers [x, y, z]")
            }
            fn visit_seq<A: serde::de::SeqAccess<'de>>(self, seq: A) -> std::result::Result<V3, A::Error> {
                read_v3(seq)
            }
        }
        d.deserialize_seq(Visitor)
    }
}

#[derive(Deserialize)]
#[serde(
    deny_unknown_fields,
    expecting = "a scene: tables [image], [camera], [[object]], [[light]], [environment]"
)]
struct FileScene {
    name: Option<String>,
    #[serde(default)]
    image: FileImage,
    camera: FileCamera,
    #[serde(default)]
    object: Vec<FileObject>,
    #[serde(default)]
    light: Vec<FileLight>,
    environment: Option<FileEnvironment>,
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields, expecting = "a table [image] (width, height, spp, seed, exposure, tone)")]
struct FileImage {
    width: Option<i64>,
    height: Option<i64>,
    spp: Option<i64>,
    seed: Option<i64>,
    exposure: Option<f32>,
    tone: Option<String>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields, expecting = "a table [camera] (position, look_at, …)")]
struct FileCamera {
    position: V3,
    look_at: V3,
    up: Option<V3>,
    vfov_deg: Option<f32>,
    aperture_radius: Option<f32>,
    focus_distance: Option<f32>,
    near: Option<f32>,
    far: Option<f32>,
    aperture: Option<FileAperture>,
    shutter: Option<FileShutterCurve>,
    close: Option<FilePose>,
    // The photographic spelling (one or the other of each pair; resolve_camera).
    focal_length_mm: Option<f32>,
    sensor_width_mm: Option<f32>,
    sensor_height_mm: Option<f32>,
    f_stop: Option<f32>,
    shutter_angle_deg: Option<f32>,
    shutter_interval: Option<Vec<Number>>,
}

/// `shutter = "box" | "tent"`: the curve. An array there is someone giving the open interval, which
/// has keys of its own.
struct FileShutterCurve(ShutterCurve);

impl<'de> Deserialize<'de> for FileShutterCurve {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
        struct Visitor;
        impl<'de> serde::de::Visitor<'de> for Visitor {
            type Value = FileShutterCurve;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("the shutter curve, \"box\" or \"tent\"")
            }
            fn visit_str<E: serde::de::Error>(self, v: &str) -> std::result::Result<FileShutterCurve, E> {
                match v {
                    "box" => Ok(FileShutterCurve(ShutterCurve::Box)),
                    "tent" => Ok(FileShutterCurve(ShutterCurve::Tent)),
                    other => Err(E::unknown_variant(other, &["box", "tent"])),
                }
            }
            fn visit_seq<A: serde::de::SeqAccess<'de>>(
                self,
                _: A,
            ) -> std::result::Result<FileShutterCurve, A::Error> {
                Err(serde::de::Error::custom(
                    "`shutter` is the shutter curve, \"box\" or \"tent\"; give the part of the frame the \
                     shutter is open as shutter_interval = [open, close] or shutter_angle_deg",
                ))
            }
        }
        d.deserialize_any(Visitor)
    }
}

/// `aperture = { shape = … }`. Every shape is a table variant so that a key the shape does not take
/// (`{ shape = "disk", blades = 6 }`) is an error: serde ignores extra keys beside a unit variant's tag.
#[derive(Deserialize)]
#[serde(
    tag = "shape",
    rename_all = "kebab-case",
    deny_unknown_fields,
    expecting = "a table { shape = \"disk\" }, { shape = \"blades\", blades = N } or { shape = \"smooth-disk\" }"
)]
enum FileAperture {
    Disk {},
    Blades {
        blades: u32,
        #[serde(default)]
        rotation_deg: f32,
    },
    SmoothDisk {},
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields, expecting = "a table [camera.close] (position, look_at, up)")]
struct FilePose {
    position: Option<V3>,
    look_at: Option<V3>,
    up: Option<V3>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields, expecting = "a table [[object]] (name, mesh, transform, material, …)")]
struct FileObject {
    name: Option<String>,
    mesh: String,
    detail: Option<u32>,
    #[serde(default)]
    normalize: bool,
    simplify: Option<f32>,
    transform: Option<FileTransform>,
    transform_close: Option<FileTransform>,
    motion_keys: Option<u32>,
    #[serde(default)]
    transform_key: Vec<FileTransformKey>,
    material: Option<FileMaterial>,
}

#[derive(Deserialize)]
#[serde(
    deny_unknown_fields,
    expecting = "a table [[object.transform_key]] (time, translate, rotate_deg, scale)"
)]
struct FileTransformKey {
    /// As written (an `f64`): a time that is in range but rounds to a neighbour in the model's `f32`
    /// is refused saying so, with the value the file wrote.
    time: f64,
    translate: Option<V3>,
    rotate_deg: Option<V3>,
    scale: Option<FileScale>,
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields, expecting = "a table of translate, rotate_deg and scale")]
struct FileTransform {
    translate: Option<V3>,
    rotate_deg: Option<V3>,
    scale: Option<FileScale>,
}

/// `scale`: one number for every axis or `[x, y, z]`.
enum FileScale {
    Uniform(f32),
    PerAxis(V3),
}

impl<'de> Deserialize<'de> for FileScale {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
        struct Visitor;
        impl<'de> serde::de::Visitor<'de> for Visitor {
            type Value = FileScale;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a number or an array of 3 numbers [x, y, z]")
            }
            fn visit_f64<E>(self, x: f64) -> std::result::Result<FileScale, E> {
                Ok(FileScale::Uniform(x as f32))
            }
            fn visit_i64<E>(self, x: i64) -> std::result::Result<FileScale, E> {
                Ok(FileScale::Uniform(x as f32))
            }
            fn visit_u64<E>(self, x: u64) -> std::result::Result<FileScale, E> {
                Ok(FileScale::Uniform(x as f32))
            }
            fn visit_seq<A: serde::de::SeqAccess<'de>>(
                self,
                seq: A,
            ) -> std::result::Result<FileScale, A::Error> {
                read_v3(seq).map(FileScale::PerAxis)
            }
        }
        d.deserialize_any(Visitor)
    }
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields, expecting = "a table [object.material] (albedo, texture, specular, …)")]
struct FileMaterial {
    albedo: Option<V3>,
    texture: Option<String>,
    specular: Option<f32>,
    roughness: Option<f32>,
    alpha: Option<f32>,
    alpha_from_texture: Option<bool>,
    tint: Option<V3>,
    one_sided: Option<bool>,
}

#[derive(Deserialize)]
#[serde(
    tag = "type",
    rename_all = "lowercase",
    deny_unknown_fields,
    expecting = "a table [[light]] with type = \"directional\", \"point\" or \"spot\""
)]
enum FileLight {
    Directional {
        direction: V3,
        color: V3,
        #[serde(default)]
        shadows: bool,
    },
    Point {
        position: V3,
        color: V3,
        #[serde(default)]
        shadows: bool,
    },
    Spot {
        position: V3,
        direction: V3,
        color: V3,
        inner_angle_deg: f32,
        outer_angle_deg: f32,
        #[serde(default)]
        shadows: bool,
    },
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields, expecting = "a table [environment] (ambient, background, indirect)")]
struct FileEnvironment {
    ambient: Option<V3>,
    background: Option<V3>,
    indirect: Option<String>,
}

/// Loads a scene file. Paths inside it are relative to its folder; the scene is named after the file
/// stem unless the file sets `name`.
pub fn load_scene_file(path: &Path) -> Result<Scene> {
    let bytes = crate::limits::read_capped(
        path,
        crate::limits::MAX_SCENE_FILE_BYTES,
        "scene file",
        "MAX_SCENE_FILE_BYTES",
    )?;
    let text = String::from_utf8(bytes).map_err(|e| {
        Error::scene(
            path.display().to_string(),
            format!("not UTF-8 text (a byte that is not UTF-8 at offset {})", e.utf8_error().valid_up_to()),
        )
    })?;
    let base_dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
    let stem = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "scene".into());
    parse_with_source(&text, &base_dir, &stem, &path.display().to_string())
}

/// Parses scene TOML; relative paths are resolved against `base_dir`, `name` is the scene's name unless
/// the text sets one.
pub fn parse_scene(text: &str, base_dir: &Path, name: &str) -> Result<Scene> {
    parse_with_source(text, base_dir, name, &format!("scene `{name}`"))
}

/// A built-in scene name (see [`BUILTIN_SCENES`]) or the path of a scene file.
pub fn load_scene(spec: &str) -> Result<Scene> {
    if let Some(scene) = builtin_scene(spec) {
        return scene;
    }
    let path = Path::new(spec);
    if path.is_file() {
        return load_scene_file(path);
    }
    Err(Error::scene(
        spec,
        format!(
            "not a built-in scene ({}) and no such scene file",
            BUILTIN_SCENES.iter().map(|s| format!("`{s}`")).collect::<Vec<_>>().join(", ")
        ),
    ))
}

/// Validation helpers that name the source and the field.
struct Ctx<'a> {
    source: &'a str,
}

impl Ctx<'_> {
    /// The model's checks ([`Scene::validate`]), naming this file.
    fn check(&self) -> Check<'_> {
        Check { source: self.source }
    }
    fn err(&self, field: &str, message: impl std::fmt::Display) -> Error {
        self.check().err(field, message)
    }
    fn finite(&self, field: &str, x: f32) -> Result<f32> {
        self.check().finite(field, x)
    }
    /// The one place a file's vector becomes a [`Vec3`]: exactly three finite numbers.
    fn vec3(&self, field: &str, v: V3) -> Result<Vec3> {
        if v.len != 3 {
            return Err(self.err(field, format!("expected 3 numbers [x, y, z], got {}", v.len)));
        }
        self.check().vec3(field, Vec3::from_array(v.xyz))
    }
    fn range(&self, field: &str, x: f32, ok: bool, expected: &str) -> Result<f32> {
        self.check().range(field, x, ok, expected)
    }
    fn limit(
        &self,
        what: &'static str,
        value: Option<i64>,
        default: u32,
        max: u32,
        name: &str,
    ) -> Result<u32> {
        let v = value.unwrap_or(default as i64);
        if (1..=max as i64).contains(&v) {
            Ok(v as u32)
        } else {
            Err(Error::Limit {
                what,
                value: v.to_string(),
                limit: format!("must be in 1..={max} ({name}) in {}", self.source),
            })
        }
    }
}

/// A TOML error on one line: where, what, and at most a fragment of the line it is on (the parser's
/// own report quotes the whole line — 100 MB of a hostile file — over several lines).
fn toml_error(text: &str, e: &toml::de::Error) -> String {
    // The parser's message can quote a value (a string of the file): at most 400 characters of it.
    let what = quote_safely(&e.message().trim().replace('\n', "; "), 400);
    let Some(span) = e.span() else { return format!("invalid scene TOML: {what}") };
    let start = span.start.min(text.len());
    let start = (0..=start).rev().find(|&i| text.is_char_boundary(i)).unwrap_or(0);
    let line_start = text[..start].rfind('\n').map_or(0, |i| i + 1);
    let line = text[..start].matches('\n').count() + 1;
    let column = text[line_start..start].chars().count() + 1;
    let line_end = text[start..].find('\n').map_or(text.len(), |i| start + i);
    // Up to 40 characters before the error and 60 from it (MAX_QUOTED_LINE_CHARS in all).
    let before: Vec<char> = text[line_start..start].chars().rev().take(40).collect();
    let before: String = before.into_iter().rev().collect();
    let after: String = text[start..line_end].chars().take(60).collect();
    let cut = |whole: usize, shown: usize| if whole > shown { "…" } else { "" };
    let fragment =
        format!("{}{before}{after}{}", cut(column - 1, 40), cut(text[start..line_end].chars().count(), 60));
    let fragment = quote_safely(fragment.trim_end(), crate::limits::MAX_QUOTED_LINE_CHARS + 2);
    format!("invalid scene TOML at line {line}, column {column}: {what} (at `{fragment}`)")
}

/// `[image] exposure` and `tone`: the PNG output's display transform ([`crate::tonemap`]).
fn image_display(cx: &Ctx, image: &FileImage) -> Result<crate::tonemap::Display> {
    use crate::tonemap::{exposure_in_range, Display, ToneCurve, MAX_EXPOSURE_EV};
    let exposure_ev = match image.exposure {
        None => 0.0,
        Some(ev) => {
            let ev = cx.finite("image.exposure", ev)?;
            let expected = format!("stops in [-{MAX_EXPOSURE_EV}, {MAX_EXPOSURE_EV}]");
            cx.range("image.exposure", ev, exposure_in_range(ev), &expected)?
        }
    };
    let curve = match image.tone.as_deref() {
        None => ToneCurve::default(),
        Some(name) => ToneCurve::parse(name).map_err(|e| cx.err("image.tone", e))?,
    };
    Ok(Display { exposure_ev, curve })
}

fn parse_with_source(text: &str, base_dir: &Path, default_name: &str, source: &str) -> Result<Scene> {
    let file: FileScene = toml::from_str(text).map_err(|e| Error::scene(source, toml_error(text, &e)))?;
    let cx = Ctx { source };

    let image = ImageSettings {
        width: cx.limit("image.width", file.image.width, 640, MAX_IMAGE_DIMENSION, "MAX_IMAGE_DIMENSION")?,
        height: cx.limit(
            "image.height",
            file.image.height,
            360,
            MAX_IMAGE_DIMENSION,
            "MAX_IMAGE_DIMENSION",
        )?,
        spp: cx.limit("image.spp", file.image.spp, 16, MAX_SPP, "MAX_SPP")?,
        seed: match file.image.seed {
            None => 1,
            Some(s) if s >= 0 => s as u64,
            Some(s) => return Err(cx.err("image.seed", format!("{s} is negative"))),
        },
        display: image_display(&cx, &file.image)?,
    };

    cx.check().image(&image)?;
    let (camera, shutter) = resolve_camera(&cx, &file.camera, &image)?;
    cx.check().camera(&camera)?;

    // Keyed by everything that shapes the mesh; the simplify fraction by its bits.
    let mut meshes: HashMap<(String, Option<u32>, bool, u32), Arc<Mesh>> = HashMap::new();
    let mut textures: HashMap<String, Arc<Texture>> = HashMap::new();
    let mut mesh_bytes = 0u64;
    let mut objects = Vec::with_capacity(file.object.len());
    for (i, o) in file.object.iter().enumerate() {
        // Control characters (an ANSI escape) are kept escaped: names reach terminals and tables.
        let name = o.name.as_deref().map_or_else(|| format!("object{i}"), printable);
        let field = object_field(i, &name);
        let simplify = o.simplify.unwrap_or(1.0);
        cx.range(&format!("{field}.simplify"), simplify, simplify > 0.0 && simplify <= 1.0, "in (0, 1]")?;
        let key = (o.mesh.clone(), o.detail, o.normalize, simplify.to_bits());
        let mesh = match meshes.get(&key) {
            Some(m) => m.clone(),
            None => {
                let full = resolve_mesh(&cx, &field, base_dir, o)?;
                let m =
                    Arc::new(full.simplified(simplify).map_err(|e| cx.err(&format!("{field}.simplify"), e))?);
                // Distinct meshes add up: refuse once they exceed the memory limit, before the next.
                mesh_bytes += m.heap_bytes();
                crate::limits::check_memory(
                    &format!("the meshes of {source} up to {field}"),
                    mesh_bytes,
                    &format!("{} distinct mesh(es)", meshes.len() + 1),
                )?;
                meshes.insert(key, m.clone());
                m
            }
        };
        let transforms = resolve_motion(&cx, &field, o, shutter)?;
        let material = resolve_material(
            &cx,
            &format!("{field}.material"),
            base_dir,
            o.material.as_ref().unwrap_or(&FileMaterial::default()),
            &mut textures,
        )?;
        let object = Object { name, mesh, transforms, material };
        cx.check().object(i, &object)?;
        objects.push(object);
    }

    let mut lights = Vec::with_capacity(file.light.len());
    for (i, l) in file.light.iter().enumerate() {
        let direction_of = |direction: V3| -> Result<Vec3> {
            let field = format!("light[{i}].direction");
            let d = cx.vec3(&field, direction)?;
            d.try_normalize().ok_or_else(|| cx.err(&field, "must not be zero"))
        };
        let color = |c: V3| cx.vec3(&format!("light[{i}].color"), c);
        let light = match *l {
            FileLight::Directional { direction, color: c, shadows } => {
                Light::Directional { direction: direction_of(direction)?, color: color(c)?, shadows }
            }
            FileLight::Point { position, color: c, shadows } => Light::Point {
                position: cx.vec3(&format!("light[{i}].position"), position)?,
                color: color(c)?,
                shadows,
            },
            FileLight::Spot { position, direction, color: c, inner_angle_deg, outer_angle_deg, shadows } => {
                cx.check().spot_cone(i, inner_angle_deg, outer_angle_deg)?;
                Light::Spot {
                    position: cx.vec3(&format!("light[{i}].position"), position)?,
                    direction: direction_of(direction)?,
                    inner_deg: inner_angle_deg,
                    outer_deg: outer_angle_deg,
                    color: color(c)?,
                    shadows,
                }
            }
        };
        cx.check().light(i, &light)?;
        lights.push(light);
    }

    let mut environment = Environment::default();
    if let Some(env) = &file.environment {
        if let Some(a) = env.ambient {
            environment.ambient = cx.vec3("environment.ambient", a)?;
        }
        if let Some(b) = env.background {
            environment.background = cx.vec3("environment.background", b)?;
        }
        if let Some(i) = &env.indirect {
            environment.indirect = match i.as_str() {
                "none" => super::Indirect::None,
                "one-bounce" => super::Indirect::OneBounce,
                other => {
                    return Err(cx.err("environment.indirect", format!("`{other}`: `none` or `one-bounce`")))
                }
            };
        }
    }

    cx.check().environment(&environment)?;

    let scene = Scene {
        name: printable(file.name.as_deref().unwrap_or(default_name)),
        image,
        camera,
        objects,
        lights,
        environment,
    };
    // Coordinates and colours within the limits every technique agrees in (scene::extremes).
    super::extremes::check_scene(&scene).map_err(|e| match e {
        Error::Scene { context, message } => cx.err(&context, message),
        e => e,
    })?;
    Ok(scene)
}

fn resolve_pose(cx: &Ctx, field: &str, position: V3, look_at: V3, up: V3) -> Result<CameraPose> {
    let position = cx.vec3(&format!("{field}.position"), position)?;
    let look_at = cx.vec3(&format!("{field}.look_at"), look_at)?;
    let up = cx.vec3(&format!("{field}.up"), up)?;
    let view = (look_at - position)
        .try_normalize()
        .ok_or_else(|| cx.err(&format!("{field}.look_at"), "must differ from position"))?;
    let up_n = up.try_normalize().ok_or_else(|| cx.err(&format!("{field}.up"), "must not be zero"))?;
    if view.cross(up_n).length() < 1e-4 {
        return Err(cx.err(&format!("{field}.up"), "is parallel to the view direction"));
    }
    Ok(CameraPose { position, look_at, up })
}

/// The part of the frame the shutter is open, `(open, close)` in frame fractions, when the camera
/// gives `shutter_angle_deg` or `shutter_interval`: the scene's open and close poses and transforms
/// are then the frame's start and end, and [`retime`] cuts the motion down to the interval.
type ShutterInterval = Option<(f32, f32)>;

/// A full-frame sensor's width, the sensor when `focal_length_mm` comes without one (Blender's
/// default sensor width too).
pub const DEFAULT_SENSOR_WIDTH_MM: f32 = 36.0;

pub use super::validate::MIN_VFOV_DEG;

/// The vertical field of view of a lens of focal length `focal_mm` on a sensor `sensor_height_mm`
/// high: `2·atan(h / 2f)` (a lens focused at infinity; the model's pinhole, docs/MODEL.md "Pinhole").
pub fn vfov_deg_of_lens(focal_mm: f32, sensor_height_mm: f32) -> f32 {
    (2.0 * (sensor_height_mm as f64 / (2.0 * focal_mm as f64)).atan()).to_degrees() as f32
}

/// The thin lens' radius in scene units (metres) of a lens of focal length `focal_mm` at f-number
/// `f_stop`: the entrance pupil's diameter is f/N, so A = f/(2N), millimetres → metres.
pub fn aperture_radius_of_lens(focal_mm: f32, f_stop: f32) -> f32 {
    (focal_mm as f64 / (2.0 * f_stop as f64) / 1000.0) as f32
}

/// `a + (b − a)·s` with the ends exact (s = 0 gives a, s = 1 gives b, bit for bit).
pub(crate) fn lerp_exact_ends<T: Copy + std::ops::Add<Output = T> + std::ops::Mul<f32, Output = T>>(
    a: T,
    b: T,
    s: f32,
) -> T {
    if s <= 0.0 {
        a
    } else if s >= 1.0 {
        b
    } else {
        a * (1.0 - s) + b * s
    }
}

fn resolve_camera(cx: &Ctx, c: &FileCamera, image: &ImageSettings) -> Result<(Camera, ShutterInterval)> {
    let both = |a: &str, b: &str| cx.err(&format!("camera.{b}"), format!("give {a} or {b}, not both"));
    let shutter = match (c.shutter_angle_deg, &c.shutter_interval) {
        (Some(_), Some(_)) => return Err(both("shutter_angle_deg", "shutter_interval")),
        (Some(angle), None) => {
            cx.range("camera.shutter_angle_deg", angle, angle > 0.0 && angle <= 360.0, "in (0, 360]")?;
            Some((0.0, angle / 360.0))
        }
        (None, Some(interval)) => {
            let f = "camera.shutter_interval";
            let [Number(open), Number(close)] = interval[..] else {
                return Err(cx.err(f, format!("expected 2 numbers [open, close], got {}", interval.len())));
            };
            cx.finite(f, open)?;
            cx.finite(f, close)?;
            if !(0.0 <= open && open < close && close <= 1.0) {
                return Err(cx.err(
                    f,
                    format!(
                        "[{}, {}] is out of range: must be 0 ≤ open < close ≤ 1 (fractions of the frame)",
                        num(open),
                        num(close)
                    ),
                ));
            }
            Some((open, close))
        }
        (None, None) => None,
    };
    let up = c.up.unwrap_or(V3::from([0.0, 1.0, 0.0]));
    let mut open = resolve_pose(cx, "camera", c.position, c.look_at, up)?;
    let mut close = match &c.close {
        Some(p) => Some(resolve_pose(
            cx,
            "camera.close",
            p.position.unwrap_or(c.position),
            p.look_at.unwrap_or(c.look_at),
            p.up.unwrap_or(up),
        )?),
        None => None,
    };
    if let (Some((a, b)), Some(end)) = (shutter, close) {
        // The frame's start and end poses → the shutter's: position, look_at and up each linear in time.
        // The interpolated pose is checked like a written one (look_at ≠ position, up not parallel).
        let start = open;
        let at = |s: f32, field: &str| {
            let v = |a: Vec3, b: Vec3| V3::from(lerp_exact_ends(a, b, s).to_array());
            resolve_pose(
                cx,
                field,
                v(start.position, end.position),
                v(start.look_at, end.look_at),
                v(start.up, end.up),
            )
        };
        open = at(a, "camera (at shutter open)")?;
        close = Some(at(b, "camera (at shutter close)")?);
    }
    let focal = match c.focal_length_mm {
        Some(f) => Some(cx.range("camera.focal_length_mm", f, f > 0.0, "> 0")?),
        None => None,
    };
    let vfov_deg = match (c.vfov_deg, focal) {
        (Some(_), Some(_)) => return Err(both("vfov_deg", "focal_length_mm")),
        (Some(v), None) => v,
        (None, None) => {
            for (key, given) in
                [("sensor_width_mm", c.sensor_width_mm), ("sensor_height_mm", c.sensor_height_mm)]
            {
                if given.is_some() {
                    return Err(cx.err(
                        &format!("camera.{key}"),
                        "needs focal_length_mm (the sensor and the focal length give the field of view)",
                    ));
                }
            }
            40.0
        }
        (None, Some(f)) => {
            let sensor_height = match (c.sensor_width_mm, c.sensor_height_mm) {
                (Some(_), Some(_)) => return Err(both("sensor_width_mm", "sensor_height_mm")),
                (None, Some(h)) => cx.range("camera.sensor_height_mm", h, h > 0.0, "> 0")?,
                (w, None) => {
                    let w = w.unwrap_or(DEFAULT_SENSOR_WIDTH_MM);
                    cx.range("camera.sensor_width_mm", w, w > 0.0, "> 0")?;
                    // The sensor has the image's aspect ratio ([image] width × height).
                    (w as f64 * image.height as f64 / image.width as f64) as f32
                }
            };
            vfov_deg_of_lens(f, sensor_height)
        }
    };
    // Its range, with the other lens values', is checked by `Check::camera` (the model's checks).
    let aperture_radius = match (c.aperture_radius, c.f_stop, focal) {
        (Some(_), Some(_), _) => return Err(both("aperture_radius", "f_stop")),
        (_, Some(_), None) => {
            return Err(cx.err(
                "camera.f_stop",
                "needs focal_length_mm (the aperture's diameter is the focal length ÷ the f-stop)",
            ))
        }
        (_, Some(n), Some(f)) => aperture_radius_of_lens(f, cx.range("camera.f_stop", n, n > 0.0, "> 0")?),
        (a, None, _) => a.unwrap_or(0.0),
    };
    let focus_distance = c.focus_distance.unwrap_or_else(|| (open.look_at - open.position).length());
    let near = c.near.unwrap_or(0.05);
    let far = c.far.unwrap_or(1000.0);
    let aperture = match c.aperture {
        None | Some(FileAperture::Disk {}) => ApertureShape::Disk,
        Some(FileAperture::SmoothDisk {}) => ApertureShape::SmoothDisk,
        Some(FileAperture::Blades { blades, rotation_deg }) => ApertureShape::Blades { blades, rotation_deg },
    };
    let camera = Camera {
        open,
        close,
        vfov_deg,
        aperture_radius,
        focus_distance,
        aperture,
        shutter: c.shutter.as_ref().map_or_else(ShutterCurve::default, |c| c.0),
        near,
        far,
    };
    Ok((camera, shutter))
}

/// Object keys in frame time → the shutter's `[a, b]`: the motion at `a` and `b` (linear between the
/// keys around them — the matrices' blend, which is the model's camera-space motion seen by a camera
/// that does not turn), the keys strictly between kept, times rescaled to `[0, 1]`.
pub(crate) fn retime(keys: Vec<(f32, Mat4)>, (a, b): (f32, f32)) -> Vec<(f32, Mat4)> {
    if keys.len() < 2 {
        return keys;
    }
    let at = |t: f32| {
        let i = keys.windows(2).position(|w| t <= w[1].0).unwrap_or(keys.len() - 2);
        let ((t0, m0), (t1, m1)) = (keys[i], keys[i + 1]);
        lerp_exact_ends(m0, m1, (t - t0) / (t1 - t0))
    };
    let mut out = vec![(0.0, at(a))];
    out.extend(keys.iter().filter(|k| k.0 > a && k.0 < b).map(|&(t, m)| ((t - a) / (b - a), m)));
    out.push((1.0, at(b)));
    out
}

fn resolve_mesh(cx: &Ctx, field: &str, base_dir: &Path, o: &FileObject) -> Result<Mesh> {
    if let Some(mesh) = builtin_mesh(&o.mesh, o.detail) {
        return mesh.map_err(|e| match e {
            Error::Limit { .. } => e,
            other => cx.err(&format!("{field}.mesh"), other),
        });
    }
    let path: PathBuf = base_dir.join(&o.mesh);
    let is_obj = path.extension().is_some_and(|e| e.eq_ignore_ascii_case("obj"));
    if !is_obj {
        return Err(cx.err(
            &format!("{field}.mesh"),
            format!(
                "`{}` is neither a built-in mesh ({}) nor an .obj path",
                o.mesh,
                BUILTIN_MESHES.join(", ")
            ),
        ));
    }
    load_obj(&path, o.normalize).map_err(|e| match e {
        Error::Limit { .. } => e,
        other => cx.err(&format!("{field}.mesh"), other),
    })
}

/// Translation, rotation (degrees about X, Y, Z) and scale of a transform table, validated.
fn resolve_trs(
    cx: &Ctx,
    field: &str,
    translate: Option<V3>,
    rotate_deg: Option<V3>,
    scale: Option<&FileScale>,
) -> Result<[Vec3; 3]> {
    let translate = cx.vec3(&format!("{field}.translate"), translate.unwrap_or(V3::from([0.0; 3])))?;
    let rot = cx.vec3(&format!("{field}.rotate_deg"), rotate_deg.unwrap_or(V3::from([0.0; 3])))?;
    let scale = match scale {
        None => Vec3::ONE,
        Some(FileScale::Uniform(s)) => Vec3::splat(cx.finite(&format!("{field}.scale"), *s)?),
        Some(FileScale::PerAxis(s)) => cx.vec3(&format!("{field}.scale"), *s)?,
    };
    if scale.abs().min_element() == 0.0 {
        return Err(cx.err(&format!("{field}.scale"), format!("{} has a zero component", vec_text(scale))));
    }
    Ok([translate, rot, scale])
}

/// The matrix T · Rz · Ry · Rx · S.
fn trs_matrix([translate, rot, scale]: [Vec3; 3]) -> Mat4 {
    let r = Mat4::from_rotation_z(rot.z.to_radians())
        * Mat4::from_rotation_y(rot.y.to_radians())
        * Mat4::from_rotation_x(rot.x.to_radians());
    Mat4::from_translation(translate) * r * Mat4::from_scale(scale)
}

fn resolve_trs_of(cx: &Ctx, field: &str, t: Option<&FileTransform>) -> Result<[Vec3; 3]> {
    match t {
        Some(t) => resolve_trs(cx, field, t.translate, t.rotate_deg, t.scale.as_ref()),
        None => Ok([Vec3::ZERO, Vec3::ZERO, Vec3::ONE]),
    }
}

/// An object's transform keys ([`Object::transforms`]) from `transform`, `transform_close`,
/// `motion_keys` and `[[object.transform_key]]`.
fn resolve_motion(
    cx: &Ctx,
    field: &str,
    o: &FileObject,
    shutter: ShutterInterval,
) -> Result<Vec<(f32, Mat4)>> {
    let open = resolve_trs_of(cx, &format!("{field}.transform"), o.transform.as_ref())?;
    let close = match &o.transform_close {
        Some(t) => Some(resolve_trs_of(cx, &format!("{field}.transform_close"), Some(t))?),
        None => None,
    };
    let max = MAX_MOTION_KEYS as u32;
    if let Some(k) = o.motion_keys {
        let f = format!("{field}.motion_keys");
        cx.range(&f, k as f32, (2..=max).contains(&k), &format!("in 2..={max} (MAX_MOTION_KEYS)"))?;
        if !o.transform_key.is_empty() {
            return Err(cx.err(&f, "give motion_keys or [[object.transform_key]] tables, not both"));
        }
        let Some(close) = close else {
            return Err(cx.err(&f, "needs [object.transform_close] (the motion it samples)"));
        };
        // Evenly spaced keys over the open shutter; translate, rotation angles and scale each
        // interpolated linearly in frame time.
        let (a, b) = shutter.unwrap_or((0.0, 1.0));
        return Ok((0..k)
            .map(|i| {
                let t = if i + 1 == k { 1.0 } else { i as f32 / (k - 1) as f32 };
                let frame = lerp_exact_ends(a, b, t);
                let trs = [0, 1, 2].map(|c| open[c] + (close[c] - open[c]) * frame);
                (t, trs_matrix(trs))
            })
            .collect());
    }
    let mut keys = vec![(0.0, trs_matrix(open))];
    for (i, key) in o.transform_key.iter().enumerate() {
        let f = format!("{field}.transform_key[{i}]");
        let last = keys.last().expect("one").0;
        let written = key.time;
        let expected = format!("in ({}, 1): after the previous key, before shutter close", num(last));
        if !written.is_finite() {
            return Err(cx.err(&format!("{f}.time"), format!("{} is not a finite number", num64(written))));
        }
        if !(written > last as f64 && written < 1.0) {
            return Err(cx.err(
                &format!("{f}.time"),
                format!("{} is out of range: must be {expected}", num64(written)),
            ));
        }
        // Times are `f32` in the model: one strictly between the neighbours in decimal may round onto
        // one of them (0.99999999 is 1 as an f32).
        let time = written as f32;
        if !(time > last && time < 1.0) {
            let largest = 1.0f32 - f32::EPSILON / 2.0;
            return Err(cx.err(
                &format!("{f}.time"),
                format!(
                    "{} rounds to {} in single precision (the model's time), which is not {expected} \
                     (the largest time before close is {})",
                    num64(written),
                    num(time),
                    num(largest)
                ),
            ));
        }
        let trs = resolve_trs(cx, &f, key.translate, key.rotate_deg, key.scale.as_ref())?;
        keys.push((time, trs_matrix(trs)));
    }
    if keys.len() + 1 > MAX_MOTION_KEYS {
        return Err(cx.err(
            &format!("{field}.transform_key"),
            format!("{} keys with the ends; at most {MAX_MOTION_KEYS} (MAX_MOTION_KEYS)", keys.len() + 1),
        ));
    }
    match close {
        Some(c) => keys.push((1.0, trs_matrix(c))),
        // Interior keys without a close transform: the object returns to where it opened.
        None if keys.len() > 1 => keys.push((1.0, keys[0].1)),
        None => {}
    }
    Ok(match shutter {
        Some(interval) => retime(keys, interval),
        None => keys,
    })
}

fn resolve_material(
    cx: &Ctx,
    field: &str,
    base_dir: &Path,
    m: &FileMaterial,
    textures: &mut HashMap<String, Arc<Texture>>,
) -> Result<Material> {
    let texture = match &m.texture {
        None => None,
        Some(t) => Some(match textures.get(t) {
            Some(tex) => tex.clone(),
            None => {
                let tex = match builtin_texture(t) {
                    Some(texture) => texture?,
                    // The error says which object's key named the file, not only the file.
                    None => Arc::new(
                        load_texture(&base_dir.join(t))
                            .map_err(|e| cx.err(&format!("{field}.texture"), e))?,
                    ),
                };
                textures.insert(t.clone(), tex.clone());
                tex
            }
        }),
    };
    let default_albedo = V3::from(if texture.is_some() { [1.0; 3] } else { [0.8; 3] });
    // Ranges are the model's checks (`Check::material`), run on the whole object.
    Ok(Material {
        albedo: cx.vec3(&format!("{field}.albedo"), m.albedo.unwrap_or(default_albedo))?,
        texture,
        specular: m.specular.unwrap_or(0.0),
        roughness: m.roughness.unwrap_or(0.5),
        alpha: m.alpha.unwrap_or(1.0),
        alpha_from_texture: m.alpha_from_texture.unwrap_or(false),
        tint: cx.vec3(&format!("{field}.tint"), m.tint.unwrap_or(V3::from([1.0; 3])))?,
        one_sided: m.one_sided.unwrap_or(false),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec2;

    fn temp_path(tag: &str, ext: &str) -> PathBuf {
        std::env::temp_dir().join(format!(
            "shutter-scene-{}-{}-{tag}.{ext}",
            std::process::id(),
            std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_nanos())
        ))
    }

    const CAMERA: &str = "[camera]\nposition = [0, 1, 5]\nlook_at = [0, 0, 0]\n";

    fn parse(text: &str) -> Result<Scene> {
        parse_scene(text, &std::env::temp_dir(), "test")
    }

    fn err(text: &str) -> String {
        parse(text).map(|_| ()).unwrap_err().to_string()
    }

    /// Object centre (object-space origin) at shutter open: (view depth, pixel position), and the
    /// pixel position at close, for lens centre.
    fn centre(scene: &Scene, name: &str) -> (f32, Vec2, Vec2) {
        let o = scene.objects.iter().find(|o| o.name == name).unwrap();
        let k = scene.camera.intrinsics(scene.image.width, scene.image.height);
        let p0 =
            scene.camera.open.view_matrix().transform_point3(o.transform_open().transform_point3(Vec3::ZERO));
        let p1 = scene
            .camera
            .pose_at_close()
            .view_matrix()
            .transform_point3(o.transform_at_close().transform_point3(Vec3::ZERO));
        (-p0.z, k.project(p0, Vec2::ZERO), k.project(p1, Vec2::ZERO))
    }

    fn in_frame(scene: &Scene, px: Vec2) -> bool {
        px.x >= 0.0 && px.y >= 0.0 && px.x < scene.image.width as f32 && px.y < scene.image.height as f32
    }

    #[test]
    fn default_scene_has_depth_of_field_and_motion_blur() {
        let s = load_scene("default").unwrap();
        assert_eq!((s.image.width, s.image.height), (640, 360));
        assert!(s.camera.aperture_radius > 0.0);
        let k = s.camera.intrinsics(640, 360);
        let coc = |name: &str| k.circle_of_confusion_px(centre(&s, name).0).abs();
        for near in ["near-box", "near-sphere"] {
            assert!(coc(near) >= 8.0, "{near}: {}", coc(near));
        }
        for far in ["far-box", "far-sphere"] {
            assert!(coc(far) >= 6.0, "{far}: {}", coc(far));
        }
        assert!(coc("spot") < 0.5, "spot is in focus: {}", coc("spot"));
        let spot = s.objects.iter().find(|o| o.name == "spot").unwrap();
        assert!(spot.material.texture.is_some() && spot.mesh.has_uvs());
        assert!(s.objects.iter().any(|o| o.material.specular > 0.0));
        // A fast mover, a slightly panning camera.
        let (_, a, b) = centre(&s, "mover");
        assert!((b - a).length() >= 30.0, "mover moves {} px", (b - a).length());
        let (_, a, b) = centre(&s, "spot");
        let pan = (b - a).length();
        assert!(s.camera.close.is_some() && (1.0..10.0).contains(&pan), "camera pan {pan} px");
        for o in &s.objects {
            if o.name != "ground" {
                let (z, a, b) = centre(&s, &o.name);
                assert!(z > 0.0 && in_frame(&s, a) && in_frame(&s, b), "{} is off screen", o.name);
            }
        }
        assert!(s.lights.iter().any(|l| matches!(l, Light::Directional { .. })));
        assert!(s.lights.iter().any(|l| matches!(l, Light::Point { .. })));
        assert_eq!(s.skipped_triangles(), 0);
    }

    #[test]
    fn static_scene_has_no_blur() {
        let s = load_scene("static").unwrap();
        assert_eq!((s.image.width, s.image.height), (640, 360));
        assert_eq!(s.camera.aperture_radius, 0.0);
        assert!(s.camera.close.is_none());
        assert!(s.objects.iter().all(|o| !o.is_moving() && o.transforms.len() == 1));
        assert!(s.objects.iter().any(|o| o.material.texture.is_some()));
        assert!(s.objects.iter().any(|o| o.material.specular > 0.0));
    }

    #[test]
    fn focus_sweep_has_a_blurred_high_poly_sphere_before_a_sharp_background() {
        let s = load_scene("focus-sweep").unwrap();
        assert_eq!((s.image.width, s.image.height), (640, 360));
        let k = s.camera.intrinsics(640, 360);
        let sphere = s.objects.iter().find(|o| o.name == "displaced-sphere").unwrap();
        assert!(sphere.mesh.triangle_count() >= 100_000);
        let (z, px, _) = centre(&s, "displaced-sphere");
        assert!(k.circle_of_confusion_px(z).abs() >= 8.0 && in_frame(&s, px));
        let (z, _, _) = centre(&s, "back-wall");
        assert!(z > 10.0 && k.circle_of_confusion_px(z - 0.3).abs() < 0.5);
    }

    /// `arena`: one 93,696-triangle textured Spot, sharp, between a blurred near post and blurred walls.
    #[test]
    fn arena_scene_is_one_high_poly_object_in_depth_of_field() {
        let s = load_scene("arena").unwrap();
        assert_eq!((s.image.width, s.image.height, s.image.spp), (160, 90, 16));
        let k = s.camera.intrinsics(160, 90);
        let coc = |name: &str| k.circle_of_confusion_px(centre(&s, name).0).abs();
        let spot = s.objects.iter().find(|o| o.name == "spot").unwrap();
        assert_eq!(spot.mesh.triangle_count(), 93_696);
        assert!(spot.material.texture.is_some() && spot.mesh.has_uvs());
        let others: usize =
            s.objects.iter().filter(|o| o.name != "spot").map(|o| o.mesh.triangle_count()).sum();
        assert!(others * 100 < 93_696, "the rest is low-poly: {others} triangles");
        assert!(coc("spot") < 1.0, "spot is in focus: {}", coc("spot"));
        assert!(coc("near-post") >= 6.0, "near post: {}", coc("near-post"));
        assert!(coc("back-wall") >= 3.0, "back wall: {}", coc("back-wall"));
        let (z, px, _) = centre(&s, "spot");
        assert!(z > 0.0 && in_frame(&s, px));
        assert!(s.camera.close.is_none() && s.objects.iter().all(|o| !o.is_moving()));
        assert!(s.lights.iter().any(|l| matches!(l, Light::Directional { .. })));
        assert!(s.lights.iter().any(|l| matches!(l, Light::Point { .. })));
        assert_eq!(s.skipped_triangles(), 0);
    }

    /// `chess`: a dozen-ish pieces on a checker board, the middle one sharp, near and far ones blurred,
    /// one moving.
    #[test]
    fn chess_scene_has_a_dozen_pieces_across_the_depth_of_field() {
        let s = load_scene("chess").unwrap();
        assert_eq!((s.image.width, s.image.height, s.image.spp), (160, 90, 16));
        assert!((12..=14).contains(&s.objects.len()), "{} objects", s.objects.len());
        let k = s.camera.intrinsics(160, 90);
        let coc = |name: &str| k.circle_of_confusion_px(centre(&s, name).0).abs();
        let board = s.objects.iter().find(|o| o.name == "board").unwrap();
        assert_eq!(board.material.texture.as_ref().map(|t| t.name.as_str()), Some("checker"));
        assert!(coc("white-knight-e4") < 0.5, "focus piece: {}", coc("white-knight-e4"));
        assert!(coc("white-pawn-f2") >= 6.0, "near pawn: {}", coc("white-pawn-f2"));
        for far in ["dark-pawn-c7", "dark-pawn-g7", "dark-rook-h8"] {
            assert!(coc(far) >= 3.0, "{far}: {}", coc(far));
        }
        for o in s.objects.iter().filter(|o| !["table", "board-base", "board"].contains(&o.name.as_str())) {
            let (z, a, b) = centre(&s, &o.name);
            assert!(z > 0.0 && in_frame(&s, a) && in_frame(&s, b), "{} is off screen", o.name);
            assert!(o.material.specular > 0.0, "{}", o.name);
        }
        let movers: Vec<&str> = s.objects.iter().filter(|o| o.is_moving()).map(|o| o.name.as_str()).collect();
        assert_eq!(movers, ["dark-knight-f6"]);
        let (_, a, b) = centre(&s, "dark-knight-f6");
        assert!((b - a).length() >= 8.0, "the knight moves {} px", (b - a).length());
        assert_eq!(s.skipped_triangles(), 0);
    }

    #[test]
    fn defaults_and_names() {
        let s = parse(CAMERA).unwrap();
        assert_eq!(s.name, "test");
        assert_eq!(
            s.image,
            ImageSettings { width: 640, height: 360, spp: 16, seed: 1, display: Default::default() }
        );
        assert!((s.camera.focus_distance - 26f32.sqrt()).abs() < 1e-5);
        assert_eq!(s.camera.open.up, Vec3::Y);
        let s = parse(&format!("name = \"x\"\n{CAMERA}[[object]]\nmesh = \"box\"\n")).unwrap();
        assert_eq!((s.name.as_str(), s.objects[0].name.as_str()), ("x", "object0"));
        let e = load_scene("no-such-scene").unwrap_err().to_string();
        assert!(e.contains("default") && e.contains("focus-sweep"), "{e}");
    }

    #[test]
    fn transforms_compose_t_rz_ry_rx_s() {
        let text = format!(
            "{CAMERA}[[object]]\nmesh = \"box\"\n[object.transform]\ntranslate = [1, 2, 3]\n\
             rotate_deg = [90, 90, 0]\nscale = [2, 1, 1]\n[object.transform_close]\nscale = 3\n"
        );
        let s = parse(&text).unwrap();
        let m = s.objects[0].transform_open();
        // X: scale 2 → (2,0,0); Rx(90) keeps it; Ry(90) takes +X to −Z; then translate.
        assert!((m.transform_point3(Vec3::X) - Vec3::new(1.0, 2.0, 1.0)).length() < 1e-5);
        // Y: Rx(90) takes +Y to +Z, Ry(90) takes +Z to +X.
        assert!((m.transform_point3(Vec3::Y) - Vec3::new(2.0, 2.0, 3.0)).length() < 1e-5);
        let c = s.objects[0].transform_at_close();
        assert!((c.transform_point3(Vec3::ONE) - Vec3::splat(3.0)).length() < 1e-6);
        // Meshes are shared between objects.
        let text = format!("{CAMERA}[[object]]\nmesh = \"sphere\"\n[[object]]\nmesh = \"sphere\"\n");
        let s = parse(&text).unwrap();
        assert!(Arc::ptr_eq(&s.objects[0].mesh, &s.objects[1].mesh));
    }

    #[test]
    fn motion_keys_sample_the_rotation_and_keys_are_validated() {
        let spin = |extra: &str| {
            format!(
                "{CAMERA}[[object]]\nmesh = \"box\"\n{extra}[object.transform]\ntranslate = [1, 0, 0]\n\
                 [object.transform_close]\ntranslate = [1, 0, 0]\nrotate_deg = [0, 0, 180]\nscale = 2\n"
            )
        };
        // Two keys by default: the vertex at +X goes straight through the centre.
        let two = parse(&spin("")).unwrap();
        assert_eq!(two.objects[0].transforms.len(), 2);
        // Five keys: 0°, 45°, …, 180° about Z, scale 1 → 2, each evaluated exactly.
        let five = parse(&spin("motion_keys = 5\n")).unwrap();
        let keys = &five.objects[0].transforms;
        assert_eq!(keys.iter().map(|k| k.0).collect::<Vec<_>>(), [0.0, 0.25, 0.5, 0.75, 1.0]);
        for (i, &(t, m)) in keys.iter().enumerate() {
            let angle = std::f32::consts::PI * t;
            let scale = 1.0 + t;
            let want = Vec3::new(1.0 + scale * angle.cos(), scale * angle.sin(), 0.0);
            let got = m.transform_point3(Vec3::X);
            assert!((got - want).length() < 1e-5, "key {i}: {got} vs {want}");
        }
        assert_eq!(keys[0].1, two.objects[0].transforms[0].1);
        assert!((keys[4].1 - two.objects[0].transforms[1].1).abs_diff_eq(Mat4::ZERO, 1e-6));
        // Explicit keys.
        let explicit = parse(&spin(
            "[[object.transform_key]]\ntime = 0.25\nrotate_deg = [0, 0, 10]\n\
             [[object.transform_key]]\ntime = 0.6\ntranslate = [0, 1, 0]\n",
        ))
        .unwrap();
        let times: Vec<f32> = explicit.objects[0].transforms.iter().map(|k| k.0).collect();
        assert_eq!(times, [0.0, 0.25, 0.6, 1.0]);
        assert!(explicit.objects[0].is_moving());
        // Keys without a close transform come back to the open one.
        let back = parse(&format!(
            "{CAMERA}[[object]]\nmesh = \"box\"\n[[object.transform_key]]\ntime = 0.5\ntranslate = [0, 1, 0]\n"
        ))
        .unwrap();
        let b = &back.objects[0].transforms;
        assert_eq!((b.len(), b[2].1), (3, b[0].1));
        // Errors name the field.
        for (extra, needle) in [
            ("motion_keys = 1\n", "motion_keys"),
            ("motion_keys = 65\n", "motion_keys"),
            ("motion_keys = 3\n[[object.transform_key]]\ntime = 0.5\n", "not both"),
            (
                "[[object.transform_key]]\ntime = 0.5\n[[object.transform_key]]\ntime = 0.4\n",
                "transform_key[1].time",
            ),
            ("[[object.transform_key]]\ntime = 1.0\n", "transform_key[0].time"),
            ("[[object.transform_key]]\ntime = 0.5\nscale = 0\n", "transform_key[0].scale"),
            ("[[object.transform_key]]\ntime = 0.5\nspin = 1\n", "spin"),
        ] {
            let e = err(&spin(extra));
            assert!(e.contains(needle), "{extra}: {e}");
        }
        let e = err(&format!("{CAMERA}[[object]]\nmesh = \"box\"\nmotion_keys = 4\n"));
        assert!(e.contains("transform_close"), "{e}");
    }

    /// Issue 16: every vector and colour takes exactly three numbers, a shape takes only its own keys,
    /// and no message names a Rust type.
    #[test]
    fn strict_vectors_shapes_and_scales() {
        let obj =
            |table: &str, keys: &str| format!("{CAMERA}[[object]]\nmesh = \"box\"\n[{table}]\n{keys}\n");
        let light = |keys: &str| format!("{CAMERA}[[light]]\n{keys}\n");
        let o = "object[0] (`object0`)";
        let cases = [
            ("[camera]\nposition = [0, 1, 5, 99]\nlook_at = [0, 0, 0]\n".to_string(), "camera.position", 4),
            ("[camera]\nposition = [0, 1]\nlook_at = [0, 0, 0]\n".to_string(), "camera.position", 2),
            ("[camera]\nposition = [0, 1, 5]\nlook_at = []\n".to_string(), "camera.look_at", 0),
            (format!("{CAMERA}up = [0, 1, 0, 0]\n"), "camera.up", 4),
            (format!("{CAMERA}[camera.close]\nposition = [1, 1, 5, 1]\n"), "camera.close.position", 4),
            (obj("object.transform", "translate = [1, 2, 3, 4]"), &format!("{o}.transform.translate"), 4),
            (obj("object.transform", "rotate_deg = [90]"), &format!("{o}.transform.rotate_deg"), 1),
            (obj("object.transform", "scale = [1, 2]"), &format!("{o}.transform.scale"), 2),
            (
                obj("object.transform_close", "translate = [1, 2]"),
                &format!("{o}.transform_close.translate"),
                2,
            ),
            (obj("object.material", "albedo = [1, 1, 1, 1]"), &format!("{o}.material.albedo"), 4),
            (obj("object.material", "tint = [1, 1]"), &format!("{o}.material.tint"), 2),
            (
                obj("[object.transform_key]]\ntime = 0.5\n#", "translate = [1, 2, 3, 4]"),
                &format!("{o}.transform_key[0].translate"),
                4,
            ),
            (
                light("type = \"directional\"\ndirection = [0, -1, 0, 0]\ncolor = [1, 1, 1]"),
                "light[0].direction",
                4,
            ),
            (light("type = \"point\"\nposition = [0, 1, 0]\ncolor = [1, 1]"), "light[0].color", 2),
            (format!("{CAMERA}[environment]\nambient = [0.1, 0.1, 0.1, 1]\n"), "environment.ambient", 4),
            (format!("{CAMERA}[environment]\nbackground = [0.1]\n"), "environment.background", 1),
        ];
        for (text, field, got) in cases {
            assert_eq!(
                err(&text),
                format!("scene error in scene `test`: {field}: expected 3 numbers [x, y, z], got {got}"),
                "{text}"
            );
        }
        // The issue's example: the wrong type inside is a TOML error on that line, in words.
        let e = err("[camera]\nposition = [0, 1, 5, 99, \"junk\"]\nlook_at = [0, 0, 0]\n");
        assert!(
            e.contains("position = [0, 1, 5, 99, \"junk\"]")
                && e.contains("invalid type: string \"junk\", expected a number"),
            "{e}"
        );
        // A scale is a number or three; the message says so, not which Rust type failed.
        for bad in ["\"big\"", "true"] {
            let e = err(&obj("object.transform", &format!("scale = {bad}")));
            assert!(e.contains("expected a number or an array of 3 numbers [x, y, z]"), "{e}");
            assert!(!e.contains("FileScale") && !e.contains("untagged"), "{e}");
        }
        let s = parse(&obj("object.transform", "scale = [1, 2, 3]")).unwrap();
        assert!(
            (s.objects[0].transform_open().transform_point3(Vec3::ONE) - Vec3::new(1.0, 2.0, 3.0)).length()
                < 1e-6
        );
        // A value of the wrong kind: what was expected, in the file's words, never a Rust type.
        let box_ = "[[object]]\nmesh = \"box\"\n";
        for (text, expected) in [
            ("camera = 5\n".to_string(), "expected a table [camera] (position, look_at, …)"),
            ("image = 5\n".to_string(), "expected a table [image] (width, height, spp, seed, exposure, tone)"),
            (format!("{CAMERA}close = 5\n"), "expected a table [camera.close] (position, look_at, up)"),
            (format!("{CAMERA}aperture = \"disk\"\n"), "expected a table { shape = \"disk\" }, { shape = \"blades\", blades = N } or { shape = \"smooth-disk\" }"),
            (format!("object = [1]\n{CAMERA}"), "expected a table [[object]] (name, mesh, transform, material, …)"),
            (format!("{CAMERA}{box_}transform = 1\n"), "expected a table of translate, rotate_deg and scale"),
            (format!("{CAMERA}{box_}transform_key = [1]\n"), "expected a table [[object.transform_key]] (time, translate, rotate_deg, scale)"),
            (format!("{CAMERA}{box_}material = 1\n"), "expected a table [object.material] (albedo, texture, specular, …)"),
            (format!("light = [1]\n{CAMERA}"), "expected a table [[light]] with type = \"directional\", \"point\" or \"spot\""),
            (format!("environment = 1\n{CAMERA}"), "expected a table [environment] (ambient, background, indirect)"),
            (format!("{CAMERA}up = 1\n"), "expected an array of 3 numbers [x, y, z]"),
            (format!("{CAMERA}shutter = 5\n"), "expected the shutter curve, \"box\" or \"tent\""),
            (format!("{CAMERA}shutter = \"slow\"\n"), "unknown variant `slow`, expected `box` or `tent`"),
            (
                format!("{CAMERA}shutter = [0, 0.5]\n"),
                "`shutter` is the shutter curve, \"box\" or \"tent\"; give the part of the frame the shutter is open as shutter_interval = [open, close] or shutter_angle_deg",
            ),
        ] {
            let e = err(&text);
            assert!(e.contains(expected), "{text}: {e}");
            assert!(!e.contains("File") && !e.contains("struct") && !e.contains("enum "), "{text}: {e}");
        }
        assert_eq!(
            parse(&format!("{CAMERA}shutter = \"tent\"\n")).unwrap().camera.shutter,
            ShutterCurve::Tent
        );
        // An aperture shape takes only its own keys.
        for (aperture, key) in [
            ("{ shape = \"disk\", blades = 6 }", "blades"),
            ("{ shape = \"smooth-disk\", rotation_deg = 10 }", "rotation_deg"),
            ("{ shape = \"blades\", blades = 6, radius = 1 }", "radius"),
        ] {
            let e = err(&format!("{CAMERA}aperture = {aperture}\n"));
            assert!(e.contains(&format!("unknown field `{key}`")), "{aperture}: {e}");
        }
        let e = err(&format!("{CAMERA}aperture = {{ shape = \"hexagon\" }}\n"));
        assert!(e.contains("unknown variant `hexagon`") && e.contains("`smooth-disk`"), "{e}");
        assert_eq!(
            parse(&format!("{CAMERA}aperture = {{ shape = \"disk\" }}\n")).unwrap().camera.aperture,
            ApertureShape::Disk
        );
    }

    /// Issue 16, item 2: focal length, sensor and f-stop give exactly the camera that vfov_deg and
    /// aperture_radius of the same values give, and they match the physics they stand for.
    #[test]
    fn photographic_camera_keys_give_the_same_camera() {
        let camera = |image: &str, keys: &str| {
            parse(&format!("{image}[camera]\nposition = [0, 1, 5]\nlook_at = [0, 0, 0]\n{keys}\n"))
                .unwrap()
                .camera
        };
        // 50 mm on a 24 mm high sensor at f/2: vfov 2·atan(12/50) ≈ 26.99°, A = 50 / 4 mm = 12.5 mm.
        let (vfov, a) = (vfov_deg_of_lens(50.0, 24.0), aperture_radius_of_lens(50.0, 2.0));
        assert!((vfov - 26.9915).abs() < 1e-3 && a == 0.0125, "{vfov} {a}");
        let photo = camera("", "focal_length_mm = 50\nsensor_height_mm = 24\nf_stop = 2");
        assert_eq!(photo, camera("", &format!("vfov_deg = {vfov}\naperture_radius = {a}")));
        // The pixel scale is the lens' magnification: s = H·f / sensor height (360 px · 50 / 24 = 750).
        assert!((photo.intrinsics(640, 360).pixel_scale - 750.0).abs() < 1e-2);
        // The default sensor is 36 mm wide with the image's aspect: 20.25 mm high at 640×360.
        let vfov = vfov_deg_of_lens(35.0, 20.25);
        assert_eq!(camera("", "focal_length_mm = 35"), camera("", &format!("vfov_deg = {vfov}")));
        assert_eq!(
            camera("", "focal_length_mm = 35\nsensor_width_mm = 36"),
            camera("", &format!("vfov_deg = {vfov}"))
        );
        let portrait = "[image]\nwidth = 200\nheight = 300\n";
        let vfov = vfov_deg_of_lens(24.0, 36.0);
        assert_eq!(
            camera(portrait, "focal_length_mm = 24\nsensor_width_mm = 24\nf_stop = 8"),
            camera(
                portrait,
                &format!("vfov_deg = {vfov}\naperture_radius = {}", aperture_radius_of_lens(24.0, 8.0))
            )
        );

        // Pairs: one or the other; ranges; f_stop and a sensor need a focal length.
        for (keys, message) in [
            ("vfov_deg = 40\nfocal_length_mm = 50", "camera.focal_length_mm: give vfov_deg or focal_length_mm, not both"),
            ("focal_length_mm = 50\naperture_radius = 0.1\nf_stop = 2", "camera.f_stop: give aperture_radius or f_stop, not both"),
            ("focal_length_mm = 50\nsensor_width_mm = 36\nsensor_height_mm = 24", "camera.sensor_height_mm: give sensor_width_mm or sensor_height_mm, not both"),
            ("shutter_angle_deg = 180\nshutter_interval = [0, 0.5]", "camera.shutter_interval: give shutter_angle_deg or shutter_interval, not both"),
            ("f_stop = 2", "camera.f_stop: needs focal_length_mm (the aperture's diameter is the focal length ÷ the f-stop)"),
            ("sensor_width_mm = 36", "camera.sensor_width_mm: needs focal_length_mm (the sensor and the focal length give the field of view)"),
            ("focal_length_mm = 0", "camera.focal_length_mm: 0 is out of range: must be > 0"),
            ("vfov_deg = 1e-45", "camera.vfov_deg: 1e-45 is out of range: must be in [0.001, 180) degrees"),
            ("focal_length_mm = 3e6", "camera.vfov_deg: 0.0003867465 is out of range: must be in [0.001, 180) degrees"),
            ("focal_length_mm = nan", "camera.focal_length_mm: NaN is not a finite number"),
            ("focal_length_mm = 50\nf_stop = -2", "camera.f_stop: -2 is out of range: must be > 0"),
            ("focal_length_mm = 50\nsensor_height_mm = 0", "camera.sensor_height_mm: 0 is out of range: must be > 0"),
            ("shutter_angle_deg = 0", "camera.shutter_angle_deg: 0 is out of range: must be in (0, 360]"),
            ("shutter_angle_deg = 400", "camera.shutter_angle_deg: 400 is out of range: must be in (0, 360]"),
            ("shutter_interval = [0.5, 0.5]", "camera.shutter_interval: [0.5, 0.5] is out of range: must be 0 ≤ open < close ≤ 1 (fractions of the frame)"),
            ("shutter_interval = [-0.5, 0.5]", "camera.shutter_interval: [-0.5, 0.5] is out of range: must be 0 ≤ open < close ≤ 1 (fractions of the frame)"),
            ("shutter_interval = [0, 0.5, 1]", "camera.shutter_interval: expected 2 numbers [open, close], got 3"),
            ("shutter_interval = [inf, 0.5]", "camera.shutter_interval: inf is not a finite number"),
        ] {
            let e = err(&format!("{CAMERA}{keys}\n"));
            assert_eq!(e, format!("scene error in scene `test`: {message}"), "{keys}");
        }
    }

    /// Issue 16, item 2: a shutter angle or interval cuts the frame's motion (camera and objects) to
    /// the open shutter — exactly the scene whose close poses are where the frame's motion is then.
    #[test]
    fn shutter_angle_and_interval_cut_the_frames_motion() {
        let scene = |camera: &str, close_x: f32, object: &str| {
            parse(&format!(
                "[camera]\nposition = [0, 1, 5]\nlook_at = [0, 0, 0]\n{camera}\n[camera.close]\nposition = [{close_x}, 1, 5]\n\
                 [[object]]\nmesh = \"box\"\n{object}\n"
            ))
            .unwrap()
        };
        let same = |a: &Scene, b: &Scene| {
            assert_eq!(a.camera, b.camera);
            assert_eq!(a.objects.len(), b.objects.len());
            for (x, y) in a.objects.iter().zip(&b.objects) {
                assert_eq!(x.transforms, y.transforms, "{}", x.name);
            }
        };
        let slide = |x0: f32, x1: f32| {
            format!("[object.transform]\ntranslate = [{x0}, 0, 0]\n[object.transform_close]\ntranslate = [{x1}, 0, 0]\n")
        };
        // 360°: the whole frame, the same scene as no key.
        same(&scene("shutter_angle_deg = 360", 0.5, &slide(0.0, 1.0)), &scene("", 0.5, &slide(0.0, 1.0)));
        same(&scene("shutter_interval = [0, 1]", 0.5, &slide(0.0, 1.0)), &scene("", 0.5, &slide(0.0, 1.0)));
        // 180°: the first half of the frame.
        same(&scene("shutter_angle_deg = 180", 0.5, &slide(0.0, 1.0)), &scene("", 0.25, &slide(0.0, 0.5)));
        // [0.25, 0.75]: the middle half — the camera from x = 0.25 to 0.75 of a 1-unit pan.
        let mid = scene("shutter_interval = [0.25, 0.75]", 1.0, &slide(0.0, 2.0));
        let want = parse(&format!(
            "[camera]\nposition = [0.25, 1, 5]\nlook_at = [0, 0, 0]\n[camera.close]\nposition = [0.75, 1, 5]\n\
             [[object]]\nmesh = \"box\"\n{}\n",
            slide(0.5, 1.5)
        ))
        .unwrap();
        // The camera's look_at is the frame's at both ends (it was not given in [camera.close]).
        same(&mid, &want);
        // motion_keys are spread over the open shutter: 5 keys over half of a 180° turn = 90°.
        let spin =
            |deg: u32| format!("motion_keys = 5\n[object.transform_close]\nrotate_deg = [0, {deg}, 0]\n");
        same(&scene("shutter_angle_deg = 180", 0.0, &spin(180)), &scene("", 0.0, &spin(90)));
        // Explicit keys: kept inside the interval (times rescaled), the motion cut at its ends.
        let keyed = scene(
            "shutter_interval = [0, 0.5]",
            0.0,
            &format!("{}[[object.transform_key]]\ntime = 0.25\ntranslate = [3, 0, 0]\n", slide(0.0, 1.0)),
        );
        let t = &keyed.objects[0].transforms;
        assert_eq!(t.iter().map(|k| k.0).collect::<Vec<_>>(), [0.0, 0.5, 1.0]);
        assert_eq!(t[1].1, Mat4::from_translation(Vec3::new(3.0, 0.0, 0.0)));
        // At frame time 0.5, two thirds of the way from the key (3 at 0.25) to the end (1 at 1).
        assert!((t[2].1.w_axis.x - (3.0 - 2.0 / 3.0)).abs() < 1e-6, "{}", t[2].1);
        // A still object stays still; a still camera stays still.
        let still = parse(&format!("{CAMERA}shutter_angle_deg = 90\n[[object]]\nmesh = \"box\"\n")).unwrap();
        assert!(still.camera.close.is_none() && !still.objects[0].is_moving());
    }

    /// Every file in `scenes/` loads from disk: the built-ins (the same scene as embedded) and the
    /// examples loaded by path, such as `spot-85mm.toml` (an OBJ and a PNG beside it, a camera in
    /// millimetres, f-stops and a shutter angle).
    #[test]
    fn every_file_in_scenes_loads() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes");
        let mut files = 0;
        for entry in std::fs::read_dir(&dir).unwrap() {
            let path = entry.unwrap().path();
            if path.extension().is_none_or(|e| e != "toml") {
                continue;
            }
            let s = load_scene_file(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
            if BUILTIN_SCENES.contains(&s.name.as_str()) {
                assert_eq!(s.content_hash(), load_scene(&s.name).unwrap().content_hash(), "{}", s.name);
            }
            files += 1;
        }
        assert!(files > BUILTIN_SCENES.len(), "{files} files");
        let s = load_scene_file(&dir.join("spot-85mm.toml")).unwrap();
        assert_eq!(s.camera.vfov_deg, vfov_deg_of_lens(85.0, 36.0 * 360.0 / 640.0));
        assert_eq!(s.camera.aperture_radius, aperture_radius_of_lens(85.0, 1.4));
        assert!((s.camera.aperture_radius - 0.030357).abs() < 1e-6);
        let spot = s.objects.iter().find(|o| o.name == "spot").unwrap();
        assert!(spot.mesh.triangle_count() == 5856 && spot.mesh.has_uvs() && spot.material.texture.is_some());
        assert_eq!(s.skipped_triangles(), 0);
        // The 180° shutter: the ball's 0.3 m of the frame, 0.15 m of it while the shutter is open.
        let ball = s.objects.iter().find(|o| o.name == "rolling-ball").unwrap();
        let moved = ball.transform_at_close().w_axis.x - ball.transform_open().w_axis.x;
        assert!((moved - 0.15).abs() < 1e-6, "{moved}");
        let k = s.camera.intrinsics(640, 360);
        assert!((k.pixel_scale - 360.0 * 85.0 / 20.25).abs() < 0.05, "{}", k.pixel_scale);
        assert!(k.circle_of_confusion_px(centre(&s, "spot").0).abs() < 0.5);
        assert!(k.circle_of_confusion_px(centre(&s, "near-ball").0).abs() > 5.0);
    }

    #[test]
    fn malformed_and_unknown_keys() {
        assert!(err("[camera\nposition = ").contains("invalid scene TOML"));
        let e = err(&format!("{CAMERA}colour = 1\n"));
        assert!(e.contains("colour"), "{e}");
        let e = err(&format!("{CAMERA}[[object]]\nmesh = \"box\"\n[object.material]\nshiny = 1\n"));
        assert!(e.contains("shiny"), "{e}");
        let e = err(&format!("{CAMERA}[[light]]\ntype = \"area\"\nposition = [0,0,0]\ncolor = [1,1,1]\n"));
        assert!(e.contains("area"), "{e}");
        let e = err(&format!(
            "{CAMERA}[[light]]\ntype = \"point\"\nposition = [0,0,0]\ncolor = [1,1,1]\nradius = 1\n"
        ));
        assert!(e.contains("radius"), "{e}");
        let e = err("[image]\nwidth = 10\n");
        assert!(e.contains("camera"), "{e}");
        let e = err(&format!("{CAMERA}[[object]]\nmesh = \"teapot\"\n"));
        assert!(e.contains("teapot") && e.contains("displaced-sphere"), "{e}");
    }

    #[test]
    fn image_exposure_and_tone() {
        use crate::tonemap::{Display, ToneCurve};
        assert_eq!(parse(CAMERA).unwrap().image.display, Display::LINEAR);
        let s = parse(&format!("[image]\nexposure = -1.5\ntone = \"aces\"\n{CAMERA}")).unwrap();
        assert_eq!(s.image.display, Display { exposure_ev: -1.5, curve: ToneCurve::Aces });
        let s = parse(&format!("[image]\nexposure = 2\ntone = \"reinhard\"\n{CAMERA}")).unwrap();
        assert_eq!(s.image.display, Display { exposure_ev: 2.0, curve: ToneCurve::Reinhard });
        let e = err(&format!("[image]\ntone = \"filmic\"\n{CAMERA}"));
        assert!(
            e.contains("image.tone") && e.contains("`filmic`") && e.contains("clip, reinhard, aces"),
            "{e}"
        );
        let e = err(&format!("[image]\nexposure = 65\n{CAMERA}"));
        assert!(e.contains("image.exposure") && e.contains("[-64, 64]"), "{e}");
        assert!(err(&format!("[image]\nexposure = nan\n{CAMERA}")).contains("image.exposure"));
        assert!(err(&format!("[image]\nexposure = \"bright\"\n{CAMERA}")).contains("exposure"));
    }

    #[test]
    fn limits_are_enforced() {
        let e = err(&format!("[image]\nwidth = 100000\n{CAMERA}"));
        assert!(e.contains("image.width") && e.contains("8192") && e.contains("MAX_IMAGE_DIMENSION"), "{e}");
        let e = err(&format!("[image]\nspp = 0\n{CAMERA}"));
        assert!(e.contains("image.spp") && e.contains("65536"), "{e}");
        assert!(err(&format!("[image]\nheight = -3\n{CAMERA}")).contains("image.height"));
        assert!(err(&format!("[image]\nseed = -3\n{CAMERA}")).contains("image.seed"));
        let cam = |extra: &str| err(&format!("{CAMERA}{extra}\n"));
        assert!(cam("vfov_deg = 180").contains("camera.vfov_deg"));
        assert!(cam("vfov_deg = 0").contains("camera.vfov_deg"));
        assert!(cam("aperture_radius = -0.1").contains("camera.aperture_radius"));
        assert!(cam("focus_distance = 0").contains("camera.focus_distance"));
        assert!(cam("near = 0").contains("camera.near"));
        assert!(cam("near = 2\nfar = 1").contains("camera.far"));
        let e = cam("near = 0.001\nfar = 1e10");
        assert!(e.contains("camera.near/far") && e.contains("MAX_FAR_OVER_NEAR"), "{e}");
        assert!(cam("near = 1e-12").contains("MIN_NEAR"));
        assert!(cam("aperture = { shape = \"blades\", blades = 2 }").contains("blades"));
        assert!(cam("up = [0, 2, 10]").contains("parallel"));
        assert!(cam("[camera.close]\nlook_at = [0, 1, 5]").contains("camera.close.look_at"));
        assert!(err("[camera]\nposition = [1, 1, 1]\nlook_at = [1, 1, 1]\n").contains("camera.look_at"));
        let s = parse(&format!("{CAMERA}aperture = {{ shape = \"blades\", blades = 6, rotation_deg = 15 }}"))
            .unwrap();
        assert_eq!(s.camera.aperture, ApertureShape::Blades { blades: 6, rotation_deg: 15.0 });
        let s = parse(&format!("{CAMERA}aperture = {{ shape = \"smooth-disk\" }}")).unwrap();
        assert_eq!(s.camera.aperture, ApertureShape::SmoothDisk);
        let mat = |m: &str| err(&format!("{CAMERA}[[object]]\nmesh = \"box\"\n[object.material]\n{m}\n"));
        assert!(mat("roughness = 0").contains("roughness"));
        assert!(mat("roughness = 1.5").contains("roughness"));
        assert!(mat("alpha = 1.5").contains("alpha"));
        assert!(mat("specular = -1").contains("specular"));
        assert!(mat("albedo = [1, -1, 0]").contains("albedo"));
        let xf = |t: &str| err(&format!("{CAMERA}[[object]]\nmesh = \"box\"\n[object.transform]\n{t}\n"));
        assert!(xf("scale = 0").contains("scale"));
        assert!(xf("scale = [1, 0, 1]").contains("scale"));
        assert!(xf("scale = inf").contains("scale"));
    }

    #[test]
    fn transparency_keys_parse_and_default_to_opaque() {
        let one = |m: &str| {
            let s = parse(&format!("{CAMERA}[[object]]\nmesh = \"box\"\n[object.material]\n{m}\n")).unwrap();
            s.objects[0].material.clone()
        };
        let m = one("");
        assert_eq!((m.alpha, m.alpha_from_texture, m.tint, m.one_sided), (1.0, false, Vec3::ONE, false));
        assert!(m.is_opaque());
        assert!(one("one_sided = true").one_sided);
        let m = one("alpha = 0.25\ntint = [0.5, 1, 0]");
        assert_eq!((m.alpha, m.tint), (0.25, Vec3::new(0.5, 1.0, 0.0)));
        assert!(!m.is_opaque());
        assert_eq!(m.transmittance(m.alpha), Vec3::new(0.375, 0.75, 0.0));
        let m = one("texture = \"spot\"\nalpha_from_texture = true");
        assert!(m.alpha_from_texture && !m.is_opaque() && m.texture.is_some());
        // The Spot texture is opaque: its alpha channel is 1 everywhere, so alpha_from_texture changes
        // nothing there.
        assert!(m.texture.as_ref().unwrap().srgb_rgba8.chunks_exact(4).all(|p| p[3] == 255));
        let mat = |m: &str| err(&format!("{CAMERA}[[object]]\nmesh = \"box\"\n[object.material]\n{m}\n"));
        for (bad, field) in [
            ("alpha = 1.5", "material.alpha"),
            ("alpha = -0.1", "material.alpha"),
            ("alpha = nan", "material.alpha"),
            ("tint = [2, 0, 0]", "material.tint"),
            ("tint = [0, -0.5, 0]", "material.tint"),
            ("tint = [nan, 0, 0]", "material.tint"),
            ("tint = [1, 1]", "material.tint: expected 3 numbers [x, y, z], got 2"),
            ("alpha_from_texture = true", "material.alpha_from_texture"),
            ("alpha_from_texture = 1", "alpha_from_texture"),
            ("one_sided = \"yes\"", "one_sided"),
        ] {
            let e = mat(bad);
            assert!(e.contains(field) && (e.contains("object[0]") || e.contains("TOML")), "{bad}: {e}");
        }
        // One-sided and mirrored: refused (the outside would be culled); mirrored alone is fine.
        let mirrored = |m: &str| {
            format!("{CAMERA}[[object]]\nmesh = \"box\"\n[object.transform]\nscale = [-1, 1, 1]\n[object.material]\n{m}\n")
        };
        let e = parse(&mirrored("one_sided = true")).map(|_| ()).unwrap_err().to_string();
        assert!(e.contains("material.one_sided") && e.contains("mirrors"), "{e}");
        assert!(parse(&mirrored("")).is_ok());
    }

    #[test]
    fn lights_parse_with_shadows_and_spots() {
        let lights = |l: &str| parse(&format!("{CAMERA}{l}")).map(|s| s.lights);
        let l = lights(
            "[[light]]\ntype = \"directional\"\ndirection = [0, -2, 0]\ncolor = [1, 1, 1]\n\
             [[light]]\ntype = \"point\"\nposition = [0, 3, 0]\ncolor = [2, 2, 2]\nshadows = true\n\
             [[light]]\ntype = \"spot\"\nposition = [1, 4, 0]\ndirection = [0, 0, -3]\ncolor = [5, 4, 3]\n\
             inner_angle_deg = 15\nouter_angle_deg = 30\nshadows = true\n",
        )
        .unwrap();
        assert_eq!(
            l,
            [
                Light::Directional { direction: -Vec3::Y, color: Vec3::ONE, shadows: false },
                Light::Point { position: Vec3::new(0.0, 3.0, 0.0), color: Vec3::splat(2.0), shadows: true },
                Light::Spot {
                    position: Vec3::new(1.0, 4.0, 0.0),
                    direction: -Vec3::Z,
                    inner_deg: 15.0,
                    outer_deg: 30.0,
                    color: Vec3::new(5.0, 4.0, 3.0),
                    shadows: true,
                },
            ]
        );
        assert!(!l[0].shadows() && l[1].shadows() && l[2].shadows());
        // A hard-edged spot (inner = outer) is fine.
        let spot = |angles: &str| {
            lights(&format!(
                "[[light]]\ntype = \"spot\"\nposition = [0, 1, 0]\ndirection = [0, -1, 0]\ncolor = [1, 1, 1]\n{angles}\n"
            ))
        };
        assert!(spot("inner_angle_deg = 20\nouter_angle_deg = 20").is_ok());
        for (bad, field) in [
            ("inner_angle_deg = 30\nouter_angle_deg = 20", "light[0].inner_angle_deg"),
            ("inner_angle_deg = -1\nouter_angle_deg = 20", "light[0].inner_angle_deg"),
            ("inner_angle_deg = 10\nouter_angle_deg = 95", "light[0].outer_angle_deg"),
            ("inner_angle_deg = 0\nouter_angle_deg = 0", "light[0].outer_angle_deg"),
            ("inner_angle_deg = nan\nouter_angle_deg = 20", "light[0].inner_angle_deg"),
            ("outer_angle_deg = 20", "inner_angle_deg"),
            // Inside a tagged table TOML reports the table's line and the type.
            ("inner_angle_deg = 10\nouter_angle_deg = 20\nshadows = \"yes\"", "expected a boolean"),
        ] {
            let e = spot(bad).unwrap_err().to_string();
            assert!(e.contains(field), "{bad}: {e}");
        }
        let e = lights(
            "[[light]]\ntype = \"spot\"\nposition = [0, 1, 0]\ndirection = [0, 0, 0]\ncolor = [1, 1, 1]\n\
             inner_angle_deg = 10\nouter_angle_deg = 20\n",
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("light[0].direction"), "{e}");
        let e = lights("[[light]]\ntype = \"torch\"\nposition = [0, 1, 0]\ncolor = [1, 1, 1]\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("torch"), "{e}");
    }

    #[test]
    fn non_finite_values_are_rejected() {
        let e = err(&format!(
            "{CAMERA}[[object]]\nmesh = \"box\"\n[object.transform]\ntranslate = [nan, 0, 0]\n"
        ));
        assert!(e.contains("translate") && e.contains("NaN") && e.contains("scene `test`"), "{e}");
        assert!(err("[camera]\nposition = [0, inf, 5]\nlook_at = [0, 0, 0]\n").contains("camera.position"));
        assert!(err(&format!("{CAMERA}focus_distance = nan\n")).contains("camera.focus_distance"));
        assert!(err(&format!(
            "{CAMERA}[[light]]\ntype = \"directional\"\ndirection = [0, -inf, 0]\ncolor = [1, 1, 1]\n"
        ))
        .contains("light[0].direction"));
        assert!(
            err(&format!("{CAMERA}[environment]\nambient = [nan, 0, 0]\n")).contains("environment.ambient")
        );
    }

    #[test]
    fn simplify_is_validated_and_keys_the_shared_meshes() {
        for bad in ["0", "-1", "1.5", "nan", "inf"] {
            let e = err(&format!("{CAMERA}[[object]]\nname = \"cow\"\nmesh = \"spot\"\nsimplify = {bad}\n"));
            assert!(e.contains("object[0] (`cow`).simplify"), "{bad}: {e}");
        }
        let object = |name: &str, simplify: &str| {
            format!("[[object]]\nname = \"{name}\"\nmesh = \"spot\"\n{simplify}\n[object.material]\ntexture = \"spot\"\n")
        };
        let text = [
            CAMERA.to_string(),
            object("full", ""),
            object("half", "simplify = 0.5"),
            object("quarter", "simplify = 0.25"),
            object("half-again", "simplify = 0.5"),
            object("one", "simplify = 1"),
        ]
        .concat();
        let s = parse(&text).unwrap();
        let mesh = |name: &str| s.objects.iter().find(|o| o.name == name).unwrap().mesh.clone();
        let (full, half, quarter) = (mesh("full"), mesh("half"), mesh("quarter"));
        assert_eq!(full.triangle_count(), 5856);
        assert!(
            full.triangle_count() > half.triangle_count() && half.triangle_count() > quarter.triangle_count()
        );
        assert!(half.has_uvs() && quarter.has_uvs());
        assert!(Arc::ptr_eq(&half, &mesh("half-again")) && Arc::ptr_eq(&full, &mesh("one")));
        assert!(!Arc::ptr_eq(&full, &half) && !Arc::ptr_eq(&half, &quarter));

        // Cached references are keyed by the content hash: it follows the geometry.
        let one = |simplify: &str| parse(&[CAMERA.to_string(), object("spot", simplify)].concat()).unwrap();
        let hash = |simplify: &str| one(simplify).content_hash();
        assert_eq!(hash(""), hash("simplify = 1.0"));
        assert_ne!(hash(""), hash("simplify = 0.5"));
        assert_ne!(hash("simplify = 0.5"), hash("simplify = 0.25"));
        assert_eq!(hash("simplify = 0.5"), hash("simplify = 0.5"));
    }

    #[test]
    fn files_meshes_and_textures_from_disk() {
        let dir = std::env::temp_dir();
        // A good scene with an OBJ (one good, one zero-area, one duplicate-vertex triangle) and a PNG.
        let obj = temp_path("mesh", "obj");
        std::fs::write(&obj, "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 2 0 0\nvt 0 0\nf 1 2 3\nf 1 2 4\nf 2 2 3\n")
            .unwrap();
        let png = temp_path("tex", "png");
        image::RgbaImage::from_raw(1, 1, vec![255, 128, 0, 255])
            .unwrap()
            .save_with_format(&png, image::ImageFormat::Png)
            .unwrap();
        let name = |p: &Path| p.file_name().unwrap().to_string_lossy().into_owned();
        let scene_path = temp_path("good", "toml");
        let text = format!(
            "{CAMERA}[[object]]\nmesh = \"{}\"\nnormalize = true\n[object.material]\ntexture = \"{}\"\n",
            name(&obj),
            name(&png)
        );
        std::fs::write(&scene_path, &text).unwrap();
        let s = load_scene(&scene_path.display().to_string()).unwrap();
        assert_eq!(s.name, scene_path.file_stem().unwrap().to_string_lossy());
        assert_eq!(s.objects[0].mesh.triangle_count(), 1);
        assert_eq!(s.objects[0].mesh.stats.skipped_degenerate, 2);
        assert_eq!(s.skipped_triangles(), 2);
        let skipped = s.skipped_by_mesh();
        assert_eq!(skipped.len(), 1);
        assert_eq!(
            skipped[0].to_string(),
            "2 zero-area or duplicate-vertex triangles skipped in the mesh of object `object0` (1 kept)"
        );
        // A mesh shared by two objects is one entry naming both; a clean mesh is none.
        std::fs::write(
            &scene_path,
            format!(
                "{text}[[object]]\nname = \"twin\"\nmesh = \"{}\"\nnormalize = true\n[[object]]\nmesh = \"box\"\n",
                name(&obj)
            ),
        )
        .unwrap();
        let s = load_scene_file(&scene_path).unwrap();
        assert_eq!(
            s.skipped_by_mesh().iter().map(|m| m.to_string()).collect::<Vec<_>>(),
            ["2 zero-area or duplicate-vertex triangles skipped in the mesh of objects `object0`, `twin` (1 kept)"]
        );
        assert_eq!(s.objects[0].material.albedo, Vec3::ONE);
        assert_eq!(s.objects[0].material.texture.as_ref().unwrap().width, 1);

        // Missing OBJ / texture: errors name the path.
        let write_scene = |mesh: &str, texture: &str| {
            let p = temp_path("bad", "toml");
            let t = format!(
                "{CAMERA}[[object]]\nmesh = \"{mesh}\"\n[object.material]\ntexture = \"{texture}\"\n"
            );
            std::fs::write(&p, t).unwrap();
            let e = load_scene_file(&p).unwrap_err().to_string();
            let _ = std::fs::remove_file(&p);
            e
        };
        let e = write_scene("missing-mesh-xyz.obj", &name(&png));
        assert!(e.contains("missing-mesh-xyz.obj"), "{e}");
        let e = write_scene(&name(&obj), "missing-texture-xyz.png");
        assert!(e.contains("missing-texture-xyz.png"), "{e}");

        // Corrupt OBJ (garbage bytes) and corrupt texture.
        let garbage: Vec<u8> = (0..2048u32).map(|i| (i.wrapping_mul(2654435761) >> 11) as u8).collect();
        let bad_obj = temp_path("garbage", "obj");
        std::fs::write(&bad_obj, &garbage).unwrap();
        let e = write_scene(&name(&bad_obj), &name(&png));
        assert!(e.contains(&name(&bad_obj)), "{e}");
        let bad_png = temp_path("garbage", "png");
        std::fs::write(&bad_png, &garbage).unwrap();
        let e = write_scene(&name(&obj), &name(&bad_png));
        assert!(e.contains(&name(&bad_png)), "{e}");

        // inf in a vertex.
        let inf_obj = temp_path("inf", "obj");
        std::fs::write(&inf_obj, "v inf 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
        let e = write_scene(&name(&inf_obj), &name(&png));
        assert!(e.contains(&name(&inf_obj)) && e.contains("non-finite"), "{e}");

        // Missing scene file.
        let e = load_scene_file(&dir.join("no-such-scene-xyz.toml")).unwrap_err().to_string();
        assert!(e.contains("no-such-scene-xyz.toml"), "{e}");

        for p in [obj, png, scene_path, bad_obj, bad_png, inf_obj] {
            let _ = std::fs::remove_file(p);
        }
    }
}
