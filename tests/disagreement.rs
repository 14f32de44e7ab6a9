//! The `disagreement` pass: the fraction of a pixel's camera rays whose first hit differs
//! between the render's backend and the other one.

mod common;

use std::path::Path;

use common::{TempDir, channel, read_exr, strahl, text};
use strahl::accel::bvh::Bvh;
use strahl::accel::paired::Paired;
use strahl::integrator;
use strahl::output::passes::{Pass, PassSet};
use strahl::scene::{Scene, from_toml_str};

/// A grey ball over a floor, the ball's centre at `ball`, at 24 × 18 pixels and 8 samples.
fn ball_scene(ball: [f32; 3], floor: bool) -> Scene {
    let floor = if floor {
        "[[objects]]\ntype = \"plane\"\nnormal = [0, 1, 0]\ndistance = 0\nmaterial = \"grey\"\n"
    } else {
        ""
    };
    let text = format!(
        "[camera]\neye = [0, 1, 4]\ntarget = [0, 0.5, 0]\nfov_deg = 40\n\
         [image]\nwidth = 24\nheight = 18\nspp = 8\nmax_depth = 1\n\
         [materials.grey]\ndiffuse = 0.5\n\
         [[lights]]\ntype = \"point\"\nposition = [2, 4, 3]\nintensity = 30\n\
         [[objects]]\ntype = \"sphere\"\ncenter = {ball:?}\nradius = 0.5\nmaterial = \"grey\"\n{floor}"
    );
    from_toml_str(&text, Path::new("ball.toml")).unwrap_or_else(|e| panic!("{e}")).scene
}

#[test]
fn the_pass_is_the_coverage_of_what_only_one_backend_sees() {
    // The first backend sees the ball; the second is built from the same scene with the ball
    // moved out of view, so they disagree exactly on the camera rays that hit the ball: the
    // pass must equal the ball's coverage, which a transparent render of the ball alone gives
    // as alpha (the same camera rays: a pixel's samples depend on its index alone).
    let mut seen = ball_scene([0.0, 0.5, 0.0], true);
    seen.output.passes = PassSet::of(&[Pass::Disagreement]);
    let hidden = ball_scene([0.0, 0.5, 100.0], true);
    let paired = Paired { first: common::accel(&seen), second: Bvh::build(&hidden).unwrap() };
    let (film, _) = integrator::render(&seen, &paired, &|_| {}).unwrap();
    let pass = &film.aovs.iter().find(|a| a.pass == Pass::Disagreement).expect("the pass").data;

    let mut alone = ball_scene([0.0, 0.5, 0.0], false);
    alone.output.transparent = true;
    let (coverage, _) = common::render(&alone);
    let (mut partial, mut whole) = (0, 0);
    for (i, &d) in pass.iter().enumerate() {
        let alpha = coverage.rgba[i][3];
        assert_eq!(d, alpha, "pixel {i}: disagreement {d}, ball coverage {alpha}");
        partial += (d > 0.0 && d < 1.0) as u32;
        whole += (d == 1.0) as u32;
    }
    assert!(partial > 10 && whole > 10, "partial {partial}, whole {whole}");

    // The same scene in both backends: the image is unchanged by the comparison.
    let same = Paired { first: common::accel(&seen), second: Bvh::build(&seen).unwrap() };
    let (compared, _) = integrator::render(&seen, &same, &|_| {}).unwrap();
    let (plain, _) = common::render(&seen);
    assert!(common::same_bits(&compared, &plain));
}

#[test]
fn the_command_writes_the_pass_with_either_backend_and_the_same_beauty() {
    let dir = TempDir::new("disagreement");
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/blob.toml");
    let size = ["--width", "64", "--height", "48", "--spp", "4"];
    let render = |name: &str, extra: &[&str]| {
        let out = dir.path(name);
        let args = [&["render", scene.to_str().unwrap(), "-o", out.to_str().unwrap()][..], &size, extra].concat();
        let run = strahl(&args);
        assert!(run.status.success(), "{}", text(&run.stderr));
        (out, text(&run.stdout))
    };
    let (plain, _) = render("plain.exr", &[]);
    let (_, _, plain) = read_exr(&plain);
    for backend in ["embree", "native"] {
        let (out, summary) = render(&format!("{backend}.exr"), &["--backend", backend, "--passes", "disagreement"]);
        let other = if backend == "embree" { "native" } else { "embree" };
        assert!(summary.contains(&format!("camera rays compared with {other}")), "{summary}");
        let (_, _, channels) = read_exr(&out);
        let pass = channel(&channels, "ViewLayer.Disagreement.X");
        assert_eq!(pass.len(), 64 * 48);
        // A fraction of 4 samples in every pixel; on this scene (blobs of 5,120 triangles)
        // the backends agree on almost every ray.
        assert!(pass.iter().all(|&d| (0.0..=1.0).contains(&d) && (d * 4.0).fract() == 0.0));
        let disagreeing = pass.iter().filter(|&&d| d > 0.0).count();
        assert!(disagreeing < 64 * 48 / 100, "{backend}: {disagreeing} pixels disagree");
        if backend == "embree" {
            // The comparison changes nothing else.
            for name in ["ViewLayer.Combined.R", "ViewLayer.Combined.G", "ViewLayer.Combined.B", "ViewLayer.Combined.A"]
            {
                assert_eq!(channel(&channels, name), channel(&plain, name), "{name}");
            }
        }
    }
    // `all` leaves it out.
    let (out, summary) = render("all.exr", &["--passes", "all"]);
    assert!(!summary.contains("compared with"), "{summary}");
    let (_, _, channels) = read_exr(&out);
    assert!(channels.iter().all(|(n, _)| !n.contains("Disagreement")));
}
