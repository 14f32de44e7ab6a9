//! Checkpoint and resume: a render stopped by SIGTERM or killed with SIGKILL at several points
//! (including while it writes a checkpoint) and resumed with `--resume` writes the same bytes
//! as an uninterrupted render and leaves no temporary; foreign, stale and damaged checkpoints
//! are moved aside and the render starts over; `--resume` of a finished render does nothing.
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
fn damaged_foreign_and_stale_checkpoints_are_moved_aside_and_the_render_starts_over() {
    let dir = TempDir::new("foreign");
    let out = dir.path("o.exr");
    let ckpt = checkpoint_of(&out);
    let o = out.to_str().unwrap().to_string();
    // The bytes of uninterrupted renders with --spp 1 and 2.
    let want = |spp: &str| {
        let full = dir.path(&format!("full{spp}.exr"));
        let r = run(&args(&full, &["--spp", spp]));
        assert!(r.status.success(), "{}", text(&r.stderr));
        std::fs::read(full).unwrap()
    };
    let (want1, want2) = (want("1"), want("2"));
    interrupted(&out, &["--spp", "2"]);
    let good = std::fs::read(&ckpt).unwrap();
    // Resumes `out` with `extra`, expecting the warning `moved` (the checkpoint moved to
    // `aside`) and the bytes `want`.
    let resume_with = |extra: &[&str], scene: Option<&Path>, moved: &str, aside: &str, want: &[u8]| {
        let mut a = args(&out, &["--resume"]);
        a.extend(extra.iter().map(|s| s.to_string()));
        if let Some(scene) = scene {
            a[1] = scene.to_str().unwrap().to_string();
        }
        // A whole output of the same render would end the run at once (and remove the
        // checkpoint): `resume_of_a_finished_render_does_nothing`.
        let _ = std::fs::remove_file(&out);
        let r = run(&a);
        let stderr = text(&r.stderr);
        assert!(r.status.success(), "{stderr}");
        let line = format!("warning: {o}.checkpoint: {moved}");
        assert!(stderr.contains(&line), "{stderr}");
        assert!(stderr.contains(&format!("moved it to {o}.checkpoint.{aside}, rendering from the start")), "{stderr}");
        assert!(!stderr.contains("resuming from"), "{stderr}");
        assert!(!ckpt.exists());
        assert!(std::fs::read(&out).unwrap() == want, "{extra:?}: the bytes differ from an uninterrupted render");
    };
    // Damaged: one float changed, cut short, not a checkpoint, another format version.
    let n = good.len();
    let mut flipped = good.clone();
    flipped[n - 100] ^= 1;
    let mut version = good.clone();
    version[8] = 9;
    for (bytes, problem) in [
        (flipped, "a damaged checkpoint (its checksum does not match)"),
        (good[..n / 2].to_vec(), "a damaged checkpoint (it ends early)"),
        (b"hello".to_vec(), "is not a strahl checkpoint"),
        (version, "checkpoint format 9, this strahl reads 1"),
    ] {
        std::fs::write(&ckpt, &bytes).unwrap();
        resume_with(&["--spp", "2"], None, problem, "damaged", &want2);
        // The damaged file is kept aside as it was, the last one replacing the one before.
        assert_eq!(std::fs::read(format!("{o}.checkpoint.damaged")).unwrap(), bytes);
    }
    // Of another render: other settings (the checkpoint is kept aside, whole).
    std::fs::write(&ckpt, &good).unwrap();
    resume_with(&["--spp", "1"], None, "a checkpoint of another render", "other", &want1);
    assert_eq!(std::fs::read(format!("{o}.checkpoint.other")).unwrap(), good);
    // Stale: the scene file changed since.
    let edited =
        dir.write("edited.toml", std::fs::read_to_string(scene()).unwrap().replace("max_depth = 8", "max_depth = 7"));
    std::fs::write(&ckpt, &good).unwrap();
    let mut a = args(&dir.path("edited-full.exr"), &["--spp", "2"]);
    a[1] = edited.to_str().unwrap().to_string();
    let r = run(&a);
    assert!(r.status.success(), "{}", text(&r.stderr));
    let want_edited = std::fs::read(dir.path("edited-full.exr")).unwrap();
    resume_with(&["--spp", "2"], Some(&edited), "a checkpoint of another render", "other", &want_edited);
    // The one kept aside resumes when renamed back.
    std::fs::rename(format!("{o}.checkpoint.other"), &ckpt).unwrap();
    std::fs::remove_file(&out).unwrap();
    let r = run(&args(&out, &["--resume", "--spp", "2"]));
    assert!(r.status.success(), "{}", text(&r.stderr));
    assert!(text(&r.stderr).contains("resuming from"), "{}", text(&r.stderr));
    assert!(std::fs::read(&out).unwrap() == want2);
}

/// `--resume` of a render whose outputs are whole does nothing, at once; with another scene or
/// settings it renders and replaces them.
#[test]
fn resume_of_a_finished_render_does_nothing() {
    let dir = TempDir::new("finished");
    let (out, png) = (dir.path("o.exr"), dir.path("o.png"));
    let with_png = ["--png", png.to_str().unwrap()];
    let first = run(&args(&out, &[&["--resume"][..], &with_png].concat()));
    assert!(first.status.success(), "{}", text(&first.stderr));
    assert!(text(&first.stdout).contains("rays:"));
    let modified = |p: &Path| std::fs::metadata(p).unwrap().modified().unwrap();
    let (exr_time, png_time) = (modified(&out), modified(&png));
    let bytes = std::fs::read(&out).unwrap();
    // A checkpoint a kill left after the outputs were renamed: removed.
    std::fs::write(checkpoint_of(&out), b"left over").unwrap();
    let again = run(&args(&out, &[&["--resume"][..], &with_png].concat()));
    let stdout = text(&again.stdout);
    assert!(again.status.success(), "{}", text(&again.stderr));
    assert!(
        stdout.contains(&format!("{}: complete, a render of this scene with these settings", out.display())),
        "{stdout}"
    );
    assert!(!stdout.contains("rays:"), "it rendered again: {stdout}");
    assert_eq!((modified(&out), modified(&png)), (exr_time, png_time));
    assert_eq!(dir.entries(), ["o.exr", "o.png"]);
    // Other settings, another region, another output setting, a missing PNG: rendered again
    // and replaced.
    for extra in
        [&["--spp", "2"][..], &["--region", "0,0,32,48"], &["--compression", "none"], &["--half"], &["--seed", "3"]]
    {
        let r = run(&args(&out, &[&["--resume"][..], &with_png, extra].concat()));
        assert!(r.status.success(), "{}", text(&r.stderr));
        assert!(text(&r.stdout).contains("rays:"), "{extra:?}: not rendered again");
    }
    std::fs::remove_file(&png).unwrap();
    let r = run(&args(&out, &[&["--resume"][..], &with_png].concat()));
    assert!(text(&r.stdout).contains("rays:") && png.exists(), "a missing PNG is rendered");
    assert!(std::fs::read(&out).unwrap() == bytes);
}

/// A directory in the checkpoint's place is refused before rendering, leaving no EXR.
#[test]
fn a_directory_at_the_checkpoint_is_refused_before_rendering() {
    let dir = TempDir::new("ckpt-dir");
    let out = dir.path("o.exr");
    std::fs::create_dir(checkpoint_of(&out)).unwrap();
    for extra in [&[][..], &["--resume"]] {
        let a: Vec<String> = args(&out, extra);
        let a: Vec<&str> = a.iter().map(String::as_str).collect();
        let e = fails(&dir, &a);
        assert!(e.contains(&format!("{}: is a directory", checkpoint_of(&out).display())), "{e}");
        assert_eq!(dir.entries(), ["o.exr.checkpoint"]);
    }
}

/// SIGKILL while a checkpoint is saved (held open by `STRAHL_TEST_WRITE_DELAY_MS`), twice:
/// each kill leaves the checkpoint's temporary, the next run removes it, and the resumed
/// render writes the uninterrupted render's bytes and leaves nothing but the EXR.
#[test]
fn temporaries_of_killed_saves_are_removed_by_the_next_run() {
    let dir = TempDir::new("stale-tmp");
    let want = uninterrupted(&dir);
    std::fs::remove_file(dir.path("full.exr")).unwrap();
    let out = dir.path("o.exr");
    for kill in 1..=2 {
        let mut a = args(&out, &["--threads", "1", "--checkpoint-every", "0"]);
        if kill == 2 {
            a.push("--resume".into());
        }
        let mut child = common::spawn_strahl(&a, ("STRAHL_TEST_WRITE_DELAY_MS", "60000"));
        let mine = format!("-{}-", child.id());
        let start = Instant::now();
        // The checkpoint's temporary, held with its bytes in it; not the empty one of the
        // start-up check that the folder takes a file, which comes before the stale ones are
        // removed.
        while !dir.written_temporaries().iter().any(|t| t.contains(&mine)) {
            assert!(start.elapsed() < Duration::from_secs(60), "no checkpoint save under way: {:?}", dir.entries());
            assert!(child.try_wait().unwrap().is_none(), "strahl ended: {:?}", dir.entries());
            std::thread::sleep(Duration::from_millis(5));
        }
        child.kill().unwrap();
        child.wait().unwrap();
        // This run's; the first run's was removed by the second.
        let left = dir.temporaries();
        assert!(left.len() == 1 && left[0].contains(&mine), "{left:?}");
        assert!(!checkpoint_of(&out).exists(), "the save was not killed");
    }
    let r = run(&args(&out, &["--resume", "--threads", "2"]));
    let stderr = text(&r.stderr);
    assert!(r.status.success(), "{stderr}");
    assert!(stderr.contains("removed 1 temporary"), "{stderr}");
    assert_eq!(dir.entries(), ["o.exr"]);
    assert!(std::fs::read(&out).unwrap() == want);
}

/// A Cornell box render (96 × 72 pixels: 30 tiles of 60 ms each on 2 threads, every pass, a
/// checkpoint after every tile) stopped again and again by a seeded random schedule —
/// SIGKILL, SIGTERM, SIGTERM then SIGKILL, two SIGTERMs, each at a random moment (a checkpoint
/// save, the EXR's write, start-up) — each time rerun with `--resume` until a run finishes,
/// ends in the bytes of an uninterrupted render and leaves nothing beside the EXR: no
/// checkpoint, no temporary, nothing moved aside. `STRAHL_KILL_SEED` picks another schedule.
#[test]
fn random_kills_of_a_cornell_render_end_in_the_uninterrupted_bytes() {
    let dir = TempDir::new("random-kills");
    let logs = TempDir::new("random-kills-logs");
    let cornell = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell.toml");
    let render = |out: &Path, extra: &[&str]| -> Vec<String> {
        let base =
            ["render", cornell.to_str().unwrap(), "-o", out.to_str().unwrap(), "--width", "96", "--height", "72"];
        let more = ["--spp", "2", "--passes", "all", "--threads", "2", "--checkpoint-every", "0"];
        base.iter().chain(&more).chain(extra).map(|s| s.to_string()).collect()
    };
    let want = {
        let full = logs.path("full.exr");
        let r = run(&render(&full, &[]));
        assert!(r.status.success(), "{}", text(&r.stderr));
        std::fs::read(full).unwrap()
    };
    let seed: u64 = std::env::var("STRAHL_KILL_SEED").ok().and_then(|s| s.parse().ok()).unwrap_or(27);
    // SplitMix64: a fixed, documented generator.
    let mut state = seed;
    let mut next = move |n: u64| {
        state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        (z ^ (z >> 31)) % n
    };
    let out = dir.path("o.exr");
    let (mut tally, mut left_temporaries) = ([0u32; 4], 0);
    for round in 0.. {
        assert!(round < 40, "no run finished in 40 rounds");
        let log = logs.path(&format!("round{round}.log"));
        let mut child = Command::new(env!("CARGO_BIN_EXE_strahl"))
            .args(render(&out, &["--resume"]))
            .env("SOURCE_DATE_EPOCH", "1700000000")
            .env("STRAHL_TEST_TILE_DELAY_MS", "60")
            .stdout(Stdio::null())
            .stderr(std::fs::File::create(&log).unwrap())
            .spawn()
            .unwrap();
        // From round 12 on the render is left alone, so that the test ends.
        let action = if round < 12 { next(4) as usize } else { 4 };
        if action < 4 {
            std::thread::sleep(Duration::from_millis(next(300)));
            match action {
                0 => common::send_signal(&child, "-KILL"),
                1 => common::send_signal(&child, "-TERM"),
                2 => {
                    common::send_signal(&child, "-TERM");
                    std::thread::sleep(Duration::from_millis(next(30)));
                    common::send_signal(&child, "-KILL");
                }
                _ => {
                    common::send_signal(&child, "-TERM");
                    std::thread::sleep(Duration::from_millis(next(30)));
                    common::send_signal(&child, "-TERM");
                }
            }
            tally[action] += 1;
        }
        let status = child.wait().unwrap();
        let stderr = std::fs::read_to_string(&log).unwrap();
        left_temporaries += dir.entries().iter().any(|e| e.ends_with(".tmp")) as u32;
        assert!(!stderr.contains("damaged") && !stderr.contains("another render"), "round {round}: {stderr}");
        // 0 finished, 1 stopped by SIGTERM with the checkpoint saved, 143 a second SIGTERM
        // (or one before the render began), none: SIGKILL.
        assert!(matches!(status.code(), Some(0 | 1 | 143) | None), "round {round}: {status:?} {stderr}");
        if status.success() {
            eprintln!(
                "seed {seed}: finished in round {round}; KILL, TERM, TERM+KILL, TERM+TERM: {tally:?}; \
                 {left_temporaries} runs left temporaries"
            );
            break;
        }
    }
    assert!(std::fs::read(&out).unwrap() == want, "seed {seed}: the bytes differ from an uninterrupted render");
    // The last run may have found the EXR complete (a kill after its rename): one more
    // run says so and removes what is left.
    let again = run(&render(&out, &["--resume"]));
    assert!(text(&again.stdout).contains("complete"), "{}", text(&again.stderr));
    assert_eq!(dir.entries(), ["o.exr"], "seed {seed}");
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
    // a path render: it is kept aside as another render's, and the path render starts over.
    let whitted = dir.path("whitted.exr");
    interrupted(&whitted, &["--spp", "2"]);
    let o = run(&path_args(&whitted, &["--resume", "--threads", "2"]));
    assert!(o.status.success(), "{}", text(&o.stderr));
    assert!(text(&o.stderr).contains("a checkpoint of another render"), "{}", text(&o.stderr));
    assert!(std::path::Path::new(&format!("{}.checkpoint.other", whitted.display())).exists());
    assert!(std::fs::read(&whitted).unwrap() == want, "a path render after a Whitted checkpoint: bytes differ");
}
