//! The path tracer's sampler: an Owen-scrambled Sobol sequence per pixel (Burley, "Practical
//! Hash-based Owen Scrambling", JCGT 2020, through the `sobol_burley` crate).
//!
//! ```text
//! value(pixel, sample, d) = sobol_burley::sample(sample, d mod 2, seed(pixel, d div 2))
//! seed(pixel, k)          = splitmix64(splitmix64(y·W + x) + k)   (the low 32 bits)
//! ```
//!
//! Every value is a function of the pixel's index `y·W + x`, the pixel's sample number and the
//! dimension alone, so tiles, `--resume`, `merge` and `--threads` give the same bytes. The
//! dimensions are padded in pairs (Burley's §4 padding, with sets of two): each pair of
//! dimensions `2j, 2j + 1` is Sobol's first two dimensions, Owen-scrambled and with its index
//! shuffled by its own seed, stratified within itself and independent of the other pairs. So
//! the crate's 256-dimension table is never the limit: a dimension's high bits (`d div 2`) are
//! folded into the seed. Pairs, not the crate's sets of four: Sobol's dimensions (0, 1) are a
//! (0, 2)-sequence, (2, 3) are not (64 points miss cells of the 4 × 16 grid), so a 2-D draw
//! ([`Sobol::next_2d`]) always takes a whole pair, and the pairs a path tracer uses (pixel
//! position, lens, light point, BSDF direction) put the first 2^k samples of a pixel one in
//! each of the 2^k elementary intervals of every shape.
//!
//! The index shuffle of `sobol_burley` is a nested uniform scramble of the bit-reversed index,
//! which maps every aligned block of 2^k indices onto an aligned block: any power-of-two
//! prefix of a pixel's samples is a whole net, so 64 samples are as well stratified as 64
//! could be, and 65 are 64 plus one.
//!
//! The sequence has 2^16 = 65,536 points: a render asking for more samples per pixel is refused
//! ([`check_spp`]).
//!
//! **Evaluation.** Only Sobol's dimensions 0 and 1 are ever drawn, so [`Sobol::value`] computes
//! `sobol_burley::sample(i, d mod 2, seed)` itself from the crate's parts (`hash`,
//! `owen_scramble_rev`), with the unscrambled point read from a table instead of the crate's
//! loop over the index's bits, whose exit is a branch mispredicted on most calls: a Sobol
//! dimension is linear over GF(2) in the index's bits, so the point of a 16-bit index is the XOR
//! of the points of its two bytes ([`PAIR_TABLE`], built from the two dimensions' direction
//! numbers, `v_k = 2^k` and `v_k = v_{k−1} ⊕ 2·v_{k−1}`). The two values of a pair share their
//! seed and shuffled index, computed once ([`Sobol::next_2d`]). What a pair takes from the pixel
//! alone, the hashes of its seed for the index shuffle and the two scrambles, is the same at
//! every sample: a pixel's sampler keeps them for the first `KEPT_PAIRS` pairs (the camera's and
//! eight bounces'; 432 bytes a pixel, for the pixels of the tiles being traced), so a sample
//! computes only what depends on its index. The test
//! `values_are_the_crates_bit_for_bit` checks every index of the sequence against the crate.
//!
//! **Dimension bookkeeping** ([`Sobol::start_sample`], [`Sobol::start_bounce`]): dimensions 0–1
//! are the pixel position, 2–3 the lens, and bounce `b` (0 at the camera ray's hit) owns the
//! [`DIMS_PER_BOUNCE`] dimensions from `4 + b·DIMS_PER_BOUNCE`, so dimension `d` always means the
//! same thing whatever happened earlier on the path.

use sobol_burley::parts;

use crate::math::Vec2;

/// Samples per pixel the sequence holds (`sobol_burley`'s limit).
pub const MAX_SAMPLES: u32 = 1 << 16;

/// Dimensions of the camera sample: the pixel position (0, 1) and the lens point (2, 3).
pub const CAMERA_DIMS: u32 = 4;

/// Dimensions each bounce owns: the light's choice and point (2, one pair:
/// [`crate::light::set::LightSet::sample`]), Russian roulette, one spare, the BSDF direction
/// (2), the BSDF lobe, one spare.
pub const DIMS_PER_BOUNCE: u32 = 8;

/// Why `spp` samples per pixel cannot be drawn from the sequence, if they cannot.
pub fn check_spp(spp: u32) -> Result<(), String> {
    if spp > MAX_SAMPLES {
        Err(format!(
            "spp {spp} is more than the {MAX_SAMPLES} samples per pixel the path tracer's Sobol sequence holds"
        ))
    } else {
        Ok(())
    }
}

/// SplitMix64's finaliser (Steele et al.): a bijective 64-bit mix.
#[inline]
pub(crate) fn splitmix64(x: u64) -> u64 {
    let mut z = x.wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// One pixel's sampler (see the module docs).
#[derive(Clone, Debug)]
pub struct Sobol {
    /// The pixel's hash.
    pixel: u64,
    /// The pixel's sample number (the sequence index), bit-reversed as `sobol_burley` takes it
    /// (every pair of dimensions of the sample starts from it: reversed once per sample).
    index_rev: u32,
    /// The next dimension to draw.
    dim: u32,
    /// How many of the pixel's first pairs `kept` holds.
    known: u32,
    /// What each of the first [`KEPT_PAIRS`] pairs of dimensions draws from the pixel alone,
    /// the same at every sample: [`PairHashes`], computed at the pair's first draw.
    kept: [PairHashes; KEPT_PAIRS],
}

/// The pairs whose hashes a pixel's sampler keeps: the camera's two and four per bounce for
/// eight bounces (later pairs are hashed at every draw).
const KEPT_PAIRS: usize = ((CAMERA_DIMS + 8 * DIMS_PER_BOUNCE) / 2) as usize;

/// What a pair of dimensions takes from the pixel and the pair alone: the hash of the index
/// shuffle and the hashes of its two dimensions' scrambles (`sobol_burley::sample`'s seeds).
#[derive(Clone, Copy, Debug, Default)]
struct PairHashes {
    shuffle: u32,
    scramble: [u32; 2],
}

impl PairHashes {
    /// Pair `j`'s hashes for the pixel whose hash is `pixel`.
    #[inline]
    fn of(pixel: u64, j: u32) -> PairHashes {
        let seed = splitmix64(pixel.wrapping_add(j as u64)) as u32;
        let scramble =
            |d: u32| parts::hash(seed.wrapping_mul(0x9c8f_2d3b) ^ if d == 0 { 0x912f_69ba } else { 0x174f_18ab });
        PairHashes { shuffle: parts::hash(seed ^ 0x79c6_8e4a), scramble: [scramble(0), scramble(1)] }
    }
}

impl Sobol {
    /// The sampler of the pixel with index `pixel_index` (`y·W + x`).
    pub fn new(pixel_index: u64) -> Self {
        Sobol {
            pixel: splitmix64(pixel_index),
            index_rev: 0,
            dim: 0,
            known: 0,
            kept: [PairHashes::default(); KEPT_PAIRS],
        }
    }

    /// Starts the pixel's sample `sample` (< [`MAX_SAMPLES`]) at dimension 0.
    pub fn start_sample(&mut self, sample: u32) {
        debug_assert!(sample < MAX_SAMPLES);
        self.index_rev = (sample & (MAX_SAMPLES - 1)).reverse_bits();
        self.dim = 0;
    }

    /// Moves to the first dimension of bounce `bounce`.
    pub fn start_bounce(&mut self, bounce: u32) {
        self.dim = CAMERA_DIMS.saturating_add(bounce.saturating_mul(DIMS_PER_BOUNCE));
    }

    /// Moves to dimension `dim`.
    pub fn set_dimension(&mut self, dim: u32) {
        self.dim = dim;
    }

    /// The hashes of the pair `j` (dimensions `2j`, `2j + 1`): kept for the first
    /// [`KEPT_PAIRS`], computed in order at their first draw.
    #[inline]
    fn hashes(&mut self, j: u32) -> PairHashes {
        if j as usize >= KEPT_PAIRS {
            return PairHashes::of(self.pixel, j);
        }
        while self.known <= j {
            self.kept[self.known as usize] = PairHashes::of(self.pixel, self.known);
            self.known += 1;
        }
        self.kept[j as usize]
    }

    /// The value of dimension `d` at the current sample, in `[0, 1)`:
    /// `sobol_burley::sample(sample, d mod 2, seed)` (module docs).
    #[inline]
    pub fn value(&mut self, d: u32) -> f32 {
        let h = self.hashes(d / 2);
        let shuffled = parts::owen_scramble_rev(self.index_rev, h.shuffle);
        scrambled(sobol_pair_rev(shuffled)[(d % 2) as usize], h.scramble[(d % 2) as usize])
    }

    /// The next dimension.
    #[inline]
    pub fn next_1d(&mut self) -> f32 {
        let v = self.value(self.dim);
        self.dim = self.dim.wrapping_add(1);
        v
    }

    /// The next two dimensions, one whole pair `2j, 2j + 1` (an odd dimension is skipped).
    #[inline]
    pub fn next_2d(&mut self) -> Vec2 {
        if self.dim % 2 == 1 {
            self.dim = self.dim.wrapping_add(1);
        }
        let h = self.hashes(self.dim / 2);
        let [x, y] = sobol_pair_rev(parts::owen_scramble_rev(self.index_rev, h.shuffle));
        self.dim = self.dim.wrapping_add(2);
        Vec2::new(scrambled(x, h.scramble[0]), scrambled(y, h.scramble[1]))
    }
}

/// Sobol's dimensions 0 and 1 (in `sobol_burley`'s reversed-bit form) of each value of the
/// reversed index's top byte (`[0]`) and next byte (`[1]`): bit `31 − k` of the reversed index
/// adds direction number `v_k` (module docs).
static PAIR_TABLE: [[[u32; 2]; 256]; 2] = pair_table();

const fn pair_table() -> [[[u32; 2]; 256]; 2] {
    // The direction numbers of dimensions 0 and 1, reversed: v_k = 2^k, and the Pascal
    // matrix mod 2 (1, 3, 5, 15, 17, 51, ...).
    let mut v = [[0u32; 2]; 16];
    let mut k = 0;
    while k < 16 {
        v[k][0] = 1 << k;
        v[k][1] = if k == 0 { 1 } else { v[k - 1][1] ^ (v[k - 1][1] << 1) };
        k += 1;
    }
    let mut table = [[[0u32; 2]; 256]; 2];
    let mut byte = 0;
    while byte < 2 {
        let mut b = 0;
        while b < 256 {
            let mut bit = 0;
            while bit < 8 {
                if b & (0x80 >> bit) != 0 {
                    let k = 8 * byte + bit;
                    table[byte][b][0] ^= v[k][0];
                    table[byte][b][1] ^= v[k][1];
                }
                bit += 1;
            }
            b += 1;
        }
        byte += 1;
    }
    table
}

/// Sobol's dimensions 0 and 1 of the reversed index `index_rev` (its top 16 bits), reversed:
/// `sobol_burley::parts::sobol_rev(index_rev, 0 | 1)`.
#[inline]
fn sobol_pair_rev(index_rev: u32) -> [u32; 2] {
    let [a, b] = [&PAIR_TABLE[0][(index_rev >> 24) as usize], &PAIR_TABLE[1][((index_rev >> 16) & 0xff) as usize]];
    [a[0] ^ b[0], a[1] ^ b[1]]
}

/// The Owen scramble with hash `scramble` ([`PairHashes`]) applied to a reversed Sobol point,
/// as a float in `[0, 1)` (`sobol_burley::sample`'s last steps).
#[inline]
fn scrambled(sobol_rev: u32, scramble: u32) -> f32 {
    parts::u32_to_f32_norm(parts::owen_scramble_rev(sobol_rev, scramble).reverse_bits())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_first_power_of_two_samples_are_stratified_in_every_pair_a_bounce_uses() {
        // For 2^k samples of a pixel, every 2-D draw puts exactly one point in each cell of a
        // 2^a × 2^(k−a) grid (the (0, m, 2)-net property), for every a, and every 1-D draw one
        // point in each of 2^k intervals; for several pixels and for bounces past the
        // crate's 256 dimensions.
        for pixel in [0u64, 1, 12345, u64::MAX] {
            for k in [4u32, 6, 8] {
                let n = 1u32 << k;
                for bounce in [0u32, 3, 40] {
                    let mut pts = Vec::new();
                    let mut ones = Vec::new();
                    let mut lens = Vec::new();
                    for s in 0..n {
                        let mut sob = Sobol::new(pixel);
                        sob.start_sample(s);
                        sob.start_bounce(bounce);
                        ones.push(sob.next_1d());
                        sob.set_dimension(CAMERA_DIMS + bounce * DIMS_PER_BOUNCE + 4);
                        pts.push(sob.next_2d());
                        sob.set_dimension(2);
                        lens.push(sob.next_2d());
                    }
                    let intervals: std::collections::BTreeSet<u32> =
                        ones.iter().map(|&v| (v * n as f32) as u32).collect();
                    assert_eq!(intervals.len(), n as usize, "pixel {pixel} 2^{k} bounce {bounce}");
                    for a in 0..=k {
                        let (nx, ny) = (1u32 << a, 1u32 << (k - a));
                        for (what, pts) in [("bounce", &pts), ("lens", &lens)] {
                            let cells: std::collections::BTreeSet<(u32, u32)> =
                                pts.iter().map(|p| ((p.x * nx as f32) as u32, (p.y * ny as f32) as u32)).collect();
                            assert_eq!(
                                cells.len(),
                                n as usize,
                                "{what}: pixel {pixel} 2^{k} {nx}×{ny} bounce {bounce}"
                            );
                        }
                    }
                    assert!(pts.iter().all(|p| (0.0..1.0).contains(&p.x) && (0.0..1.0).contains(&p.y)));
                }
            }
        }
    }

    #[test]
    fn values_depend_on_pixel_sample_and_dimension_only() {
        // Visiting pixels and samples in any order gives the same values.
        let draw = |pixel: u64, sample: u32| {
            let mut s = Sobol::new(pixel);
            s.start_sample(sample);
            (0..40).map(|_| s.next_1d()).collect::<Vec<_>>()
        };
        let forward: Vec<_> = (0..16u64).flat_map(|p| (0..8).map(move |s| (p, s))).map(|(p, s)| draw(p, s)).collect();
        let mut shared = Sobol::new(0);
        let backward: Vec<_> = (0..16u64)
            .rev()
            .flat_map(|p| (0..8).rev().map(move |s| (p, s)))
            .map(|(p, s)| {
                // One sampler reused across pixels gives the same as a fresh one.
                shared = Sobol::new(p);
                shared.start_sample(s);
                (0..40).map(|_| shared.next_1d()).collect::<Vec<_>>()
            })
            .collect();
        let mut backward = backward;
        backward.reverse();
        assert_eq!(forward, backward);
        // Different pixels and different dimension sets are not the same sequence.
        assert_ne!(draw(0, 0), draw(1, 0));
        let mut s = Sobol::new(7);
        assert_ne!(s.value(0), s.value(2));
        assert_ne!(s.value(1000), s.value(1002));
    }

    #[test]
    fn values_are_the_crates_bit_for_bit() {
        // Every index of the sequence, both dimensions of a pair, for pixels and pairs whose
        // seeds differ in every way; against the crate's own `sample`.
        for pixel in [0u64, 1, 77, 12345, u64::MAX] {
            let mut s = Sobol::new(pixel);
            for index in 0..MAX_SAMPLES {
                s.start_sample(index);
                for d in [0u32, 1, 6, 7, 301, 1 << 20] {
                    let seed = splitmix64(s.pixel.wrapping_add(d as u64 / 2)) as u32;
                    let expect = sobol_burley::sample(index, d % 2, seed);
                    assert_eq!(s.value(d).to_bits(), expect.to_bits(), "pixel {pixel} index {index} d {d}");
                }
                s.set_dimension(300);
                let v = s.next_2d();
                assert_eq!((v.x.to_bits(), v.y.to_bits()), (s.value(300).to_bits(), s.value(301).to_bits()));
            }
        }
    }

    #[test]
    fn more_than_the_sequence_is_refused() {
        assert!(check_spp(MAX_SAMPLES).is_ok());
        let e = check_spp(MAX_SAMPLES + 1).unwrap_err();
        assert!(e.contains("65537") && e.contains("65536") && !e.contains('\n'), "{e}");
    }
}
