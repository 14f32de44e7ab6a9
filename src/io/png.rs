//! An 8-bit sRGB PNG preview of the film: the linear radiance scaled by `2^exposure_ev`,
//! clipped to [0, 1], encoded with the sRGB transfer curve (IEC 61966-2-1) and rounded.
//! RGB only: alpha, depth and the other AOVs are in the EXR.

use std::path::Path;

use image::ImageEncoder;
use image::codecs::png::PngEncoder;

use super::atomic::{self, Staged, WriteError, commit_all};
use crate::film::Film;

/// The sRGB transfer curve ("gamma") of a linear value in [0, 1].
pub fn srgb_encode(linear: f32) -> f32 {
    if linear <= 0.003_130_8 { 12.92 * linear } else { 1.055 * linear.powf(1.0 / 2.4) - 0.055 }
}

/// A linear radiance value as an 8-bit sRGB code after multiplying by `scale`; negative and
/// NaN values become 0, values above 1 clip to 255.
#[allow(clippy::manual_clamp)] // `clamp` keeps NaN; `max` maps it to 0
pub fn to_srgb8(linear: f32, scale: f32) -> u8 {
    let x = (linear * scale).max(0.0).min(1.0);
    (srgb_encode(x) * 255.0).round() as u8
}

/// Encodes `film` as an RGB PNG in memory, with the exposure `exposure_ev` in stops.
pub fn encode(film: &Film, exposure_ev: f32) -> Result<Vec<u8>, image::ImageError> {
    let scale = exposure_ev.exp2();
    let pixels: Vec<u8> = film
        .rgba
        .iter()
        .flat_map(|px| [to_srgb8(px[0], scale), to_srgb8(px[1], scale), to_srgb8(px[2], scale)])
        .collect();
    let mut bytes = Vec::new();
    PngEncoder::new(&mut bytes).write_image(&pixels, film.width, film.height, image::ExtendedColorType::Rgb8)?;
    Ok(bytes)
}

/// Writes the preview of `film` to `path`, atomically.
pub fn write(film: &Film, exposure_ev: f32, path: &Path) -> Result<(), WriteError> {
    commit_all(vec![stage(film, exposure_ev, path)?])
}

/// [`write`] up to the temporary file, to be renamed with [`commit_all`] (with the EXR it
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
