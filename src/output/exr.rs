//! The rendered film as OpenEXR: one part (a single header, as Blender and Cycles write),
//! scan lines in increasing order, every pass of the film as named channels.
//!
//! **Channel names** ([`Layout`]). The default, `blender`, is Blender's multilayer naming, so
//! Blender's Image node lists the passes by name (view layer `ViewLayer`):
//!
//! | pass | `blender` | `nuke` |
//! |---|---|---|
//! | combined | `ViewLayer.Combined.R/G/B/A` | `R`, `G`, `B`, `A` (Nuke's `rgba`) |
//! | depth | `ViewLayer.Depth.Z` | `Z` (Nuke's `depth.Z`) |
//! | normal | `ViewLayer.Normal.X/Y/Z` | `N.X/Y/Z` |
//! | albedo | `ViewLayer.DiffCol.R/G/B` | `albedo.R/G/B` |
//! | emission, background | `ViewLayer.Emit`, `ViewLayer.Env` `.R/G/B` | `emission`, `background` `.R/G/B` |
//! | diffuse_direct, diffuse_indirect | `ViewLayer.DiffDir`, `.DiffInd` `.R/G/B` | `diffuse_direct`, `diffuse_indirect` `.R/G/B` |
//! | glossy_direct, glossy_indirect, glossy_color | `ViewLayer.GlossDir`, `.GlossInd`, `.GlossCol` `.R/G/B` | `glossy_direct`, `glossy_indirect`, `glossy_color` `.R/G/B` |
//! | transmission_direct, _indirect, _color | `ViewLayer.TransDir`, `.TransInd`, `.TransCol` `.R/G/B` | `transmission_direct`, `transmission_indirect`, `transmission_color` `.R/G/B` |
//! | position | `ViewLayer.Position.X/Y/Z` | `P.X/Y/Z` |
//! | distance | `ViewLayer.Distance.Z` | `distance.Z` |
//! | object_index, material_index | `ViewLayer.IndexOB.X`, `ViewLayer.IndexMA.X` | `object_index.X`, `material_index.X` |
//! | crypto_object | `ViewLayer.CryptoObject00.r/g/b/a`, `01`, … | `CryptoObject00.R/G/B/A`, … |
//! | crypto_material | `ViewLayer.CryptoMaterial00.r/g/b/a`, … | `CryptoMaterial00.R/G/B/A`, … |
//! | disagreement | `ViewLayer.Disagreement.X` | `disagreement.X` |
//! | sample_count, variance | `ViewLayer.Debug Sample Count.X`, `ViewLayer.Variance.R/G/B` | `sample_count.X`, `variance.R/G/B` |
//!
//! The Cryptomatte passes are named `ViewLayer.CryptoObject` / `CryptoObject` (and material)
//! in their `cryptomatte/<key>/name` attributes ([`crate::output::cryptomatte`]).
//!
//! **Sample types.** float32; with `half`, the colour passes (combined, albedo, the light
//! passes) and the normals are half floats, while depth, distance, position, the indices and
//! Cryptomatte stay float32: Cryptomatte ids are float bit patterns and must not be rounded,
//! and depth and position are absolute coordinates (half keeps 11 bits, a 2 mm step at 4 m).
//! Normals are unit vectors, which half stores to 5·10⁻⁴, well below what relighting or a
//! normal-based matte can see; kept float32 they would hold half the file (measured on the
//! 4K Whitted frame, ZIP: normals float 16 MB of 38 MB; all of it 91.1 MB as float32, 27.8 MB
//! with `--half`, 3.3× smaller).
//!
//! **Compression** ([`Compression`]): ZIP over 16 lines by default, deflated by strahl
//! itself at zlib level 1 on `threads` threads (`exr_zip`; the `exr` crate's level-4
//! miniz_oxide took 7.2 s for the 4K Whitted frame on 2 threads, 82.2 MB; level 1, also
//! miniz_oxide (`flate2`'s default backend), 3.1 s, 91.1 MB. `flate2`'s zlib-rs backend measured
//! no faster: 1920 × 1080 Whitted, 1 thread, output 0.43–0.62 s against 0.42–0.47 s, 25.2 MB
//! against 24.6 MB); `none`, `rle`, `zips` (ZIP
//! over single lines), `piz`, `pxr24` (lossy: float32 rounded to 24 bits; a file with
//! Cryptomatte or index passes is written with ZIP instead, with a warning,
//! [`Compression::for_output`]), `b44`, `b44a` (lossy, half channels only; float32 channels
//! stored uncompressed, with a warning): what the `exr` crate writes (it cannot write
//! DWAA/DWAB).
//!
//! `Z` (and `distance`) is `+inf` (not 0, nor Blender's 10¹⁰) for rays that escape: it sorts
//! behind every surface in depth compositing, and it cannot be mistaken for a real distance.
//!
//! **Text.** OpenEXR stores a `string` attribute as a length and bytes, with no encoding of
//! its own (OpenEXRFileLayout: "a sequence of chars"); the `exr` crate's `Text` constructors
//! take Latin-1 only. strahl writes every string as its UTF-8 bytes ([`text`]): what the
//! Cryptomatte specification asks of the names in its manifests (hashed as UTF-8 bytes), what
//! Blender writes, and what OpenEXR's Python binding decodes a string attribute as. So any scene
//! path or object name can be written; [`check_encodable`] proves it for a render's header
//! before the render starts, so that no text can make a finished render unwritable.
//! Attribute and channel names are strahl's own (1 to 255 bytes, no NUL, as OpenEXR requires).
//!
//! **Regions.** A film of a [`crate::output::region::Region`] of the image is written with that region
//! as the `dataWindow` inside the whole image's `displayWindow`, so compositors place it;
//! `strahl merge` joins such files through the same writer ([`encode_blocks`]).
//!
//! **Streaming.** Blocks of 16 (or 1) lines are cut straight from the film's channels
//! ([`Film::channels`]), compressed on `threads` threads and written in increasing line order:
//! no per-channel copy of the frame is made, and the bytes are the same for any number of
//! threads. A render compresses its ZIP blocks while the tiles render
//! ([`super::exr_stream`]); this writer then takes them as they are, with the same bytes.

use std::io::{Cursor, Read, Seek, SeekFrom, Write};
use std::path::Path;

use exr::block::chunk::{Chunk, CompressedBlock, CompressedScanLineBlock};
use exr::block::writer::{ChunksWriter, ParallelBlocksCompressor, SequentialBlocksCompressor};
use exr::block::{BlockIndex, UncompressedBlock};
use exr::meta::attribute::{AttributeValue, ChannelDescription, IntegerBounds, SampleType, Text};
use exr::meta::header::Header;
use exr::prelude::{LineOrder, Vec2, f16};

use crate::output::film::{ChannelView, Film};
use crate::output::passes::{OutputSpec, Pass};
use crate::sys::atomic::{Staged, WriteError, commit_all, stage_with};

/// How channels are named (see the module docs).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Layout {
    /// Blender's multilayer names under the view layer `ViewLayer`.
    #[default]
    Blender,
    /// Nuke's conventions: bare `R G B A Z`, then `layer.channel`.
    Nuke,
}

/// The compressions strahl writes (the `exr` crate's encoders).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Compression {
    None,
    Rle,
    /// ZIP over single scan lines.
    Zips,
    /// ZIP over blocks of 16 scan lines.
    #[default]
    Zip,
    Piz,
    Pxr24,
    B44,
    B44a,
}

impl Compression {
    /// Every compression with its command-line name.
    pub const ALL: [(Compression, &'static str); 8] = [
        (Compression::None, "none"),
        (Compression::Rle, "rle"),
        (Compression::Zips, "zips"),
        (Compression::Zip, "zip"),
        (Compression::Piz, "piz"),
        (Compression::Pxr24, "pxr24"),
        (Compression::B44, "b44"),
        (Compression::B44a, "b44a"),
    ];

    /// The command-line name.
    pub fn name(self) -> &'static str {
        Compression::ALL.iter().find(|(c, _)| *c == self).map_or("zip", |(_, n)| n)
    }

    /// The compression called `name` ([`Compression::name`]).
    pub fn from_name(name: &str) -> Option<Compression> {
        Compression::ALL.iter().find(|(_, n)| *n == name).map(|(c, _)| *c)
    }

    /// The compression a file of `output`'s passes is written with when `self` is asked for,
    /// and the warning to print when that differs or hides something. EXR compresses a whole
    /// part alike, and `pxr24` rounds float32 to 24 bits: Cryptomatte ids are float bit
    /// patterns (and object or material indices above 2¹⁵ would round), so a file with them is
    /// written with ZIP instead (lossless, what Blender's mattes need). `b44`/`b44a` compress
    /// only half channels: the float32 ones (depth, distance, position, indices, Cryptomatte, every
    /// channel without `--half`) are stored uncompressed, which the warning says.
    pub fn for_output(self, output: &OutputSpec, half: bool) -> (Compression, Option<String>) {
        let exact =
            output.passes.iter().find(|p| p.is_crypto() || matches!(p, Pass::ObjectIndex | Pass::MaterialIndex));
        match (self, exact) {
            (Compression::Pxr24, Some(pass)) => (
                Compression::Zip,
                Some(format!(
                    "warning: --compression pxr24 rounds float32 channels to 24 bits, which would destroy the {pass} pass's ids: writing ZIP (lossless) instead"
                )),
            ),
            (Compression::B44 | Compression::B44a, _) => {
                let float: Vec<&str> = output
                    .passes
                    .iter()
                    .filter(|&p| !(half && (p.is_colour() || matches!(p, Pass::Normal | Pass::DenoisingNormal))))
                    .map(Pass::name)
                    .collect();
                let note = (!float.is_empty()).then(|| {
                    format!(
                        "warning: --compression {} compresses half channels only; the float32 channels of {} are                          stored uncompressed",
                        self.name(),
                        float.join(", ")
                    )
                });
                (self, note)
            }
            _ => (self, None),
        }
    }

    fn to_exr(self) -> exr::compression::Compression {
        use exr::compression::Compression as C;
        match self {
            Compression::None => C::Uncompressed,
            Compression::Rle => C::RLE,
            Compression::Zips => C::ZIP1,
            Compression::Zip => C::ZIP16,
            Compression::Piz => C::PIZ,
            Compression::Pxr24 => C::PXR24,
            Compression::B44 => C::B44,
            Compression::B44a => C::B44A,
        }
    }
}

/// A header attribute strahl writes beyond the channels ([`crate::output::metadata`] makes them).
#[derive(Clone, Debug, PartialEq)]
pub enum Attribute {
    Text(String),
    Int(i32),
    Float(f32),
    /// A 4×4 matrix, 16 floats in the order the file stores them.
    Matrix([f32; 16]),
}

/// How to write the EXR: names, sample types, compression, header attributes.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ExrOptions {
    pub layout: Layout,
    /// The view layer of the `blender` layout (checked by [`super::layer_name`]); `None`:
    /// [`VIEW_LAYER`].
    pub view_layer: Option<String>,
    /// Colour passes as half floats.
    pub half: bool,
    pub compression: Compression,
    /// Extra header attributes, `(name, value)`, in addition to the Cryptomatte ones.
    pub attributes: Vec<(String, Attribute)>,
    /// Object and material names for the Cryptomatte manifests (object index order, then the
    /// scene's material order). Needed only when the film holds Cryptomatte passes.
    pub object_names: Vec<String>,
    pub material_names: Vec<String>,
}

/// The view layer of the `blender` layout.
pub const VIEW_LAYER: &str = "ViewLayer";

impl ExrOptions {
    /// The `blender` layout's view layer name.
    pub fn layer(&self) -> &str {
        self.view_layer.as_deref().unwrap_or(VIEW_LAYER)
    }
}

/// The name of component `component` of `pass` in `layout` (see the module docs).
pub fn channel_name(layout: Layout, pass: Pass, component: usize) -> String {
    layer_channel_name(layout, VIEW_LAYER, pass, component)
}

/// [`channel_name`] with the `blender` layout's view layer named `layer`.
pub fn layer_channel_name(layout: Layout, layer: &str, pass: Pass, component: usize) -> String {
    const RGBA: [&str; 4] = ["R", "G", "B", "A"];
    const XYZ: [&str; 3] = ["X", "Y", "Z"];
    let (blender, nuke, names): (&str, &str, &[&str]) = match pass {
        Pass::Combined => ("Combined", "", &RGBA),
        Pass::Depth => ("Depth", "", &["Z"]),
        Pass::Normal => ("Normal", "N", &XYZ),
        Pass::Albedo => ("DiffCol", "albedo", &RGBA),
        Pass::Emission => ("Emit", "emission", &RGBA),
        Pass::DiffuseDirect => ("DiffDir", "diffuse_direct", &RGBA),
        Pass::DiffuseIndirect => ("DiffInd", "diffuse_indirect", &RGBA),
        Pass::GlossyDirect => ("GlossDir", "glossy_direct", &RGBA),
        Pass::GlossyIndirect => ("GlossInd", "glossy_indirect", &RGBA),
        Pass::GlossyColor => ("GlossCol", "glossy_color", &RGBA),
        Pass::TransmissionDirect => ("TransDir", "transmission_direct", &RGBA),
        Pass::TransmissionIndirect => ("TransInd", "transmission_indirect", &RGBA),
        Pass::TransmissionColor => ("TransCol", "transmission_color", &RGBA),
        Pass::Background => ("Env", "background", &RGBA),
        Pass::Position => ("Position", "P", &XYZ),
        Pass::Distance => ("Distance", "distance", &["Z"]),
        Pass::ObjectIndex => ("IndexOB", "object_index", &["X"]),
        Pass::MaterialIndex => ("IndexMA", "material_index", &["X"]),
        Pass::Disagreement => ("Disagreement", "disagreement", &["X"]),
        Pass::SampleCount => ("Debug Sample Count", "sample_count", &["X"]),
        Pass::Variance => ("Variance", "variance", &RGBA),
        Pass::DenoisingAlbedo => ("Denoising Albedo", "Denoising Albedo", &RGBA),
        Pass::DenoisingNormal => ("Denoising Normal", "Denoising Normal", &XYZ),
        Pass::CryptoObject | Pass::CryptoMaterial => {
            let (view_layer, crypto) = (layer, format!("{}{:02}", crypto_type(pass), component / 4));
            return match layout {
                Layout::Blender => format!("{view_layer}.{crypto}.{}", ["r", "g", "b", "a"][component % 4]),
                Layout::Nuke => format!("{crypto}.{}", RGBA[component % 4]),
            };
        }
    };
    let channel = names[component];
    match layout {
        Layout::Blender => format!("{layer}.{blender}.{channel}"),
        Layout::Nuke if nuke.is_empty() => channel.to_string(),
        Layout::Nuke => format!("{nuke}.{channel}"),
    }
}

/// `CryptoObject` or `CryptoMaterial`.
fn crypto_type(pass: Pass) -> &'static str {
    if pass == Pass::CryptoMaterial { "CryptoMaterial" } else { "CryptoObject" }
}

/// The Cryptomatte pass name of `pass` in `layout` (`ViewLayer.CryptoObject`, `CryptoObject`).
pub fn crypto_name(layout: Layout, pass: Pass) -> String {
    layer_crypto_name(layout, VIEW_LAYER, pass)
}

/// [`crypto_name`] with the `blender` layout's view layer named `layer`.
pub fn layer_crypto_name(layout: Layout, layer: &str, pass: Pass) -> String {
    match layout {
        Layout::Blender => format!("{layer}.{}", crypto_type(pass)),
        Layout::Nuke => crypto_type(pass).to_string(),
    }
}

/// A channel of the file: its name, sample type and where its values come from.
pub(crate) struct Channel<'a> {
    name: String,
    half: bool,
    view: ChannelView<'a>,
}

/// The film's channels as the file lists them: named, typed, sorted by name (EXR's order).
pub(crate) fn file_channels<'a>(film: &'a Film, options: &ExrOptions) -> Vec<Channel<'a>> {
    let mut channels: Vec<Channel> = film
        .channels()
        .into_iter()
        .map(|view| Channel {
            name: layer_channel_name(options.layout, options.layer(), view.pass, view.component),
            half: options.half && (view.pass.is_colour() || matches!(view.pass, Pass::Normal | Pass::DenoisingNormal)),
            view,
        })
        .collect();
    channels.sort_by(|a, b| a.name.as_bytes().cmp(b.name.as_bytes()));
    channels
}

/// A string attribute's value: its UTF-8 bytes (see the module docs); any string is one.
pub fn text(value: &str) -> Text {
    Text::from_slice_unchecked(value.as_bytes())
}

/// An attribute or channel name: its UTF-8 bytes, which OpenEXR ends with a NUL byte and
/// limits to 255 bytes.
fn name(value: &str, what: &str) -> exr::error::Result<Text> {
    if value.is_empty() || value.len() > 255 || value.contains('\0') {
        let problem = format!("{what} '{}' is not 1 to 255 bytes without NUL", value.escape_debug());
        return Err(exr::error::Error::Invalid(problem.into()));
    }
    Ok(text(value))
}

/// The file's header.
fn header(film: &Film, channels: &[Channel], options: &ExrOptions) -> exr::error::Result<Header> {
    let descriptions = channels
        .iter()
        .map(|c| {
            let sample_type = if c.half { SampleType::F16 } else { SampleType::F32 };
            Ok(ChannelDescription::new(name(&c.name, "a channel name")?, sample_type, false))
        })
        .collect::<exr::error::Result<_>>()?;
    // The data window is the film's region, inside the whole image's display window.
    let size = Vec2(film.width as usize, film.height as usize);
    let mut header = Header::new(text(""), size, descriptions).with_encoding(
        options.compression.to_exr(),
        exr::meta::BlockDescription::ScanLines,
        LineOrder::Increasing,
    );
    header.own_attributes.layer_name = None;
    header.own_attributes.layer_position = Vec2(film.origin_x as i32, film.origin_y as i32);
    let display = Vec2(film.display_width as usize, film.display_height as usize);
    header.shared_attributes.display_window = IntegerBounds::new((0, 0), display);
    let own = &mut header.own_attributes;
    for (key, value) in &options.attributes {
        // The standard attributes the `exr` crate keeps in fields of its own.
        match (key.as_str(), value) {
            ("software", Attribute::Text(s)) => own.software_name = Some(text(s)),
            ("capDate", Attribute::Text(s)) => own.capture_date = Some(text(s)),
            ("utcOffset", Attribute::Float(f)) => own.utc_offset = Some(*f),
            ("worldToCamera", Attribute::Matrix(m)) => own.world_to_camera = Some(*m),
            ("worldToNDC", Attribute::Matrix(m)) => own.world_to_normalized_device = Some(*m),
            _ => {}
        }
        if matches!(key.as_str(), "software" | "capDate" | "utcOffset" | "worldToCamera" | "worldToNDC") {
            continue;
        }
        let value = match value {
            Attribute::Text(s) => AttributeValue::Text(text(s)),
            Attribute::Int(i) => AttributeValue::I32(*i),
            Attribute::Float(f) => AttributeValue::F32(*f),
            Attribute::Matrix(m) => AttributeValue::Matrix4x4(*m),
        };
        own.other.insert(name(key, "an attribute name")?, value);
    }
    for pass in film.passes().into_iter().filter(|p| p.is_crypto()) {
        let names = if pass == Pass::CryptoObject { &options.object_names } else { &options.material_names };
        for (key, value) in
            crate::output::cryptomatte::attributes(&layer_crypto_name(options.layout, options.layer(), pass), names)
        {
            own.other.insert(name(&key, "an attribute name")?, AttributeValue::Text(text(&value)));
        }
    }
    Ok(header)
}

/// The uncompressed bytes of the block `index` (its position relative to the data window, as
/// the film's pixels are): line after line, in each line every channel's
/// samples (in the file's channel order), little-endian.
pub(crate) fn block_bytes(film: &Film, channels: &[Channel], index: BlockIndex) -> Vec<u8> {
    let (x0, w) = (index.pixel_position.0, index.pixel_size.0);
    let bytes_per_pixel: usize = channels.iter().map(|c| if c.half { 2 } else { 4 }).sum();
    let mut out = Vec::with_capacity(bytes_per_pixel * w * index.pixel_size.1);
    for y in index.pixel_position.1..index.pixel_position.1 + index.pixel_size.1 {
        let row = y * film.width as usize;
        for c in channels {
            let pixels = row + x0..row + x0 + w;
            if c.half {
                out.extend(pixels.flat_map(|i| f16::from_f32(c.view.get(i)).to_le_bytes()));
            } else {
                out.extend(pixels.flat_map(|i| c.view.get(i).to_le_bytes()));
            }
        }
    }
    out
}

/// Encodes `film` into `out`, compressing on `threads` threads. The header's attributes are
/// in the `exr` crate's order; [`encode`] sorts them.
pub fn encode_to<W: Write + Seek>(
    film: &Film,
    options: &ExrOptions,
    threads: usize,
    out: W,
) -> std::result::Result<(), exr::error::Error> {
    let channels = file_channels(film, options);
    let header = header(film, &channels, options)?;
    write_blocks(header, threads, |index| Ok(block_bytes(film, &channels, index)), &|_| Ok(None), out)
}

/// Where a block's compressed bytes may already be: `Ok(Some(bytes))` for block number `i`
/// (in line order) compressed before, `Ok(None)` to compress it now.
pub(crate) type Compressed<'a> = dyn Fn(usize) -> std::io::Result<Option<Vec<u8>>> + Sync + 'a;

/// Writes a single-part scan-line file with `header` whose block `index` holds the
/// uncompressed bytes `block(index)` (line after line, in each line every channel's samples in
/// the header's channel order), compressing on `threads` threads, blocks in increasing order.
/// With ZIP, a block that `compressed` has (compressed while the tiles rendered,
/// [`super::exr_stream`]) is taken from it instead.
fn write_blocks<W: Write + Seek>(
    header: Header,
    threads: usize,
    block: impl Fn(BlockIndex) -> std::io::Result<Vec<u8>> + Sync,
    compressed: &Compressed,
    out: W,
) -> std::result::Result<(), exr::error::Error> {
    let zip = matches!(header.compression, exr::compression::Compression::ZIP16 | exr::compression::Compression::ZIP1);
    exr::block::write(out, exr::prelude::SmallVec::from_vec(vec![header]), true, |meta, chunk_writer| {
        if zip {
            // strahl's own ZIP (a faster deflate, `exr_zip`), a batch of blocks at a time in
            // parallel (each block's bytes gathered and compressed on the same thread), written
            // in order.
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads.max(1))
                .build()
                .map_err(|e| exr::error::Error::Io(std::io::Error::other(e)))?;
            let mut indices = meta.enumerate_ordered_header_block_indices();
            loop {
                let batch: Vec<(usize, BlockIndex)> = indices.by_ref().take(8 * threads.max(1)).collect();
                if batch.is_empty() {
                    return Ok(());
                }
                let done: Vec<std::io::Result<Vec<u8>>> = pool.install(|| {
                    use rayon::prelude::*;
                    batch
                        .par_iter()
                        .map(|(i, index)| match compressed(*i)? {
                            Some(bytes) => Ok(bytes),
                            None => Ok(super::exr_zip::compress_block(&block(*index)?)),
                        })
                        .collect()
                });
                for ((index, block_index), pixels) in batch.into_iter().zip(done) {
                    let pixels = pixels?;
                    // Lines are numbered in the file's coordinates: the data window's origin
                    // (a region's) plus the line in the block's layer.
                    let y_coordinate = i32::try_from(block_index.pixel_position.1)
                        .ok()
                        .and_then(|y| y.checked_add(meta.headers[0].own_attributes.layer_position.1))
                        .ok_or_else(|| exr::error::Error::Invalid("image too tall".into()))?;
                    let compressed_block = CompressedBlock::ScanLine(CompressedScanLineBlock {
                        y_coordinate,
                        compressed_pixels_le: pixels,
                    });
                    chunk_writer.write_chunk(index, Chunk { layer_index: 0, compressed_block })?;
                }
            }
        }
        let blocks = meta
            .enumerate_ordered_header_block_indices()
            .map(|(i, index)| Ok((i, UncompressedBlock { index, data: block(index)? })));
        if threads > 1 {
            let pool = || rayon::ThreadPoolBuilder::new().num_threads(threads).build();
            if let Some(mut parallel) = ParallelBlocksCompressor::new_with_thread_pool(&meta, chunk_writer, pool) {
                for next in blocks {
                    let (index, block) = next.map_err(exr::error::Error::Io)?;
                    parallel.add_block_to_compression_queue(index, block)?;
                }
                return Ok(());
            }
        }
        let mut sequential = SequentialBlocksCompressor::new(&meta, chunk_writer);
        for next in blocks {
            let (index, block) = next.map_err(exr::error::Error::Io)?;
            sequential.compress_block(index, block)?;
        }
        Ok(())
    })
}

/// Encodes `film` as an OpenEXR file in memory, compressing on `threads` threads.
pub fn encode(film: &Film, options: &ExrOptions, threads: usize) -> std::result::Result<Vec<u8>, exr::error::Error> {
    let channels = file_channels(film, options);
    let header = header(film, &channels, options)?;
    encode_blocks(header, threads, |index| Ok(block_bytes(film, &channels, index)))
}

/// Checks that a film of `output`'s passes can be written with `options` (its layout, its
/// Cryptomatte names, its header attributes), by encoding a 1 × 1 film of those passes through
/// the writer every render uses: called before rendering, so that a render never ends
/// unwritable for its text (see the module docs).
pub fn check_encodable(output: &OutputSpec, options: &ExrOptions) -> std::result::Result<(), exr::error::Error> {
    encode(&Film::with_output(1, 1, output), options, 1).map(drop)
}

/// The one way strahl makes an EXR file's bytes, a render's and `strahl merge`'s alike: a
/// single-part scan-line file with `header` and the blocks `block(index)` (see
/// `write_blocks`), its header attributes in name order so that the bytes are reproducible.
pub fn encode_blocks(
    header: Header,
    threads: usize,
    block: impl Fn(BlockIndex) -> std::io::Result<Vec<u8>> + Sync,
) -> std::result::Result<Vec<u8>, exr::error::Error> {
    let mut bytes = Cursor::new(Vec::new());
    write_blocks(header, threads, block, &|_| Ok(None), &mut bytes)?;
    let mut bytes = bytes.into_inner();
    sort_header_attributes(&mut bytes);
    Ok(bytes)
}

/// Puts the attributes of a single-part header in name order, in place. The `exr` crate keeps
/// non-standard attributes in a `HashMap` and writes them in its (random) iteration order;
/// sorting them makes the bytes the same on every run. The header keeps its length, so the
/// offset table after it stays valid. Leaves anything it cannot parse untouched.
/// Returns where the sorted attributes end, if it sorted them.
pub(crate) fn sort_header_attributes(bytes: &mut [u8]) -> Option<usize> {
    let spans = header_attribute_spans(bytes)?;
    let (start, end) = (spans[0].start, spans[spans.len() - 1].end);
    let mut sorted: Vec<&std::ops::Range<usize>> = spans.iter().collect();
    sorted.sort_by(|a, b| {
        let name = |r: &std::ops::Range<usize>| bytes[r.clone()].split(|&c| c == 0).next().map(<[u8]>::to_vec);
        name(a).cmp(&name(b))
    });
    let reordered: Vec<u8> = sorted.iter().flat_map(|r| bytes[(*r).clone()].iter().copied()).collect();
    bytes[start..end].copy_from_slice(&reordered);
    Some(end)
}

/// The byte ranges of the attributes of a single-part header (name, type, size, value each).
fn header_attribute_spans(bytes: &[u8]) -> Option<Vec<std::ops::Range<usize>>> {
    let mut spans = Vec::new();
    let mut at = 8; // magic number and version
    loop {
        if *bytes.get(at)? == 0 {
            return (!spans.is_empty()).then_some(spans);
        }
        let start = at;
        for _ in 0..2 {
            at += bytes.get(at..)?.iter().position(|&c| c == 0)? + 1; // name, then type
        }
        let size = i32::from_le_bytes(bytes.get(at..at + 4)?.try_into().ok()?);
        at += 4 + usize::try_from(size).ok()?;
        spans.push(start..at);
    }
}

/// Writes `film` to `path` as OpenEXR, atomically, compressing on `threads` threads. The
/// blocks go to the file as they are compressed (the file is never whole in memory); the
/// header's attributes are then sorted in place.
pub fn write(film: &Film, options: &ExrOptions, path: &Path, threads: usize) -> std::result::Result<(), WriteError> {
    commit_all(vec![stage(film, options, path, threads)?])
}

/// [`write()`] up to the temporary file, to be renamed with [`commit_all`] (with its PNG
/// preview, say).
pub fn stage(
    film: &Film,
    options: &ExrOptions,
    path: &Path,
    threads: usize,
) -> std::result::Result<Staged, WriteError> {
    stage_compressed(film, options, path, threads, &|_| Ok(None))
}

/// [`stage`], taking the blocks that `compressed` has from it ([`super::exr_stream`]).
pub(crate) fn stage_compressed(
    film: &Film,
    options: &ExrOptions,
    path: &Path,
    threads: usize,
    compressed: &Compressed,
) -> std::result::Result<Staged, WriteError> {
    let channels = file_channels(film, options);
    let header =
        header(film, &channels, options).map_err(|e| WriteError::new(path, format!("cannot encode OpenEXR: {e}")))?;
    stage_header_blocks(header, threads, |index| Ok(block_bytes(film, &channels, index)), compressed, path)
}

/// The file of [`encode_blocks`] written to the temporary file of `path` (to be renamed with
/// [`commit_all`]), its blocks going to the file as they are compressed (the file is never
/// whole in memory); the header's attributes are then sorted in place. An error of `block`
/// ends the writing with that error.
pub fn stage_blocks(
    header: Header,
    threads: usize,
    block: impl Fn(BlockIndex) -> std::io::Result<Vec<u8>> + Sync,
    path: &Path,
) -> std::result::Result<Staged, WriteError> {
    stage_header_blocks(header, threads, block, &|_| Ok(None), path)
}

fn stage_header_blocks(
    header: Header,
    threads: usize,
    block: impl Fn(BlockIndex) -> std::io::Result<Vec<u8>> + Sync,
    compressed: &Compressed,
    path: &Path,
) -> std::result::Result<Staged, WriteError> {
    let mut encode_error = None;
    let written = stage_with(path, |file| {
        if let Err(e) = write_blocks(header, threads, block, compressed, &mut *file) {
            let problem = match e {
                // An error of `block` (or of the disk) as it is.
                exr::error::Error::Io(e) => return Err(e),
                e => format!("cannot encode OpenEXR: {e}"),
            };
            encode_error = Some(problem.clone());
            return Err(std::io::Error::other(problem));
        }
        file.flush()?;
        sort_header_attributes_of(file.get_mut())
    });
    match (written, encode_error) {
        (Err(_), Some(problem)) => Err(WriteError::new(path, problem)),
        (result, _) => result,
    }
}

/// [`sort_header_attributes`] on the file `file`: reads the file's start, 1 MB and then four
/// times more until it holds the whole header (a Cryptomatte manifest of many objects makes a
/// header of many megabytes), and writes the sorted header back.
fn sort_header_attributes_of(file: &mut std::fs::File) -> std::io::Result<()> {
    let length = file.seek(SeekFrom::End(0))?;
    let mut size = 1u64 << 20;
    loop {
        let mut head = vec![0u8; length.min(size) as usize];
        file.seek(SeekFrom::Start(0))?;
        file.read_exact(&mut head)?;
        if let Some(end) = sort_header_attributes(&mut head) {
            file.seek(SeekFrom::Start(0))?;
            return file.write_all(&head[..end]);
        }
        if size >= length {
            return Ok(());
        }
        size *= 4;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Vec3;
    use crate::output::passes::{OutputSpec, PassSet};
    use exr::prelude::{FlatSamples, ReadChannels, ReadLayers};

    /// A film of every pass whose every channel differs per pixel, with misses (+inf depth) on
    /// row 0.
    fn film(w: u32, h: u32) -> Film {
        let output = OutputSpec { passes: PassSet::all(), ..Default::default() };
        let mut f = Film::with_output(w, h, &output);
        for y in 0..h {
            for x in 0..w {
                let i = f.index(x, y);
                let v = (x + 1000 * y) as f32;
                f.rgba[i] = [v, v + 0.25, v + 0.5, if y == 0 { 0.0 } else { 1.0 }];
                f.depth[i] = if y == 0 { f32::INFINITY } else { 1.0 + v / 7.0 };
                f.normal[i] = if y == 0 { Vec3::ZERO } else { Vec3::new(x as f32, -(y as f32), 0.5).normalize() };
                f.albedo[i] = Vec3::new(0.1, 0.2, 0.3) * (x % 3) as f32;
            }
        }
        for (k, aov) in f.aovs.iter_mut().enumerate() {
            for (j, v) in aov.data.iter_mut().enumerate() {
                *v = (k * 100000 + j) as f32 * 0.5;
            }
        }
        f
    }

    fn read(bytes: &[u8]) -> exr::image::FlatImage {
        exr::prelude::read()
            .no_deep_data()
            .largest_resolution_level()
            .all_channels()
            .all_layers()
            .all_attributes()
            .from_buffered(Cursor::new(bytes))
            .unwrap()
    }

    #[test]
    fn every_channel_reads_back_exactly_in_both_layouts() {
        let f = film(37, 40); // 40 lines: three ZIP blocks, the last one short
        for layout in [Layout::Blender, Layout::Nuke] {
            let options = ExrOptions { layout, ..Default::default() };
            let image = read(&encode(&f, &options, 1).unwrap());
            assert_eq!(image.layer_data.len(), 1);
            let layer = &image.layer_data[0];
            assert_eq!(layer.size, Vec2(37, 40));
            assert_eq!(layer.encoding.compression, exr::compression::Compression::ZIP16);
            let views = f.channels();
            assert_eq!(layer.channel_data.list.len(), views.len());
            for view in views {
                let name = channel_name(layout, view.pass, view.component);
                let c = layer.channel_data.list.iter().find(|c| c.name.to_string() == name).expect(&name);
                let FlatSamples::F32(got) = &c.sample_data else { panic!("{name} is not f32") };
                let want: Vec<f32> = (0..37 * 40).map(|i| view.get(i)).collect();
                assert!(got.iter().zip(&want).all(|(a, b)| a.to_bits() == b.to_bits()), "channel {name}");
            }
        }
    }

    #[test]
    fn half_makes_colour_passes_half_and_keeps_the_rest_float() {
        let f = film(8, 5);
        let image = read(&encode(&f, &ExrOptions { half: true, ..Default::default() }, 1).unwrap());
        for c in &image.layer_data[0].channel_data.list {
            let is_half = matches!(c.sample_data, FlatSamples::F16(_));
            let colour = [
                "Combined", "DiffCol", "Emit", "DiffDir", "DiffInd", "GlossDir", "GlossInd", "GlossCol", "TransDir",
                "TransInd", "TransCol", "Env", "Normal",
            ]
            .iter()
            .any(|p| c.name.to_string().starts_with(&format!("{VIEW_LAYER}.{p}.")));
            assert_eq!(is_half, colour, "{}", c.name);
        }
    }

    #[test]
    fn names_follow_the_layouts() {
        assert_eq!(channel_name(Layout::Blender, Pass::Combined, 3), "ViewLayer.Combined.A");
        assert_eq!(channel_name(Layout::Blender, Pass::Depth, 0), "ViewLayer.Depth.Z");
        assert_eq!(channel_name(Layout::Blender, Pass::CryptoObject, 6), "ViewLayer.CryptoObject01.b");
        assert_eq!(channel_name(Layout::Nuke, Pass::Combined, 0), "R");
        assert_eq!(channel_name(Layout::Nuke, Pass::Depth, 0), "Z");
        assert_eq!(channel_name(Layout::Nuke, Pass::Normal, 1), "N.Y");
        assert_eq!(channel_name(Layout::Nuke, Pass::CryptoMaterial, 4), "CryptoMaterial01.R");
    }

    #[test]
    fn the_streamed_file_is_the_encoded_bytes() {
        let f = film(30, 40);
        let options = ExrOptions {
            attributes: vec![("b".into(), Attribute::Int(1)), ("a".into(), Attribute::Text("x".into()))],
            ..Default::default()
        };
        let path = std::env::temp_dir().join(format!("strahl-exr-stream-{}.exr", std::process::id()));
        write(&f, &options, &path, 2).unwrap();
        let bytes = std::fs::read(&path).unwrap();
        let _ = std::fs::remove_file(&path);
        assert_eq!(bytes, encode(&f, &options, 1).unwrap());
        let spans = header_attribute_spans(&bytes).unwrap();
        let names: Vec<&[u8]> = spans.iter().map(|r| bytes[r.clone()].split(|&c| c == 0).next().unwrap()).collect();
        assert!(names.is_sorted(), "attributes in name order");
    }

    #[test]
    fn text_is_utf8_and_bad_names_are_refused_before_writing() {
        let output = OutputSpec { passes: PassSet::all(), ..Default::default() };
        let mut options = ExrOptions {
            attributes: vec![("strahl/scene".into(), Attribute::Text("сцена ❤.toml".into()))],
            object_names: vec!["шар".into(), "a\"b".into()],
            material_names: vec!["сталь".into()],
            ..Default::default()
        };
        check_encodable(&output, &options).unwrap();
        let image = read(&encode(&Film::with_output(2, 2, &output), &options, 1).unwrap());
        let attributes = &image.layer_data[0].attributes.other;
        let value = |name: &str| match attributes.get(&Text::from(name)) {
            Some(AttributeValue::Text(t)) => String::from_utf8(t.as_slice().to_vec()).unwrap(),
            other => panic!("{name}: {other:?}"),
        };
        assert_eq!(value("strahl/scene"), "сцена ❤.toml");
        let key = crate::output::cryptomatte::key(&crypto_name(Layout::Blender, Pass::CryptoObject));
        assert_eq!(
            value(&format!("cryptomatte/{key}/manifest")),
            crate::output::cryptomatte::manifest(&options.object_names)
        );
        for bad in ["a\0b", &"x".repeat(256), ""] {
            options.attributes = vec![(bad.to_string(), Attribute::Int(1))];
            assert!(check_encodable(&output, &options).is_err(), "{bad:?}");
        }
    }

    #[test]
    fn a_header_of_many_megabytes_is_sorted_too() {
        // 800,000 object names: a 20 MB manifest, more than the first reads of the header.
        let output = OutputSpec { passes: PassSet::of(&[Pass::Combined, Pass::CryptoObject]), ..Default::default() };
        let options = ExrOptions {
            object_names: (0..800_000).map(|i| format!("tree {i}")).collect(),
            attributes: vec![("b".into(), Attribute::Int(1)), ("a".into(), Attribute::Int(2))],
            ..Default::default()
        };
        let path = std::env::temp_dir().join(format!("strahl-exr-big-header-{}.exr", std::process::id()));
        write(&Film::with_output(3, 2, &output), &options, &path, 1).unwrap();
        let bytes = std::fs::read(&path).unwrap();
        let _ = std::fs::remove_file(&path);
        let spans = header_attribute_spans(&bytes).unwrap();
        assert!(spans.last().unwrap().end > 16 << 20);
        let names: Vec<&[u8]> = spans.iter().map(|r| bytes[r.clone()].split(|&c| c == 0).next().unwrap()).collect();
        assert!(names.is_sorted(), "attributes in name order");
    }

    #[test]
    fn same_bytes_on_any_number_of_threads() {
        let f = film(64, 100);
        let options = ExrOptions::default();
        let one = encode(&f, &options, 1).unwrap();
        assert_eq!(encode(&f, &options, 2).unwrap(), one);
        assert_eq!(encode(&f, &options, 3).unwrap(), one);
    }
}
