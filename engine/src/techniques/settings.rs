//! One grammar for a render's settings: `KEY=VALUE`, the same for `shutter render` (its flags and
//! `--set`), `shutter bench -c`, `shutter quality -s` and a library caller ([`RenderSettings::set`]).
//!
//! Each key belongs to the options of what reads it, is listed beside its parser and parsed there:
//! the frame's own keys (`spp`, `seed`, `size`: [`FRAME_KEYS`]) here, the stochastic frame's in
//! `stochastic/options.rs` ([`super::stochastic::KEYS`], `StochasticOptions::set`), technique
//! `interleaved`'s in `techniques/interleaved.rs` ([`super::interleaved::KEYS`],
//! `InterleavedOptions::set`), the shadow maps' ([`super::shadow_maps::KEYS`]) and transparency's
//! ([`super::forward::TRANSPARENCY_KEYS`]) by their settings' `FromStr`. Each technique's
//! [`super::TechniqueInfo::keys`] names the groups it reads; [`option_keys`] gathers them all, for
//! help texts and error messages, and a test checks that every listed key is accepted.

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

/// An [`OptionKey`] (for the owners' tables).
pub const fn key(
    key: &'static str,
    owner: &'static str,
    values: &'static str,
    example: &'static str,
) -> OptionKey {
    OptionKey { key, owner, values, example }
}

/// The frame's own keys, which every technique reads.
pub const FRAME_KEYS: &[OptionKey] = &[
    key("spp", "frame", "samples per pixel S", "16"),
    key("seed", "frame", "the sample pattern's seed", "7"),
    key("size", "frame", "WIDTHxHEIGHT", "96x54"),
];

/// Every key [`RenderSettings::set`] takes: the frame's, then each registered technique's groups
/// ([`super::TechniqueInfo::keys`]) in registry order, each key once.
pub fn option_keys() -> Vec<OptionKey> {
    let mut keys: Vec<OptionKey> = Vec::new();
    let all = super::registry::TECHNIQUES.iter().flat_map(|t| t.info().option_keys());
    for k in FRAME_KEYS.iter().chain(all) {
        if !keys.iter().any(|known| known.key == k.key) {
            keys.push(*k);
        }
    }
    keys
}

/// The keys, for an error message: `spp, seed, … (stochastic: bound, …)`.
pub fn option_key_names() -> String {
    let keys = option_keys();
    let mut owners: Vec<&str> = Vec::new();
    for k in &keys {
        if !owners.contains(&k.owner) {
            owners.push(k.owner);
        }
    }
    owners
        .iter()
        .map(|o| {
            let names: Vec<&str> = keys.iter().filter(|k| k.owner == *o).map(|k| k.key).collect();
            format!("{o}: {}", names.join(", "))
        })
        .collect::<Vec<_>>()
        .join("; ")
}

pub(crate) fn setting_error(key: &str, value: &str, message: impl std::fmt::Display) -> Error {
    Error::Unsupported(format!("setting `{key}={value}`: {message}"))
}

/// `value` parsed as `T`, or an error naming the setting.
pub(crate) fn number<T: std::str::FromStr>(key: &str, value: &str) -> Result<T>
where
    T::Err: std::fmt::Display,
{
    value.parse().map_err(|e| setting_error(key, value, e))
}

impl RenderSettings {
    /// Sets one `key=value` ([`option_keys`]); an unknown key or a bad value is an error naming it.
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

#[cfg(test)]
mod tests {
    use super::*;

    fn settings() -> RenderSettings {
        RenderSettings::new(160, 90, 4, 1)
    }

    #[test]
    fn every_listed_key_takes_its_example_and_changes_the_settings() {
        for k in option_keys() {
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
