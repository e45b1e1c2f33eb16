//! Adaptive texture-space shading on the GPU (docs/ATSS.md), so far its per-triangle shading rate:
//! `shaders-glsl/texture_space/rate.glsl` (run by `ShadingRates`) against its CPU mirror
//! `shutter::mirror::texture_space::rate::triangle_level_over_shutter`, triangle by triangle, on built-in
//! scenes with depth of field, motion, Spot's own uvs and generated charts, and on the hard cases of a
//! camera rolling and turning half round (several shading times).

use glam::Vec2;
use shutter::mirror::texture_space::atlas::MipAtlas;
use shutter::mirror::texture_space::rate::{shading_time_count, triangle_level_over_shutter};
use shutter::scene::builtin::builtin_scene;
use shutter::scene::camera_space::CameraSpaceScene;
use shutter::techniques::texture_space::{AtlasResult, ShadingAtlas, ShadingRates, BILINEAR_HULL_TEXELS};
use shutter::techniques::{FrameTechnique, RenderSettings};
use shutter_tests::renderer;

/// Relative difference of the minor radius allowed between the GPU (f32 throughout) and the CPU (f32
/// derivatives, f64 ellipse): the footprint's determinant cancels for a triangle seen nearly edge-on.
const RADIUS_TOLERANCE: f64 = 1e-2;

/// Same level, minor radius within [`RADIUS_TOLERANCE`], and a footprint at the same vertices —
/// except where the radius sits within that tolerance of a power of two, where rounding may pick
/// either neighbouring level.
#[test]
fn gpu_shading_rates_match_the_cpu_mirror() {
    let (w, h, finest) = (320, 180, 4096);
    let mut r = renderer();
    for name in ["default", "focus-sweep", "glass", "foliage", "camera-roll-180", "camera-turn-180"] {
        let scene = match builtin_scene(name) {
            Some(scene) => scene.expect("parses"),
            None => shutter::hard_cases::HardCase::named(name).and_then(|c| c.scene()).expect("hard case"),
        };
        let settings = RenderSettings::new(w, h, 1, 1);
        let mut prepared = r
            .prepare_with(&scene, &settings, |ctx| {
                let t: Box<dyn FrameTechnique> = Box::new(ShadingRates::new(ctx, finest)?);
                Ok(t)
            })
            .expect("prepare");
        r.render_prepared(&mut prepared).expect("run");
        let rates = prepared.technique_as::<ShadingRates>().expect("the probe");
        let intrinsics = scene.camera.intrinsics(w, h);
        let space = CameraSpaceScene::new(&scene);
        let (mut compared, mut levels_differ, mut near_boundary) = (0usize, 0usize, 0usize);
        let mut worst = 0.0f64;
        let mut histogram = vec![0usize; rates.levels() as usize];
        for (i, o) in scene.objects.iter().enumerate() {
            let (Some(gpu), Some((shading, coords))) = (&rates.results[i], rates.object(i)) else { continue };
            let motion = &space.objects[i];
            let times = shading_time_count(motion);
            if name.starts_with("camera-") {
                assert!(times > 1, "{name}: {times} shading time(s)");
            }
            for (t, g) in gpu.iter().enumerate() {
                let tex: [Vec2; 3] = [0, 1, 2].map(|k| coords[3 * t + k]);
                let cpu =
                    triangle_level_over_shutter(&intrinsics, &o.mesh, motion, t, tex, rates.levels(), times)
                        .map(|(c, _)| c);
                let what = format!("{name} `{}` ({shading}) triangle {t}", o.name);
                assert_eq!(g.valid, cpu.is_some(), "{what}: GPU {g:?}, CPU {cpu:?}");
                let Some(cpu) = cpu else { continue };
                compared += 1;
                let (a, b) = (g.radius_texels as f64, cpu.radius_texels);
                let rel = (a - b).abs() / b.max(1e-3);
                worst = worst.max(rel);
                assert!(rel <= RADIUS_TOLERANCE, "{what}: radius GPU {a} vs CPU {b}");
                let spacing = (g.spacing_px - cpu.spacing_px).abs() / cpu.spacing_px;
                assert!(
                    spacing < 1e-5,
                    "{what}: grid spacing GPU {} vs CPU {}",
                    g.spacing_px,
                    cpu.spacing_px
                );
                if g.level != cpu.level {
                    let to_boundary = (b.log2() - b.log2().round()).abs();
                    assert!(
                        to_boundary < 2e-3,
                        "{what}: level GPU {} vs CPU {} (r = {b})",
                        g.level,
                        cpu.level
                    );
                    near_boundary += 1;
                    levels_differ += 1;
                }
                histogram[g.level as usize] += 1;
            }
        }
        println!(
            "{name}: {compared} triangles, radius within {worst:.1e} (relative), levels differ on {levels_differ} \
             ({near_boundary} at a power-of-two radius); triangles per level {histogram:?}"
        );
        assert!(compared >= 40, "{name}: {compared} triangles compared");
    }
}

/// Too many generated charts for the atlas: a clear error naming the sizes, not a silent overlap.
/// (`focus-sweep`'s displaced sphere has 327,680 triangles and no uvs of its own: at 2048² its
/// charts with 2-texel gutters do not fit; at 4096² they do.)
#[test]
fn charts_that_do_not_fit_are_a_clear_error() {
    let scene = builtin_scene("focus-sweep").expect("built-in").expect("parses");
    let mut r = renderer();
    let settings = RenderSettings::new(64, 36, 1, 1);
    let err = r
        .prepare_with(&scene, &settings, |ctx| {
            let t: Box<dyn FrameTechnique> = Box::new(ShadingRates::new(ctx, 2048)?);
            Ok(t)
        })
        .map(|_| ())
        .expect_err("2048² is too small for its charts")
        .to_string();
    assert!(err.contains("2048") && err.contains("per-triangle charts"), "{err}");
}

/// Pass 1 of every object of `scene` into `finest²`-level atlases, with or without the conservative
/// sub-pass.
/// Also returns the atlas passes' texel counters (shade sub-pass, conservative sub-pass).
fn atlases_counted(
    scene: &shutter::scene::Scene,
    finest: u32,
    hull: Option<f32>,
) -> (Vec<Option<AtlasResult>>, (u64, u64)) {
    let mut r = renderer();
    let settings = RenderSettings::new(160, 90, 1, 1);
    let atlas = MipAtlas::new(finest, 4).expect("layout");
    let mut prepared = r
        .prepare_with(scene, &settings, |ctx| {
            let t: Box<dyn FrameTechnique> = Box::new(ShadingAtlas::new(ctx, atlas, hull)?);
            Ok(t)
        })
        .expect("prepare");
    r.render_prepared(&mut prepared).expect("pass 1");
    let probe = prepared.technique_as::<ShadingAtlas>().expect("the probe");
    (probe.results.clone(), probe.texels)
}

fn atlases(scene: &shutter::scene::Scene, finest: u32, hull: Option<f32>) -> Vec<Option<AtlasResult>> {
    atlases_counted(scene, finest, hull).0
}

/// Lookups of pass 2 at random points of every triangle read the four texels of a bilinear fetch at
/// the triangle's level. Counts, over all objects, the lookups that read a texel nobody wrote.
fn unwritten_lookups(results: &[Option<AtlasResult>], atlas: MipAtlas, per_triangle: u32) -> (usize, usize) {
    let mut rng = shutter::sampling::Pcg32::new(13, 7);
    let (mut lookups, mut misses) = (0usize, 0usize);
    for res in results.iter().flatten() {
        let img = &res.image;
        for (t, l) in res.levels.iter().enumerate() {
            // Culled triangles are shaded nowhere: no sample can hit them, so nothing looks them up.
            if !l.valid || l.culled {
                continue;
            }
            let [x, y, side, _] = atlas.level_rect(l.level);
            let scale = side as f32 / atlas.finest() as f32;
            for _ in 0..per_triangle {
                let (mut u, mut v) = (rng.next_f32(), rng.next_f32());
                if u + v > 1.0 {
                    (u, v) = (1.0 - u, 1.0 - v);
                }
                let c = &res.coords[3 * t..3 * t + 3];
                let tex = (1.0 - u - v) * c[0] + u * c[1] + v * c[2];
                let a = tex * scale + Vec2::new(x as f32, y as f32) - Vec2::splat(0.5);
                let (x0, y0) = (a.x.floor() as i64, a.y.floor() as i64);
                lookups += 1;
                let written = [(0, 0), (1, 0), (0, 1), (1, 1)].iter().all(|&(dx, dy)| {
                    let (px, py) = (x0 + dx, y0 + dy);
                    px >= 0
                        && py >= 0
                        && (px as u32) < img.width
                        && (py as u32) < img.height
                        && img.get(px as u32, py as u32)[3] > 0.0
                });
                if !written {
                    misses += 1;
                }
            }
        }
    }
    (lookups, misses)
}

/// The depth-trick sub-pass (the paper's Figures 6–8): without it, bilinear lookups near triangle
/// edges read texels no triangle shaded (Figure 6's artefact); with hulls dilated by a whole texel,
/// none do — and the texels the shade sub-pass wrote keep their values (the conservative hulls only
/// add gutters behind them). The paper's half-texel outer hull still leaves some (counted, printed).
#[test]
fn the_conservative_sub_pass_fills_every_texel_a_lookup_reads() {
    let scene = builtin_scene("glass").expect("built-in").expect("parses");
    let finest = 512;
    let atlas = MipAtlas::new(finest, 4).expect("layout");
    let without = atlases(&scene, finest, None);
    let half = atlases(&scene, finest, Some(0.5));
    let (with, (shaded_count, gutter_count)) = atlases_counted(&scene, finest, Some(BILINEAR_HULL_TEXELS));
    let (lookups, misses_without) = unwritten_lookups(&without, atlas, 16);
    let (_, misses_half) = unwritten_lookups(&half, atlas, 16);
    let (_, misses_with) = unwritten_lookups(&with, atlas, 16);
    println!(
        "{lookups} lookups: {misses_without} read an unwritten texel without the conservative sub-pass, \
         {misses_half} with the half-texel outer hull, {misses_with} with the whole-texel one"
    );
    for (a, b) in without.iter().zip(&with) {
        let (Some(a), Some(b)) = (a, b) else { continue };
        let shaded = |img: &shutter::image::LinearImage| img.pixels.iter().filter(|p| p[3] == 1.0).count();
        assert_eq!(shaded(&a.image), shaded(&b.image), "`{}`: the shade sub-pass' texels", a.name);
        for (p, q) in a.image.pixels.iter().zip(&b.image.pixels) {
            if p[3] == 1.0 {
                assert_eq!(p, q, "`{}`: a shaded texel was overwritten", a.name);
            }
        }
        let added = b.image.pixels.iter().filter(|p| p[3] == 0.5).count();
        println!(
            "`{}` ({}): {} texels shaded, {added} gutter texels added",
            a.name,
            a.space,
            shaded(&a.image)
        );
        let _ = shutter::image_io::save_image(
            shutter_tests::output_dir().join(format!("atlas-{}.png", a.name)),
            &b.image,
        );
    }
    // The instrumented atlas passes count exactly the texels each sub-pass wrote: a hull texel behind
    // a shaded one is tested before the fragment stage runs, so it is neither shaded nor counted.
    let written = |alpha: f32| {
        with.iter()
            .flatten()
            .map(|r| r.image.pixels.iter().filter(|p| p[3] == alpha).count() as u64)
            .sum::<u64>()
    };
    assert_eq!((shaded_count, gutter_count), (written(1.0), written(0.5)), "texel counters");
    assert!(misses_without > 0, "no lookup missed without the conservative sub-pass: the test shows nothing");
    assert!(misses_half < misses_without, "the half-texel hull fills some");
    assert_eq!(misses_with, 0, "lookups read unwritten texels with the conservative sub-pass");
}

/// Pass 1's culling over the lens and the shutter (`texture_space/cull.glsl`) against its CPU mirror
/// `texture_space::cull::culled`, triangle by triangle, on `default` (a large ground plane reaching
/// behind the camera and out of the image, depth of field, a moving sphere and a panning camera) with
/// every material made one-sided, so back faces are culled too: the same verdicts, but where the CPU's
/// own verdict changes within ±1 % of the frustum margin or between half and twice the back-facing
/// margin (f32 transforms differ in the last bits); and both cullings are not vacuous.
#[test]
fn gpu_culling_matches_the_cpu_mirror() {
    use shutter::mirror::texture_space::cull::{
        back_facing_by, culled, key_points, outside_frustum, BACK_FACING_MARGIN, CULL_MARGIN_PX,
    };
    let mut scene = builtin_scene("default").expect("built-in").expect("parses");
    for o in &mut scene.objects {
        o.material.one_sided = true;
    }
    let (w, h) = (160, 90);
    let results = atlases(&scene, 256, Some(BILINEAR_HULL_TEXELS));
    let intrinsics = scene.camera.intrinsics(w, h);
    let r = intrinsics.aperture_radius;
    let space = shutter::scene::view::View::camera(&scene, w, h).space;
    let (mut frustum, mut back, mut kept, mut borderline) = (0usize, 0usize, 0usize, 0usize);
    for (i, o) in scene.objects.iter().enumerate() {
        let Some(res) = &results[i] else { continue };
        for (t, l) in res.levels.iter().enumerate() {
            if !l.valid {
                continue;
            }
            let points = key_points(&o.mesh, &space.objects[i], t);
            let (f, b) = culled(&intrinsics, true, &points);
            if l.culled != (f || b) {
                let lo = outside_frustum(&intrinsics, &points, 0.99 * CULL_MARGIN_PX);
                let hi = outside_frustum(&intrinsics, &points, 1.01 * CULL_MARGIN_PX);
                let back_lo = back_facing_by(r, &points, 0.5 * BACK_FACING_MARGIN);
                let back_hi = back_facing_by(r, &points, 2.0 * BACK_FACING_MARGIN);
                assert!(
                    lo != hi || back_lo != back_hi,
                    "`{}` triangle {t}: GPU culled {}, CPU frustum {f} back {b}",
                    o.name,
                    l.culled
                );
                borderline += 1;
            }
            frustum += f as usize;
            back += b as usize;
            kept += !(f || b) as usize;
        }
    }
    println!(
        "default (one-sided) at {w}×{h}: {frustum} triangles outside the frustum, {back} back-facing, \
         {kept} kept, {borderline} borderline"
    );
    assert!(frustum > 0 && back > 0 && kept > frustum, "frustum {frustum}, back {back}, kept {kept}");
}

/// Texture-space shading against a converged reference, beside the exact shading of the same samples
/// (per-sample lookups beside per-sample shading, per-pixel lookups beside per-pixel shading): on
/// `glass` (defocus, a sliding pane, Spot's texture, tinted panes) and `foliage` (shadow maps read by
/// pass 1) at S = 16, its error is within the
/// stated margin of the exact rate's — the price of shading once, at the lens centre and mid-shutter,
/// into a mip level chosen per triangle. Numbers printed with `--nocapture`.
#[test]
fn texture_space_error_is_close_to_exact_shading() {
    use shutter::techniques::ShadingRate;
    let (w, h, spp, seed) = (96, 54, 16, 5);
    let mut r = renderer();
    // `glass` with both lookups; `foliage` (a stochastic shadow map of cut-out leaves, read by pass 1)
    // per sample.
    let cases: [(&str, &[(ShadingRate, ShadingRate)]); 2] = [
        (
            "glass",
            &[
                (ShadingRate::TextureSpace, ShadingRate::PerSample),
                (ShadingRate::TextureSpacePerPixel, ShadingRate::PerPixel),
            ],
        ),
        ("foliage", &[(ShadingRate::TextureSpace, ShadingRate::PerSample)]),
    ];
    for (name, pairs) in cases {
        let scene = builtin_scene(name).expect("built-in").expect("parses");
        let reference = shutter_tests::reference_image(&scene, (w, h), 256, 77);
        let mut render = |shading| {
            let o = shutter::techniques::StochasticOptions { shading, ..Default::default() };
            let s = RenderSettings::new(w, h, spp, seed).with_stochastic(o);
            r.render(&scene, shutter::techniques::Technique::STOCHASTIC, &s).expect("render")
        };
        for &(lookup, exact) in pairs {
            let ts = render(lookup);
            let ex = render(exact);
            let e_ts = shutter::metrics::compare(&reference, &ts.image).expect("compare");
            let e_ex = shutter::metrics::compare(&reference, &ex.image).expect("compare");
            let between = shutter::metrics::compare(&ex.image, &ts.image).expect("compare");
            shutter_tests::save_comparison(&format!("{}-{name}", lookup.name()), &reference, &ts.image);
            shutter_tests::save_comparison(&format!("{}-{name}", exact.name()), &reference, &ex.image);
            println!(
                "{name} S={spp}: {} RMSE {:.5} FLIP {:.5}; {} RMSE {:.5} FLIP {:.5}; between them RMSE {:.5}",
                lookup.name(),
                e_ts.rmse,
                e_ts.flip,
                exact.name(),
                e_ex.rmse,
                e_ex.flip,
                between.rmse
            );
            let names: Vec<&str> = ts.timings.passes.iter().map(|(n, _)| n.as_str()).collect();
            assert!(names.contains(&"atlas shade") && names.contains(&"atlas conservative"), "{names:?}");
            assert!(
                e_ts.flip <= e_ex.flip * TS_FLIP_RATIO_MAX,
                "{name}: {} FLIP {} vs {} {}",
                lookup.name(),
                e_ts.flip,
                exact.name(),
                e_ex.flip
            );
        }
    }
}

/// Stated margin: texture-space shading's FLIP against the reference at most this times that of the
/// exact rate it looks up like (per sample, per pixel) on `glass` at S = 16 (measured 1.035 per
/// sample: FLIP 0.0196 against 0.0189; 1.096 with a half-float atlas).
const TS_FLIP_RATIO_MAX: f64 = 1.15;

/// Issue 28, item 3: a camera that rolls (up (0, 1, 0) → (0, −1, 0)) or turns (look_at swinging
/// behind it) by 180° within the shutter collapses every triangle at mid-shutter — vertices move
/// linearly in camera space — so, shaded at mid-shutter only, no triangle had a footprint and none
/// was shaded (black; `plan --atlases`: 0 texels), and a triangle given a rate elsewhere was shaded
/// with a collapsed normal and light directions. Shaded at several times instead, weighed by how
/// many samples see it then (`atlas.frag`), texture-space shading's floor over per-sample shading's
/// error — √(e_ts² − e_ps²) against a converged reference — stays within the matrix's limit for the
/// rate at every turn and roll (10° is shaded at mid-shutter as before), and the CPU estimate of the
/// texels shaded is not 0. Numbers printed with `--nocapture`.
#[test]
fn texture_space_shades_through_a_half_turn_of_the_camera() {
    use shutter::hard_cases::Column;
    use shutter::techniques::{ShadingRate, StochasticOptions, Technique};
    let (w, h, spp, seed) = (48, 27, 16, 3);
    let limit = Column::Stochastic(ShadingRate::TextureSpace).floor_limit().expect("an approximation");
    let mut r = renderer();
    let scene = |close: &str| {
        let text = format!(
            "[camera]\nposition = [0, 0, 4]\nlook_at = [0, 0, 0]\nvfov_deg = 40\n[camera.close]\n{close}\n\
             [[object]]\nmesh = \"box\"\n[object.transform]\nrotate_deg = [20, 30, 0]\n\
             [object.material]\nalbedo = [0.8, 0.5, 0.3]\ntexture = \"checker\"\n\
             [[object]]\nmesh = \"sphere\"\n[object.transform]\ntranslate = [1.3, 0.4, -0.5]\nscale = 0.5\n\
             [object.material]\nalbedo = [0.3, 0.6, 0.8]\nspecular = 0.3\nroughness = 0.4\n\
             [[light]]\ntype = \"directional\"\ndirection = [-0.3, -1, -0.5]\ncolor = [2, 2, 2]\n\
             [environment]\nbackground = [0.2, 0.3, 0.4]\nambient = [0.05, 0.05, 0.05]\n"
        );
        shutter::scene::file::parse_scene(&text, std::path::Path::new("."), "half-turn").expect("parses")
    };
    let mut cases = vec![];
    for deg in [10f32, 90.0, 180.0] {
        let (s, c) = (deg.to_radians().sin(), deg.to_radians().cos());
        cases.push((format!("roll {deg}°"), format!("up = [{}, {c}, 0]", -s)));
        cases.push((format!("turn {deg}°"), format!("look_at = [{}, 0, {}]", 4.0 * s, 4.0 - 4.0 * c)));
    }
    let mut failures = vec![];
    for (name, close) in &cases {
        let scene = scene(close);
        let reference = shutter_tests::reference_image(&scene, (w, h), 256, 11);
        let mut render = |shading| {
            let o = StochasticOptions { shading, ..Default::default() };
            let s = RenderSettings::new(w, h, spp, seed).with_stochastic(o);
            r.render(&scene, Technique::STOCHASTIC, &s).expect("render").image
        };
        let ts = render(ShadingRate::TextureSpace);
        let ps = render(ShadingRate::PerSample);
        let e_ts = shutter::metrics::compare(&reference, &ts).expect("compare").rmse;
        let e_ps = shutter::metrics::compare(&reference, &ps).expect("compare").rmse;
        let floor = (e_ts * e_ts - e_ps * e_ps).max(0.0).sqrt();
        let file = format!("texture-space-half-turn-{}", name.replace([' ', '°'], ""));
        shutter_tests::save_comparison(&file, &reference, &ts);
        let view = shutter::scene::View::camera(&scene, w, h);
        let largest = MipAtlas::new(
            shutter::techniques::stochastic::TEXTURE_SPACE_FINEST,
            shutter::techniques::stochastic::TEXTURE_SPACE_GUTTER,
        )
        .unwrap();
        let plans = shutter::techniques::texture_space::plan_atlases(&scene, &view, largest);
        let texels: f64 = plans.iter().map(|p| p.texels).sum();
        println!(
            "{name}: texture-space RMSE {e_ts:.4}, per-sample {e_ps:.4}, floor {floor:.4} (limit {limit}); \
             about {texels:.0} texels"
        );
        if floor > limit {
            failures.push(format!(
                "{name}: floor {floor:.4} over {limit} (RMSE {e_ts:.4}, per-sample {e_ps:.4})"
            ));
        }
        if texels <= 100.0 {
            failures.push(format!("{name}: about {texels} texels shaded"));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
