//! Debian 12's `libshaderc-dev` ships a `libshaderc_combined.a` without glslang and SPIRV-Tools, and
//! an under-linked `libshaderc.so.1` (it uses glslang's symbols without needing a library that has
//! them), so `shaderc-sys`, left to itself, cannot link. `shutter` asks `shaderc-sys` for the static
//! archive (feature `prefer-static-linking`) and depends on this crate, whose build script adds
//! what the archive lacks: Debian's static glslang and SPIRV-Tools archives (packages `glslang-dev`,
//! `spirv-tools`) and the C++ runtime.
//!
//! They are `static:-bundle`: not copied into this crate's rlib but passed to the linker with the
//! upstream native libraries, after every Rust crate's archive — after `shaderc-sys`'s, whose
//! `libshaderc_combined.a` refers to them (a static archive only supplies what is already missing
//! when the linker reaches it).
//!
//! Nothing is emitted where the archives are not there (another distribution, a Vulkan SDK through
//! `SHADERC_LIB_DIR` or `VULKAN_SDK`, a shaderc built from source): `shaderc-sys` links on its own.
//! Inside Shutter's workspace `.cargo/config.toml` overrides `shaderc-sys`'s link as well; the
//! archives this adds are then already linked and add nothing.

use std::path::Path;

/// In link order: each after the ones that use it.
const ARCHIVES: [&str; 9] = [
    "SPIRV",
    "glslang",
    "MachineIndependent",
    "GenericCodeGen",
    "OSDependent",
    "OGLCompiler",
    "HLSL",
    "SPIRV-Tools-opt",
    "SPIRV-Tools",
];

fn main() {
    println!("cargo:rerun-if-env-changed=SHADERC_LIB_DIR");
    println!("cargo:rerun-if-env-changed=VULKAN_SDK");
    let os = std::env::var("CARGO_CFG_TARGET_OS").unwrap_or_default();
    let arch = std::env::var("CARGO_CFG_TARGET_ARCH").unwrap_or_default();
    if os != "linux"
        || std::env::var_os("SHADERC_LIB_DIR").is_some()
        || std::env::var_os("VULKAN_SDK").is_some()
    {
        return;
    }
    let arch = if arch == "x86" { "i386".to_string() } else { arch };
    let dir = format!("/usr/lib/{arch}-linux-gnu");
    let has = |name: &str| Path::new(&dir).join(format!("lib{name}.a")).exists();
    println!("cargo:rerun-if-changed={dir}/libshaderc_combined.a");
    if !has("shaderc_combined") || !has("glslang") {
        return;
    }
    println!("cargo:rustc-link-search=native={dir}");
    for name in ARCHIVES.into_iter().filter(|n| has(n)) {
        println!("cargo:rustc-link-lib=static:-bundle={name}");
    }
    println!("cargo:rustc-link-lib=dylib=stdc++");
}
