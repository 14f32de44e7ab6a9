//! The two backends through the `strahl` command: `render --backend native` and `--backend
//! embree` of the shipped Whitted and Cornell scenes, at their own sizes and sample counts,
//! read back from the EXRs, differ in at most 0.1 % of pixels; `strahl bench` prints every
//! column of its table.

mod common;

use std::path::{Path, PathBuf};

use common::{TempDir, read_exr, strahl, text};

fn scene_path(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes").join(name)
}

/// Renders `scene` with `backend` on two threads into `dir`; returns the EXR's path.
fn render(scene: &Path, backend: &str, dir: &TempDir) -> PathBuf {
    let exr = dir.path(&format!("{backend}.exr"));
    let out = strahl(&["render", scene.to_str().unwrap(), "-o", exr.to_str().unwrap(), "--backend", backend]);
    assert!(out.status.success(), "{backend}: {}", text(&out.stderr));
    let stdout = text(&out.stdout);
    assert!(stdout.contains(&format!("\n  backend: {backend}, BVH built in ")), "{stdout}");
    exr
}

/// Whether two values of a channel differ by more than rounding: the backends' `t` differ in
/// the last few ulps (crosscheck's |Δt|/t is about 10⁻⁷), which moves a hit point, its shadow
/// ray and its reflections by as little and shading by a relative 10⁻⁶ or so; 10⁻⁴ is far above
/// that and far below any change a different hit makes (another object, a shadow, a miss).
fn differ(a: f32, b: f32) -> bool {
    // Equal values (infinite depths too) never differ; a NaN on either side always does.
    let close = (a - b).abs() <= 1e-4 * a.abs().max(b.abs()) + 1e-6;
    a != b && !close
}

/// Renders `name` with both backends and returns the fractions of pixels that differ in any
/// channel beyond rounding (see [`differ`]) and in any bit.
fn compare_backends(name: &str) -> (f64, f64) {
    let dir = TempDir::new(&format!("backends-{name}"));
    let scene = scene_path(name);
    let (w, h, embree) = read_exr(&render(&scene, "embree", &dir));
    let (w2, h2, native) = read_exr(&render(&scene, "native", &dir));
    assert_eq!((w, h), (w2, h2));
    let names = |c: &[(String, Vec<f32>)]| c.iter().map(|(n, _)| n.clone()).collect::<Vec<_>>();
    assert_eq!(names(&embree), names(&native));
    let (mut beyond, mut bitwise, mut worst) = (vec![false; w * h], vec![false; w * h], 0f32);
    for ((_, a), (_, b)) in embree.iter().zip(&native) {
        for (i, (&a, &b)) in a.iter().zip(b).enumerate() {
            beyond[i] |= differ(a, b);
            bitwise[i] |= a.to_bits() != b.to_bits();
            if a != b {
                worst = worst.max((a - b).abs() / a.abs().max(b.abs()));
            }
        }
    }
    let fraction = |v: &[bool]| v.iter().filter(|&&d| d).count() as f64 / v.len() as f64;
    let (beyond, bitwise) = (fraction(&beyond), fraction(&bitwise));
    println!(
        "{name} ({w} × {h}): {:.4} % of pixels differ, {:.4} % in some bit; largest relative difference {worst:.2e}",
        100.0 * beyond,
        100.0 * bitwise
    );
    (beyond, bitwise)
}

#[test]
fn whitted_renders_alike_with_both_backends() {
    // Spheres and a plane only: both backends call the same sphere and plane routines.
    let (beyond, _) = compare_backends("whitted.toml");
    assert!(beyond <= 0.001, "{beyond}");
}

#[test]
fn cornell_renders_alike_with_both_backends() {
    // Triangles too: two different f32 triangle tests decide hit or miss, but shading
    // re-solves each hit's t, u, v in f64 on the same triangle, so only a different decision
    // at an edge can change a pixel (measured: none; before the re-solve most pixels differed
    // in their last bits).
    let (beyond, bitwise) = compare_backends("cornell.toml");
    assert!(beyond <= 0.001, "{beyond}");
    assert!(bitwise <= 0.001, "{bitwise}");
}

/// The numbers in a table row after its label.
fn numbers(line: &str) -> Vec<f64> {
    line.split_whitespace().filter_map(|w| w.parse().ok()).collect()
}

#[test]
fn bench_prints_every_column() {
    let lecture = scene_path("lecture.toml");
    let out = strahl(&["bench", lecture.to_str().unwrap(), "--rays", "2000", "--runs", "1"]);
    let stdout = text(&out.stdout);
    println!("{stdout}");
    assert!(out.status.success(), "{}", text(&out.stderr));
    // The line that starts with `label` followed by at least two spaces (a table row), or
    // by anything for a label that ends in a space or a colon.
    // Throughput rows are looked for after the `Mrays/s` header (the build rows have the same
    // engine names).
    let find = |text: &str, label: &str| -> String {
        let row =
            |l: &&str| l.strip_prefix(label).is_some_and(|rest| label.ends_with([' ', ':']) || rest.starts_with("  "));
        text.lines().find(row).unwrap_or_else(|| panic!("no line {label:?}: {stdout}")).to_string()
    };
    let line = |label: &str| find(&stdout, label);
    let throughput = stdout.split("\nMrays/s").nth(1).expect("a Mrays/s table");
    assert!(line(&format!("{}: ", lecture.display())).contains(
        "2000 rays per kind (primary, random, secondary, shadow; primary: 48 × 48), median of 1 run; load average"
    ));
    assert_eq!(line("1 triangles, "), "1 triangles, 1 spheres, 1 planes");
    assert_eq!(line("build ms").split_whitespace().collect::<Vec<_>>(), ["build", "ms", "1", "thr", "2", "thr"]);
    for engine in ["embree", "native"] {
        assert_eq!(numbers(&line(engine)).len(), 2, "{engine}");
    }
    let columns = line("Mrays/s").split_whitespace().skip(1).collect::<Vec<_>>().join(" ");
    assert_eq!(columns, "primary 1t random 1t secondary 1t shadow 1t primary 2t random 2t secondary 2t shadow 2t");
    // Raw Embree on the same rays, strahl's wrapper, the native BVH, and the ratios to raw.
    for row in [
        "raw embree x1",
        "embree x1 (strahl)",
        "raw embree x8",
        "embree x8 (strahl)",
        "native",
        "embree x1 / raw x1",
        "embree x8 / raw x8",
        "native / raw x1",
    ] {
        let values = numbers(&find(throughput, row));
        assert_eq!(values.len(), 8, "{row}: {values:?}");
        assert!(values.iter().all(|v| *v > 0.0), "{row}: {values:?}");
    }
    assert_eq!(numbers(&line("hit %")).len(), 8);
    assert!(line("load average after: ").len() > "load average after: ".len());

    // One kind, one thread count.
    let out = strahl(&[
        "bench",
        lecture.to_str().unwrap(),
        "--rays",
        "500",
        "--runs",
        "2",
        "--kind",
        "random",
        "--threads",
        "2",
    ]);
    let stdout = text(&out.stdout);
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert!(
        stdout.contains("median of 2 runs") && stdout.contains("\nMrays/s") && stdout.contains(" random 2t\n"),
        "{stdout}"
    );
    assert!(!stdout.contains("primary 2t") && !stdout.contains("1 thr"), "{stdout}");
    // Usage errors: exit status 2, one line.
    for args in [["--threads", "0"], ["--runs", "0"]] {
        let out = strahl(&["bench", lecture.to_str().unwrap(), args[0], args[1]]);
        assert_eq!(out.status.code(), Some(2), "{args:?}");
        assert_eq!(text(&out.stderr).lines().count(), 1, "{}", text(&out.stderr));
    }
}

#[test]
fn render_refuses_a_mesh_file_and_an_unknown_backend() {
    let dir = TempDir::new("backends-refused");
    let out = dir.path("out.exr");
    let mesh = scene_path("meshes/blob-coarse.ply");
    let e = common::fails(&dir, &["render", mesh.to_str().unwrap(), "-o", out.to_str().unwrap()]);
    assert_eq!(
        e,
        format!(
            "error: {}: is a mesh file, with no camera or lights to render it by; name it in a scene file (an object \
             of `type = \"mesh\"`, see docs/scene-format.md)",
            mesh.display()
        )
    );
    let lecture = scene_path("lecture.toml");
    let args = ["render", lecture.to_str().unwrap(), "-o", out.to_str().unwrap(), "--backend", "optix"];
    let out = strahl(&args);
    assert_eq!(out.status.code(), Some(2));
    assert!(text(&out.stderr).contains("invalid value 'optix' for '--backend"), "{}", text(&out.stderr));
}
