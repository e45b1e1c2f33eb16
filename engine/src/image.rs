//! The engine's image type: linear HDR RGBA, f32, row-major, top row first.

/// A linear-light RGBA image (what every technique and the reference produce).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LinearImage {
    pub width: u32,
    pub height: u32,
    /// `width × height` texels, row-major, top row first.
    pub pixels: Vec<[f32; 4]>,
}

impl LinearImage {
    pub fn new(width: u32, height: u32) -> Self {
        LinearImage { width, height, pixels: vec![[0.0; 4]; (width * height) as usize] }
    }
    pub fn get(&self, x: u32, y: u32) -> [f32; 4] {
        self.pixels[(y * self.width + x) as usize]
    }
    pub fn set(&mut self, x: u32, y: u32, v: [f32; 4]) {
        self.pixels[(y * self.width + x) as usize] = v;
    }
    /// True when every channel of every pixel is finite.
    pub fn all_finite(&self) -> bool {
        self.pixels.iter().all(|p| p.iter().all(|c| c.is_finite()))
    }
}
