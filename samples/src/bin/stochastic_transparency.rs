//! `stochastic_transparency [OUT]`: renders a tinted pane of coverage 0.4 in front of a moving ball with
//! technique `stochastic`, and writes the image (.png or .exr; default `stochastic_transparency.png`).
fn main() -> anyhow::Result<()> {
    let out = std::env::args().nth(1).unwrap_or_else(|| "stochastic_transparency.png".into());
    let mut renderer = shutter_samples::renderer()?;
    let sample = shutter_samples::stochastic_transparency(&mut renderer)?;
    sample.save(std::path::Path::new(&out))?;
    println!("wrote {out} ({:.1} ms GPU)", sample.output.timings.total_ms());
    Ok(())
}
