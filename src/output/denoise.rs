//! Denoising a rendered frame with Intel Open Image Denoise (OIDN 2.x), as Cycles does: OIDN's
//! `RT` filter on the beauty with the albedo and normal passes as auxiliary images, `hdr = true`
//! (the beauty is linear radiance, unbounded), on the CPU.
//!
//! **The file in, the file out** ([`denoise_exr`]). Any strahl EXR with the passes `combined`,
//! `albedo` and `normal` (Blender's or Nuke's channel names, [`crate::output::exr`]), in
//! particular a frame `strahl merge` joined from a farm's tiles: every channel of the input is
//! kept, the beauty's RGB is replaced by the denoised RGB (alpha unchanged), and Blender's
//! denoising passes are added beside it, so Blender's Denoise node and Nuke's OIDN gizmos take
//! the file as they take Cycles' (layer names as Cycles writes them, under `ViewLayer.` in the
//! `blender` layout, bare in the `nuke` layout):
//!
//! | layer | channels | holds |
//! |---|---|---|
//! | `Combined` (`R G B A` in `nuke`) | `R G B A` | the denoised beauty; A as rendered |
//! | `Noisy Image` | `R G B A` | the beauty as rendered |
//! | `Denoising Albedo` | `R G B` | the albedo OIDN was given: the file's own, else a copy of `DiffCol` |
//! | `Denoising Normal` | `X Y Z` | the normal OIDN was given: the file's own, else a copy of `Normal` (world space) |
//! | `Denoising Depth` | `Z` | the `Depth` pass, when the file has one |
//!
//! Each new channel keeps its source's sample type (half under `--half`); the file keeps its
//! compression and header attributes (in name order, as [`crate::output::exr`] writes them),
//! its blocks in increasing line order. The output is a
//! function of the input's bytes alone, so a merged farm frame denoised gives the same bytes as
//! the whole frame rendered and denoised in one process (`render --denoise` denoises the file
//! it has written, through this function).
//!
//! **The auxiliary images** are the render's denoising features (`Denoising Albedo`,
//! `Denoising Normal`, [`crate::integrator::features`]: Cycles' features, seen through
//! mirrors and glass), or, in a file without them, the first hit's `DiffCol` and `Normal`.
//! Either is free of sampling noise but the pixel footprint's (strahl follows both directions
//! at glass where Cycles samples one), so they are used as clean (`cleanAux = true`).
//! Cycles' "Accurate" mode first denoises the albedo and normal with OIDN's auxiliary-only
//! `RT` filters; the `oidn` crate (2.5.1) always sets its filter's `color` image, so it has no
//! safe call for a filter without one, and strahl keeps `unsafe` out of everything but the
//! Embree wrapper: that prefilter is not run.
//!
//! **Determinism.** OIDN on one CPU gives the same bytes for the same input whatever the number
//! of its worker threads (checked: 1 and 2 cores, `tests/denoise.rs`); OIDN's documentation
//! makes no promise across CPU instruction sets (AVX2 vs AVX-512) or versions, so a farm's
//! frames are denoised once, after the merge, on one machine.
//!
//! **Why a cargo feature** (`denoise`, off by default): the `oidn` crate links
//! `libOpenImageDenoise` when strahl is linked, and Debian 12 has no package of it, so a build
//! that always linked it would not build on a machine without it. `make oidn` unpacks OIDN's
//! official libraries into a cache folder, and the Makefile then builds with the feature, the
//! binaries finding the libraries by their run path (build.rs). Loading the library at run time
//! instead (dlopen) would need `unsafe` calls of our own. Without the feature,
//! [`check_available`] says in one line how to get OIDN.

use std::io::Cursor;
use std::path::Path;

use exr::prelude::{AnyChannel, FlatSamples, LineOrder, ReadChannels, ReadLayers, Text, WritableImage, f16, read};

/// A denoising that failed: the message names the file (or says how to get OIDN).
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct DenoiseError(pub String);

fn fail<T>(path: &Path, problem: impl std::fmt::Display) -> Result<T, DenoiseError> {
    Err(DenoiseError(format!("{}: {problem}", path.display())))
}

/// What to do to get OIDN, for the error of a strahl built without it.
pub const HOW_TO_GET_OIDN: &str = "this strahl was built without Intel Open Image Denoise: run \
    `make oidn` (fetches OIDN 2.5.1's libraries), then `make install` (or build with \
    `--features denoise` and OIDN_DIR set to the folder `make oidn` prints)";

/// Whether OIDN can denoise here: built in, and its CPU device can be created.
pub fn check_available() -> Result<(), DenoiseError> {
    oidn_filter::check()
}

/// The channel names of one layout: the prefix of Blender's layers (`ViewLayer.`, the view
/// layer `--layer-name` gave, or none), and the beauty's own prefix (`ViewLayer.Combined.`, or
/// none for Nuke's `R G B A`).
struct Names {
    layer: String,
    combined: String,
    albedo: String,
    normal: String,
    depth: String,
}

impl Names {
    /// Blender's names under the view layer of the file's `LAYER.Combined.R` channel (the
    /// first such), else Nuke's.
    fn of(list: &[AnyChannel<FlatSamples>]) -> Names {
        let blender = list.iter().find_map(|c| c.name.to_string().strip_suffix("Combined.R").map(str::to_string));
        match blender.filter(|layer| layer.ends_with('.')) {
            Some(layer) => Names {
                combined: format!("{layer}Combined."),
                albedo: format!("{layer}DiffCol."),
                normal: format!("{layer}Normal."),
                depth: format!("{layer}Depth.Z"),
                layer,
            },
            None => Names {
                layer: String::new(),
                combined: String::new(),
                albedo: "albedo.".into(),
                normal: "N.".into(),
                depth: "Z".into(),
            },
        }
    }
}

/// The beauty, albedo and normal of a frame as OIDN takes them: RGB/XYZ triples, row by row.
pub struct Frame {
    pub width: usize,
    pub height: usize,
    pub color: Vec<f32>,
    pub albedo: Vec<f32>,
    pub normal: Vec<f32>,
}

/// Denoises `input` (a strahl EXR) into `output`, written atomically; see the module docs.
/// Refuses an output that is the input, a file without the beauty, albedo and normal passes,
/// and a file already denoised.
pub fn denoise_file(input: &Path, output: &Path) -> Result<(), DenoiseError> {
    if input == output || crate::sys::same_file::same_file(input, output) {
        return fail(output, "is the input too; `strahl denoise` never overwrites its input");
    }
    check_available()?;
    let bytes = read_input(input)?;
    let denoised = denoise_exr(input, &bytes)?;
    crate::sys::atomic::write_atomically(output, &denoised).map_err(|e| DenoiseError(e.to_string()))
}

/// The denoised beauty as the file stores it (half-rounded under `--half`): RGB triples, row
/// by row, for the PNG preview of a denoised render.
pub struct Beauty {
    pub width: u32,
    pub height: u32,
    pub rgb: Vec<f32>,
}

/// Replaces the EXR at `path` (which the caller has just written) by its denoised form,
/// atomically; returns the denoised beauty as written.
pub fn denoise_in_place(path: &Path) -> Result<Beauty, DenoiseError> {
    let bytes = read_input(path)?;
    let (denoised, beauty) = denoise_exr_and_beauty(path, &bytes)?;
    crate::sys::atomic::write_atomically(path, &denoised).map_err(|e| DenoiseError(e.to_string()))?;
    Ok(beauty)
}

fn read_input(path: &Path) -> Result<Vec<u8>, DenoiseError> {
    let limit = crate::sys::read::remaining_memory();
    crate::sys::read::open_regular(path, limit, "")
        .and_then(|(mut file, length)| {
            let mut data = Vec::with_capacity(length as usize);
            std::io::Read::read_to_end(&mut file, &mut data).map_err(crate::sys::read::ReadError::Io)?;
            Ok(data)
        })
        .or_else(|e| fail(path, e))
}

/// The denoised EXR of the EXR `bytes` (read from `path`, which errors name).
pub fn denoise_exr(path: &Path, bytes: &[u8]) -> Result<Vec<u8>, DenoiseError> {
    denoise_exr_and_beauty(path, bytes).map(|(exr, _)| exr)
}

/// [`denoise_exr`], and the denoised beauty as the file holds it.
fn denoise_exr_and_beauty(path: &Path, bytes: &[u8]) -> Result<(Vec<u8>, Beauty), DenoiseError> {
    // What decoding will hold, from the header, before anything is decoded: the samples as read
    // (at most 4 bytes each), the output's copies and OIDN's three images in and one out.
    let meta = exr::meta::MetaData::read_from_buffered(Cursor::new(bytes), false).or_else(|e| fail(path, e))?;
    let [header] = meta.headers.as_slice() else {
        return fail(path, format!("has {} parts; strahl writes one", meta.headers.len()));
    };
    let pixels = header.layer_size.area() as u64;
    let channels = header.channels.list.len() as u64 + 4 + 3 + 3 + 1;
    let need = pixels.saturating_mul(4).saturating_mul(2 * channels + 12);
    crate::sys::read::check_memory(need, "denoising the frame").or_else(|e| fail(path, e))?;

    let mut image = read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .all_layers()
        .all_attributes()
        .from_buffered(Cursor::new(bytes))
        .or_else(|e| fail(path, e))?;
    let layer = &mut image.layer_data[0];
    let list = &mut layer.channel_data.list;
    let names = Names::of(list);
    let layer_prefix = names.layer.as_str();
    if find(list, &format!("{layer_prefix}Noisy Image.R")).is_some() {
        return fail(path, "is denoised already (it has a `Noisy Image` layer)");
    }
    let need = |pass: &str, prefix: &str, components: &str| -> Result<Vec<usize>, DenoiseError> {
        components
            .chars()
            .map(|c| {
                find(list, &format!("{prefix}{c}")).ok_or_else(|| {
                    DenoiseError(format!(
                        "{}: has no {pass} pass ({prefix}{}); render with --passes combined,albedo,normal \
                         (or --denoise)",
                        path.display(),
                        components.chars().map(String::from).collect::<Vec<_>>().join("/")
                    ))
                })
            })
            .collect()
    };
    let combined = need("combined", &names.combined, "RGB")?;
    // The render's denoising features when it wrote them, else the first hit's DiffCol and Normal.
    let features = |name: &str, components: &str| -> Option<Vec<usize>> {
        components.chars().map(|c| find(list, &format!("{layer_prefix}{name}.{c}"))).collect()
    };
    let (albedo, albedo_written) = match features("Denoising Albedo", "RGB") {
        Some(a) => (a, true),
        None => (need("albedo", &names.albedo, "RGB")?, false),
    };
    let (normal, normal_written) = match features("Denoising Normal", "XYZ") {
        Some(n) => (n, true),
        None => (need("normal", &names.normal, "XYZ")?, false),
    };
    let alpha = find(list, &format!("{}A", names.combined));
    let depth = find(list, &names.depth);

    let frame = Frame {
        width: layer.size.width(),
        height: layer.size.height(),
        color: interleave(list, &combined),
        albedo: interleave(list, &albedo),
        normal: interleave(list, &normal),
    };
    let denoised = denoise_frame(&frame).or_else(|e| fail(path, e))?;

    let mut added = Vec::new();
    let copy = |source: usize, name: String| AnyChannel { name: Text::from(name.as_str()), ..list[source].clone() };
    for (i, c) in ["R", "G", "B"].iter().enumerate() {
        added.push(copy(combined[i], format!("{layer_prefix}Noisy Image.{c}")));
        if !albedo_written {
            added.push(copy(albedo[i], format!("{layer_prefix}Denoising Albedo.{c}")));
        }
    }
    if let Some(a) = alpha {
        added.push(copy(a, format!("{layer_prefix}Noisy Image.A")));
    }
    for (i, c) in ["X", "Y", "Z"].iter().enumerate() {
        if !normal_written {
            added.push(copy(normal[i], format!("{layer_prefix}Denoising Normal.{c}")));
        }
    }
    if let Some(d) = depth {
        added.push(copy(d, format!("{layer_prefix}Denoising Depth.Z")));
    }
    for (i, &channel) in combined.iter().enumerate() {
        let values = denoised.iter().skip(i).step_by(3).copied();
        list[channel].sample_data = match &list[channel].sample_data {
            FlatSamples::F16(_) => FlatSamples::F16(values.map(f16::from_f32).collect()),
            _ => FlatSamples::F32(values.collect()),
        };
    }
    let beauty = Beauty { width: frame.width as u32, height: frame.height as u32, rgb: interleave(list, &combined) };
    list.extend(added);
    list.sort_by(|a, b| a.name.cmp(&b.name));
    // Chunks in increasing line order: the same bytes whatever order the compressing threads
    // finish in.
    layer.encoding.line_order = LineOrder::Increasing;
    let mut out = Cursor::new(Vec::new());
    image.write().to_buffered(&mut out).or_else(|e| fail(path, format!("cannot encode the denoised frame: {e}")))?;
    // The `exr` crate writes the header's other attributes in a `HashMap`'s order.
    let mut bytes = out.into_inner();
    crate::output::exr::sort_header_attributes(&mut bytes);
    Ok((bytes, beauty))
}

fn find(list: &[AnyChannel<FlatSamples>], name: &str) -> Option<usize> {
    list.iter().position(|c| c.name.eq(name))
}

/// The three channels `index` of `list` as interleaved triples.
fn interleave(list: &[AnyChannel<FlatSamples>], index: &[usize]) -> Vec<f32> {
    let planes: Vec<Vec<f32>> = index.iter().map(|&i| list[i].sample_data.values_as_f32().collect()).collect();
    (0..planes[0].len()).flat_map(|p| planes.iter().map(move |plane| plane[p])).collect()
}

/// The denoised beauty of `frame` (RGB triples).
pub fn denoise_frame(frame: &Frame) -> Result<Vec<f32>, String> {
    let n = frame.width * frame.height * 3;
    if frame.color.len() != n || frame.albedo.len() != n || frame.normal.len() != n {
        return Err(format!("the frame's images are not {} × {} RGB", frame.width, frame.height));
    }
    if let Some(bad) = frame.color.iter().chain(&frame.albedo).chain(&frame.normal).find(|v| !v.is_finite()) {
        return Err(format!("the beauty, albedo or normal holds {bad}, which OIDN cannot denoise"));
    }
    oidn_filter::run(frame)
}

#[cfg(feature = "denoise")]
mod oidn_filter {
    use super::{DenoiseError, Frame};

    pub fn check() -> Result<(), DenoiseError> {
        oidn::Device::cpu().map(drop).map_err(|e| {
            DenoiseError(format!("Intel Open Image Denoise has no CPU device here ({e}); run `make oidn`"))
        })
    }

    pub fn run(frame: &Frame) -> Result<Vec<f32>, String> {
        let device = oidn::Device::cpu().map_err(|e| format!("OIDN: {e}"))?;
        let mut filter = oidn::RayTracing::try_new(&device).map_err(|e| format!("OIDN: {e}"))?;
        filter
            .hdr(true)
            .srgb(false)
            .clean_aux(true)
            .image_dimensions(frame.width, frame.height)
            .albedo_normal(&frame.albedo, &frame.normal);
        let mut output = vec![0.0; frame.color.len()];
        filter.filter(&frame.color, &mut output).map_err(|e| format!("OIDN: {e}"))?;
        Ok(output)
    }
}

#[cfg(not(feature = "denoise"))]
mod oidn_filter {
    use super::{DenoiseError, Frame, HOW_TO_GET_OIDN};

    pub fn check() -> Result<(), DenoiseError> {
        Err(DenoiseError(HOW_TO_GET_OIDN.to_string()))
    }

    pub fn run(_: &Frame) -> Result<Vec<f32>, String> {
        Err(HOW_TO_GET_OIDN.to_string())
    }
}
