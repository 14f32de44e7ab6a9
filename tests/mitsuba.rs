//! strahl against Mitsuba 3, a renderer strahl did not write: the Cornell box lit by its area
//! light, a quad (tools/mitsuba/cornell-diffuse.toml), and by a disk and a sphere light
//! (tools/mitsuba/cornell-shapes.toml), rendered by this strahl binary and by Mitsuba 3's
//! `direct` integrator, and the same box path-traced (tools/mitsuba/cornell-path.toml) against
//! Mitsuba's `path` integrator, through tools/mitsuba-compare.py, which exits non-zero when a channel's
//! image mean differs by more than 1 %, fewer than 99 % of the pixels agree within 3 standard
//! errors, or the mean signed z-score shows a bias (docs/mitsuba.md). 32×32 pixels, strahl 4
//! independent copies × 1024 spp, Mitsuba 8 seeds × 1024 spp: a few seconds.
//!
//! Skips, saying so, when python3 cannot import mitsuba (`make test-mitsuba` installs it and
//! runs this test with `STRAHL_REQUIRE_MITSUBA=1`, which turns the skip into a failure).

mod common;

use std::path::Path;
use std::process::Command;

/// Whether python3 can import what the script needs.
fn mitsuba_available() -> bool {
    Command::new("python3").args(["-c", "import mitsuba, numpy, tomllib"]).output().is_ok_and(|o| o.status.success())
}

/// Runs the comparison on `scene` (under tools/mitsuba/) and asserts its verdict; skips when
/// Mitsuba is missing, unless `STRAHL_REQUIRE_MITSUBA=1`.
fn compare(scene: &str) {
    if !mitsuba_available() {
        assert!(
            std::env::var("STRAHL_REQUIRE_MITSUBA").as_deref() != Ok("1"),
            "STRAHL_REQUIRE_MITSUBA=1 but python3 cannot import mitsuba, numpy and tomllib"
        );
        common::skip("python3 cannot import mitsuba (make test-deps or make test-mitsuba installs it)");
        return;
    }
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let out = Command::new("python3")
        .arg(root.join("tools/mitsuba-compare.py"))
        .arg(env!("CARGO_BIN_EXE_strahl"))
        .arg("--scene")
        .arg(root.join("tools/mitsuba").join(scene))
        .args(["--size", "32", "--spp", "1024", "--copies", "4", "--mitsuba-spp", "8192", "--seeds", "8"])
        .output()
        .expect("python3 runs");
    let stdout = String::from_utf8_lossy(&out.stdout);
    println!("{stdout}");
    assert!(
        out.status.success(),
        "{scene}: strahl and Mitsuba disagree:\n{stdout}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    // The script printed its measurements: three channel means and the verdict.
    assert_eq!(stdout.matches("mean radiance ").count(), 3, "{stdout}");
    assert!(stdout.contains("OK: strahl and Mitsuba 3 agree"), "{stdout}");
}

#[test]
fn cornell_quad_light_matches_mitsuba() {
    compare("cornell-diffuse.toml");
}

#[test]
fn disk_and_sphere_lights_match_mitsuba() {
    compare("cornell-shapes.toml");
}

#[test]
fn path_traced_cornell_box_matches_mitsubas_path_integrator() {
    compare("cornell-path.toml");
}
