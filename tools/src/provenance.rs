//! Where a number came from: every report `shutter` writes (bench, quality, bounds, probe, hard cases)
//! carries one [`Provenance`], so a timing is never read without its driver, device, CPU, commit and the
//! command that made it.

use serde::{Deserialize, Serialize};
use shutter::vk::Capabilities;

/// The conditions a report was made under.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Provenance {
    /// `shutter --version` and the commit it was built from.
    pub shutter_version: String,
    pub commit: String,
    /// Shutter's name for the driver (`lavapipe-25.0`), its own description, and the device.
    pub driver: String,
    pub driver_info: String,
    pub device: String,
    /// The CPU's model name and core count (llvmpipe's speed is the CPU's).
    pub cpu: String,
    /// The command line, as typed.
    pub command: String,
    /// Environment variables set that change what runs: Shutter's own, the Vulkan loader's, Mesa's.
    pub environment: Vec<String>,
}

/// Prefixes of the environment variables that can change a result.
const ENV_PREFIXES: [&str; 6] = ["SHUTTER_", "VK_", "LP_", "MESA_", "GALLIUM_", "RAYON_"];

impl Provenance {
    /// This process's conditions on `caps`' device.
    pub fn of(caps: &Capabilities) -> Provenance {
        let mut environment: Vec<String> = std::env::vars()
            .filter(|(k, _)| ENV_PREFIXES.iter().any(|p| k.starts_with(p)))
            // Cargo's copy of the build's own commit (set when it runs the tests), not a setting.
            .filter(|(k, _)| k != "SHUTTER_GIT_COMMIT")
            // The manifests Shutter offered the loader itself are not the user's setting.
            .filter_map(|(k, v)| match (k.as_str(), shutter::vk::drivers::user_add_driver_files()) {
                ("VK_ADD_DRIVER_FILES", Some(user)) => user.map(|u| (k, u)),
                _ => Some((k, v)),
            })
            .map(|(k, v)| format!("{k}={v}"))
            .collect();
        environment.sort();
        Provenance {
            shutter_version: env!("CARGO_PKG_VERSION").into(),
            commit: env!("SHUTTER_GIT_COMMIT").into(),
            driver: caps.driver_key.clone(),
            driver_info: caps.driver_info.clone(),
            device: caps.device_name.clone(),
            cpu: cpu_model(),
            command: std::env::args().map(|a| quote(&a)).collect::<Vec<_>>().join(" "),
            environment,
        }
    }

    /// Markdown lines, one fact each, for the head of a report.
    pub fn markdown(&self) -> String {
        format!(
            "- driver: `{}` ({}) on {}\n- CPU: {}\n- shutter {} at commit `{}`\n- command: `{}`\n- environment: {}\n",
            self.driver,
            self.driver_info,
            self.device,
            self.cpu,
            self.shutter_version,
            self.commit,
            self.command,
            if self.environment.is_empty() {
                "nothing that changes behaviour".to_string()
            } else {
                self.environment.iter().map(|e| format!("`{e}`")).collect::<Vec<_>>().join(", ")
            }
        )
    }

    /// CSV comment lines (`# key: value`) for the head of a CSV file.
    pub fn csv_comment(&self) -> String {
        self.markdown().lines().map(|l| format!("# {}\n", l.trim_start_matches("- "))).collect()
    }
}

/// `/proc/cpuinfo`'s model name and the logical CPUs this process may use.
fn cpu_model() -> String {
    let info = std::fs::read_to_string("/proc/cpuinfo").unwrap_or_default();
    let model = info
        .lines()
        .find(|l| l.starts_with("model name"))
        .and_then(|l| l.split_once(':'))
        .map(|(_, m)| m.trim().to_string())
        .unwrap_or_else(|| std::env::consts::ARCH.to_string());
    let cores = std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1);
    format!("{model}, {cores} logical CPUs")
}

/// An argument as a shell would need it typed.
fn quote(a: &str) -> String {
    if !a.is_empty() && a.chars().all(|c| c.is_ascii_alphanumeric() || "-_./=,:+@%".contains(c)) {
        a.to_string()
    } else {
        format!("'{}'", a.replace('\'', r"'\''"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn arguments_are_quoted_only_when_a_shell_needs_it() {
        assert_eq!(quote("--spp=16"), "--spp=16");
        assert_eq!(quote("a b"), "'a b'");
        assert_eq!(quote("it's"), r"'it'\''s'");
        assert_eq!(quote(""), "''");
    }

    #[test]
    fn the_commit_is_recorded() {
        let c = env!("SHUTTER_GIT_COMMIT");
        assert!(c == "unknown" || (c.len() == 40 && c.chars().all(|c| c.is_ascii_hexdigit())), "{c}");
    }
}
