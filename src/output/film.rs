//! The rendered image: linear RGBA radiance plus the passes (AOVs) written to EXR
//! ([`crate::output::passes`] lists them; this table gives the rules of the first four).
//!
//! Pixels are stored row by row, `y = 0` at the top (the camera's convention and EXR's).
//! A film may hold only a [`Region`] of the image (its data window): it then stores
//! `width × height` pixels starting at image pixel `(origin_x, origin_y)` of a
//! `display_width × display_height` image, and is indexed with image coordinates.
//!
//! What each channel holds, for a pixel with `spp` samples of which `k` primary rays hit
//! geometry (the integrator's rules, [`crate::integrator`]):
//!
//! | channel | value | where no sample hit (`k = 0`) |
//! |---|---|---|
//! | RGB | mean radiance over all `spp` samples (box filter), linear, in the scene's units; a sample that hits nothing contributes the background radiance | the background |
//! | A | 1 (an opaque frame); with `transparent`, `k / spp`, the fraction of samples whose primary ray hit geometry (coverage) | 1; with `transparent`, 0 |
//! | depth | the view-axis depth of the nearest first hit (the hit sample with the smallest `t`): `−w·(p − e)`, its `z` in camera space, as Blender's and Nuke's Z (the ray's length is the `distance` pass) | `+∞` |
//! | normal | the world-space unit shading normal at the first hit, facing the eye, summed over the hit samples and divided by `spp` (coverage-weighted, as Cycles' Normal pass) | zero |
//! | albedo | the diffuse albedo ρ at the first hit (texture × vertex colour; 0 for pure mirrors and glass), summed over the hit samples and divided by `spp` (coverage-weighted, as Cycles' DiffCol) | zero |
//!
//! **Alpha.** RGBA is premultiplied, so `over` composites it correctly either way:
//! - by default the frame is opaque: A = 1 everywhere, the background radiance `b` in RGB
//!   wherever rays escape (the camera's, and those seen through mirrors and glass);
//! - with `transparent` (`[output] transparent = true`, `--transparent`), every ray that
//!   escapes returns radiance 0, camera rays and those seen through mirrors and glass alike
//!   (Cycles' "Film > Transparent" with transparent glass taken as black), and A is the
//!   coverage `k / spp`: where nothing was hit `over` shows exactly the plate behind, and a
//!   mirror shows black where it would reflect the background.
//!
//! Depth is a minimum, not a mean, so it is never a
//! distance between two objects at an edge (Cycles writes its first sample's instead); normal
//! and albedo fade with the coverage at edges against the background, as in Cycles, so that a
//! denoiser sees the same edge in them as in the beauty.

use crate::math::Vec3;
use crate::output::passes::{OutputSpec, Pass};
use crate::output::region::Region;

/// A rendered frame and its arbitrary output variables (AOVs).
#[derive(Clone, Debug, PartialEq)]
pub struct Film {
    /// Pixels stored per row (the data window's width).
    pub width: u32,
    /// Rows stored (the data window's height).
    pub height: u32,
    /// The image pixel of the film's first stored pixel (the data window's top-left corner).
    pub origin_x: u32,
    pub origin_y: u32,
    /// The whole image's size (the display window).
    pub display_width: u32,
    pub display_height: u32,
    /// Linear radiance, box-filtered over the pixel's samples, and alpha (see the module docs).
    pub rgba: Vec<[f32; 4]>,
    /// Distance along the primary ray from the eye to the nearest first hit among the pixel's
    /// samples; `+∞` where no sample hit. Empty when the `depth` pass is off.
    pub depth: Vec<f32>,
    /// World-space unit shading normal at the first hit, mean over the hit samples,
    /// renormalised; zero where no sample hit. Empty when the `normal` pass is off.
    pub normal: Vec<Vec3>,
    /// Diffuse albedo at the first hit, mean over the hit samples; zero where no sample hit.
    /// Empty when the `albedo` pass is off.
    pub albedo: Vec<Vec3>,
    /// The other passes, in [`Pass::ALL`] order.
    pub aovs: Vec<Aov>,
}

/// One pass beyond the first four: `floats_per_pixel` floats per pixel, pixel after pixel.
#[derive(Clone, Debug, PartialEq)]
pub struct Aov {
    pub pass: Pass,
    pub floats_per_pixel: usize,
    pub data: Vec<f32>,
}

/// One channel of the film, wherever it lives: sample `i` is `data[i·stride + offset]`.
#[derive(Clone, Copy, Debug)]
pub struct ChannelView<'a> {
    pub pass: Pass,
    /// Which of the pass's floats (`0..floats_per_pixel`).
    pub component: usize,
    pub data: &'a [f32],
    pub stride: usize,
    pub offset: usize,
}

impl ChannelView<'_> {
    /// The channel's value at pixel index `i`.
    #[inline]
    pub fn get(&self, i: usize) -> f32 {
        self.data[i * self.stride + self.offset]
    }
}

impl Film {
    /// A film with the default passes ([`OutputSpec::default`]), every channel zero and depth at
    /// `f32::INFINITY`.
    pub fn new(width: u32, height: u32) -> Self {
        Film::with_output(width, height, &OutputSpec::default())
    }

    /// A film holding the passes of `output`, zero, with depth at `f32::INFINITY`.
    pub fn with_output(width: u32, height: u32, output: &OutputSpec) -> Self {
        Film::for_region(width, height, Region::full(width, height), output)
    }

    /// A film of the pixels of `region` of a `display_width × display_height` image, holding
    /// the passes of `output`, zero, with depth at `f32::INFINITY`.
    pub fn for_region(display_width: u32, display_height: u32, region: Region, output: &OutputSpec) -> Self {
        let (width, height) = (region.width(), region.height());
        let n = width as usize * height as usize;
        let on = |p: Pass| if output.passes.contains(p) { n } else { 0 };
        let aovs = output
            .passes
            .iter()
            .filter(|p| !matches!(p, Pass::Combined | Pass::Depth | Pass::Normal | Pass::Albedo))
            .map(|pass| {
                let floats_per_pixel = pass.floats_per_pixel(output.crypto_levels);
                let empty = if pass == Pass::Distance { f32::INFINITY } else { 0.0 };
                Aov { pass, floats_per_pixel, data: vec![empty; n * floats_per_pixel] }
            })
            .collect();
        Film {
            width,
            height,
            origin_x: region.x0,
            origin_y: region.y0,
            display_width,
            display_height,
            rgba: vec![[0.0; 4]; n],
            depth: vec![f32::INFINITY; on(Pass::Depth)],
            normal: vec![Vec3::ZERO; on(Pass::Normal)],
            albedo: vec![Vec3::ZERO; on(Pass::Albedo)],
            aovs,
        }
    }

    /// Index of image pixel `(x, y)` (inside the film's region) in every channel.
    #[inline]
    pub fn index(&self, x: u32, y: u32) -> usize {
        (y - self.origin_y) as usize * self.width as usize + (x - self.origin_x) as usize
    }

    /// The pixels the film holds, in image coordinates (its data window).
    pub fn region(&self) -> Region {
        Region { x0: self.origin_x, y0: self.origin_y, x1: self.origin_x + self.width, y1: self.origin_y + self.height }
    }

    /// Every channel's storage as flat floats with the number of floats per pixel, in the
    /// order of [`Film::channels`] (pass by pass).
    pub fn buffers(&self) -> Vec<(&[f32], usize)> {
        let mut out: Vec<(&[f32], usize)> = vec![(self.rgba.as_flattened(), 4)];
        if !self.depth.is_empty() {
            out.push((&self.depth, 1));
        }
        if !self.normal.is_empty() {
            out.push((bytemuck::cast_slice(&self.normal), 3));
        }
        if !self.albedo.is_empty() {
            out.push((bytemuck::cast_slice(&self.albedo), 3));
        }
        for aov in &self.aovs {
            out.push((&aov.data, aov.floats_per_pixel));
        }
        out
    }

    /// Every channel's storage, mutable, as flat floats with the number of floats per pixel,
    /// in the order of [`Film::channels`] (pass by pass). For copying whole pixels between
    /// films of the same passes (a checkpoint's tiles).
    pub fn buffers_mut(&mut self) -> Vec<(&mut [f32], usize)> {
        let mut out: Vec<(&mut [f32], usize)> = vec![(self.rgba.as_flattened_mut(), 4)];
        if !self.depth.is_empty() {
            out.push((&mut self.depth, 1));
        }
        if !self.normal.is_empty() {
            out.push((bytemuck::cast_slice_mut(&mut self.normal), 3));
        }
        if !self.albedo.is_empty() {
            out.push((bytemuck::cast_slice_mut(&mut self.albedo), 3));
        }
        for aov in &mut self.aovs {
            out.push((&mut aov.data, aov.floats_per_pixel));
        }
        out
    }

    /// The pass `pass` beyond the first four, if the film holds it.
    pub fn aov(&self, pass: Pass) -> Option<&Aov> {
        self.aovs.iter().find(|a| a.pass == pass)
    }

    /// The passes the film holds, in [`Pass::ALL`] order.
    pub fn passes(&self) -> Vec<Pass> {
        let first = [
            (Pass::Combined, true),
            (Pass::Depth, !self.depth.is_empty()),
            (Pass::Normal, !self.normal.is_empty()),
            (Pass::Albedo, !self.albedo.is_empty()),
        ];
        let first = first.into_iter().filter(|&(_, on)| on).map(|(p, _)| p);
        first.chain(self.aovs.iter().map(|a| a.pass)).collect()
    }

    /// Every channel of the film, pass by pass in [`Pass::ALL`] order, each pass's floats in
    /// order (R, G, B, A; X, Y, Z; Cryptomatte id, coverage, id, coverage, …). The EXR writer
    /// names them ([`crate::output::exr`]); a tool that copies channels can go through this list.
    pub fn channels(&self) -> Vec<ChannelView<'_>> {
        let mut out = Vec::new();
        fn add<'a>(out: &mut Vec<ChannelView<'a>>, pass: Pass, data: &'a [f32], stride: usize) {
            for component in 0..stride {
                out.push(ChannelView { pass, component, data, stride, offset: component });
            }
        }
        // [f32; 4] and glam's Vec3 (three f32, no padding, `Pod`) seen as flat floats.
        add(&mut out, Pass::Combined, self.rgba.as_flattened(), 4);
        if !self.depth.is_empty() {
            add(&mut out, Pass::Depth, &self.depth, 1);
        }
        if !self.normal.is_empty() {
            add(&mut out, Pass::Normal, bytemuck::cast_slice(&self.normal), 3);
        }
        if !self.albedo.is_empty() {
            add(&mut out, Pass::Albedo, bytemuck::cast_slice(&self.albedo), 3);
        }
        for aov in &self.aovs {
            add(&mut out, aov.pass, &aov.data, aov.floats_per_pixel);
        }
        out
    }
}
