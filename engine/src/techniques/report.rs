//! The report `shutter render` prints after a frame: what ran, for how long, and what each path
//! counted. In the engine so that a library caller gets the same lines as the CLI.

use super::{RenderOutput, RenderSettings, Technique};
use crate::scene::Scene;

impl RenderOutput {
    /// The frame's report: a headline (scene, technique, size, S, device, passes, GPU and CPU ms), the
    /// GPU passes' ms, and per path what it decided and counted (plan, transparency, shadows, bounds,
    /// sample counters, caches).
    pub fn report(
        &self,
        scene: &Scene,
        technique: Technique,
        settings: &RenderSettings,
        device_name: &str,
    ) -> Vec<String> {
        let mut lines = Vec::new();
        lines.push(format!(
            "{} {} {}x{} spp {} on {}: {} passes, MSAA {}x, GPU {}, CPU frame {:.1} ms, upload {:.1} ms",
            scene.name,
            technique.name(),
            settings.width,
            settings.height,
            settings.spp,
            device_name,
            self.stats.passes,
            self.stats.msaa_samples,
            if self.timings.passes.is_empty() {
                "not timed (no timestamp queries)".to_string()
            } else {
                format!("{:.1} ms", self.timings.total_ms())
            },
            self.stats.cpu_frame_ms,
            self.stats.upload_ms
        ));
        for (name, ms) in &self.timings.passes {
            lines.push(format!("  {name:<12} {ms:>10.2} ms"));
        }
        if let Some(plan) = &self.stats.plan {
            let paths: Vec<String> =
                plan.objects.iter().map(|o| format!("{} {}", o.name, o.effects.name())).collect();
            lines.push(format!("  plan: {}", paths.join(", ")));
        }
        if let Some(method) = self.stats.transparency {
            // The stochastic frame takes all S samples of a pixel in its pass(es); the forward
            // path's are MSAA × passes.
            if self.stats.msaa_samples == 1 && self.stats.passes < settings.spp {
                lines.push(format!(
                    "  transparency {method}: S = {} samples per pixel (the stochastic frame's)",
                    settings.spp
                ));
            } else {
                lines.push(format!(
                    "  transparency {method}: S = {} samples per pixel (MSAA {}x × {} passes)",
                    self.stats.msaa_samples * self.stats.passes,
                    self.stats.msaa_samples,
                    self.stats.passes
                ));
            }
        }
        if let Some(shadows) = &self.stats.shadows {
            lines.push(format!("  shadows: {shadows}"));
        }
        if technique == Technique::STOCHASTIC
            || self
                .stats
                .plan
                .as_ref()
                .is_some_and(|p| p.auto_frame().0 == crate::plan::AutoFrame::Stochastic)
        {
            let coverage = match self.stats.coverage {
                Some(c) if c.mask_rate().is_some() => format!(
                    "{} coverage (MSAA {}x × {} passes)",
                    c.name(),
                    self.stats.msaa_samples,
                    self.stats.passes
                ),
                Some(c) => format!("{} coverage", c.name()),
                None => format!("{} coverage", settings.stochastic.coverage.name()),
            };
            lines.push(format!(
                "  bound {}, shading {}, {} hull, {coverage}",
                settings.stochastic.bound.name(),
                settings.stochastic.shading.name(),
                settings.stochastic.expansion.name()
            ));
            let clustered: Vec<String> = self
                .stats
                .clusters
                .iter()
                .zip(&scene.objects)
                .filter(|(n, _)| **n > 0)
                .map(|(n, o)| format!("{} ({n} triangles per cluster)", o.name))
                .collect();
            if !clustered.is_empty() {
                lines.push(format!("  cluster bounds: {}", clustered.join(", ")));
            }
        }
        if let Some(p) = self.stats.pipeline_statistics {
            lines.push(format!("  pipeline statistics (the device's): {}", p.summary()));
        }
        if let Some(c) = self.stats.counters {
            lines.push(format!(
                "  fragments {}, samples tested {}, hit {}, STE {:.4}, shading invocations {}",
                c.fragments,
                c.samples_tested,
                c.samples_hit,
                c.sample_test_efficiency(),
                c.shading_invocations
            ));
            if let Some((shaded, gutter)) = c.atlas_texels {
                lines.push(format!(
                    "  atlas texels shaded {shaded} (shade sub-pass) + {gutter} (conservative sub-pass)"
                ));
            }
            if let Some(k) = c.cache {
                match k.memory {
                None => lines.push(format!(
                    "  decoupled cache: {} lookups, {} hits, {} misses shaded, {} evictions, {} stores lost to a race",
                    k.lookups,
                    k.hits,
                    k.misses(),
                    k.evictions,
                    k.busy
                )),
                Some(m) => {
                    lines.push(format!(
                        "  deferred hash table: {} lookups, {} hits, {} new shading points, {} overflows (shaded on the spot)",
                        k.lookups,
                        k.hits,
                        k.misses() - k.overflows,
                        k.overflows
                    ));
                    lines.push(format!(
                        "  deferred memory: {:.2} bytes per sample of a pass (G-buffer {} B + table and queue {} B, {} samples) against {} bytes per sample ({} B) for an MSAA G-buffer",
                        m.bytes_per_sample(),
                        m.refs_bytes,
                        m.table_bytes,
                        m.samples,
                        crate::techniques::stochastic::MSAA_GBUFFER_BYTES_PER_SAMPLE,
                        m.msaa_gbuffer_bytes()
                    ));
                }
            }
            }
        }
        lines
    }
}
