//! Tests of the reference renderer against closed-form expectations of the model.

use std::sync::Arc;

use glam::{Mat4, Vec2, Vec3};

use super::*;
use crate::sampling::{ApertureShape, SampleTile, ShutterCurve};
use crate::scene::{CameraPose, Environment, ImageSettings, Light, Material, Mesh, Object};

const W: u32 = 64;
const H: u32 = 64;

fn camera(aperture_radius: f32, focus_distance: f32) -> Camera {
    Camera {
        open: CameraPose { position: Vec3::ZERO, look_at: -Vec3::Z, up: Vec3::Y },
        close: None,
        vfov_deg: 40.0,
        aperture_radius,
        focus_distance,
        aperture: ApertureShape::Disk,
        shutter: ShutterCurve::Box,
        near: 0.1,
        far: 100.0,
    }
}

/// Camera-space point at depth `z` that the pinhole camera sees at pixel position `(px, py)`.
fn unproject(cam: &Camera, w: u32, h: u32, px: f32, py: f32, z: f32) -> Vec3 {
    let tan = cam.intrinsics(w, h).pixel_to_tan(Vec2::new(px, py));
    Vec3::new(tan.x * z, tan.y * z, -z)
}

/// A quad covering pixel rectangle `[x0, x1] × [y0, y1]` (pinhole view) at depth `z`, facing the
/// camera, with uvs.
fn pixel_quad(cam: &Camera, w: u32, h: u32, [x0, x1, y0, y1]: [f32; 4], z: f32) -> Arc<Mesh> {
    let p = [
        unproject(cam, w, h, x0, y1, z),
        unproject(cam, w, h, x1, y1, z),
        unproject(cam, w, h, x1, y0, z),
        unproject(cam, w, h, x0, y0, z),
    ];
    let uv = vec![Vec2::new(0.0, 1.0), Vec2::new(1.0, 1.0), Vec2::new(1.0, 0.0), Vec2::new(0.0, 0.0)];
    Arc::new(Mesh::new("quad", p.to_vec(), vec![Vec3::Z; 4], uv, vec![0, 1, 2, 0, 2, 3]).unwrap())
}

fn object(mesh: Arc<Mesh>, albedo: Vec3, alpha: f32) -> Object {
    Object {
        name: "quad".into(),
        mesh,
        transforms: vec![(0.0, Mat4::IDENTITY)],
        material: Material { albedo, alpha, ..Material::default() },
    }
}

/// A scene lit only by unit ambient light, so radiance = albedo and a white surface's pixel value is
/// its coverage.
fn scene(camera: Camera, objects: Vec<Object>, background: Vec3) -> Scene {
    Scene {
        name: "test".into(),
        image: ImageSettings { width: W, height: H, spp: 64, seed: 1, display: Default::default() },
        camera,
        objects,
        lights: vec![],
        environment: Environment { ambient: Vec3::ONE, background, ..Default::default() },
    }
}

fn settings(width: u32, height: u32, spp: u32) -> ReferenceSettings {
    ReferenceSettings { width, height, spp, seed: 7, progress: false, shading: Default::default() }
}

fn render(scene: &Scene, s: ReferenceSettings) -> LinearImage {
    let (image, stats) = render_reference_with_stats(scene, &s).unwrap();
    assert!(image.all_finite());
    assert!(image.pixels.iter().all(|p| p[3] == 1.0));
    assert_eq!(stats.rays, s.width as u64 * s.height as u64 * s.spp as u64);
    image
}

#[test]
fn pixel_samples_are_the_sample_tile() {
    for spp in [1, 5, 16] {
        let tile = SampleTile::new(spp, SAMPLE_TILE_SIZE, 99);
        for (x, y) in [(0, 0), (5, 9), (63, 63), (64, 0), (130, 77)] {
            assert_eq!(tile.pixel(x, y), &pixel_samples(spp, 99, x, y)[..]);
        }
    }
}

#[test]
fn limits_are_errors_naming_the_limit() {
    let sc = scene(camera(0.0, 5.0), vec![], Vec3::ZERO);
    for (s, what) in [
        (settings(0, 10, 1), "width"),
        (settings(8193, 10, 1), "width"),
        (settings(10, 0, 1), "height"),
        (settings(10, 9000, 1), "height"),
        (settings(10, 10, 0), "spp"),
        (settings(10, 10, 65537), "spp"),
    ] {
        match render_reference(&sc, &s) {
            Err(Error::Limit { what: w, .. }) => assert_eq!(w, what),
            other => panic!("{what}: expected a limit error, got {other:?}"),
        }
    }
    // The scene is checked as the scene file's loader checks it (`Scene::validate`), same words.
    let mut bad = sc.clone();
    bad.camera.near = 0.0;
    let e = render_reference(&bad, &settings(4, 4, 1)).unwrap_err();
    assert!(matches!(e, Error::Scene { .. }), "{e}");
    assert!(e.to_string().ends_with("camera.near: 0 is out of range: must be > 0"), "{e}");
}

#[test]
fn empty_scene_is_background() {
    let img = render(&scene(camera(0.1, 5.0), vec![], Vec3::new(0.1, 0.2, 0.3)), settings(20, 10, 4));
    assert!(img.pixels.iter().all(|p| *p == [0.1, 0.2, 0.3, 1.0]));
}

/// (2) Pinhole coverage at edges through known subpixel positions is exact (x and y are stratified
/// in `spp` strata each).
#[test]
fn pinhole_edge_coverage_is_exact() {
    let cam = camera(0.0, 5.0);
    let quad = pixel_quad(&cam, W, H, [10.5, 20.25, 8.75, 24.5], 5.0);
    let sc = scene(cam, vec![object(quad, Vec3::ONE, 1.0)], Vec3::ZERO);
    let img = render(&sc, settings(W, H, 64));
    let at = |x, y| img.get(x, y)[0];
    for y in 9..24 {
        assert_eq!(at(9, y), 0.0);
        assert!((at(10, y) - 0.5).abs() < 0.02, "left edge through pixel centres: {}", at(10, y));
        assert_eq!(at(15, y), 1.0);
        assert!((at(20, y) - 0.25).abs() < 0.02, "right edge at quarter: {}", at(20, y));
        assert_eq!(at(21, y), 0.0);
    }
    for x in 11..20 {
        assert!((at(x, 8) - 0.25).abs() < 0.02, "top edge: {}", at(x, 8));
        assert!((at(x, 24) - 0.5).abs() < 0.02, "bottom edge: {}", at(x, 24));
        assert_eq!(at(x, 25), 0.0);
    }
    // Corner pixel: 0.5 × 0.25 of the area.
    assert!((at(10, 8) - 0.125).abs() < 0.03, "corner: {}", at(10, 8));
}

/// (3) Same inputs → bit-identical images, for any number of threads.
#[test]
fn renders_are_deterministic_across_thread_counts() {
    let mut cam = camera(0.15, 4.0);
    cam.close = Some(CameraPose { position: Vec3::new(0.2, 0.0, 0.0), look_at: -Vec3::Z, up: Vec3::Y });
    let a = pixel_quad(&cam, 40, 30, [5.0, 30.0, 5.0, 25.0], 3.0);
    let b = pixel_quad(&cam, 40, 30, [15.0, 38.0, 2.0, 20.0], 6.0);
    let mut moving = object(a, Vec3::new(0.9, 0.5, 0.2), 0.6);
    let close = Mat4::from_translation(Vec3::new(0.5, 0.2, -0.3));
    moving.set_close(close);
    let mut sc = scene(cam, vec![moving, object(b, Vec3::new(0.2, 0.7, 0.9), 1.0)], Vec3::new(0.0, 0.0, 0.1));
    sc.lights = vec![
        Light::Directional { direction: Vec3::new(-1.0, -1.0, -1.0), color: Vec3::ONE, shadows: false },
        Light::Point { position: Vec3::new(1.0, 1.0, -1.0), color: Vec3::splat(2.0), shadows: false },
    ];
    sc.objects[1].material.specular = 0.5;
    let s = settings(40, 30, 16);
    let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
    let three = rayon::ThreadPoolBuilder::new().num_threads(3).build().unwrap();
    let x = one.install(|| render(&sc, s));
    let y = three.install(|| render(&sc, s));
    let z = render(&sc, s);
    assert_eq!(x, y);
    assert_eq!(x, z);
    // A different seed is a different estimate.
    let other = render(&sc, ReferenceSettings { seed: 8, ..s });
    assert_ne!(x, other);
}

/// Crossing positions (pixel-centre coordinates) where a row's coverage profile passes `level` going
/// up and going down.
fn crossings(row: &[f32], level: f32) -> (f32, f32) {
    let mut up = f32::NAN;
    let mut down = f32::NAN;
    for x in 0..row.len() - 1 {
        let (a, b) = (row[x], row[x + 1]);
        let at = x as f32 + 0.5 + (level - a) / (b - a);
        if a < level && b >= level && up.is_nan() {
            up = at;
        }
        if a >= level && b < level {
            down = at;
        }
    }
    (up, down)
}

/// (4) A quad moving `m` pixels during a box shutter leaves ramps of width `m` at both ends.
#[test]
fn motion_streak_ramp_matches_motion_length() {
    let (w, h, m) = (96u32, 24u32, 24.0f32);
    let cam = camera(0.0, 5.0);
    let z = 5.0;
    let quad = pixel_quad(&cam, w, h, [10.0, 40.0, 4.0, 20.0], z);
    let shift = m * z / cam.intrinsics(w, h).pixel_scale;
    let mut o = object(quad, Vec3::ONE, 1.0);
    let close = Mat4::from_translation(Vec3::new(shift, 0.0, 0.0));
    o.set_close(close);
    let sc = scene(cam, vec![o], Vec3::ZERO);
    let img = render(&sc, settings(w, h, 64));
    let row: Vec<f32> = (0..w).map(|x| img.get(x, 12)[0]).collect();
    // Trailing ramp rises over [10, 34], leading ramp falls over [40, 64]: 10 % → 90 % spans 0.8 m.
    let (up10, down10) = crossings(&row, 0.1);
    let (up90, down90) = crossings(&row, 0.9);
    assert!(((up90 - up10) - 0.8 * m).abs() < 1.0, "trailing ramp {up10}..{up90}");
    assert!(((down10 - down90) - 0.8 * m).abs() < 1.0, "leading ramp {down90}..{down10}");
    assert!((up10 - (10.0 + 0.1 * m)).abs() < 1.0 && (down10 - (40.0 + 0.9 * m)).abs() < 1.0);
    // Coverage is conserved: the streak integrates to the quad's width.
    let total: f32 = row.iter().sum();
    assert!((total - 30.0).abs() < 0.5, "total {total}");
    // Full coverage in the overlap of start and end positions.
    assert!(row[36] > 0.99 && row[37] > 0.99, "{row:?}");
}

/// (5) A small bright quad far behind the focus plane blurs into a disc of radius |φ(z)|.
#[test]
fn defocus_blur_disc_has_coc_radius() {
    let (f, z, q) = (2.0f32, 10.0f32, 3.0f32);
    let mut cam = camera(0.0, f);
    let s = cam.intrinsics(W, H).pixel_scale;
    let radius = 12.0f32;
    cam.aperture_radius = radius / (s * (1.0 / f - 1.0 / z));
    let intr = cam.intrinsics(W, H);
    assert!((intr.circle_of_confusion_px(z).abs() - radius).abs() < 1e-3);
    let c = 0.5 * W as f32;
    let quad = pixel_quad(&cam, W, H, [c - 0.5 * q, c + 0.5 * q, c - 0.5 * q, c + 0.5 * q], z);
    let sc = scene(cam, vec![object(quad, Vec3::ONE, 1.0)], Vec3::ZERO);
    let img = render(&sc, settings(W, H, 256));
    let (mut energy, mut second, mut outside) = (0.0f64, 0.0f64, 0.0f32);
    let mut centroid = Vec2::ZERO;
    for y in 0..H {
        for x in 0..W {
            let v = img.get(x, y)[0];
            let r = Vec2::new(x as f32 + 0.5 - c, y as f32 + 0.5 - c);
            energy += v as f64;
            second += (v * r.length_squared()) as f64;
            centroid += v * r;
            if r.length() > radius + q / std::f32::consts::SQRT_2 + 1.0 {
                outside = outside.max(v);
            }
        }
    }
    // Each lens point sees the quad's q² pixels, shifted: the total is conserved.
    assert!((energy - (q * q) as f64).abs() < 0.03 * (q * q) as f64, "energy {energy}");
    assert!((centroid / energy as f32).length() < 0.3, "centroid {}", centroid / energy as f32);
    assert_eq!(outside, 0.0, "light outside the disc");
    // E[r²] = R²/2 (uniform disc) + q²/6 (the quad) + 1/6 (box filter over the pixel).
    let mean_r2 = second / energy;
    let est = (2.0 * (mean_r2 - (q * q + 1.0) as f64 / 6.0)).sqrt() as f32;
    assert!((est - radius).abs() < 0.04 * radius, "disc radius {est}, expected {radius}");
}

/// (6) Alpha 0.5 is a 50 % blend, over the background and over another surface.
#[test]
fn half_alpha_blends_half() {
    let cam = camera(0.0, 5.0);
    let front = pixel_quad(&cam, W, H, [-1.0, 65.0, -1.0, 65.0], 2.0);
    let back = pixel_quad(&cam, W, H, [-1.0, 65.0, 32.0, 65.0], 4.0);
    let sc = scene(cam, vec![object(front, Vec3::X, 0.5), object(back, Vec3::Y, 1.0)], Vec3::Z);
    let img = render(&sc, settings(W, H, 64));
    let mean = |y0: u32, y1: u32| {
        let mut m = Vec3::ZERO;
        for y in y0..y1 {
            for x in 0..W {
                let p = img.get(x, y);
                m += Vec3::new(p[0], p[1], p[2]);
                assert!((p[0] - 0.5).abs() < 0.3, "pixel {x},{y} = {p:?}");
            }
        }
        m / ((y1 - y0) * W) as f32
    };
    let over_background = mean(0, 32);
    assert!((over_background - Vec3::new(0.5, 0.0, 0.5)).abs().max_element() < 0.02, "{over_background}");
    let over_surface = mean(32, 64);
    assert!((over_surface - Vec3::new(0.5, 0.5, 0.0)).abs().max_element() < 0.02, "{over_surface}");
}

/// (7) A triangle that crosses the camera plane z = 0 during the shutter (and one that always
/// straddles it) renders without NaN; hits nearer than `near` are clipped.
#[test]
fn triangle_crossing_camera_plane_is_finite() {
    let mut cam = camera(0.2, 3.0);
    cam.shutter = ShutterCurve::Tent;
    let tri = Arc::new(
        Mesh::new(
            "t",
            vec![Vec3::new(-3.0, -2.0, -2.0), Vec3::new(3.0, -2.0, -2.0), Vec3::new(0.0, 3.0, -2.0)],
            vec![],
            vec![],
            vec![0, 1, 2],
        )
        .unwrap(),
    );
    let straddle = Arc::new(
        Mesh::new(
            "s",
            vec![Vec3::new(-1.0, 0.0, 2.0), Vec3::new(1.0, 0.0, 2.0), Vec3::new(0.0, 0.5, -3.0)],
            vec![],
            vec![],
            vec![0, 1, 2],
        )
        .unwrap(),
    );
    let mut crossing = object(tri, Vec3::ONE, 1.0);
    let close = Mat4::from_translation(Vec3::new(0.0, 0.0, 3.0));
    crossing.set_close(close);
    let mut sc = scene(cam, vec![crossing, object(straddle, Vec3::X, 1.0)], Vec3::ZERO);
    sc.lights = vec![Light::Point { position: Vec3::ZERO, color: Vec3::ONE, shadows: false }];
    let img = render(&sc, settings(48, 32, 16));
    let lit = img.pixels.iter().filter(|p| p[0] > 0.0).count();
    assert!(lit > 100, "the triangle is visible for part of the shutter ({lit} pixels)");
}

/// Two-sided shading: a quad seen from its back shades like its front, with the normal flipped.
#[test]
fn back_faces_shade_like_front_faces() {
    let cam = camera(0.0, 5.0);
    let front = pixel_quad(&cam, 16, 16, [-1.0, 17.0, -1.0, 17.0], 3.0);
    // Same quad with reversed winding and normals pointing away from the camera.
    let back = Arc::new(
        Mesh::new("back", front.positions.clone(), vec![-Vec3::Z; 4], vec![], vec![0, 2, 1, 0, 3, 2])
            .unwrap(),
    );
    let mut images = vec![];
    for mesh in [front, back] {
        let mut sc = scene(cam.clone(), vec![object(mesh, Vec3::ONE, 1.0)], Vec3::ZERO);
        sc.environment.ambient = Vec3::ZERO;
        sc.lights = vec![Light::Directional {
            direction: Vec3::new(0.3, -0.2, -1.0),
            color: Vec3::ONE,
            shadows: false,
        }];
        images.push(render(&sc, settings(16, 16, 4)));
    }
    // Flat quad, directional light, no specular: radiance is the same Lambert term everywhere.
    let lambert = Vec3::new(-0.3, 0.2, 1.0).normalize().z;
    for p in &images[0].pixels {
        assert!((p[0] - lambert).abs() < 1e-5, "{p:?} vs {lambert}");
    }
    for (a, b) in images[0].pixels.iter().zip(&images[1].pixels) {
        assert!((a[0] - b[0]).abs() < 1e-5, "{a:?} vs {b:?}");
    }
}

/// One-sided materials: a camera ray passes through a one-sided triangle's back (untinted, unshaded)
/// and still meets its front; the back still casts shadows.
#[test]
fn one_sided_backs_are_invisible_to_camera_rays_but_cast_shadows() {
    let cam = camera(0.0, 5.0);
    let wall = pixel_quad(&cam, 16, 16, [-1.0, 17.0, -1.0, 17.0], 5.0);
    let front = pixel_quad(&cam, 16, 16, [4.0, 12.0, 4.0, 12.0], 3.0);
    let back = Arc::new(
        Mesh::new("back", front.positions.clone(), vec![-Vec3::Z; 4], vec![], vec![0, 2, 1, 0, 3, 2])
            .unwrap(),
    );
    let centre = |mesh: &Arc<Mesh>, one_sided: bool, lit: bool| {
        let mut occluder = object(mesh.clone(), Vec3::new(1.0, 0.0, 0.0), 1.0);
        occluder.material.one_sided = one_sided;
        let mut sc = scene(cam.clone(), vec![object(wall.clone(), Vec3::ONE, 1.0), occluder], Vec3::ZERO);
        if lit {
            sc.environment.ambient = Vec3::ZERO;
            sc.lights = vec![Light::Directional { direction: -Vec3::Z, color: Vec3::ONE, shadows: true }];
        }
        let img = render(&sc, settings(16, 16, 4));
        (img.get(8, 8), img.get(1, 1))
    };
    let red = [1.0, 0.0, 0.0, 1.0];
    let white = [1.0; 4];
    // Two-sided, both orientations are seen; one-sided, only the front.
    assert_eq!(centre(&front, false, false), (red, white));
    assert_eq!(centre(&back, false, false), (red, white));
    assert_eq!(centre(&front, true, false), (red, white));
    assert_eq!(centre(&back, true, false), (white, white));
    // Lit head-on by a directional shadow-casting light: through the culled back the wall is seen in
    // the occluder's shadow; beside it the wall is lit (Lambert 1).
    assert_eq!(centre(&back, true, true), ([0.0, 0.0, 0.0, 1.0], white));
}

/// Textured quads: albedo × bilinear texture at the interpolated uv.
#[test]
fn textures_modulate_albedo() {
    let cam = camera(0.0, 5.0);
    let quad = pixel_quad(&cam, 8, 8, [0.0, 8.0, 0.0, 8.0], 3.0);
    // 4×1 texture: left half white, right half black (sRGB 255 / 0).
    let texels = [[255u8; 4], [255; 4], [0, 0, 0, 255], [0, 0, 0, 255]].concat();
    let texture = Arc::new(Texture::from_srgb_rgba8("t", 4, 1, texels));
    let mut o = object(quad, Vec3::new(0.5, 1.0, 1.0), 1.0);
    o.material.texture = Some(texture);
    let img = render(&scene(cam, vec![o], Vec3::ZERO), settings(8, 8, 16));
    // Pixel 1 spans u ∈ [1/8, 1/4]: between the centres of the two white texels; pixel 6 the black ones.
    let left = img.get(1, 4);
    let right = img.get(6, 4);
    assert!((left[0] - 0.5).abs() < 0.03 && (left[1] - 1.0).abs() < 0.03, "{left:?}");
    assert!(right[1] < 0.03, "{right:?}");
}

/// Progress on stderr (a bar on a terminal, sparse lines otherwise) does not change the image.
#[test]
fn progress_bar_without_terminal_is_harmless() {
    let cam = camera(0.05, 3.0);
    let quad = pixel_quad(&cam, 40, 40, [5.0, 30.0, 5.0, 30.0], 3.0);
    let sc = scene(cam, vec![object(quad, Vec3::ONE, 1.0)], Vec3::ZERO);
    let quiet = render(&sc, settings(40, 40, 4));
    let loud = render(&sc, ReferenceSettings { progress: true, ..settings(40, 40, 4) });
    assert_eq!(quiet, loud);
}

/// Motion keys: objects with different key times split the shutter into several intervals, each with
/// its own tree; every ray at every time finds exactly the hit a brute-force test of every triangle
/// over its own key segment finds.
#[test]
fn keyed_motion_finds_the_brute_force_hit_in_every_interval() {
    let mut cam = camera(0.2, 4.0);
    cam.close = Some(CameraPose { position: Vec3::new(0.3, 0.1, 0.0), look_at: -Vec3::Z, up: Vec3::Y });
    let a = pixel_quad(&cam, W, H, [4.0, 40.0, 6.0, 50.0], 3.0);
    let b = pixel_quad(&cam, W, H, [20.0, 60.0, 10.0, 60.0], 5.0);
    let spin = |k: usize, angle: f32, times: &[f32]| -> Vec<(f32, Mat4)> {
        times
            .iter()
            .enumerate()
            .map(|(i, &t)| {
                let r = Mat4::from_translation(Vec3::new(0.0, 0.0, -3.0 - 0.1 * k as f32))
                    * Mat4::from_rotation_z(angle * t)
                    * Mat4::from_translation(Vec3::new(0.0, 0.0, 3.0 + 0.1 * k as f32));
                (t, if i == 0 { Mat4::IDENTITY } else { r })
            })
            .collect()
    };
    let mut oa = object(a, Vec3::ONE, 1.0);
    oa.transforms = spin(0, 2.0, &[0.0, 0.3, 0.55, 1.0]);
    let mut ob = object(b, Vec3::new(0.3, 0.6, 0.9), 1.0);
    ob.transforms = spin(1, -1.5, &[0.0, 0.3, 0.8, 1.0]);
    let sc = scene(cam, vec![oa, ob], Vec3::ZERO);
    let s = settings(W, H, 4);
    let tracer = Tracer::new(&sc, &s);
    assert_eq!(tracer.intervals.times(), &[0.0, 0.3, 0.55, 0.8, 1.0]);
    assert_eq!(tracer.bvhs.len(), 4);
    let mut rng = Pcg32::new(5, 9);
    let k = sc.camera.intrinsics(W, H);
    let mut hits = 0;
    for i in 0..20_000 {
        let pos = Vec2::new(rng.next_f32() * W as f32, rng.next_f32() * H as f32);
        let lens = sc.camera.aperture.map(Vec2::new(rng.next_f32(), rng.next_f32()));
        // Every tenth ray exactly at a key time.
        let time = if i % 10 == 0 { [0.0, 0.3, 0.55, 0.8, 1.0][i / 10 % 5] } else { rng.next_f32() };
        let (o, d) = k.primary_ray(pos, lens);
        let got = tracer.nearest_hit(o, d, time, (0, 0), 0);
        let mut want: Option<Hit> = None;
        for id in 0..tracer.surface.len() as u32 {
            let ([(p0, _), (p1, _)], st) = tracer.segment_at(id, time);
            let Some(h) =
                crate::geometry::intersect_triangle(&MovingTriangle { v0: p0, v1: p1 }.at(st), o, d)
            else {
                continue;
            };
            let best = want.map_or(f32::INFINITY, |w| w.hit.depth_z);
            if h.depth_z >= sc.camera.near && h.depth_z <= sc.camera.far && h.depth_z < best {
                want = Some(Hit { id, hit: h });
            }
        }
        assert_eq!(got, want, "ray {i} at t = {time}");
        hits += got.is_some() as u32;
    }
    assert!(hits > 4000, "{hits} hits: the test should exercise hits");
}

/// Keys on the straight line an object already moves along change nothing: the motion between them
/// is the same linear motion (up to the rounding of the interior keys' positions).
#[test]
fn keys_on_a_linear_path_leave_the_image_unchanged() {
    let cam = camera(0.1, 4.0);
    let quad = pixel_quad(&cam, 48, 32, [8.0, 30.0, 6.0, 24.0], 4.0);
    let mut two = object(quad, Vec3::new(0.8, 0.6, 0.3), 1.0);
    let shift = Vec3::new(0.6, 0.2, -0.5);
    two.set_close(Mat4::from_translation(shift));
    let mut many = two.clone();
    many.transforms =
        (0..6).map(|i| i as f32 / 5.0).map(|t| (t, Mat4::from_translation(shift * t))).collect();
    let s = settings(48, 32, 32);
    let a = render(&scene(cam.clone(), vec![two], Vec3::ZERO), s);
    let b = render(&scene(cam, vec![many], Vec3::ZERO), s);
    let diff = a.pixels.iter().zip(&b.pixels).map(|(p, q)| (p[0] - q[0]).abs()).fold(0.0f32, f32::max);
    // One sample of 32 flipping at an edge by rounding would be 1/32.
    assert!(diff <= 1.0 / 32.0 + 1e-6, "max difference {diff}");
    let changed = a.pixels.iter().zip(&b.pixels).filter(|(p, q)| p != q).count();
    assert!(changed <= 3, "{changed} pixels changed");
}

// ---- Transparency and shadows (docs/TRANSPARENCY.md) ----

/// A pane's material: coverage `alpha`, colour (= radiance under unit ambient) `albedo`, tint.
fn pane(mesh: Arc<Mesh>, albedo: Vec3, alpha: f32, tint: Vec3) -> Object {
    let mut o = object(mesh, albedo, alpha);
    o.material.tint = tint;
    o
}

/// Overlapping tinted panes in front of a background: the reference's mean over a patch converges
/// to the closed-form composite, within 4 standard errors of the exact per-sample variance, in any
/// object order, and its per-pixel error falls as 1/√S.
#[test]
fn stochastic_coverage_converges_to_the_closed_form_composite() {
    let (w, h) = (32u32, 32u32);
    let cam = camera(0.0, 5.0);
    let background = Vec3::new(0.6, 0.7, 0.8);
    // (pixel rectangle, depth, alpha, colour, tint); the nearest pane covers the left half only.
    let panes = [
        ([-1.0, 16.0, -1.0, 33.0], 2.0, 0.3, Vec3::new(0.9, 0.2, 0.1), Vec3::new(1.0, 0.6, 0.3)),
        ([-1.0, 33.0, -1.0, 33.0], 3.0, 0.5, Vec3::new(0.1, 0.8, 0.3), Vec3::new(0.4, 1.0, 0.7)),
        ([-1.0, 33.0, -1.0, 33.0], 4.0, 0.2, Vec3::new(0.2, 0.3, 0.9), Vec3::new(0.9, 0.9, 0.2)),
        // A pure filter: no coverage, only transmission.
        ([-1.0, 33.0, -1.0, 33.0], 5.0, 0.0, Vec3::ONE, Vec3::new(0.5, 0.8, 1.0)),
    ];
    let objects: Vec<Object> =
        panes.iter().map(|&(rect, z, a, c, t)| pane(pixel_quad(&cam, w, h, rect, z), c, a, t)).collect();
    let layer = |i: usize| {
        let (_, _, a, c, t) = panes[i];
        (a as f64, c.as_dvec3().to_array(), t.as_dvec3().to_array())
    };
    let bg = background.as_dvec3().to_array();
    let left = crate::transparency::composite(&[layer(0), layer(1), layer(2), layer(3)], bg);
    let right = crate::transparency::composite(&[layer(1), layer(2), layer(3)], bg);
    // Columns 0..15 see all four panes, 17..32 the last three.
    let patches = [(0u32..15u32, left), (17..32, right)];

    // (mean error, RMS per-pixel error, standard deviation of one sample) per patch and channel.
    let measure = |img: &LinearImage, spp: u32| {
        let mut out = vec![];
        for (cols, (mean, var)) in &patches {
            for ch in 0..3 {
                let (mut sum, mut sq, mut n) = (0.0f64, 0.0f64, 0.0f64);
                for y in 0..h {
                    for x in cols.clone() {
                        let e = img.get(x, y)[ch] as f64 - mean[ch];
                        sum += e;
                        sq += e * e;
                        n += 1.0;
                    }
                }
                let sigma = var[ch].sqrt();
                out.push((sum / n, (sq / n).sqrt(), sigma, n * spp as f64));
            }
        }
        out
    };
    let mut rms = vec![];
    for (order, spp) in [(0, 16u32), (0, 256), (1, 256)] {
        let mut objects = objects.clone();
        if order == 1 {
            objects.reverse(); // the composite does not depend on the order of the list
        }
        let img = render(&scene(cam.clone(), objects, background), settings(w, h, spp));
        let m = measure(&img, spp);
        for &(mean_error, _, sigma, samples) in &m {
            // 4 standard errors of the mean over the patch's samples as if every coverage decision
            // were independent (pixels are; the stratified samples of one pixel only err less).
            let bound = 4.0 * sigma / samples.sqrt();
            assert!(mean_error.abs() < bound, "S={spp}: mean error {mean_error} ≥ {bound}");
        }
        if order == 0 {
            rms.push(m);
        }
    }
    // The per-pixel RMS error is at most σ/√S — the error of independent coverage decisions; the
    // stratified masks (exactly ⌊αS⌋ or ⌈αS⌉ samples per pixel and triangle) measured 0.26–0.85 of it
    // — and falls by at least about √16 = 4 from S = 16 to 256 (measured 3.9–6.0: a stratified count
    // converges faster than 1/√S).
    for (a, b) in rms[0].iter().zip(&rms[1]) {
        let (rms16, rms256, sigma) = (a.1, b.1, a.2);
        assert!(rms16 <= sigma / 4.0, "RMS {rms16} > σ/√16 = {}", sigma / 4.0);
        assert!(rms256 <= sigma / 16.0, "RMS {rms256} > σ/√256 = {}", sigma / 16.0);
        let ratio = rms16 / rms256;
        assert!((2.8..8.0).contains(&ratio), "error fell by {ratio} from S=16 to S=256 (expected ≥ ~4)");
    }
}

/// Coverage 0 and 1 are exact: a ray through pure filters carries the product of their tints.
#[test]
fn pure_filters_multiply_exactly() {
    let cam = camera(0.0, 5.0);
    let rect = [-1.0, 17.0, -1.0, 17.0];
    let (t1, t2) = (Vec3::new(0.5, 0.25, 1.0), Vec3::new(0.75, 0.5, 0.125));
    let filters = vec![
        pane(pixel_quad(&cam, 16, 16, rect, 2.0), Vec3::ONE, 0.0, t1),
        pane(pixel_quad(&cam, 16, 16, rect, 3.0), Vec3::ONE, 0.0, t2),
    ];
    let img = render(&scene(cam.clone(), filters.clone(), Vec3::ONE), settings(16, 16, 4));
    assert!(img.pixels.iter().all(|p| Vec3::new(p[0], p[1], p[2]) == t1 * t2), "{:?}", img.pixels[0]);
    // An opaque wall behind them: its colour through both filters.
    let mut with_wall = filters;
    with_wall.push(object(pixel_quad(&cam, 16, 16, rect, 4.0), Vec3::new(0.5, 1.0, 0.5), 1.0));
    let img = render(&scene(cam, with_wall, Vec3::ONE), settings(16, 16, 4));
    let want = t1 * t2 * Vec3::new(0.5, 1.0, 0.5);
    assert!(img.pixels.iter().all(|p| Vec3::new(p[0], p[1], p[2]) == want), "{:?}", img.pixels[0]);
}

/// Coverage from the texture's alpha: coverage = alpha × texel alpha at the hit's uv.
#[test]
fn texture_alpha_multiplies_coverage() {
    let cam = camera(0.0, 5.0);
    let quad = pixel_quad(&cam, 16, 16, [0.0, 16.0, 0.0, 16.0], 3.0);
    // 8×1 white texture whose alpha is 0 on the left half and 255 on the right.
    let texels: Vec<u8> = (0..8).flat_map(|i| [255, 255, 255, if i < 4 { 0 } else { 255 }]).collect();
    let mut o = object(quad, Vec3::ONE, 0.5);
    o.material.texture = Some(Arc::new(Texture::from_srgb_rgba8("a", 8, 1, texels)));
    o.material.alpha_from_texture = true;
    let img = render(&scene(cam, vec![o.clone()], Vec3::ZERO), settings(16, 16, 256));
    // Bilinear texel alpha is exactly 0 for u in [1/16, 7/16] (columns 1..7) and exactly 1 for u in
    // [9/16, 15/16] (columns 9..15, coverage 0.5); near u = 0 the repeat addressing blends both.
    let column = |x: u32| (0..16).map(|y| img.get(x, y)[0] as f64).sum::<f64>() / 16.0;
    for x in 1..7 {
        assert_eq!(column(x), 0.0, "column {x}");
    }
    for x in 9..15 {
        assert!((column(x) - 0.5).abs() < 0.05, "column {x}: {}", column(x));
    }
    // Without alpha_from_texture the texture's alpha is ignored.
    o.material.alpha_from_texture = false;
    o.material.alpha = 1.0;
    let img = render(&scene(camera(0.0, 5.0), vec![o], Vec3::ZERO), settings(16, 16, 4));
    assert!(img.pixels.iter().all(|p| p[0] == 1.0));
}

const SHADOW_W: u32 = 32;
/// Shadow scenes: the camera sees only a white wall at depth 6 (ambient `SHADOW_AMBIENT`); occluders
/// lie at depths 3.5–4.5, nearer than the camera's near plane (5), so camera rays skip them while
/// shadow rays (not clipped by the camera's planes) cross them.
const SHADOW_AMBIENT: f32 = 0.05;

fn shadow_scene(lights: Vec<Light>, occluders: Vec<Object>) -> Scene {
    let mut cam = camera(0.0, 6.0);
    cam.near = 5.0;
    let wall = object(pixel_quad(&cam, SHADOW_W, SHADOW_W, [-1.0, 33.0, -1.0, 33.0], 6.0), Vec3::ONE, 1.0);
    let mut objects = vec![wall];
    objects.extend(occluders);
    let mut sc = scene(cam, objects, Vec3::ZERO);
    sc.environment.ambient = Vec3::splat(SHADOW_AMBIENT);
    sc.lights = lights;
    sc
}

/// A square pane of half-size `half` in the plane at depth `z`, centred on the view axis (two
/// triangles sharing the diagonal x = y, which shadow rays cross in these tests).
fn square_pane(half: f32, z: f32, alpha: f32, tint: Vec3) -> Object {
    let p = [
        Vec3::new(-half, -half, -z),
        Vec3::new(half, -half, -z),
        Vec3::new(half, half, -z),
        Vec3::new(-half, half, -z),
    ];
    let uv = vec![Vec2::new(0.0, 1.0), Vec2::new(1.0, 1.0), Vec2::new(1.0, 0.0), Vec2::ZERO];
    let mesh = Arc::new(Mesh::new("pane", p.to_vec(), vec![Vec3::Z; 4], uv, vec![0, 1, 2, 0, 2, 3]).unwrap());
    pane(mesh, Vec3::ONE, alpha, tint)
}

type Pixels = Vec<(u32, u32)>;

/// Pixels of the wall whose every point's segment towards the light crosses the plane at depth
/// `z` inside `|x|, |y| < half − margin` (umbra), and those whose every point crosses outside
/// `half + margin` (lit).
fn umbra_and_lit(light: &Light, half: f32, z: f32) -> (Pixels, Pixels) {
    let cam = shadow_scene(vec![], vec![]).camera;
    let crossing = |p: Vec3| {
        let towards = match *light {
            Light::Directional { direction, .. } => -direction,
            Light::Point { position, .. } | Light::Spot { position, .. } => position - p,
        };
        let s = (-z - p.z) / towards.z;
        p + s * towards
    };
    let (margin, mut umbra, mut lit) = (0.05, vec![], vec![]);
    for y in 0..SHADOW_W {
        for x in 0..SHADOW_W {
            let corners = [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)].map(|(dx, dy)| {
                crossing(unproject(&cam, SHADOW_W, SHADOW_W, x as f32 + dx, y as f32 + dy, 6.0))
            });
            if corners.iter().all(|q| q.x.abs().max(q.y.abs()) < half - margin) {
                umbra.push((x, y));
            } else if corners.iter().all(|q| q.x.abs().max(q.y.abs()) > half + margin) {
                lit.push((x, y));
            }
        }
    }
    assert!(umbra.len() > 20 && lit.len() > 20, "umbra {} lit {}", umbra.len(), lit.len());
    (umbra, lit)
}

fn rgb(img: &LinearImage, (x, y): (u32, u32)) -> Vec3 {
    let p = img.get(x, y);
    Vec3::new(p[0], p[1], p[2])
}

/// Shadow rays towards point, directional and spot lights: an opaque occluder leaves exactly the
/// ambient light in its umbra; a tinted pane multiplies the direct light by `(1 − α)·T` per channel;
/// two panes by the product, in either order; outside the shadow, and with `shadows = false`, the
/// image is bit-identical to the unshadowed one (no shadow acne).
#[test]
fn shadow_rays_multiply_the_transmittance_of_what_they_cross() {
    let lights = [
        Light::Point { position: Vec3::new(0.3, 0.2, -2.0), color: Vec3::splat(16.0), shadows: true },
        Light::Directional {
            direction: Vec3::new(-0.1, 0.05, -1.0).normalize(),
            color: Vec3::ONE,
            shadows: true,
        },
        Light::Spot {
            position: Vec3::new(0.3, 0.2, -2.0),
            direction: -Vec3::Z,
            inner_deg: 50.0,
            outer_deg: 60.0,
            color: Vec3::splat(16.0),
            shadows: true,
        },
    ];
    let s = settings(SHADOW_W, SHADOW_W, 4);
    for light in lights {
        let unshadowed_light = match light {
            Light::Point { position, color, .. } => Light::Point { position, color, shadows: false },
            Light::Directional { direction, color, .. } => {
                Light::Directional { direction, color, shadows: false }
            }
            Light::Spot { position, direction, inner_deg, outer_deg, color, .. } => {
                Light::Spot { position, direction, inner_deg, outer_deg, color, shadows: false }
            }
        };
        let (half, z) = (0.6, 4.0);
        let (umbra, lit) = umbra_and_lit(&light, half, z);
        let free = render(&shadow_scene(vec![light], vec![]), s);
        let unshadowed = render(&shadow_scene(vec![unshadowed_light], vec![]), s);
        assert_eq!(free, unshadowed, "{light:?}: an unoccluded shadow-casting light changes nothing");
        // shadows = false: the occluder is ignored.
        let ignored =
            render(&shadow_scene(vec![unshadowed_light], vec![square_pane(half, z, 1.0, Vec3::ONE)]), s);
        assert_eq!(ignored, unshadowed, "{light:?}");

        let ambient = Vec3::splat(SHADOW_AMBIENT);
        let opaque = render(&shadow_scene(vec![light], vec![square_pane(half, z, 1.0, Vec3::ONE)]), s);
        for &px in &umbra {
            assert_eq!(rgb(&opaque, px), ambient, "{light:?} umbra {px:?}");
        }
        for &px in &lit {
            assert_eq!(rgb(&opaque, px), rgb(&unshadowed, px), "{light:?} lit {px:?}");
            assert!(rgb(&unshadowed, px).x > SHADOW_AMBIENT + 0.05, "{light:?}: lit {px:?} gets light");
        }

        // Tinted panes, one and two (both orders).
        let (a1, t1) = (0.25, Vec3::new(0.8, 0.5, 0.2));
        let (a2, t2) = (0.5, Vec3::new(0.3, 1.0, 0.6));
        let p1 = || square_pane(half, z, a1, t1);
        // Behind the first, and large enough to cover the first one's umbra.
        let p2 = || square_pane(half + 0.25, z + 0.5, a2, t2);
        let v1 = (1.0 - a1) * t1;
        let v12 = v1 * ((1.0 - a2) * t2);
        let lit2: Vec<(u32, u32)> =
            umbra_and_lit(&light, half + 0.25, z + 0.5).1.into_iter().filter(|p| lit.contains(p)).collect();
        for (occluders, v, lit) in
            [(vec![p1()], v1, &lit), (vec![p1(), p2()], v12, &lit2), (vec![p2(), p1()], v12, &lit2)]
        {
            let img = render(&shadow_scene(vec![light], occluders), s);
            for &px in &umbra {
                let (got, direct) = (rgb(&img, px) - ambient, rgb(&unshadowed, px) - ambient);
                assert!(direct.min_element() > 0.05, "{light:?} {px:?}: {direct}");
                let err = (got - v * direct).abs().max_element();
                assert!(err < 1e-5, "{light:?} umbra {px:?}: {got} vs {v} × {direct}");
            }
            for &px in lit {
                assert_eq!(rgb(&img, px), rgb(&unshadowed, px), "{light:?} lit {px:?}");
            }
        }
    }
}

/// A shadow ray through the edge two triangles of one pane share hits both; it is one crossing.
#[test]
fn a_shadow_ray_through_a_shared_edge_crosses_once() {
    let t = Vec3::new(0.8, 0.5, 0.2);
    let sc = shadow_scene(vec![], vec![square_pane(0.6, 4.0, 0.25, t)]);
    let s = settings(SHADOW_W, SHADOW_W, 1);
    let tracer = Tracer::new(&sc, &s);
    // From the wall's centre straight at the light: through (0, 0, −4), on the pane's diagonal.
    let (o, d) = (Vec3::new(0.0, 0.0, -6.0), Vec3::new(0.0, 0.0, 4.0));
    let mut hits = vec![];
    tracer.bvhs[0].for_each_hit(o, d, 0.5, 0.0, 1.0, |id, _, s| {
        hits.push((id, s));
        true
    });
    assert_eq!(hits.len(), 2, "both triangles: {hits:?}");
    assert_eq!(tracer.transmittance(o, d, 1.0, 0.5, 1e-4), 0.75 * t);
    // Two panes of different objects at the same place are two crossings.
    let sc = shadow_scene(vec![], vec![square_pane(0.6, 4.0, 0.25, t), square_pane(0.6, 4.0, 0.25, t)]);
    let tracer = Tracer::new(&sc, &s);
    assert_eq!(tracer.transmittance(o, d, 1.0, 0.5, 1e-4), (0.75 * t) * (0.75 * t));
}

/// The form factor from a differential area to a parallel rectangle `[0, a] × [0, b]` (in units of
/// their distance) whose corner lies straight across from it: Howell's catalogue, C-11.
fn corner_form_factor(a: f64, b: f64) -> f64 {
    let (sa, sb) = ((1.0 + a * a).sqrt(), (1.0 + b * b).sqrt());
    (a / sa * (b / sa).atan() + b / sb * (a / sb).atan()) / (2.0 * std::f64::consts::PI)
}

/// A small grey sensor facing a white floor (a square 4 × 4 at distance 1) that a directional light at
/// 30° lights; the sensor's own face gets no direct light and there is no ambient, so all it shows is
/// the floor's light reflected once more: `ρ_sensor · ρ_floor · cos 30° · (F_floor − F_shadow)` with `F`
/// the form factors from the sensor to the floor and to its own shadow on it. The scene (without
/// indirect light) and that closed form.
fn lit_floor_and_sensor() -> (Scene, f64) {
    let (h, half, s, theta) = (1.0f32, 2.0f32, 0.04f32, 30f32.to_radians());
    let (rho_floor, rho_sensor) = (0.8f32, 0.5f32);
    // A square in the plane z = c.z, wound so that its geometric normal is `normal` (±z).
    let square = |name: &str, c: Vec3, half: f32, normal: Vec3| {
        let p = [
            c + Vec3::new(-half, -half, 0.0),
            c + Vec3::new(half, -half, 0.0),
            c + Vec3::new(half, half, 0.0),
            c + Vec3::new(-half, half, 0.0),
        ];
        let indices = if normal.z > 0.0 { vec![0, 1, 2, 0, 2, 3] } else { vec![0, 2, 1, 0, 3, 2] };
        Arc::new(Mesh::new(name, p.to_vec(), vec![normal; 4], vec![], indices).unwrap())
    };
    // The camera between them looks at the sensor (depth 0.5); the floor lies behind it.
    let sensor = object(
        square("sensor", Vec3::new(0.0, 0.0, -0.5 * h), 0.5 * s, Vec3::Z),
        Vec3::splat(rho_sensor),
        1.0,
    );
    let floor =
        object(square("floor", Vec3::new(0.0, 0.0, 0.5 * h), half, -Vec3::Z), Vec3::splat(rho_floor), 1.0);
    let mut cam = camera(0.0, 1.0);
    cam.vfov_deg = 3.0;
    let mut sc = scene(cam, vec![sensor, floor], Vec3::ZERO);
    sc.environment.ambient = Vec3::ZERO;
    // From the light into the scene: towards +z (the floor), tilted by θ.
    sc.lights = vec![Light::Directional {
        direction: Vec3::new(-theta.sin(), 0.0, theta.cos()),
        color: Vec3::ONE,
        shadows: true,
    }];
    let a = (half / h) as f64;
    let floor_ff = 4.0 * corner_form_factor(a, a);
    // The sensor's shadow: its own square, shifted by h·tan θ, seen from its centre (small: to first
    // order in its area).
    let r2 = (h as f64).powi(2) + (h * theta.tan()) as f64 * (h * theta.tan()) as f64;
    let shadow_ff = (s as f64).powi(2) * (h as f64).powi(2) / (std::f64::consts::PI * r2 * r2);
    (sc, (rho_sensor * rho_floor * theta.cos()) as f64 * (floor_ff - shadow_ff))
}

fn mean_red(img: &LinearImage) -> f64 {
    img.pixels.iter().map(|p| p[0] as f64).sum::<f64>() / img.pixels.len() as f64
}

/// One-bounce indirect light by bounce rays against its closed form ([`lit_floor_and_sensor`]): the
/// reference's mean over the sensor matches to 1 % (the estimate's standard error is about 0.15 %); with
/// `indirect = none` the sensor is black.
#[test]
fn one_bounce_matches_the_form_factor_of_a_lit_floor() {
    let (mut sc, expected) = lit_floor_and_sensor();
    let dark = render(&sc, settings(16, 16, 16));
    assert_eq!(mean_red(&dark), 0.0, "the sensor's face is unlit without indirect light");
    sc.environment.indirect = Indirect::OneBounce;
    let img = render(&sc, settings(16, 16, 256));
    let got = mean_red(&img);
    println!("one bounce: {got:.5} against the closed form {expected:.5}");
    assert!((got / expected - 1.0).abs() < 0.01, "{got} against {expected}");
    // Each pixel's own estimate is noisy but unbiased: none far from the mean.
    assert!(img.pixels.iter().all(|p| (p[0] as f64 - expected).abs() < 0.3 * expected));
}

/// The same light by instant radiosity ([`vpl`]): the directional light's photons land on the floor
/// (and the sensor's back) as VPLs, and the sensor gathering them matches the closed form to 1 %;
/// clamping the `1/d²` beyond the nearest VPLs' distance (1) darkens it, as it must. VPLs are refused
/// for a scene without indirect light and for a moving one.
#[test]
fn virtual_point_lights_match_the_form_factor_of_a_lit_floor() {
    let (mut sc, expected) = lit_floor_and_sensor();
    let v = VplSettings { count: 4096, clamp: 0.0, seed: 3 };
    assert!(matches!(render_reference_vpl(&sc, &settings(4, 4, 1), &v), Err(Error::Unsupported(_))));
    sc.environment.indirect = Indirect::OneBounce;
    let vpls = virtual_point_lights(&sc, &v).unwrap();
    // The photons leave a disk across the light around the scene's bounding sphere (radius: half the
    // diagonal of the box [−2, 2]² × [−0.5, 0.5]); those that meet the floor (its area seen from the
    // light: 16 cos 30°) land, and the sensor's back takes the few its shadow stands for.
    let disk = std::f64::consts::PI * 0.25 * 33.0;
    let share = 16.0 * 30f64.to_radians().cos() / disk;
    let landed = vpls.len() as f64 / 4096.0;
    assert!((landed - share).abs() < 0.01, "{} VPLs: {landed} of the photons against {share}", vpls.len());
    let (img, _, n) = render_reference_vpl(&sc, &settings(8, 8, 4), &v).unwrap();
    assert_eq!(n, vpls.len());
    let got = mean_red(&img);
    println!("instant radiosity, {n} VPLs: {got:.5} against the closed form {expected:.5}");
    assert!((got / expected - 1.0).abs() < 0.01, "{got} against {expected}");
    let clamped =
        mean_red(&render_reference_vpl(&sc, &settings(8, 8, 4), &VplSettings { clamp: 1.5, ..v }).unwrap().0);
    println!("clamped at 1.5: {clamped:.5}");
    assert!(clamped < 0.95 * got, "clamping at 1.5 leaves {clamped} of {got}");
    let mut moving = sc.clone();
    moving.objects[0].transforms.push((1.0, Mat4::from_translation(Vec3::X)));
    assert!(matches!(render_reference_vpl(&moving, &settings(4, 4, 1), &v), Err(Error::Unsupported(_))));
}

/// The cosine-distributed directions: unit length, in the normal's hemisphere, and with the density
/// `cos θ / π` (the mean of cos θ is 2/3, of cos² θ is 1/2).
#[test]
fn cosine_directions_follow_the_cosine() {
    let mut rng = Pcg32::new(3, 4);
    for n in [
        Vec3::Z,
        -Vec3::Z,
        Vec3::new(0.3, -0.8, 0.2).normalize(),
        Vec3::new(0.0, 0.0, -1.0 + 1e-7).normalize(),
    ] {
        let set = crate::sampling::multi_jittered(4096, &mut rng);
        let (mut c1, mut c2) = (0.0f64, 0.0f64);
        for u in &set {
            let d = cosine_direction(n, *u);
            assert!((d.length() - 1.0).abs() < 1e-5 && d.dot(n) >= -1e-6, "{n} {u} {d}");
            c1 += d.dot(n) as f64;
            c2 += (d.dot(n) as f64).powi(2);
        }
        let k = set.len() as f64;
        assert!(
            (c1 / k - 2.0 / 3.0).abs() < 2e-3 && (c2 / k - 0.5).abs() < 2e-3,
            "{n}: {} {}",
            c1 / k,
            c2 / k
        );
    }
}

/// Issue 28, item 14: the memory estimate the reference checks before any work follows what it
/// allocates: on a 1,046,528-triangle sphere at 2 and 8 motion keys, within 25 % of the peak RSS
/// above the loaded scene measured with `/usr/bin/time` (477 MB and 1,728 MB).
#[test]
fn memory_estimate_matches_the_measured_peak() {
    let mesh = Arc::new(crate::scene::builtin::builtin_mesh("sphere", Some(1024)).unwrap().unwrap());
    assert_eq!(mesh.triangle_count(), 1_046_528);
    let s = |keys: usize| {
        let mut sc = scene(camera(0.0, 5.0), vec![], Vec3::ZERO);
        let transforms = (0..keys)
            .map(|k| {
                (k as f32 / (keys - 1) as f32, Mat4::from_translation(Vec3::new(k as f32 * 0.1, 0.0, -5.0)))
            })
            .collect();
        sc.objects.push(Object {
            name: "sphere".into(),
            mesh: mesh.clone(),
            transforms,
            material: Default::default(),
        });
        let settings = settings(8, 8, 1);
        memory_estimate(&sc, &settings).0 as f64 - mesh.heap_bytes() as f64
    };
    for (keys, measured) in [(2, 477e6), (8, 1728e6)] {
        let estimate = s(keys);
        assert!(
            (estimate / measured - 1.0).abs() < 0.25,
            "{keys} keys: estimate {estimate:.3e}, measured {measured:.3e}"
        );
    }
}

/// Measures, for shadow-ray offsets of k·2⁻²⁴ times the triangle's coordinate scale, how often a
/// shadow ray from a shaded point (found as the reference finds it: a camera ray's barycentric point)
/// hits its own surface — the triangle, its coplanar neighbour across the diagonal, or a neighbour
/// folded 30° away (convex) — for lights down to 0.06° above the surface, triangles of size 10⁻² to
/// 10³ placed up to 20 sizes from the origin.
fn self_hits(multipliers: &[f32], cases: usize) -> Vec<usize> {
    use crate::geometry::intersect_triangle;
    let mut rng = Pcg32::new(0x5eed, 11);
    let mut u = || rng.next_f32();
    let mut fails = vec![0; multipliers.len()];
    for _ in 0..cases {
        let size = 10f32.powf(-2.0 + 5.0 * u());
        let centre = Vec3::new(u() - 0.5, u() - 0.5, -0.2 - u()) * 20.0 * size * u();
        let rot = glam::Quat::from_euler(glam::EulerRot::XYZ, 6.3 * u(), 6.3 * u(), 6.3 * u());
        let at = |x: f32, y: f32, z: f32| centre + rot * (Vec3::new(x, y, z) * size);
        let (a, b, c, d) = (at(-0.5, -0.5, 0.0), at(0.5, -0.5, 0.0), at(0.5, 0.5, 0.0), at(-0.5, 0.5, 0.0));
        // The light's side, and the fold away from it (a convex edge seen from the light).
        let side = if u() < 0.5 { 1.0 } else { -1.0 };
        let fold = at(1.0, 0.0, -side * 0.5 * 30f32.to_radians().tan());
        let tris = [[a, b, c], [a, c, d], [b, fold, c]];
        let bvh = Bvh::build(&tris.map(MovingTriangle::fixed));
        // A camera ray (from the origin) to a point of the first triangle.
        let (w1, w2) = (u(), u());
        let (w1, w2) = if w1 + w2 > 1.0 { (1.0 - w1, 1.0 - w2) } else { (w1, w2) };
        let target = tris[0][0] + w1 * (tris[0][1] - tris[0][0]) + w2 * (tris[0][2] - tris[0][0]);
        let Some(hit) = intersect_triangle(&tris[0], Vec3::ZERO, target) else { continue };
        let position = hit.point(&tris[0]);
        let scale = tris[0].iter().fold(position.abs().max_element(), |m, v| m.max(v.abs().max_element()));
        let g = (tris[0][1] - tris[0][0]).cross(tris[0][2] - tris[0][0]).normalize();
        // A light between 0.001 rad and normal incidence.
        let elevation = 0.001f32.max(std::f32::consts::FRAC_PI_2 * u() * u() * u());
        let along = g.any_orthonormal_vector();
        let along = glam::Quat::from_axis_angle(g, 6.3 * u()) * along;
        let l = (side * elevation.sin() * g + elevation.cos() * along).normalize();
        for (k, &m) in multipliers.iter().enumerate() {
            let offset = m * f32::EPSILON * 0.5 * scale;
            let o = position + if g.dot(l) >= 0.0 { offset } else { -offset } * g;
            let mut hits = 0;
            bvh.for_each_hit(o, l, 0.5, 0.0, f32::INFINITY, |_, _, _| {
                hits += 1;
                false
            });
            fails[k] += (hits > 0) as usize;
        }
    }
    fails
}

/// The direct shadow rays' origin offset ([`SHADOW_RAY_LIFT`], 64 ulps of the scale) clears the
/// shaded surface in every case of [`self_hits`], with a wide margin: 4 ulps already do, 1 does not.
#[test]
fn shadow_rays_clear_their_own_surface() {
    let ulps = SHADOW_RAY_LIFT / (0.5 * f32::EPSILON);
    let multipliers = [1.0, 2.0, 4.0, ulps];
    let fails = self_hits(&multipliers, 50_000);
    println!("self-hits in 50000 at 1, 2, 4, {ulps} ulps: {fails:?}");
    assert!(fails[0] > 0, "the cases are not hard enough: {fails:?}");
    assert_eq!((fails[2], fails[3]), (0, 0), "{fails:?}");
}
