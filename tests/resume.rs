//! Checkpoint and resume: a render stopped by SIGTERM or killed with SIGKILL at several points
//! (including while it writes a checkpoint) and resumed with `--resume` writes the same bytes
//! as an uninterrupted render; foreign, stale and damaged checkpoints are refused.
//!
//! The points are chosen by polling the checkpoint file (the number of finished tiles it
//! holds), with `STRAHL_TEST_TILE_DELAY_MS` slowing every tile so that the render is still
//! running when the test acts: no sleeps decide the outcome.

mod common;

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use common::{TempDir, fails, strahl, text};

fn scene() -> String {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/whitted.toml").to_str().unwrap().to_string()
}

/// 64 × 48 pixels: 12 tiles of 16².
fn args(out: &Path, extra: &[&str]) -> Vec<String> {
    let mut a: Vec<String> =
        ["render", &scene(), "-o", out.to_str().unwrap(), "--width", "64", "--height", "48", "--passes", "all"]
            .iter()
            .map(|s| s.to_string())
            .collect();
    a.extend(extra.iter().map(|s| s.to_string()));
    a
}

fn run(args: &[String]) -> std::process::Output {
    let a: Vec<&str> = args.iter().map(String::as_str).collect();
    strahl(&a)
}

/// Starts a slow render (every tile waits `delay_ms`), saving a checkpoint after every tile.
fn spawn_slow(out: &Path, delay_ms: u32) -> Child {
    Command::new(env!("CARGO_BIN_EXE_strahl"))
        .args(args(out, &["--threads", "1", "--checkpoint-every", "0"]))
        .env("SOURCE_DATE_EPOCH", "1700000000")
        .env("STRAHL_TEST_TILE_DELAY_MS", delay_ms.to_string())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap()
}

/// The number of finished tiles in the checkpoint at `path` (0 when there is none yet), read
/// from its documented layout.
fn tiles_in(path: &Path) -> u32 {
    let Ok(b) = std::fs::read(path) else { return 0 };
    let key_len = u32::from_le_bytes(b[12..16].try_into().unwrap()) as usize;
    let at = 16 + key_len + 8;
    u32::from_le_bytes(b[at..at + 4].try_into().unwrap())
}

/// Waits until the checkpoint holds at least `k` tiles.
fn wait_for_tiles(path: &Path, k: u32) {
    let start = Instant::now();
    while tiles_in(path) < k {
        assert!(start.elapsed() < Duration::from_secs(60), "no checkpoint with {k} tiles after 60 s");
        std::thread::sleep(Duration::from_millis(2));
    }
}

fn checkpoint_of(out: &Path) -> PathBuf {
    PathBuf::from(format!("{}.checkpoint", out.display()))
}

fn uninterrupted(dir: &TempDir) -> Vec<u8> {
    let full = dir.path("full.exr");
    let o = run(&args(&full, &["--threads", "2"]));
    assert!(o.status.success(), "{}", text(&o.stderr));
    std::fs::read(full).unwrap()
}

/// Resumes the render of `out` and returns the bytes it writes; the checkpoint is gone after.
fn resume(out: &Path) -> Vec<u8> {
    let o = run(&args(out, &["--resume", "--threads", "2"]));
    assert!(o.status.success(), "{}", text(&o.stderr));
    assert!(!checkpoint_of(out).exists(), "the finished render removes its checkpoint");
    std::fs::read(out).unwrap()
}

#[test]
fn sigterm_saves_a_checkpoint_and_resume_gives_the_same_bytes() {
    let dir = TempDir::new("sigterm");
    let want = uninterrupted(&dir);
    for k in [1, 5, 11] {
        let out = dir.path(&format!("term{k}.exr"));
        let child = spawn_slow(&out, 40);
        wait_for_tiles(&checkpoint_of(&out), k);
        common::send_signal(&child, "-TERM");
        let done = child.wait_with_output().unwrap();
        let stderr = text(&done.stderr);
        assert_eq!(done.status.code(), Some(1), "{stderr}");
        assert!(stderr.contains("interrupted:") && stderr.contains("--resume"), "{stderr}");
        assert!(!out.exists(), "an interrupted render writes no image");
        assert!(tiles_in(&checkpoint_of(&out)) >= k);
        assert!(resume(&out) == want, "resumed after SIGTERM at {k} tiles: bytes differ");
    }
}

#[test]
fn sigkill_at_several_points_then_resume_gives_the_same_bytes() {
    let dir = TempDir::new("sigkill");
    let want = uninterrupted(&dir);
    // 0: killed before any checkpoint (resume starts from nothing).
    for k in [0, 2, 7] {
        let out = dir.path(&format!("kill{k}.exr"));
        let mut child = spawn_slow(&out, 40);
        wait_for_tiles(&checkpoint_of(&out), k);
        child.kill().unwrap(); // SIGKILL
        child.wait().unwrap();
        assert!(!out.exists());
        assert!(resume(&out) == want, "resumed after SIGKILL at {k} tiles: bytes differ");
    }
}

#[test]
fn sigkill_while_a_checkpoint_is_written_then_resume_gives_the_same_bytes() {
    let dir = TempDir::new("sigkill-write");
    let want = uninterrupted(&dir);
    let out = dir.path("o.exr");
    let mut child = spawn_slow(&out, 5);
    // Kill the moment a temporary file (a checkpoint being written) appears.
    let start = Instant::now();
    let mut caught = false;
    while start.elapsed() < Duration::from_secs(30) && child.try_wait().unwrap().is_none() {
        if dir.entries().iter().any(|e| e.ends_with(".tmp")) && tiles_in(&checkpoint_of(&out)) > 0 {
            child.kill().unwrap();
            caught = true;
            break;
        }
    }
    child.wait().unwrap();
    eprintln!("killed while a checkpoint was being written: {caught}");
    // A temporary left by a kill in mid-write, whether the poll caught one or not.
    let ckpt = checkpoint_of(&out);
    if ckpt.exists() {
        let bytes = std::fs::read(&ckpt).unwrap();
        std::fs::write(dir.path(".strahl-999999-0.tmp"), &bytes[..bytes.len() / 2]).unwrap();
    }
    assert!(resume(&out) == want, "resumed after a kill during a checkpoint write: bytes differ");
}

/// A checkpoint of `out` holding some tiles, made by stopping a render with SIGTERM.
fn interrupted(out: &Path, extra: &[&str]) {
    let mut a = args(out, &["--threads", "1", "--checkpoint-every", "0"]);
    a.extend(extra.iter().map(|s| s.to_string()));
    let child = common::spawn_strahl(&a, ("STRAHL_TEST_TILE_DELAY_MS", "30"));
    wait_for_tiles(&checkpoint_of(out), 3);
    common::send_signal(&child, "-TERM");
    child.wait_with_output().unwrap();
    assert!(checkpoint_of(out).exists());
}

#[test]
fn foreign_stale_and_damaged_checkpoints_are_refused() {
    let dir = TempDir::new("foreign");
    let out = dir.path("o.exr");
    let o = out.to_str().unwrap().to_string();
    interrupted(&out, &["--spp", "2"]);
    let resume_with = |extra: &[&str]| {
        let mut a = args(&out, &["--resume"]);
        a.extend(extra.iter().map(|s| s.to_string()));
        let a: Vec<&str> = a.iter().map(String::as_str).collect();
        fails(&dir, &a)
    };
    // Other settings, another region, another backend.
    for extra in [&["--spp", "1"][..], &["--spp", "2", "--region", "0,0,32,48"], &["--spp", "2", "--backend", "native"]]
    {
        let e = resume_with(extra);
        assert!(e.contains(&format!("{o}.checkpoint: a checkpoint of another render")), "{e}");
    }
    // A stale checkpoint: the scene file changed since.
    let edited =
        dir.write("edited.toml", std::fs::read_to_string(scene()).unwrap().replace("max_depth = 8", "max_depth = 7"));
    let mut a = args(&out, &["--resume", "--spp", "2"]);
    a[1] = edited.to_str().unwrap().to_string();
    let a: Vec<&str> = a.iter().map(String::as_str).collect();
    let e = fails(&dir, &a);
    assert!(e.contains("a checkpoint of another render"), "{e}");
    // Damaged: one float changed, or cut short.
    let ckpt = checkpoint_of(&out);
    let good = std::fs::read(&ckpt).unwrap();
    let mut bad = good.clone();
    let n = bad.len();
    bad[n - 100] ^= 1;
    std::fs::write(&ckpt, &bad).unwrap();
    assert!(resume_with(&["--spp", "2"]).contains("a damaged checkpoint"));
    std::fs::write(&ckpt, &good[..n / 2]).unwrap();
    assert!(resume_with(&["--spp", "2"]).contains("a damaged checkpoint"));
    std::fs::write(&ckpt, b"hello").unwrap();
    assert!(resume_with(&["--spp", "2"]).contains("is not a strahl checkpoint"));
    // The intact one still resumes.
    std::fs::write(&ckpt, &good).unwrap();
    let o = run(&args(&out, &["--resume", "--spp", "2"]));
    assert!(o.status.success(), "{}", text(&o.stderr));
    assert!(text(&o.stderr).contains("resuming from"));
}

/// Every pass the path tracer writes (the light-path passes are the Whitted integrator's).
const PATH_PASSES: &str =
    "combined,depth,normal,albedo,position,object_index,material_index,crypto_object,crypto_material";

/// [`args`] for the path tracer at 2 spp.
fn path_args(out: &Path, extra: &[&str]) -> Vec<String> {
    let out = out.to_str().unwrap();
    let base = ["render", &scene(), "-o", out, "--width", "64", "--height", "48", "--integrator", "path", "--spp", "2"];
    let mut a: Vec<String> = base.iter().map(|s| s.to_string()).collect();
    a.extend(["--passes".to_string(), PATH_PASSES.to_string()]);
    a.extend(extra.iter().map(|s| s.to_string()));
    a
}

#[test]
fn a_path_traced_render_resumes_to_the_same_bytes_and_no_whitted_checkpoint_resumes_it() {
    let dir = TempDir::new("path");
    let full = dir.path("full.exr");
    let o = run(&path_args(&full, &["--threads", "2"]));
    assert!(o.status.success(), "{}", text(&o.stderr));
    let want = std::fs::read(&full).unwrap();
    let out = dir.path("term.exr");
    let child = Command::new(env!("CARGO_BIN_EXE_strahl"))
        .args(path_args(&out, &["--threads", "1", "--checkpoint-every", "0"]))
        .env("SOURCE_DATE_EPOCH", "1700000000")
        .env("STRAHL_TEST_TILE_DELAY_MS", "40")
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    wait_for_tiles(&checkpoint_of(&out), 5);
    common::send_signal(&child, "-TERM");
    let done = child.wait_with_output().unwrap();
    assert_eq!(done.status.code(), Some(1), "{}", text(&done.stderr));
    let o = run(&path_args(&out, &["--resume", "--threads", "2"]));
    assert!(o.status.success(), "{}", text(&o.stderr));
    assert!(std::fs::read(&out).unwrap() == want, "resumed path render: bytes differ");
    // The EXR says which integrator made it.
    let image = common::read_exr_image(&out);
    use exr::meta::attribute::{AttributeValue, Text};
    let integrator = image.layer_data[0].attributes.other.get(&Text::from("strahl/integrator"));
    assert_eq!(integrator, Some(&AttributeValue::Text(Text::from("path"))));
    // A Whitted render's checkpoint of the same scene, settings and file is not resumed by
    // a path render.
    let whitted = dir.path("whitted.exr");
    interrupted(&whitted, &["--spp", "2"]);
    let a = path_args(&whitted, &["--resume"]);
    let a: Vec<&str> = a.iter().map(String::as_str).collect();
    let e = fails(&dir, &a);
    assert!(e.contains("a checkpoint of another render"), "{e}");
}
