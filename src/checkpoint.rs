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
//! another key (another scene, other settings, an edited scene file: stale) is refused, as is a
//! damaged one (its FNV-1a checksum, the layout of its floats).
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

use std::path::{Path, PathBuf};

use crate::film::Film;
use crate::region::{Region, TILE_SIZE};
use crate::scene::Scene;
use crate::scene::hash::{fnv1a, scene_hash_hex};

const MAGIC: &[u8; 8] = b"STRAHLCK";
const VERSION: u32 = 1;

/// Why a checkpoint cannot be used: one line naming the file.
#[derive(Debug, thiserror::Error)]
#[error("{}: {problem}", path.display())]
pub struct CheckpointError {
    pub path: PathBuf,
    pub problem: String,
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

/// The checkpoint bytes of the tiles `done` (indices into `tiles`) of `film`.
pub fn encode(film: &Film, tiles: &[Region], done: &[usize], key: &str) -> Vec<u8> {
    let buffers = film.buffers();
    let floats: usize = buffers.iter().map(|(_, n)| n).sum();
    let mut out = Vec::new();
    out.extend_from_slice(MAGIC);
    for v in [VERSION, key.len() as u32] {
        out.extend_from_slice(&v.to_le_bytes());
    }
    out.extend_from_slice(key.as_bytes());
    for v in [tiles.len() as u32, floats as u32, done.len() as u32] {
        out.extend_from_slice(&v.to_le_bytes());
    }
    for &k in done {
        out.extend_from_slice(&(k as u32).to_le_bytes());
    }
    for &k in done {
        let t = tiles[k];
        for (data, n) in &buffers {
            for y in t.y0..t.y1 {
                let start = film.index(t.x0, y) * n;
                for v in &data[start..start + t.width() as usize * n] {
                    out.extend_from_slice(&v.to_le_bytes());
                }
            }
        }
    }
    let sum = fnv1a(&out);
    out.extend_from_slice(&sum.to_le_bytes());
    out
}

/// Reads the checkpoint `bytes` (from `path`) of a render with `key` over `tiles` into `film`
/// (an empty film of the render's region and passes) and returns the finished tiles' indices.
pub fn decode_into(
    bytes: &[u8],
    path: &Path,
    key: &str,
    tiles: &[Region],
    film: &mut Film,
) -> Result<Vec<usize>, CheckpointError> {
    let err = |problem: String| CheckpointError { path: path.to_path_buf(), problem };
    let damaged = |what: &str| err(format!("a damaged checkpoint ({what}); delete it to render from the start"));
    if bytes.len() < MAGIC.len() + 8 || &bytes[..8] != MAGIC {
        return Err(err("is not a strahl checkpoint".into()));
    }
    let (body, sum) = bytes.split_at(bytes.len() - 8);
    if fnv1a(body).to_le_bytes() != sum {
        return Err(damaged("its checksum does not match"));
    }
    let mut r = Reader { bytes: body, at: 8 };
    let early = || damaged("it ends early");
    let version = r.u32().ok_or_else(early)?;
    if version != VERSION {
        return Err(err(format!("checkpoint format {version}, this strahl reads {VERSION}")));
    }
    let key_len = r.u32().ok_or_else(early)? as usize;
    let theirs = String::from_utf8_lossy(r.take(key_len).ok_or_else(early)?);
    if theirs != key {
        return Err(err(format!(
            "a checkpoint of another render ({theirs}), not of this one ({key}); delete it or render without --resume"
        )));
    }
    let mut next = || r.u32().map(|v| v as usize).ok_or_else(early);
    let (tile_count, floats, count) = (next()?, next()?, next()?);
    let floats_here: usize = film.buffers().iter().map(|(_, n)| n).sum();
    if tile_count != tiles.len() || floats != floats_here || count > tile_count {
        return Err(damaged("its tiles or passes do not fit the render"));
    }
    let mut done = Vec::with_capacity(count);
    for _ in 0..count {
        let k = next()?;
        if k >= tile_count || done.contains(&k) {
            return Err(damaged("a tile index is out of range or repeated"));
        }
        done.push(k);
    }
    // The film index of each finished tile's rows, in the order the file lists them.
    let rows: Vec<(usize, usize)> = done
        .iter()
        .flat_map(|&k| {
            let t = tiles[k];
            (t.y0..t.y1).map(move |y| (t, y))
        })
        .map(|(t, y)| (film.index(t.x0, y), t.width() as usize))
        .collect();
    let mut buffers = film.buffers_mut();
    let mut row = 0;
    for &k in &done {
        let h = tiles[k].height() as usize;
        for (data, n) in buffers.iter_mut() {
            for &(start, w) in &rows[row..row + h] {
                let (start, len) = (start * *n, w * *n);
                let src = r.take(4 * len).ok_or_else(early)?;
                for (dst, v) in data[start..start + len].iter_mut().zip(src.chunks_exact(4)) {
                    *dst = f32::from_le_bytes([v[0], v[1], v[2], v[3]]);
                }
            }
        }
        row += h;
    }
    if r.at != body.len() {
        return Err(damaged("it has bytes beyond its tiles"));
    }
    Ok(done)
}

/// Reads a checkpoint's fields in order; `None` past its end.
struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl<'a> Reader<'a> {
    fn take(&mut self, n: usize) -> Option<&'a [u8]> {
        let v = self.bytes.get(self.at..self.at.checked_add(n)?)?;
        self.at += n;
        Some(v)
    }

    fn u32(&mut self) -> Option<u32> {
        self.take(4).map(|v| u32::from_le_bytes([v[0], v[1], v[2], v[3]]))
    }
}
