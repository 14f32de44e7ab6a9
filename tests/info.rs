//! `strahl info SCENE` through the binary: one line per object (name, type, mesh file, count,
//! materials) and per total, the bounding box, the degenerate triangles dropped, the memory
//! estimate and the load time, in a fixed order; warnings on stderr; errors as one line with exit status 1.

mod common;

use std::path::Path;

use common::{TempDir, data_dir, fails, strahl, text};

/// The lines `strahl info` prints for `scene` (which must succeed), without the memory
/// estimate and the load time, which it checks are a sum of megabytes and a number of
/// milliseconds; and its stderr.
fn info(scene: &Path) -> (Vec<String>, String) {
    let out = strahl(&["info", scene.to_str().unwrap()]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let mut lines: Vec<String> = text(&out.stdout).lines().map(String::from).collect();
    let last = lines.pop().unwrap();
    let ms = last.strip_prefix("load time: ").and_then(|l| l.strip_suffix(" ms")).expect("the load time comes last");
    assert!(ms.parse::<f64>().is_ok_and(|ms| ms >= 0.0), "{last}");
    let default = lines.pop().unwrap();
    assert!(default.starts_with("default --max-memory: "), "the default budget before it: {default}");
    let memory = lines.pop().unwrap();
    let parts = memory.strip_prefix("memory estimate: ").expect("the memory estimate before it");
    let mb = |s: &str| s.trim_end_matches(',').parse::<u64>().unwrap();
    let words: Vec<&str> = parts.split([' ', '(', ')']).filter(|w| !w.is_empty()).collect();
    let total = mb(words[0]);
    let sum: u64 = words.windows(2).filter(|w| w[1].starts_with("MB")).skip(1).map(|w| mb(w[0])).sum();
    // Each part is rounded up to whole MB, so the total lies within their count of the sum.
    assert!(total <= sum && sum <= total + 6, "{memory}");
    (lines, text(&out.stderr))
}

fn shipped(name: &str) -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes").join(name)
}

#[test]
fn the_whitted_scene_with_the_bounds_of_its_spheres() {
    let scene = shipped("whitted.toml");
    let (lines, stderr) = info(&scene);
    // Bounds: the mirror ball (−1.9, 0.7, −2.4) r 1.2 and the glass ball (0.3, 0.4, 0.6) r 0.9.
    let want = [
        format!("scene: {}", scene.display()),
        "object 0 'floor': plane, material checker".into(),
        "object 1 'mirror ball': sphere, material mirror".into(),
        "object 2 'glass ball': sphere, material glass".into(),
        "objects: 3".into(),
        "triangles: 0".into(),
        "spheres: 2".into(),
        "planes: 1".into(),
        "lights: 1".into(),
        "materials: 3".into(),
        "bounds: min [-3.1000, -0.5000, -3.6000] max [1.2000, 1.9000, 1.5000] (meshes and spheres; planes are unbounded)"
            .into(),
        "degenerate triangles dropped: 0".into(),
    ];
    assert_eq!(lines, want);
    assert_eq!(stderr, "");
}

#[test]
fn the_blob_scene_loads_its_generated_meshes() {
    let scene = shipped("blob.toml");
    let (lines, stderr) = info(&scene);
    // Icospheres of 20·4² and 20·4⁴ triangles.
    let dir = shipped("meshes");
    let want_start = [
        format!("scene: {}", scene.display()),
        "object 0 'floor': plane, material checker".into(),
        format!("object 1 'flat blob': mesh {}, 320 triangles, material clay", dir.join("blob-coarse.ply").display()),
        format!("object 2 'smooth blob': mesh {}, 320 triangles, material clay", dir.join("blob-coarse.ply").display()),
        format!("object 3 'glass blob': mesh {}, 5120 triangles, material glass", dir.join("blob.ply").display()),
        "objects: 4".into(),
        "triangles: 5760".into(),
        "spheres: 0".into(),
        "planes: 1".into(),
        "lights: 1".into(),
        "materials: 3".into(),
    ];
    assert_eq!(lines[..want_start.len()], want_start);
    assert!(lines[want_start.len()].starts_with("bounds: min ["), "{lines:?}");
    assert_eq!(lines[want_start.len() + 1..], ["degenerate triangles dropped: 0"]);
    assert_eq!(stderr, "");
}

#[test]
fn the_cornell_box_obj_and_a_mesh_with_degenerate_triangles() {
    let Some(data) = data_dir() else { return };
    let dir = TempDir::new("cornell");
    let head = "[camera]\neye = [0, 1, 4]\ntarget = [0, 1, 0]\nfov_deg = 40\n";
    let cornell = data.join("cornell/CornellBox-Original.obj");
    let scene = dir.write("box.toml", format!("{head}[[objects]]\ntype = \"mesh\"\npath = {:?}\n", cornell.display()));
    let (lines, stderr) = info(&scene);
    let materials = ["leftWall", "rightWall", "floor", "ceiling", "backWall", "shortBox", "tallBox", "light"]
        .map(|m| format!("CornellBox-Original.obj/{m}"))
        .join(", ");
    assert_eq!(lines[1], format!("object 0: mesh {}, 36 triangles, materials {materials}", cornell.display()));
    assert!(
        lines.contains(&"materials: 8".into()) && lines.contains(&"lights: 1 (1 emitting mesh)".into()),
        "{lines:?}"
    );
    // The corners of the box in the OBJ: x from −1.02 to 1, y from 0 to 1.99, z from −1.04 to 0.99.
    assert!(lines.contains(&"bounds: min [-1.0200, 0.0000, -1.0400] max [1.0000, 1.9900, 0.9900] (meshes and spheres; planes are unbounded)".into()), "{lines:?}");
    assert_eq!(stderr, "");

    // The spider drops 56 of its 1,368 triangles (zero area): counted, and warned about. (Its
    // MTL library names textures the data does not ship, an error: the copy leaves it out.)
    let text = std::fs::read_to_string(data.join("edge-cases/assimp-obj/spider.obj")).unwrap();
    let spider =
        dir.write("spider.obj", text.lines().filter(|l| !l.starts_with("mtllib")).collect::<Vec<_>>().join("\n"));
    let scene = dir.write(
        "spider.toml",
        format!("{head}[materials.m]\ndiffuse = 0.5\n[[objects]]\ntype = \"mesh\"\nname = \"spider\"\npath = {:?}\nmaterial = \"m\"\n", spider.display()),
    );
    let (lines, stderr) = info(&scene);
    assert_eq!(
        lines[1],
        format!("object 0 'spider': mesh {}, 1312 triangles (56 degenerate dropped), material m", spider.display())
    );
    assert!(lines.contains(&"triangles: 1312".into()) && lines.ends_with(&["degenerate triangles dropped: 56".into()]));
    let warning =
        format!("object 'spider' (mesh): {}: dropped 56 degenerate (zero-area) triangles of 1368", spider.display());
    assert!(stderr.lines().any(|l| l.starts_with("warning: ") && l.ends_with(&warning)), "{stderr}");
}

#[test]
fn a_missing_scene_is_one_line() {
    let dir = TempDir::new("missing");
    let scene = dir.path("nope.toml");
    let e = fails(&dir, &["info", scene.to_str().unwrap()]);
    assert!(e.starts_with(&format!("error: {}: cannot read the scene: ", scene.display())), "{e}");
}

#[test]
fn a_mesh_file_on_its_own_is_a_scene_of_that_mesh() {
    // As a scene file with one `type = "mesh"` object naming it: the same object line.
    let mesh = shipped("meshes/blob-coarse.ply");
    let (lines, stderr) = info(&mesh);
    assert_eq!(
        lines[..3],
        [
            format!("scene: {}", mesh.display()),
            format!("object 0: mesh {}, 320 triangles, material blob-coarse.ply/default", mesh.display()),
            "objects: 1".into(),
        ]
    );
    assert!(lines.contains(&"lights: 0".into()) && lines.contains(&"materials: 1".into()), "{lines:?}");
    assert_eq!(stderr, "");
    // A broken mesh file: the loader's one line.
    let dir = TempDir::new("mesh-file");
    let bad = dir.write("bad.obj", "v 0 0 0\nv 1 0 0\nf 1 2 3\n");
    let e = fails(&dir, &["info", bad.to_str().unwrap()]);
    assert!(e.starts_with(&format!("error: {}:3: ", bad.display())), "{e}");
}

/// `--width`, `--height` and `--passes` give the memory estimate of the render a farm user
/// plans: 16384² pixels × 11 floats (RGBA, Z, N, albedo) × 4 bytes = 11,811 MB of film, or
/// × 4 floats with `--passes combined`; sizes and passes are checked as `strahl render` checks them.
#[test]
fn the_memory_estimate_at_the_size_and_passes_given() {
    let scene = shipped("whitted.toml");
    let estimate = |extra: &[&str]| -> String {
        let out = strahl(&[&["info", scene.to_str().unwrap()][..], extra].concat());
        assert!(out.status.success(), "{}", text(&out.stderr));
        text(&out.stdout).lines().find(|l| l.starts_with("memory estimate: ")).unwrap().to_string()
    };
    let film_mb = |line: &str| -> u64 {
        let at = line.find("film ").unwrap() + "film ".len();
        line[at..].split(' ').next().unwrap().parse().unwrap()
    };
    let big = estimate(&["--width", "16384", "--height", "16384"]);
    assert_eq!(film_mb(&big), (16384u64 * 16384 * 11 * 4).div_ceil(1_000_000), "{big}");
    assert!(big.ends_with("at 16384 × 16384 (strahl render refuses more than --max-memory)"), "{big}");
    let combined = estimate(&["--width", "16384", "--height", "16384", "--passes", "combined"]);
    assert_eq!(film_mb(&combined), (16384u64 * 16384 * 4 * 4).div_ceil(1_000_000), "{combined}");
    // Without them, the scene's own size (whitted.toml: 640 × 480).
    assert!(estimate(&[]).contains(" at 640 × 480 "), "{}", estimate(&[]));
    let dir = TempDir::new("info-size");
    let e = fails(&dir, &["info", scene.to_str().unwrap(), "--width", "40000", "--height", "40000"]);
    assert!(e.contains("40000 × 40000 pixels is more than the 1073741824"), "{e}");
    let e = fails(&dir, &["info", scene.to_str().unwrap(), "--passes", "bogus"]);
    assert!(e.contains("--passes: unknown pass 'bogus'"), "{e}");
}
