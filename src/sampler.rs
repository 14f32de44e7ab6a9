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
//!
//! **Light and lens samples** ([`SampleDims`]) are stratified the same way, across the pixel's
//! samples: pixel sample `s` takes stratum `π(s)` of the same `nx × ny` grid over the light's
//! (or the lens's) unit square, `π` a random permutation of the samples drawn per pixel (so
//! the light stratum is not tied to the pixel stratum, which would correlate them), and a
//! light asking for `k` samples per shading point splits that stratum again into the
//! `strata(k)` grid. Over a pixel the `spp·k` light points are thus one stratum each of a
//! jittered grid. These numbers come from a second generator, seeded with the pixel index
//! and a different stream constant, and only scenes with area lights or a lens draw them: a
//! pinhole scene with point lights consumes exactly the random numbers it did before.

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

/// Seed offset of the [`SampleDims`] generator, so it never repeats the positions' stream.
const DIMS_STREAM: u64 = 0x9e37_79b9_7f4a_7c15;

/// The lens and light sample points of one pixel's samples (see the module docs). Call
/// [`SampleDims::begin`] before each pixel sample.
#[derive(Clone, Debug)]
pub struct SampleDims {
    rng: Pcg64Mcg,
    nx: u32,
    ny: u32,
    light_perm: Vec<u32>,
    lens_perm: Vec<u32>,
    sample: u32,
}

/// A random permutation of `0..n`.
fn permutation(rng: &mut Pcg64Mcg, n: u32) -> Vec<u32> {
    let mut p: Vec<u32> = (0..n).collect();
    for i in (1..p.len()).rev() {
        p.swap(i, rng.random_range(0..=i));
    }
    p
}

impl SampleDims {
    /// The sample points of pixel `pixel_index` for `spp` samples: `lights` when the scene
    /// has area lights, `lens` when the camera has an aperture. Neither draws nothing.
    pub fn new(spp: u32, pixel_index: u64, lights: bool, lens: bool) -> Self {
        let (nx, ny) = strata(spp);
        let mut rng = Pcg64Mcg::seed_from_u64(pixel_index ^ DIMS_STREAM);
        let light_perm = if lights { permutation(&mut rng, spp.max(1)) } else { Vec::new() };
        let lens_perm = if lens { permutation(&mut rng, spp.max(1)) } else { Vec::new() };
        SampleDims { rng, nx, ny, light_perm, lens_perm, sample: 0 }
    }

    /// For code that traces single rays outside a render (no area lights, no lens): draws
    /// nothing until asked.
    pub fn unused() -> Self {
        SampleDims { rng: Pcg64Mcg::new(0), nx: 1, ny: 1, light_perm: Vec::new(), lens_perm: Vec::new(), sample: 0 }
    }

    /// Starts pixel sample `s`.
    pub fn begin(&mut self, s: u32) {
        self.sample = s;
    }

    /// A point of stratum `π(s)` of the pixel's grid, sub-stratum `j` of the `grid`.
    fn point(&mut self, lens: bool, j: u32, grid: (u32, u32)) -> Vec2 {
        let perm = if lens { &self.lens_perm } else { &self.light_perm };
        let k = perm.get(self.sample as usize).copied().unwrap_or(0);
        let (cx, cy) = (k % self.nx, k / self.nx);
        let (sx, sy) = (j % grid.0, (j / grid.0).min(grid.1 - 1));
        let (jx, jy): (f32, f32) = (self.rng.random(), self.rng.random());
        let inside = |c: u32, n: u32, s: u32, m: u32, xi: f32| {
            let cells = (n * m) as f32;
            (((c * m + s) as f32 + xi) / cells).min(1.0 - f32::EPSILON / 2.0)
        };
        Vec2::new(inside(cx, self.nx, sx, grid.0, jx), inside(cy, self.ny, sy, grid.1, jy))
    }

    /// The point in `[0, 1)²` of light sample `j` of a light with `strata(k) = grid` samples per
    /// shading point, at the current pixel sample.
    pub fn light(&mut self, j: u32, grid: (u32, u32)) -> Vec2 {
        self.point(false, j, grid)
    }

    /// The lens point in `[0, 1)²` of the current pixel sample.
    pub fn lens(&mut self) -> Vec2 {
        self.point(true, 0, (1, 1))
    }
}

/// Shirley and Chiu's concentric map of `[0, 1)²` onto the unit disk, which preserves areas
/// (so uniform points stay uniform) and keeps strata compact.
pub fn concentric_disk(u: Vec2) -> (f64, f64) {
    let (a, b) = (2.0 * u.x as f64 - 1.0, 2.0 * u.y as f64 - 1.0);
    if a == 0.0 && b == 0.0 {
        return (0.0, 0.0);
    }
    let q = std::f64::consts::FRAC_PI_4;
    let (r, phi) = if a.abs() > b.abs() { (a, q * (b / a)) } else { (b, 2.0 * q - q * (a / b)) };
    (r * phi.cos(), r * phi.sin())
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
    fn light_points_over_a_pixel_fill_every_stratum_once() {
        // 8 pixel samples (4×2) × 6 light samples (3×2): 48 points, one in each cell of the
        // 12×4 grid, whichever permutation the pixel drew.
        for pixel in [0, 1, 99] {
            let mut d = SampleDims::new(8, pixel, true, true);
            let mut seen = std::collections::BTreeSet::new();
            for s in 0..8 {
                d.begin(s);
                for j in 0..6 {
                    let p = d.light(j, strata(6));
                    assert!(p.x >= 0.0 && p.x < 1.0 && p.y >= 0.0 && p.y < 1.0);
                    assert!(seen.insert(((p.x * 12.0) as u32, (p.y * 4.0) as u32)), "pixel {pixel}: {p}");
                }
            }
            assert_eq!(seen.len(), 48);
            // The lens points: one per stratum of the pixel's 4×2 grid.
            let lens: std::collections::BTreeSet<_> = (0..8)
                .map(|s| {
                    d.begin(s);
                    let p = d.lens();
                    ((p.x * 4.0) as u32, (p.y * 2.0) as u32)
                })
                .collect();
            assert_eq!(lens.len(), 8);
        }
        // Deterministic per pixel, different between pixels.
        let draw = |pixel| {
            let mut d = SampleDims::new(4, pixel, true, false);
            d.begin(2);
            d.light(0, (1, 1))
        };
        assert_eq!(draw(5), draw(5));
        assert_ne!(draw(5), draw(6));
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
