//! Regions, farm tiles and `strahl merge`: a frame rendered in pieces and merged is the same
//! file, byte for byte, as the frame rendered in one process; a region's EXR places its pixels
//! by its dataWindow; bad regions, tiles and part sets are refused with one line.
//! `strahl farm slurm`: every value reaches the jobs exactly as given or is refused in one line
//! before anything is written (run through a model of sbatch, with hostile strings), and the
//! farm's frame equals a local render byte for byte.

mod common;

use std::ffi::{OsStr, OsString};
use std::os::unix::ffi::OsStringExt;
use std::os::unix::fs::PermissionsExt;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

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
        _ => common::skip("exrheader is not installed: checked the windows with the exr crate only"),
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

// ---- strahl farm slurm ----------------------------------------------------------------------
//
// The jobs run through tests/slurm_stub.py, a model of sbatch (its #SBATCH parser, its log
// names, --open-mode), put on PATH as `sbatch`; with SBATCH_STUB_RUN=1 it runs every task at
// once with bash. `--strahl` names a recorder that appends its working directory and argv to
// a file, so a test sees exactly what each task received.

/// A folder with the sbatch stub and a strahl recorder, where farm tests run.
struct Farm {
    dir: TempDir,
}

/// One run of the recorder: its working directory and arguments.
#[derive(Debug, PartialEq)]
struct Call {
    cwd: OsString,
    argv: Vec<OsString>,
}

const RECORDER: &str =
    "#!/bin/bash\n{ printf '%s\\0' \"$#\" \"$PWD\" \"$@\"; } >> \"$STRAHL_RECORD\"\necho \"recorded $# arguments\"\n";

impl Farm {
    /// `None` (saying so) when python3, which runs the stub, is missing.
    fn new(tag: &str) -> Option<Farm> {
        // The system's interpreter when there is one: a version manager's shim takes ~1 s a call.
        let python = ["/usr/bin/python3", "python3"].into_iter().find(|p| Command::new(p).arg("-V").output().is_ok());
        let Some(python) = python else {
            common::skip("python3 (for tests/slurm_stub.py) is not installed");
            return None;
        };
        let dir = TempDir::new(tag);
        for sub in ["bin", "state", "root"] {
            std::fs::create_dir(dir.path(sub)).unwrap();
        }
        let stub = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/slurm_stub.py");
        let wrapper = format!("#!/bin/sh\nexec {python} -S '{}' \"$@\"\n", stub.display());
        executable(&dir.path("bin/sbatch"), &wrapper);
        executable(&dir.path("recorder"), RECORDER);
        Some(Farm { dir })
    }

    /// Where the jobs run and what they write: the working directory of every command here.
    fn root(&self) -> PathBuf {
        self.dir.path("root")
    }

    fn recorder(&self) -> PathBuf {
        self.dir.path("recorder")
    }

    /// `program args` in the root, with the stub first on PATH; `run`: the stub runs the jobs.
    fn command(&self, program: impl AsRef<OsStr>, run: bool) -> Command {
        let mut c = Command::new(program);
        let path = format!("{}:{}", self.dir.path("bin").display(), std::env::var("PATH").unwrap_or_default());
        c.current_dir(self.root())
            .env("PATH", path)
            .env("SBATCH_STUB_DIR", self.dir.path("state"))
            .env("STRAHL_RECORD", self.dir.path("record"))
            .env("SOURCE_DATE_EPOCH", "1700000000")
            .env("SBATCH_STUB_RUN", if run { "1" } else { "0" });
        c
    }

    fn strahl<S: AsRef<OsStr>>(&self, args: &[S], run: bool) -> Output {
        self.command(env!("CARGO_BIN_EXE_strahl"), run).args(args).output().unwrap()
    }

    /// Every run of the recorder so far, in order.
    fn calls(&self) -> Vec<Call> {
        let bytes = std::fs::read(self.dir.path("record")).unwrap_or_default();
        let mut fields = bytes.split(|&b| b == 0).map(|f| OsString::from_vec(f.to_vec()));
        let mut calls = Vec::new();
        while let Some(count) = fields.next() {
            let Ok(n) = count.to_string_lossy().parse::<usize>() else { break };
            let cwd = fields.next().unwrap();
            calls.push(Call { cwd, argv: fields.by_ref().take(n).collect() });
        }
        calls
    }

    /// The stub's records: one per submission (`argv`, `options`, `job_id`), one per task run
    /// (`ran`, `task`, `log`, `status`).
    fn submissions(&self) -> Vec<serde_json::Value> {
        let text = std::fs::read_to_string(self.dir.path("state/submissions.jsonl")).unwrap_or_default();
        text.lines().map(|l| serde_json::from_str(l).unwrap()).collect()
    }

    /// Every file named PWNED anywhere under the farm's folder (what the payloads make).
    fn pwned(&self) -> Vec<PathBuf> {
        fn walk(dir: &Path, found: &mut Vec<PathBuf>) {
            for entry in std::fs::read_dir(dir).into_iter().flatten().flatten() {
                let path = entry.path();
                if entry.file_name() == "PWNED" {
                    found.push(path.clone());
                }
                if entry.file_type().is_ok_and(|t| t.is_dir()) {
                    walk(&path, found);
                }
            }
        }
        let mut found = Vec::new();
        walk(&self.dir.0, &mut found);
        found
    }
}

fn executable(path: &Path, text: &str) {
    std::fs::write(path, text).unwrap();
    std::fs::set_permissions(path, std::fs::Permissions::from_mode(0o755)).unwrap();
}

fn os(s: impl AsRef<OsStr>) -> OsString {
    s.as_ref().to_os_string()
}

/// `path` with `suffix` appended to its last component.
fn with_suffix(path: &Path, suffix: &str) -> PathBuf {
    let mut s = path.as_os_str().to_os_string();
    s.push(suffix);
    PathBuf::from(s)
}

/// The arguments task `i` of `n` must receive.
fn task_argv(scene: &Path, folder: &Path, i: u32, n: u32, extra: &[OsString]) -> Vec<OsString> {
    let mut argv = vec![os("render"), os(scene), os("-o"), os(folder.join(format!("tile-{i}.exr")))];
    argv.extend([os("--tile"), os(format!("{i}/{n}")), os("--resume")]);
    argv.extend(extra.iter().cloned());
    argv
}

/// The arguments the merge job must receive (in the folder).
fn merge_argv(output: &Path, n: u32) -> Vec<OsString> {
    let mut argv = vec![os("merge"), os(output)];
    argv.extend((1..=n).map(|i| os(format!("tile-{i}.exr"))));
    argv
}

/// `stderr` is one `error: …` line that contains `naming`.
fn refused(o: &Output, naming: &str) {
    let e = text(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{e}");
    assert_eq!(e.lines().count(), 1, "one line: {e:?}");
    assert!(e.starts_with("error: ") && e.contains(naming), "{naming:?} in {e:?}");
}

#[test]
fn farm_slurm_writes_an_array_of_tile_renders_and_a_merge_after_it() {
    let dir = TempDir::new("slurm-scripts");
    let out = dir.path("frame.exr");
    let args = ["farm", "slurm", &scene_path("whitted.toml"), "-o", out.to_str().unwrap(), "--tiles", "8"];
    let o = strahl(
        &[&args[..], &["--partition", "render", "--time", "30:00", "--cpus", "2", "--", "--spp", "16"]].concat(),
    );
    assert!(o.status.success(), "{}", text(&o.stderr));
    let farm = dir.path("frame.exr.farm");
    let render = std::fs::read_to_string(farm.join("render.sbatch")).unwrap();
    for line in [
        "#SBATCH --array=1-8",
        "#SBATCH --partition=render",
        "#SBATCH --time=30:00",
        "#SBATCH --cpus-per-task=2",
        "#SBATCH --requeue",
        "#SBATCH --open-mode=append",
        &format!("#SBATCH --output=\"{}/render-%A_%a.log\"", farm.display()),
    ] {
        assert!(render.lines().any(|l| l == line), "{line} in {render}");
    }
    assert!(render.contains("--tile \"$SLURM_ARRAY_TASK_ID\"/8 --resume --threads 2 '--spp' '16'\n"), "{render}");
    let merge = std::fs::read_to_string(farm.join("merge.sbatch")).unwrap();
    assert!(merge.contains("#SBATCH --open-mode=append\n"), "{merge}");
    assert!(merge.contains(&format!("cd '{}' || exit 1\n", farm.display())), "{merge}");
    assert!(merge.contains(&format!("merge '{}' tile-1.exr tile-2.exr", out.display())), "{merge}");
    assert!(merge.ends_with(" tile-8.exr\n"), "{merge}");
    let printed = text(&o.stdout);
    assert!(printed.contains("sbatch --dependency=afterany:\"${id%%;*}\""), "{printed}");
}

#[test]
fn injection_strings_are_refused_in_one_line_before_anything_is_written() {
    let Some(farm) = Farm::new("slurm-injection") else { return };
    let scene = scene_path("whitted.toml");
    let root = farm.root();
    std::fs::create_dir(root.join("out")).unwrap();
    let hostile_folder = root.join("d\ntouch PWNED;");
    std::fs::create_dir(&hostile_folder).unwrap();
    let recorder = farm.recorder();
    let cases: [(Vec<OsString>, &str); 4] = [
        (vec![os("-o"), os("out/a\ntouch PWNED\nb.exr")], "the output (-o)"),
        (vec![os("-o"), os("out/x.exr"), os("--partition"), os("p\ntouch PWNED")], "--partition \"p\\ntouch PWNED\""),
        (vec![os("-o"), os("out/x.exr"), os("--time"), os("1:00\ntouch PWNED")], "--time \"1:00\\ntouch PWNED\""),
        (vec![os("-o"), os(hostile_folder.join("frame.exr"))], "d\\ntouch PWNED;"),
    ];
    for (extra, naming) in cases {
        let mut args = vec![os("farm"), os("slurm"), os(&scene), os("--tiles"), os("2"), os("--submit")];
        args.extend([os("--strahl"), os(&recorder)]);
        args.extend(extra);
        let o = farm.strahl(&args, true);
        refused(&o, naming);
        assert!(std::fs::read_dir(root.join("out")).unwrap().next().is_none(), "{args:?} wrote into out/");
        assert!(std::fs::read_dir(&hostile_folder).unwrap().next().is_none(), "{args:?} wrote a folder");
    }
    assert!(farm.submissions().is_empty() && farm.calls().is_empty());
    assert!(farm.pwned().is_empty(), "{:?}", farm.pwned());
}

#[test]
fn hostile_paths_slurm_can_carry_reach_every_task_exactly() {
    let Some(farm) = Farm::new("slurm-carried") else { return };
    let root = farm.root();
    // Spaces, quotes, $( ), backticks, ;, #, % patterns of Slurm's log names, non-ASCII.
    let hostile = "d $(touch PWNED) `touch PWNED`;'\"# 50%A %% ш";
    let folder = root.join(hostile);
    std::fs::create_dir(&folder).unwrap();
    let scene = folder.join("scene $(touch PWNED).toml");
    std::fs::copy(scene_path("whitted.toml"), &scene).unwrap();
    let strahl_dir = root.join(format!("bin {hostile}"));
    std::fs::create_dir(&strahl_dir).unwrap();
    let recorder = strahl_dir.join("strahl;touch PWNED");
    std::fs::copy(farm.recorder(), &recorder).unwrap();
    let output = folder.join("frame '$(touch PWNED)'.exr");
    let args = [
        os("farm"),
        os("slurm"),
        os(&scene),
        os("-o"),
        os(&output),
        os("--tiles"),
        os("3"),
        os("--cpus"),
        os("2"),
        os("--partition"),
        os("render,gpu_a.1"),
        os("--time"),
        os("1-00:30"),
        os("--strahl"),
        os(&recorder),
        os("--submit"),
        os("--"),
        os("--spp"),
        os("3"),
    ];
    let o = farm.strahl(&args, true);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let jobs_folder = with_suffix(&output, ".farm");
    let extra = [os("--threads"), os("2"), os("--spp"), os("3")];
    let mut expected: Vec<Call> =
        (1..=3).map(|i| Call { cwd: os(&root), argv: task_argv(&scene, &jobs_folder, i, 3, &extra) }).collect();
    expected.push(Call { cwd: os(&jobs_folder), argv: merge_argv(&output, 3) });
    assert_eq!(farm.calls(), expected);
    let submissions = farm.submissions();
    let render = &submissions[0]["options"];
    assert_eq!(render["partition"], "render,gpu_a.1");
    assert_eq!(render["time"], "1-00:30");
    assert_eq!(render["array"], "1-3");
    assert_eq!(render["open-mode"], "append");
    for i in 1..=3 {
        let log = jobs_folder.join(format!("render-100_{i}.log"));
        assert_eq!(std::fs::read_to_string(&log).unwrap(), "recorded 11 arguments\n", "{}", log.display());
    }
    let merge =
        submissions.iter().find(|s| s["argv"][1] == "--dependency=afterany:100").expect("the merge's submission");
    assert!(jobs_folder.join(format!("merge-{}.log", merge["job_id"])).is_file());
    assert!(farm.pwned().is_empty(), "{:?}", farm.pwned());
}

#[test]
fn the_printed_submit_commands_run_nothing_when_pasted() {
    let Some(farm) = Farm::new("slurm-printed") else { return };
    std::fs::create_dir(farm.root().join("out")).unwrap();
    let args = ["farm", "slurm", &scene_path("whitted.toml"), "-o", "out/$(touch PWNED).exr", "--tiles", "2"];
    let o = farm.strahl(&args, false);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let printed = text(&o.stdout);
    let commands = printed.split_once("submit with:\n").expect("the submit commands").1;
    let pasted = farm.command("bash", false).arg("-c").arg(commands).output().unwrap();
    assert!(pasted.status.success(), "{commands}: {}", text(&pasted.stderr));
    let folder = std::fs::canonicalize(farm.root()).unwrap().join("out/$(touch PWNED).exr.farm");
    let submitted: Vec<serde_json::Value> = farm.submissions().into_iter().map(|s| s["argv"].clone()).collect();
    let render = folder.join("render.sbatch").to_str().unwrap().to_string();
    let merge = folder.join("merge.sbatch").to_str().unwrap().to_string();
    assert_eq!(
        submitted,
        [serde_json::json!(["--parsable", render]), serde_json::json!(["--dependency=afterany:100", merge])]
    );
    assert!(farm.pwned().is_empty(), "{:?}", farm.pwned());
}

#[test]
fn a_requeued_task_appends_to_its_log() {
    let Some(farm) = Farm::new("slurm-requeue") else { return };
    let out = farm.root().join("frame.exr");
    let args = [os("farm"), os("slurm"), os(scene_path("whitted.toml")), os("-o"), os(&out), os("--tiles"), os("1")];
    let o = farm.strahl(&[&args[..], &[os("--strahl"), os(farm.recorder())]].concat(), false);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let script = farm.root().join("frame.exr.farm/render.sbatch");
    // The same job run twice, as Slurm runs a requeued task under its id.
    for _ in 0..2 {
        let run = farm.command("sbatch", true).env("SBATCH_STUB_JOB_ID", "7").arg(&script).output().unwrap();
        assert!(run.status.success(), "{}", text(&run.stderr));
    }
    let log = std::fs::read_to_string(farm.root().join("frame.exr.farm/render-7_1.log")).unwrap();
    assert_eq!(log, "recorded 7 arguments\nrecorded 7 arguments\n");
}

#[test]
fn render_options_every_task_would_refuse_are_refused_before_anything_is_written() {
    let dir = TempDir::new("slurm-refuses");
    let scene = scene_path("whitted.toml");
    let out = dir.path("frame.exr");
    let out = out.to_str().unwrap();
    let size = ["--width", "40", "--height", "30"];
    let cases: &[(&[&str], &[&str], &str)] = &[
        (&[], &["--output=x.exr"], "must not set -o/--output"),
        (&[], &["-ox.exr"], "must not set -o/--output"),
        (&[], &["--tile=1/1"], "must not set --tile"),
        (&[], &["--region=0,0,4,4"], "must not set --region"),
        (&[], &["--resume"], "must not set --resume"),
        (&[], &["--png", "x.png"], "every tile would write the same PNG"),
        (&[], &["other.toml"], "must not name a scene"),
        (&[], &["--spp", "abc"], "invalid value 'abc' for '--spp <N>'"),
        (&[], &["--passes", "combined,nonsense"], "--passes"),
        (&[], &["--camera", "front"], "--camera chooses among the cameras of a glTF file"),
        (&["--cpus", "2"], &["--threads", "4"], "--threads 4 disagrees with --cpus 2"),
        (&["--cpus", "4"], &["--threads", "4"], "already run --cpus 4 threads"),
        (&[], &["--threads", "4"], "give --cpus 4 instead"),
        (&["--tiles", "31"], &size, "--tiles 31 is more than the image's 30 rows"),
        (&[], &["--exposure", "inf"], "--exposure inf is not a finite number"),
        (&[], &["--integrator", "path", "--spp", "70000"], "spp 70000 is more than the 65536 samples per pixel"),
        (&[], &["--integrator", "path", "--clamp", "0"], "clamp 0 must be finite and > 0"),
        (&[], &["--checkpoint-every", "-1"], "--checkpoint-every -1 is not a number of seconds"),
        (&[], &["--checkpoint-every", "1e20"], "-- --checkpoint-every 1e20 is not a number of seconds from 0 to 1e9"),
        (&[], &["--max-memory", "1K"], "more than -- --max-memory 1 MB"),
        (&[], &["--environment-strength", "2"], "--environment-strength: the scene has no environment"),
        (&[], &["--environment", "1,1,1", "--environment-rotation", "nan"], "--environment-rotation NaN: rotation"),
        (&[], &["--environment", "no-such-sky.exr"], "no-such-sky.exr"),
        (&[], &["--light-sampler", "uniform"], "light_sampler \"uniform\" is not one of"),
        (&["--partition", "a b"], &[], "--partition \"a b\": is not a Slurm partition name"),
        (&["--time", "30 minutes"], &[], "--time \"30 minutes\": is not a Slurm time limit"),
    ];
    for (farm_options, render_options, expected) in cases {
        let mut args = vec!["farm", "slurm", &scene, "-o", out];
        if !farm_options.contains(&"--tiles") {
            args.extend(["--tiles", "4"]);
        }
        args.extend(*farm_options);
        args.push("--");
        args.extend(*render_options);
        let e = fails(&dir, &args);
        assert!(e.contains(expected), "{args:?}: {expected:?} in {e:?}");
    }
    let mesh = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/meshes/blob.ply");
    let e = fails(&dir, &["farm", "slurm", mesh.to_str().unwrap(), "-o", out, "--tiles", "2"]);
    assert!(e.contains("blob.ply: is a mesh file"), "{e}");
    // clap's own range: a usage error, status 2, nothing written.
    let o = strahl(&["farm", "slurm", &scene, "-o", out, "--tiles", "10001"]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o.stderr));
    assert!(dir.entries().is_empty());
}

#[test]
fn a_farm_frame_equals_a_local_render_byte_for_byte_whatever_the_scene_path_spelling() {
    let Some(farm) = Farm::new("slurm-frame") else { return };
    let repo = Path::new(env!("CARGO_MANIFEST_DIR"));
    let options = ["--width", "40", "--height", "30", "--spp", "2", "--passes", "all"];
    let local = farm.root().join("local.exr");
    // Spelled relative to the repository here; the farm makes it absolute.
    let o = Command::new(env!("CARGO_BIN_EXE_strahl"))
        .current_dir(repo)
        .args(["render", "scenes/cornell.toml", "-o", local.to_str().unwrap(), "--threads", "2"])
        .args(options)
        .env("SOURCE_DATE_EPOCH", "1700000000")
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", text(&o.stderr));
    let spelled = repo.join("scenes/../scenes/./cornell.toml");
    let frame = farm.root().join("frame.exr");
    let mut args = vec![os("farm"), os("slurm"), os(&spelled), os("-o"), os(&frame), os("--tiles"), os("3")];
    args.extend([os("--cpus"), os("1"), os("--submit"), os("--")]);
    args.extend(options.iter().map(os));
    let o = farm.strahl(&args, true);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let runs: Vec<_> = farm.submissions().into_iter().filter(|s| s.get("ran").is_some()).collect();
    assert_eq!(runs.len(), 4, "{runs:?}");
    assert!(runs.iter().all(|r| r["status"] == 0), "{runs:?}");
    assert!(
        std::fs::read(&frame).unwrap() == std::fs::read(&local).unwrap(),
        "the farm's frame differs from the local render"
    );
    let image = read_exr_image(&frame);
    use exr::meta::attribute::{AttributeValue, Text};
    let scene = image.layer_data[0].attributes.other.get(&Text::from("strahl/scene"));
    assert_eq!(scene, Some(&AttributeValue::Text(Text::from("cornell.toml"))));
}

/// Pieces of hostile strings: shell and sbatch syntax, Slurm's log-name patterns, control
/// characters, non-ASCII; `None` stands for a byte that is not UTF-8.
const PIECES: &[Option<&str>] = &[
    Some("a"),
    Some("Z9"),
    Some(" "),
    Some("'"),
    Some("\""),
    Some("\\"),
    Some("$(touch PWNED)"),
    Some("`touch PWNED`"),
    Some(";touch PWNED;"),
    Some("#"),
    Some("%"),
    Some("%A"),
    Some("%%"),
    Some("%5a"),
    Some("\n"),
    Some("\ntouch PWNED\n"),
    Some("\r"),
    Some("\r\n"),
    Some("\t"),
    Some("\x1b[31m"),
    Some("ш"),
    Some("❤"),
    Some("*"),
    Some("?"),
    Some("~"),
    Some("-"),
    Some("--"),
    Some("="),
    Some("!"),
    Some("$HOME"),
    Some("${IFS}"),
    Some("&"),
    Some("|"),
    Some(">PWNED"),
    Some("("),
    Some("}"),
    Some("."),
    Some(","),
    Some(":"),
    None,
];

/// A string of 0-6 pieces; `plain`: none that the output path may not hold (control
/// characters, backslash, non-UTF-8).
fn hostile(rng: &mut rand_pcg::Pcg64Mcg, plain: bool) -> OsString {
    use rand::Rng;
    let mut bytes = Vec::new();
    for _ in 0..rng.random_range(0..=6) {
        let piece = PIECES[rng.random_range(0..PIECES.len())];
        match piece {
            Some(p) if plain && (p.chars().any(char::is_control) || p.contains('\\')) => bytes.push(b'x'),
            Some(p) => bytes.extend(p.as_bytes()),
            None if plain => bytes.push(b'y'),
            None => bytes.extend([0xff, b'z']),
        }
    }
    OsString::from_vec(bytes)
}

/// A file name from [`hostile`]: no `/`, never empty, `.` or `..`.
fn hostile_name(rng: &mut rand_pcg::Pcg64Mcg, plain: bool) -> OsString {
    let mut name = hostile(rng, plain).into_vec();
    name.retain(|&b| b != b'/');
    name.insert(0, b'n');
    OsString::from_vec(name)
}

#[test]
fn every_value_farm_slurm_writes_reaches_the_jobs_exactly_or_is_refused_in_one_line() {
    use rand::{Rng, SeedableRng};
    use strahl::farm::{SlurmJob, slurm_scripts};
    let Some(farm) = Farm::new("slurm-property") else { return };
    let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(27);
    let (mut carried, mut refusals) = (0, 0);
    for round in 0..160 {
        let root = farm.root().join(format!("r{round}"));
        std::fs::create_dir(&root).unwrap();
        let mut pick = |p: f64| rng.random_bool(p);
        let (plain_output, plain_strahl) = (pick(0.8), pick(0.9));
        let output = root.join(hostile_name(&mut rng, plain_output)).join({
            let mut n = hostile_name(&mut rng, plain_output);
            n.push(".exr");
            n
        });
        let strahl = root.join(hostile_name(&mut rng, plain_strahl)).join("strahl");
        let some = |rng: &mut rand_pcg::Pcg64Mcg, p: f64| rng.random_bool(p);
        let partition = match rng.random_range(0..4) {
            0 => None,
            1 => Some(hostile(&mut rng, false).to_string_lossy().into_owned()),
            _ => Some(["render", "a,b", "gpu_a.1+x"][rng.random_range(0..3)].to_string()),
        };
        let time = match rng.random_range(0..4) {
            0 => None,
            1 => Some(hostile(&mut rng, false).to_string_lossy().into_owned()),
            _ => Some(["30", "1:00:00", "2-12:30", "UNLIMITED"][rng.random_range(0..4)].to_string()),
        };
        let absolute = |s: OsString| {
            let mut p = OsString::from("/");
            p.push(s);
            PathBuf::from(p)
        };
        let plain_rest = some(&mut rng, 0.85);
        let job = SlurmJob {
            strahl: strahl.clone(),
            scene: absolute(hostile(&mut rng, plain_rest)),
            output: output.clone(),
            tiles: rng.random_range(1..=3),
            partition,
            time,
            cpus: some(&mut rng, 0.5).then(|| rng.random_range(1..=8)),
            confine: some(&mut rng, 0.3).then(|| absolute(hostile(&mut rng, plain_rest))),
            render_options: (0..rng.random_range(0..4)).map(|_| hostile(&mut rng, plain_rest)).collect(),
            denoise: rng.random_bool(0.5),
        };
        // What must be refused, by the rules of strahl::farm's module docs.
        let carries = |s: &OsStr| s.to_str().is_some();
        let output_ok = output.to_str().is_some_and(|s| !s.contains('\\') && !s.chars().any(char::is_control));
        let name_ok = |n: &str| !n.is_empty() && n.chars().all(|c| c.is_ascii_alphanumeric() || "._-+".contains(c));
        let time_ok = |t: &str| {
            let number = |s: &str| (1..=9).contains(&s.len()) && s.bytes().all(|b| b.is_ascii_digit());
            let (days, clock) = t.split_once('-').map_or((None, t), |(d, c)| (Some(d), c));
            let fields: Vec<&str> = clock.split(':').collect();
            t.eq_ignore_ascii_case("unlimited")
                || (days.is_none_or(number) && fields.len() <= 3 && fields.iter().all(|f| number(f)))
        };
        let bad: Vec<&str> = [
            (!output_ok, "the output (-o)"),
            (!carries(strahl.as_os_str()), "--strahl"),
            (!carries(job.scene.as_os_str()), "the scene"),
            (!job.confine.as_ref().is_none_or(|c| carries(c.as_os_str())), "--confine"),
            (!job.partition.as_deref().is_none_or(|p| p.split(',').all(name_ok)), "--partition"),
            (!job.time.as_deref().is_none_or(time_ok), "--time"),
            (!job.render_options.iter().all(|o| carries(o)), "the render option"),
        ]
        .into_iter()
        .filter_map(|(b, name)| b.then_some(name))
        .collect();
        let scripts = match slurm_scripts(&job) {
            Err(e) => {
                let e = e.to_string();
                assert!(!e.contains('\n'), "one line: {e:?}");
                assert!(bad.iter().any(|b| e.starts_with(b)), "{e:?} names none of {bad:?} ({job:?})");
                refusals += 1;
                continue;
            }
            Ok(s) => s,
        };
        assert!(bad.is_empty(), "{job:?} was not refused, though {bad:?}");
        carried += 1;
        std::fs::create_dir_all(&scripts.folder).unwrap();
        std::fs::create_dir_all(strahl.parent().unwrap()).unwrap();
        std::fs::copy(farm.recorder(), &strahl).unwrap();
        std::fs::write(scripts.render_path(), &scripts.render).unwrap();
        std::fs::write(scripts.merge_path(), &scripts.merge).unwrap();
        for shell in ["bash", "sh"] {
            for script in [scripts.render_path(), scripts.merge_path()] {
                let o = Command::new(shell).arg("-n").arg(&script).output().unwrap();
                assert!(o.status.success(), "{shell} -n {}: {}", script.display(), text(&o.stderr));
            }
        }
        // Submitted by the printed commands, as pasted into bash; the stub runs the jobs.
        let before = farm.calls().len();
        let submitted = farm.submissions().len();
        let o =
            farm.command("bash", true).current_dir(&root).arg("-c").arg(scripts.submit_commands()).output().unwrap();
        assert!(o.status.success(), "{job:?}: {}", text(&o.stderr));
        let n = job.tiles;
        let mut extra = Vec::new();
        if let Some(c) = job.cpus {
            extra.extend([os("--threads"), os(c.to_string())]);
        }
        if let Some(d) = &job.confine {
            extra.extend([os("--confine"), os(d)]);
        }
        extra.extend(job.render_options.iter().cloned());
        let mut expected: Vec<Call> = (1..=n)
            .map(|i| Call { cwd: os(&root), argv: task_argv(&job.scene, &scripts.folder, i, n, &extra) })
            .collect();
        if job.denoise {
            // Merged into the jobs' folder, then denoised once into the output.
            expected.push(Call { cwd: os(&scripts.folder), argv: merge_argv(Path::new("noisy.exr"), n) });
            let denoise = vec![os("denoise"), os("noisy.exr"), os("-o"), os(&output)];
            expected.push(Call { cwd: os(&scripts.folder), argv: denoise });
        } else {
            expected.push(Call { cwd: os(&scripts.folder), argv: merge_argv(&output, n) });
        }
        assert_eq!(farm.calls()[before..], expected[..], "{job:?}");
        let records = &farm.submissions()[submitted..];
        let render = &records[0];
        assert_eq!(render["options"]["partition"].as_str(), job.partition.as_deref(), "{job:?}");
        assert_eq!(render["options"]["time"].as_str(), job.time.as_deref(), "{job:?}");
        assert_eq!(render["options"]["array"], format!("1-{n}"));
        let id = render["job_id"].as_u64().unwrap();
        for i in 1..=n {
            let log = scripts.folder.join(format!("render-{id}_{i}.log"));
            let expected = format!("recorded {} arguments\n", 7 + extra.len());
            assert_eq!(std::fs::read_to_string(&log).ok().as_deref(), Some(&expected[..]), "{}", log.display());
        }
        assert!(records.iter().filter(|r| r.get("ran").is_some()).all(|r| r["status"] == 0), "{records:?}");
        assert!(farm.pwned().is_empty(), "{job:?}: {:?}", farm.pwned());
    }
    eprintln!("{carried} carried exactly, {refusals} refused");
    assert!(carried >= 40 && refusals >= 40, "{carried} carried, {refusals} refused");
}

#[test]
fn an_environment_map_among_the_render_options_is_read_and_confined_before_anything_is_written() {
    let dir = TempDir::new("slurm-environment");
    let inside = dir.path("inside");
    std::fs::create_dir(&inside).unwrap();
    let scene = inside.join("scene.toml");
    std::fs::copy(scene_path("cornell-path.toml"), &scene).unwrap();
    // A readable map outside the confined folder: refused by the farm, naming it.
    let pixels = vec![image::Rgb([0.5f32, 0.5, 0.5]); 8 * 4];
    let mut bytes = Vec::new();
    image::codecs::hdr::HdrEncoder::new(&mut bytes).encode(&pixels, 8, 4).unwrap();
    let sky = dir.write("sky.hdr", &bytes);
    let out = inside.join("frame.exr");
    let (s, o, m, d) =
        (scene.to_str().unwrap(), out.to_str().unwrap(), sky.to_str().unwrap(), inside.to_str().unwrap());
    let e = fails(&dir, &["farm", "slurm", s, "-o", o, "--tiles", "2", "--confine", d, "--", "--environment", m]);
    assert!(e.contains("sky.hdr") && e.contains("--confine"), "{e}");
    assert!(!out.with_extension("exr.farm").exists());
    // Inside it, with strength and rotation: the scripts carry the options as given.
    let inner = inside.join("sky.hdr");
    std::fs::copy(&sky, &inner).unwrap();
    let args =
        ["--environment", inner.to_str().unwrap(), "--environment-strength", "2", "--environment-rotation", "-30"];
    let mut all = vec!["farm", "slurm", s, "-o", o, "--tiles", "2", "--confine", d, "--"];
    all.extend(args);
    let ok = strahl(&all);
    assert!(ok.status.success(), "{}", text(&ok.stderr));
    let script = std::fs::read_to_string(inside.join("frame.exr.farm/render.sbatch")).unwrap();
    assert!(script.contains("'--environment-rotation' '-30'"), "{script}");
}

#[test]
fn merge_removes_the_temporaries_killed_runs_of_this_host_left_and_nothing_else() {
    let host = std::fs::read_to_string("/proc/sys/kernel/hostname").unwrap_or_default().trim().to_string();
    if host.is_empty() || host.len() > 40 || !host.bytes().all(|b| b.is_ascii_alphanumeric() || b"._-".contains(&b)) {
        common::skip(&format!("host name {host:?} is not kept as it is in temporary names"));
        return;
    }
    let dir = TempDir::new("merge-stale");
    let scene = scene_path("whitted.toml");
    let parts: Vec<PathBuf> = (1..=2).map(|i| dir.path(&format!("t{i}.exr"))).collect();
    for (i, part) in parts.iter().enumerate() {
        render(&scene, part, &["--tile", &format!("{}/2", i + 1)]);
    }
    // A writer that is gone: a process that has ended.
    let mut ended = Command::new("true").spawn().unwrap();
    ended.wait().unwrap();
    let stale = format!(".strahl-{host}-{}-1-0.tmp", ended.id());
    let foreign = format!(".strahl-another-host-{}-1-0.tmp", ended.id());
    std::fs::write(dir.path(&stale), vec![0u8; 1000]).unwrap();
    std::fs::write(dir.path(&foreign), b"x").unwrap();
    let o = merge(&dir.path("frame.exr"), &parts);
    let stderr = text(&o.stderr);
    assert!(o.status.success(), "{stderr}");
    assert!(stderr.contains("removed 1 temporary"), "{stderr}");
    let mut left = dir.entries();
    left.sort();
    assert_eq!(left, [foreign.as_str(), "frame.exr", "t1.exr", "t2.exr"]);
}
