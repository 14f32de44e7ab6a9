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
    let e = run_fails(&["--passes", "combined,diffuse"]);
    assert!(e.contains("cornell.toml") && e.contains("the diffuse pass is the Whitted integrator's"), "{e}");
    let e = run_fails(&["--spp", "65537"]);
    assert!(e.contains("spp 65537 is more than the 65536"), "{e}");
    let e = run_fails(&["--clamp", "-1"]);
    assert!(e.contains("clamp -1 must be finite and > 0"), "{e}");
    // A usage error, as clap reports them (status 2).
    let e = strahl(&["render", &scene, "-o", o, "--integrator", "bidirectional"]);
    let stderr = text(&e.stderr);
    assert_eq!((e.status.code(), stderr.lines().count()), (Some(2), 1), "{stderr}");
    assert!(stderr.contains("integrator \"bidirectional\" is not one of"), "{stderr}");
    assert!(!out.exists());
    // In the scene file: named with its line and column.
    let bad =
        dir.write("bad.toml", std::fs::read_to_string(cornell()).unwrap() + "\n[render]\nintegrator = \"photons\"\n");
    let e = fails(&dir, &["render", bad.to_str().unwrap(), "-o", o]);
    assert!(e.contains("bad.toml:") && e.contains("render: integrator \"photons\""), "{e}");
    std::fs::remove_file(&bad).unwrap();
    // And it renders: 8 × 8 at 4 spp, the header naming the integrator.
    let ok = strahl(&with(&["--spp", "4"]).iter().map(String::as_str).collect::<Vec<_>>());
    assert!(ok.status.success(), "{}", text(&ok.stderr));
    let image = common::read_exr_image(&out);
    use exr::meta::attribute::{AttributeValue, Text};
    let attributes = &image.layer_data[0].attributes.other;
    assert_eq!(attributes.get(&Text::from("strahl/integrator")), Some(&AttributeValue::Text(Text::from("path"))));
}
