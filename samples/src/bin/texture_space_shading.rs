//! `texture_space_shading [OUT]`: renders Spot walking across the plane of focus with technique `stochastic`
//! and texture-space shading, and writes the image (.png or .exr; default `texture_space_shading.png`).
fn main() -> anyhow::Result<()> {
    let out = std::env::args().nth(1).unwrap_or_else(|| "texture_space_shading.png".into());
    let mut renderer = shutter_samples::renderer()?;
    let sample = shutter_samples::texture_space_shading(&mut renderer, "texture-space")?;
    sample.save(std::path::Path::new(&out))?;
    println!("wrote {out} ({:.1} ms GPU)", sample.output.timings.total_ms());
    Ok(())
}
