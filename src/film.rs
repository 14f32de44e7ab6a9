//! The rendered image: linear RGBA radiance plus the AOV channels written to EXR.
//!
//! Pixels are stored row by row, `y = 0` at the top (the camera's convention and EXR's).

use crate::math::Vec3;

/// A rendered frame and its arbitrary output variables (AOVs).
#[derive(Clone, Debug, PartialEq)]
pub struct Film {
    pub width: u32,
    pub height: u32,
    /// Linear radiance, box-filtered over the pixel's samples; alpha is the fraction of the
    /// pixel's samples whose primary ray hit geometry.
    pub rgba: Vec<[f32; 4]>,
    /// Distance along the primary ray from the eye to the first hit (see the EXR channel
    /// docs for what pixels that see nothing hold).
    pub depth: Vec<f32>,
    /// World-space shading normal at the first hit.
    pub normal: Vec<Vec3>,
    /// Diffuse albedo at the first hit.
    pub albedo: Vec<Vec3>,
}

impl Film {
    /// A film of the given size with every channel zero and depth at `f32::INFINITY`.
    pub fn new(width: u32, height: u32) -> Self {
        let n = width as usize * height as usize;
        Film {
            width,
            height,
            rgba: vec![[0.0; 4]; n],
            depth: vec![f32::INFINITY; n],
            normal: vec![Vec3::ZERO; n],
            albedo: vec![Vec3::ZERO; n],
        }
    }

    /// Index of pixel `(x, y)` in every channel.
    #[inline]
    pub fn index(&self, x: u32, y: u32) -> usize {
        y as usize * self.width as usize + x as usize
    }
}
