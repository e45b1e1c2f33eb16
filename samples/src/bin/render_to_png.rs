//! `render_to_png [SCENE] [OUT]`: renders a scene with accumulation buffering, 16 passes, 640×360.
fn main() -> anyhow::Result<()> {
    let mut args = std::env::args().skip(1);
    let scene = args.next().unwrap_or_else(|| "default".into());
    let out = args.next().unwrap_or_else(|| "render_to_png.png".into());
    let ms = shutter_samples::render_to_png(
        &scene,
        shutter::techniques::Technique::ACCUMULATION,
        640,
        360,
        16,
        std::path::Path::new(&out),
    )?;
    println!("wrote {out} ({ms:.1} ms GPU)");
    Ok(())
}
