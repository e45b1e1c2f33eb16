//! `decoupled_shading [OUT]`: renders a checkered glossy ball moving past an out-of-focus box with technique
//! `stochastic` and decoupled shading, and writes the image (.png or .exr; default `decoupled_shading.png`).
fn main() -> anyhow::Result<()> {
    let out = std::env::args().nth(1).unwrap_or_else(|| "decoupled_shading.png".into());
    let mut renderer = shutter_samples::renderer()?;
    let sample = shutter_samples::decoupled_shading(&mut renderer, "decoupled", 4096)?;
    sample.save(std::path::Path::new(&out))?;
    println!("wrote {out} ({:.1} ms GPU)", sample.output.timings.total_ms());
    Ok(())
}
