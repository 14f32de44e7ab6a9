//! Regions, farm tiles and `strahl merge`: a frame rendered in pieces and merged is the same
//! file, byte for byte, as the frame rendered in one process; a region's EXR places its pixels
//! by its dataWindow; bad regions, tiles and part sets are refused with one line.

mod common;

use std::path::{Path, PathBuf};

use common::{TempDir, fails, float_channels, read_exr_image, strahl, text};

fn scene_path(name: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes").join(name).to_str().unwrap().to_string()
}

const W: u32 = 40;
const H: u32 = 30;

/// Renders `scene` at W × H, 2 spp (jittered: per-pixel seeding must hold), every pass, into
/// `out`, with `extra` arguments.
fn render(scene: &str, out: &Path, extra: &[&str]) {
    let (w, h) = (W.to_string(), H.to_string());
    let mut args = vec!["render", scene, "-o", out.to_str().unwrap(), "--width", &w, "--height", &h];
    args.extend(["--spp", "2", "--passes", "all"]);
    args.extend(extra);
    if !extra.contains(&"--threads") {
        args.extend(["--threads", "1"]);
    }
    let o = strahl(&args);
    assert!(o.status.success(), "render {args:?} failed: {}", text(&o.stderr));
}

fn merge(out: &Path, parts: &[PathBuf]) -> std::process::Output {
    let mut args = vec!["merge".to_string(), out.to_str().unwrap().to_string()];
    args.extend(parts.iter().map(|p| p.to_str().unwrap().to_string()));
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    strahl(&args)
}

#[test]
fn quadrants_and_seven_tiles_merge_to_the_full_render_byte_for_byte() {
    for name in ["whitted.toml", "cornell.toml", "blob.toml"] {
        let dir = TempDir::new(&format!("merge-{name}"));
        let scene = scene_path(name);
        let full = dir.path("full.exr");
        render(&scene, &full, &["--threads", "2"]);
        let full_bytes = std::fs::read(&full).unwrap();

        let (mx, my) = (W / 2 - 3, H / 2 + 1); // off the 16-pixel tile grid on purpose
        let quadrants = [(0, 0, mx, my), (mx, 0, W, my), (0, my, mx, H), (mx, my, W, H)];
        let mut parts = Vec::new();
        for (k, (x0, y0, x1, y1)) in quadrants.into_iter().enumerate() {
            let part = dir.path(&format!("q{k}.exr"));
            render(&scene, &part, &["--region", &format!("{x0},{y0},{x1},{y1}")]);
            parts.push(part);
        }
        parts.reverse(); // the order of the arguments does not matter
        let merged = dir.path("quadrants.exr");
        let o = merge(&merged, &parts);
        assert!(o.status.success(), "{name}: {}", text(&o.stderr));
        assert!(std::fs::read(&merged).unwrap() == full_bytes, "{name}: merged quadrants differ from the full render");

        let tiles: Vec<PathBuf> = (1..=7)
            .map(|i| {
                let part = dir.path(&format!("tile{i}.exr"));
                render(&scene, &part, &["--tile", &format!("{i}/7")]);
                part
            })
            .collect();
        let merged = dir.path("tiles.exr");
        let o = merge(&merged, &tiles);
        assert!(o.status.success(), "{name}: {}", text(&o.stderr));
        assert!(std::fs::read(&merged).unwrap() == full_bytes, "{name}: merged tiles differ from the full render");
    }
}

/// The layer of the EXR at `path`: data window position and size, display window size, and
/// every channel by name.
#[allow(clippy::type_complexity)]
fn read_layer(path: &Path) -> ((i32, i32), (usize, usize), (usize, usize), Vec<(String, Vec<f32>)>) {
    let image = read_exr_image(path);
    let layer = &image.layer_data[0];
    let channels = float_channels(layer);
    let position = layer.attributes.layer_position;
    let display = image.attributes.display_window.size;
    ((position.0, position.1), (layer.size.0, layer.size.1), (display.0, display.1), channels)
}

#[test]
fn a_region_is_the_full_renders_pixels_in_its_data_window() {
    let dir = TempDir::new("region");
    let scene = scene_path("whitted.toml");
    let (full, part) = (dir.path("full.exr"), dir.path("part.exr"));
    render(&scene, &full, &[]);
    render(&scene, &part, &["--region", "5,3,27,20"]);
    let (p0, size0, display0, whole) = read_layer(&full);
    assert_eq!((p0, size0, display0), ((0, 0), (40, 30), (40, 30)));
    let (p, size, display, region) = read_layer(&part);
    assert_eq!((p, size, display), ((5, 3), (22, 17), (40, 30)));
    assert_eq!(region.len(), whole.len());
    for ((name, r), (name0, f)) in region.iter().zip(&whole) {
        assert_eq!(name, name0);
        for y in 0..17 {
            for x in 0..22 {
                let (a, b) = (r[y * 22 + x], f[(y + 3) * 40 + x + 5]);
                assert_eq!(a.to_bits(), b.to_bits(), "{name} at ({}, {})", x + 5, y + 3);
            }
        }
    }
    // exrheader (OpenEXR's own tool), when installed, reads the same windows.
    match std::process::Command::new("exrheader").arg(&part).output() {
        Ok(o) if o.status.success() => {
            let out = text(&o.stdout);
            assert!(out.contains("dataWindow (type box2i): (5 3) - (26 19)"), "{out}");
            assert!(out.contains("displayWindow (type box2i): (0 0) - (39 29)"), "{out}");
        }
        _ => eprintln!("exrheader not installed: checked the windows with the exr crate only"),
    }
}

#[test]
fn bad_regions_and_tiles_are_refused_with_one_line() {
    let dir = TempDir::new("bad-region");
    let scene = scene_path("whitted.toml");
    let out = dir.path("o.exr");
    let o = out.to_str().unwrap();
    let base = ["render", &scene, "-o", o, "--width", "40", "--height", "30"];
    let with = |extra: &[&str]| -> String {
        let mut a = base.to_vec();
        a.extend(extra);
        fails(&dir, &a)
    };
    assert!(with(&["--region", "0,0,41,30"]).contains("outside the 40 × 30 image"));
    assert!(with(&["--region", "5,5,5,9"]).contains("empty"));
    assert!(with(&["--region", "9,5,4,9"]).contains("reversed"));
    assert!(with(&["--region", "1,2,3"]).contains("x0,y0,x1,y1"));
    assert!(with(&["--tile", "0/4"]).contains("1-based"));
    assert!(with(&["--tile", "5/4"]).contains("from 1 to 4"));
    assert!(with(&["--tile", "1/31"]).contains("at most 30"));
    assert!(with(&["--tile", "2"]).contains("I/N"));
    let mut a = base.to_vec();
    a.extend(["--tile", "1/2", "--region", "0,0,2,2"]);
    let both = strahl(&a);
    assert!(!both.status.success() && text(&both.stderr).contains("cannot be used with"));
    assert!(dir.entries().is_empty());
}

#[test]
fn merge_refuses_missing_overlapping_and_foreign_parts() {
    let dir = TempDir::new("merge-refuses");
    let scene = scene_path("whitted.toml");
    let part = |name: &str, extra: &[&str]| {
        let p = dir.path(name);
        render(&scene, &p, extra);
        p.to_str().unwrap().to_string()
    };
    let t1 = part("t1.exr", &["--tile", "1/3"]);
    let t2 = part("t2.exr", &["--tile", "2/3"]);
    let t3 = part("t3.exr", &["--tile", "3/3"]);
    let wide = part("wide.exr", &["--region", "0,5,40,15"]);
    let foreign = part("foreign.exr", &["--tile", "3/3", "--depth", "3"]);
    let half = part("half.exr", &["--tile", "3/3", "--compression", "piz"]);
    let out = dir.path("m.exr");
    let out = out.to_str().unwrap();

    let e = fails(&dir, &["merge", out, &t1, &t3]);
    assert!(e.contains("do not cover the 40 × 30 image: missing 0,10,40,20"), "{e}");
    let e = fails(&dir, &["merge", out, &t1, &wide, &t2, &t3]);
    assert!(e.contains("overlap in 0,5,40,10"), "{e}");
    let e = fails(&dir, &["merge", out, &t1, &t2, &foreign]);
    assert!(e.contains("foreign.exr: scene/settings hash") && e.contains("different scenes or settings"), "{e}");
    let e = fails(&dir, &["merge", out, &t1, &t2, &half]);
    assert!(e.contains("half.exr: compression"), "{e}");
    let e = fails(&dir, &["merge", &t1, &t1, &t2, &t3]);
    assert!(e.contains("is both a part and the output"), "{e}");
    let junk = dir.write("junk.exr", b"not an exr");
    let e = fails(&dir, &["merge", out, &t1, &t2, junk.to_str().unwrap()]);
    assert!(e.contains("junk.exr: not a readable OpenEXR file"), "{e}");
    let o = strahl(&["merge", out, &t3, &t1, &t2]);
    assert!(o.status.success(), "{}", text(&o.stderr));
}

#[test]
fn farm_slurm_writes_an_array_of_tile_renders_and_a_dependent_merge() {
    let dir = TempDir::new("slurm-scripts");
    let out = dir.path("frame.exr");
    let o = strahl(&[
        "farm",
        "slurm",
        &scene_path("whitted.toml"),
        "-o",
        out.to_str().unwrap(),
        "--tiles",
        "8",
        "--partition",
        "render",
        "--time",
        "30:00",
        "--",
        "--spp",
        "16",
    ]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let farm = dir.path("frame.exr.farm");
    let render = std::fs::read_to_string(farm.join("render.sbatch")).unwrap();
    for line in ["#SBATCH --array=1-8", "#SBATCH --partition=render", "#SBATCH --time=30:00", "#SBATCH --requeue"] {
        assert!(render.contains(line), "{line} in {render}");
    }
    assert!(render.contains("--tile \"$SLURM_ARRAY_TASK_ID\"/8 --resume '--spp' '16'"), "{render}");
    let merge = std::fs::read_to_string(farm.join("merge.sbatch")).unwrap();
    assert!(merge.contains(&format!("merge '{}'", out.display())), "{merge}");
    assert!(merge.contains(&format!("'{}'\n", farm.join("tile-8.exr").display())), "{merge}");
    assert!(text(&o.stdout).contains("--dependency=afterok:"));
    // The jobs set these themselves.
    let e = fails(
        &dir,
        &[
            "farm",
            "slurm",
            &scene_path("whitted.toml"),
            "-o",
            out.to_str().unwrap(),
            "--tiles",
            "2",
            "--",
            "--tile",
            "1/2",
        ],
    );
    assert!(e.contains("must not set"), "{e}");
}
