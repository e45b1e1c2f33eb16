//! `motion_blur_defocus [OUT]`: renders a ball moving across an 85 mm f/1.4 lens' plane of focus and a box
//! behind it, out of focus, with technique `stochastic`, and writes the image (.png or .exr; default
//! `motion_blur_defocus.png`).
fn main() -> anyhow::Result<()> {
    let out = std::env::args().nth(1).unwrap_or_else(|| "motion_blur_defocus.png".into());
    let mut renderer = shutter_samples::renderer()?;
    let sample = shutter_samples::motion_blur_defocus(&mut renderer)?;
    sample.save(std::path::Path::new(&out))?;
    println!("wrote {out} ({:.1} ms GPU)", sample.output.timings.total_ms());
    Ok(())
}
