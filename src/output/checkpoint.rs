//! Checkpoints: the finished tiles of a render saved beside its output, so that a render
//! stopped at any moment (a kill, a preempted farm node) continues where it was with
//! `--resume` and ends in the same bytes as an uninterrupted render.
//!
//! **The rule.** A tile's pixels are final once the tile is finished (each pixel is written by
//! one tile, from its own samples), so a checkpoint is the list of finished tiles (indices
//! into [`Region::tiles`] of the rendered region) and their pixels: every float of every pass
//! of the film, bit for bit. Resuming copies them back into an empty film and traces only the
//! other tiles; the film, hence the EXR, is then identical. The file is written atomically
//! (temporary file, then rename), so a kill at any moment leaves the previous or the new
//! checkpoint whole.
//!
//! **Identity.** A checkpoint carries a key: strahl's version, the scene/settings hash
//! ([`crate::scene::hash`]), the region, the tile size and the backend. A checkpoint with
//! another key (another scene, other settings, an edited scene file, another strahl:
//! [`Problem::Other`]) cannot be resumed, nor can a damaged one (not a checkpoint, another
//! format version, its FNV-1a checksum, the layout of its floats: [`Problem::Damaged`]). Neither
//! may stop a farm's retries until a person comes: the render moves it aside ([`aside`]) and
//! starts from nothing, saying so in one line. A checkpoint that cannot be read at all (no
//! permission, an I/O error: [`Problem::Unreadable`]) stops the render, as it may be fine.
//!
//! **Format** (little-endian), hand-written because it holds raw film floats that only strahl
//! reads back and that must round-trip exactly, of a partial frame:
//!
//! ```text
//! "STRAHLCK"  u32 version (1)  u32 key length  key (UTF-8)
//! u32 tiles in the region  u32 floats per pixel  u32 finished tiles  u32 index × finished
//! for each finished tile, for each film buffer (Film::buffers order): its pixels row by row,
//!   floats_per_pixel f32 each
//! u64 FNV-1a of everything before
//! ```

use std::io::{self, Read, Write};
use std::path::{Path, PathBuf};
use std::sync::Mutex;

use crate::output::film::Film;
use crate::output::region::{Region, TILE_SIZE};
use crate::scene::Scene;
use crate::scene::hash::{Fnv1a, scene_hash_hex};
use crate::sys::read::open_regular;

const MAGIC: &[u8; 8] = b"STRAHLCK";
const VERSION: u32 = 1;

/// Why a checkpoint cannot be used: one line naming the file.
#[derive(Debug, thiserror::Error)]
#[error("{}: {problem}", path.display())]
pub struct CheckpointError {
    pub path: PathBuf,
    pub kind: Problem,
    pub problem: String,
}

/// What is wrong with a checkpoint (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Problem {
    /// It could not be read (it may be whole).
    Unreadable,
    /// Not a checkpoint, another format version, or its bytes are wrong.
    Damaged,
    /// A whole checkpoint of another render.
    Other,
}

/// Where a checkpoint with `problem` (not [`Problem::Unreadable`]) is moved aside:
/// `OUT.exr.checkpoint.damaged`, or `OUT.exr.checkpoint.other` for one of another render (kept,
/// so that going back to its settings can resume it by renaming it back). One of each at most:
/// the next replaces it, so that a task retried again and again does not fill the disk (a
/// checkpoint of a 16384² frame is 12 GB).
pub fn aside(checkpoint: &Path, problem: Problem) -> PathBuf {
    let mut name = checkpoint.as_os_str().to_owned();
    name.push(if problem == Problem::Other { ".other" } else { ".damaged" });
    PathBuf::from(name)
}

/// The checkpoint of the render writing `output`: `output` with `.checkpoint` appended.
pub fn path_for(output: &Path) -> PathBuf {
    let mut name = output.as_os_str().to_owned();
    name.push(".checkpoint");
    PathBuf::from(name)
}

/// The key of a render of `region` of `scene` with `backend` (see the module docs).
pub fn key(scene: &Scene, region: Region, backend: &str) -> String {
    format!(
        "strahl {} scene {} region {region} tile {TILE_SIZE} backend {backend}",
        env!("CARGO_PKG_VERSION"),
        scene_hash_hex(scene)
    )
}

/// Writes the checkpoint of the tiles `done` (indices into `tiles`) of `film` to `out`, as it
/// goes: a checkpoint of a 16384² frame is 12 GB, which must not be built in memory beside the
/// film, nor written with the film locked (the tiles still rendering would wait for the disk).
/// Finished tiles do not change, so the film is locked only while a batch of about
/// [`BATCH_BYTES`] of them is copied out.
pub fn write_to(
    film: &Mutex<Film>,
    tiles: &[Region],
    done: &[usize],
    key: &str,
    out: &mut impl Write,
) -> io::Result<()> {
    let lock = || film.lock().unwrap_or_else(|p| p.into_inner());
    let floats: usize = lock().buffers().iter().map(|(_, n)| n).sum();
    let mut out = Hashing { inner: out, hash: Fnv1a::default() };
    out.write_all(MAGIC)?;
    for v in [VERSION, key.len() as u32] {
        out.write_all(&v.to_le_bytes())?;
    }
    out.write_all(key.as_bytes())?;
    for v in [tiles.len() as u32, floats as u32, done.len() as u32] {
        out.write_all(&v.to_le_bytes())?;
    }
    for &k in done {
        out.write_all(&(k as u32).to_le_bytes())?;
    }
    let mut batch = Vec::new();
    let mut rest = done;
    while !rest.is_empty() {
        batch.clear();
        let film = lock();
        let buffers = film.buffers();
        while let Some((&k, tail)) = rest.split_first() {
            if batch.len() >= BATCH_BYTES {
                break;
            }
            rest = tail;
            let t = tiles[k];
            for (data, n) in &buffers {
                for y in t.y0..t.y1 {
                    let start = film.index(t.x0, y) * n;
                    batch.extend(data[start..start + t.width() as usize * n].iter().flat_map(|v| v.to_le_bytes()));
                }
            }
        }
        drop(buffers);
        drop(film);
        out.write_all(&batch)?;
    }
    let sum = out.hash.value();
    out.inner.write_all(&sum.to_le_bytes())
}

/// How many bytes of tiles [`write_to`] copies out of the film per lock.
pub const BATCH_BYTES: usize = 32 << 20;

/// A writer that hashes what passes through it.
struct Hashing<'a, W: Write> {
    inner: &'a mut W,
    hash: Fnv1a,
}

impl<W: Write> Write for Hashing<'_, W> {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        let n = self.inner.write(buf)?;
        self.hash.bytes(&buf[..n]);
        Ok(n)
    }
    fn flush(&mut self) -> io::Result<()> {
        self.inner.flush()
    }
}

/// Reads the checkpoint at `path` of a render with `key` over `tiles` into `film` (an empty
/// film of the render's region and passes) and returns the finished tiles' indices. The file
/// is read as it goes, never whole in memory; its checksum is compared at the end, so a
/// damaged file may have filled part of `film` when it is refused.
pub fn read_into(path: &Path, key: &str, tiles: &[Region], film: &mut Film) -> Result<Vec<usize>, CheckpointError> {
    // Only a regular file (opening a FIFO would wait for a writer); any size, as it is streamed.
    let (file, length) = open_regular(path, u64::MAX, "").map_err(|e| CheckpointError {
        path: path.to_path_buf(),
        kind: Problem::Unreadable,
        problem: format!("cannot read the checkpoint: {e}"),
    })?;
    read_from(io::BufReader::with_capacity(1 << 20, file), length, path, key, tiles, film)
}

/// [`read_into`] from the `length` bytes of `source`, named `path` in errors (the fuzz
/// target `checkpoint` reads from memory).
pub fn read_from(
    source: impl Read,
    length: u64,
    path: &Path,
    key: &str,
    tiles: &[Region],
    film: &mut Film,
) -> Result<Vec<usize>, CheckpointError> {
    let err = |kind: Problem, problem: String| CheckpointError { path: path.to_path_buf(), kind, problem };
    let damaged = |what: &str| err(Problem::Damaged, format!("a damaged checkpoint ({what})"));
    let mut r = Reader { inner: source, hash: Fnv1a::default(), at: 0 };
    let mut magic = [0u8; 8];
    if length < MAGIC.len() as u64 + 8 || r.fill(&mut magic).is_none() || &magic != MAGIC {
        return Err(err(Problem::Damaged, "is not a strahl checkpoint".into()));
    }
    // Everything but the trailing checksum.
    let body = length - 8;
    let early = || damaged("it ends early");
    let version = r.u32(body).ok_or_else(early)?;
    if version != VERSION {
        return Err(err(Problem::Damaged, format!("checkpoint format {version}, this strahl reads {VERSION}")));
    }
    let key_len = r.u32(body).ok_or_else(early)? as usize;
    if key_len as u64 > body - r.at {
        return Err(early());
    }
    let mut theirs = vec![0u8; key_len];
    r.fill(&mut theirs).ok_or_else(early)?;
    let theirs = String::from_utf8_lossy(&theirs);
    if theirs != key {
        return Err(err(Problem::Other, format!("a checkpoint of another render ({theirs}), not of this one ({key})")));
    }
    let mut next = || r.u32(body).map(|v| v as usize).ok_or_else(early);
    let (tile_count, floats, count) = (next()?, next()?, next()?);
    let floats_here: usize = film.buffers().iter().map(|(_, n)| n).sum();
    if tile_count != tiles.len() || floats != floats_here || count > tile_count {
        return Err(damaged("its tiles or passes do not fit the render"));
    }
    let mut done = Vec::with_capacity(count);
    let mut seen = vec![false; tile_count];
    for _ in 0..count {
        let k = next()?;
        if k >= tile_count || std::mem::replace(&mut seen[k], true) {
            return Err(damaged("a tile index is out of range or repeated"));
        }
        done.push(k);
    }
    // The tiles' floats must be exactly what is left before the checksum.
    let pixels: u64 = done.iter().map(|&k| tiles[k].pixel_count()).sum();
    if pixels * floats as u64 * 4 != body - r.at {
        return Err(damaged(if pixels * floats as u64 * 4 > body - r.at {
            "it ends early"
        } else {
            "it has bytes beyond its tiles"
        }));
    }
    // The film index of each finished tile's first pixel and its row stride.
    let firsts: Vec<usize> = done.iter().map(|&k| film.index(tiles[k].x0, tiles[k].y0)).collect();
    let stride = film.width as usize;
    let mut buffers = film.buffers_mut();
    let mut bytes = Vec::new();
    for (&k, &first) in done.iter().zip(&firsts) {
        let (w, h) = (tiles[k].width() as usize, tiles[k].height() as usize);
        for (data, n) in buffers.iter_mut() {
            for row in 0..h {
                let start = (first + row * stride) * *n;
                bytes.resize(4 * w * *n, 0);
                r.fill(&mut bytes).ok_or_else(early)?;
                for (dst, v) in data[start..start + w * *n].iter_mut().zip(bytes.chunks_exact(4)) {
                    *dst = f32::from_le_bytes([v[0], v[1], v[2], v[3]]);
                }
            }
        }
    }
    let mut sum = [0u8; 8];
    let expected = r.hash.value();
    r.inner.read_exact(&mut sum).map_err(|_| early())?;
    if u64::from_le_bytes(sum) != expected {
        return Err(damaged("its checksum does not match"));
    }
    Ok(done)
}

/// Reads a checkpoint's fields in order, hashing them; `None` past the end.
struct Reader<R: Read> {
    inner: R,
    hash: Fnv1a,
    /// Bytes read so far.
    at: u64,
}

impl<R: Read> Reader<R> {
    fn fill(&mut self, buf: &mut [u8]) -> Option<()> {
        self.inner.read_exact(buf).ok()?;
        self.hash.bytes(buf);
        self.at += buf.len() as u64;
        Some(())
    }

    /// The next u32, if it ends before `end`.
    fn u32(&mut self, end: u64) -> Option<u32> {
        if self.at + 4 > end {
            return None;
        }
        let mut v = [0u8; 4];
        self.fill(&mut v)?;
        Some(u32::from_le_bytes(v))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::output::passes::{OutputSpec, PassSet};

    /// A 20 × 20 region's film (4 tiles, 3 partial) with every pass, filled with distinct
    /// values, its tiles, and the checkpoint of tiles 1, 2 and 3 of it.
    fn saved() -> (Vec<Region>, Film, Vec<u8>) {
        let region = Region::parse("8,4,28,24").unwrap();
        let output = OutputSpec { passes: PassSet::all(), transparent: false, crypto_levels: 2 };
        let mut film = Film::for_region(64, 32, region, &output);
        for (data, _) in film.buffers_mut() {
            for (i, v) in data.iter_mut().enumerate() {
                *v = i as f32 * 0.25 - 3.0;
            }
        }
        let tiles = region.tiles();
        let mut bytes = Vec::new();
        write_to(&Mutex::new(film.clone()), &tiles, &[1, 2, 3], "k", &mut bytes).unwrap();
        (tiles, film, bytes)
    }

    fn read(bytes: &[u8], tiles: &[Region], film: &mut Film) -> Result<Vec<usize>, CheckpointError> {
        read_from(bytes, bytes.len() as u64, Path::new("c"), "k", tiles, film)
    }

    #[test]
    fn a_checkpoint_reads_back_bit_for_bit() {
        let (tiles, film, bytes) = saved();
        let output = OutputSpec { passes: PassSet::all(), transparent: false, crypto_levels: 2 };
        let mut back = Film::for_region(64, 32, film.region(), &output);
        assert_eq!(read(&bytes, &tiles, &mut back).unwrap(), [1, 2, 3]);
        for ((a, n), (b, _)) in film.buffers().iter().zip(back.buffers()) {
            for &k in &[1usize, 2, 3] {
                let t = tiles[k];
                for y in t.y0..t.y1 {
                    let s = film.index(t.x0, y) * n;
                    let e = s + t.width() as usize * n;
                    assert!(a[s..e].iter().zip(&b[s..e]).all(|(x, y)| x.to_bits() == y.to_bits()));
                }
            }
        }
    }

    /// Every cut and every single changed byte of a checkpoint is refused as damaged (or, in
    /// the key or its length, as another render's), never a panic.
    #[test]
    fn every_cut_and_every_changed_byte_is_refused() {
        let (tiles, film, bytes) = saved();
        let mut scratch = film.clone();
        for cut in 0..bytes.len() {
            let e = read(&bytes[..cut], &tiles, &mut scratch).unwrap_err();
            assert_eq!(e.kind, Problem::Damaged, "cut at {cut}: {e}");
        }
        let key_at = 12..17;
        for at in (0..bytes.len()).step_by(7).chain(bytes.len() - 8..bytes.len()) {
            for flip in [0x01u8, 0x80, 0xff] {
                let mut bad = bytes.clone();
                bad[at] ^= flip;
                let e = read(&bad, &tiles, &mut scratch).unwrap_err();
                let other = e.kind == Problem::Other && key_at.contains(&at);
                assert!(e.kind == Problem::Damaged || other, "byte {at} ^ {flip:#x}: {e}");
            }
        }
    }
}
