//! An 8-bit sRGB PNG preview of the film: the linear radiance scaled by `2^exposure_ev`,
//! clipped to [0, 1], encoded with the sRGB transfer curve (IEC 61966-2-1) and rounded.
//! RGB only: alpha, depth and the other AOVs are in the EXR.
//!
//! The code of a clipped value `x` is `round(255 · srgb(x))` ([`code_of`]), which grows with
//! `x`; so it is the number of the 255 thresholds `T_k` (the least `x` whose code is `k`,
//! found once by bisecting the floats of [0, 1]) at most `x`, and [`to_srgb8`] finds it from
//! `x`'s 4096th of [0, 1] and a step or two along that table instead of a `powf` per channel
//! (the conversion was four
//! fifths of the preview's time: 1920 × 1080, 62 → 31 ms, `cargo bench --bench output`). A
//! test compares the two on every float within 65,536 ulps of each threshold and on a
//! sample of the rest.

use std::path::Path;
use std::sync::OnceLock;

use image::ImageEncoder;
use image::codecs::png::PngEncoder;

use crate::output::film::Film;
use crate::sys::atomic::{self, Staged, WriteError, commit_all};

/// The sRGB transfer curve ("gamma") of a linear value in [0, 1].
pub fn srgb_encode(linear: f32) -> f32 {
    if linear <= 0.003_130_8 { 12.92 * linear } else { 1.055 * linear.powf(1.0 / 2.4) - 0.055 }
}

/// The 8-bit code of `x` in [0, 1]: `round(255 · srgb(x))`.
pub fn code_of(x: f32) -> u8 {
    (srgb_encode(x) * 255.0).round() as u8
}

/// Buckets of [0, 1] in the lookup's first step.
const BUCKETS: usize = 4096;

/// The codes' thresholds and where to start looking in them.
struct Thresholds {
    /// `T_k` for `k` = 1 to 255 at index `k − 1`: the least float in [0, 1] whose code is `k`.
    t: [f32; 255],
    /// The code of `b / BUCKETS`, for `b` = 0 to `BUCKETS`: the code of any `x` in bucket `b`
    /// is this or a little more (the curve climbs at most 255 · 12.92 / 4096 < 1 code per
    /// bucket).
    start: [u8; BUCKETS + 1],
}

fn thresholds() -> &'static Thresholds {
    static TABLE: OnceLock<Thresholds> = OnceLock::new();
    TABLE.get_or_init(|| {
        let t: [f32; 255] = std::array::from_fn(|i| {
            // Bisect the bit patterns of [0, 1] (ordered as the floats are).
            let k = i as u8 + 1;
            let (mut lo, mut hi) = (0u32, 1f32.to_bits());
            while lo < hi {
                let mid = lo + (hi - lo) / 2;
                if code_of(f32::from_bits(mid)) >= k { hi = mid } else { lo = mid + 1 }
            }
            f32::from_bits(lo)
        });
        let start = std::array::from_fn(|b| t.partition_point(|&t| t <= b as f32 / BUCKETS as f32) as u8);
        Thresholds { t, start }
    })
}

/// A linear radiance value as an 8-bit sRGB code after multiplying by `scale`; negative and
/// NaN values become 0, values above 1 clip to 255.
#[allow(clippy::manual_clamp)] // `clamp` keeps NaN; `max` maps it to 0
pub fn to_srgb8(linear: f32, scale: f32) -> u8 {
    srgb8_with(thresholds(), linear, scale)
}

/// [`to_srgb8`] with the table at hand.
#[inline]
#[allow(clippy::manual_clamp)] // `clamp` keeps NaN; `max` maps it to 0
fn srgb8_with(table: &Thresholds, linear: f32, scale: f32) -> u8 {
    let x = (linear * scale).max(0.0).min(1.0);
    // `x · BUCKETS` is exact (a power of two), so `x` is at least its bucket's start.
    let mut code = table.start[(x * BUCKETS as f32) as usize] as usize;
    while code < 255 && table.t[code] <= x {
        code += 1;
    }
    code as u8
}

/// Encodes `film` as an RGB PNG in memory, with the exposure `exposure_ev` in stops.
pub fn encode(film: &Film, exposure_ev: f32) -> Result<Vec<u8>, image::ImageError> {
    encode_rgb(film.width, film.height, film.rgba.iter().map(|px| [px[0], px[1], px[2]]), exposure_ev)
}

/// Encodes the linear RGB `pixels` (row by row) of a `width` × `height` image as an RGB PNG
/// in memory, with the exposure `exposure_ev` in stops.
pub fn encode_rgb(
    width: u32,
    height: u32,
    pixels: impl Iterator<Item = [f32; 3]>,
    exposure_ev: f32,
) -> Result<Vec<u8>, image::ImageError> {
    let (scale, table) = (exposure_ev.exp2(), thresholds());
    let mut codes = Vec::with_capacity(3 * width as usize * height as usize);
    for px in pixels {
        codes.extend(px.map(|linear| srgb8_with(table, linear, scale)));
    }
    let mut bytes = Vec::new();
    PngEncoder::new(&mut bytes).write_image(&codes, width, height, image::ExtendedColorType::Rgb8)?;
    Ok(bytes)
}

/// Writes the preview of the linear RGB triples `rgb` to `path`, atomically: the PNG of a
/// frame denoised after it was written ([`crate::output::denoise::Beauty`]).
pub fn write_rgb(width: u32, height: u32, rgb: &[f32], exposure_ev: f32, path: &Path) -> Result<(), WriteError> {
    if !exposure_ev.is_finite() {
        return Err(WriteError::new(path, format!("exposure {exposure_ev} is not a finite number of stops")));
    }
    let pixels = rgb.chunks_exact(3).map(|p| [p[0], p[1], p[2]]);
    let bytes = encode_rgb(width, height, pixels, exposure_ev)
        .map_err(|e| WriteError::new(path, format!("cannot encode PNG: {e}")))?;
    commit_all(vec![atomic::stage(path, &bytes)?])
}

/// Writes the preview of `film` to `path`, atomically.
pub fn write(film: &Film, exposure_ev: f32, path: &Path) -> Result<(), WriteError> {
    commit_all(vec![stage(film, exposure_ev, path)?])
}

/// [`write()`] up to the temporary file, to be renamed with [`commit_all`] (with the EXR it
/// previews, say).
pub fn stage(film: &Film, exposure_ev: f32, path: &Path) -> Result<Staged, WriteError> {
    if !exposure_ev.is_finite() {
        return Err(WriteError::new(path, format!("exposure {exposure_ev} is not a finite number of stops")));
    }
    let bytes = encode(film, exposure_ev).map_err(|e| WriteError::new(path, format!("cannot encode PNG: {e}")))?;
    atomic::stage(path, &bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_curve_at_known_points() {
        assert_eq!(to_srgb8(0.0, 1.0), 0);
        assert_eq!(to_srgb8(1.0, 1.0), 255);
        assert_eq!(to_srgb8(7.0, 1.0), 255);
        assert_eq!(to_srgb8(-1.0, 1.0), 0);
        assert_eq!(to_srgb8(f32::NAN, 1.0), 0);
        // 0.5 linear → 1.055·0.5^(1/2.4) − 0.055 = 0.7354 → 187.5 → 188.
        assert_eq!(to_srgb8(0.5, 1.0), 188);
        // 18 % grey → 0.4614 → 117.7 → 118.
        assert_eq!(to_srgb8(0.18, 1.0), 118);
        // The linear toe: 0.002 · 12.92 · 255 = 6.59 → 7.
        assert_eq!(to_srgb8(0.002, 1.0), 7);
        // The two pieces meet at 0.0031308 (continuity within an ulp or two).
        assert!((12.92 * 0.003_130_8f32 - (1.055 * 0.003_130_8f32.powf(1.0 / 2.4) - 0.055)).abs() < 1e-6);
    }

    #[test]
    fn the_threshold_table_gives_the_codes_of_the_curve() {
        let table = &thresholds().t;
        assert!(table.is_sorted());
        let one = 1f32.to_bits();
        let check = |bits: u32| {
            let x = f32::from_bits(bits);
            assert_eq!(to_srgb8(x, 1.0), code_of(x), "x = {x:e} ({bits:#x})");
        };
        // Where the code changes, every float around it (a rounding of `powf` could only
        // matter there) ...
        for t in table {
            let b = t.to_bits();
            (b.saturating_sub(1 << 16)..=(b + (1 << 16)).min(one)).for_each(check);
        }
        // ... and a sample of all the others.
        (0..=one).step_by(997).for_each(check);
        check(one);
        assert_eq!((code_of(table[254]), code_of(f32::from_bits(table[254].to_bits() - 1))), (255, 254));
    }

    #[test]
    fn one_stop_doubles() {
        // 0.25 at +1 EV is 0.5.
        assert_eq!(to_srgb8(0.25, 1f32.exp2()), 188);
        assert_eq!(to_srgb8(1.0, (-1f32).exp2()), 188);
    }

    #[test]
    fn encodes_a_decodable_rgb_image() {
        let mut film = Film::new(3, 2);
        let i = film.index(2, 1);
        film.rgba[i] = [1.0, 0.5, 0.0, 1.0];
        let bytes = encode(&film, 0.0).unwrap();
        let img = image::load_from_memory_with_format(&bytes, image::ImageFormat::Png).unwrap().to_rgb8();
        assert_eq!(img.dimensions(), (3, 2));
        assert_eq!(img.get_pixel(2, 1).0, [255, 188, 0]);
        assert_eq!(img.get_pixel(0, 0).0, [0, 0, 0]);
    }
}
