//! One grammar for a render's settings: `KEY=VALUE`, the same for `shutter render` (its flags and
//! `--set`), `shutter bench -c`, `shutter quality -s` and a library caller ([`RenderSettings::set`]).
//!
//! Each key belongs to the options of what reads it, and is parsed there: the frame's own keys
//! (`spp`, `seed`, `size`) here, the stochastic frame's in [`StochasticOptions::set`], technique
//! `interleaved`'s in [`InterleavedOptions::set`], the shadow maps' and transparency's by their
//! settings' `FromStr`. [`OPTION_KEYS`] lists every key with its owner and values, for help texts
//! and error messages, and a test checks that every listed key is accepted.

use super::interleaved::InterleavedOptions;
use super::stochastic::StochasticOptions;
use super::RenderSettings;
use crate::error::{Error, Result};

/// One settings key: who reads it and what it takes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct OptionKey {
    pub key: &'static str,
    /// The technique or stage whose options hold it.
    pub owner: &'static str,
    /// Its values, as a user types them.
    pub values: &'static str,
    /// An example value (the key's test sets it).
    pub example: &'static str,
}

const fn key(
    key: &'static str,
    owner: &'static str,
    values: &'static str,
    example: &'static str,
) -> OptionKey {
    OptionKey { key, owner, values, example }
}

/// Every key [`RenderSettings::set`] takes.
pub const OPTION_KEYS: &[OptionKey] = &[
    key("spp", "frame", "samples per pixel S", "16"),
    key("seed", "frame", "the sample pattern's seed", "7"),
    key("size", "frame", "WIDTHxHEIGHT", "96x54"),
    key("shadow-map", "shadow maps", "SIZE[/SAMPLES[/PCF]] or off", "512/4/1"),
    key("transparency", "pinhole, accumulation", "a transparency method (docs/TRANSPARENCY.md)", "peeling/4"),
    key("bound", "stochastic", "a bound or a per-object policy (docs/STOCHASTIC.md)", "bbox"),
    key("shading", "stochastic", "a shading rate", "per-pixel"),
    key("per-pass", "stochastic", "samples per pass", "8"),
    key("hull", "stochastic", "geometry-shader or compute", "compute"),
    key("intervals", "stochastic", "time intervals of the bounds: auto or a power of two", "4"),
    key("clusters", "stochastic", "cluster bounds: auto, off or triangles per cluster", "32"),
    key("cache", "stochastic", "decoupled shading's cache entries", "4096"),
    key("vpls", "interleaved", "photons", "256"),
    key("clamp", "interleaved", "the VPLs' clamp distance", "0.2"),
    key("pattern", "interleaved", "NxM", "8x6"),
    key("split", "interleaved", "one or two", "one"),
    key("block", "interleaved", "BxB patterns", "2x2"),
    key("filter", "interleaved", "none, plain, full or axis", "plain"),
    key("radius", "interleaved", "the filter's radius in texels", "3"),
    key("bilinear", "interleaved", "false, true (pairs lerped in the shader) or sampler", "true"),
    key("vpl-maps", "interleaved", "SIZE texels a face, or off", "16"),
];

/// The keys, for an error message: `spp, seed, … (stochastic: bound, …)`.
pub fn option_key_names() -> String {
    let mut owners: Vec<&str> = Vec::new();
    for k in OPTION_KEYS {
        if !owners.contains(&k.owner) {
            owners.push(k.owner);
        }
    }
    owners
        .iter()
        .map(|o| {
            let keys: Vec<&str> = OPTION_KEYS.iter().filter(|k| k.owner == *o).map(|k| k.key).collect();
            format!("{o}: {}", keys.join(", "))
        })
        .collect::<Vec<_>>()
        .join("; ")
}

fn setting_error(key: &str, value: &str, message: impl std::fmt::Display) -> Error {
    Error::Unsupported(format!("setting `{key}={value}`: {message}"))
}

/// `value` parsed as `T`, or an error naming the setting.
fn number<T: std::str::FromStr>(key: &str, value: &str) -> Result<T>
where
    T::Err: std::fmt::Display,
{
    value.parse().map_err(|e| setting_error(key, value, e))
}

impl RenderSettings {
    /// Sets one `key=value` ([`OPTION_KEYS`]); an unknown key or a bad value is an error naming it.
    pub fn set(&mut self, key: &str, value: &str) -> Result<()> {
        let (key, value) = (key.trim(), value.trim());
        match key {
            "spp" => self.spp = number(key, value)?,
            "seed" => self.seed = number(key, value)?,
            "size" => {
                let (w, h) =
                    value.split_once('x').ok_or_else(|| setting_error(key, value, "WIDTHxHEIGHT"))?;
                (self.width, self.height) = (number(key, w)?, number(key, h)?);
            }
            "shadow-map" => self.shadows = value.parse()?,
            "transparency" => self.transparency = value.parse()?,
            _ => {
                if !self.stochastic.set(key, value)? && !self.interleaved.set(key, value)? {
                    return Err(Error::Unsupported(format!(
                        "unknown setting `{key}` ({})",
                        option_key_names()
                    )));
                }
            }
        }
        Ok(())
    }

    /// Sets each `KEY=VALUE` of `pairs` in order.
    pub fn set_all<'a>(&mut self, pairs: impl IntoIterator<Item = &'a str>) -> Result<()> {
        for kv in pairs {
            let (key, value) = kv
                .split_once('=')
                .ok_or_else(|| Error::Unsupported(format!("setting `{kv}` is not KEY=VALUE")))?;
            self.set(key, value)?;
        }
        Ok(())
    }
}

impl StochasticOptions {
    /// Sets one of the stochastic frame's keys; `Ok(false)` when `key` is not one of them.
    pub fn set(&mut self, key: &str, value: &str) -> Result<bool> {
        match key {
            "bound" => self.bound = value.parse()?,
            "shading" => self.shading = value.parse()?,
            "per-pass" => self.per_pass = Some(number(key, value)?),
            "hull" => self.expansion = value.parse()?,
            "intervals" => self.intervals = value.parse()?,
            "clusters" => self.clusters = value.parse()?,
            "cache" => self.cache_entries = number(key, value)?,
            _ => return Ok(false),
        }
        Ok(true)
    }
}

impl InterleavedOptions {
    /// Sets one of technique `interleaved`'s keys; `Ok(false)` when `key` is not one of them.
    pub fn set(&mut self, key: &str, value: &str) -> Result<bool> {
        use crate::interleaved::{Blur, Edges, Pattern};
        match key {
            "vpls" => self.photons = number(key, value)?,
            "clamp" => self.clamp = number(key, value)?,
            "pattern" => self.pattern = value.parse()?,
            "split" => self.split = value.parse()?,
            "block" => {
                let b: Pattern = value.parse()?;
                self.block = (b.n, b.m);
            }
            "filter" => {
                let radius = self.blur.map_or(self.pattern.n.max(self.pattern.m), |b| b.radius);
                let bilinear = self.blur.is_some_and(|b| b.bilinear);
                self.blur = Edges::of_filter(value)?.map(|edges| Blur { radius, bilinear, edges });
            }
            "radius" => match &mut self.blur {
                Some(b) => b.radius = number(key, value)?,
                None => return Err(setting_error(key, value, "a radius without a filter (filter=none)")),
            },
            "vpl-maps" => {
                self.vpl_maps = match value {
                    "off" => None,
                    v => Some(number(key, v)?),
                }
            }
            "bilinear" => match &mut self.blur {
                Some(b) => {
                    (b.bilinear, self.bilinear_sampler) = match value {
                        "false" => (false, false),
                        "true" | "pairs" => (true, false),
                        "sampler" => (true, true),
                        _ => return Err(setting_error(
                            key,
                            value,
                            "false, true (pairs lerped in the shader) or sampler (pairs fetched by the hardware's linear filter)",
                        )),
                    }
                }
                None => return Err(setting_error(key, value, "bilinear pairs without a filter (filter=none)")),
            },
            _ => return Ok(false),
        }
        Ok(true)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn settings() -> RenderSettings {
        RenderSettings::new(160, 90, 4, 1)
    }

    #[test]
    fn every_listed_key_takes_its_example_and_changes_the_settings() {
        for k in OPTION_KEYS {
            let mut s = settings();
            let before = format!("{s:?}");
            s.set(k.key, k.example).unwrap_or_else(|e| panic!("{}={}: {e}", k.key, k.example));
            assert_ne!(format!("{s:?}"), before, "{}={} changed nothing", k.key, k.example);
        }
    }

    #[test]
    fn unknown_keys_and_bad_values_are_refused_by_name() {
        let mut s = settings();
        let e = s.set("bogus", "1").unwrap_err().to_string();
        assert!(e.contains("unknown setting `bogus`") && e.contains("interleaved: vpls"), "{e}");
        let e = s.set("spp", "many").unwrap_err().to_string();
        assert!(e.contains("spp=many"), "{e}");
        let e = s.set_all(["spp"]).unwrap_err().to_string();
        assert!(e.contains("not KEY=VALUE"), "{e}");
        s.set("filter", "none").unwrap();
        assert!(s.set("radius", "2").is_err());
    }

    #[test]
    fn pairs_apply_in_order() {
        let mut s = settings();
        s.set_all(["spp=8", "size=64x36", "vpl-maps=off", "spp=12"]).unwrap();
        assert_eq!((s.spp, s.width, s.height, s.interleaved.vpl_maps), (12, 64, 36, None));
    }
}
