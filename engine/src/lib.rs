pub mod shaders {
    #[derive(Clone, Copy, Debug, PartialEq, Eq)]
    pub enum ShaderStage { Vertex, Geometry, Fragment, Compute }
    #[derive(Clone, Copy, Debug)]
    pub struct ShaderSource { pub file: &'static str, pub permutation: &'static str, pub stage: ShaderStage, pub defines: &'static [&'static str], pub spirv: &'static [u8] }
    include!(concat!(env!("OUT_DIR"), "/shaders.rs"));
}
