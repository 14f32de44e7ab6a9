//! The `strahl render` command end to end: the EXR it writes (channel names, values, the
//! analytic depth of every pixel), the PNG preview, identical bytes on any thread count, and
//! bad input refused with one line on stderr, exit status 1 and no output file.

mod common;

use std::path::{Path, PathBuf};
use std::process::Output;

use common::{TempDir, channel, fails, read_exr, strahl, text, triangle_hit};
use glam::DVec3;
use strahl::material::Texture;
use strahl::scene::Scene;

/// The default passes in Blender's multilayer naming, as EXR sorts them.
const CHANNELS_SORTED: [&str; 11] = [
    "ViewLayer.Combined.A",
    "ViewLayer.Combined.B",
    "ViewLayer.Combined.G",
    "ViewLayer.Combined.R",
    "ViewLayer.Depth.Z",
    "ViewLayer.DiffCol.B",
    "ViewLayer.DiffCol.G",
    "ViewLayer.DiffCol.R",
    "ViewLayer.Normal.X",
    "ViewLayer.Normal.Y",
    "ViewLayer.Normal.Z",
];

fn scene_path(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes").join(name)
}

/// Renders `scene` small (`--spp 1`: one ray through each pixel centre) into `dir`.
fn render_small(scene: &Path, dir: &TempDir, threads: &str, w: u32, h: u32) -> (PathBuf, PathBuf, Output) {
    let (exr, png) = (dir.path(&format!("t{threads}.exr")), dir.path(&format!("t{threads}.png")));
    let out = strahl(&[
        "render",
        scene.to_str().unwrap(),
        "-o",
        exr.to_str().unwrap(),
        "--png",
        png.to_str().unwrap(),
        "--width",
        &w.to_string(),
        "--height",
        &h.to_string(),
        "--spp",
        "1",
        "--threads",
        threads,
        "--exposure",
        "0.5",
    ]);
    assert!(out.status.success(), "strahl failed: {}", text(&out.stderr));
    (exr, png, out)
}

#[test]
fn render_writes_the_documented_exr_channels_and_a_png() {
    let dir = TempDir::new("channels");
    let (exr, png, out) = render_small(&scene_path("whitted.toml"), &dir, "2", 64, 48);
    // The summary on stdout; on stderr only what is being written (renders this small end
    // before the first progress line).
    let stdout = text(&out.stdout);
    assert!(stdout.contains("whitted.toml: 64 × 48 pixels, 1 spp, max depth 8, 2 threads"), "{stdout}");
    assert!(stdout.contains("primary") && stdout.contains("shadow") && stdout.contains("refracted"), "{stdout}");
    assert!(stdout.contains("Mrays/s"), "{stdout}");
    let (exr_shown, png_shown) = (dir.path("t2.exr").display().to_string(), dir.path("t2.png").display().to_string());
    assert_eq!(text(&out.stderr), format!("writing {exr_shown} ...\nwriting {png_shown} ...\n"));
    assert!(stdout.contains(&format!("wrote {exr_shown} (")) && stdout.contains(" MB), "), "{stdout}");
    assert_eq!(dir.entries(), ["t2.exr", "t2.png"], "no temporary files left");

    let (w, h, channels) = read_exr(&exr);
    assert_eq!((w, h), (64, 48));
    let names: Vec<&str> = channels.iter().map(|(n, _)| n.as_str()).collect();
    assert_eq!(names, CHANNELS_SORTED);
    for (name, values) in &channels {
        assert_eq!(values.len(), 64 * 48);
        for (i, &v) in values.iter().enumerate() {
            if name == "ViewLayer.Depth.Z" {
                assert!(v == f32::INFINITY || (v.is_finite() && v > 0.0), "Z[{i}] = {v}");
            } else {
                assert!(v.is_finite(), "{name}[{i}] = {v}");
            }
        }
    }
    for (i, &a) in channel(&channels, "ViewLayer.Combined.A").iter().enumerate() {
        assert!((0.0..=1.0).contains(&a), "A[{i}] = {a}");
    }

    // The PNG is the EXR's radiance ×2^0.5, clipped and sRGB-encoded (reference in f64).
    let img = image::open(&png).unwrap().to_rgb8();
    assert_eq!(img.dimensions(), (64, 48));
    let srgb8 = |x: f32| -> i32 {
        let x = (x as f64 * 0.5f64.exp2()).clamp(0.0, 1.0);
        let e = if x <= 0.0031308 { 12.92 * x } else { 1.055 * x.powf(1.0 / 2.4) - 0.055 };
        (e * 255.0).round() as i32
    };
    let (r, g, b) = (
        channel(&channels, "ViewLayer.Combined.R"),
        channel(&channels, "ViewLayer.Combined.G"),
        channel(&channels, "ViewLayer.Combined.B"),
    );
    for (i, px) in img.pixels().enumerate() {
        let want = [srgb8(r[i]), srgb8(g[i]), srgb8(b[i])];
        for c in 0..3 {
            assert!((px.0[c] as i32 - want[c]).abs() <= 1, "pixel {i}: {:?} vs {want:?}", px.0);
        }
    }
}

#[test]
fn same_bytes_on_one_and_two_threads() {
    let dir = TempDir::new("threads");
    let scene = scene_path("whitted.toml");
    let (exr1, png1, _) = render_small(&scene, &dir, "1", 80, 60);
    let (exr2, png2, _) = render_small(&scene, &dir, "2", 80, 60);
    assert!(std::fs::read(&exr1).unwrap() == std::fs::read(&exr2).unwrap(), "EXR bytes differ");
    assert!(std::fs::read(&png1).unwrap() == std::fs::read(&png2).unwrap(), "PNG bytes differ");
}

/// The lecture's pinhole camera in f64: the unit direction through the centre of pixel (x, y).
fn primary_direction(scene: &Scene, x: usize, y: usize) -> (DVec3, DVec3) {
    let c = &scene.camera;
    let (e, z, up) = (c.eye.as_dvec3(), c.target.as_dvec3(), c.up.as_dvec3());
    let w = (e - z).normalize();
    let u = up.cross(w).normalize();
    let v = w.cross(u);
    let (width, height) = (scene.image.width as f64, scene.image.height as f64);
    let d = 1.0;
    let t = d * ((c.fov_deg as f64).to_radians() / 2.0).tan();
    let (b, r) = (-t, t * width / height);
    let l = -r;
    let su = l + (r - l) * (x as f64 + 0.5) / width;
    let sv = t + (b - t) * (y as f64 + 0.5) / height;
    let s = su * u + sv * v - d * w;
    (e, s.normalize())
}

/// What the primary ray through a pixel sees first, from the scene's planes, spheres and
/// triangles.
enum FirstHit {
    Nothing,
    Plane {
        t: f64,
        index: usize,
    },
    Sphere {
        t: f64,
        index: usize,
    },
    Triangle,
    /// Too close to a silhouette, an edge or the horizon for f32 and f64 to agree on it.
    Ambiguous,
}

fn triangles(scene: &Scene) -> Vec<[DVec3; 3]> {
    let mut all = Vec::new();
    for m in &scene.meshes {
        for i in 0..m.indices.len() {
            all.push(m.triangle(i).map(|p| p.as_dvec3()));
        }
    }
    all
}

fn first_hit(scene: &Scene, org: DVec3, dir: DVec3) -> FirstHit {
    let mut best = (f64::INFINITY, FirstHit::Nothing);
    for (i, p) in scene.planes.iter().enumerate() {
        let (n, d) = (p.normal.as_dvec3(), p.dist as f64);
        let denom = dir.dot(n);
        if denom.abs() < 0.05 {
            return FirstHit::Ambiguous; // grazing: t is ill-conditioned
        }
        let t = (d - org.dot(n)) / denom;
        if t > 0.0 && t < best.0 {
            best = (t, FirstHit::Plane { t, index: i });
        }
    }
    for (i, s) in scene.spheres.iter().enumerate() {
        let (c, r) = (s.center.as_dvec3(), s.radius as f64);
        let f = org - c;
        let b = dir.dot(f);
        let disc = b * b - (f.dot(f) - r * r);
        if disc.abs() < 1e-3 * r * r {
            return FirstHit::Ambiguous; // grazing the silhouette
        }
        if disc > 0.0 {
            let t = -b - disc.sqrt();
            if t > 0.0 && t < best.0 {
                best = (t, FirstHit::Sphere { t, index: i });
            }
        }
    }
    for tri in triangles(scene) {
        match triangle_hit(org, dir, tri, 1e-3) {
            Err(_) => return FirstHit::Ambiguous,
            Ok(Some(t)) if t < best.0 => best = (t, FirstHit::Triangle),
            Ok(_) => {}
        }
    }
    best.1
}

/// Whether the segment from `p` along unit `dir` up to `tmax` is blocked by a sphere or a
/// triangle: `None` when it passes too close to an outline to say.
fn blocked(scene: &Scene, p: DVec3, dir: DVec3, tmax: f64) -> Option<bool> {
    let mut hit = false;
    for s in &scene.spheres {
        let (c, r) = (s.center.as_dvec3(), s.radius as f64);
        let along = (c - p).dot(dir).clamp(0.0, tmax);
        let miss_by = (p + along * dir - c).length() - r;
        if miss_by.abs() < 1e-3 {
            return None;
        }
        hit |= miss_by < 0.0;
    }
    for tri in triangles(scene) {
        match triangle_hit(p, dir, tri, 1e-3) {
            Err(_) => return None,
            Ok(Some(t)) => hit |= t < tmax,
            Ok(None) => {}
        }
    }
    Some(hit)
}

#[test]
fn depth_normal_albedo_and_alpha_match_the_analytic_scene() {
    let dir = TempDir::new("analytic");
    let (w, h) = (64usize, 48usize);
    let path = scene_path("whitted.toml");
    let (exr, _, _) = render_small(&path, &dir, "2", w as u32, h as u32);
    let mut scene = strahl::scene::load(&path).unwrap().scene;
    (scene.image.width, scene.image.height) = (w as u32, h as u32);
    let (_, _, ch) = read_exr(&exr);
    let (z, a) = (channel(&ch, "ViewLayer.Depth.Z"), channel(&ch, "ViewLayer.Combined.A"));
    let n =
        [channel(&ch, "ViewLayer.Normal.X"), channel(&ch, "ViewLayer.Normal.Y"), channel(&ch, "ViewLayer.Normal.Z")];
    let albedo =
        [channel(&ch, "ViewLayer.DiffCol.R"), channel(&ch, "ViewLayer.DiffCol.G"), channel(&ch, "ViewLayer.DiffCol.B")];
    let rgb = [
        channel(&ch, "ViewLayer.Combined.R"),
        channel(&ch, "ViewLayer.Combined.G"),
        channel(&ch, "ViewLayer.Combined.B"),
    ];
    let (mut planes, mut spheres, mut misses) = (0, 0, 0);
    for y in 0..h {
        for x in 0..w {
            let i = y * w + x;
            let (org, dir) = primary_direction(&scene, x, y);
            let normal = DVec3::new(n[0][i] as f64, n[1][i] as f64, n[2][i] as f64);
            let alb = DVec3::new(albedo[0][i] as f64, albedo[1][i] as f64, albedo[2][i] as f64);
            match first_hit(&scene, org, dir) {
                FirstHit::Ambiguous | FirstHit::Triangle => {}
                FirstHit::Nothing => {
                    misses += 1;
                    assert_eq!(z[i], f32::INFINITY, "pixel ({x}, {y}) sees nothing");
                    assert_eq!(a[i], 1.0, "pixel ({x}, {y}): an opaque frame");
                    let bg = scene.image.background;
                    assert_eq!([rgb[0][i], rgb[1][i], rgb[2][i]], [bg.x, bg.y, bg.z], "pixel ({x}, {y})");
                }
                FirstHit::Plane { t, index } => {
                    planes += 1;
                    let want = common::axis_depth(&scene.camera, dir, t);
                    let rel = (z[i] as f64 - want).abs() / want;
                    assert!(rel <= 1e-5, "pixel ({x}, {y}): Z {} vs {want} (rel {rel:e})", z[i]);
                    assert_eq!(a[i], 1.0);
                    let plane = scene.planes[index];
                    assert!((normal - plane.normal.as_dvec3()).length() < 1e-6, "pixel ({x}, {y}): N {normal}");
                    // The checker colour at the hit point, away from the cell borders.
                    let p = org + t * dir;
                    let m = &scene.materials[plane.material as usize];
                    if let Texture::Checker { even, odd, size } = m.diffuse {
                        let q = p / size as f64;
                        let border = (q - q.round()).abs().min_element();
                        if border > 1e-3 {
                            let k = q.floor();
                            let parity = (k.x + k.y + k.z).rem_euclid(2.0);
                            let want = if parity == 0.0 { even } else { odd }.as_dvec3();
                            assert!((alb - want).length() < 1e-6, "pixel ({x}, {y}): albedo {alb} vs {want}");
                        }
                    }
                }
                FirstHit::Sphere { t, index } => {
                    spheres += 1;
                    let want = common::axis_depth(&scene.camera, dir, t);
                    let rel = (z[i] as f64 - want).abs() / want;
                    assert!(rel <= 1e-5, "pixel ({x}, {y}): Z {} vs {want} (rel {rel:e})", z[i]);
                    assert_eq!(a[i], 1.0);
                    let s = scene.spheres[index];
                    let outward = (org + t * dir - s.center.as_dvec3()) / s.radius as f64;
                    assert!((normal - outward).length() < 1e-4, "pixel ({x}, {y}): N {normal} vs {outward}");
                    let m = &scene.materials[s.material as usize];
                    if let Texture::Constant(c) = m.diffuse {
                        assert!((alb - c.as_dvec3()).length() < 1e-6, "pixel ({x}, {y}): albedo {alb}");
                    }
                }
            }
        }
    }
    // The test saw all three cases in quantity.
    assert!(planes > 500 && spheres > 300 && misses > 300, "planes {planes}, spheres {spheres}, misses {misses}");
}

#[test]
fn lit_floor_is_lambertian_under_a_point_and_a_directional_light() {
    // The lecture scene's floor is grey (ρ = 0.6) and matte: its radiance is
    // ρ/π · (I·cosθ/d² + E·cosθ') for each light it sees, plus ρ·ambient.
    let dir = TempDir::new("radiance");
    let (w, h) = (64usize, 48usize);
    let path = scene_path("lecture.toml");
    let (exr, _, _) = render_small(&path, &dir, "2", w as u32, h as u32);
    let mut scene = strahl::scene::load(&path).unwrap().scene;
    (scene.image.width, scene.image.height) = (w as u32, h as u32);
    let (_, _, ch) = read_exr(&exr);
    let rgb = [
        channel(&ch, "ViewLayer.Combined.R"),
        channel(&ch, "ViewLayer.Combined.G"),
        channel(&ch, "ViewLayer.Combined.B"),
    ];
    let (mut lit, mut shadowed) = (0, 0);
    for y in 0..h {
        for x in 0..w {
            let i = y * w + x;
            let (org, ray_dir) = primary_direction(&scene, x, y);
            let FirstHit::Plane { t, index } = first_hit(&scene, org, ray_dir) else { continue };
            let plane = scene.planes[index];
            let (p, n) = (org + t * ray_dir, plane.normal.as_dvec3());
            let m = &scene.materials[plane.material as usize];
            let Texture::Constant(albedo) = m.diffuse else { panic!("the floor is plain") };
            let rho = albedo.x as f64;
            let mut irradiance = 0.0;
            let mut ambiguous = false;
            let mut in_shadow = false;
            for light in &scene.lights {
                let (to_light, dist, e) = match *light {
                    strahl::light::Light::Point { position, intensity } => {
                        let d = position.as_dvec3() - p;
                        let dist = d.length();
                        (d / dist, dist, intensity.x as f64 / (dist * dist))
                    }
                    strahl::light::Light::Directional { direction, irradiance } => {
                        (-direction.as_dvec3().normalize(), f64::INFINITY, irradiance.x as f64)
                    }
                };
                match blocked(&scene, p, to_light, dist) {
                    None => ambiguous = true,
                    Some(true) => in_shadow = true,
                    Some(false) => irradiance += e * n.dot(to_light).max(0.0),
                }
            }
            if ambiguous {
                continue;
            }
            if in_shadow {
                shadowed += 1
            } else {
                lit += 1
            }
            let want = rho / std::f64::consts::PI * irradiance + rho * scene.image.ambient.x as f64;
            for (c, channel) in rgb.iter().enumerate() {
                let got = channel[i] as f64;
                assert!((got - want).abs() <= 1e-4 * want, "pixel ({x}, {y}) channel {c}: {got} vs {want}");
            }
        }
    }
    assert!(lit > 500 && shadowed > 20, "lit {lit}, shadowed {shadowed}");
}

// ----- bad input: one line on stderr, exit status 1, no output file -----

/// Writes a scene file: the Whitted scene with `from` replaced by `to`.
fn broken_scene(dir: &TempDir, name: &str, from: &str, to: &str) -> PathBuf {
    let good = std::fs::read_to_string(scene_path("whitted.toml")).unwrap();
    assert!(good.contains(from), "whitted.toml has no {from:?}");
    let path = dir.path(name);
    std::fs::write(&path, good.replacen(from, to, 1)).unwrap();
    path
}

/// The 1-based line of the first occurrence of `needle` in the Whitted scene.
fn whitted_line(needle: &str) -> usize {
    let good = std::fs::read_to_string(scene_path("whitted.toml")).unwrap();
    good.lines().position(|l| l.contains(needle)).unwrap() + 1
}

fn render_args<'a>(scene: &'a str, exr: &'a str) -> Vec<&'a str> {
    vec!["render", scene, "-o", exr, "--width", "16", "--height", "12"]
}

#[test]
fn missing_scene_file() {
    let dir = TempDir::new("missing-scene");
    let (scene, exr) = (dir.path("nope.toml"), dir.path("x.exr"));
    let e = fails(&dir, &render_args(scene.to_str().unwrap(), exr.to_str().unwrap()));
    assert!(e.starts_with(&format!("error: {}: cannot read the scene: ", scene.display())), "{e}");
    assert!(e.contains("No such file"), "{e}");
}

#[test]
fn toml_syntax_error_with_line_and_column() {
    let dir = TempDir::new("syntax");
    // A missing comma in an array.
    let scene = broken_scene(&dir, "bad.toml", "target = [-0.4, 0.6, 0.0]", "target = [-0.4, 0.6 0.0]");
    let exr = dir.path("x.exr");
    let e = fails(&dir, &render_args(scene.to_str().unwrap(), exr.to_str().unwrap()));
    let line = whitted_line("target = [-0.4, 0.6, 0.0]");
    let column = "target = [-0.4, ".len() + 1;
    assert!(e.starts_with(&format!("error: {}:{line}:{column}: ", scene.display())), "{e}");
}

#[test]
fn unknown_material() {
    let dir = TempDir::new("material");
    let scene = broken_scene(&dir, "bad.toml", "material = \"glass\"", "material = \"crystal\"");
    let exr = dir.path("x.exr");
    let e = fails(&dir, &render_args(scene.to_str().unwrap(), exr.to_str().unwrap()));
    let line = whitted_line("material = \"glass\"");
    assert!(e.starts_with(&format!("error: {}:{line}:12: ", scene.display())), "{e}");
    assert!(e.contains("object 'glass ball' (sphere): unknown material 'crystal' (known: checker, glass, mirror)"));
}

#[test]
fn width_zero() {
    let dir = TempDir::new("width");
    let scene = broken_scene(&dir, "bad.toml", "width = 640", "width = 0");
    let exr = dir.path("x.exr");
    let e = fails(&dir, &["render", scene.to_str().unwrap(), "-o", exr.to_str().unwrap()]);
    let line = whitted_line("width = 640");
    assert_eq!(e, format!("error: {}:{line}:9: image: width must be at least 1 pixel", scene.display()));
}

#[test]
fn up_parallel_to_the_view_direction() {
    let dir = TempDir::new("up");
    // The view direction (target − eye) is (−1, −0.8, −6); make `up` point along it.
    let scene = broken_scene(&dir, "bad.toml", "up = [0, 1, 0]", "up = [1, 0.8, 6]");
    let exr = dir.path("x.exr");
    let e = fails(&dir, &render_args(scene.to_str().unwrap(), exr.to_str().unwrap()));
    let line = whitted_line("up = [0, 1, 0]");
    assert!(e.starts_with(&format!("error: {}:{line}:6: camera: up [1, 0.8, 6] is parallel", scene.display())), "{e}");
}

#[test]
fn sphere_radius_not_positive() {
    let dir = TempDir::new("radius");
    let scene = broken_scene(&dir, "bad.toml", "radius = 0.9", "radius = -0.9");
    let exr = dir.path("x.exr");
    let e = fails(&dir, &render_args(scene.to_str().unwrap(), exr.to_str().unwrap()));
    let line = whitted_line("radius = 0.9");
    assert_eq!(
        e,
        format!("error: {}:{line}:10: object 'glass ball' (sphere): radius -0.9 must be > 0", scene.display())
    );
}

#[test]
fn output_directory_missing() {
    let dir = TempDir::new("outdir");
    let scene = scene_path("whitted.toml");
    let exr = dir.path("no/such/dir/x.exr");
    let e = fails(&dir, &render_args(scene.to_str().unwrap(), exr.to_str().unwrap()));
    assert_eq!(
        e,
        format!("error: {}: the directory {} does not exist", exr.display(), dir.path("no/such/dir").display())
    );
    // A missing PNG directory is found before rendering too: no EXR appears either.
    let exr = dir.path("x.exr");
    let png = dir.path("gone/x.png");
    let mut args = render_args(scene.to_str().unwrap(), exr.to_str().unwrap());
    args.extend(["--png", png.to_str().unwrap()]);
    let e = fails(&dir, &args);
    assert!(e.contains(&format!("the directory {} does not exist", dir.path("gone").display())), "{e}");
}

#[test]
fn output_must_be_exr() {
    let dir = TempDir::new("ext");
    let scene = scene_path("whitted.toml");
    let out = dir.path("x.png");
    let e = fails(&dir, &render_args(scene.to_str().unwrap(), out.to_str().unwrap()));
    assert!(e.contains("must have the extension .exr"), "{e}");
}

#[test]
fn malformed_command_lines_are_one_line_too() {
    let scene = scene_path("whitted.toml");
    for args in [
        vec!["render", scene.to_str().unwrap()],
        vec!["render", scene.to_str().unwrap(), "-o", "x.exr", "--width", "0"],
        vec!["render", scene.to_str().unwrap(), "-o", "x.exr", "--threads", "many"],
    ] {
        let out = strahl(&args);
        let stderr = text(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {stderr}");
        assert_eq!(stderr.lines().count(), 1, "{stderr:?}");
        assert!(stderr.starts_with("error: "), "{stderr:?}");
    }
    let out = strahl(&["render", scene.to_str().unwrap()]);
    assert!(text(&out.stderr).contains("--output"), "names the missing option");
    let out = strahl(&["--help"]);
    assert!(out.status.success() && text(&out.stdout).contains("render"));
}

#[test]
fn negative_numbers_are_refused_naming_their_option() {
    let scene = format!("{}/scenes/spheres.toml", env!("CARGO_MANIFEST_DIR"));
    for (option, value) in
        [("--width", "-1"), ("--height", "-7"), ("--spp", "-4"), ("--depth", "-2"), ("--threads", "-1")]
    {
        let out = common::strahl(&["render", &scene, "-o", "/nonexistent-dir/x.exr", option, value]);
        let stderr = common::text(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{option} {value}: {stderr}");
        assert!(stderr.starts_with(&format!("error: invalid value '{value}' for '{option} <")), "{stderr}");
        assert_eq!(stderr.lines().count(), 1, "{stderr}");
    }
}

#[test]
fn a_closed_standard_output_ends_the_command_quietly() {
    // `strahl info scenes/blob.toml | head -0`: the reader is gone before strahl prints.
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_strahl"))
        .args(["info", scene_path("blob.toml").to_str().unwrap()])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("strahl starts");
    drop(child.stdout.take());
    let out = child.wait_with_output().unwrap();
    // The status of a tool that SIGPIPE ended, and no report of a bug.
    assert_eq!(out.status.code(), Some(141), "{}", text(&out.stderr));
    assert!(out.stderr.is_empty(), "{}", text(&out.stderr));
}
