//! `strahl merge`: joins EXR files of regions of one image (`render --region`/`--tile`, on
//! one machine or many) into the file of the whole image.
//!
//! **The rule.** Every part's pixels go to its `dataWindow` inside the common
//! `displayWindow`; the result's `dataWindow` is the whole `displayWindow`. Every channel is
//! copied, whatever its name and sample type (half, float, uint), sample for sample, and
//! every header attribute of the parts is kept. The parts must be of one render:
//!
//! - the same `strahl/sceneHash` ([`crate::scene::hash`]: scene and settings), checked first;
//! - the same header otherwise (display window, channels and their types, compression, line
//!   order, every attribute), except the attributes of one run: `capDate` and `Date` (the
//!   result has the latest), `renderTimeSeconds`, `RenderTime` and `cycles.LAYER.render_time`
//!   (the sum), `strahl/scene`
//!   (the path as given, which may differ between machines: the top-left part's is kept),
//!   and the Cryptomatte manifests `cryptomatte/*/manifest`, which are joined: the union of
//!   their JSON objects, the first part's entries first (a name with two different ids is
//!   refused);
//! - data windows inside the display window, no two overlapping, and together covering it
//!   (the error lists the missing rectangles, `x0,y0,x1,y1` half-open).
//!
//! The parts are taken in the order of their data windows (top to bottom, then left to
//! right), so the argument order does not matter. The result is encoded by the writer every
//! render uses ([`crate::output::exr::stage_blocks`]), so merging the tiles of a render gives
//! the same bytes as rendering the whole image in one process (given fixed dates: with
//! `SOURCE_DATE_EPOCH` set, see [`crate::output::metadata`]).
//!
//! Single-part scan-line files only, in the compressions strahl writes; tiled, deep,
//! multi-part, subsampled or DWA-compressed files are refused with a message.
//!
//! **Streaming.** The merged file is made a block of lines at a time, in line order: block
//! `b` of the result (`L` lines, the compression's block height, full width) is gathered
//! from the blocks of the parts that hold its lines, each read from its file at its offset
//! and decompressed when needed, then compressed and written. Nothing of the frame is whole
//! in memory: a thread holds one block of the result and one block of a part at a time, and
//! the writer a batch of compressed blocks ([`Plan::memory`]).
//!
//! **What a part's file must back.** A part is a file that someone else made, so every size
//! its header declares is checked against the file before anything of that size is
//! allocated or read:
//!
//! - the offset table (8 bytes a block, one block per `L` lines of the data window) and the
//!   blocks' own 8-byte headers fit in the file;
//! - every block's offset lies in the file, its line is the one the table's place says, and
//!   its stored size is at most its raw size (OpenEXR stores a block raw when compression
//!   does not make it smaller) and at most what the file holds from there;
//! - the raw pixels (data window × bytes per pixel, of the whole part and of each block) are
//!   at most [`max_ratio`] times the stored bytes: the most the part's compression can
//!   expand (deflate's limit is 1032:1). A 17 KB file that declares 32768² pixels of 64
//!   float channels (275 GB) is refused before its pixels are read.
//!
//! **Memory.** [`Plan::memory`] bounds what the merge holds at once; `strahl merge` refuses a
//! merge over `--max-memory` (default [`crate::sys::memory::default_limit`]) before writing, or
//! uses fewer threads when that fits.

use std::collections::HashMap;
use std::fs::File;
use std::io::{BufReader, Read, Seek};
use std::os::unix::fs::FileExt;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

use exr::block::UncompressedBlock;
use exr::block::chunk::{Chunk, CompressedBlock, CompressedScanLineBlock};
use exr::compression::Compression;
use exr::meta::attribute::{AttributeValue, IntegerBounds, Text};
use exr::meta::header::Header;
use exr::meta::{BlockDescription, MetaData};
use exr::prelude::Vec2;

use crate::output::region::{Region, uncovered};
use crate::scene::load::file::MAX_PIXELS;
use crate::sys::atomic::Staged;

/// Why parts cannot be merged: one line, naming the file(s).
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct MergeError(pub String);

fn fail<T>(message: String) -> Result<T, MergeError> {
    Err(MergeError(message))
}

/// The attributes that may differ between the parts of one render (see the module docs), and
/// Blender's `cycles.LAYER.render_time` ([`is_per_run`]).
const PER_RUN: [&str; 4] = ["Date", "renderTimeSeconds", "RenderTime", "strahl/scene"];

/// Whether the attribute `name` may differ between the parts of one render.
fn is_per_run(name: &[u8]) -> bool {
    PER_RUN.iter().any(|p| p.as_bytes() == name) || (name.starts_with(b"cycles.") && name.ends_with(b".render_time"))
}

/// The scene/settings fingerprint attribute.
const SCENE_HASH: &str = "strahl/sceneHash";

/// The process, the thread pool and the writer's fixed buffers, in [`Plan::memory`].
pub const MERGE_BASE_BYTES: u64 = 32 << 20;

/// Blocks the writer compresses ahead of the one it writes, per thread
/// ([`crate::output::exr`] hands a batch of 8 blocks a thread to the threads at once).
const BATCH_PER_THREAD: u64 = 8;

/// The most that `compression` can expand stored bytes into raw pixel bytes: deflate's limit
/// of 1032:1 (258 bytes from a 2-bit code) for ZIP and ZIPS; PXR24 deflates float32 samples
/// cut to 24 bits, 4/3 × 1032; PIZ's Huffman coder stores at most 255 repeats of a 16-bit value
/// in a code, a count and a repeat code (about 410:1), B44 a 4 × 4 block of halfs in 3
/// bytes at best (about 11:1), both under 1032; RLE repeats a byte at most 128 times for 2
/// bytes (64:1); an uncompressed block is its raw bytes. `None` for the compressions merge
/// does not take (DWAA, DWAB: lossy and not written by strahl).
pub fn max_ratio(compression: Compression) -> Option<u64> {
    match compression {
        Compression::Uncompressed => Some(1),
        Compression::RLE => Some(64),
        Compression::ZIP1 | Compression::ZIP16 | Compression::PIZ | Compression::B44 | Compression::B44A => Some(1032),
        Compression::PXR24 => Some(1376),
        _ => None,
    }
}

/// Where a part's bytes are: a file, or bytes in memory (the fuzz target's parts).
pub enum Source {
    File(PathBuf),
    Bytes { name: PathBuf, bytes: Vec<u8> },
}

impl Source {
    /// The name errors give the part.
    pub fn path(&self) -> &Path {
        match self {
            Source::File(path) | Source::Bytes { name: path, .. } => path,
        }
    }

    fn open(&self) -> std::io::Result<Opened<'_>> {
        match self {
            Source::File(path) => File::open(path).map(Opened::File),
            Source::Bytes { bytes, .. } => Ok(Opened::Bytes(bytes)),
        }
    }
}

/// A part opened for reading at offsets.
enum Opened<'a> {
    File(File),
    Bytes(&'a [u8]),
}

impl Opened<'_> {
    fn len(&self) -> std::io::Result<u64> {
        match self {
            Opened::File(file) => Ok(file.metadata()?.len()),
            Opened::Bytes(bytes) => Ok(bytes.len() as u64),
        }
    }

    fn read_exact_at(&self, buffer: &mut [u8], offset: u64) -> std::io::Result<()> {
        match self {
            Opened::File(file) => file.read_exact_at(buffer, offset),
            Opened::Bytes(bytes) => {
                let range = usize::try_from(offset).ok().and_then(|at| Some(at..at.checked_add(buffer.len())?));
                let part = range.and_then(|r| bytes.get(r));
                let part = part.ok_or_else(|| std::io::Error::from(std::io::ErrorKind::UnexpectedEof))?;
                buffer.copy_from_slice(part);
                Ok(())
            }
        }
    }

    /// The part from its start, buffered.
    fn reader(&self) -> std::io::Result<Box<dyn Read + '_>> {
        Ok(match self {
            Opened::File(file) => {
                let mut file: &File = file;
                file.seek(std::io::SeekFrom::Start(0))?;
                Box::new(BufReader::new(file))
            }
            Opened::Bytes(bytes) => Box::new(*bytes),
        })
    }
}

/// One part: its source, header, place in the display window and blocks.
struct Part {
    source: Source,
    /// Its one header (as [`UncompressedBlock::decompress_chunk`] takes it).
    meta: MetaData,
    /// The data window relative to the display window's top-left corner.
    region: Region,
    /// Each block's pixel data, `(offset in the file, stored size)`, in increasing line order.
    blocks: Vec<(u64, usize)>,
    /// Bytes of the header in the file.
    header_bytes: u64,
}

impl Part {
    fn header(&self) -> &Header {
        &self.meta.headers[0]
    }

    fn shown(&self) -> std::path::Display<'_> {
        self.source.path().display()
    }
}

/// The parts of a merge, checked and in order, and the merged file's header: everything but
/// the pixels ([`plan`]).
pub struct Plan {
    parts: Vec<Part>,
    header: Header,
    /// Bytes of each channel's sample, in the header's channel order.
    sample_bytes: Vec<usize>,
    /// Lines of a block (the compression's).
    lines: usize,
}

/// Reads and checks the parts' headers and block tables, and makes the merged file's header
/// (see the module docs); no pixel is read.
pub fn plan(sources: Vec<Source>) -> Result<Plan, MergeError> {
    if sources.is_empty() {
        return fail("no parts to merge".into());
    }
    let mut parts = sources.into_iter().map(read_part).collect::<Result<Vec<_>, _>>()?;
    parts.sort_by_key(|p| (p.region.y0, p.region.x0));
    let first = &parts[0];
    for part in &parts[1..] {
        compare(first, part)?;
    }
    check_cover(&parts)?;

    let display = first.header().shared_attributes.display_window;
    let mut header = first.header().clone();
    header.own_attributes.layer_position = display.position;
    header.layer_size = display.size;
    let (compression, blocks, line_order) = (header.compression, header.blocks, header.line_order);
    let header = header.with_encoding(compression, blocks, line_order);
    let header = joined_attributes(header, &parts)?;
    let sample_bytes = header.channels.list.iter().map(|c| c.sample_type.bytes_per_sample()).collect();
    Ok(Plan { parts, header, sample_bytes, lines: compression.scan_lines_per_block() })
}

impl Plan {
    /// Bytes of one line of the merged image.
    fn line_bytes(&self) -> u64 {
        self.header.layer_size.0 as u64 * self.sample_bytes.iter().sum::<usize>() as u64
    }

    /// An upper bound of the memory a merge on `threads` threads holds at once, bytes:
    ///
    /// ```text
    /// memory = base + Σ parts (3 × header + 16 × blocks) + (4·T + 8·T + 4) × B
    /// ```
    ///
    /// with `B` the raw bytes of a block of the result (`L` full lines, or the image's height
    /// if less) and `T` the threads:
    /// each thread holds a block of the result, a block of a part stored and decompressed
    /// (each at most `B`), then the result's block and its compressed form while compressing
    /// it (4 × B in all); the writer keeps up to 8 compressed blocks a thread (each at most
    /// `B`) until their turn, and the exr crate's compressors (for the compressions other
    /// than ZIP) hold `T + 2` blocks and their copies (within the same bound); the parsed
    /// headers (Cryptomatte manifests, three copies at most) and the block tables stay in
    /// memory for the whole merge. `base` is [`MERGE_BASE_BYTES`].
    pub fn memory(&self, threads: usize) -> u64 {
        let lines = self.lines.min(self.header.layer_size.1) as u64;
        let block = self.line_bytes().saturating_mul(lines);
        let parts: u64 = self.parts.iter().map(|p| 3 * p.header_bytes + 16 * p.blocks.len() as u64).sum();
        let t = threads.max(1) as u64;
        let blocks = (4 * t + BATCH_PER_THREAD * t + 4).saturating_mul(block);
        MERGE_BASE_BYTES.saturating_add(parts).saturating_add(blocks)
    }

    /// The most threads, up to `threads`, whose merge fits in `budget` bytes
    /// ([`Plan::memory`]); an error saying what the merge needs if not even one does.
    pub fn threads_within(&self, threads: usize, budget: u64) -> Result<usize, MergeError> {
        let mut fit = threads.max(1);
        while fit > 1 && self.memory(fit) > budget {
            fit -= 1;
        }
        if self.memory(fit) > budget {
            let (w, h) = (self.header.layer_size.0, self.header.layer_size.1);
            return fail(format!(
                "merging {} parts into a {w} × {h} image of {} bytes per pixel needs about {} on one thread, \
                 more than the memory budget {} (--max-memory)",
                self.parts.len(),
                self.sample_bytes.iter().sum::<usize>(),
                crate::sys::memory::megabytes(self.memory(1)),
                crate::sys::memory::megabytes(budget)
            ));
        }
        Ok(fit)
    }

    /// Writes the merged file to the temporary file of `out` on `threads` threads, to be
    /// renamed with [`crate::sys::atomic::commit_all`].
    pub fn stage(&self, out: &Path, threads: usize) -> Result<Staged, MergeError> {
        let problem = Mutex::new(None);
        let staged =
            crate::output::exr::stage_blocks(self.header.clone(), threads, |index| self.block(index, &problem), out);
        staged.map_err(|e| problem.into_inner().unwrap_or_else(|p| p.into_inner()).unwrap_or(MergeError(e.to_string())))
    }

    /// The merged file's bytes, made in memory on `threads` threads (for tests and the fuzz
    /// target; [`Plan::stage`] streams them to a file).
    pub fn encode(&self, threads: usize) -> Result<Vec<u8>, MergeError> {
        let problem = Mutex::new(None);
        let bytes =
            crate::output::exr::encode_blocks(self.header.clone(), threads, |index| self.block(index, &problem));
        bytes.map_err(|e| {
            let problem = problem.into_inner().unwrap_or_else(|p| p.into_inner());
            problem.unwrap_or_else(|| MergeError(format!("cannot encode the merged OpenEXR: {e}")))
        })
    }

    /// The raw bytes of the result's block `index` (see [`crate::output::exr::encode_blocks`]),
    /// gathered from the parts; a failure is kept in `problem` (the first one) and ends the
    /// writing.
    fn block(&self, index: exr::block::BlockIndex, problem: &Mutex<Option<MergeError>>) -> std::io::Result<Vec<u8>> {
        self.gather(index.pixel_position.1, index.pixel_size.1).map_err(|e| {
            let message = e.0.clone();
            problem.lock().unwrap_or_else(|p| p.into_inner()).get_or_insert(e);
            std::io::Error::other(message)
        })
    }

    /// The raw bytes of lines `y .. y + h` of the result: line after line, in each line
    /// every channel's samples in turn.
    fn gather(&self, y: usize, h: usize) -> Result<Vec<u8>, MergeError> {
        let width = self.header.layer_size.0;
        let line_bytes = self.line_bytes() as usize;
        let pixel_bytes: usize = self.sample_bytes.iter().sum();
        // `offsets[c]`: where channel c's run starts in a line.
        let offsets: Vec<usize> =
            self.sample_bytes.iter().scan(0, |at, s| Some(std::mem::replace(at, *at + s * width))).collect();
        let mut out = vec![0u8; line_bytes * h];
        let (y0, y1) = (y as u32, (y + h) as u32);
        for part in self.parts.iter().filter(|p| p.region.y0 < y1 && y0 < p.region.y1) {
            let shown = part.shown();
            let opened = part.source.open().map_err(|e| MergeError(format!("{shown}: cannot open: {e}")))?;
            let lines = self.lines as u32;
            let first = (y0.max(part.region.y0) - part.region.y0) / lines;
            let last = (y1.min(part.region.y1) - 1 - part.region.y0) / lines;
            for k in first..=last {
                let pixels = self.decompress(part, &opened, k as usize)?;
                // Lines `top .. top + n` of the image are in this block of the part.
                let top = part.region.y0 + k * lines;
                let n = lines.min(part.region.y1 - top);
                let part_width = part.region.width() as usize;
                for line in top.max(y0)..(top + n).min(y1) {
                    let mut at = (line - top) as usize * part_width * pixel_bytes;
                    let row = (line - y0) as usize * line_bytes;
                    for (c, &s) in self.sample_bytes.iter().enumerate() {
                        let run = part_width * s;
                        let dst = row + offsets[c] + part.region.x0 as usize * s;
                        out[dst..dst + run].copy_from_slice(&pixels[at..at + run]);
                        at += run;
                    }
                }
            }
        }
        Ok(out)
    }

    /// Block `k` of `part`, read and decompressed (its raw bytes, checked to be the block's
    /// size).
    fn decompress(&self, part: &Part, opened: &Opened, k: usize) -> Result<Vec<u8>, MergeError> {
        let shown = part.shown();
        let broken = |e: String| MergeError(format!("{shown}: cannot read its pixels: {e}"));
        let (offset, size) = part.blocks[k];
        let mut stored = vec![0u8; size];
        opened.read_exact_at(&mut stored, offset).map_err(|e| broken(e.to_string()))?;
        let header = part.header();
        let y_coordinate = header.own_attributes.layer_position.1 + (k * self.lines) as i32;
        let chunk = Chunk {
            layer_index: 0,
            compressed_block: CompressedBlock::ScanLine(CompressedScanLineBlock {
                y_coordinate,
                compressed_pixels_le: stored,
            }),
        };
        let block = UncompressedBlock::decompress_chunk(chunk, &part.meta, true).map_err(|e| broken(e.to_string()))?;
        let lines = self.lines.min(part.region.height() as usize - k * self.lines);
        let expected = lines * part.region.width() as usize * self.sample_bytes.iter().sum::<usize>();
        if block.data.len() != expected {
            return Err(broken(format!("block {k} holds {} bytes, not {expected}", block.data.len())));
        }
        Ok(block.data)
    }
}

/// Reads the header and block table of the part `source` and checks it is a file merge can
/// take, every declared size backed by the file (see the module docs).
fn read_part(source: Source) -> Result<Part, MergeError> {
    let shown = source.path().display().to_string();
    if let Source::File(path) = &source {
        if !path.is_file() {
            return fail(format!("{shown}: is not a file"));
        }
    }
    let opened = source.open().map_err(|e| MergeError(format!("{shown}: cannot open: {e}")))?;
    let length = opened.len().map_err(|e| MergeError(format!("{shown}: cannot read: {e}")))?;
    let unreadable = |e: exr::error::Error| MergeError(format!("{shown}: not a readable OpenEXR file: {e}"));
    let reader = opened.reader().map_err(|e| MergeError(format!("{shown}: cannot read: {e}")))?;
    let meta = MetaData::read_from_buffered(reader, true).map_err(unreadable)?;
    if meta.headers.len() != 1 || meta.requirements.has_multiple_layers {
        return fail(format!("{shown}: has {} parts; merge takes single-part files", meta.headers.len()));
    }
    MetaData::validate(&meta.headers, true).map_err(unreadable)?;
    let header = &meta.headers[0];
    if header.deep {
        return fail(format!("{shown}: holds deep data, which merge cannot join"));
    }
    if header.blocks != BlockDescription::ScanLines {
        return fail(format!("{shown}: is tiled; merge takes scan-line files"));
    }
    let Some(ratio) = max_ratio(header.compression) else {
        return fail(format!(
            "{shown}: is compressed with {}, which merge does not take (it takes what strahl writes: {})",
            header.compression,
            crate::output::exr::Compression::ALL.map(|(_, n)| n).join(", ")
        ));
    };
    if let Some(c) = header.channels.list.iter().find(|c| c.sampling != Vec2(1, 1)) {
        return fail(format!(
            "{shown}: channel {} is subsampled; merge takes full-resolution channels",
            lossy(&c.name)
        ));
    }
    let display = header.shared_attributes.display_window;
    if display.size.0 as u64 * display.size.1 as u64 > MAX_PIXELS {
        return fail(format!(
            "{shown}: its {} × {} display window is more than the {MAX_PIXELS} pixels strahl handles",
            display.size.0, display.size.1
        ));
    }
    let data = header.data_window();
    let relative = |a: i32, origin: i32| u32::try_from(a as i64 - origin as i64).ok();
    let region = (|| {
        let x0 = relative(data.position.0, display.position.0)?;
        let y0 = relative(data.position.1, display.position.1)?;
        let x1 = x0.checked_add(u32::try_from(data.size.0).ok()?)?;
        let y1 = y0.checked_add(u32::try_from(data.size.1).ok()?)?;
        let r = Region { x0, y0, x1, y1 };
        (r.x1 as usize <= display.size.0 && r.y1 as usize <= display.size.1).then_some(r)
    })()
    .ok_or_else(|| {
        MergeError(format!(
            "{shown}: its data window {} lies outside its display window {}",
            bounds(&data),
            bounds(&display)
        ))
    })?;

    // The header's end: where the offset table begins.
    let header_bytes = header_length(&opened).map_err(|e| MergeError(format!("{shown}: {e}")))?;
    let lines = header.compression.scan_lines_per_block();
    let count = region.height().div_ceil(lines as u32) as u64;
    if header.chunk_count as u64 != count {
        return fail(format!("{shown}: declares {} blocks where its data window has {count}", header.chunk_count));
    }
    let pixel_bytes = header.channels.bytes_per_pixel as u64;
    let raw = region.pixel_count().saturating_mul(pixel_bytes);
    // The table, and each block's line and size fields.
    let table_end = header_bytes.saturating_add(8 * count);
    if table_end.saturating_add(8 * count) > length {
        return fail(format!(
            "{shown}: its {count} blocks need {} bytes of offsets and block headers after its {header_bytes}-byte \
             header, more than its {length} bytes",
            16 * count
        ));
    }
    if raw > ratio.saturating_mul(length - header_bytes) {
        return fail(format!(
            "{shown}: its {} × {} data window of {} bytes per pixel is {raw} bytes of pixels, more than its \
             {length} bytes can hold with {} (at most {ratio}:1)",
            region.width(),
            region.height(),
            pixel_bytes,
            header.compression
        ));
    }
    let mut table = vec![0u8; 8 * count as usize];
    opened.read_exact_at(&mut table, header_bytes).map_err(|e| MergeError(format!("{shown}: cannot read: {e}")))?;
    let mut blocks = Vec::with_capacity(count as usize);
    for (k, entry) in table.chunks_exact(8).enumerate() {
        let offset = u64::from_le_bytes(entry.try_into().unwrap_or_default());
        let block_lines = (lines as u64).min(region.height() as u64 - k as u64 * lines as u64);
        let block_raw = block_lines * region.width() as u64 * pixel_bytes;
        let bad = |what: String| MergeError(format!("{shown}: block {k} of {count}: {what}"));
        if offset < table_end || offset.saturating_add(8) > length {
            return Err(bad(format!("its offset {offset} lies outside the file's blocks ({table_end} to {length})")));
        }
        let mut fields = [0u8; 8];
        opened.read_exact_at(&mut fields, offset).map_err(|e| bad(format!("cannot read: {e}")))?;
        let y = i32::from_le_bytes([fields[0], fields[1], fields[2], fields[3]]);
        let size = i32::from_le_bytes([fields[4], fields[5], fields[6], fields[7]]);
        let want = data.position.1 as i64 + k as i64 * lines as i64;
        if y as i64 != want {
            return Err(bad(format!("holds line {y} where line {want} belongs")));
        }
        let size = u64::try_from(size).unwrap_or(u64::MAX);
        if size > block_raw || size > length - offset - 8 {
            return Err(bad(format!(
                "declares {size} stored bytes, more than its {block_raw} raw bytes or the {} bytes left in the file",
                length - offset - 8
            )));
        }
        if block_raw > ratio.saturating_mul(size) {
            return Err(bad(format!(
                "declares {block_raw} raw bytes in {size} stored bytes, more than {} can hold (at most {ratio}:1)",
                header.compression
            )));
        }
        blocks.push((offset + 8, size as usize));
    }
    drop(opened);
    Ok(Part { source, meta, region, blocks, header_bytes })
}

/// The length of a single-part header at the start of `opened`: its attributes (name, type,
/// size, value each) up to the NUL byte that ends it.
fn header_length(opened: &Opened) -> Result<u64, String> {
    let short = || "its header ends past the end of the file".to_string();
    let mut read = opened.reader().map_err(|e| format!("cannot read: {e}"))?;
    let mut at = 8u64; // magic number and version
    std::io::copy(&mut (&mut read).take(at), &mut std::io::sink()).map_err(|_| short())?;
    let mut byte = [0u8; 1];
    let mut next = |read: &mut dyn Read| read.read_exact(&mut byte).map(|()| byte[0]).map_err(|_| short());
    loop {
        // The name, then the type: each NUL-terminated, at most 255 bytes; an empty name ends
        // the header.
        for field in 0..2 {
            let mut n = 0u64;
            while next(&mut read)? != 0 {
                n += 1;
                if n > 255 {
                    return Err("an attribute name or type longer than 255 bytes".into());
                }
            }
            at += n + 1;
            if field == 0 && n == 0 {
                return Ok(at);
            }
        }
        let mut size = [0u8; 4];
        read.read_exact(&mut size).map_err(|_| short())?;
        let size = u64::try_from(i32::from_le_bytes(size)).map_err(|_| "an attribute of negative size".to_string())?;
        if std::io::copy(&mut (&mut read).take(size), &mut std::io::sink()).map_err(|_| short())? != size {
            return Err(short());
        }
        at += 4 + size;
    }
}

/// The bytes of `t` as text: UTF-8 (what strahl writes), any other byte shown as U+FFFD.
fn lossy(t: &Text) -> String {
    String::from_utf8_lossy(t.as_slice()).into_owned()
}

/// `(x0, y0) – (x1, y1)`, inclusive, as `exrheader` prints windows.
fn bounds(b: &IntegerBounds) -> String {
    let max = b.max();
    format!("({} {}) - ({} {})", b.position.0, b.position.1, max.0, max.1)
}

/// A region in the file's own coordinates (the display window's origin added back).
fn absolute(r: &Region, display: &IntegerBounds) -> String {
    let (ox, oy) = (display.position.0 as i64, display.position.1 as i64);
    format!("{},{},{},{}", r.x0 as i64 + ox, r.y0 as i64 + oy, r.x1 as i64 + ox, r.y1 as i64 + oy)
}

fn text_attribute(header: &Header, name: &str) -> Option<String> {
    match header.own_attributes.other.get(&Text::from(name)) {
        Some(AttributeValue::Text(t)) => Some(lossy(t)),
        Some(other) => Some(format!("{other:?}")),
        None => None,
    }
}

fn is_manifest(name: &Text) -> bool {
    name.as_slice().starts_with(b"cryptomatte/") && name.as_slice().ends_with(b"/manifest")
}

/// The header with what may differ between parts taken out (see the module docs).
fn comparable(header: &Header) -> Header {
    let mut h = header.clone();
    h.layer_size = Vec2(0, 0);
    h.chunk_count = 0;
    h.own_attributes.layer_position = Vec2(0, 0);
    h.own_attributes.capture_date = None;
    h.own_attributes.other.retain(|name, _| !is_per_run(name.as_slice()) && !is_manifest(name));
    h
}

/// Refuses `part` unless it is of the same render as `first` (see the module docs).
fn compare(first: &Part, part: &Part) -> Result<(), MergeError> {
    let (a, b) = (first.shown(), part.shown());
    let (ha, hb) = (text_attribute(first.header(), SCENE_HASH), text_attribute(part.header(), SCENE_HASH));
    if ha != hb {
        let show = |h: Option<String>| h.unwrap_or_else(|| "none".into());
        return fail(format!(
            "{b}: scene/settings hash {} differs from {a}'s {}: the parts are of different scenes or settings",
            show(hb),
            show(ha)
        ));
    }
    let (x, y) = (comparable(first.header()), comparable(part.header()));
    if x == y {
        return Ok(());
    }
    let what = if x.shared_attributes.display_window != y.shared_attributes.display_window {
        format!(
            "display window {} differs from {a}'s {}",
            bounds(&y.shared_attributes.display_window),
            bounds(&x.shared_attributes.display_window)
        )
    } else if x.channels != y.channels {
        let names = |h: &Header| {
            h.channels
                .list
                .iter()
                .map(|c| format!("{}:{:?}", lossy(&c.name), c.sample_type))
                .collect::<Vec<_>>()
                .join(" ")
        };
        format!("channels [{}] differ from {a}'s [{}]", names(&y), names(&x))
    } else if x.compression != y.compression {
        format!("compression {:?} differs from {a}'s {:?}", y.compression, x.compression)
    } else if let Some(name) = differing_attribute(&x.own_attributes.other, &y.own_attributes.other)
        .or_else(|| differing_attribute(&x.shared_attributes.other, &y.shared_attributes.other))
    {
        format!("attribute {name} differs from {a}'s")
    } else {
        "its header differs from the first part's in a standard attribute".to_string()
    };
    fail(format!("{b}: {what}: the parts are not of one render"))
}

/// The name of an attribute present in one map and not the other, or with another value.
fn differing_attribute(a: &HashMap<Text, AttributeValue>, b: &HashMap<Text, AttributeValue>) -> Option<String> {
    let mut names: Vec<&Text> = a.keys().chain(b.keys()).collect();
    names.sort_by(|x, y| x.as_slice().cmp(y.as_slice()));
    names.into_iter().find(|n| a.get(*n) != b.get(*n)).map(lossy)
}

/// Refuses overlapping parts and an incomplete cover of the display window.
fn check_cover(parts: &[Part]) -> Result<(), MergeError> {
    let display = parts[0].header().shared_attributes.display_window;
    for (i, p) in parts.iter().enumerate() {
        for q in &parts[i + 1..] {
            if let Some(both) = p.region.intersection(&q.region) {
                return fail(format!(
                    "{} and {} overlap in {} (x0,y0,x1,y1, half-open)",
                    p.shown(),
                    q.shown(),
                    absolute(&both, &display)
                ));
            }
        }
    }
    let whole = Region::full(display.size.0 as u32, display.size.1 as u32);
    let regions: Vec<Region> = parts.iter().map(|p| p.region).collect();
    let missing = uncovered(&whole, &regions);
    if !missing.is_empty() {
        const SHOWN: usize = 8;
        let mut list: Vec<String> = missing.iter().take(SHOWN).map(|r| absolute(r, &display)).collect();
        if missing.len() > SHOWN {
            list.push(format!("and {} more", missing.len() - SHOWN));
        }
        return fail(format!(
            "the parts do not cover the {} × {} image: missing {} (x0,y0,x1,y1, half-open)",
            whole.x1,
            whole.y1,
            list.join("; ")
        ));
    }
    Ok(())
}

/// `header` (the first part's, resized) with the attributes of one run joined over `parts`.
fn joined_attributes(mut header: Header, parts: &[Part]) -> Result<Header, MergeError> {
    // The latest date: the greatest text (both date formats sort as dates do).
    let latest = |get: &dyn Fn(&Header) -> Option<Text>| {
        parts.iter().filter_map(|p| get(p.header())).max_by(|a, b| a.as_slice().cmp(b.as_slice()))
    };
    header.own_attributes.capture_date = latest(&|h| h.own_attributes.capture_date.clone());
    let date_key = Text::from("Date");
    if let Some(date) = latest(&|h| match h.own_attributes.other.get(&date_key) {
        Some(AttributeValue::Text(t)) => Some(t.clone()),
        _ => None,
    }) {
        header.own_attributes.other.insert(date_key.clone(), AttributeValue::Text(date));
    }
    let other = &mut header.own_attributes.other;
    let times: Vec<f32> = parts
        .iter()
        .filter_map(|p| match p.header().own_attributes.other.get(&Text::from("renderTimeSeconds")) {
            Some(AttributeValue::F32(t)) => Some(*t),
            _ => None,
        })
        .collect();
    if !times.is_empty() {
        let total: f64 = times.iter().map(|&t| t as f64).sum();
        other.insert(Text::from("renderTimeSeconds"), AttributeValue::F32(total as f32));
        let text = crate::output::metadata::render_time_text(total);
        let keys: Vec<Text> = other
            .keys()
            .filter(|k| {
                k.as_slice() == b"RenderTime" || (is_per_run(k.as_slice()) && k.as_slice().starts_with(b"cycles."))
            })
            .cloned()
            .collect();
        for key in keys {
            other.insert(key, AttributeValue::Text(crate::output::exr::text(&text)));
        }
    }
    let manifests: Vec<Text> = other.keys().filter(|k| is_manifest(k)).cloned().collect();
    for key in manifests {
        let texts: Vec<(&[u8], &Path)> = parts
            .iter()
            .filter_map(|p| match p.header().own_attributes.other.get(&key) {
                Some(AttributeValue::Text(t)) => Some((t.as_slice(), p.source.path())),
                _ => None,
            })
            .collect();
        let joined = join_manifests(&lossy(&key), &texts)?;
        other.insert(key, AttributeValue::Text(Text::from_slice_unchecked(&joined)));
    }
    Ok(header)
}

/// The union of Cryptomatte manifests (`{"name":"hex",…}`, UTF-8 JSON): the text itself when
/// all agree, else the first's entries in order, then each further name in the order it
/// appears.
fn join_manifests(attribute: &str, texts: &[(&[u8], &Path)]) -> Result<Vec<u8>, MergeError> {
    let Some((first, _)) = texts.first() else { return Ok(Vec::new()) };
    if texts.iter().all(|(t, _)| t == first) {
        return Ok(first.to_vec());
    }
    let mut entries: Vec<(String, String)> = Vec::new();
    for (text, path) in texts {
        let parsed: OrderedObject = serde_json::from_slice(text).map_err(|e| {
            MergeError(format!("{}: {attribute} is not a UTF-8 JSON object of names: {e}", path.display()))
        })?;
        for (name, id) in parsed.0 {
            match entries.iter().find(|(n, _)| *n == name) {
                Some((_, known)) if *known != id => {
                    return fail(format!(
                        "{}: {attribute} gives '{name}' the id {id}, another part {known}",
                        path.display()
                    ));
                }
                Some(_) => {}
                None => entries.push((name, id)),
            }
        }
    }
    let json = |s: &str| serde_json::to_string(s).unwrap_or_default();
    let body: Vec<String> = entries.iter().map(|(n, id)| format!("{}:{}", json(n), json(id))).collect();
    Ok(format!("{{{}}}", body.join(",")).into_bytes())
}

/// A JSON object of strings, its entries in the order of the text.
struct OrderedObject(Vec<(String, String)>);

impl<'de> serde::Deserialize<'de> for OrderedObject {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct Visitor;
        impl<'de> serde::de::Visitor<'de> for Visitor {
            type Value = OrderedObject;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("an object of strings")
            }
            fn visit_map<M: serde::de::MapAccess<'de>>(self, mut map: M) -> Result<OrderedObject, M::Error> {
                let mut out = Vec::new();
                while let Some(entry) = map.next_entry::<String, String>()? {
                    out.push(entry);
                }
                Ok(OrderedObject(out))
            }
        }
        d.deserialize_map(Visitor)
    }
}

/// Merges the parts given as bytes in memory on one thread within `budget` bytes (see
/// [`Plan::memory`]): what `strahl merge` does, without files. The fuzz target's entry.
pub fn merge_bytes(parts: Vec<Vec<u8>>, budget: u64) -> Result<Vec<u8>, MergeError> {
    let sources = parts
        .into_iter()
        .enumerate()
        .map(|(k, bytes)| Source::Bytes { name: format!("part{k}").into(), bytes })
        .collect();
    let plan = plan(sources)?;
    let threads = plan.threads_within(1, budget)?;
    plan.encode(threads)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn manifests_join_as_a_union_in_order() {
        let p = Path::new("a.exr");
        let join = |texts: &[(&str, &Path)]| {
            let bytes: Vec<(&[u8], &Path)> = texts.iter().map(|(t, p)| (t.as_bytes(), *p)).collect();
            join_manifests("m", &bytes).map(|b| String::from_utf8(b).unwrap())
        };
        assert_eq!(join(&[("{\"x\":\"01\"}", p), ("{\"x\":\"01\"}", p)]).unwrap(), "{\"x\":\"01\"}");
        let texts = [("{\"b\":\"02\",\"a\":\"01\"}", p), ("{\"c\":\"03\",\"a\":\"01\"}", p)];
        assert_eq!(join(&texts).unwrap(), "{\"b\":\"02\",\"a\":\"01\",\"c\":\"03\"}");
        let clash = [("{\"a\":\"01\"}", p), ("{\"a\":\"02\"}", p)];
        assert!(join(&clash).unwrap_err().to_string().contains("'a'"));
        assert!(join(&[("{}", p), ("[1]", p)]).is_err());
        // UTF-8 names stay UTF-8.
        let cyrillic = [("{\"шар\":\"01\"}", p), ("{\"куб\":\"02\"}", p)];
        assert_eq!(join(&cyrillic).unwrap(), "{\"шар\":\"01\",\"куб\":\"02\"}");
    }
}
