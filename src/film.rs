//! The rendered image: linear RGBA radiance plus the AOV channels written to EXR.
//!
//! Pixels are stored row by row, `y = 0` at the top (the camera's convention and EXR's).
//!
//! What each channel holds, for a pixel with `spp` samples of which `k` primary rays hit
//! geometry (the integrator's rules, [`crate::integrator`]):
//!
//! | channel | value | where no sample hit (`k = 0`) |
//! |---|---|---|
//! | RGB | mean radiance over all `spp` samples (box filter), linear, in the scene's units; a sample that hits nothing contributes the background radiance | the background |
//! | A | `k / spp`, the fraction of samples whose primary ray hit geometry (coverage) | 0 |
//! | depth | the smallest `t` among the hit samples: the distance from the eye to the nearest first hit along its primary ray (unit directions, so `t` is a distance; not the z-depth along the view axis) | `+∞` |
//! | normal | the world-space unit shading normal at the first hit, facing the eye, averaged over the hit samples and renormalised (zero if they cancel) | zero |
//! | albedo | the diffuse albedo ρ at the first hit (texture × vertex colour; 0 for pure mirrors and glass), averaged over the hit samples | zero |
//!
//! RGB is premultiplied by A only when the background is black: a background radiance `b`
//! adds `(1 − A)·b` to every pixel's RGB. Compositing over another background therefore
//! needs a black background in the scene. Depth is a minimum, not a mean, so it is never a
//! distance between two objects at an edge; normal and albedo are means over the hit samples
//! only, so edges against the background are not darkened.

use crate::math::Vec3;

/// A rendered frame and its arbitrary output variables (AOVs).
#[derive(Clone, Debug, PartialEq)]
pub struct Film {
    pub width: u32,
    pub height: u32,
    /// Linear radiance, box-filtered over the pixel's samples, background included; alpha is
    /// the fraction of the pixel's samples whose primary ray hit geometry (see the module docs).
    pub rgba: Vec<[f32; 4]>,
    /// Distance along the primary ray from the eye to the nearest first hit among the pixel's
    /// samples; `+∞` where no sample hit.
    pub depth: Vec<f32>,
    /// World-space unit shading normal at the first hit, mean over the hit samples,
    /// renormalised; zero where no sample hit.
    pub normal: Vec<Vec3>,
    /// Diffuse albedo at the first hit, mean over the hit samples; zero where no sample hit.
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
