//! The EXR's blocks compressed while the tiles render (`strahl::output::exr_stream`), through the
//! command line: the file is the same bytes on 1 and 2 threads whether the compressed blocks
//! wait in memory or in a scratch file beside the output, and an interrupted render leaves no
//! scratch file.

mod common;

use std::process::Command;
use std::time::{Duration, Instant};

use common::{TempDir, text};

fn scene() -> String {
    format!("{}/scenes/whitted.toml", env!("CARGO_MANIFEST_DIR"))
}

/// Renders the Whitted scene at 96 × 70 (five 16-line blocks, the last short) on `threads`
/// threads with a block budget of `budget` bytes; returns the EXR's bytes.
fn render(dir: &TempDir, name: &str, threads: &str, budget: &str) -> Vec<u8> {
    let out = dir.path(name);
    let run = Command::new(env!("CARGO_BIN_EXE_strahl"))
        .args(["render", &scene(), "--width", "96", "--height", "70", "--threads", threads])
        .args(["--passes", "combined,depth,normal,albedo,crypto_object", "-o", out.to_str().unwrap()])
        .env("SOURCE_DATE_EPOCH", "1")
        .env("STRAHL_TEST_BLOCK_BUDGET", budget)
        .output()
        .unwrap();
    assert!(run.status.success(), "{}", text(&run.stderr));
    assert!(text(&run.stdout).contains("s of it compressing the EXR"), "{}", text(&run.stdout));
    std::fs::read(&out).unwrap()
}

#[test]
fn the_exr_is_the_same_bytes_whether_blocks_wait_in_memory_or_in_a_scratch_file() {
    let dir = TempDir::new("stream-bytes");
    let memory = render(&dir, "memory.exr", "1", "100000000");
    assert_eq!(render(&dir, "memory2.exr", "2", "100000000"), memory, "2 threads");
    assert_eq!(render(&dir, "scratch.exr", "2", "0"), memory, "every block through the scratch file");
    assert_eq!(render(&dir, "some.exr", "2", "20000"), memory, "some blocks in memory, the rest in the file");
    // The file is a valid EXR of the right size; nothing else is left in the directory.
    let (w, h, channels) = common::read_exr(&dir.path("scratch.exr"));
    assert_eq!((w, h), (96, 70));
    assert!(channels.iter().any(|(n, _)| n == "ViewLayer.Depth.Z"));
    assert_eq!(dir.entries(), ["memory.exr", "memory2.exr", "scratch.exr", "some.exr"]);
}

#[test]
fn sigint_while_blocks_wait_in_a_scratch_file_leaves_no_scratch_file() {
    let dir = TempDir::new("stream-signal");
    let out = dir.path("out.exr");
    let mut child = Command::new(env!("CARGO_BIN_EXE_strahl"))
        .args(["render", &scene(), "--width", "64", "--height", "64", "--threads", "1", "-o"])
        .arg(&out)
        .env("STRAHL_TEST_BLOCK_BUDGET", "0")
        .env("STRAHL_TEST_TILE_DELAY_MS", "100")
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    // The first 16-line block is complete after the first row of four tiles: the scratch file
    // appears then.
    let start = Instant::now();
    while dir.written_temporaries().is_empty() {
        assert!(start.elapsed() < Duration::from_secs(120), "no scratch file appeared: {:?}", dir.entries());
        std::thread::sleep(Duration::from_millis(10));
    }
    // The first SIGINT stops the render gracefully: the checkpoint is saved, exit status 1.
    common::send_signal(&child, "-INT");
    assert_eq!(child.wait().unwrap().code(), Some(1));
    // The checkpoint to resume from, and nothing else.
    assert_eq!(dir.entries(), ["out.exr.checkpoint"]);
}
