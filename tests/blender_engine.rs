//! The Blender add-on (blender/strahl_engine) rendering with strahl, driven headless:
//! tools/blender/room.py builds a .blend (a Cornell-like room, a metal and a glass sphere, an
//! area light, a camera; 64 × 48 pixels, 4 samples, Depth, Normal, DiffCol and Cryptomatte
//! passes, a compositor tree) with the add-on installed in a temporary BLENDER_USER_SCRIPTS,
//! and exports its frame 1 with the add-on's exporter; `blender -b room.blend -E STRAHL -f 1`
//! then renders it through the add-on, which runs the strahl binary built with the tests.
//!
//! - The saved image's view layer channels are **bit for bit** strahl's own render of the
//!   exported glTF file with the same settings: Blender's render result and its 32-bit EXR
//!   store floats unchanged (the multilayer EXR is scene-linear, no view transform), so any
//!   difference is a pass put in the wrong place, flipped, cropped or converted.
//! - The result has exactly the passes the view layer asks for, and the compositor ran on
//!   them: Composite = DiffCol·(1 − m) + (1, 0, 1)·m, with m the Cryptomatte matte of the
//!   object "metal" computed here from strahl's own Cryptomatte pass and manifest (1e-6).
//! - A border render with crop is the border's pixels only, equal to that part of the frame.
//! - A 3-frame animation writes 3 frames, each its own (the metal sphere moves).
//! - Cancelling (SIGINT to Blender, its Ctrl-C) leaves no strahl process: the add-on prints
//!   strahl's PID, which must be gone once Blender has exited.
//! - strahl's error reaches Blender as one report line.
//! - A view layer of another name (dotted) gets the passes; a camera named like options and shell
//!   commands renders the same image and runs nothing.
//! - Film > Transparent gives alpha 0 on the background, strahl's `--transparent` render; two
//!   view layers each get their own passes; the progress bar rises to 1.0.
//! - F12 in Blender's window (Xvfb, tools/blender/f12_ui.py) saves the headless render's
//!   image bit for bit; skipped, saying so, without xvfb-run.
//! - The farm button (`bpy.ops.strahl.write_farm_job`) writes a Slurm job per frame whose
//!   merged frames, run through tests/slurm_stub.py, are the F12 renders bit for bit.
//!
//! Skips, saying so, when Blender is not installed; `STRAHL_REQUIRE_BLENDER=1` makes that a
//! failure.

mod common;

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::sync::OnceLock;
use std::time::{Duration, Instant};

use common::{TempDir, channel, read_exr, strahl};

const WIDTH: usize = 64;
const HEIGHT: usize = 48;

/// The .blend, its exported frame 1 and strahl's own render of it, made once for all tests.
struct Room {
    dir: TempDir,
    blend: PathBuf,
    reference: PathBuf,
    /// The camera's index in the exported glTF file, as the add-on passes it.
    camera: String,
}

fn repo(path: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(path)
}

fn blender_missing() -> bool {
    !common::blender_installed("the Blender add-on is not tested")
}

/// `blender -b --factory-startup`, in `dir`, with the add-on installed (a copy of blender/strahl_engine
/// in `dir`/scripts/addons) and enabled, and the tests' strahl first on PATH.
fn blender(dir: &Path, strahl_dir: Option<&Path>) -> Command {
    let scripts = dir.join("scripts");
    let addon = scripts.join("addons/strahl_engine");
    if !addon.exists() {
        std::fs::create_dir_all(&addon).unwrap();
        for entry in std::fs::read_dir(repo("blender/strahl_engine")).unwrap() {
            let path = entry.unwrap().path();
            if path.extension().is_some_and(|e| e == "py") {
                std::fs::copy(&path, addon.join(path.file_name().unwrap())).unwrap();
            }
        }
    }
    let strahl_dir = strahl_dir
        .map_or_else(|| Path::new(env!("CARGO_BIN_EXE_strahl")).parent().unwrap().to_path_buf(), Path::to_path_buf);
    let path = std::env::join_paths(
        std::iter::once(strahl_dir).chain(std::env::split_paths(&std::env::var_os("PATH").unwrap_or_default())),
    )
    .unwrap();
    let mut cmd = Command::new("blender");
    cmd.current_dir(dir).env("BLENDER_USER_SCRIPTS", &scripts).env("PATH", path).args([
        "-b",
        "--factory-startup",
        "--addons",
        "strahl_engine",
    ]);
    cmd
}

/// [`blender`] with its window, under `xvfb-run` (the interactive UI, no `-b`); `None`, saying
/// so, when xvfb-run is missing.
fn blender_ui(dir: &Path) -> Option<Command> {
    if Command::new("xvfb-run").arg("--help").output().is_err() {
        common::skip("xvfb-run is not installed (apt-get install xvfb); F12 in Blender's window is not tested");
        return None;
    }
    let background = blender(dir, None);
    let mut cmd = Command::new("xvfb-run");
    cmd.current_dir(dir).args(["-a", "-s", "-screen 0 800x600x24", "blender"]);
    cmd.args(background.get_args().filter(|a| *a != "-b"));
    for (key, value) in background.get_envs() {
        if let Some(value) = value {
            cmd.env(key, value);
        }
    }
    // Blender's quit.blend goes to TMPDIR: the test's folder.
    cmd.env("TMPDIR", dir);
    Some(cmd)
}

fn check(out: &Output, what: &str) {
    assert!(
        out.status.success(),
        "{what} failed:\n{}\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}

/// strahl's arguments for the room's settings (tools/blender/room.py), as the add-on gives them.
fn room_settings(camera: &str) -> Vec<String> {
    let args = "--camera CAMERA --width 64 --height 48 --integrator path --spp 4 --depth 6 --backend embree \
                --threads 1 --passes combined,depth,normal,albedo,crypto_object --cryptomatte-levels 2";
    args.split(' ').map(|a| if a == "CAMERA" { camera.to_string() } else { a.to_string() }).collect()
}

fn room() -> Option<&'static Room> {
    static ROOM: OnceLock<Option<Room>> = OnceLock::new();
    ROOM.get_or_init(|| {
        if blender_missing() {
            return None;
        }
        let dir = TempDir::new("blender-engine");
        let out = blender(&dir.0, None)
            .arg("--python")
            .arg(repo("tools/blender/room.py"))
            .arg("--")
            .arg(&dir.0)
            .output()
            .unwrap();
        check(&out, "tools/blender/room.py");
        let stdout = String::from_utf8_lossy(&out.stdout);
        let camera = stdout
            .lines()
            .find_map(|l| l.strip_prefix("CAMERA "))
            .expect("room.py prints the camera")
            .trim()
            .to_string();
        let gltf = dir.path("reference/scene.gltf");
        let reference = dir.path("reference.exr");
        let mut args =
            vec!["render".to_string(), gltf.display().to_string(), "-o".into(), reference.display().to_string()];
        args.extend(room_settings(&camera));
        let out = strahl(&args.iter().map(String::as_str).collect::<Vec<_>>());
        check(&out, "strahl render of the exported glTF file");
        Some(Room { blend: dir.path("room.blend"), reference, dir, camera })
    })
    .as_ref()
}

/// Renders the room through the add-on: `blender -b room.blend -E STRAHL [python] -o
/// <dir>/<name>/frame_#### ARGS`; returns the output folder.
fn render(room: &Room, name: &str, python: Option<&str>, args: &[&str]) -> PathBuf {
    let out_dir = room.dir.path(name);
    let mut cmd = blender(&room.dir.0, None);
    cmd.arg(&room.blend).args(["-E", "STRAHL"]);
    if let Some(expr) = python {
        cmd.args(["--python-expr", expr]);
    }
    cmd.arg("-o").arg(out_dir.join("frame_####")).args(args);
    let out = cmd.output().unwrap();
    check(&out, name);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(!text.contains("Error: strahl"), "{name}: the add-on reported an error:\n{text}");
    out_dir
}

/// The channels named `ViewLayer.*` (the view layer's passes), sorted by name.
fn view_layer(channels: &[(String, Vec<f32>)]) -> Vec<(String, Vec<f32>)> {
    let mut v: Vec<_> = channels.iter().filter(|(n, _)| n.starts_with("ViewLayer.")).cloned().collect();
    v.sort_by(|a, b| a.0.cmp(&b.0));
    v
}

fn bits(v: &[f32]) -> Vec<u32> {
    v.iter().map(|x| x.to_bits()).collect()
}

/// The Cryptomatte matte of object `name` at each pixel ([`common::crypto_matte`]).
fn matte(reference: &Path, channels: &[(String, Vec<f32>)], name: &str) -> Vec<f32> {
    common::crypto_matte(reference, channels, name).unwrap_or_else(|| panic!("{name} is not in the manifest"))
}

#[test]
fn f12_render_is_strahls_own_render_with_the_passes_asked_for_and_composites() {
    let Some(room) = room() else { return };
    let out = render(room, "still", None, &["-f", "1"]);
    let frame = out.join("frame_0001.exr");
    let (w, h, blender) = read_exr(&frame);
    let (rw, rh, reference) = read_exr(&room.reference);
    assert_eq!((w, h, rw, rh), (WIDTH, HEIGHT, WIDTH, HEIGHT));

    // Exactly the passes asked for, each bit for bit strahl's.
    let (got, want) = (view_layer(&blender), view_layer(&reference));
    let names: Vec<&str> = got.iter().map(|(n, _)| n.as_str()).collect();
    let expected = [
        "Combined.A",
        "Combined.B",
        "Combined.G",
        "Combined.R",
        "CryptoObject00.a",
        "CryptoObject00.b",
        "CryptoObject00.g",
        "CryptoObject00.r",
        "Depth.Z",
        "DiffCol.B",
        "DiffCol.G",
        "DiffCol.R",
        "Normal.X",
        "Normal.Y",
        "Normal.Z",
    ]
    .map(|n| format!("ViewLayer.{n}"));
    assert_eq!(names, expected.iter().map(String::as_str).collect::<Vec<_>>());
    for ((name, a), (_, b)) in got.iter().zip(&want) {
        let differing = a.iter().zip(b).filter(|(x, y)| x.to_bits() != y.to_bits()).count();
        assert_eq!(bits(a), bits(b), "{name}: {differing} of {} pixels differ from strahl's own render", a.len());
    }
    let combined = channel(&blender, "ViewLayer.Combined.R");
    assert!(combined.iter().all(|&v| v > 0.0), "every pixel sees the lit room");

    // The compositor ran on the passes: DiffCol mixed towards magenta by the metal's matte.
    let m = matte(&room.reference, &reference, "metal");
    let covered = m.iter().filter(|&&v| v > 0.99).count();
    let empty = m.iter().filter(|&&v| v == 0.0).count();
    assert!(covered > 50 && empty > 1000, "the metal sphere covers {covered} pixels, {empty} are free of it");
    for (k, s) in ["R", "G", "B"].iter().enumerate() {
        let diffcol = channel(&reference, &format!("ViewLayer.DiffCol.{s}"));
        let composite = channel(&blender, &format!("Composite.Combined.{s}"));
        let magenta = [1.0f32, 0.0, 1.0][k];
        for i in 0..w * h {
            let want = diffcol[i] * (1.0 - m[i]) + magenta * m[i];
            assert!(
                (composite[i] - want).abs() <= 1e-6,
                "Composite.{s} at pixel {i}: {} != {want} (matte {})",
                composite[i],
                m[i]
            );
        }
    }
}

#[test]
fn border_render_with_crop_is_the_border_only() {
    let Some(room) = room() else { return };
    // Blender's border: x from 25 % to 75 %, y (from the bottom) from 50 % to 100 %: strahl's
    // region x 16..48, rows 0..24 from the top.
    let expr = "import bpy; r = bpy.context.scene.render; r.use_border = True; r.use_crop_to_border = True; \
                r.border_min_x, r.border_max_x, r.border_min_y, r.border_max_y = 0.25, 0.75, 0.5, 1.0";
    let out = render(room, "border", Some(expr), &["-f", "1"]);
    let (w, h, blender) = read_exr(&out.join("frame_0001.exr"));
    assert_eq!((w, h), (32, 24));
    let (_, _, reference) = read_exr(&room.reference);
    for (name, got) in view_layer(&blender) {
        let full = channel(&reference, &name);
        let want: Vec<f32> =
            (0..24).flat_map(|y| (16..48).map(move |x| (y, x))).map(|(y, x)| full[y * WIDTH + x]).collect();
        assert_eq!(bits(&got), bits(&want), "{name}: the border differs from that part of the frame");
    }
}

/// The panel's seed reaches strahl, with the frame number added under Animated Seed (Cycles'
/// rule): frame 1 of seed 3 is strahl's own render of the export (of frame 1) with `--seed 4`,
/// which differs from the render without a seed.
#[test]
fn the_panels_animated_seed_is_the_seed_plus_the_frame() {
    let Some(room) = room() else { return };
    let expr = "import bpy; s = bpy.context.scene.strahl; s.seed = 3; s.use_animated_seed = True";
    let out = render(room, "seeded", Some(expr), &["-f", "1"]);
    let (_, _, blender) = read_exr(&out.join("frame_0001.exr"));
    let seeded = strahl_own(room, &room.dir.path("reference/scene.gltf"), "seed4.exr", None, &["--seed", "4"]);
    let (_, _, unseeded) = read_exr(&room.reference);
    let r = |c: &[(String, Vec<f32>)]| bits(channel(c, "ViewLayer.Combined.R"));
    assert_eq!(r(&blender), r(&seeded), "frame 1 of seed 3 is strahl's render with --seed 4");
    assert_ne!(r(&seeded), r(&unseeded), "the seed changed no pixel: the test proves nothing");
}

/// The panel's adaptive sampling reaches strahl: the frame is strahl's own render of the export
/// with `--adaptive-threshold`, which differs from the uniform render at the same maximum.
#[test]
fn adaptive_sampling_from_the_panel_is_strahls() {
    let Some(room) = room() else { return };
    let expr = "import bpy; s = bpy.context.scene.strahl; s.samples = 64; s.use_adaptive_sampling = True; \
                s.adaptive_threshold = 0.1";
    let out = render(room, "adaptive", Some(expr), &["-f", "1"]);
    let (_, _, blender) = read_exr(&out.join("frame_0001.exr"));
    let strahl_render = |name: &str, extra: &[&str]| {
        let exr = room.dir.path(name);
        let gltf = room.dir.path("reference/scene.gltf");
        let camera = room.camera.clone();
        let mut args = vec!["render".to_string(), gltf.display().to_string(), "-o".into(), exr.display().to_string()];
        args.extend(room_settings(&camera).into_iter().map(|a| if a == "4" { "64".into() } else { a }));
        args.extend(extra.iter().map(|s| s.to_string()));
        check(&strahl(&args.iter().map(String::as_str).collect::<Vec<_>>()), name);
        read_exr(&exr).2
    };
    let adaptive = strahl_render("adaptive.exr", &["--adaptive-threshold", "0.1"]);
    let uniform = strahl_render("uniform.exr", &[]);
    let r = |c: &[(String, Vec<f32>)]| bits(channel(c, "ViewLayer.Combined.R"));
    assert_eq!(r(&blender), r(&adaptive), "the frame is strahl's adaptive render");
    assert_ne!(r(&adaptive), r(&uniform), "adaptive sampling stopped no pixel: the test proves nothing");
}

#[test]
fn animation_renders_each_frame() {
    let Some(room) = room() else { return };
    let out = render(room, "animation", None, &["-s", "1", "-e", "3", "-a"]);
    let mut files: Vec<String> =
        std::fs::read_dir(&out).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
    files.sort();
    assert_eq!(files, ["frame_0001.exr", "frame_0002.exr", "frame_0003.exr"]);
    let frames: Vec<Vec<f32>> = files
        .iter()
        .map(|f| {
            let (w, h, c) = read_exr(&out.join(f));
            assert_eq!((w, h), (WIDTH, HEIGHT));
            channel(&c, "ViewLayer.Combined.R").to_vec()
        })
        .collect();
    let (_, _, reference) = read_exr(&room.reference);
    assert_eq!(bits(&frames[0]), bits(channel(&reference, "ViewLayer.Combined.R")), "frame 1 is the still frame");
    // The metal sphere moves from x = 0.5 to 0.1: each frame is its own.
    assert_ne!(bits(&frames[0]), bits(&frames[1]), "frame 2 shows frame 1's scene");
    assert_ne!(bits(&frames[1]), bits(&frames[2]), "frame 3 shows frame 2's scene");
}

#[test]
fn cancelling_leaves_no_strahl_process() {
    let Some(room) = room() else { return };
    let expr = "import bpy; bpy.context.scene.strahl.samples = 65536";
    let mut child = blender(&room.dir.0, None)
        .arg(&room.blend)
        .args(["-E", "STRAHL", "--python-expr", expr, "-o"])
        .arg(room.dir.path("cancelled/frame_####"))
        .args(["-f", "1"])
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let mut lines = BufReader::new(child.stdout.take().unwrap()).lines();
    let pid: u32 = lines
        .by_ref()
        .map_while(Result::ok)
        .find_map(|l| l.strip_prefix("strahl: pid ").map(|p| p.trim().parse().unwrap()))
        .expect("the add-on prints strahl's PID");
    let proc = PathBuf::from(format!("/proc/{pid}"));
    assert!(proc.exists(), "strahl {pid} is running");
    std::thread::sleep(Duration::from_millis(500));
    // Blender in the background takes SIGINT (Ctrl-C) as the user's break: test_break().
    common::send_signal(&child, "-INT");
    let rest: Vec<String> = lines.map_while(Result::ok).collect();
    let start = Instant::now();
    let status = loop {
        if let Some(status) = child.try_wait().unwrap() {
            break status;
        }
        assert!(start.elapsed() < Duration::from_secs(120), "Blender did not stop after SIGINT");
        std::thread::sleep(Duration::from_millis(100));
    };
    assert!(
        rest.iter().any(|l| l.starts_with(&format!("strahl: pid {pid} stopped"))),
        "the add-on stopped strahl (status {status}):\n{}",
        rest.join("\n")
    );
    // Gone, not even a zombie: the add-on waited for it, and Blender has exited.
    let alive = std::fs::read_to_string(proc.join("cmdline")).is_ok_and(|c| c.contains("strahl"));
    assert!(!alive, "strahl {pid} outlived the cancelled render");
}

#[test]
fn strahls_error_is_one_report_line() {
    let Some(room) = room() else { return };
    // A strahl that says it is strahl and then fails as strahl does: one `error:` line.
    let fake = room.dir.path("fake-strahl");
    std::fs::create_dir_all(&fake).unwrap();
    let script = fake.join("strahl");
    std::fs::write(
        &script,
        "#!/bin/sh\nif [ \"$1\" = --version ]; then echo 'strahl 0.1.0'; exit 0; fi\n\
         echo 'warning: something to ignore' >&2\necho 'error: scene.gltf: node 3: broken' >&2\nexit 1\n",
    )
    .unwrap();
    std::fs::set_permissions(&script, std::os::unix::fs::PermissionsExt::from_mode(0o755)).unwrap();
    let out = blender(&room.dir.0, Some(&fake))
        .arg(&room.blend)
        .args(["-E", "STRAHL", "-o"])
        .arg(room.dir.path("failed/frame_####"))
        .args(["-f", "1"])
        .output()
        .unwrap();
    let all = format!("{}{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    let reports: Vec<&str> = all.lines().filter(|l| l.starts_with("Error: strahl")).collect();
    assert_eq!(reports, ["Error: strahl: scene.gltf: node 3: broken"], "{all}");
    assert!(!room.dir.path("failed/frame_0001.exr").exists() || out.status.success());
}

/// A view layer named with a dot, a space and a leading '-': strahl names the channels after it
/// (`--layer-name`), and Blender's reader, which splits a channel name at its last two dots,
/// loads every pass.
#[test]
fn a_view_layer_of_another_name_gets_the_passes() {
    let Some(room) = room() else { return };
    let expr = "import bpy; bpy.context.scene.view_layers[0].name = '-Beauty pass.v2'";
    let out = render(room, "renamed", Some(expr), &["-f", "1"]);
    let (_, _, blender) = read_exr(&out.join("frame_0001.exr"));
    let (_, _, reference) = read_exr(&room.reference);
    let got: Vec<_> = blender.iter().filter(|(n, _)| n.starts_with("-Beauty pass.v2.")).collect();
    assert_eq!(got.len(), view_layer(&reference).len(), "every pass, under the layer's name");
    for (name, values) in got {
        let want = channel(&reference, &name.replacen("-Beauty pass.v2.", "ViewLayer.", 1));
        assert_eq!(bits(values), bits(want), "{name}");
    }
}

#[test]
fn hostile_names_reach_strahl_as_data() {
    let Some(room) = room() else { return };
    // A camera whose name reads as options and shell: the add-on passes the camera by index,
    // and every value as an argument of its own, never through a shell.
    let expr = r#"import bpy; bpy.context.scene.camera.name = "--spp=1 $(touch pwned) `touch pwned2`; '\" -o /tmp/x" + chr(10)"#;
    let out = render(room, "hostile", Some(expr), &["-f", "1"]);
    let (_, _, blender) = read_exr(&out.join("frame_0001.exr"));
    let (_, _, reference) = read_exr(&room.reference);
    for (name, values) in view_layer(&blender) {
        assert_eq!(bits(&values), bits(channel(&reference, &name)), "{name}");
    }
    for file in ["pwned", "pwned2"] {
        assert!(!room.dir.path(file).exists(), "a shell ran the camera's name");
    }
}

/// Every file named PWNED under `dir` (what a payload that ran would leave).
fn pwned(dir: &Path) -> Vec<PathBuf> {
    let mut found = Vec::new();
    for entry in std::fs::read_dir(dir).into_iter().flatten().flatten() {
        let path = entry.path();
        if entry.file_name() == "PWNED" {
            found.push(path.clone());
        }
        if entry.file_type().is_ok_and(|t| t.is_dir()) {
            found.extend(pwned(&path));
        }
    }
    found
}

/// The farm button, headless: `bpy.ops.strahl.write_farm_job` on frames 1-2 writes one
/// `strahl farm slurm` job per frame into a folder named like options and shell commands (the
/// scene too), submitted to tests/slurm_stub.py (a model of sbatch that runs the tasks and the
/// merge at once); each merged frame's passes equal the add-on's F12 render of that frame bit
/// for bit, and nothing the names hold ran.
#[test]
fn the_farm_button_writes_jobs_whose_frames_are_the_f12_renders() {
    let Some(room) = room() else { return };
    let Some(python) = ["/usr/bin/python3", "python3"].into_iter().find(|p| Command::new(p).arg("-V").output().is_ok())
    else {
        common::skip("python3 (for tests/slurm_stub.py) is not installed; the farm button is not tested");
        return;
    };
    let f12 = render(room, "farm-f12", None, &["-s", "1", "-e", "2", "-a"]);

    let base = room.dir.path("farm");
    let bin = base.join("bin");
    let state = base.join("state");
    std::fs::create_dir_all(&bin).unwrap();
    std::fs::create_dir_all(&state).unwrap();
    let stub = repo("tests/slurm_stub.py");
    let sbatch = bin.join("sbatch");
    std::fs::write(&sbatch, format!("#!/bin/sh\nexec {python} -S '{}' \"$@\"\n", stub.display())).unwrap();
    std::fs::set_permissions(&sbatch, std::os::unix::fs::PermissionsExt::from_mode(0o755)).unwrap();
    let hostile = "-farm $(touch PWNED) `touch PWNED`; touch PWNED; 'q' \"d\" --spp=1";
    let folder = base.join(hostile);
    let strahl_dir = Path::new(env!("CARGO_BIN_EXE_strahl")).parent().unwrap().to_path_buf();
    let path = std::env::join_paths(
        [bin, strahl_dir].into_iter().chain(std::env::split_paths(&std::env::var_os("PATH").unwrap_or_default())),
    )
    .unwrap();
    let expr = "import bpy, os; s = bpy.context.scene; s.name = os.environ['FARM_NAME']; \
                s.frame_start, s.frame_end = 1, 2; s.strahl.farm_tiles = 3; s.strahl.farm_submit = True; \
                print('FARM', bpy.ops.strahl.write_farm_job(directory=os.environ['FARM_DIR']))";
    let out = blender(&room.dir.0, None)
        .arg(&room.blend)
        .args(["--python-expr", expr])
        .env("PATH", path)
        .env("FARM_DIR", &folder)
        .env("FARM_NAME", hostile)
        .env("SBATCH_STUB_DIR", &state)
        .env("SBATCH_STUB_RUN", "1")
        .output()
        .unwrap();
    check(&out, "write_farm_job");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains("FARM {'FINISHED'}"), "{stdout}\n{}", String::from_utf8_lossy(&out.stderr));

    let submissions = std::fs::read_to_string(state.join("submissions.jsonl")).unwrap();
    let runs: Vec<serde_json::Value> = submissions
        .lines()
        .map(|l| serde_json::from_str::<serde_json::Value>(l).unwrap())
        .filter(|s| s.get("ran").is_some())
        .collect();
    // Per frame 3 tiles and a merge.
    assert_eq!(runs.len(), 8, "{runs:?}");
    assert!(runs.iter().all(|r| r["status"] == 0), "{runs:?}");
    for frame in [1, 2] {
        let farm = folder.join(format!("frame_{frame:04}.exr"));
        let (w, h, farm_channels) = read_exr(&farm);
        assert_eq!((w, h), (WIDTH, HEIGHT));
        let (_, _, f12_channels) = read_exr(&f12.join(format!("frame_{frame:04}.exr")));
        let (got, want) = (view_layer(&farm_channels), view_layer(&f12_channels));
        assert_eq!(got.len(), want.len(), "frame {frame}: the passes differ");
        for ((name, a), (name_f12, b)) in got.iter().zip(&want) {
            assert_eq!(name, name_f12);
            assert_eq!(bits(a), bits(b), "frame {frame}, {name}: the farm's frame differs from F12's");
        }
    }
    assert!(pwned(&room.dir.0).is_empty(), "a name ran as a command: {:?}", pwned(&room.dir.0));
}

/// Blender's progress bar follows strahl's progress lines, which the add-on asks for every
/// `PROGRESS_INTERVAL` seconds (`--progress-interval`, 0.5 s; 0.1 s here, so that the count of
/// lines does not hang on how fast the render is): the values the add-on gives
/// `update_progress` (through its `set_progress`, which the test's script wraps to record them)
/// rise from below 1 to 1.0 and never fall.
#[test]
fn the_progress_bar_moves_and_ends_at_one() {
    let Some(room) = room() else { return };
    // 128 samples on one thread: one to a few seconds, about ten progress lines or more.
    let expr = "import bpy, strahl_engine.engine as e; bpy.context.scene.strahl.samples = 128\n\
                e.PROGRESS_INTERVAL = 0.1\n\
                def record(self, value, set_progress=e.StrahlRenderEngine.set_progress):\n    \
                    print('PROGRESS %r' % value, flush=True)\n    set_progress(self, value)\n\
                e.StrahlRenderEngine.set_progress = record";
    let out_dir = room.dir.path("progress");
    let out = blender(&room.dir.0, None)
        .arg(&room.blend)
        .args(["-E", "STRAHL", "--python-expr", expr, "-o"])
        .arg(out_dir.join("frame_####"))
        .args(["-f", "1"])
        .output()
        .unwrap();
    check(&out, "progress");
    let values: Vec<f64> = String::from_utf8_lossy(&out.stdout)
        .lines()
        .filter_map(|l| l.strip_prefix("PROGRESS "))
        .map(|v| v.trim().parse().unwrap())
        .collect();
    assert!(values.windows(2).all(|w| w[0] <= w[1]), "the bar went back: {values:?}");
    assert_eq!(values.last(), Some(&1.0), "{values:?}");
    let between = values.iter().filter(|&&v| v > 0.0 && v < 1.0).count();
    assert!(between >= 2, "only {between} progress values before the end: {values:?}");
    println!("update_progress values: {values:?}");
}

/// strahl's own render of `gltf` with the room's settings, `passes` in place of the room's and
/// `extra` options; its channels.
fn strahl_own(room: &Room, gltf: &Path, name: &str, passes: Option<&str>, extra: &[&str]) -> Vec<(String, Vec<f32>)> {
    let exr = room.dir.path(name);
    let mut args = vec!["render".to_string(), gltf.display().to_string(), "-o".into(), exr.display().to_string()];
    let mut settings = room_settings(&room.camera);
    if let Some(p) = passes {
        let at = settings.iter().position(|a| a == "--passes").unwrap();
        settings.truncate(at);
        settings.extend(["--passes".to_string(), p.to_string()]);
    }
    args.extend(settings);
    args.extend(extra.iter().map(|s| s.to_string()));
    check(&strahl(&args.iter().map(String::as_str).collect::<Vec<_>>()), name);
    read_exr(&exr).2
}

/// Film > Transparent: with the back wall and the ceiling hidden, the rays that leave the room
/// give alpha 0 in the render result, and every pass is strahl's own `--transparent` render of
/// the same export (made by the test's script) bit for bit.
#[test]
fn film_transparency_gives_alpha_zero_on_the_background() {
    let Some(room) = room() else { return };
    let export = room.dir.path("transparent-export");
    let expr = format!(
        "import bpy, os, strahl_engine.export as x; s = bpy.context.scene; s.render.film_transparent = True; \
         [setattr(bpy.data.objects[n], 'hide_render', True) for n in ('back', 'ceiling')]; os.makedirs({dir:?}); \
         x.export_frame(s, bpy.context.view_layer, bpy.context.evaluated_depsgraph_get(), {dir:?})",
        dir = export.display().to_string()
    );
    let out = render(room, "transparent", Some(&expr), &["-f", "1"]);
    let (_, _, blender) = read_exr(&out.join("frame_0001.exr"));
    let own = strahl_own(room, &export.join("scene.gltf"), "transparent.exr", None, &["--transparent"]);
    let (got, want) = (view_layer(&blender), view_layer(&own));
    assert_eq!(got.len(), want.len());
    for ((name, a), (_, b)) in got.iter().zip(&want) {
        assert_eq!(bits(a), bits(b), "{name}: differs from strahl's --transparent render");
    }
    let alpha = channel(&blender, "ViewLayer.Combined.A");
    let (clear, opaque) = (alpha.iter().filter(|&&a| a == 0.0).count(), alpha.iter().filter(|&&a| a == 1.0).count());
    println!("alpha 0 on {clear} pixels, 1 on {opaque} of {}", alpha.len());
    assert!(clear > 200 && opaque > 200, "alpha 0 on {clear} pixels, 1 on {opaque}");
    let red = channel(&blender, "ViewLayer.Combined.R");
    assert!(alpha.iter().zip(red).all(|(&a, &r)| a > 0.0 || r == 0.0), "a background pixel has colour");
}

/// Two view layers: Blender renders each through the add-on, each with its own passes (the
/// second: Combined and Normal only) under its own name, each strahl's own render bit for bit.
#[test]
fn two_view_layers_each_get_their_passes() {
    let Some(room) = room() else { return };
    let expr = "import bpy; v = bpy.context.scene.view_layers.new('Second'); v.use_pass_z = False; \
                v.use_pass_normal = True; v.use_pass_diffuse_color = False; v.use_pass_cryptomatte_object = False";
    let out = render(room, "two-layers", Some(expr), &["-f", "1"]);
    let (_, _, blender) = read_exr(&out.join("frame_0001.exr"));
    let (_, _, reference) = read_exr(&room.reference);
    let first = view_layer(&blender);
    let want = view_layer(&reference);
    assert_eq!(first.len(), want.len(), "the first layer's passes");
    for ((name, a), (wname, b)) in first.iter().zip(&want) {
        assert_eq!(name, wname);
        assert_eq!(bits(a), bits(b), "{name}");
    }
    let mut second: Vec<_> = blender.iter().filter(|(n, _)| n.starts_with("Second.")).cloned().collect();
    second.sort_by(|a, b| a.0.cmp(&b.0));
    let names: Vec<&str> = second.iter().map(|(n, _)| n.as_str()).collect();
    assert_eq!(
        names,
        [
            "Second.Combined.A",
            "Second.Combined.B",
            "Second.Combined.G",
            "Second.Combined.R",
            "Second.Normal.X",
            "Second.Normal.Y",
            "Second.Normal.Z"
        ]
    );
    let own = strahl_own(room, &room.dir.path("reference/scene.gltf"), "second.exr", Some("combined,normal"), &[]);
    for (name, values) in &second {
        let want = channel(&own, &name.replacen("Second.", "ViewLayer.", 1));
        assert_eq!(bits(values), bits(want), "{name}");
    }
}

/// F12 in Blender's interactive UI (a window on Xvfb, not `-b`): tools/blender/f12_ui.py
/// renders the room from a timer with `bpy.ops.render.render(write_still=True)` and quits; the
/// saved image is the headless render's, every channel bit for bit (the passes and the
/// compositor's output).
#[test]
fn f12_in_the_interactive_ui_equals_the_headless_render() {
    let Some(room) = room() else { return };
    let Some(mut ui) = blender_ui(&room.dir.0) else { return };
    let saved = room.dir.path("ui/frame.exr");
    let out = ui
        .arg(&room.blend)
        .arg("--python")
        .arg(repo("tools/blender/f12_ui.py"))
        .arg("--")
        .arg(&saved)
        .output()
        .unwrap();
    check(&out, "F12 in Blender's window");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains("F12 False ['FINISHED']"), "not an interactive render:\n{stdout}");
    assert!(!stdout.contains("Error: strahl"), "{stdout}");
    let headless = render(room, "ui-headless", None, &["-f", "1"]);
    let (w, h, got) = read_exr(&saved);
    let (_, _, want) = read_exr(&headless.join("frame_0001.exr"));
    assert_eq!((w, h), (WIDTH, HEIGHT));
    let names = |c: &[(String, Vec<f32>)]| c.iter().map(|(n, _)| n.clone()).collect::<Vec<_>>();
    assert_eq!(names(&got), names(&want));
    assert!(got.iter().any(|(n, _)| n.starts_with("Composite.")) && got.len() > 15, "{:?}", names(&got));
    for ((name, a), (_, b)) in got.iter().zip(&want) {
        assert_eq!(bits(a), bits(b), "{name}: the window's F12 differs from the headless render");
    }
}
