//! The EXR encoded while the tiles render: with ZIP (and ZIPS), a block of the file is
//! compressed as soon as its last pixel is final, by the thread whose tile completed it, so
//! that when the last tile ends almost nothing is left to compress.
//!
//! **The rule.** Block `b` holds lines `b·L .. min((b+1)·L, h)` of the film (`L` = 16 for
//! ZIP, 1 for ZIPS, as [`super::exr`] writes them). It is final once every tile still to
//! render that overlaps it is in the film: pixels restored from a checkpoint are final from
//! the start, so each block counts only the pixels of the tiles to render
//! ([`BlockStream::new`]), and the tile that brings its count to zero
//! ([`BlockStream::tile_done`]) gathers the block from the film (under the film's lock),
//! compresses it outside the lock and keeps the bytes (`Held`). When the render ends,
//! [`BlockStream::stage`] writes the EXR through the one writer ([`super::exr::stage`]),
//! which takes every block in line order from those kept, compressing there only the blocks no
//! rendered tile completed (all of a resumed render's restored ones; every block of the other
//! compressions).
//!
//! **Same bytes.** A block's compressed bytes depend only on its pixels, which are final when
//! it is compressed; the file's layout (line order, offsets) is made at the end. So the file
//! is byte for byte the one of compressing everything after the render, for any number of
//! threads, any tile order, and any resume (tests below and in tests/).
//!
//! **Where the compressed blocks wait.** The EXR's header holds the render time, so the file
//! is written after the render, and blocks complete out of line order anyway (each thread works
//! through its own stretch of tiles). They wait in memory up to [`BlockStream::budget`] (a
//! sixteenth of the film's bytes, at least 32 MB, the whole compressed 1920 × 1080 frame of
//! default passes, 24.6 MB, for the Whitted scene, and at most 256 MB, 2 % of a 16384² film),
//! the rest in a scratch file beside the
//! output ([`Scratch`], created when first needed), which costs a write and a read through
//! the page cache: on the 1-thread 1920 × 1080 Whitted frame, all of it in a scratch file took
//! 0.03–0.05 s more system time than all of it in memory. The budget keeps a 3840 × 2160 frame
//! within 60 bytes per pixel. A block that cannot be stored (a full disk) is compressed again
//! at the end, where the same disk will report the error. `STRAHL_TEST_BLOCK_BUDGET` (for
//! tests) sets the budget in bytes.

use std::os::unix::fs::FileExt;
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::sync::atomic::{AtomicU64, Ordering};

use exr::block::BlockIndex;
use exr::prelude::Vec2;

use super::exr::{Compression, ExrOptions, block_bytes, file_channels, stage_compressed};
use crate::output::film::Film;
use crate::output::region::Region;
use crate::sys::atomic::{Scratch, Staged, WriteError};

/// The blocks of one render's EXR compressed while its tiles render (see the module docs).
pub struct BlockStream {
    /// Lines per block; 0 when the compression is not streamed.
    lines: u32,
    /// The film's data window.
    window: Region,
    /// Pixels of each block still to render.
    remaining: Vec<AtomicU64>,
    /// The channel layout and sample types (the header attributes are not used).
    options: ExrOptions,
    /// Where the scratch file goes (beside this).
    output: PathBuf,
    /// Bytes of compressed blocks kept in memory at most.
    budget: usize,
    /// `None` when the compression is not streamed.
    held: Option<Mutex<Held>>,
    /// Time the rendering threads spent on blocks, summed over the threads.
    nanos: AtomicU64,
}

/// The compressed blocks so far.
#[derive(Default)]
struct Held {
    blocks: Vec<Option<Stored>>,
    /// Bytes of `blocks` in memory.
    in_memory: usize,
    /// Created when the budget is first exceeded.
    scratch: Option<Scratch>,
    /// Bytes written to the scratch file.
    end: u64,
    /// The scratch file could not be created: blocks beyond the budget are not kept.
    no_scratch: bool,
}

/// A compressed block, in memory or in the scratch file.
enum Stored {
    Memory(Vec<u8>),
    Scratch { at: u64, length: usize },
}

impl BlockStream {
    /// A stream for `film` (as allocated before rendering) written with `options`' layout,
    /// sample types and compression to `output`, of which the tiles `todo` remain to render.
    /// The scratch file, if any, will go beside `output`. Keeps nothing for a compression
    /// other than ZIP and ZIPS.
    pub fn new(film: &Film, options: &ExrOptions, output: &Path, todo: &[Region]) -> BlockStream {
        let lines = match options.compression {
            Compression::Zip => 16,
            Compression::Zips => 1,
            _ => 0,
        };
        let window = film.region();
        let film_bytes: usize = film.buffers().iter().map(|(data, _)| data.len() * 4).sum();
        let mut stream = BlockStream {
            lines,
            window,
            remaining: Vec::new(),
            options: ExrOptions { attributes: Vec::new(), ..options.clone() },
            output: output.to_path_buf(),
            budget: std::env::var("STRAHL_TEST_BLOCK_BUDGET")
                .ok()
                .and_then(|v| v.parse().ok())
                .unwrap_or_else(|| BlockStream::budget(film_bytes)),
            held: None,
            nanos: AtomicU64::new(0),
        };
        if lines == 0 || window.is_empty() {
            return stream;
        }
        let count = window.height().div_ceil(lines) as usize;
        stream.remaining = (0..count).map(|_| AtomicU64::new(0)).collect();
        stream.held = Some(Mutex::new(Held { blocks: (0..count).map(|_| None).collect(), ..Held::default() }));
        for tile in todo {
            for (b, pixels) in stream.blocks_of(tile) {
                stream.remaining[b].fetch_add(pixels, Ordering::Relaxed);
            }
        }
        stream
    }

    /// The bytes of compressed blocks kept in memory for a film of `film_bytes` bytes: a
    /// sixteenth of it, at least 32 MB and at most 256 MB (see the module docs).
    pub fn budget(film_bytes: usize) -> usize {
        (film_bytes / 16).clamp(32 << 20, 256 << 20)
    }

    /// The blocks that `tile` overlaps, with the number of its pixels in each.
    fn blocks_of(&self, tile: &Region) -> impl Iterator<Item = (usize, u64)> + use<> {
        let (lines, window) = (self.lines, self.window);
        let tile = tile.intersection(&window).unwrap_or(Region { x0: 0, y0: 0, x1: 0, y1: 0 });
        let (y0, y1) = (tile.y0.saturating_sub(window.y0), tile.y1.saturating_sub(window.y0));
        let first = if tile.is_empty() || lines == 0 { 1 } else { y0 / lines };
        let last = if tile.is_empty() || lines == 0 { 0 } else { (y1 - 1) / lines };
        (first..=last).map(move |b| {
            let rows = (y1.min((b + 1) * lines) - y0.max(b * lines)) as u64;
            (b as usize, rows * tile.width() as u64)
        })
    }

    /// `tile` (one of `todo`) is in `film` now: compresses and stores the blocks it completed.
    pub fn tile_done(&self, tile: &Region, film: &Mutex<Film>) {
        let Some(held) = &self.held else { return };
        for (b, pixels) in self.blocks_of(tile) {
            if self.remaining[b].fetch_sub(pixels, Ordering::AcqRel) != pixels {
                continue;
            }
            let start = std::time::Instant::now();
            let y = b as u32 * self.lines;
            let index = BlockIndex {
                layer: 0,
                pixel_position: Vec2(0, y as usize),
                pixel_size: Vec2(self.window.width() as usize, (self.lines.min(self.window.height() - y)) as usize),
                level: Vec2(0, 0),
            };
            let raw = {
                let film = film.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
                block_bytes(&film, &file_channels(&film, &self.options), index)
            };
            let bytes = super::exr_zip::compress_block(&raw);
            let mut held = held.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
            held.blocks[b] = self.keep(&mut held, bytes);
            self.nanos.fetch_add(start.elapsed().as_nanos() as u64, Ordering::Relaxed);
        }
    }

    /// Seconds the rendering threads spent gathering, compressing and keeping blocks, summed
    /// over the threads.
    pub fn thread_seconds(&self) -> f64 {
        self.nanos.load(Ordering::Relaxed) as f64 * 1e-9
    }

    /// Keeps the compressed `bytes` of a block: in memory within the budget, else in the
    /// scratch file; `None` if that cannot be written.
    fn keep(&self, held: &mut Held, bytes: Vec<u8>) -> Option<Stored> {
        if held.in_memory + bytes.len() <= self.budget {
            held.in_memory += bytes.len();
            return Some(Stored::Memory(bytes));
        }
        if held.scratch.is_none() && !held.no_scratch {
            held.scratch = Scratch::beside(&self.output).ok();
            held.no_scratch = held.scratch.is_none();
        }
        let at = held.end;
        held.scratch.as_ref()?.file.write_all_at(&bytes, at).ok()?;
        held.end += bytes.len() as u64;
        Some(Stored::Scratch { at, length: bytes.len() })
    }

    /// How many blocks are compressed and kept so far: in memory, in the scratch file.
    pub fn kept(&self) -> (usize, usize) {
        let Some(held) = &self.held else { return (0, 0) };
        let held = held.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
        let in_memory = held.blocks.iter().flatten().filter(|s| matches!(s, Stored::Memory(_))).count();
        (in_memory, held.blocks.iter().flatten().count() - in_memory)
    }

    /// Writes the finished `film` as [`super::exr::stage`] does (the same bytes), taking the
    /// kept blocks (each freed as it is written) if `options` lay the blocks out as the
    /// stream's did; the scratch file goes when this returns.
    pub fn stage(self, film: &Film, options: &ExrOptions, path: &Path, threads: usize) -> Result<Staged, WriteError> {
        let o = &self.options;
        let same_layout = (o.layout, o.half, o.compression) == (options.layout, options.half, options.compression);
        let Some(held) = self.held.filter(|_| same_layout) else {
            return super::exr::stage(film, options, path, threads);
        };
        let held = held.into_inner().unwrap_or_else(|poisoned| poisoned.into_inner());
        let blocks: Vec<Mutex<Option<Stored>>> = held.blocks.into_iter().map(Mutex::new).collect();
        let scratch = held.scratch;
        stage_compressed(film, options, path, threads, &|i| {
            let stored = blocks.get(i).and_then(|b| b.lock().unwrap_or_else(|poisoned| poisoned.into_inner()).take());
            match (stored, &scratch) {
                (Some(Stored::Memory(bytes)), _) => Ok(Some(bytes)),
                (Some(Stored::Scratch { at, length }), Some(scratch)) => {
                    let mut bytes = vec![0; length];
                    scratch.file.read_exact_at(&mut bytes, at)?;
                    Ok(Some(bytes))
                }
                _ => Ok(None),
            }
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::output::passes::{OutputSpec, PassSet};

    /// The value every channel of pixel `(x, y)` ends with (all different, misses on row 3).
    fn paint(film: &mut Film, tile: &Region) {
        for y in tile.y0..tile.y1 {
            for x in tile.x0..tile.x1 {
                let i = film.index(x, y);
                let v = (x + 1000 * y) as f32;
                film.rgba[i] = [v, v + 0.25, v + 0.5, 1.0];
                film.depth[i] = if y == 3 { f32::INFINITY } else { 1.0 + v / 7.0 };
                film.normal[i] = crate::math::Vec3::new(x as f32, -(y as f32), 0.5).normalize();
                film.albedo[i] = crate::math::Vec3::new(0.1, 0.2, 0.3) * (x % 3) as f32;
                for aov in &mut film.aovs {
                    let n = aov.floats_per_pixel;
                    for (k, s) in aov.data[i * n..(i + 1) * n].iter_mut().enumerate() {
                        *s = v * 0.5 + k as f32;
                    }
                }
            }
        }
    }

    /// Renders (paints) the tiles of `region` in a scrambled order through a stream, with the
    /// tiles `restored` painted before (a resume), and checks the file is the plain encoder's.
    fn check(
        region: Region,
        compression: Compression,
        restored: &[usize],
        stride: usize,
        budget: usize,
    ) -> (usize, usize) {
        let output = OutputSpec { passes: PassSet::all(), ..Default::default() };
        let options = ExrOptions { compression, ..Default::default() };
        let dir = std::env::temp_dir().join(format!("strahl-stream-{}-{}", std::process::id(), region));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("out.exr");
        let tiles = region.tiles();
        let film = Mutex::new(Film::for_region(200, 150, region, &output));
        for &k in restored {
            paint(&mut film.lock().unwrap(), &tiles[k]);
        }
        let todo: Vec<Region> = (0..tiles.len())
            .map(|k| (k * stride) % tiles.len())
            .filter(|k| !restored.contains(k))
            .map(|k| tiles[k])
            .collect();
        let mut stream = BlockStream::new(&film.lock().unwrap(), &options, &path, &todo);
        stream.budget = budget;
        for tile in &todo {
            paint(&mut film.lock().unwrap(), tile);
            stream.tile_done(tile, &film);
        }
        let kept = stream.kept();
        let scratch_files = std::fs::read_dir(&dir).unwrap().count();
        assert_eq!(scratch_files, usize::from(kept.1 > 0), "a scratch file only for blocks beyond the budget");
        let film = film.into_inner().unwrap();
        let staged = stream.stage(&film, &options, &path, 2).unwrap();
        crate::sys::atomic::commit_all(vec![staged]).unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), super::super::exr::encode(&film, &options, 1).unwrap());
        let left: Vec<_> = std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().file_name()).collect();
        assert_eq!(left, ["out.exr"], "the scratch file is gone");
        std::fs::remove_dir_all(&dir).unwrap();
        kept
    }

    /// Streams with the default options, then writes with `half`: the file is the plain
    /// encoder's with `half`. Returns how many blocks had been kept (and were not used).
    fn check_other_layout_at_the_end(region: Region) -> usize {
        let output = OutputSpec { passes: PassSet::all(), ..Default::default() };
        let dir = std::env::temp_dir().join(format!("strahl-stream-half-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("out.exr");
        let tiles = region.tiles();
        let film = Mutex::new(Film::for_region(200, 150, region, &output));
        let stream = BlockStream::new(&film.lock().unwrap(), &ExrOptions::default(), &path, &tiles);
        for tile in &tiles {
            paint(&mut film.lock().unwrap(), tile);
            stream.tile_done(tile, &film);
        }
        let kept = stream.kept().0;
        let film = film.into_inner().unwrap();
        let half = ExrOptions { half: true, ..Default::default() };
        crate::sys::atomic::commit_all(vec![stream.stage(&film, &half, &path, 1).unwrap()]).unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), super::super::exr::encode(&film, &half, 1).unwrap());
        std::fs::remove_dir_all(&dir).unwrap();
        kept
    }

    #[test]
    fn the_streamed_file_is_the_plain_encoders_in_any_tile_order() {
        // 150 lines: ten 16-line blocks (the last short); tiles not aligned to the blocks.
        let full = Region::full(200, 150);
        let count = 150usize.div_ceil(16);
        let all = usize::MAX;
        assert_eq!(check(full, Compression::Zip, &[], 1, all), (count, 0), "every block compressed while rendering");
        assert_eq!(check(full, Compression::Zip, &[], 7, all), (count, 0));
        assert_eq!(check(full, Compression::Zips, &[], 5, all), (150, 0));
        // Beyond the budget, blocks go to the scratch file; none in memory, or some.
        assert_eq!(check(full, Compression::Zip, &[], 7, 0), (0, count));
        let (in_memory, in_scratch) = check(full, Compression::Zip, &[], 7, 100_000);
        assert!(in_memory > 0 && in_scratch > 0 && in_memory + in_scratch == count, "{in_memory} {in_scratch}");
        // A region whose data window starts off the tile grid and off the block grid.
        let region = Region { x0: 13, y0: 21, x1: 170, y1: 140 };
        assert_eq!(check(region, Compression::Zip, &[], 3, all), (119usize.div_ceil(16), 0));
        // Resumed: the restored tiles' blocks that no rendered tile touches are compressed at
        // the end, the others while rendering; the bytes are the same. The first row of
        // 16-pixel tiles is block 0 whole; half the second row is part of block 1.
        let restored: Vec<usize> = (0..13 + 6).collect();
        assert_eq!(check(full, Compression::Zip, &restored, 1, all), (count - 1, 0));
        // Other compressions are written at the end, as before.
        assert_eq!(check(full, Compression::Piz, &[], 1, all), (0, 0));
        // Blocks kept for one layout are not used for another.
        assert_eq!(check_other_layout_at_the_end(full), count);
    }
}
