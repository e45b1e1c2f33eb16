//! The effect planner: simulate only what the scene calls for.
//!
//! Per object and frame, from its geometry at both shutter ends in camera space
//! ([`crate::scene::CameraSpaceScene`], carried by the camera [`View`]): the largest circle of
//! confusion in pixels over the object's visible depth
//! range, the largest screen motion of any vertex over the shutter, and whether the object crosses the
//! near plane or the plane of focus. From those the object takes one of four paths ([`Effects`]):
//! the plain pinhole pipeline, or a stochastic-rasterization shader permutation that simulates only
//! defocus, only motion, or both. Technique `auto` renders a frame from the plan: with no effect
//! anywhere it *is* the `pinhole` technique (same passes, bit-identical image and cost); otherwise the
//! stochastic frame of S samples per pixel, in which the pinhole objects are drawn by the plain
//! pipeline into the same multisampled targets.
//!
//! Why bounds at the vertices suffice: camera-space positions are linear in t (docs/MODEL.md "Shutter"), a
//! linearly moving point projects to a straight screen path (a projective map keeps lines straight
//! while z > 0), so its largest displacement is between its end positions; and `|φ(z)|` is monotonic
//! on each side of the focus plane, so over a triangle (depths between its vertices') and over time
//! it is largest at the extremes of the object's clamped depth range.

use std::fmt;

use glam::Vec2;

use crate::mirror::shadow_maps::{casters_move, ShadowKind, SPOT_CUBE_DEG};
use crate::scene::{Intrinsics, Light, Scene, View};

/// Blur below which an effect is not simulated, in pixels (circle-of-confusion radius; screen-motion
/// length). Ignoring a blur of b px moves edges by at most b px, so the error grows about linearly in
/// b; at a quarter pixel it reaches the error the pinhole path's own 4 MSAA samples per pixel leave
/// (measured on the CPU reference in `plan::tests`: a sphere with 0.2 px of both blurs changes by RMSE
/// 0.0026, 0.25 px by 0.0033, against 0.0033 for 4 vs 1024 samples per pixel; 0.5 px by 0.0068).
pub const DEFAULT_THRESHOLD_PX: f32 = 0.25;

/// Which effects an object's path simulates.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Effects {
    /// The plain pinhole pipeline: mid-shutter, lens centre.
    Pinhole,
    /// Stochastic rasterization over the lens only (the object at mid-shutter).
    Defocus,
    /// Stochastic rasterization over the shutter only (pinhole lens).
    Motion,
    /// Stochastic rasterization over lens and shutter.
    Both,
}

impl Effects {
    pub const ALL: [Effects; 4] = [Effects::Pinhole, Effects::Defocus, Effects::Motion, Effects::Both];

    pub fn new(defocus: bool, motion: bool) -> Self {
        match (defocus, motion) {
            (false, false) => Effects::Pinhole,
            (true, false) => Effects::Defocus,
            (false, true) => Effects::Motion,
            (true, true) => Effects::Both,
        }
    }
    pub fn name(&self) -> &'static str {
        match self {
            Effects::Pinhole => "pinhole",
            Effects::Defocus => "defocus",
            Effects::Motion => "motion",
            Effects::Both => "defocus+motion",
        }
    }
    pub fn defocus(&self) -> bool {
        matches!(self, Effects::Defocus | Effects::Both)
    }
    pub fn motion(&self) -> bool {
        matches!(self, Effects::Motion | Effects::Both)
    }
    pub fn is_stochastic(&self) -> bool {
        *self != Effects::Pinhole
    }
    /// The effect axis of the stochastic shader permutations (`shaders-glsl/permutations.toml`):
    /// `Pinhole` objects take the `still` one (mid-shutter, lens centre).
    pub fn shader_axis(self) -> crate::shaders::axes::Effects {
        use crate::shaders::axes::Effects as Axis;
        match self {
            Effects::Pinhole => Axis::Still,
            Effects::Both => Axis::Both,
            Effects::Defocus => Axis::Defocus,
            Effects::Motion => Axis::Motion,
        }
    }
}

/// The decision for one object, with the numbers behind it.
#[derive(Clone, Debug, PartialEq)]
pub struct ObjectPlan {
    pub name: String,
    pub triangles: usize,
    /// Camera-space depth range of the object's vertices over the shutter (may reach behind the camera).
    pub depth_range: (f32, f32),
    /// Largest |circle of confusion| radius in pixels over the visible depth range (0 without aperture).
    pub max_coc_px: f32,
    /// Largest screen path of a vertex over the shutter (through its motion keys), pixels; infinite when
    /// a moving vertex is at or behind the near plane at some key (its projection is unbounded).
    pub max_motion_px: f32,
    /// Some vertex is at or in front of the near plane (z ≤ near) at some time.
    pub crosses_near: bool,
    /// Motion keys (2: open and close; more for an object with transform keys), each key segment
    /// drawn and bounded on its own by the stochastic rasterizer.
    pub motion_keys: usize,
    /// The depth range straddles the plane of focus (the object is sharp somewhere, blurred elsewhere).
    pub crosses_focus: bool,
    /// Entirely before the near plane or beyond the far plane at both ends: nothing to draw.
    pub culled: bool,
    pub effects: Effects,
    /// Pixel-space box (min, max) holding every circle of confusion of every vertex at both shutter
    /// ends — the `bbox` bound of the whole object, so it holds every pixel any of its triangles can
    /// cover — or `None` when a vertex reaches the near plane (the projection is unbounded there).
    pub screen_box: Option<(Vec2, Vec2)>,
}

/// Per-object decisions for one frame and image size.
/// The frame `auto` renders ([`Plan::auto_frame`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AutoFrame {
    Pinhole,
    Stochastic,
    Accumulation,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Plan {
    pub width: u32,
    pub height: u32,
    pub threshold_px: f32,
    pub objects: Vec<ObjectPlan>,
    /// Objects with coverage below 1 (rendered with a transparency method), and of those the tinted.
    pub transparent_objects: usize,
    pub tinted_objects: usize,
    /// Objects whose coverage comes from their texture's alpha.
    pub texture_alpha_objects: usize,
    /// The shadow-casting lights (index, how each is mapped), the map kind their casters need, and
    /// whether the maps follow motion (rendered per pass) — none of it built for a scene without
    /// shadow-casting lights.
    pub shadow_lights: Vec<(usize, &'static str)>,
    pub shadow_kind: Option<ShadowKind>,
    pub shadows_follow_motion: bool,
}

impl Plan {
    /// The plan with [`DEFAULT_THRESHOLD_PX`].
    pub fn new(scene: &Scene, width: u32, height: u32) -> Self {
        Plan::with_threshold(scene, width, height, DEFAULT_THRESHOLD_PX)
    }

    /// The plan with blur below `threshold_px` (circle-of-confusion radius, motion length) ignored.
    pub fn with_threshold(scene: &Scene, width: u32, height: u32, threshold_px: f32) -> Self {
        Plan::for_view(scene, &View::camera(scene, width, height), threshold_px)
    }

    /// The plan from an already built camera view (the scene in camera space at both shutter ends),
    /// so a frame builds camera space once.
    pub fn for_view(scene: &Scene, camera: &View, threshold_px: f32) -> Self {
        let (width, height) = camera.size();
        let k = scene.camera.intrinsics(width, height);
        let objects = scene
            .objects
            .iter()
            .zip(&camera.space.objects)
            .map(|(o, motion)| {
                let ends: Vec<Vec<glam::Vec3>> =
                    o.mesh.positions.iter().map(|&p| motion.positions(p)).collect();
                plan_object(&o.name, o.mesh.triangle_count(), &ends, &k, threshold_px)
            })
            .collect();
        let transparent = || scene.objects.iter().filter(|o| !o.material.is_opaque());
        let shadow_lights: Vec<(usize, &'static str)> = scene
            .lights
            .iter()
            .enumerate()
            .filter(|(_, l)| l.shadows())
            .map(|(i, l)| {
                let how = match *l {
                    Light::Directional { .. } => "directional: one orthographic map",
                    Light::Spot { outer_deg, .. } if outer_deg <= SPOT_CUBE_DEG => {
                        "spot: one perspective map"
                    }
                    Light::Spot { .. } => "wide spot: a cube of six maps",
                    Light::Point { .. } => "point: a cube of six maps",
                };
                (i, how)
            })
            .collect();
        let shadow_kind = (!shadow_lights.is_empty()).then(|| ShadowKind::for_scene(scene));
        Plan {
            width,
            height,
            threshold_px,
            objects,
            transparent_objects: transparent().count(),
            tinted_objects: transparent().filter(|o| o.material.tint != glam::Vec3::ONE).count(),
            texture_alpha_objects: transparent().filter(|o| o.material.alpha_from_texture).count(),
            // Lights do not move in the world: maps change only when an object moves there.
            shadows_follow_motion: !shadow_lights.is_empty() && casters_move(scene),
            shadow_lights,
            shadow_kind,
        }
    }

    /// Does any object need stochastic rasterization?
    pub fn needs_stochastic(&self) -> bool {
        self.objects.iter().any(|o| o.effects.is_stochastic())
    }

    /// The frame technique `auto` renders, and why when it is not the obvious one: the pinhole
    /// technique when nothing needs blur; the stochastic frame when something does — unless the scene
    /// has what the stochastic frame does not render yet (shadow maps of moving casters), when it is
    /// `accumulation`, which renders them with the blur.
    pub fn auto_frame(&self) -> (AutoFrame, Option<String>) {
        if !self.needs_stochastic() {
            return (AutoFrame::Pinhole, None);
        }
        if self.shadows_follow_motion {
            let why = "the stochastic frame renders no shadow maps of moving casters yet";
            (AutoFrame::Accumulation, Some(why.to_string()))
        } else {
            (AutoFrame::Stochastic, None)
        }
    }

    /// Each object's path, in scene order.
    pub fn effects(&self) -> Vec<Effects> {
        self.objects.iter().map(|o| o.effects).collect()
    }

    /// Triangles on each path.
    pub fn triangles_by_path(&self) -> [(Effects, usize); 4] {
        Effects::ALL
            .map(|e| (e, self.objects.iter().filter(|o| o.effects == e).map(|o| o.triangles).sum::<usize>()))
    }
}

/// The decision for one object from its vertices' camera-space positions at its motion keys (each
/// vertex's positions in key order: open and close, and any keys between). A vertex's motion is the
/// length of its screen path through the keys.
pub fn plan_object<K: AsRef<[glam::Vec3]>>(
    name: &str,
    triangles: usize,
    ends: &[K],
    k: &Intrinsics,
    threshold_px: f32,
) -> ObjectPlan {
    let (mut z_lo, mut z_hi) = (f32::INFINITY, f32::NEG_INFINITY);
    let mut max_motion = 0.0f32;
    let (mut box_lo, mut box_hi) = (Vec2::INFINITY, Vec2::NEG_INFINITY);
    for keys in ends {
        let keys = keys.as_ref();
        for &p in keys {
            let z = -p.z;
            if z > k.near {
                let (c, r) = (k.project(p, Vec2::ZERO), k.circle_of_confusion_px(z).abs());
                box_lo = box_lo.min(c - Vec2::splat(r));
                box_hi = box_hi.max(c + Vec2::splat(r));
            }
            z_lo = z_lo.min(z);
            z_hi = z_hi.max(z);
        }
        let mut path = 0.0f32;
        for w in keys.windows(2) {
            let (p0, p1) = (w[0], w[1]);
            if p0 == p1 {
                continue;
            }
            path += if (-p0.z).min(-p1.z) <= k.near {
                f32::INFINITY
            } else {
                (k.project(p1, Vec2::ZERO) - k.project(p0, Vec2::ZERO)).length()
            };
        }
        max_motion = max_motion.max(path);
    }
    let empty = ends.is_empty() || triangles == 0;
    let culled = empty || z_hi < k.near || z_lo > k.far;
    // |φ| over the visible depths [max(z_lo, near), min(z_hi, far)] is largest at an end.
    let max_coc = if culled || k.aperture_radius <= 0.0 {
        0.0
    } else {
        let (a, b) = (z_lo.max(k.near), z_hi.min(k.far));
        k.circle_of_confusion_px(a).abs().max(k.circle_of_confusion_px(b).abs())
    };
    let crosses_near = !empty && z_lo <= k.near;
    let crosses_focus = !culled && z_lo < k.focus_distance && z_hi > k.focus_distance;
    let effects = if culled {
        Effects::Pinhole
    } else {
        Effects::new(max_coc >= threshold_px, max_motion >= threshold_px)
    };
    let screen_box = (!crosses_near && box_lo.is_finite() && box_hi.is_finite()).then_some((box_lo, box_hi));
    ObjectPlan {
        name: name.to_string(),
        motion_keys: ends.first().map_or(2, |k| k.as_ref().len()),
        triangles,
        screen_box,
        depth_range: (z_lo, z_hi),
        max_coc_px: max_coc,
        max_motion_px: max_motion,
        crosses_near,
        crosses_focus,
        culled,
        effects,
    }
}

impl fmt::Display for Plan {
    /// The plan as a markdown table (what `shutter plan` prints).
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "{}x{}, threshold {} px (circle-of-confusion radius and screen motion)\n",
            self.width, self.height, self.threshold_px
        )?;
        writeln!(
            f,
            "| object | triangles | depth range | max CoC px | max motion px | motion keys | crosses | path |"
        )?;
        writeln!(f, "|---|---:|---|---:|---:|---:|---|---|")?;
        for o in &self.objects {
            let mut crosses = Vec::new();
            if o.crosses_near {
                crosses.push("near");
            }
            if o.crosses_focus {
                crosses.push("focus");
            }
            if o.culled {
                crosses.push("culled");
            }
            let motion = if o.max_motion_px.is_finite() {
                format!("{:.2}", o.max_motion_px)
            } else {
                "unbounded".into()
            };
            writeln!(
                f,
                "| {} | {} | {:.2}..{:.2} | {:.2} | {} | {} | {} | {} |",
                o.name,
                o.triangles,
                o.depth_range.0,
                o.depth_range.1,
                o.max_coc_px,
                motion,
                o.motion_keys,
                if crosses.is_empty() { "-".into() } else { crosses.join(", ") },
                o.effects.name()
            )?;
        }
        let by_path: Vec<String> = self
            .triangles_by_path()
            .iter()
            .filter(|(_, n)| *n > 0)
            .map(|(e, n)| format!("{} {n}", e.name()))
            .collect();
        if self.transparent_objects > 0 {
            writeln!(
                f,
                "\ntransparency: {} object(s) with coverage below 1 ({} tinted): a transparency method \
                 (--transparency)",
                self.transparent_objects, self.tinted_objects
            )?;
        }
        if let Some(kind) = self.shadow_kind {
            let lights: Vec<String> =
                self.shadow_lights.iter().map(|(i, how)| format!("light[{i}] {how}")).collect();
            writeln!(
                f,
                "\nshadows: {}; {} shadow maps (the casters need them), rendered {}",
                lights.join(", "),
                kind.name(),
                if self.shadows_follow_motion {
                    "before every pass (something moves)"
                } else {
                    "once per frame"
                }
            )?;
        }
        let frame = match self.auto_frame() {
            (AutoFrame::Pinhole, _) => "the pinhole technique (one MSAA pass): nothing to simulate".to_string(),
            (AutoFrame::Stochastic, _) => {
                "the stochastic frame (pinhole objects on its still permutation, in the same visibility buffer)"
                    .to_string()
            }
            (AutoFrame::Accumulation, why) => {
                format!("accumulation (S passes): {}", why.unwrap_or_default())
            }
        };
        write!(f, "\ntriangles by path: {}; frame: {frame}", by_path.join(", "))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::builtin::builtin_scene;
    use glam::{Mat4, Vec3};

    fn plan_of(name: &str) -> Plan {
        let s = builtin_scene(name).unwrap().unwrap();
        Plan::new(&s, s.image.width, s.image.height)
    }

    /// `auto` takes pinhole without blur, the stochastic frame with blur, and accumulation with blur
    /// and what the stochastic frame lacks (shadow maps of moving casters); the plan says which
    /// shadow maps a scene needs and whether they follow motion.
    #[test]
    fn auto_frame_follows_blur_and_what_the_stochastic_frame_renders() {
        assert_eq!(plan_of("static").auto_frame(), (AutoFrame::Pinhole, None));
        assert_eq!(plan_of("default").auto_frame(), (AutoFrame::Stochastic, None));
        let mut s = builtin_scene("default").unwrap().unwrap();
        s.lights.push(Light::Point { position: Vec3::Y, color: Vec3::ONE, shadows: true });
        let p = Plan::new(&s, 64, 36);
        let (frame, why) = p.auto_frame();
        assert_eq!(frame, AutoFrame::Accumulation);
        assert!(why.unwrap().contains("shadow maps of moving casters"));
        assert_eq!(p.shadow_lights, vec![(s.lights.len() - 1, "point: a cube of six maps")]);
        assert_eq!(p.shadow_kind, Some(ShadowKind::Plain));
        assert!(p.shadows_follow_motion, "the default scene's sphere moves");
        assert!(p.to_string().contains("shadows: light["), "{p}");
        // Tints, texture alpha and shadows of still casters: the stochastic frame renders them all.
        assert_eq!(plan_of("glass").auto_frame(), (AutoFrame::Stochastic, None));
        let foliage = plan_of("foliage");
        assert_eq!(foliage.auto_frame(), (AutoFrame::Stochastic, None));
        assert_eq!(foliage.texture_alpha_objects, 4);
        // Shadows of still casters are rendered by the stochastic frame.
        let mut still = builtin_scene("focus-sweep").unwrap().unwrap();
        still.lights[0] = Light::Directional { direction: -Vec3::Y, color: Vec3::ONE, shadows: true };
        let p = Plan::new(&still, 64, 36);
        assert_eq!((p.auto_frame().0, p.shadows_follow_motion), (AutoFrame::Stochastic, false));
        assert_eq!(
            (foliage.shadow_kind, foliage.shadows_follow_motion),
            (Some(ShadowKind::Stochastic), false)
        );
        // Nothing about shadows or transparency in an opaque, unshadowed plan.
        let st = plan_of("static");
        assert!(st.shadow_kind.is_none() && st.transparent_objects == 0);
        assert!(!st.to_string().contains("shadows:") && !st.to_string().contains("transparency:"));
    }

    fn path(p: &Plan, object: &str) -> Effects {
        p.objects.iter().find(|o| o.name == object).unwrap().effects
    }

    /// The screen box holds every triangle's bound (the shading pass scans only its pixels): on every
    /// built-in scene, each object's triangles that stay in front of the near plane have their
    /// `bbox` bound inside the box; an object reaching the near plane has no box (the whole image).
    #[test]
    fn screen_box_holds_every_triangle_bound() {
        use crate::geometry::MovingTriangle;
        use crate::mirror::bounds::{bound, BoundKind};
        use crate::scene::CameraSpaceScene;
        for name in ["default", "one-mover", "static"] {
            let s = builtin_scene(name).unwrap().unwrap();
            let (w, h) = (s.image.width, s.image.height);
            let plan = Plan::new(&s, w, h);
            let k = s.camera.intrinsics(w, h);
            let space = CameraSpaceScene::new(&s);
            for ((o, motion), op) in s.objects.iter().zip(&space.objects).zip(&plan.objects) {
                let Some((lo, hi)) = op.screen_box else {
                    assert!(op.crosses_near, "{name}/{}: no box but in front of near", o.name);
                    continue;
                };
                let ends: Vec<Vec<Vec3>> = o.mesh.positions.iter().map(|&p| motion.positions(p)).collect();
                for t in o.mesh.indices.chunks_exact(3) {
                    let idx = [t[0], t[1], t[2]].map(|i| i as usize);
                    for j in 0..motion.segments() {
                        let tri =
                            MovingTriangle { v0: idx.map(|i| ends[i][j]), v1: idx.map(|i| ends[i][j + 1]) };
                        let Some((blo, bhi)) = bound(&tri, &k, BoundKind::BoundingBox).aabb() else {
                            continue;
                        };
                        let tol = 1e-3 * (1.0 + blo.abs().max(bhi.abs()).max_element());
                        assert!(
                            blo.x >= lo.x - tol
                                && blo.y >= lo.y - tol
                                && bhi.x <= hi.x + tol
                                && bhi.y <= hi.y + tol,
                            "{name}/{}: bound {blo}..{bhi} outside the box {lo}..{hi}",
                            o.name
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn static_scene_needs_nothing() {
        let p = plan_of("static");
        assert!(!p.needs_stochastic(), "{p}");
        assert!(p.objects.iter().all(|o| o.max_coc_px == 0.0 && o.max_motion_px == 0.0));
    }

    #[test]
    fn default_scene_paths_follow_its_comments() {
        // The scene file documents |φ| per object; the camera pans ≈ 4 px, so everything moves.
        let p = plan_of("default");
        for o in &p.objects {
            assert!(o.max_motion_px >= 1.0, "{p}");
        }
        let near = p.objects.iter().find(|o| o.name == "near-box").unwrap();
        assert!((15.0..25.0).contains(&near.max_coc_px), "{p}");
        let mover = p.objects.iter().find(|o| o.name == "mover").unwrap();
        assert!(mover.max_motion_px > 70.0, "{p}");
        assert!(p.objects.iter().find(|o| o.name == "ground").unwrap().crosses_near);
        assert!(p.objects.iter().find(|o| o.name == "spot").unwrap().crosses_focus);
    }

    #[test]
    fn focus_sweep_keeps_the_focused_wall_on_the_pinhole_path() {
        // Nothing moves; the wall is in focus (≈ 0.07 px), the props just behind blur by 0.27–0.37 px.
        let p = plan_of("focus-sweep");
        assert_eq!(path(&p, "displaced-sphere"), Effects::Defocus, "{p}");
        assert_eq!(path(&p, "floor"), Effects::Defocus, "{p}");
        assert_eq!(path(&p, "back-wall"), Effects::Pinhole, "{p}");
        for o in &p.objects {
            assert_eq!(o.effects, Effects::new(o.max_coc_px >= DEFAULT_THRESHOLD_PX, false), "{p}");
        }
    }

    #[test]
    fn one_mover_in_the_static_scene_is_the_only_stochastic_object() {
        let mut s = builtin_scene("static").unwrap().unwrap();
        let i = s.objects.iter().position(|o| o.name == "blue-sphere").unwrap();
        let close = Mat4::from_translation(Vec3::new(0.3, 0.0, 0.0)) * s.objects[i].transform_open();
        s.objects[i].set_close(close);
        let p = Plan::new(&s, 320, 180);
        for (j, o) in p.objects.iter().enumerate() {
            assert_eq!(o.effects, if j == i { Effects::Motion } else { Effects::Pinhole }, "{p}");
        }
    }

    #[test]
    fn motion_is_the_endpoint_displacement_and_unbounded_through_the_near_plane() {
        let k = builtin_scene("static").unwrap().unwrap().camera.intrinsics(640, 360);
        let s = k.pixel_scale;
        // A point at depth 5 moving 0.01 units sideways: s·0.01/5 px.
        let ends = [[Vec3::new(0.0, 0.0, -5.0), Vec3::new(0.01, 0.0, -5.0)]];
        let o = plan_object("p", 1, &ends, &k, 0.5);
        assert!((o.max_motion_px - s * 0.01 / 5.0).abs() < 1e-3);
        assert_eq!(o.effects, Effects::Motion);
        // Just under the threshold: pinhole.
        let d = 0.49 * 5.0 / s;
        let o = plan_object("p", 1, &[[Vec3::new(0.0, 0.0, -5.0), Vec3::new(d, 0.0, -5.0)]], &k, 0.5);
        assert_eq!(o.effects, Effects::Pinhole, "{o:?}");
        // A moving vertex behind the camera: unbounded motion.
        let o = plan_object(
            "p",
            1,
            &[[Vec3::new(0.0, 0.0, 1.0), Vec3::new(0.1, 0.0, 1.0)], [Vec3::new(0.0, 0.0, -5.0); 2]],
            &k,
            0.5,
        );
        assert!(o.max_motion_px.is_infinite() && o.crosses_near && o.effects == Effects::Motion);
        // Entirely behind the camera: culled, nothing to simulate.
        let o = plan_object("p", 1, &[[Vec3::new(0.0, 0.0, 2.0), Vec3::new(0.5, 0.0, 2.0)]], &k, 0.5);
        assert!(o.culled && o.effects == Effects::Pinhole);
    }

    #[test]
    fn coc_is_the_largest_over_the_visible_depth_range() {
        let mut k = builtin_scene("default").unwrap().unwrap().camera.intrinsics(640, 360);
        // Straddling the focus plane (F = 6): the larger of |φ(4)| and |φ(9)|.
        let ends = [[Vec3::new(0.0, 0.0, -4.0); 2], [Vec3::new(0.0, 0.0, -9.0); 2]];
        let o = plan_object("p", 1, &ends, &k, 0.5);
        let want = k.circle_of_confusion_px(4.0).abs().max(k.circle_of_confusion_px(9.0).abs());
        assert!((o.max_coc_px - want).abs() < 1e-4 && o.crosses_focus && o.effects == Effects::Defocus);
        // Reaching behind the camera: clamped at the near plane.
        let ends = [[Vec3::new(0.0, 0.0, 3.0); 2], [Vec3::new(0.0, 0.0, -9.0); 2]];
        let o = plan_object("p", 1, &ends, &k, 0.5);
        assert!((o.max_coc_px - k.circle_of_confusion_px(k.near).abs()).abs() < 1e-2);
        // No aperture: no defocus at any depth.
        k.aperture_radius = 0.0;
        assert_eq!(plan_object("p", 1, &ends, &k, 0.5).max_coc_px, 0.0);
    }

    /// A sphere (radius ≈ 4.7 px, bright on dark) with `blur_px` of defocus (circle-of-confusion radius
    /// at its centre) and `blur_px` of motion: RMSE between the CPU reference with and without the
    /// effects, and the plan of the blurred scene.
    fn neglected_blur_rmse(blur_px: f32, spp: u32) -> (f32, Plan, f32) {
        use crate::reference::{render_reference, ReferenceSettings};
        let mut s = builtin_scene("static").unwrap().unwrap();
        s.objects.retain(|o| o.name == "blue-sphere");
        let (w, h) = (96, 54);
        let k = s.camera.intrinsics(w, h);
        let z = 4.4f32; // the sphere's view depth
        s.camera.aperture_radius = 0.05;
        s.camera.focus_distance = 1.0 / (1.0 / z - blur_px / (0.05 * k.pixel_scale));
        let mut sharp = s.clone();
        sharp.camera.aperture_radius = 0.0;
        let shift = blur_px * z / k.pixel_scale;
        let close = Mat4::from_translation(Vec3::new(shift, 0.0, 0.0)) * s.objects[0].transform_open();
        s.objects[0].set_close(close);
        let settings = ReferenceSettings {
            width: w,
            height: h,
            spp: 1024,
            seed: 3,
            progress: false,
            shading: Default::default(),
        };
        let blurred = render_reference(&s, &settings).unwrap();
        let plain = render_reference(&sharp, &settings).unwrap();
        let effect = crate::metrics::compare(&plain, &blurred).unwrap().rmse as f32;
        let few = render_reference(&sharp, &ReferenceSettings { spp, ..settings }).unwrap();
        let aliasing = crate::metrics::compare(&plain, &few).unwrap().rmse as f32;
        (effect, Plan::new(&s, w, h), aliasing)
    }

    /// The threshold's justification, measured: with both blurs just under [`DEFAULT_THRESHOLD_PX`] the
    /// planner takes the pinhole path and the neglected blur changes the image by less than the
    /// pinhole path's own 4 samples per pixel leave anyway; at 0.4 px it would not, and the planner
    /// simulates it. (Measured: 0.1 px → RMSE 0.0013, 0.2 → 0.0026, 0.25 → 0.0033, 0.4 → 0.0054,
    /// 0.5 → 0.0068, against 0.0033 for 4 spp.)
    #[test]
    fn sub_threshold_blur_changes_the_image_by_less_than_its_antialiasing() {
        let (effect, plan, aliasing) = neglected_blur_rmse(0.2, 4);
        let o = &plan.objects[0];
        assert!(o.max_coc_px > 0.2 && o.max_motion_px > 0.2, "{plan}");
        assert_eq!(o.effects, Effects::Pinhole, "{plan}");
        assert!(effect < aliasing, "neglected blur RMSE {effect} vs 4-spp antialiasing RMSE {aliasing}");
        let (effect, plan, aliasing) = neglected_blur_rmse(0.4, 4);
        assert_eq!(plan.objects[0].effects, Effects::Both, "{plan}");
        assert!(effect > aliasing, "neglected blur RMSE {effect} vs 4-spp antialiasing RMSE {aliasing}");
    }
}
