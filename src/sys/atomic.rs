//! Writing a file all at once or not at all: the bytes go to a temporary file in the
//! destination's directory, which is then renamed over the destination (atomic on one file
//! system). On any error the temporary file is removed and the destination is untouched.
//!
//! Several files that belong together (an EXR and its PNG preview) are first written whole to
//! their temporaries ([`stage_with`]) and then renamed one after the other in [`commit_all`],
//! with the signal registry locked: an error while writing either leaves neither, and a
//! SIGINT/SIGTERM waits until both are renamed. Before the first rename, the existing
//! destinations of the files renamed after it (the old PNG) are removed, so that a process
//! killed between the renames (SIGKILL, power loss) leaves the new EXR without a preview, never
//! beside the previous render's PNG: an old file beside a new one would silently mislead.
//! Such a kill also leaves the unrenamed temporary behind; a later run removes it
//! ([`crate::sys::temporary::remove_stale`]) once its writer is known to be gone.
//! A rename failing in between (both temporaries already written in full, in the destinations'
//! own folders; a directory in a destination's place is refused before) leaves the new first
//! file and no second one, for the same reason. `STRAHL_TEST_COMMIT_DELAY_MS` (for tests)
//! waits that long after the first rename.
//!
//! The temporary's name, `.strahl-HOST-PID-START-N.tmp` ([`crate::sys::temporary`]), is short,
//! so that any legal output name works (a name derived from the output's would exceed the
//! 255-byte limit for long ones), and names its writer, so that a stale one can be told from a
//! live one. While it
//! exists it is registered with [`crate::sys::signals`], which removes it if SIGINT or SIGTERM ends
//! the process. `STRAHL_TEST_WRITE_DELAY_MS` (for tests) waits that long once the bytes are in
//! it, before its sync and rename: a temporary held so is never empty, which tells it from the
//! empty one the start-up check that an output's folder takes a file creates and removes.

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
    commit_all(vec![stage_with(path, write)?])
}

/// A file written whole to its temporary and synced, not yet renamed over its destination
/// ([`commit_all`]). Dropped uncommitted, its temporary is removed.
#[must_use = "a staged file is written only when committed"]
#[derive(Debug)]
pub struct Staged {
    tmp: PathBuf,
    path: PathBuf,
    /// Renamed, or removed: nothing left for the drop to do.
    done: bool,
}

impl Drop for Staged {
    fn drop(&mut self) {
        if !self.done {
            crate::sys::signals::untrack(&[&self.tmp], || fs::remove_file(&self.tmp)).ok();
        }
    }
}

/// Writes `bytes` to the temporary file of `path` (see [`stage_with`]).
pub fn stage(path: &Path, bytes: &[u8]) -> Result<Staged, WriteError> {
    stage_with(path, |file| file.write_all(bytes))
}

/// Writes the temporary file of `path` with `write` and syncs it, leaving `path` untouched
/// until [`commit_all`]. On any error the temporary is removed.
pub fn stage_with(
    path: &Path,
    write: impl FnOnce(&mut io::BufWriter<fs::File>) -> io::Result<()>,
) -> Result<Staged, WriteError> {
    let (file, tmp) = create_temporary(path)?;
    let staged = Staged { tmp, path: path.to_path_buf(), done: false };
    let result = (|| -> io::Result<()> {
        let mut buffered = io::BufWriter::with_capacity(1 << 20, file);
        write(&mut buffered)?;
        let file = buffered.into_inner().map_err(|e| e.into_error())?;
        if let Some(ms) = std::env::var("STRAHL_TEST_WRITE_DELAY_MS").ok().and_then(|v| v.parse().ok()) {
            std::thread::sleep(std::time::Duration::from_millis(ms));
        }
        file.sync_all()
    })();
    // On error `staged` is dropped, removing the temporary.
    result.map(|()| staged).map_err(|e| WriteError::new(path, format!("cannot write: {e}")))
}

/// Creates a new temporary file in the directory of `path` (see the module docs), registered
/// with [`crate::sys::signals`]; errors name `path`.
fn create_temporary(path: &Path) -> Result<(fs::File, PathBuf), WriteError> {
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let dir = directory_of(path);
    if path.file_name().is_none() {
        return Err(WriteError::new(path, "is not a file name"));
    }
    if !dir.is_dir() {
        return Err(WriteError::new(path, format!("the directory {} does not exist", dir.display())));
    }
    // A name unique to this process and call; `create_new` refuses to reuse a leftover.
    loop {
        let n = COUNTER.fetch_add(1, Ordering::Relaxed);
        let tmp = dir.join(crate::sys::temporary::name(n));
        match OpenOptions::new().read(true).write(true).create_new(true).open(&tmp) {
            Ok(file) => {
                crate::sys::signals::track(&tmp);
                return Ok((file, tmp));
            }
            Err(e) if e.kind() == io::ErrorKind::AlreadyExists && n < 1000 => continue,
            Err(e) => return Err(WriteError::new(path, format!("cannot create a file in {}: {e}", dir.display()))),
        }
    }
}

/// A working file beside an output (a temporary of the module docs' kind) that is never
/// renamed: removed when dropped, and by [`crate::sys::signals`] if SIGINT or SIGTERM ends the
/// process first. The EXR encoder keeps the blocks it compresses during a render in one
/// ([`crate::output::exr_stream`]).
#[derive(Debug)]
pub struct Scratch {
    pub file: fs::File,
    tmp: PathBuf,
}

impl Scratch {
    /// A new, empty scratch file in the directory of `path` (errors name `path`).
    pub fn beside(path: &Path) -> Result<Scratch, WriteError> {
        let (file, tmp) = create_temporary(path)?;
        Ok(Scratch { file, tmp })
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        crate::sys::signals::untrack(&[&self.tmp], || fs::remove_file(&self.tmp)).ok();
    }
}

/// Renames every staged file over its destination, in order, with the signal registry locked
/// (see the module docs). A failed rename removes the temporaries not yet renamed.
pub fn commit_all(mut files: Vec<Staged>) -> Result<(), WriteError> {
    let tmps: Vec<PathBuf> = files.iter().map(|f| f.tmp.clone()).collect();
    let tmp_refs: Vec<&Path> = tmps.iter().map(PathBuf::as_path).collect();
    crate::sys::signals::untrack(&tmp_refs, || {
        // A directory in a destination's place would fail its rename after the others: refuse
        // it before renaming any.
        if let Some(f) = files.iter().find(|f| f.path.is_dir()) {
            let path = f.path.clone();
            discard(&mut files);
            return Err(WriteError::new(&path, "cannot write: is a directory"));
        }
        // The old versions of the files renamed after the first go first (see the module
        // docs); one that cannot be removed stops the commit before anything changed.
        for i in 1..files.len() {
            match fs::remove_file(&files[i].path) {
                Err(e) if e.kind() != io::ErrorKind::NotFound => {
                    let path = files[i].path.clone();
                    discard(&mut files);
                    return Err(WriteError::new(&path, format!("cannot replace: {e}")));
                }
                _ => {}
            }
        }
        for i in 0..files.len() {
            if i == 1
                && let Some(ms) = std::env::var("STRAHL_TEST_COMMIT_DELAY_MS").ok().and_then(|v| v.parse().ok())
            {
                std::thread::sleep(std::time::Duration::from_millis(ms));
            }
            if let Err(e) = fs::rename(&files[i].tmp, &files[i].path) {
                // This one and the rest are removed here, still under the lock.
                discard(&mut files[i..]);
                return Err(WriteError::new(&files[i].path, format!("cannot write: {e}")));
            }
            files[i].done = true;
        }
        Ok(())
    })?;
    Ok(())
}

/// Removes the temporaries of `files` at once, under the signal registry's lock that
/// [`commit_all`] holds (their drop would take it again).
fn discard(files: &mut [Staged]) {
    for f in files {
        fs::remove_file(&f.tmp).ok();
        f.done = true;
    }
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
    fn staged_files_are_renamed_together_or_not_at_all() {
        let dir = TempDir::new("staged");
        let (a, b) = (dir.0.join("a.exr"), dir.0.join("b.png"));
        fs::write(&a, b"old a").unwrap();
        // b's place is taken by a non-empty directory: a is not replaced either.
        fs::create_dir(&b).unwrap();
        fs::write(b.join("x"), b"x").unwrap();
        let staged = vec![stage(&a, b"new a").unwrap(), stage(&b, b"new b").unwrap()];
        assert!(commit_all(staged).unwrap_err().to_string().contains("b.png: cannot write: is a directory"));
        assert_eq!(fs::read(&a).unwrap(), b"old a");
        // A staged file dropped uncommitted leaves nothing.
        drop(stage(&dir.0.join("c.exr"), b"c").unwrap());
        let mut left = entries(&dir.0);
        left.sort();
        assert_eq!(left, ["a.exr", "b.png"]);
        fs::remove_dir_all(&b).unwrap();
        commit_all(vec![stage(&a, b"new a").unwrap(), stage(&b, b"new b").unwrap()]).unwrap();
        assert_eq!((fs::read(&a).unwrap(), fs::read(&b).unwrap()), (b"new a".to_vec(), b"new b".to_vec()));
    }

    #[test]
    fn a_scratch_file_is_removed_when_dropped() {
        let dir = TempDir::new("scratch");
        let scratch = Scratch::beside(&dir.0.join("out.exr")).unwrap();
        (&scratch.file).write_all(b"blocks").unwrap();
        assert_eq!(entries(&dir.0).len(), 1);
        assert!(entries(&dir.0)[0].starts_with(".strahl-"));
        drop(scratch);
        assert!(entries(&dir.0).is_empty());
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
