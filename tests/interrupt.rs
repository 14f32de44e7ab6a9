//! SIGINT and SIGTERM while an output is being written: strahl exits with 128 + signal, the
//! temporary file is gone and the previous output is untouched (`strahl::signals`). Temporary
//! names are short (`.strahl-PID-N.tmp`), so a 250-byte output name renders.

mod common;

use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use common::TempDir;

fn scene() -> String {
    format!("{}/scenes/spheres.toml", env!("CARGO_MANIFEST_DIR"))
}

/// Starts a render that pauses 60 s after creating its temporary file, waits for that file,
/// sends `signal` and returns the exit code and the folder's entries.
fn interrupted(tag: &str, signal: &str) -> (Option<i32>, Vec<String>, Vec<u8>) {
    let dir = TempDir::new(tag);
    let out = dir.write("out.exr", b"the previous output");
    let mut child = Command::new(env!("CARGO_BIN_EXE_strahl"))
        .args(["render", &scene(), "--width", "32", "--height", "24", "-o"])
        .arg(&out)
        .env("STRAHL_TEST_WRITE_DELAY_MS", "60000")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let start = Instant::now();
    while !dir.entries().iter().any(|e| e.starts_with(".strahl-") && e.ends_with(".tmp")) {
        assert!(start.elapsed() < Duration::from_secs(120), "no temporary file appeared: {:?}", dir.entries());
        std::thread::sleep(Duration::from_millis(20));
    }
    // The shell's built-in kill: a minimal root (the Embree 4 run) may have no /bin/kill.
    let killed = Command::new("sh").args(["-c", &format!("kill {signal} {}", child.id())]).status().unwrap();
    assert!(killed.success());
    let status = child.wait().unwrap();
    (status.code(), dir.entries(), std::fs::read(&out).unwrap())
}

#[test]
fn sigterm_during_the_write_leaves_no_temporary_file_and_the_old_output() {
    let (code, entries, bytes) = interrupted("sigterm", "-TERM");
    assert_eq!(code, Some(143));
    assert_eq!(entries, ["out.exr"]);
    assert_eq!(bytes, b"the previous output");
}

#[test]
fn sigint_during_the_write_leaves_no_temporary_file_and_the_old_output() {
    let (code, entries, bytes) = interrupted("sigint", "-INT");
    assert_eq!(code, Some(130));
    assert_eq!(entries, ["out.exr"]);
    assert_eq!(bytes, b"the previous output");
}

#[test]
fn a_250_byte_output_name_is_written() {
    let dir = TempDir::new("longname");
    let name = format!("{}.exr", "x".repeat(246));
    let out = dir.path(&name);
    let run = common::strahl(&["render", &scene(), "--width", "8", "--height", "6", "-o", out.to_str().unwrap()]);
    assert!(run.status.success(), "{}", common::text(&run.stderr));
    assert_eq!(dir.entries(), [name]);
    let (w, h, channels) = common::read_exr(&out);
    assert_eq!((w, h), (8, 6));
    assert!(channels.iter().any(|(n, _)| n.ends_with('R')));
}
