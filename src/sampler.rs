//! Where in a pixel its samples go: stratified (jittered) positions for antialiasing,
//! deterministic per pixel.
//!
//! `spp` samples split the pixel into a grid of `nx × ny = spp` equal strata (`ny` the largest
//! divisor of `spp` not above `√spp`, so 4 → 2×2, 8 → 4×2, 9 → 3×3; a prime gives a row of
//! vertical strips), and sample `s` lies at a uniformly random point of stratum
//! `(s mod nx, s div nx)`. The random numbers come from a PCG generator seeded with the
//! pixel's index `y·W + x` alone, never from the thread or the time, so every pixel gets the
//! same positions on every run and with any number of threads. `spp = 1` is not jittered: its
//! one sample is exactly the pixel centre, the lecture's ray.

use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64Mcg;

use crate::math::Vec2;

/// The sample positions of one pixel, in `[0, 1)²` (`(0.5, 0.5)` is the centre), in sample
/// order. Draw them in order with [`PixelSampler::next_offset`].
#[derive(Clone, Debug)]
pub struct PixelSampler {
    rng: Pcg64Mcg,
    nx: u32,
    ny: u32,
    spp: u32,
    next: u32,
}

/// The strata grid `(nx, ny)` for `spp` samples: `ny` is the largest divisor of `spp` with
/// `ny² ≤ spp`, `nx = spp / ny`.
pub fn strata(spp: u32) -> (u32, u32) {
    // In u64: `d·d` cannot overflow for any u32 `spp`.
    let ny = (1..=spp.max(1))
        .take_while(|&d| d as u64 * d as u64 <= spp as u64)
        .filter(|d| spp % d == 0)
        .last()
        .unwrap_or(1);
    (spp.max(1) / ny, ny)
}

impl PixelSampler {
    /// The sampler of the pixel with index `pixel_index` (`y·W + x`) for `spp` samples.
    pub fn new(spp: u32, pixel_index: u64) -> Self {
        let (nx, ny) = strata(spp);
        // One sample is the pixel centre and draws nothing: skip seeding (PCG's seed expansion
        // was 3 % of a 1-spp render); `Pcg64Mcg::new` only stores its state.
        let rng = if spp > 1 { Pcg64Mcg::seed_from_u64(pixel_index) } else { Pcg64Mcg::new(0) };
        PixelSampler { rng, nx, ny, spp, next: 0 }
    }

    /// The position of the next sample. After `spp` samples it starts a new, independent
    /// round of strata (callers draw exactly `spp`).
    pub fn next_offset(&mut self) -> Vec2 {
        if self.spp <= 1 {
            return Vec2::splat(0.5);
        }
        let s = self.next;
        self.next = (self.next + 1) % self.spp;
        let (i, j) = (s % self.nx, s / self.nx);
        let (jx, jy): (f32, f32) = (self.rng.random(), self.rng.random());
        // (i + ξ)/n in f32 can round up to exactly 1 for ξ just below 1: keep it inside.
        let inside = |k: u32, xi: f32, n: u32| ((k as f32 + xi) / n as f32).min(1.0 - f32::EPSILON / 2.0);
        Vec2::new(inside(i, jx, self.nx), inside(j, jy, self.ny))
    }
}

/// All `spp` sample positions of pixel `pixel_index`, in sample order.
pub fn offsets(spp: u32, pixel_index: u64) -> Vec<Vec2> {
    let mut s = PixelSampler::new(spp, pixel_index);
    (0..spp.max(1)).map(|_| s.next_offset()).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn strata_are_as_square_as_the_count_allows() {
        assert_eq!(strata(1), (1, 1));
        // No overflow at the top of the range: 2³² − 1 = 3·5·17·257·65537.
        assert_eq!(strata(u32::MAX), (65537, 65535));
        assert_eq!(strata(2), (2, 1));
        assert_eq!(strata(4), (2, 2));
        assert_eq!(strata(8), (4, 2));
        assert_eq!(strata(9), (3, 3));
        assert_eq!(strata(7), (7, 1));
        assert_eq!(strata(64), (8, 8));
    }

    #[test]
    fn every_sample_lies_in_its_own_stratum() {
        for spp in [2, 6, 16] {
            let (nx, ny) = strata(spp);
            let o = offsets(spp, 12345);
            for (s, p) in o.iter().enumerate() {
                let (i, j) = ((p.x * nx as f32) as u32, (p.y * ny as f32) as u32);
                assert_eq!((i, j), (s as u32 % nx, s as u32 / nx), "spp {spp} sample {s} at {p}");
                assert!(p.x >= 0.0 && p.x < 1.0 && p.y >= 0.0 && p.y < 1.0);
            }
        }
    }
}
