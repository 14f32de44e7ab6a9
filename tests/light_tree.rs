//! The light tree in the path tracer: a floor under a ceiling of 512 small emissive triangles
//! (`procedural::light_panel_room`, 16 × 16 quads, without its icosahedra), direct light only
//! (max depth 1), against the closed form: every floor point's radiance is
//! `ρ · Σ_i L_i · F_i`, `F_i` the form factor from the point to quad `i` (a parallel
//! rectangle), and the camera sees only floor. Both choices of light (`tree`, `power`) and both
//! backends must give it within 3 standard errors; NEE and the MIS weight of emitters found by
//! BSDF samples both use the tree's pmf, so a pmf that differs from what `sample` did biases
//! the image. At equal samples the tree's noise is lower than power's.

mod common;

use strahl::accel::bvh::Bvh;
use strahl::integrator;
use strahl::light::set::LightSampler;
use strahl::output::passes::{Pass, PassSet};
use strahl::scene::Scene;
use strahl::scene::procedural::light_panel_room;

/// The room of 16 × 16 quads over 12 × 12 m, seen straight down from 1 m above the floor point
/// `(0.4, 0.1)` (so every pixel sees floor), direct light only.
fn room(sampler: LightSampler) -> Scene {
    let mut s = light_panel_room(16, 12.0, 16, 16, 128, 1);
    s.meshes.truncate(2);
    s.camera.eye = strahl::math::Vec3::new(0.4, 1.0, 0.1);
    s.camera.target = strahl::math::Vec3::new(0.4, 0.0, 0.1);
    s.camera.up = strahl::math::Vec3::Z;
    s.camera.fov_deg = 4.0;
    s.render.light_sampler = sampler;
    s.output.passes = PassSet::parse(&["combined", "position"]).unwrap();
    s
}

/// `ρ · Σ L_i · F_i` (red) at the floor point `(x, z)`.
fn exact(s: &Scene, x: f64, z: f64) -> f64 {
    let panel = &s.meshes[0];
    let rho = 0.5;
    let mut sum = 0.0;
    for q in 0..panel.indices.len() / 2 {
        let [a, b, _] = panel.triangle(2 * q);
        let [_, _, c] = panel.triangle(2 * q);
        let (lo, hi) = (a.min(b).min(c), a.max(b).max(c));
        let l = s.materials[panel.material_of(2 * q) as usize].emission.x as f64;
        sum += l * common::form_factor(lo.x as f64, hi.x as f64, lo.z as f64, hi.z as f64, lo.y as f64, x, z);
    }
    rho * sum
}

/// The residuals (pixel − closed form) of a render of `s` through `accel`.
fn residuals(s: &Scene, film: &strahl::output::film::Film) -> Vec<f64> {
    let position = &film.aovs.iter().find(|a| a.pass == Pass::Position).unwrap().data;
    film.rgba
        .iter()
        .enumerate()
        .map(|(i, p)| {
            assert!((position[3 * i + 1]).abs() < 1e-4, "pixel {i} sees the floor");
            p[0] as f64 - exact(s, position[3 * i] as f64, position[3 * i + 2] as f64)
        })
        .collect()
}

#[test]
fn tree_and_power_converge_to_the_closed_form_on_both_backends() {
    let want = exact(&room(LightSampler::Tree), 0.4, 0.1);
    let mut errors = Vec::new();
    for sampler in [LightSampler::Tree, LightSampler::Power] {
        let s = room(sampler);
        let embree = common::accel(&s);
        let bvh = Bvh::build(&s).unwrap();
        for (backend, film) in [
            ("embree", integrator::render(&s, &embree, &|_| {}).unwrap().0),
            ("native", integrator::render(&s, &bvh, &|_| {}).unwrap().0),
        ] {
            let (bias, se) = common::mean_and_error(&residuals(&s, &film));
            eprintln!("{sampler:?} {backend}: residual {bias:.5} ± {se:.5} of {want:.4}");
            assert!(bias.abs() <= 3.0 * se, "{sampler:?} {backend}: {bias} ± {se} (value {want})");
            assert!(se < 0.01 * want, "too noisy to tell: ± {se} of {want}");
            errors.push(se);
        }
    }
    // The same light reached with fewer wasted samples: the tree's standard error is lower.
    eprintln!("standard error tree / power: {:.3}", errors[0] / errors[2]);
    assert!(errors[0] < 0.8 * errors[2] && errors[1] < 0.8 * errors[3], "{errors:?}");
}

/// `[render] light_sampler` and `--light-sampler` choose the sampler; a name that is neither is
/// refused in one line (the file, line and column; clap's usage error), nothing written.
#[test]
fn the_sampler_is_chosen_in_the_scene_file_and_on_the_command_line() {
    use std::path::Path;
    let dir = common::TempDir::new("light-sampler");
    let out = dir.path("o.exr");
    let o = out.to_str().unwrap();
    let cornell = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-path.toml"))
        .unwrap()
        .replace("[render]\n", "[render]\nlight_sampler = \"power\"\n");
    let scene = dir.write("power.toml", &cornell);
    let loaded = strahl::scene::load::file::load(&scene).unwrap().scene;
    assert_eq!(loaded.render.light_sampler, LightSampler::Power);
    assert_eq!(room(LightSampler::Tree).render.light_sampler, LightSampler::default());
    let bad = dir.write("bad.toml", cornell.replace("\"power\"", "\"uniform\""));
    let e = common::fails(&dir, &["render", bad.to_str().unwrap(), "-o", o]);
    assert!(e.contains("bad.toml:") && e.contains("light_sampler \"uniform\" is not one of"), "{e}");
    let s = scene.to_str().unwrap();
    let small = ["render", s, "-o", o, "--width", "8", "--height", "8", "--spp", "2", "--integrator", "path"];
    let e = common::strahl(&[&small[..], &["--light-sampler", "uniform"]].concat());
    let stderr = common::text(&e.stderr);
    assert_eq!((e.status.code(), stderr.lines().count()), (Some(2), 1), "{stderr}");
    assert!(!out.exists());
    for name in ["tree", "power"] {
        let ok = common::strahl(&[&small[..], &["--light-sampler", name]].concat());
        assert!(ok.status.success(), "{}", common::text(&ok.stderr));
        assert!(out.exists());
        std::fs::remove_file(&out).unwrap();
    }
}
