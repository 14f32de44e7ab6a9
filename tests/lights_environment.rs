//! The environment light, rendered by the path tracer, against closed forms: every estimate
//! within 3 standard errors (measured from the image's own pixels, which are independent
//! estimates of the same value) of the exact value.
//!
//! - **White furnace**: a Lambertian sphere of albedo 1 inside a uniform environment of
//!   radiance 1 has radiance 1 everywhere, at every max depth ≥ 1 (a convex object never sees
//!   itself), whether the environment is a colour or a map of constant texels.
//! - **A diffuse plane under a constant sky** `L`: irradiance `E = π·L`, radiance `ρ·L`.
//! - **Orientation**: a map black but for one texel lights a small square only from the
//!   side Blender's convention puts that texel on (the map's centre column faces `+x`, three
//!   quarters `+z`), turned by `rotation`; the radiance is `ρ/π · L · ∫_texel cos⁺ dω`.
//! - The `[environment]` table and `strahl render --environment` read EXR and `.hdr` maps,
//!   and bad input is one line naming the file.

mod common;

use std::path::Path;

use strahl::scene::Scene;

fn scene_in(toml: &str, dir: &Path) -> Scene {
    strahl::scene::load::file::from_toml_str(toml, &dir.join("environment.toml")).unwrap().scene
}

fn scene(toml: &str) -> Scene {
    scene_in(toml, Path::new(""))
}

/// Mean and standard error of each channel over the pixels.
fn stats(scene: &Scene) -> ([f64; 3], [f64; 3]) {
    let (film, _) = common::render(scene);
    let mut mean = [0.0; 3];
    let mut se = [0.0; 3];
    for c in 0..3 {
        let v: Vec<f64> = film.rgba.iter().map(|p| p[c] as f64).collect();
        (mean[c], se[c]) = common::mean_and_error(&v);
    }
    (mean, se)
}

fn assert_close(what: &str, (mean, se): ([f64; 3], [f64; 3]), want: [f64; 3]) {
    eprintln!("{what}: {mean:?} ± {se:?} (exact {want:?})");
    for c in 0..3 {
        assert!(
            (mean[c] - want[c]).abs() <= 3.0 * se[c] + 1e-5,
            "{what}: channel {c}: {} ± {} vs {}",
            mean[c],
            se[c],
            want[c]
        );
        assert!(se[c] <= 0.02 * want[c].max(0.05), "{what}: too noisy to tell: ± {}", se[c]);
    }
}

/// Writes a `w × h` EXR map of RGB texels (row 0 at the top) to `path`.
fn write_exr(path: &Path, w: usize, h: usize, texel: impl Fn(usize, usize) -> [f32; 3] + Sync) {
    exr::prelude::write_rgb_file(path, w, h, |x, y| {
        let t = texel(x, y);
        (t[0], t[1], t[2])
    })
    .unwrap();
}

fn furnace(environment: &str, depth: u32) -> String {
    format!(
        r#"
[render]
integrator = "path"
[camera]
eye = [0, 0, 3]
target = [0, 0, 0]
fov_deg = 60
[image]
width = 24
height = 24
spp = 32
max_depth = {depth}
[materials.white]
diffuse = [1, 1, 1]
[[objects]]
type = "sphere"
center = [0, 0, 0]
radius = 1
material = "white"
{environment}
"#
    )
}

#[test]
fn white_furnace_renders_one_everywhere() {
    let dir = common::TempDir::new("furnace");
    write_exr(&dir.path("white.exr"), 32, 16, |_, _| [1.0, 1.0, 1.0]);
    for env in ["[environment]\ncolor = [1, 1, 1]", "[environment]\nfile = \"white.exr\"\nrotation = 33"] {
        for depth in [1, 2, 5] {
            let s = scene_in(&furnace(env, depth), &dir.path(""));
            let (film, _) = common::render(&s);
            // Every pixel, not only the mean: the sphere's pixels are 1 within their noise.
            let v: Vec<f64> = film.rgba.iter().map(|p| p[1] as f64).collect();
            assert_close(&format!("{env:?} depth {depth}"), stats(&s), [1.0; 3]);
            let worst = v.iter().map(|x| (x - 1.0).abs()).fold(0.0, f64::max);
            assert!(worst < 0.5, "{env:?} depth {depth}: a pixel off by {worst}");
        }
    }
}

#[test]
fn a_diffuse_plane_under_a_constant_sky_reflects_rho_times_l() {
    let s = scene(
        r#"
[render]
integrator = "path"
[camera]
eye = [0, 5, 0.01]
target = [0, 0, 0]
fov_deg = 30
[image]
width = 16
height = 16
spp = 64
max_depth = 3
[materials.grey]
diffuse = [0.5, 0.5, 0.5]
[[objects]]
type = "plane"
normal = [0, 1, 0]
distance = 0
material = "grey"
[environment]
color = [0.4, 0.8, 1.0]
strength = 2
"#,
    );
    assert_close("plane under the sky", stats(&s), [0.4, 0.8, 1.0]);
}

/// `∫ max(0, n·ω) dω` over texel `(i, j)` of a `w × h` map turned by `rotation_deg`
/// (midpoint rule on a fine grid, with the module's mapping written out again).
fn texel_cosine_integral(n: [f64; 3], i: usize, j: usize, w: usize, h: usize, rotation_deg: f64) -> f64 {
    use std::f64::consts::PI;
    let k = 400;
    let (c, s) = (rotation_deg.to_radians().cos(), rotation_deg.to_radians().sin());
    let mut sum = 0.0;
    for a in 0..k {
        for b in 0..k {
            let u = (i as f64 + (a as f64 + 0.5) / k as f64) / w as f64;
            let t = (j as f64 + (b as f64 + 0.5) / k as f64) / h as f64;
            let (theta, phi) = (PI * t, 2.0 * PI * (u - 0.5));
            let d = [theta.sin() * phi.cos(), theta.cos(), theta.sin() * phi.sin()];
            // The map's frame to the world: turned right-handedly about +y.
            let world = [c * d[0] + s * d[2], d[1], -s * d[0] + c * d[2]];
            let cos = n[0] * world[0] + n[1] * world[1] + n[2] * world[2];
            let d_omega = 2.0 * PI * PI * theta.sin() / (w * h) as f64 / (k * k) as f64;
            sum += cos.max(0.0) * d_omega;
        }
    }
    sum
}

/// A small grey square facing `n`, seen head-on, under `environment`.
fn facing(n: [f64; 3], environment: &str) -> String {
    // Two unit vectors across the square.
    let up = if n[1].abs() > 0.9 { [1.0, 0.0, 0.0] } else { [0.0, 1.0, 0.0] };
    let cross =
        |a: [f64; 3], b: [f64; 3]| [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
    let e1 = cross(up, n);
    let e2 = cross(n, e1);
    let p = |s1: f64, s2: f64| {
        format!("[{}, {}, {}]", s1 * e1[0] + s2 * e2[0], s1 * e1[1] + s2 * e2[1], s1 * e1[2] + s2 * e2[2])
    };
    format!(
        r#"
[render]
integrator = "path"
[camera]
eye = [{}, {}, {}]
target = [0, 0, 0]
up = [{}, {}, {}]
fov_deg = 10
[image]
width = 12
height = 12
spp = 64
max_depth = 1
[materials.grey]
diffuse = [0.5, 0.5, 0.5]
[[objects]]
type = "triangles"
positions = [{}, {}, {}, {}]
indices = [[0, 1, 2], [0, 2, 3]]
material = "grey"
{environment}
"#,
        4.0 * n[0],
        4.0 * n[1],
        4.0 * n[2],
        up[0],
        up[1],
        up[2],
        p(-1.0, -1.0),
        p(1.0, -1.0),
        p(1.0, 1.0),
        p(-1.0, 1.0),
    )
}

#[test]
fn one_bright_texel_lights_from_blenders_direction() {
    let dir = common::TempDir::new("one-texel");
    // An 8 × 4 map, black but for texel (6, 1): φ ∈ [90°, 135°] (towards +z, a little −x),
    // θ ∈ [45°, 90°] from straight up.
    let (w, h, ti, tj, l) = (8, 4, 6, 1, 50.0);
    write_exr(&dir.path("texel.exr"), w, h, |x, y| if (x, y) == (ti, tj) { [l; 3] } else { [0.0; 3] });
    for rotation in [0.0, 90.0] {
        let env = format!("[environment]\nfile = \"texel.exr\"\nrotation = {rotation}");
        for n in [[0.0, 0.0, 1.0], [0.0, 0.0, -1.0], [1.0, 0.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 1.0, 0.0]] {
            let s = scene_in(&facing(n, &env), &dir.path(""));
            let want = 0.5 / std::f64::consts::PI * l as f64 * texel_cosine_integral(n, ti, tj, w, h, rotation);
            let what = format!("rotation {rotation}, square facing {n:?}");
            assert_close(&what, stats(&s), [want; 3]);
            // The texel lights +z (Blender's −y) unturned, and +x turned by 90°.
            let lit = if rotation == 0.0 { [0.0, 0.0, 1.0] } else { [1.0, 0.0, 0.0] };
            if n == lit {
                assert!(want > 0.5, "{what}: {want}");
            }
            if n == [-lit[0], 0.0, -lit[2]] {
                assert_eq!(want, 0.0, "{what}");
            }
        }
    }
}

#[test]
fn hdr_maps_and_the_command_line_option() {
    let dir = common::TempDir::new("env-cli");
    // A constant map of 0.5 as Radiance HDR (exact in RGBE), given on the command line to a
    // scene without an environment: the furnace at depth 2 renders 0.5.
    let pixels = vec![image::Rgb([0.5f32, 0.5, 0.5]); 16 * 8];
    let mut bytes = Vec::new();
    image::codecs::hdr::HdrEncoder::new(&mut bytes).encode(&pixels, 16, 8).unwrap();
    let hdr = dir.write("sky.hdr", &bytes);
    let toml = dir.write("furnace.toml", furnace("", 2));
    let out = dir.path("out.exr");
    for env in [hdr.to_str().unwrap(), "0.5,0.5,0.5"] {
        let o = common::strahl(&[
            "render",
            toml.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
            "--integrator",
            "path",
            "--environment",
            env,
        ]);
        assert!(o.status.success(), "{}", common::text(&o.stderr));
        let (_, _, channels) = common::read_exr(&out);
        let g = common::channel(&channels, "ViewLayer.Combined.G");
        let mean = g.iter().map(|&x| x as f64).sum::<f64>() / g.len() as f64;
        assert!((mean - 0.5).abs() < 0.01, "--environment {env}: mean {mean}");
    }
    // Bad input: one line naming the file, no output.
    std::fs::remove_file(&out).unwrap();
    let junk = dir.write("junk.hdr", b"#?RADIANCE\nnot really\n");
    for (args, names) in [
        (vec!["--environment", junk.to_str().unwrap()], "junk.hdr"),
        (vec!["--environment", dir.path("missing.exr").to_str().unwrap()], "missing.exr"),
        (vec!["--environment", "1,-1,1"], "--environment"),
    ] {
        let mut all = vec!["render", toml.to_str().unwrap(), "-o", out.to_str().unwrap(), "--integrator", "path"];
        all.extend(args);
        let e = common::fails(&dir, &all);
        assert!(e.contains(names) && e.trim().lines().count() == 1, "{e}");
        assert!(!out.exists());
    }
    let bad = dir.write("bad.toml", furnace("[environment]\nfile = \"junk.hdr\"", 2));
    let e = common::fails(&dir, &["render", bad.to_str().unwrap(), "-o", out.to_str().unwrap()]);
    assert!(e.contains("bad.toml:") && e.contains("junk.hdr") && e.trim().lines().count() == 1, "{e}");
    let both = dir.write("both.toml", furnace("[environment]\nfile = \"sky.hdr\"\ncolor = 1", 2));
    let e = common::fails(&dir, &["render", both.to_str().unwrap(), "-o", out.to_str().unwrap()]);
    assert!(e.contains("both.toml:") && e.contains("not both"), "{e}");
}

#[test]
fn strength_and_rotation_from_the_command_line_equal_the_scene_keys() {
    let dir = common::TempDir::new("env-flags");
    let (w, h) = (8, 4);
    write_exr(&dir.path("texel.exr"), w, h, |x, y| if (x, y) == (6, 1) { [50.0; 3] } else { [0.0; 3] });
    let render = |toml: &str, extra: &[&str]| {
        let scene = dir.write("s.toml", toml);
        let out = dir.path("out.exr");
        let mut args = vec!["render", scene.to_str().unwrap(), "-o", out.to_str().unwrap(), "--integrator", "path"];
        args.extend(extra);
        let o = common::strahl(&args);
        assert!(o.status.success(), "{}", common::text(&o.stderr));
        let (_, _, channels) = common::read_exr(&out);
        common::channel(&channels, "ViewLayer.Combined.G").to_vec()
    };
    // A square facing +x: lit only once the map is turned by 90°, and 2.5 times as bright at
    // strength 2.5; the flags give the pixels the scene keys give, bit for bit.
    let keys = facing([1.0, 0.0, 0.0], "[environment]\nfile = \"texel.exr\"\nrotation = 90\nstrength = 2.5");
    let plain = facing([1.0, 0.0, 0.0], "[environment]\nfile = \"texel.exr\"");
    let by_keys = render(&keys, &[]);
    let by_flags = render(&plain, &["--environment-rotation", "90", "--environment-strength", "2.5"]);
    let unturned = render(&plain, &[]);
    assert_eq!(by_keys, by_flags);
    let mean = |v: &[f32]| v.iter().map(|&x| x as f64).sum::<f64>() / v.len() as f64;
    assert!(mean(&by_flags) > 0.5 && mean(&unturned) < 1e-3, "{} {}", mean(&by_flags), mean(&unturned));
    // The flags override the keys, and rotation −90 is 270.
    let back = render(&keys, &["--environment-rotation", "-90", "--environment-strength", "1"]);
    assert!(mean(&back) < 1e-3, "{}", mean(&back));
    // With --environment too, after it.
    let constant = render(&plain, &["--environment", "0.5,0.5,0.5", "--environment-strength", "2"]);
    assert!((mean(&constant) - 0.5 / std::f64::consts::PI * std::f64::consts::PI * 2.0 * 0.5).abs() < 0.02);
    // Bad values and a scene without an environment: one line naming the flag, no output.
    let out = dir.path("out.exr");
    std::fs::remove_file(&out).unwrap();
    let none = dir.write("none.toml", facing([1.0, 0.0, 0.0], ""));
    for (scene, flag, value) in [
        (&plain, "--environment-strength", "-1"),
        (&plain, "--environment-strength", "nan"),
        (&plain, "--environment-rotation", "inf"),
        (&String::new(), "--environment-rotation", "10"),
    ] {
        let path = if scene.is_empty() { none.clone() } else { dir.write("s.toml", scene) };
        let e = common::fails(&dir, &["render", path.to_str().unwrap(), "-o", out.to_str().unwrap(), flag, value]);
        assert!(e.contains(flag) && e.trim().lines().count() == 1, "{e}");
        assert!(!out.exists());
    }
}
