//! SIGINT and SIGTERM while an output is being written: strahl exits with 128 + signal, the
//! temporary file is gone and the previous output is untouched (`strahl::sys::signals`). Temporary
//! names are short (`.strahl-HOST-PID-START-N.tmp`), so a 250-byte output name renders.

mod common;

use std::time::{Duration, Instant};

use common::{TempDir, strahl, text};

fn scene() -> String {
    format!("{}/scenes/spheres.toml", env!("CARGO_MANIFEST_DIR"))
}

#[test]
fn sigterm_and_sigint_during_the_write_leave_no_temporary_file_and_the_old_output() {
    for (signal, code) in [("-TERM", 143), ("-INT", 130)] {
        // A render that pauses 60 s with its output written to its temporary, interrupted then.
        let dir = TempDir::new(&format!("signal{signal}"));
        let out = dir.write("out.exr", b"the previous output");
        let args = ["render", &scene(), "--width", "32", "--height", "24", "-o", out.to_str().unwrap()];
        let mut child = common::spawn_strahl(args, ("STRAHL_TEST_WRITE_DELAY_MS", "60000"));
        let start = Instant::now();
        while dir.written_temporaries().is_empty() {
            assert!(start.elapsed() < Duration::from_secs(120), "no temporary file appeared: {:?}", dir.entries());
            std::thread::sleep(Duration::from_millis(20));
        }
        common::send_signal(&child, signal);
        assert_eq!(child.wait().unwrap().code(), Some(code), "{signal}");
        assert_eq!(dir.entries(), ["out.exr"], "{signal}");
        assert_eq!(std::fs::read(&out).unwrap(), b"the previous output", "{signal}");
    }
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

/// The EXR and its PNG are written whole to temporaries and renamed together: when the PNG
/// cannot be written, the EXR is not replaced either, and no temporary is left.
#[test]
fn a_failing_png_leaves_the_previous_exr_and_no_temporary() {
    let dir = TempDir::new("png-fails");
    let scene = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/lecture.toml");
    let exr = dir.path("out.exr");
    let small = ["--width", "16", "--height", "12"];
    let first = strahl(&[&["render", scene, "-o", exr.to_str().unwrap()][..], &small].concat());
    assert!(first.status.success(), "{}", text(&first.stderr));
    let before = std::fs::read(&exr).unwrap();
    // A PNG that cannot be created (/proc takes no new files, even from root) and one whose
    // place is taken by a directory: both refused before rendering.
    std::fs::create_dir(dir.path("taken.png")).unwrap();
    std::fs::write(dir.path("taken.png/x"), "x").unwrap();
    for png in ["/proc/strahl-test.png".to_string(), dir.path("taken.png").display().to_string()] {
        let out = strahl(
            &[&["render", scene, "-o", exr.to_str().unwrap(), "--png", &png, "--spp", "2"][..], &small].concat(),
        );
        assert_eq!(out.status.code(), Some(1), "{png}: {}", text(&out.stderr));
        assert!(text(&out.stderr).contains(&format!("error: {png}: ")), "{}", text(&out.stderr));
        assert_eq!(std::fs::read(&exr).unwrap(), before, "{png}: the EXR was replaced");
        let mut left = dir.entries();
        left.sort();
        assert_eq!(left, ["out.exr", "taken.png"], "{png}");
    }
}

/// SIGKILL between the EXR's rename and the PNG's (held open by `STRAHL_TEST_COMMIT_DELAY_MS`):
/// the folder has the new EXR and no PNG — never the new EXR beside the previous render's PNG
/// (the old PNG is removed before the first rename, `strahl::sys::atomic`). The PNG's temporary
/// is left, as after any SIGKILL.
#[test]
fn sigkill_between_the_renames_never_pairs_the_new_exr_with_the_old_png() {
    let dir = TempDir::new("sigkill-pair");
    let scene = scene();
    let (exr, png) = (dir.path("out.exr"), dir.path("out.png"));
    let outputs = ["-o", exr.to_str().unwrap(), "--png", png.to_str().unwrap()];
    let first = strahl(&[&["render", &scene, "--width", "16", "--height", "12"][..], &outputs].concat());
    assert!(first.status.success(), "{}", text(&first.stderr));
    let old_exr = std::fs::read(&exr).unwrap();
    assert!(png.exists());
    let args = [&["render", &scene, "--width", "20", "--height", "12"][..], &outputs].concat();
    let mut child = common::spawn_strahl(args, ("STRAHL_TEST_COMMIT_DELAY_MS", "60000"));
    let start = Instant::now();
    while std::fs::read(&exr).unwrap() == old_exr {
        assert!(start.elapsed() < Duration::from_secs(120), "the EXR was not replaced: {:?}", dir.entries());
        assert!(child.try_wait().unwrap().is_none(), "strahl ended before its first rename");
        std::thread::sleep(Duration::from_millis(20));
    }
    common::send_signal(&child, "-KILL");
    child.wait().unwrap();
    assert_eq!(common::read_exr(&exr).0, 20, "the new EXR, whole");
    assert!(!png.exists(), "the previous render's PNG is beside the new EXR: {:?}", dir.entries());
    let mut left = dir.entries();
    left.sort();
    assert_eq!(left.len(), 2, "{left:?}");
    assert!(left[0].starts_with(".strahl-") && left[0].ends_with(".tmp") && left[1] == "out.exr", "{left:?}");
}
