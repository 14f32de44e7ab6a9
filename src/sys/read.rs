//! Reading input files (scenes, meshes, MTL libraries, textures, glTF buffers and images) so
//! that no input can hang strahl, exhaust memory or reach outside what it was given. The rules:
//!
//! - **Only regular files are read.** The path is `stat`ed first (following symlinks) and a
//!   FIFO, device (`/dev/zero`, `/dev/urandom`), socket or directory is refused before it is
//!   opened: opening a FIFO blocks until a writer appears, and a device never ends. The open
//!   itself is non-blocking and what was opened is checked again (the path may have been
//!   replaced between).
//! - **Reads are bounded**: at most `limit` bytes are read whatever the file claims (a regular
//!   file can grow while it is read, and `/proc` files report a size of 0); a file over the
//!   limit is refused, never truncated. Scenes: [`MAX_SCENE_BYTES`] (32 MiB, as parsing TOML
//!   takes about 40 bytes of memory per byte of inline geometry). Meshes and MTL
//!   libraries: [`max_mesh_bytes`], 4 GiB unless the environment variable
//!   [`MAX_MESH_BYTES_ENV`] (`STRAHL_MAX_MESH_BYTES`, a number of bytes) says otherwise.
//! - **gzip is inflated twice, counted before it is kept**: a first pass inflates into nothing,
//!   counting, and stops past [`gzip_limit`] = `min(cap, max(ISIZE, 16 × compressed size))`,
//!   where ISIZE is the uncompressed size (mod 2³²) the gzip trailer declares and `cap` the
//!   mesh limit; only then is the counted size (never ISIZE) checked against the memory budget
//!   and allocated, and the data inflated into it. So a 4 MB `.ply.gz` of honest members that
//!   inflates to 4 GiB is refused after 64 MB of inflating, and one whose last trailer is
//!   forged to ISIZE 0xFFFFFFFF after at most `cap` inflated bytes, both in a few MB of
//!   memory. The `16 ×` allowance covers the multi-member files (`bgzip`) whose last member's
//!   ISIZE does not describe the whole.
//! - **The memory budget** ([`LoadOptions::max_memory`], `strahl render --max-memory`, else
//!   [`crate::sys::memory::default_limit`]) bounds every large allocation a load makes from what a
//!   file declares: a file read whole, gzip's inflated bytes, a texture's decoded texels
//!   ([`Held`]: counted while they live), a glTF file's meshes and instances. Each is checked
//!   against [`remaining_memory`] = budget − [`crate::sys::memory::BASE_BYTES`] − texels held,
//!   before it is allocated. The render's own estimate ([`crate::job::memory`]) checks the whole
//!   scene afterwards.
//! - **Confinement** ([`LoadOptions::confine`], `--confine DIR`): every input must resolve,
//!   after symlinks, inside the folder; the path is canonicalised before it is opened and the
//!   opened file's own path (`/proc/self/fd`) is checked again, so a symlink swapped in between
//!   does not escape. Checked here, in [`read_regular`] and [`note_input`], which every
//!   reader goes through, so no reader can bypass it.
//! - **Every file read is remembered** ([`inputs_read`]): scenes, meshes, MTL libraries,
//!   textures and glTF buffers all come through [`read_regular`] (or [`note_input`]), so that
//!   `strahl render` can refuse an output path that is any of them.
//!
//! The options are the process's, set once by the command ([`set_load_options`]) before it
//! loads a scene: a process loads one scene, and every reader, however deep, sees the same
//! options without each loader passing them on.
//!
//! Hand-written over `std::fs` and `flate2` because the rules are strahl's own; the
//! decompression itself is `flate2`'s.

use std::fs::File;
use std::io::Read;
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::sync::atomic::{AtomicU64, Ordering};

/// The files read as input so far in this process, in the order they were first read.
static INPUTS: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

/// What a scene load may read and allocate (see the module header).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct LoadOptions {
    /// The memory budget, bytes (`--max-memory`); `None`: [`crate::sys::memory::default_limit`].
    pub max_memory: Option<u64>,
    /// Every input must resolve inside this folder (`--confine`); canonical once set.
    pub confine: Option<PathBuf>,
}

/// This process's load options.
static OPTIONS: Mutex<LoadOptions> = Mutex::new(LoadOptions { max_memory: None, confine: None });

/// Sets the load options of this process (the folder of `confine` is canonicalised: it must
/// exist). Returns a one-line message naming the folder when it cannot be used.
pub fn set_load_options(mut options: LoadOptions) -> Result<(), String> {
    if let Some(dir) = &options.confine {
        let real = dir.canonicalize().map_err(|e| format!("--confine {}: {e}", dir.display()))?;
        if !real.is_dir() {
            return Err(format!("--confine {}: not a directory", dir.display()));
        }
        options.confine = Some(real);
    }
    *OPTIONS.lock().unwrap_or_else(|poisoned| poisoned.into_inner()) = options;
    Ok(())
}

/// This process's load options.
pub fn load_options() -> LoadOptions {
    OPTIONS.lock().unwrap_or_else(|poisoned| poisoned.into_inner()).clone()
}

/// Bytes of decoded inputs alive in this process (see [`Held`]).
static HELD_BYTES: AtomicU64 = AtomicU64::new(0);

/// The memory budget of a load: [`LoadOptions::max_memory`], else
/// [`crate::sys::memory::default_limit`]; `None` when neither is known.
pub fn memory_limit() -> Option<u64> {
    load_options().max_memory.or_else(|| crate::sys::memory::default_limit().map(|l| l.bytes))
}

/// Bytes a load may still allocate: the budget less [`crate::sys::memory::BASE_BYTES`] and the
/// decoded inputs alive ([`Held`]); `u64::MAX` without a budget.
pub fn remaining_memory() -> u64 {
    match memory_limit() {
        Some(limit) => {
            limit.saturating_sub(crate::sys::memory::BASE_BYTES).saturating_sub(HELD_BYTES.load(Ordering::Relaxed))
        }
        None => u64::MAX,
    }
}

/// Refuses an allocation of `bytes` (for `what`, e.g. `the inflated gzip data`) over
/// [`remaining_memory`].
pub fn check_memory(bytes: u64, what: impl Into<String>) -> Result<(), ReadError> {
    let remaining = remaining_memory();
    if bytes > remaining {
        return Err(ReadError::OverBudget { what: what.into(), bytes, remaining_bytes: remaining });
    }
    Ok(())
}

/// Memory a decoded input (a texture's texels) holds, counted against the budget from
/// [`Held::take`] until it is dropped.
#[derive(Debug)]
pub struct Held {
    bytes: u64,
}

impl Held {
    /// Counts `bytes` as held, if they fit in [`remaining_memory`] (checked and counted at
    /// once, so that loads on several threads cannot both take the last of the budget).
    pub fn take(bytes: u64, what: impl Into<String>) -> Result<Held, ReadError> {
        let budget = memory_limit().map(|l| l.saturating_sub(crate::sys::memory::BASE_BYTES));
        let taken = HELD_BYTES.fetch_update(Ordering::SeqCst, Ordering::SeqCst, |held| match budget {
            Some(b) if held.saturating_add(bytes) > b => None,
            _ => Some(held.saturating_add(bytes)),
        });
        match taken {
            Ok(_) => Ok(Held { bytes }),
            Err(held) => Err(ReadError::OverBudget {
                what: what.into(),
                bytes,
                remaining_bytes: budget.unwrap_or(u64::MAX).saturating_sub(held),
            }),
        }
    }

    /// Holds nothing (a value that describes an input without its data).
    pub fn nothing() -> Held {
        Held { bytes: 0 }
    }

    /// The bytes held.
    pub fn bytes(&self) -> u64 {
        self.bytes
    }
}

impl Clone for Held {
    /// A copy holds as much again (unchecked: the copy exists already).
    fn clone(&self) -> Held {
        HELD_BYTES.fetch_add(self.bytes, Ordering::SeqCst);
        Held { bytes: self.bytes }
    }
}

impl Drop for Held {
    fn drop(&mut self) {
        HELD_BYTES.fetch_sub(self.bytes, Ordering::SeqCst);
    }
}

impl PartialEq for Held {
    /// What is held is bookkeeping, not part of the value.
    fn eq(&self, _: &Held) -> bool {
        true
    }
}

/// Remembers `path` as an input of this process (see [`inputs_read`]), for a file read
/// earlier under another path (a texture shared by its canonical path): confined as
/// [`read_regular`] is.
pub fn note_input(path: &Path) -> Result<(), ReadError> {
    confined(path, &load_options())?;
    remember(path);
    Ok(())
}

fn remember(path: &Path) {
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
    /// An allocation the file asks for is over what is left of the memory budget.
    #[error(
        "{what} would take {bytes} bytes, more than the {remaining_bytes} bytes left of the memory budget \
         (--max-memory)"
    )]
    OverBudget { what: String, bytes: u64, remaining_bytes: u64 },
    /// The file resolves outside the folder reads are confined to.
    #[error("resolves to {}, outside {} (--confine): not read", real.display(), dir.display())]
    Outside { real: PathBuf, dir: PathBuf },
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
/// opening it, opens it without blocking, and checks again what was opened (the path may have
/// been replaced between). Not confined: for strahl's own files (checkpoints); a scene's
/// inputs are read by [`read_regular`].
pub fn open_regular(path: &Path, limit_bytes: u64, hint: &'static str) -> Result<(File, u64), ReadError> {
    let meta = std::fs::metadata(path).map_err(ReadError::Io)?;
    if !meta.is_file() {
        return Err(ReadError::NotRegular(kind(meta.file_type())));
    }
    if meta.len() > limit_bytes {
        return Err(ReadError::TooLarge { size_bytes: meta.len(), limit_bytes, hint });
    }
    let mut open = std::fs::OpenOptions::new();
    open.read(true);
    #[cfg(unix)]
    {
        // A FIFO swapped in after the `stat` must not block the open.
        use std::os::unix::fs::OpenOptionsExt;
        open.custom_flags(libc::O_NONBLOCK);
    }
    let file = open.open(path).map_err(ReadError::Io)?;
    let meta = file.metadata().map_err(ReadError::Io)?;
    if !meta.is_file() {
        return Err(ReadError::NotRegular(kind(meta.file_type())));
    }
    Ok((file, meta.len()))
}

/// The path to open for `path` under `options`: `path` itself, or with a confining folder its
/// canonical form, which must lie inside it.
fn confined(path: &Path, options: &LoadOptions) -> Result<PathBuf, ReadError> {
    let Some(dir) = &options.confine else { return Ok(path.to_path_buf()) };
    let real = path.canonicalize().map_err(ReadError::Io)?;
    if !real.starts_with(dir) {
        return Err(ReadError::Outside { real, dir: dir.clone() });
    }
    Ok(real)
}

/// Checks again, by the opened file's own path, that it lies in the confining folder: the
/// canonical path may have been made a symlink after it was resolved. Where the system does
/// not say (no `/proc`), the check before the open stands.
fn check_opened(file: &File, options: &LoadOptions) -> Result<(), ReadError> {
    let Some(dir) = &options.confine else { return Ok(()) };
    #[cfg(target_os = "linux")]
    {
        use std::os::fd::AsRawFd;
        if let Ok(real) = std::fs::read_link(format!("/proc/self/fd/{}", file.as_raw_fd())) {
            if !real.starts_with(dir) {
                return Err(ReadError::Outside { real, dir: dir.clone() });
            }
        }
    }
    let _ = file;
    Ok(())
}

/// The bytes of the regular file at `path`, at most `limit_bytes` of them (`hint` is appended
/// to the message of a file over the limit), opened by [`open_regular`], confined
/// ([`LoadOptions::confine`]), within the memory budget, and remembered as an input: how every
/// input of a scene is read.
pub fn read_regular(path: &Path, limit_bytes: u64, hint: &'static str) -> Result<Vec<u8>, ReadError> {
    read_regular_with(path, limit_bytes, hint, &load_options())
}

fn read_regular_with(
    path: &Path,
    limit_bytes: u64,
    hint: &'static str,
    options: &LoadOptions,
) -> Result<Vec<u8>, ReadError> {
    let real = confined(path, options)?;
    let (file, length) = open_regular(&real, limit_bytes, hint)?;
    check_opened(&file, options)?;
    check_memory(length, "the file")?;
    remember(path);
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
/// [`gzip_limit`]`(data, cap_bytes)`: counted first without keeping anything, then checked
/// against the memory budget, then inflated into exactly the counted size.
pub fn inflate(data: &[u8], cap_bytes: u64) -> Result<Vec<u8>, ReadError> {
    let limit_bytes = gzip_limit(data, cap_bytes);
    let declared = declared_size(data);
    let mut decoder = flate2::read::MultiGzDecoder::new(data).take(limit_bytes.saturating_add(1));
    let mut chunk = vec![0u8; 1 << 16];
    let mut size = 0u64;
    loop {
        match decoder.read(&mut chunk) {
            Ok(0) => break,
            Ok(n) => size += n as u64,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(ReadError::Gzip(e)),
        }
    }
    if size > limit_bytes {
        return Err(ReadError::GzipTooLarge {
            limit_bytes,
            compressed_bytes: data.len() as u64,
            declared_bytes: declared,
        });
    }
    check_memory(size, "the inflated gzip data")?;
    let mut out = Vec::with_capacity(size as usize);
    flate2::read::MultiGzDecoder::new(data).take(size).read_to_end(&mut out).map_err(ReadError::Gzip)?;
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

    #[test]
    fn a_forged_trailer_costs_inflating_not_memory() {
        // 8 MiB of zeros whose trailer claims 4 GiB − 1: the limit is the cap, and the count
        // finds the true size before anything is kept.
        let mut z = gzip(&vec![0u8; 8 << 20]);
        let n = z.len();
        z[n - 4..].copy_from_slice(&u32::MAX.to_le_bytes());
        assert_eq!(gzip_limit(&z, 1 << 20), 1 << 20);
        let e = inflate(&z, 1 << 20).unwrap_err();
        assert!(matches!(e, ReadError::GzipTooLarge { limit_bytes: 1_048_576, declared_bytes: 4294967295, .. }), "{e}");
        // Under a larger cap the count reaches the trailer, which does not match: corrupt,
        // found before anything was allocated for it.
        assert!(matches!(inflate(&z, 64 << 20), Err(ReadError::Gzip(_))));
    }

    #[test]
    fn confinement_resolves_symlinks_before_reading() {
        let dir = std::env::temp_dir().join(format!("strahl-confine-{}", std::process::id()));
        let inside = dir.join("inside");
        std::fs::create_dir_all(inside.join("sub")).unwrap();
        std::fs::write(inside.join("sub/a.txt"), "a").unwrap();
        std::fs::write(dir.join("outside.txt"), "secret").unwrap();
        std::os::unix::fs::symlink(dir.join("outside.txt"), inside.join("link.txt")).unwrap();
        std::os::unix::fs::symlink(inside.join("sub/a.txt"), inside.join("inner-link.txt")).unwrap();
        let options = LoadOptions { max_memory: None, confine: Some(inside.canonicalize().unwrap()) };
        let read = |p: &Path| read_regular_with(p, 1 << 20, "", &options);
        assert_eq!(read(&inside.join("sub/a.txt")).unwrap(), b"a");
        assert_eq!(read(&inside.join("sub/../inner-link.txt")).unwrap(), b"a");
        for escape in [inside.join("link.txt"), inside.join("../outside.txt"), inside.join("sub/../../outside.txt")] {
            let e = read(&escape).unwrap_err();
            assert!(matches!(&e, ReadError::Outside { real, .. } if real.ends_with("outside.txt")), "{escape:?}: {e}");
            assert!(e.to_string().ends_with("(--confine): not read"), "{e}");
        }
        assert!(matches!(read(&PathBuf::from("/etc/passwd")), Err(ReadError::Outside { .. })));
        // Unconfined, the same paths read.
        let free = LoadOptions::default();
        assert_eq!(read_regular_with(&inside.join("link.txt"), 1 << 20, "", &free).unwrap(), b"secret");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn held_memory_is_counted_while_it_lives() {
        let a = Held::take(1000, "a").unwrap();
        assert_eq!((a.bytes(), a.clone().bytes()), (1000, 1000));
        // More than any machine's budget is refused, naming what asked.
        let e = Held::take(u64::MAX / 2, "the decoded texels (1 × 1)").unwrap_err();
        assert!(e.to_string().starts_with("the decoded texels (1 × 1) would take 9223372036854775807 bytes"), "{e}");
    }
}
