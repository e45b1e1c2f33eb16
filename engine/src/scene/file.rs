// TEMP placeholder until the scene-file module lands.
pub const MAX_IMAGE_DIMENSION: u32 = 8192;
pub const MAX_SPP: u32 = 65536;
