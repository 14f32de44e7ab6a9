//! Adaptive sampling: a pixel stops taking samples once its own noise estimate is below a
//! threshold, Cycles' rule copied (Blender Cycles, `intern/cycles`; the file names below are
//! those of its sources). `image.spp` is then the most samples a pixel takes.
//!
//! **The settings** (`scene/integrator.cpp`, `Integrator::get_adaptive_sampling`), from the
//! user's threshold `T` (`--adaptive-threshold`, `[render] adaptive_threshold`; Cycles'
//! default is 0.01) and minimum samples `m` (`[render] adaptive_min_samples`, 0 = automatic):
//!
//! ```text
//! min_samples = max(4, ceil(16 / T^0.3))   when m = 0   (T = 0.1 → 32, 0.01 → 64, 0.001 → 128)
//!             = max(4, m)                  otherwise
//! threshold   = 5 · T                      (Cycles: "makes the threshold more similar to what it was before")
//! step        = 16
//! ```
//!
//! **When a pixel is tested** (`integrator/adaptive_sampling.cpp`, `need_filter`): after its
//! sample `s` (0-based) when `s > min_samples` and `s mod 16 = 15`, so after 16·k samples,
//! the first time after `(min_samples + 1) | 15` + 1 of them (80 at T = 0.01).
//!
//! **The test** (`kernel/film/adaptive_sampling.h`, `film_adaptive_sampling_convergence_check`,
//! after Dammertz et al., "A hierarchical automatic stopping condition for Monte Carlo global
//! illumination", §2.1, applied per pixel): with `I` the sum of the pixel's `n` samples' RGB,
//! and `A` twice the sum of its class-A samples (`kernel/sample/pattern.h`,
//! `sample_is_class_A`: sample `s` is in class A when `popcount(s & 0xaaaaaaaa)` is odd;
//! exactly half of any 16·k first samples are), in f32 as Cycles computes it:
//!
//! ```text
//! error_difference = (|I.r − A.r| + |I.g − A.g| + |I.b − A.b|) / n
//! intensity        = (I.r + I.g + I.b) / n
//! error_normalize  = sqrt(intensity) if intensity < 1, else intensity
//! error            = error_difference / (0.0001 + error_normalize)
//! converged        ⇔ error < threshold            (threshold = 5·T)
//! ```
//!
//! **The dilation** (`film_adaptive_sampling_filter_x`, then `_y`, [`dilate`]): after the
//! test, a converged pixel goes on sampling when one of its eight neighbours has not
//! converged (a horizontal pass, then a vertical one: a 3 × 3 box). A pixel stops only when it
//! and its neighbours have converged, so a pixel whose first samples happened to miss a rare
//! bright path (a caustic) goes on while a neighbour has seen one. A stopped pixel takes no
//! more samples; its film value is the mean over the samples it took ([`super::pixel`]).
//!
//! **Differences from Cycles**, each so that when a pixel stops depends on its own cell of the
//! tile grid alone, hence regions, `--tile`, `--resume`, `merge` and any `--threads` give the
//! same bytes:
//! - the dilation stays inside the pixel's cell of the tile grid
//!   ([`TILE_SIZE`](crate::output::region::TILE_SIZE)² squares anchored at pixel `(0, 0)`), as
//!   Cycles' stays inside its tile (the whole frame, for frames up to 2048² rendered in the
//!   background); a tile the region clips traces its whole cell. Without the dilation strahl's
//!   error stopped falling: on the Cycles benchmark's Cornell room (240 × 135, threshold 0.01)
//!   9.3 % RMSE at most 2048 samples, against 5.8 % with it (docs/performance.md);
//! - a stopped pixel stays stopped: Cycles sends a pixel back to sampling when the dilation
//!   of a later test reaches it;
//! - a threshold of 0 turns adaptive sampling off (Cycles turns it off with its own switch and
//!   reads 0 as "automatic", `max(0.001, 1 / spp)`);
//! - no film exposure (Cycles scales `I` and `A` by it; strahl's exposure is the PNG's only);
//! - only the path tracer: its Sobol samples are a progressive sequence (any first `n` are
//!   well spread), where Whitted's stratified positions for `spp` samples are not.
//!
//! **The variance pass** ([`PixelNoise::variance_of_mean`]): the variance of the pixel's mean
//! per channel, `S / (n − 1) / n` with `S` the sum of squared deviations from the mean,
//! accumulated by Welford's update in f64 as pbrt-v4's `VarianceEstimator` does
//! (`util/sampling.h`; 0 for `n < 2`). pbrt-v4's GBuffer film writes `S / (n − 1)` itself, the
//! variance of one sample, as `Variance`; strahl's is that divided by `n`, the error of the
//! value in the image (its square root is the standard error), so that `n ×` strahl's is pbrt's.

use glam::DVec3;

use crate::math::Vec3;
use crate::scene::AdaptiveSpec;

/// Cycles' `adaptive_step`: pixels are tested after every 16th sample.
pub const STEP: u32 = 16;

/// The rule the tile loop applies: when to test a pixel and the threshold it must be under.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Adaptive {
    /// Cycles' effective threshold, 5 × the user's.
    pub threshold: f32,
    /// Samples every pixel takes before its first test can come.
    pub min_samples: u32,
}

impl Adaptive {
    /// The rule of the user's settings (see the module docs).
    pub fn new(spec: &AdaptiveSpec) -> Adaptive {
        let min_samples = if spec.min_samples == 0 {
            (16.0f32 / spec.threshold.powf(0.3)).ceil().max(4.0) as u32
        } else {
            spec.min_samples.max(4)
        };
        Adaptive { threshold: 5.0 * spec.threshold, min_samples }
    }

    /// Whether pixels are tested after their sample `sample` (0-based).
    pub fn tests_after(&self, sample: u32) -> bool {
        sample > self.min_samples && sample % STEP == STEP - 1
    }

    /// Whether a pixel whose `n` samples sum to `sum` has converged.
    pub fn converged(&self, sum: Vec3, noise: &PixelNoise) -> bool {
        error(sum, 2.0 * noise.class_a, noise.samples) < self.threshold
    }
}

/// Cycles' error estimate of a pixel (the module docs' formula): `sum` the sum of its `n`
/// samples, `a` twice the sum of its class-A samples.
pub fn error(sum: Vec3, a: Vec3, n: u32) -> f32 {
    let scale = 1.0 / n as f32;
    let d = sum - a;
    let error_difference = (d.x.abs() + d.y.abs() + d.z.abs()) * scale;
    let intensity = (sum.x + sum.y + sum.z) * scale;
    let error_normalize = if intensity < 1.0 { intensity.sqrt() } else { intensity };
    error_difference / (0.0001 + error_normalize)
}

/// The dilation of the module docs over a cell of `width` pixels a row, its pixels row by
/// row: which pixels go on sampling, given which have not converged (a pixel that has stopped
/// counts as converged). Each goes on when it or one of its eight neighbours in the cell has
/// not converged.
pub fn dilate(unconverged: &[bool], width: usize) -> Vec<bool> {
    let height = unconverged.len() / width.max(1);
    let row_of = |y: usize| &unconverged[y * width..(y + 1) * width];
    let mut out = vec![false; unconverged.len()];
    for y in 0..height {
        for x in 0..width {
            let (x0, x1) = (x.saturating_sub(1), (x + 2).min(width));
            out[y * width + x] =
                (y.saturating_sub(1)..(y + 2).min(height)).any(|yy| row_of(yy)[x0..x1].iter().any(|&u| u));
        }
    }
    out
}

/// Whether sample `sample` (0-based) is in Cycles' class A.
pub fn is_class_a(sample: u32) -> bool {
    (sample & 0xaaaa_aaaa).count_ones() & 1 == 1
}

/// A pixel's noise estimates, updated sample by sample in sample order: the count, the sum of
/// the class-A samples (for [`Adaptive::converged`]) and Welford's running mean and squared
/// deviations (for the variance pass).
#[derive(Clone, Copy, Debug, Default)]
pub struct PixelNoise {
    samples: u32,
    class_a: Vec3,
    mean: DVec3,
    deviations: DVec3,
}

impl PixelNoise {
    /// Adds the next sample's radiance.
    pub fn add(&mut self, radiance: Vec3) {
        if is_class_a(self.samples) {
            self.class_a += radiance;
        }
        self.samples += 1;
        let x = radiance.as_dvec3();
        let delta = x - self.mean;
        self.mean += delta / self.samples as f64;
        self.deviations += delta * (x - self.mean);
    }

    /// The samples added.
    pub fn samples(&self) -> u32 {
        self.samples
    }

    /// The variance of the mean of the samples, per channel: `S / (n − 1) / n` (0 for `n < 2`).
    pub fn variance_of_mean(&self) -> Vec3 {
        let n = self.samples as f64;
        if self.samples < 2 { Vec3::ZERO } else { (self.deviations / ((n - 1.0) * n)).as_vec3() }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cycles_minimum_samples() {
        let min = |threshold, min_samples| Adaptive::new(&AdaptiveSpec { threshold, min_samples }).min_samples;
        // Cycles' comment: 0.1 → 32, 0.01 → 64, 0.001 → 128.
        assert_eq!([min(0.1, 0), min(0.01, 0), min(0.001, 0)], [32, 64, 128]);
        assert_eq!([min(1000.0, 0), min(0.01, 2), min(0.01, 100)], [4, 4, 100]);
        // 5 × 0.01 in f32, as Cycles multiplies.
        assert_eq!(Adaptive::new(&AdaptiveSpec { threshold: 0.01, min_samples: 0 }).threshold, 5.0 * 0.01f32);
    }

    #[test]
    fn tests_come_every_16_samples_after_the_minimum() {
        let rule = Adaptive::new(&AdaptiveSpec { threshold: 0.01, min_samples: 0 });
        let after: Vec<u32> = (0..200).filter(|&s| rule.tests_after(s)).map(|s| s + 1).collect();
        assert_eq!(after, [80, 96, 112, 128, 144, 160, 176, 192]);
    }

    #[test]
    fn class_a_is_half_of_every_16() {
        for block in 0..64u32 {
            assert_eq!((block * 16..block * 16 + 16).filter(|&s| is_class_a(s)).count(), 8);
        }
        assert_eq!((0..8).map(is_class_a).collect::<Vec<_>>(), [false, false, true, true, false, false, true, true]);
    }

    #[test]
    fn error_is_cycles_formula() {
        // Constant samples: A = I, no error.
        assert_eq!(error(Vec3::splat(16.0), Vec3::splat(16.0), 16), 0.0);
        // I = (8, 4, 4) over 16 samples, A = (4, 4, 4): difference 0.25, intensity 1 → 0.25 / 1.0001.
        let e = error(Vec3::new(8.0, 4.0, 4.0), Vec3::splat(4.0), 16);
        assert_eq!(e, 0.25 / 1.0001);
        // Dark pixels are normalised by the square root: intensity 0.25 → 0.5.
        let e = error(Vec3::new(2.0, 1.0, 1.0), Vec3::new(1.0, 1.0, 1.0), 16);
        assert!((e - 0.0625 / 0.5001).abs() < 1e-7);
    }

    #[test]
    fn the_dilation_is_a_3_by_3_box_inside_the_cell() {
        // A 4 × 3 cell, one unconverged pixel at (0, 1) and one at (3, 2).
        let mut unconverged = vec![false; 12];
        unconverged[4] = true;
        unconverged[11] = true;
        let going_on: Vec<u8> = dilate(&unconverged, 4).into_iter().map(u8::from).collect();
        #[rustfmt::skip]
        assert_eq!(going_on, [
            1, 1, 0, 0,
            1, 1, 1, 1,
            1, 1, 1, 1,
        ]);
        assert_eq!(dilate(&[false; 6], 3), [false; 6]);
        assert_eq!(dilate(&[true], 1), [true]);
    }

    #[test]
    fn variance_of_the_mean() {
        let mut noise = PixelNoise::default();
        for v in [1.0, 2.0, 3.0, 4.0] {
            noise.add(Vec3::new(v, 2.0 * v, 5.0));
        }
        // Sample variance 5/3, of the mean 5/12; the second channel 4×; the third 0.
        let var = noise.variance_of_mean();
        assert!((var.x - 5.0 / 12.0).abs() < 1e-7 && (var.y - 20.0 / 12.0).abs() < 1e-6 && var.z == 0.0);
        assert_eq!(noise.samples(), 4);
        let mut one = PixelNoise::default();
        one.add(Vec3::ONE);
        assert_eq!(one.variance_of_mean(), Vec3::ZERO);
    }
}
