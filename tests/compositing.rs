//! The compositing EXR read back by readers strahl did not write: Blender's recipe rebuilds
//! the beauty from the light-path passes on every shipped scene, with either integrator; alpha composites with `over` (oiiotool); the camera
//! matrices map the position pass back onto the depth pass; Cryptomatte decodes with Python's
//! `mmh3` to the object-index coverage; `exrheader` and `oiiotool --stats` read every layout
//! and option; `--half` files are smaller. Tests that need a tool skip with a message when it
//! is missing.

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

use common::{TempDir, channel, float_channels, read_exr, read_exr_image, strahl, text};
use glam::DVec3;

fn scene_path(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes").join(name)
}

/// Renders `scene` at `w × h` into `out` with extra arguments; panics with stderr on failure.
fn render(scene: &Path, out: &Path, w: u32, h: u32, extra: &[&str]) {
    let (w, h) = (w.to_string(), h.to_string());
    let mut args = vec!["render", scene.to_str().unwrap(), "-o", out.to_str().unwrap(), "--width", &w, "--height", &h];
    args.extend_from_slice(extra);
    let output = strahl(&args);
    assert!(output.status.success(), "strahl {args:?}: {}", text(&output.stderr));
}

/// Whether `tool --help`-style probing finds `tool` on the PATH; prints a skip line if not.
fn have(tool: &str, probe: &[&str]) -> bool {
    let ok = Command::new(tool).args(probe).output().is_ok_and(|o| o.status.success());
    if !ok {
        common::skip(&format!("`{tool}` is not installed"));
    }
    ok
}

/// Blender's families of light passes: (direct, indirect, colour).
const FAMILIES: [[&str; 3]; 3] =
    [["DiffDir", "DiffInd", "DiffCol"], ["GlossDir", "GlossInd", "GlossCol"], ["TransDir", "TransInd", "TransCol"]];

/// Checks Blender's recipe on the file `out` (w × h): for every pixel and channel,
/// Combined = Σ_families (Dir + Ind)·Col + Emit + Env, within `tol` relative; returns how many
/// pixel channels held light and how many had light in each family.
fn check_recipe(out: &Path, what: &str, tol: f64) -> (usize, [usize; 3]) {
    let (w, h, ch) = read_exr(out);
    let mut lit = 0;
    let mut families = [0; 3];
    for comp in ["R", "G", "B"] {
        let get = |p: &str| channel(&ch, &format!("ViewLayer.{p}.{comp}"));
        let beauty = get("Combined");
        let (emit, env) = (get("Emit"), get("Env"));
        for i in 0..w * h {
            let mut sum = emit[i] as f64 + env[i] as f64;
            for (k, [d, ind, c]) in FAMILIES.iter().enumerate() {
                let term = (get(d)[i] as f64 + get(ind)[i] as f64) * get(c)[i] as f64;
                families[k] += (term > 0.0) as usize;
                sum += term;
            }
            let want = beauty[i] as f64;
            assert!(
                (sum - want).abs() <= tol * want.abs() + 1e-12,
                "{what}: pixel {i} channel {comp}: Blender's recipe gives {sum}, Combined {want}"
            );
            lit += (want > 0.0) as usize;
        }
    }
    (lit, families)
}

#[test]
fn blenders_recipe_rebuilds_the_beauty_on_every_shipped_scene() {
    let dir = TempDir::new("sum");
    let mut scenes: Vec<PathBuf> = std::fs::read_dir(scene_path(""))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    scenes.sort();
    assert!(scenes.len() >= 5, "{scenes:?}");
    let mut families = [0; 3];
    for scene in &scenes {
        for integrator in ["whitted", "path"] {
            for transparent in [false, true] {
                let out = dir.path("sum.exr");
                let mut extra = vec!["--passes", "all", "--threads", "2", "--integrator", integrator, "--spp", "4"];
                if transparent {
                    extra.push("--transparent");
                }
                render(scene, &out, 48, 36, &extra);
                let what =
                    format!("{} ({integrator}{})", scene.display(), if transparent { ", transparent" } else { "" });
                let (lit, f) = check_recipe(&out, &what, 1e-5);
                assert!(lit > 0, "{what}: a black image proves nothing");
                for k in 0..3 {
                    families[k] += f[k];
                }
                let (_, _, ch) = read_exr(&out);
                let a = channel(&ch, "ViewLayer.Combined.A");
                if transparent {
                    let env = channel(&ch, "ViewLayer.Env.R");
                    assert!(env.iter().all(|&e| e == 0.0), "{what}: transparent, no background");
                } else {
                    assert!(a.iter().all(|&a| a == 1.0), "{what}: an opaque frame has A = 1");
                }
            }
        }
    }
    // The shipped scenes hold diffuse, glossy (mirrors, highlights) and glass surfaces.
    assert!(families.iter().all(|&n| n > 100), "pixel channels lit per family: {families:?}");
}

/// The path tracer's split on its Cornell box: every family holds light (walls, the mirror
/// sphere, the glass sphere), the closed box shows no environment, and on the white walls
/// both the direct light and the interreflections are there, the second a part of the first.
#[test]
fn the_path_tracers_passes_split_the_cornell_box_as_blender_does() {
    let dir = TempDir::new("cornell-split");
    let out = dir.path("c.exr");
    render(
        &scene_path("cornell-path.toml"),
        &out,
        32,
        32,
        &["--passes", "light", "--spp", "64", "--integrator", "path"],
    );
    let (lit, families) = check_recipe(&out, "cornell-path", 1e-5);
    assert!(lit > 2500 && families.iter().all(|&n| n > 20), "lit {lit}, per family {families:?}");
    let (w, h, ch) = read_exr(&out);
    let get = |p: &str| channel(&ch, &format!("ViewLayer.{p}.G"));
    assert!(get("Env").iter().all(|&v| v == 0.0), "the box is closed and its background 0");
    let white = |i: usize| (get("DiffCol")[i] - 0.71).abs() < 1e-6;
    let direct: f64 = (0..w * h).filter(|&i| white(i)).map(|i| get("DiffDir")[i] as f64).sum();
    let indirect: f64 = (0..w * h).filter(|&i| white(i)).map(|i| get("DiffInd")[i] as f64).sum();
    println!("white walls: DiffDir sum {direct}, DiffInd sum {indirect}");
    assert!(direct > 0.0 && indirect > 0.1 * direct && indirect < direct, "direct {direct}, indirect {indirect}");
}

/// `pxr24` rounds float32 to 24 bits: a file with Cryptomatte is written with ZIP instead, with
/// a warning, so its ids are the bits a ZIP render stores; `b44` says that it leaves float32
/// channels uncompressed.
#[test]
fn lossy_compression_never_touches_cryptomatte_ids() {
    let dir = TempDir::new("lossy");
    let scene = scene_path("whitted.toml");
    let run = |name: &str, extra: &[&str]| {
        let out = dir.path(name);
        let mut args = vec!["render", scene.to_str().unwrap(), "-o", out.to_str().unwrap()];
        args.extend(["--width", "48", "--height", "36", "--spp", "2", "--integrator", "whitted"]);
        args.extend_from_slice(extra);
        let o = strahl(&args);
        assert!(o.status.success(), "{}", text(&o.stderr));
        (out, text(&o.stderr))
    };
    let crypto = ["--passes", "default,crypto_object,object_index"];
    let (zip, _) = run("zip.exr", &crypto);
    let (pxr, stderr) = run("pxr24.exr", &[&crypto[..], &["--compression", "pxr24"]].concat());
    assert!(stderr.contains("pxr24 rounds float32 channels to 24 bits") && stderr.contains("writing ZIP"), "{stderr}");
    let (_, _, a) = read_exr(&zip);
    let (_, _, b) = read_exr(&pxr);
    let mut compared = 0;
    for (name, values) in &a {
        if name.contains("Crypto") || name.contains("IndexOB") {
            let other = channel(&b, name);
            assert!(values.iter().zip(other).all(|(x, y)| x.to_bits() == y.to_bits()), "{name} changed");
            compared += 1;
        }
    }
    assert!(compared >= 7, "{compared} channels compared");
    // Without ids, pxr24 is written as asked (and rounds the beauty).
    let (plain, stderr) = run("plain.exr", &["--compression", "pxr24"]);
    assert!(!stderr.contains("warning"), "{stderr}");
    let (_, _, p) = read_exr(&plain);
    let (beauty, rounded) = (channel(&a, "ViewLayer.Combined.R"), channel(&p, "ViewLayer.Combined.R"));
    assert!(beauty.iter().zip(rounded).any(|(x, y)| x != y), "pxr24 kept every bit: the test proves nothing");
    let (_, stderr) = run("b44.exr", &["--compression", "b44"]);
    assert!(stderr.contains("b44 compresses half channels only") && stderr.contains("depth"), "{stderr}");
}

#[test]
fn transparent_over_a_plate_gives_the_plate_where_nothing_was_hit() {
    if !have("oiiotool", &["--version"]) {
        return;
    }
    let dir = TempDir::new("over");
    let (fg, plate, comp) = (dir.path("fg.exr"), dir.path("plate.exr"), dir.path("comp.exr"));
    // The Nuke layout: bare R G B A, which oiiotool composites.
    render(&scene_path("whitted.toml"), &fg, 64, 48, &["--transparent", "--exr-layout", "nuke", "--spp", "4"]);
    let run = |args: &[&str]| {
        let o = Command::new("oiiotool").args(args).output().unwrap();
        assert!(o.status.success(), "oiiotool {args:?}: {}", text(&o.stderr));
    };
    run(&["--pattern", "constant:color=1,0,0,1", "64x48", "4", "-d", "float", "-o", plate.to_str().unwrap()]);
    run(&[fg.to_str().unwrap(), "--ch", "R,G,B,A", plate.to_str().unwrap(), "--over", "-o", comp.to_str().unwrap()]);
    let (_, _, ours) = read_exr(&fg);
    let (_, _, theirs) = read_exr(&comp);
    let (z, a) = (channel(&ours, "Z"), channel(&ours, "A"));
    let out: Vec<&[f32]> = ["R", "G", "B", "A"].iter().map(|c| channel(&theirs, c)).collect();
    let (mut empty, mut partial) = (0, 0);
    for i in 0..64 * 48 {
        if z[i] == f32::INFINITY {
            empty += 1;
            assert_eq!([out[0][i], out[1][i], out[2][i], out[3][i]], [1.0, 0.0, 0.0, 1.0], "pixel {i}");
        } else {
            partial += (a[i] < 1.0) as usize;
            let rgb: Vec<f32> = ["R", "G", "B"].iter().map(|c| channel(&ours, c)[i]).collect();
            let want = [rgb[0] + (1.0 - a[i]), rgb[1], rgb[2]];
            for c in 0..3 {
                assert!((out[c][i] - want[c]).abs() <= 1e-6 * want[c].abs().max(1.0), "pixel {i}");
            }
        }
    }
    assert!(empty > 100 && partial > 0, "empty {empty}, partly covered {partial}");
}

/// A row-major row-vector matrix applied to a point: `[p 1] · m`.
fn apply(m: &[f32; 16], p: DVec3) -> [f64; 4] {
    let row = [p.x, p.y, p.z, 1.0];
    std::array::from_fn(|j| (0..4).map(|i| row[i] * m[4 * i + j] as f64).sum())
}

#[test]
fn world_to_camera_maps_the_position_pass_onto_the_depth_pass() {
    let dir = TempDir::new("camera");
    let out = dir.path("cam.exr");
    let (w, h) = (40usize, 30usize);
    // One sample: the position is then that of the pixel-centre ray (NDC checked below).
    render(
        &scene_path("whitted.toml"),
        &out,
        w as u32,
        h as u32,
        &["--passes", "default,position,distance", "--spp", "1"],
    );
    // One read for the header's matrices and the channels.
    let image = read_exr_image(&out);
    let attrs = &image.layer_data[0].attributes;
    let to_camera = attrs.world_to_camera.expect("worldToCamera");
    let to_ndc = attrs.world_to_normalized_device.expect("worldToNDC");
    let ch = float_channels(&image.layer_data[0]);
    let (z, d) = (channel(&ch, "ViewLayer.Depth.Z"), channel(&ch, "ViewLayer.Distance.Z"));
    let p: Vec<&[f32]> = ["X", "Y", "Z"].iter().map(|c| channel(&ch, &format!("ViewLayer.Position.{c}"))).collect();
    let mut hits = 0;
    for y in 0..h {
        for x in 0..w {
            let i = y * w + x;
            if z[i] == f32::INFINITY {
                continue;
            }
            hits += 1;
            let world = DVec3::new(p[0][i] as f64, p[1][i] as f64, p[2][i] as f64);
            let c = apply(&to_camera, world);
            // Depth is camera-space z (Blender's), the distance pass the ray's length.
            assert!((c[2] - z[i] as f64).abs() <= 1e-5 * z[i] as f64, "pixel ({x}, {y}): z {} vs {}", c[2], z[i]);
            let length = DVec3::new(c[0], c[1], c[2]).length();
            assert!((length - d[i] as f64).abs() <= 1e-5 * d[i] as f64, "pixel ({x}, {y}): {length} vs {}", d[i]);
            assert!(c[2] > 0.0 && d[i] >= z[i], "pixel ({x}, {y}): in front of the camera");
            let n = apply(&to_ndc, world);
            let (nx, ny) = (n[0] / n[3], n[1] / n[3]);
            assert!((nx - (x as f64 + 0.5) / w as f64).abs() < 1e-4, "pixel ({x}, {y}): NDC x {nx}");
            assert!((ny - (y as f64 + 0.5) / h as f64).abs() < 1e-4, "pixel ({x}, {y}): NDC y {ny}");
        }
    }
    assert!(hits > w * h / 3);
    // The rest of the metadata.
    let other = &attrs.other;
    let get = |k: &str| other.get(&exr::prelude::Text::from(k)).map(|v| format!("{v:?}"));
    assert!(get("strahl/sceneHash").is_some_and(|v| v.len() > 16), "{other:?}");
    assert!(get("samplesPerPixel").is_some() && get("strahl/maxDepth").is_some() && get("strahl/backend").is_some());
    assert!(attrs.software_name.as_ref().is_some_and(|s| s.to_string().starts_with("strahl ")));
}

#[test]
fn cryptomatte_decodes_with_python_mmh3_to_the_object_index_coverage() {
    let probe = ["-c", "import OpenEXR, mmh3, numpy"];
    if !have("python3", &probe) {
        return;
    }
    let dir = TempDir::new("crypto");
    // Every compression strahl writes keeps the ids decodable, half floats or not.
    for (k, (_, compression)) in strahl::output::exr::Compression::ALL.iter().enumerate() {
        let out = dir.path(&format!("crypto-{compression}.exr"));
        let passes = "default,object_index,material_index,crypto_object,crypto_material";
        let mut extra = vec!["--spp", "1", "--passes", passes, "--compression", compression];
        if k % 2 == 1 {
            extra.push("--half");
        }
        render(&scene_path("whitted.toml"), &out, 96, 72, &extra);
        let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/cryptomatte_check.py");
        let o = Command::new("python3").arg(&script).arg(&out).output().unwrap();
        let stdout = text(&o.stdout);
        assert!(o.status.success(), "{compression}: {stdout}\n{}", text(&o.stderr));
        // Every object of the scene is in the manifest and was checked.
        for name in ["floor", "mirror ball", "glass ball"] {
            assert!(stdout.contains(&format!("object '{name}': ")), "{compression}: {stdout}");
        }
        assert!(stdout.contains("unknown ids: 0"), "{compression}: {stdout}");
        println!("{compression}:\n{stdout}");
    }
}

#[test]
fn blender_lists_the_passes_by_name() {
    if !have("blender", &["-b", "--factory-startup", "--version"]) {
        return;
    }
    let dir = TempDir::new("blender");
    let out = dir.path("blender.exr");
    render(&scene_path("whitted.toml"), &out, 64, 48, &["--passes", "all", "--spp", "1"]);
    // The object index of the floor: 1 + its place among the scene's objects.
    let scene = strahl::scene::load(scene_path("whitted.toml")).unwrap().scene;
    let ids = strahl::output::ids::ObjectIds::new(&scene);
    let floor = 1 + ids.object_names.iter().position(|n| n == "floor").unwrap();
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/blender_check.py");
    let o = Command::new("blender")
        .args(["-b", "--factory-startup", "--python-exit-code", "1", "--python"])
        .arg(&script)
        .arg("--")
        .arg(&out)
        .args(["floor", &floor.to_string(), "64", "48"])
        .output()
        .unwrap();
    let stdout = text(&o.stdout);
    assert!(o.status.success(), "{stdout}\n{}", text(&o.stderr));
    let line = stdout.lines().find(|l| l.starts_with("PASSES ")).unwrap_or_else(|| panic!("{stdout}"));
    for pass in [
        "Combined",
        "Depth",
        "Normal",
        "DiffCol",
        "Emit",
        "DiffDir",
        "DiffInd",
        "GlossDir",
        "GlossInd",
        "GlossCol",
        "TransDir",
        "TransInd",
        "TransCol",
        "Env",
        "Position",
        "IndexOB",
        "CryptoObject00",
    ] {
        assert!(line.split(' ').any(|p| p == pass), "{pass} missing from {line}");
    }
    assert!(stdout.contains("MATTE OK"), "{stdout}");
    // Blender's recipe, built from Mix nodes in Blender's compositor, rebuilds Combined.
    assert!(stdout.contains("RECIPE OK"), "{stdout}");
}

#[test]
fn exrheader_and_oiiotool_read_every_layout_and_option() {
    // exrheader exits 1 on a directory, so its probe fails even where it is installed: the
    // file is looked for first, so that the skip line is printed only when it is missing.
    if !Path::new("/usr/bin/exrheader").exists() && !have("exrheader", &[env!("CARGO_MANIFEST_DIR")]) {
        return;
    }
    if !have("oiiotool", &["--version"]) {
        return;
    }
    let dir = TempDir::new("readers");
    let scene = scene_path("whitted.toml");
    for layout in ["blender", "nuke"] {
        for half in [false, true] {
            for compression in ["none", "rle", "zips", "zip", "piz", "pxr24", "b44", "b44a"] {
                let out = dir.path(&format!("{layout}-{half}-{compression}.exr"));
                let mut extra = vec!["--passes", "all", "--exr-layout", layout, "--compression", compression];
                if half {
                    extra.push("--half");
                }
                render(&scene, &out, 24, 18, &extra);
                let header = Command::new("exrheader").arg(&out).output().unwrap();
                let shown = text(&header.stdout);
                assert!(header.status.success(), "exrheader {}: {}", out.display(), text(&header.stderr));
                assert!(shown.contains("worldToCamera") && shown.contains("cryptomatte/"), "{shown}");
                let stats = Command::new("oiiotool").arg("--stats").arg(&out).output().unwrap();
                assert!(stats.status.success(), "oiiotool {}: {}", out.display(), text(&stats.stderr));
                assert!(text(&stats.stdout).contains("Stats Min"), "{}", text(&stats.stdout));
            }
        }
    }
}

#[test]
fn half_files_are_much_smaller() {
    // The 4K Whitted frame, default passes, ZIP.
    let dir = TempDir::new("half");
    let (full, half) = (dir.path("full.exr"), dir.path("half.exr"));
    let scene = scene_path("whitted.toml");
    render(&scene, &full, 3840, 2160, &["--spp", "1"]);
    render(&scene, &half, 3840, 2160, &["--spp", "1", "--half"]);
    let size = |p: &Path| std::fs::metadata(p).unwrap().len() as f64;
    let ratio = size(&full) / size(&half);
    println!("float32 {} bytes, half {} bytes: {ratio:.2}×", size(&full), size(&half));
    assert!(ratio >= 3.0, "half is only {ratio:.2}× smaller");
    // The colour is the float one rounded to half.
    let (_, _, f) = read_exr(&full);
    let h = exr::prelude::read_all_flat_layers_from_file(&half).unwrap();
    let r = h.layer_data[0].channel_data.list.iter().find(|c| c.name.to_string() == "ViewLayer.Combined.R").unwrap();
    let fr = channel(&f, "ViewLayer.Combined.R");
    for (i, &v) in fr.iter().enumerate().step_by(97) {
        assert_eq!(r.sample_data.value_by_flat_index(i).to_f32(), exr::prelude::f16::from_f32(v).to_f32());
    }
}

#[test]
fn the_output_table_chooses_passes_alpha_and_levels() {
    let base = "[camera]\neye = [0, 0, 5]\ntarget = [0, 0, 0]\nfov_deg = 40\n";
    let path = Path::new("s.toml");
    let ok = strahl::scene::from_toml_str(
        &format!(
            "{base}[output]\npasses = [\"default\", \"crypto_object\"]\ntransparent = true\ncryptomatte_levels = 4\n"
        ),
        path,
    )
    .unwrap();
    let out = ok.scene.output;
    assert!(out.transparent && out.crypto_levels == 4);
    assert!(
        out.passes.contains(strahl::output::passes::Pass::CryptoObject)
            && out.passes.contains(strahl::output::passes::Pass::Depth)
    );
    assert!(!out.passes.contains(strahl::output::passes::Pass::Position));
    let e = strahl::scene::from_toml_str(&format!("{base}[output]\npasses = [\"beauty\"]\n"), path).unwrap_err();
    assert!(
        e.to_string().starts_with("s.toml:6:10: output: unknown pass 'beauty' (known: default, all, light, diffuse, glossy, transmission, combined"),
        "{e}"
    );
    let e = strahl::scene::from_toml_str(&format!("{base}[output]\ncryptomatte_levels = 0\n"), path).unwrap_err();
    assert_eq!(e.to_string(), "s.toml:6:22: output: cryptomatte_levels 0 must lie in 1..=16");
}
