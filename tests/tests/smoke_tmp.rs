use glam::{Mat4, Vec2, Vec3};
use shutter::sampling::*;
use shutter::scene::*;
use std::sync::Arc;

#[test]
fn smoke() {
    let mesh = Mesh::new(
        "quad",
        vec![Vec3::new(-1., -1., 0.), Vec3::new(1., -1., 0.), Vec3::new(1., 1., 0.), Vec3::new(-1., 1., 0.)],
        vec![],
        vec![Vec2::ZERO; 4],
        vec![0, 1, 2, 0, 2, 3],
    )
    .unwrap();
    let scene = Scene {
        name: "t".into(),
        image: ImageSettings { width: 64, height: 48, spp: 4, seed: 1 },
        camera: Camera {
            open: CameraPose { position: Vec3::new(0., 0., 5.), look_at: Vec3::ZERO, up: Vec3::Y },
            close: None,
            vfov_deg: 40.0,
            aperture_radius: 0.1,
            focus_distance: 5.0,
            aperture: ApertureShape::Disk,
            shutter: ShutterCurve::Box,
            near: 0.05,
            far: 100.0,
        },
        objects: vec![Object {
            name: "q".into(),
            mesh: Arc::new(mesh),
            transform_open: Mat4::IDENTITY,
            transform_close: Some(Mat4::from_translation(Vec3::X)),
            material: Material::default(),
        }],
        lights: vec![Light::Directional { direction: Vec3::new(0., 0., -1.), color: Vec3::ONE }],
        environment: Environment::default(),
    };
    let dev = shutter::vk::create_device().unwrap();
    println!("{}", dev.caps);
    let mut r = shutter::techniques::Renderer::new(dev).unwrap();
    for t in [shutter::techniques::Technique::Pinhole, shutter::techniques::Technique::Accumulation] {
        let s = shutter::techniques::RenderSettings { width: 64, height: 48, spp: 16, seed: 1 };
        let out = r.render(&scene, t, &s).unwrap();
        let c = out.image.get(32, 24);
        println!("{:?} center {:?} corner {:?} {:?}", t, c, out.image.get(0, 0), out.timings);
        for y in (0..48).step_by(4) {
            let row: String = (0..64)
                .map(|x| {
                    let v = out.image.get(x, y)[0];
                    if v > 0.6 {
                        '#'
                    } else if v > 0.2 {
                        '+'
                    } else {
                        '.'
                    }
                })
                .collect();
            println!("{row}");
        }
    }
}
