//! Writing a file all at once or not at all: the bytes go to a temporary file in the
//! destination's directory, which is then renamed over the destination (atomic on one file
//! system). On any error the temporary file is removed and the destination is untouched.
//!
//! The temporary name is short, `.strahl-PID-N.tmp`, so that any legal output name works (a
//! name derived from the output's would exceed the 255-byte limit for long ones). While it
//! exists it is registered with [`crate::signals`], which removes it if SIGINT or SIGTERM ends
//! the process. `STRAHL_TEST_WRITE_DELAY_MS` (for tests) waits that long after creating it.

use std::fs::{self, OpenOptions};
use std::io::{self, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// Why an output file could not be written. Displays as one line naming the file.
#[derive(Debug, thiserror::Error)]
#[error("{}: {problem}", path.display())]
pub struct WriteError {
    pub path: PathBuf,
    pub problem: String,
}

impl WriteError {
    pub fn new(path: &Path, problem: impl Into<String>) -> Self {
        WriteError { path: path.to_path_buf(), problem: problem.into() }
    }
}

/// The directory a file at `path` goes into (`.` for a bare file name).
pub fn directory_of(path: &Path) -> &Path {
    match path.parent() {
        Some(dir) if !dir.as_os_str().is_empty() => dir,
        _ => Path::new("."),
    }
}

/// Writes `bytes` to `path` atomically: either the whole file appears, or nothing changes.
pub fn write_atomically(path: &Path, bytes: &[u8]) -> Result<(), WriteError> {
    write_atomically_with(path, |file| file.write_all(bytes))
}

/// Like [`write_atomically`], with the contents streamed by `write` into the temporary file
/// (buffered; it may seek, to patch what it wrote), so that a large file never has to be
/// whole in memory.
pub fn write_atomically_with(
    path: &Path,
    write: impl FnOnce(&mut io::BufWriter<fs::File>) -> io::Result<()>,
) -> Result<(), WriteError> {
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let dir = directory_of(path);
    if path.file_name().is_none() {
        return Err(WriteError::new(path, "is not a file name"));
    }
    if !dir.is_dir() {
        return Err(WriteError::new(path, format!("the directory {} does not exist", dir.display())));
    }
    // A name unique to this process and call; `create_new` refuses to reuse a leftover.
    let (file, tmp) = loop {
        let n = COUNTER.fetch_add(1, Ordering::Relaxed);
        let tmp = dir.join(format!(".strahl-{}-{n}.tmp", std::process::id()));
        match OpenOptions::new().read(true).write(true).create_new(true).open(&tmp) {
            Ok(file) => {
                crate::signals::track(&tmp);
                break (file, tmp);
            }
            Err(e) if e.kind() == io::ErrorKind::AlreadyExists && n < 1000 => continue,
            Err(e) => return Err(WriteError::new(path, format!("cannot create a file in {}: {e}", dir.display()))),
        }
    };
    if let Some(ms) = std::env::var("STRAHL_TEST_WRITE_DELAY_MS").ok().and_then(|v| v.parse().ok()) {
        std::thread::sleep(std::time::Duration::from_millis(ms));
    }
    let result = (|| -> io::Result<()> {
        let mut buffered = io::BufWriter::with_capacity(1 << 20, file);
        write(&mut buffered)?;
        let file = buffered.into_inner().map_err(|e| e.into_error())?;
        file.sync_all()?;
        drop(file);
        crate::signals::untrack(&tmp, || fs::rename(&tmp, path))
    })();
    result.map_err(|e| {
        crate::signals::untrack(&tmp, || fs::remove_file(&tmp)).ok();
        WriteError::new(path, format!("cannot write: {e}"))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A fresh directory under the system's temporary directory, removed on drop.
    struct TempDir(PathBuf);
    impl TempDir {
        fn new(tag: &str) -> Self {
            let p = std::env::temp_dir().join(format!("strahl-atomic-{tag}-{}", std::process::id()));
            let _ = fs::remove_dir_all(&p);
            fs::create_dir_all(&p).unwrap();
            TempDir(p)
        }
    }
    impl Drop for TempDir {
        fn drop(&mut self) {
            let _ = fs::remove_dir_all(&self.0);
        }
    }

    fn entries(dir: &Path) -> Vec<String> {
        let mut v: Vec<String> =
            fs::read_dir(dir).unwrap().map(|e| e.unwrap().file_name().into_string().unwrap()).collect();
        v.sort();
        v
    }

    #[test]
    fn writes_and_replaces_leaving_no_temporary_file() {
        let dir = TempDir::new("replace");
        let path = dir.0.join("a.bin");
        write_atomically(&path, b"first").unwrap();
        write_atomically(&path, b"second").unwrap();
        assert_eq!(fs::read(&path).unwrap(), b"second");
        assert_eq!(entries(&dir.0), ["a.bin"]);
    }

    #[test]
    fn a_255_byte_output_name_works() {
        // The longest name a Linux file system allows; the temporary name must not grow it.
        let dir = TempDir::new("long");
        let path = dir.0.join(format!("{}.exr", "n".repeat(251)));
        write_atomically(&path, b"long").unwrap();
        assert_eq!(fs::read(&path).unwrap(), b"long");
        assert_eq!(entries(&dir.0).len(), 1);
    }

    #[test]
    fn missing_directory_is_an_error_naming_it() {
        let dir = TempDir::new("missing");
        let path = dir.0.join("nope").join("a.bin");
        let e = write_atomically(&path, b"x").unwrap_err();
        assert!(e.to_string().ends_with(&format!("the directory {} does not exist", dir.0.join("nope").display())));
        assert!(entries(&dir.0).is_empty());
    }

    #[test]
    fn failed_rename_removes_the_temporary_file() {
        // The destination is a non-empty directory: the rename fails after the bytes were written.
        let dir = TempDir::new("rename");
        let path = dir.0.join("taken");
        fs::create_dir(&path).unwrap();
        fs::write(path.join("inside"), b"x").unwrap();
        let e = write_atomically(&path, b"data").unwrap_err();
        assert!(e.to_string().contains("cannot write"), "{e}");
        assert_eq!(entries(&dir.0), ["taken"]);
    }
}
