//! `strahl render --progress-interval SECONDS`: with stderr not a terminal, progress lines
//! (`rendering: 42% after 1.2 s, eta 1.6 s`) come at most every SECONDS; 0 gives one per
//! finished tile, the default (5 s) none for a render shorter than that. Bad intervals are
//! refused in one line naming the option.

mod common;

use std::path::Path;

use common::{TempDir, fails, strahl, text};

fn progress_lines(dir: &TempDir, extra: &[&str]) -> Vec<f64> {
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell.toml");
    let out = dir.path("p.exr");
    let mut args = vec!["render", scene.to_str().unwrap(), "-o", out.to_str().unwrap(), "--integrator", "whitted"];
    args.extend(["--width", "64", "--height", "64", "--spp", "1", "--threads", "1"]);
    args.extend(extra);
    let o = strahl(&args);
    assert!(o.status.success(), "{}", text(&o.stderr));
    text(&o.stderr)
        .lines()
        .filter_map(|l| l.strip_prefix("rendering: "))
        .map(|l| l.split('%').next().unwrap().parse().unwrap())
        .collect()
}

#[test]
fn an_interval_of_zero_prints_a_line_per_tile_and_the_default_none_for_a_short_render() {
    let dir = TempDir::new("progress");
    let every_tile = progress_lines(&dir, &["--progress-interval", "0"]);
    // 64 x 64 pixels in 16-pixel tiles: a line after each of the first 15 of 16.
    assert!(every_tile.len() > 1, "{every_tile:?}");
    assert!(every_tile.windows(2).all(|w| w[0] <= w[1]) && every_tile.iter().all(|&p| p < 100.0), "{every_tile:?}");
    let default = progress_lines(&dir, &[]);
    assert!(default.is_empty(), "a render well under 5 s printed {default:?}");
}

#[test]
fn bad_intervals_are_refused_in_one_line() {
    let dir = TempDir::new("progress-bad");
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell.toml");
    let out = dir.path("p.exr");
    for bad in ["-1", "nan", "inf", "86401"] {
        let e =
            fails(&dir, &["render", scene.to_str().unwrap(), "-o", out.to_str().unwrap(), "--progress-interval", bad]);
        assert!(e.starts_with("error: --progress-interval "), "{bad}: {e}");
    }
}
