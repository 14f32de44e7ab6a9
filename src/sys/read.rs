//! Reading input files (scenes, meshes, MTL libraries) so that no input can hang strahl or
//! exhaust memory. The rules:
//!
//! - **Only regular files are read.** The path is `stat`ed first (following symlinks) and a
//!   FIFO, device (`/dev/zero`, `/dev/urandom`), socket or directory is refused before it is
//!   opened: opening a FIFO blocks until a writer appears, and a device never ends.
//! - **Reads are bounded**: at most `limit` bytes are read whatever the file claims (a regular
//!   file can grow while it is read, and `/proc` files report a size of 0); a file over the
//!   limit is refused, never truncated. Scenes: [`MAX_SCENE_BYTES`] (32 MiB, as parsing TOML
//!   takes about 40 bytes of memory per byte of inline geometry). Meshes and MTL
//!   libraries: [`max_mesh_bytes`], 4 GiB unless the environment variable
//!   [`MAX_MESH_BYTES_ENV`] (`STRAHL_MAX_MESH_BYTES`, a number of bytes) says otherwise.
//! - **gzip is inflated through a bounded reader**: the inflated bytes may not exceed
//!   [`gzip_limit`] = `min(cap, max(ISIZE, 16 × compressed size))`, where ISIZE is the
//!   uncompressed size (mod 2³²) the gzip trailer declares and `cap` the mesh limit. A file that
//!   inflates past that is refused as soon as it does, so a 4 MB `.ply.gz` that inflates to
//!   4 GiB costs at most 64 MB and a fraction of a second. The `16 ×` allowance covers the
//!   multi-member files (`bgzip`) whose last member's ISIZE does not describe the whole.
//!
//! - **Every file read is remembered** ([`inputs_read`]): scenes, meshes, MTL libraries,
//!   textures and glTF buffers all come through [`read_regular`] (or [`note_input`]), so that
//!   `strahl render` can refuse an output path that is any of them.
//!
//! Hand-written over `std::fs` and `flate2` because the rules are strahl's own; the
//! decompression itself is `flate2`'s.

use std::fs::File;
use std::io::Read;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// The files read as input so far in this process, in the order they were first read.
static INPUTS: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

/// Remembers `path` as an input of this process (see [`inputs_read`]).
pub fn note_input(path: &Path) {
    let mut inputs = INPUTS.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
    if !inputs.iter().any(|p| p == path) {
        inputs.push(path.to_path_buf());
    }
}

/// Every file this process has read as input (scene, meshes, MTL libraries, textures, glTF
/// buffers and images), as the paths it opened them by.
pub fn inputs_read() -> Vec<PathBuf> {
    INPUTS.lock().unwrap_or_else(|poisoned| poisoned.into_inner()).clone()
}

/// Largest scene file read, in bytes (32 MiB): far beyond any hand-written TOML, and bounding
/// the parse's memory. The TOML document is built whole before strahl sees a value, at about
/// 40 bytes per byte of inline `triangles` (a 14 MB scene of 300,000 inline triangles: 547 MB
/// RSS; 200 MB took 6.3 GB), so this keeps a scene's parse near 1.3 GB at most. Large geometry
/// belongs in a mesh file, which is read in a compact form.
pub const MAX_SCENE_BYTES: u64 = 32 << 20;
/// What a scene over [`MAX_SCENE_BYTES`] is told.
pub const SCENE_TOO_LARGE_HINT: &str =
    "; put large geometry in a file of its own (an OBJ or PLY `mesh` object, a `gltf` object)";
/// Default largest mesh or MTL file, after decompression, in bytes (4 GiB).
pub const DEFAULT_MAX_MESH_BYTES: u64 = 4 << 30;
/// The environment variable that overrides [`DEFAULT_MAX_MESH_BYTES`] (a number of bytes).
pub const MAX_MESH_BYTES_ENV: &str = "STRAHL_MAX_MESH_BYTES";
/// Inflated bytes allowed per compressed byte when the gzip trailer's ISIZE is smaller.
pub const GZIP_RATIO_ALLOWANCE: u64 = 16;

/// Why an input file could not be read. Displays as the problem alone: the caller names the
/// file.
#[derive(Debug, thiserror::Error)]
pub enum ReadError {
    /// The operating system's error (not found, permission denied, …).
    #[error("{0}")]
    Io(std::io::Error),
    /// The path names something other than a regular file.
    #[error("not a regular file (a {0}): only regular files are read")]
    NotRegular(&'static str),
    /// The file is larger than the limit for its kind.
    #[error("{size_bytes} bytes is more than the limit of {limit_bytes} bytes{hint}")]
    TooLarge { size_bytes: u64, limit_bytes: u64, hint: &'static str },
    /// The gzip data is corrupt.
    #[error("corrupt gzip data: {0}")]
    Gzip(std::io::Error),
    /// The gzip data inflates to more than the limit.
    #[error(
        "gzip data inflates to more than {limit_bytes} bytes ({compressed_bytes} compressed, {declared_bytes} declared \
         in its trailer); refused as a decompression bomb (set {MAX_MESH_BYTES_ENV} to raise the limit for a genuinely \
         huge mesh)"
    )]
    GzipTooLarge { limit_bytes: u64, compressed_bytes: u64, declared_bytes: u64 },
    /// The environment variable that sets the mesh limit is not a number of bytes.
    #[error("{MAX_MESH_BYTES_ENV}={0:?} is not a number of bytes")]
    BadLimit(String),
}

/// Hint appended to a mesh file's [`ReadError::TooLarge`].
pub const MESH_LIMIT_HINT: &str = " (set STRAHL_MAX_MESH_BYTES to raise it)";

/// The largest mesh or MTL file read, in bytes: [`MAX_MESH_BYTES_ENV`] if set, else
/// [`DEFAULT_MAX_MESH_BYTES`].
pub fn max_mesh_bytes() -> Result<u64, ReadError> {
    match std::env::var(MAX_MESH_BYTES_ENV) {
        Ok(v) => v.trim().parse().map_err(|_| ReadError::BadLimit(v)),
        Err(std::env::VarError::NotPresent) => Ok(DEFAULT_MAX_MESH_BYTES),
        Err(std::env::VarError::NotUnicode(v)) => Err(ReadError::BadLimit(v.to_string_lossy().into_owned())),
    }
}

/// What kind of thing a non-regular file is, for messages.
fn kind(file_type: std::fs::FileType) -> &'static str {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if file_type.is_fifo() {
            return "FIFO";
        } else if file_type.is_char_device() {
            return "character device";
        } else if file_type.is_block_device() {
            return "block device";
        } else if file_type.is_socket() {
            return "socket";
        }
    }
    if file_type.is_dir() { "directory" } else { "special file" }
}

/// The regular file at `path`, opened, and its length (no larger than `limit_bytes`; `hint`
/// is appended to the message of a file over it). Refuses anything but a regular file before
/// opening it, and checks again what was opened (the path may have been replaced between).
pub fn open_regular(path: &Path, limit_bytes: u64, hint: &'static str) -> Result<(File, u64), ReadError> {
    let meta = std::fs::metadata(path).map_err(ReadError::Io)?;
    if !meta.is_file() {
        return Err(ReadError::NotRegular(kind(meta.file_type())));
    }
    if meta.len() > limit_bytes {
        return Err(ReadError::TooLarge { size_bytes: meta.len(), limit_bytes, hint });
    }
    let file = File::open(path).map_err(ReadError::Io)?;
    let meta = file.metadata().map_err(ReadError::Io)?;
    if !meta.is_file() {
        return Err(ReadError::NotRegular(kind(meta.file_type())));
    }
    Ok((file, meta.len()))
}

/// The bytes of the regular file at `path`, at most `limit_bytes` of them (`hint` is appended
/// to the message of a file over the limit), opened by [`open_regular`] and remembered as an
/// input.
pub fn read_regular(path: &Path, limit_bytes: u64, hint: &'static str) -> Result<Vec<u8>, ReadError> {
    let (file, length) = open_regular(path, limit_bytes, hint)?;
    note_input(path);
    let mut data = Vec::with_capacity(length.min(limit_bytes) as usize);
    file.take(limit_bytes.saturating_add(1)).read_to_end(&mut data).map_err(ReadError::Io)?;
    if data.len() as u64 > limit_bytes {
        return Err(ReadError::TooLarge { size_bytes: data.len() as u64, limit_bytes, hint });
    }
    Ok(data)
}

/// Whether `data` starts with the gzip magic number.
pub fn is_gzip(data: &[u8]) -> bool {
    data.starts_with(&[0x1f, 0x8b])
}

/// The uncompressed size (mod 2³²) the gzip trailer of `data` declares (its last 4 bytes).
fn declared_size(data: &[u8]) -> u64 {
    match data.len().checked_sub(4) {
        Some(start) if data.len() >= 18 => u32::from_le_bytes(data[start..].try_into().expect("4 bytes")) as u64,
        _ => 0,
    }
}

/// The most bytes the gzip `data` may inflate to: `min(cap, max(ISIZE, 16 × data.len()))`.
pub fn gzip_limit(data: &[u8], cap_bytes: u64) -> u64 {
    let by_ratio = (data.len() as u64).saturating_mul(GZIP_RATIO_ALLOWANCE);
    cap_bytes.min(declared_size(data).max(by_ratio))
}

/// Inflates the gzip `data` (all its members), refusing it once it passes
/// [`gzip_limit`]`(data, cap_bytes)`.
pub fn inflate(data: &[u8], cap_bytes: u64) -> Result<Vec<u8>, ReadError> {
    let limit_bytes = gzip_limit(data, cap_bytes);
    let declared = declared_size(data);
    let mut out = Vec::with_capacity(declared.min(limit_bytes).min(1 << 30) as usize);
    flate2::read::MultiGzDecoder::new(data)
        .take(limit_bytes.saturating_add(1))
        .read_to_end(&mut out)
        .map_err(ReadError::Gzip)?;
    if out.len() as u64 > limit_bytes {
        return Err(ReadError::GzipTooLarge {
            limit_bytes,
            compressed_bytes: data.len() as u64,
            declared_bytes: declared,
        });
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Write;

    fn gzip(data: &[u8]) -> Vec<u8> {
        let mut e = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
        e.write_all(data).unwrap();
        e.finish().unwrap()
    }

    #[test]
    fn gzip_round_trips_within_its_declared_size() {
        // Mesh-like text: numbers that vary, compressing about 3:1 as real meshes do.
        let text: Vec<u8> = (0..10_000u64)
            .flat_map(|i| format!("v {} {} 0\n", i * 7919 % 10007, i * 104729 % 1009).into_bytes())
            .collect();
        let z = gzip(&text);
        assert_eq!(declared_size(&z), text.len() as u64);
        assert_eq!(inflate(&z, DEFAULT_MAX_MESH_BYTES).unwrap(), text);
        // Two members (bgzip): the last member's ISIZE is small, the 16× allowance covers it.
        let mut two = z.clone();
        two.extend(gzip(b"v 1 1 1\n"));
        assert_eq!(inflate(&two, DEFAULT_MAX_MESH_BYTES).unwrap().len(), text.len() + 8);
    }

    #[test]
    fn gzip_over_its_limit_is_refused() {
        let zeros = vec![0u8; 1 << 20];
        let z = gzip(&zeros);
        // A trailer that lies: it declares 100 bytes.
        let mut lying = z.clone();
        let n = lying.len();
        lying[n - 4..].copy_from_slice(&100u32.to_le_bytes());
        let limit = gzip_limit(&lying, DEFAULT_MAX_MESH_BYTES);
        assert_eq!(limit, 16 * lying.len() as u64);
        assert!(limit < zeros.len() as u64, "1 MiB of zeros compresses more than 16:1");
        let e = inflate(&lying, DEFAULT_MAX_MESH_BYTES).unwrap_err();
        assert!(matches!(e, ReadError::GzipTooLarge { .. }), "{e}");
        // An honest trailer, but a cap below the size.
        let e = inflate(&z, 1000).unwrap_err();
        assert!(e.to_string().starts_with("gzip data inflates to more than 1000 bytes"), "{e}");
        assert!(matches!(inflate(&z[..z.len() - 9], 1 << 30), Err(ReadError::Gzip(_))));
    }

    #[test]
    fn only_regular_files_within_the_limit_are_read() {
        let e = read_regular(Path::new("/dev/zero"), 10, "").unwrap_err();
        assert_eq!(e.to_string(), "not a regular file (a character device): only regular files are read");
        let e = read_regular(Path::new("/"), 10, "").unwrap_err();
        assert!(matches!(e, ReadError::NotRegular("directory")));
        let e = read_regular(Path::new("Cargo.toml"), 10, " (hint)").unwrap_err();
        assert!(e.to_string().ends_with("is more than the limit of 10 bytes (hint)"), "{e}");
        assert!(read_regular(Path::new("Cargo.toml"), 1 << 20, "").unwrap().starts_with(b"[package]"));
        // A /proc file says it has 0 bytes; the read is bounded all the same.
        let e = read_regular(Path::new("/proc/self/maps"), 16, "").unwrap_err();
        assert!(matches!(e, ReadError::TooLarge { size_bytes: 17, limit_bytes: 16, .. }), "{e}");
    }
}
