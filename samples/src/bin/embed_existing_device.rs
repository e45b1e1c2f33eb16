//! `embed_existing_device [OUT]`: renders the sample scene with technique `stochastic` on a device,
//! command buffer and image of its own (Shutter borrows them), reads its image back and writes it
//! (.png or .exr; default `embed_existing_device.png`).
fn main() -> anyhow::Result<()> {
    let out = std::env::args().nth(1).unwrap_or_else(|| "embed_existing_device.png".into());
    let scene = shutter_samples::embedding_scene()?;
    let frame = shutter_samples::embed_existing_device(&scene)?;
    shutter::image_io::save_image(std::path::Path::new(&out), &frame.image)?;
    println!("wrote {out} ({} passes recorded into the engine's command buffer)", frame.passes.len());
    Ok(())
}
