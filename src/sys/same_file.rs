//! Whether two paths name the same file, so that an output is never written over an input.
//!
//! The rule: two existing paths are the same file when their device and inode numbers agree
//! (this sees through symbolic links, hard links, `..` and different spellings); a path that
//! does not exist yet is compared by its canonical folder and its name.

use std::fs;
use std::os::unix::fs::MetadataExt;
use std::path::{Path, PathBuf};

use super::atomic::directory_of;

/// `true` if `a` and `b` are, or would be, one file.
pub fn same_file(a: &Path, b: &Path) -> bool {
    match (fs::metadata(a), fs::metadata(b)) {
        (Ok(x), Ok(y)) => x.dev() == y.dev() && x.ino() == y.ino(),
        (Err(_), Err(_)) => matches!((resolved(a), resolved(b)), (Some(x), Some(y)) if x == y),
        _ => false, // one exists and the other does not
    }
}

fn resolved(path: &Path) -> Option<PathBuf> {
    Some(directory_of(path).canonicalize().ok()?.join(path.file_name()?))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn links_and_spellings_are_seen_through() {
        let dir = std::env::temp_dir().join(format!("strahl-same-file-{}", std::process::id()));
        let _ = fs::remove_dir_all(&dir);
        fs::create_dir_all(dir.join("sub")).unwrap();
        let scene = dir.join("scene.toml");
        fs::write(&scene, b"x").unwrap();
        std::os::unix::fs::symlink(&scene, dir.join("soft.exr")).unwrap();
        fs::hard_link(&scene, dir.join("hard.exr")).unwrap();
        fs::write(dir.join("other.toml"), b"x").unwrap();
        assert!(same_file(&scene, &dir.join("soft.exr")));
        assert!(same_file(&scene, &dir.join("hard.exr")));
        assert!(same_file(&scene, &dir.join("sub/../scene.toml")));
        assert!(!same_file(&scene, &dir.join("other.toml")));
        assert!(!same_file(&scene, &dir.join("new.exr")));
        assert!(same_file(&dir.join("new.exr"), &dir.join("sub/../new.exr")));
        assert!(!same_file(&dir.join("new.exr"), &dir.join("new.png")));
        fs::remove_dir_all(&dir).unwrap();
    }
}
