//! Nothing but a link: its build script adds the static libraries Debian 12's
//! `libshaderc_combined.a` needs and lacks (glslang and SPIRV-Tools), so `shutter`'s build script,
//! which compiles the shaders with shaderc, links on Debian with no `.cargo/config.toml` of the
//! dependent crate's own. See `build.rs`.
