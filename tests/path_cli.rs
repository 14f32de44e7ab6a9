//! The path tracer on the command line: `--integrator` and `[render]` choose it, and what it
//! cannot do is refused in one line before anything is written.

mod common;

use std::path::Path;

use common::{TempDir, fails, strahl, text};

fn cornell() -> String {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell.toml").to_str().unwrap().to_string()
}

#[test]
fn the_path_tracer_refuses_what_it_cannot_render_in_one_line() {
    let dir = TempDir::new("path-cli");
    let out = dir.path("o.exr");
    let o = out.to_str().unwrap();
    let scene = cornell();
    let base = ["render", &scene, "-o", o, "--width", "8", "--height", "8", "--integrator", "path"];
    let with = |extra: &[&str]| -> Vec<String> { base.iter().chain(extra).map(|s| s.to_string()).collect() };
    let run_fails = |extra: &[&str]| {
        let a = with(extra);
        let a: Vec<&str> = a.iter().map(String::as_str).collect();
        fails(&dir, &a)
    };
    let e = run_fails(&["--spp", "65537"]);
    assert!(e.contains("cornell.toml") && e.contains("spp 65537 is more than the 65536"), "{e}");
    let e = run_fails(&["--clamp", "-1"]);
    assert!(e.contains("clamp -1 must be finite and > 0"), "{e}");
    for seed in ["-1", "2147483648", "1e3", "0x10", "7; rm -rf /"] {
        let e = strahl(&with(&["--seed", seed]).iter().map(String::as_str).collect::<Vec<_>>());
        let stderr = text(&e.stderr);
        assert_eq!((e.status.code(), stderr.lines().count()), (Some(2), 1), "{seed}: {stderr}");
        assert!(stderr.contains("--seed"), "{stderr}");
    }
    // A usage error, as clap reports them (status 2).
    let e = strahl(&["render", &scene, "-o", o, "--integrator", "bidirectional"]);
    let stderr = text(&e.stderr);
    assert_eq!((e.status.code(), stderr.lines().count()), (Some(2), 1), "{stderr}");
    assert!(stderr.contains("integrator \"bidirectional\" is not one of"), "{stderr}");
    assert!(!out.exists());
    // In the scene file: named with its line and column.
    let lecture = std::fs::read_to_string(cornell()).unwrap();
    assert!(lecture.contains("integrator = \"whitted\""));
    let bad = dir.write("bad.toml", lecture.replace("integrator = \"whitted\"", "integrator = \"photons\""));
    let e = fails(&dir, &["render", bad.to_str().unwrap(), "-o", o]);
    assert!(e.contains("bad.toml:") && e.contains("render: integrator \"photons\""), "{e}");
    std::fs::remove_file(&bad).unwrap();
    for (seed, problem) in [("-3", "expected u32"), ("2147483648", "render: seed 2147483648 is more than 2147483647")] {
        let bad = dir.write("seed.toml", lecture.replace("integrator = \"whitted\"", &format!("seed = {seed}")));
        let e = fails(&dir, &["render", bad.to_str().unwrap(), "-o", o]);
        assert!(e.contains("seed.toml:") && e.contains(problem), "{e}");
        std::fs::remove_file(&bad).unwrap();
    }
    // And it renders: 8 × 8 at 4 spp, the header naming the integrator.
    let ok = strahl(&with(&["--spp", "4"]).iter().map(String::as_str).collect::<Vec<_>>());
    assert!(ok.status.success(), "{}", text(&ok.stderr));
    let image = common::read_exr_image(&out);
    use exr::meta::attribute::{AttributeValue, Text};
    let attributes = &image.layer_data[0].attributes.other;
    assert_eq!(attributes.get(&Text::from("strahl/integrator")), Some(&AttributeValue::Text(Text::from("path"))));
    assert_eq!(attributes.get(&Text::from("strahl/lightSampler")), Some(&AttributeValue::Text(Text::from("tree"))));
    assert_eq!(attributes.get(&Text::from("strahl/clamp")), None);
    assert_eq!(attributes.get(&Text::from("strahl/adaptiveThreshold")), None);
    assert_eq!(attributes.get(&Text::from("strahl/seed")), None);
    // The settings that change the estimator are recorded with the values given.
    let args = with(&[
        "--spp",
        "4",
        "--light-sampler",
        "power",
        "--clamp",
        "7.5",
        "--adaptive-threshold",
        "0.02",
        "--seed",
        "2147483647",
    ]);
    let ok = strahl(&args.iter().map(String::as_str).collect::<Vec<_>>());
    assert!(ok.status.success(), "{}", text(&ok.stderr));
    let image = common::read_exr_image(&out);
    let attributes = &image.layer_data[0].attributes.other;
    assert_eq!(attributes.get(&Text::from("strahl/lightSampler")), Some(&AttributeValue::Text(Text::from("power"))));
    assert_eq!(attributes.get(&Text::from("strahl/clamp")), Some(&AttributeValue::F32(7.5)));
    assert_eq!(attributes.get(&Text::from("strahl/adaptiveThreshold")), Some(&AttributeValue::F32(0.02)));
    assert_eq!(attributes.get(&Text::from("strahl/seed")), Some(&AttributeValue::I32(2147483647)));
    // The Whitted integrator has none of them.
    let ok = strahl(&["render", &scene, "-o", o, "--width", "8", "--height", "8", "--integrator", "whitted"]);
    assert!(ok.status.success(), "{}", text(&ok.stderr));
    let image = common::read_exr_image(&out);
    assert_eq!(image.layer_data[0].attributes.other.get(&Text::from("strahl/lightSampler")), None);
}

/// The integrator an EXR's header names.
fn integrator_of(exr: &Path) -> String {
    use exr::meta::attribute::{AttributeValue, Text};
    let image = common::read_exr_image(exr);
    match image.layer_data[0].attributes.other.get(&Text::from("strahl/integrator")) {
        Some(AttributeValue::Text(t)) => t.to_string(),
        other => panic!("strahl/integrator is {other:?}"),
    }
}

#[test]
fn the_path_tracer_is_the_default_and_the_lecture_scenes_choose_whitted() {
    let dir = TempDir::new("path-default");
    // The Cornell box without its `[render]` table: path-traced, with a warning that the path
    // tracer ignores the scene's ambient term.
    let lecture = std::fs::read_to_string(cornell()).unwrap();
    let chosen = "[render]\nintegrator = \"whitted\"";
    assert!(lecture.contains(chosen));
    let plain = dir.write("plain.toml", lecture.replace(chosen, ""));
    let out = dir.path("plain.exr");
    let args = ["--width", "8", "--height", "8", "--spp", "2"];
    let run = strahl(&[&["render", plain.to_str().unwrap(), "-o", out.to_str().unwrap()][..], &args].concat());
    assert!(run.status.success(), "{}", text(&run.stderr));
    assert_eq!(integrator_of(&out), "path");
    let stderr = text(&run.stderr);
    assert!(stderr.contains("warning: ") && stderr.contains("ambient is the Whitted integrator's"), "{stderr}");
    // Every lecture scene shipped says `whitted`, and renders so without a warning.
    for name in ["whitted", "lecture", "cornell", "spheres", "blob"] {
        let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("scenes/{name}.toml"));
        let out = dir.path(&format!("{name}.exr"));
        let run = strahl(&[&["render", scene.to_str().unwrap(), "-o", out.to_str().unwrap()][..], &args].concat());
        assert!(run.status.success(), "{name}: {}", text(&run.stderr));
        assert_eq!(integrator_of(&out), "whitted", "{name}");
        assert!(!text(&run.stderr).contains("warning"), "{name}: {}", text(&run.stderr));
    }
}
