//! `shadow_maps [OUT]`: renders a box and a ball casting sun shadows, from 1024² shadow maps, with technique
//! `stochastic` through a lens, and writes the image (.png or .exr; default `shadow_maps.png`).
fn main() -> anyhow::Result<()> {
    let out = std::env::args().nth(1).unwrap_or_else(|| "shadow_maps.png".into());
    let mut renderer = shutter_samples::renderer()?;
    let sample = shutter_samples::shadow_maps(&mut renderer, "1024/4/1")?;
    sample.save(std::path::Path::new(&out))?;
    println!("wrote {out} ({:.1} ms GPU)", sample.output.timings.total_ms());
    Ok(())
}
