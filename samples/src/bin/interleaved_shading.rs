//! `interleaved_shading [OUT]`: renders a Cornell box with one bounce of indirect light with technique
//! `interleaved` (256 photons), and writes the image (.png or .exr; default `interleaved_shading.png`).
fn main() -> anyhow::Result<()> {
    let out = std::env::args().nth(1).unwrap_or_else(|| "interleaved_shading.png".into());
    let mut renderer = shutter_samples::renderer()?;
    let sample = shutter_samples::interleaved_shading(&mut renderer, 256)?;
    sample.save(std::path::Path::new(&out))?;
    println!("wrote {out} ({:.1} ms GPU)", sample.output.timings.total_ms());
    Ok(())
}
