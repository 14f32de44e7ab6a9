//! Reading an environment map: OpenEXR (the `exr` crate, as strahl reads EXR elsewhere; the
//! first layer with `R`, `G` and `B` channels, at its largest resolution level) or Radiance
//! `.hdr` (RGBE, the `image` crate's `hdr` decoder), chosen by the file's first bytes.
//!
//! The file is read through [`crate::sys::read::read_regular`] (so `--confine` applies, and
//! the size limit of mesh and texture files, [`crate::sys::read::max_mesh_bytes`]); the
//! header is read before anything is allocated, and a map is refused when its texels (12
//! bytes each, linear f32 RGB, as a texture's) do not fit in the memory budget, when it has
//! more than [`MAX_ENVIRONMENT_TEXELS`], or when an EXR's declared pixels need more bytes
//! than its file holds at the best compression ratio OpenEXR's codecs reach (1376:1,
//! PXR24's; deflate's 1032:1 for ZIP). The texels are counted against the budget while the
//! map lives. Texels must be finite; negative ones (left by some HDR processing) count as 0.
//! Every error is one line naming the file.

use std::io::Cursor;
use std::path::Path;

use crate::math::Vec3;
use crate::sys::read::{MESH_LIMIT_HINT, check_memory, max_mesh_bytes, read_regular};
use crate::texture::{Image, TEXEL_BYTES};

/// Most texels a map may have (2³⁰, e.g. 46,000 × 23,000; 12 GiB of texels).
pub const MAX_ENVIRONMENT_TEXELS: u64 = 1 << 30;

/// The best ratio of raw pixel bytes to stored bytes of any compression an EXR may use.
const EXR_MAX_RATIO: u64 = 1376;

/// The environment a command-line argument names: `R,G,B` (three numbers, a constant
/// radiance, finite and ≥ 0) or the path of a map; errors are one line.
pub fn environment_argument(arg: &str) -> Result<crate::light::environment::Environment, String> {
    use crate::light::environment::Environment;
    let numbers: Vec<Option<f32>> = arg.split(',').map(|x| x.trim().parse::<f32>().ok()).collect();
    if let [Some(r), Some(g), Some(b)] = numbers[..] {
        let env = Environment::constant(Vec3::new(r, g, b));
        return match env.problem() {
            Some(problem) => Err(format!("--environment {arg}: {problem}")),
            None => Ok(env),
        };
    }
    Ok(Environment::map(read_environment_map(Path::new(arg))?))
}

/// Reads the map at `path` (see the module docs); errors are one line naming `path`.
pub fn read_environment_map(path: &Path) -> Result<Image, String> {
    let name = path.display().to_string();
    let cannot = |e: &dyn std::fmt::Display| format!("{name}: cannot read the environment map: {e}");
    let limit = max_mesh_bytes().map_err(|e| cannot(&e))?;
    let bytes = read_regular(path, limit, MESH_LIMIT_HINT).map_err(|e| cannot(&e))?;
    decode_environment_map(&bytes, &name)
}

/// Decodes an EXR or Radiance HDR file's `bytes`; `name` names it in errors.
pub fn decode_environment_map(bytes: &[u8], name: &str) -> Result<Image, String> {
    let fail = |e: &dyn std::fmt::Display| format!("{name}: cannot read the environment map: {e}");
    let texels = if bytes.starts_with(&[0x76, 0x2f, 0x31, 0x01]) {
        decode_exr(bytes, name).map_err(|e| fail(&e))?
    } else if bytes.starts_with(b"#?") {
        decode_hdr(bytes, name).map_err(|e| fail(&e))?
    } else {
        return Err(format!("{name}: is not an OpenEXR or Radiance HDR image (an environment map must be one)"));
    };
    let (width, height, mut texels) = texels;
    for (k, t) in texels.iter_mut().enumerate() {
        if !t.is_finite() {
            return Err(format!("{name}: texel ({}, {}) is {t}, not finite", k % width, k / width));
        }
        *t = t.max(Vec3::ZERO);
    }
    Image::from_texels(name, width, height, texels)
}

/// Refuses a map of `width × height` texels over the limits (module docs).
fn check_size(width: u64, height: u64, name: &str) -> Result<(), String> {
    if width == 0 || height == 0 {
        return Err("the image has no pixels".into());
    }
    let texels = width.saturating_mul(height);
    if texels > MAX_ENVIRONMENT_TEXELS {
        return Err(format!("{width} × {height} texels exceed {MAX_ENVIRONMENT_TEXELS}"));
    }
    check_memory(texels * TEXEL_BYTES, format!("{name}: {width} × {height} texels")).map_err(|e| e.to_string())
}

type Texels = (usize, usize, Vec<Vec3>);

fn decode_exr(bytes: &[u8], name: &str) -> Result<Texels, String> {
    use exr::prelude::ReadChannels as _;
    use exr::prelude::ReadLayers as _;
    let meta = exr::meta::MetaData::read_from_buffered(Cursor::new(bytes), false).map_err(|e| e.to_string())?;
    for header in meta.headers.iter() {
        let size = header.layer_size;
        let (w, h) = (size.width() as u64, size.height() as u64);
        check_size(w, h, name)?;
        let raw = w * h * header.channels.bytes_per_pixel as u64;
        if raw / EXR_MAX_RATIO > bytes.len() as u64 {
            return Err(format!(
                "declares {w} × {h} pixels, which need at least {} bytes; the file has {} (truncated or forged)",
                raw / EXR_MAX_RATIO,
                bytes.len()
            ));
        }
    }
    let image = exr::prelude::read()
        .no_deep_data()
        .largest_resolution_level()
        .rgb_channels(
            |size, _| (size.width(), vec![Vec3::ZERO; size.width() * size.height()]),
            |(w, texels): &mut (usize, Vec<Vec3>), at, (r, g, b): (f32, f32, f32)| {
                texels[at.y() * *w + at.x()] = Vec3::new(r, g, b);
            },
        )
        .first_valid_layer()
        .all_attributes()
        .from_buffered(Cursor::new(bytes))
        .map_err(|e| e.to_string())?;
    let size = image.layer_data.size;
    let (_, texels) = image.layer_data.channel_data.pixels;
    Ok((size.width(), size.height(), texels))
}

fn decode_hdr(bytes: &[u8], name: &str) -> Result<Texels, String> {
    use image::ImageDecoder as _;
    let mut decoder = image::codecs::hdr::HdrDecoder::new(Cursor::new(bytes)).map_err(|e| e.to_string())?;
    let (w, h) = decoder.dimensions();
    check_size(w as u64, h as u64, name)?;
    if decoder.color_type() != image::ColorType::Rgb32F {
        return Err(format!("{:?} pixels are not read", decoder.color_type()));
    }
    let mut limits = image::Limits::no_limits();
    limits.max_image_width = Some(w);
    limits.max_image_height = Some(h);
    decoder.set_limits(limits).map_err(|e| e.to_string())?;
    let mut texels = vec![Vec3::ZERO; w as usize * h as usize];
    decoder.read_image(bytemuck::cast_slice_mut(&mut texels)).map_err(|e| e.to_string())?;
    Ok((w as usize, h as usize, texels))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bad_bytes_are_one_line_naming_the_file() {
        for bytes in
            [&b"not a map"[..], &[0x76, 0x2f, 0x31, 0x01, 2, 0, 0][..], b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n"]
        {
            let e = decode_environment_map(bytes, "sky.exr").unwrap_err();
            assert!(e.starts_with("sky.exr: ") && !e.contains('\n'), "{e}");
        }
    }

    #[test]
    fn hdr_round_trip() {
        // A 4 × 2 map written by the `image` crate's encoder reads back (RGBE: 8-bit mantissas).
        let pixels: Vec<image::Rgb<f32>> =
            (0..8).map(|k| image::Rgb([k as f32 + 0.5, 2.0 * k as f32 + 1.0, 0.25])).collect();
        let mut bytes = Vec::new();
        image::codecs::hdr::HdrEncoder::new(&mut bytes).encode(&pixels, 4, 2).unwrap();
        let img = decode_environment_map(&bytes, "t.hdr").unwrap();
        assert_eq!((img.width, img.height), (4, 2));
        for (t, p) in img.texels.iter().zip(&pixels) {
            let want = Vec3::new(p.0[0], p.0[1], p.0[2]);
            assert!((*t - want).abs().max_element() <= 0.02 * want.max_element(), "{t} vs {want}");
        }
    }
}
