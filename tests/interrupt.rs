//! SIGINT and SIGTERM while an output is being written: strahl exits with 128 + signal, the
//! temporary file is gone and the previous output is untouched (`strahl::signals`). Temporary
//! names are short (`.strahl-PID-N.tmp`), so a 250-byte output name renders.

mod common;

use std::time::{Duration, Instant};

use common::TempDir;

fn scene() -> String {
    format!("{}/scenes/spheres.toml", env!("CARGO_MANIFEST_DIR"))
}

#[test]
fn sigterm_and_sigint_during_the_write_leave_no_temporary_file_and_the_old_output() {
    for (signal, code) in [("-TERM", 143), ("-INT", 130)] {
        // A render that pauses 60 s after creating its temporary file, interrupted then.
        let dir = TempDir::new(&format!("signal{signal}"));
        let out = dir.write("out.exr", b"the previous output");
        let args = ["render", &scene(), "--width", "32", "--height", "24", "-o", out.to_str().unwrap()];
        let mut child = common::spawn_strahl(args, ("STRAHL_TEST_WRITE_DELAY_MS", "60000"));
        let start = Instant::now();
        while !dir.entries().iter().any(|e| e.starts_with(".strahl-") && e.ends_with(".tmp")) {
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
