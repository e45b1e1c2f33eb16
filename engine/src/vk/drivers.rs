//! Which Vulkan drivers Shutter runs on, and how one is chosen by name.
//!
//! The answer to "what does accuracy cost in time" depends on the driver more than on any lever of
//! ours (a lavapipe two years newer runs the stochastic frame several times faster), so every driver
//! has a name and every report says which one it ran on. A driver's name is its family and version:
//! `lavapipe-25.0` for Mesa 25.0's software rasterizer, or the device's name for anything else
//! (`nvidia-h200`). A wanted name matches by whole components: `lavapipe` matches every lavapipe,
//! `lavapipe-25` every 25.x, `lavapipe-25.0.7` that release only.
//!
//! Where drivers come from: the system's installed ICDs (the Vulkan loader finds them as usual) and
//! the project's own, unpacked by `scripts/setup.sh` under `.drivers/NAME/` (or `$SHUTTER_DRIVERS_DIR`):
//! each folder holds an `icd.json` whose `library_path` names the driver's shared library. The loader
//! offers the project's drivers beside the system's ([`offer_project_drivers`]), so one process lists
//! (and can choose among) every driver; both lavapipes load side by side in one process.

use std::path::{Path, PathBuf};

use ash::vk;

use crate::error::{Error, Result};

/// A driver the project brought along (a folder under [`drivers_dir`]).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ProjectDriver {
    /// The folder's name, e.g. `lavapipe-25.0.7`.
    pub folder: String,
    /// Its `icd.json`.
    pub manifest: PathBuf,
    /// The shared library the manifest names (absolute, or relative to the manifest's folder).
    pub library: PathBuf,
}

/// Where the project's drivers live: `$SHUTTER_DRIVERS_DIR`, else the checkout's `.drivers` (the
/// folder `scripts/setup.sh` fills), if it exists.
pub fn drivers_dir() -> Option<PathBuf> {
    if let Some(d) = std::env::var_os("SHUTTER_DRIVERS_DIR").filter(|d| !d.is_empty()) {
        return Some(PathBuf::from(d));
    }
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../.drivers").canonicalize().ok().filter(|d| d.is_dir())
}

/// The project's drivers, sorted by folder name. A folder without `icd.json` is not a driver; a
/// manifest that does not parse, or names a library that is not there, is an error (a broken setup
/// should not silently run everything on the system's driver).
pub fn project_drivers() -> Result<Vec<ProjectDriver>> {
    let Some(dir) = drivers_dir() else { return Ok(vec![]) };
    let entries = match std::fs::read_dir(&dir) {
        Ok(e) => e,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(vec![]),
        Err(e) => return Err(Error::io(&dir, e)),
    };
    let mut found = vec![];
    for entry in entries {
        let entry = entry.map_err(|e| Error::io(&dir, e))?;
        let manifest = entry.path().join("icd.json");
        if !manifest.is_file() {
            continue;
        }
        let library = manifest_library(&manifest)?;
        if !library.is_file() {
            return Err(Error::Unsupported(format!(
                "driver manifest {} names {}, which is not there (rerun scripts/setup.sh)",
                manifest.display(),
                library.display()
            )));
        }
        found.push(ProjectDriver {
            folder: entry.file_name().to_string_lossy().into_owned(),
            manifest,
            library,
        });
    }
    found.sort_by(|a, b| a.folder.cmp(&b.folder));
    Ok(found)
}

/// The library an ICD manifest names, resolved against the manifest's folder.
fn manifest_library(manifest: &Path) -> Result<PathBuf> {
    let text = std::fs::read_to_string(manifest).map_err(|e| Error::io(manifest, e))?;
    let json: serde_json::Value = serde_json::from_str(&text)
        .map_err(|e| Error::Unsupported(format!("driver manifest {}: {e}", manifest.display())))?;
    let path = json.get("ICD").and_then(|icd| icd.get("library_path")).and_then(|p| p.as_str()).ok_or_else(
        || Error::Unsupported(format!("driver manifest {}: no ICD.library_path", manifest.display())),
    )?;
    let path = PathBuf::from(path);
    Ok(if path.is_absolute() { path } else { manifest.parent().unwrap_or(Path::new(".")).join(path) })
}

/// Environment variables with which the user chose the loader's drivers themselves; Shutter then adds
/// none of its own.
const LOADER_DRIVER_VARS: [&str; 2] = ["VK_ICD_FILENAMES", "VK_DRIVER_FILES"];

/// `VK_ADD_DRIVER_FILES` as the user set it (None: unset), recorded where
/// [`offer_project_drivers`] appended the project's manifests to it.
static USER_ADD_DRIVER_FILES: std::sync::OnceLock<Option<String>> = std::sync::OnceLock::new();

/// What the user's environment held in `VK_ADD_DRIVER_FILES` before Shutter added the project's
/// drivers to it (`Some(None)`: unset), or None where Shutter left it alone — so a report lists the
/// user's settings, not the manifests of every project driver whichever one the run used (its
/// driver is named on its own).
pub fn user_add_driver_files() -> Option<Option<String>> {
    USER_ADD_DRIVER_FILES.get().cloned()
}

/// Offers the project's drivers to the Vulkan loader, once per process, and returns them: their
/// manifests are appended to `VK_ADD_DRIVER_FILES` (which the loader reads when an instance is
/// created), unless the user chose the drivers with `VK_ICD_FILENAMES` or `VK_DRIVER_FILES`.
///
/// Why the environment: the loader's in-process alternative, `VK_LUNARG_direct_driver_loading`, is
/// not in Debian 12's loader (1.3.239). Setting a variable is only sound while no other thread reads
/// the C environment; every Vulkan call of Shutter's goes through here first, so the one write happens
/// before any instance exists (and with it any driver thread), under a `Once` that makes concurrent
/// callers wait.
pub fn offer_project_drivers() -> Result<Vec<ProjectDriver>> {
    static OFFERED: std::sync::OnceLock<std::result::Result<Vec<ProjectDriver>, String>> =
        std::sync::OnceLock::new();
    let offered = OFFERED.get_or_init(|| {
        let drivers = project_drivers().map_err(|e| e.to_string())?;
        let user_chose =
            LOADER_DRIVER_VARS.iter().any(|v| std::env::var_os(v).is_some_and(|x| !x.is_empty()));
        if drivers.is_empty() || user_chose {
            return Ok(if user_chose { vec![] } else { drivers });
        }
        let user = std::env::var_os("VK_ADD_DRIVER_FILES").filter(|v| !v.is_empty());
        let _ = USER_ADD_DRIVER_FILES.set(user.as_ref().map(|v| v.to_string_lossy().into_owned()));
        let mut files: Vec<std::ffi::OsString> = user.into_iter().collect();
        files.extend(drivers.iter().map(|d| d.manifest.clone().into_os_string()));
        let joined = std::env::join_paths(&files).map_err(|e| e.to_string())?;
        std::env::set_var("VK_ADD_DRIVER_FILES", joined);
        Ok(drivers)
    });
    offered.clone().map_err(Error::Unsupported)
}

/// The version a driver reports in its `driverInfo`: the first token that starts with a digit, up to
/// the first character that is neither digit nor dot (`Mesa 25.0.7-2~bpo12+1 (LLVM 15.0.6)` → `25.0.7`;
/// NVIDIA's `580.65.06` → `580.65.06`). Empty when there is none.
pub fn driver_version(driver_info: &str) -> String {
    driver_info
        .split_whitespace()
        .find(|t| t.starts_with(|c: char| c.is_ascii_digit()))
        .map(|t| t.chars().take_while(|c| c.is_ascii_digit() || *c == '.').collect::<String>())
        .map(|v| v.trim_end_matches('.').to_string())
        .unwrap_or_default()
}

/// Lower-case, runs of anything but letters and digits to one `-`.
fn slug(s: &str) -> String {
    let mut out = String::new();
    for c in s.chars() {
        if c.is_ascii_alphanumeric() {
            out.push(c.to_ascii_lowercase());
        } else if !out.is_empty() && !out.ends_with('-') {
            out.push('-');
        }
    }
    out.trim_end_matches('-').to_string()
}

/// A driver's family: `lavapipe` for Mesa's software rasterizer, else the device's name as a slug.
pub fn driver_family(driver_id: &str, device_name: &str) -> String {
    if driver_id == format!("{:?}", vk::DriverId::MESA_LLVMPIPE) {
        "lavapipe".into()
    } else {
        // "llvmpipe (LLVM 15.0.6, 256 bits)" style suffixes say nothing a name needs.
        slug(device_name.split('(').next().unwrap_or(device_name))
    }
}

/// The name Shutter gives a driver: family and major.minor version (`lavapipe-25.0`), or the family
/// alone where the driver reports no version.
pub fn driver_key(driver_id: &str, device_name: &str, driver_info: &str) -> String {
    let family = driver_family(driver_id, device_name);
    let version = driver_version(driver_info);
    let short: Vec<&str> = version.split('.').filter(|s| !s.is_empty()).take(2).collect();
    if short.is_empty() {
        family
    } else {
        format!("{family}-{}", short.join("."))
    }
}

/// Whether `wanted` names this driver: its components (split at `-` and `.`) are a prefix of the
/// driver's full name `family-version`'s, case-insensitive (`lavapipe`, `lavapipe-25`,
/// `lavapipe-25.0`, `lavapipe-25.0.7` all name Mesa 25.0.7's lavapipe).
pub fn driver_matches(wanted: &str, driver_id: &str, device_name: &str, driver_info: &str) -> bool {
    let full = format!("{}-{}", driver_family(driver_id, device_name), driver_version(driver_info));
    let parts = |s: &str| -> Vec<String> {
        s.to_ascii_lowercase().split(['-', '.']).filter(|p| !p.is_empty()).map(String::from).collect()
    };
    let (w, f) = (parts(wanted), parts(&full));
    !w.is_empty() && w.len() <= f.len() && w.iter().zip(&f).all(|(a, b)| a == b)
}

/// Orders versions by their numeric components (`25.0.7` > `22.3.6`, `9` < `10`).
pub fn version_cmp(a: &str, b: &str) -> std::cmp::Ordering {
    let nums = |s: &str| -> Vec<u64> { s.split('.').map(|p| p.parse().unwrap_or(0)).collect() };
    nums(a).cmp(&nums(b))
}

#[cfg(test)]
mod tests {
    use super::*;

    const LLVMPIPE: &str = "MESA_LLVMPIPE";
    const DEVICE: &str = "llvmpipe (LLVM 15.0.6, 256 bits)";

    #[test]
    fn lavapipe_versions_get_their_names() {
        assert_eq!(driver_version("Mesa 25.0.7-2~bpo12+1 (LLVM 15.0.6)"), "25.0.7");
        assert_eq!(driver_version("Mesa 22.3.6 (LLVM 15.0.6)"), "22.3.6");
        assert_eq!(driver_version("580.65.06"), "580.65.06");
        assert_eq!(driver_version("no version here"), "");
        assert_eq!(driver_key(LLVMPIPE, DEVICE, "Mesa 25.0.7-2~bpo12+1 (LLVM 15.0.6)"), "lavapipe-25.0");
        assert_eq!(driver_key(LLVMPIPE, DEVICE, "Mesa 22.3.6 (LLVM 15.0.6)"), "lavapipe-22.3");
        assert_eq!(driver_key("NVIDIA_PROPRIETARY", "NVIDIA H200", "580.65.06"), "nvidia-h200-580.65");
        assert_eq!(driver_key("NVIDIA_PROPRIETARY", "NVIDIA H200", ""), "nvidia-h200");
    }

    #[test]
    fn names_match_by_whole_components() {
        let info = "Mesa 25.0.7-2~bpo12+1 (LLVM 15.0.6)";
        for yes in ["lavapipe", "LAVAPIPE-25", "lavapipe-25.0", "lavapipe-25.0.7"] {
            assert!(driver_matches(yes, LLVMPIPE, DEVICE, info), "{yes}");
        }
        for no in ["lavapipe-2", "lavapipe-25.1", "lavapipe-22.3", "lavapipe-25.0.7.1", "llvm", "", "-"] {
            assert!(!driver_matches(no, LLVMPIPE, DEVICE, info), "{no}");
        }
        assert!(driver_matches("nvidia-h200", "NVIDIA_PROPRIETARY", "NVIDIA H200", "580.65.06"));
        assert!(!driver_matches("nvidia-h100", "NVIDIA_PROPRIETARY", "NVIDIA H200", "580.65.06"));
    }

    #[test]
    fn versions_order_numerically() {
        use std::cmp::Ordering::*;
        assert_eq!(version_cmp("25.0.7", "22.3.6"), Greater);
        assert_eq!(version_cmp("9.0", "10.0"), Less);
        assert_eq!(version_cmp("22.3.6", "22.3.6"), Equal);
    }

    #[test]
    fn manifests_resolve_relative_libraries_and_refuse_broken_ones() {
        let dir = std::env::temp_dir().join(format!("shutter-drivers-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let m = dir.join("icd.json");
        std::fs::write(&m, r#"{"file_format_version":"1.0.0","ICD":{"library_path":"lib/x.so"}}"#).unwrap();
        assert_eq!(manifest_library(&m).unwrap(), dir.join("lib/x.so"));
        std::fs::write(&m, r#"{"ICD":{"library_path":"/abs/x.so"}}"#).unwrap();
        assert_eq!(manifest_library(&m).unwrap(), PathBuf::from("/abs/x.so"));
        std::fs::write(&m, r#"{"ICD":{}}"#).unwrap();
        assert!(manifest_library(&m).unwrap_err().to_string().contains("no ICD.library_path"));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
