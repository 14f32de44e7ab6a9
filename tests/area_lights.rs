//! Area lights against closed forms, rendered through the whole integrator: the irradiance on
//! the axis of a disk light, a fully visible sphere light, exact umbra and exact full light
//! around a penumbra, the emitter seen by the camera, determinism on both backends, and the
//! scene file's refusals.
//!
//! A diffuse receiver of albedo 1 reflects `E/π`, so a pixel that sees it holds `E/π`; with a
//! field of view of 0.01° every pixel sees (within 1e-4 m) the same receiver point, and each
//! pixel is an independent estimate (its light points are seeded from its index).

mod common;

use std::f64::consts::PI;
use std::path::Path;

use strahl::accel::bvh::Bvh;
use strahl::camera::Camera;
use strahl::integrator;
use strahl::output::film::Film;
use strahl::scene::{Scene, from_toml_str};

/// `text` as a scene for the Whitted integrator, whose area-light estimates these tests check.
fn scene(text: &str) -> Scene {
    let text = format!("[render]\nintegrator = \"whitted\"\n{text}");
    from_toml_str(&text, Path::new("area.toml")).unwrap_or_else(|e| panic!("{e}")).scene
}

/// A white diffuse floor (albedo 1) of 40 × 40 m at y = 0, and `rest` (camera, image, lights).
fn on_floor(rest: &str) -> String {
    format!(
        r#"{rest}
[materials.white]
diffuse = 1
[materials.black]
diffuse = 0
[[objects]]
type = "triangles"
positions = [[-20, 0, -20], [-20, 0, 20], [20, 0, 20], [20, 0, -20]]
indices = [[0, 1, 2], [0, 2, 3]]
material = "white"
"#
    )
}

/// A camera at height `y` above the origin looking straight down, `fov_deg` wide, `n × n`
/// pixels of `spp` samples, no ambient, black background.
fn looking_down(y: f64, fov_deg: f64, n: u32, spp: u32) -> String {
    format!(
        "[camera]\neye = [0, {y}, 0]\ntarget = [0, 0, 0]\nup = [0, 0, -1]\nfov_deg = {fov_deg}\n\
         [image]\nwidth = {n}\nheight = {n}\nspp = {spp}\nmax_depth = 0\n"
    )
}

/// `π·pixel` (the irradiance estimate) of every pixel's red channel.
fn irradiance_estimates(film: &Film) -> Vec<f64> {
    film.rgba.iter().map(|p| PI * p[0] as f64).collect()
}

fn mean_and_standard_error(v: &[f64]) -> (f64, f64) {
    let m = v.iter().sum::<f64>() / v.len() as f64;
    let var = v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (v.len() - 1) as f64;
    (m, (var / v.len() as f64).sqrt())
}

fn rms_error(v: &[f64], exact: f64) -> f64 {
    (v.iter().map(|x| (x - exact).powi(2)).sum::<f64>() / v.len() as f64).sqrt()
}

#[test]
fn disk_light_on_its_axis_converges_to_pi_l_r2_over_h2_plus_r2() {
    let (l, r, h) = (3.0, 0.5, 2.0);
    let exact = PI * l * r * r / (h * h + r * r);
    let mut rms = Vec::new();
    for samples in [1, 16, 256] {
        let light = format!(
            "[[lights]]\ntype = \"disk\"\ncenter = [0, {h}, 0]\nnormal = [0, -1, 0]\nradius = {r}\n\
             radiance = {l}\nlight_samples = {samples}\n"
        );
        let s = scene(&on_floor(&format!("{}{light}", looking_down(1.0, 0.01, 32, 1))));
        let (film, counts) = common::render(&s);
        assert_eq!(counts.shadow, 32 * 32 * samples);
        let e = irradiance_estimates(&film);
        let (mean, se) = mean_and_standard_error(&e);
        assert!((mean - exact).abs() <= 3.0 * se, "{samples} samples: {mean} vs {exact} ± {se}");
        rms.push(rms_error(&e, exact));
    }
    // The error falls at least as 1/√N (16× the samples: a quarter of the error, or less:
    // the light points are stratified).
    assert!(rms[1] <= 0.3 * rms[0] && rms[2] <= 0.3 * rms[1], "rms errors {rms:?}");
}

#[test]
fn a_fully_visible_sphere_light_gives_pi_l_r2_over_d2_cos_theta() {
    let (l, r, c) = (2.0, 0.4, [1.5, 3.0, 0.0]);
    let d: f64 = c[0] * c[0] + c[1] * c[1] + c[2] * c[2];
    let cos = c[1] / d.sqrt();
    let exact = PI * l * r * r / d * cos;
    let light = format!(
        "[[lights]]\ntype = \"sphere\"\ncenter = [{}, {}, {}]\nradius = {r}\nradiance = {l}\nlight_samples = 4\n",
        c[0], c[1], c[2]
    );
    let s = scene(&on_floor(&format!("{}{light}", looking_down(0.5, 0.01, 32, 4))));
    let e = irradiance_estimates(&common::render(&s).0);
    let (mean, se) = mean_and_standard_error(&e);
    assert!((mean - exact).abs() <= 3.0 * se, "{mean} vs {exact} ± {se}");
    assert!(se < 1e-3 * exact, "the cone sampling is nearly noiseless here: {se}");
}

/// Where the centre ray of pixel `(x, y)` meets the floor, unless it misses it or the blocker
/// (the square |x|, |z| ≤ 0.5 at height 1) is in the way.
fn floor_point(camera: &Camera, x: u32, y: u32) -> Option<(f64, f64)> {
    let ray = camera.centre_ray(x, y);
    let (o, d) = (ray.org.as_dvec3(), ray.dir.as_dvec3());
    let at = |h: f64| o + d * ((h - o.y) / d.y);
    let b = at(1.0);
    // (With a margin: the pixel's samples spread around its centre ray.)
    if b.x.abs() <= 0.7 && b.z.abs() <= 0.7 {
        return None;
    }
    let p = at(0.0);
    (d.y < 0.0 && p.x.abs() < 19.0 && p.z.abs() < 19.0).then_some((p.x, p.z))
}

#[test]
fn umbra_is_exactly_black_and_full_light_exactly_unoccluded() {
    // A disk light of radius 0.5 at height 2 and a 1 × 1 m blocker at height 1 centred under
    // it: floor points with |x|, |z| ≤ 0.5 see none of the light (umbra), points with |x| or
    // |z| > 1.5 see all of it (the segment to any light point passes the blocker's plane more
    // than 0.25 m from the disk's shadow centre).
    // Seen obliquely, so that the floor under the blocker is in view.
    let view = "[camera]\neye = [3, 1.8, 0]\ntarget = [0, 0, 0]\nfov_deg = 90\n\
                [image]\nwidth = 64\nheight = 64\nspp = 2\nmax_depth = 0\n";
    let light = "[[lights]]\ntype = \"disk\"\ncenter = [0, 2, 0]\nnormal = [0, -1, 0]\nradius = 0.5\n\
                 radiance = 5\nlight_samples = 8\n";
    let blocker = "[[objects]]\ntype = \"triangles\"\n\
                   positions = [[-0.5, 1, -0.5], [-0.5, 1, 0.5], [0.5, 1, 0.5], [0.5, 1, -0.5]]\n\
                   indices = [[0, 1, 2], [0, 2, 3]]\nmaterial = \"black\"\n";
    let open = scene(&on_floor(&format!("{view}{light}")));
    let blocked = scene(&on_floor(&format!("{view}{light}{blocker}")));
    let (a, _) = common::render(&open);
    let (b, _) = common::render(&blocked);
    let camera = Camera::new(&open.camera, 64, 64).unwrap();
    let (mut umbra, mut lit, mut penumbra) = (0, 0, 0);
    for y in 0..64 {
        for x in 0..64 {
            // The two samples of a pixel lie within half a pixel of its centre: up to 0.2 m on the
            // floor, seen at a grazing angle; the margins are wider.
            let Some((px, pz)) = floor_point(&camera, x, y) else { continue };
            let i = a.index(x, y);
            if px.abs() <= 0.3 && pz.abs() <= 0.3 {
                assert_eq!(b.rgba[i][..3], [0.0; 3], "umbra pixel ({x}, {y}) at ({px}, {pz})");
                umbra += 1;
            } else if px.abs() > 2.0 || pz.abs() > 2.0 {
                assert_eq!(b.rgba[i], a.rgba[i], "fully lit pixel ({x}, {y}) at ({px}, {pz})");
                assert!(a.rgba[i][0] > 0.0);
                lit += 1;
            } else if b.rgba[i][0] > 0.0 && b.rgba[i][0] < a.rgba[i][0] {
                penumbra += 1;
            }
        }
    }
    assert!(umbra > 0 && lit > 1000 && penumbra > 100, "umbra {umbra}, lit {lit}, penumbra {penumbra}");
}

#[test]
fn emitters_are_seen_with_their_radiance_from_the_front_only_unless_two_sided() {
    for (two_sided, eye_y, expected) in [(false, 0.0, 1.0), (false, 4.0, 0.0), (true, 4.0, 1.0)] {
        let text = format!(
            "[camera]\neye = [0, {eye_y}, 0]\ntarget = [0, 2, 0]\nup = [0, 0, -1]\nfov_deg = 1\n\
             [image]\nwidth = 4\nheight = 4\n\
             [[lights]]\ntype = \"quad\"\ncorner = [-1, 2, -1]\nedge1 = [2, 0, 0]\nedge2 = [0, 0, 2]\n\
             radiance = [3, 2, 1]\ntwo_sided = {two_sided}\n"
        );
        let (film, _) = common::render(&scene(&text));
        for p in &film.rgba {
            assert_eq!(p[..3], [3.0 * expected, 2.0 * expected, expected], "two_sided {two_sided}, eye y {eye_y}");
        }
    }
}

#[test]
fn same_bits_on_any_thread_count_on_both_backends() {
    let text = on_floor(&format!(
        "{}[[lights]]\ntype = \"sphere\"\ncenter = [0.3, 1.2, 0]\nradius = 0.2\nradiance = 4\nlight_samples = 3\n\
         [[objects]]\ntype = \"sphere\"\ncenter = [0, 0.3, 0]\nradius = 0.3\nmaterial = \"white\"\n",
        looking_down(2.5, 60.0, 40, 5)
    ));
    let s = scene(&text);
    let pool = |n| rayon::ThreadPoolBuilder::new().num_threads(n).build().unwrap();
    let embree = common::accel(&s);
    let bvh = Bvh::build(&s).unwrap();
    let e1 = pool(1).install(|| integrator::render(&s, &embree, &|_| {}).unwrap().0);
    let e3 = pool(3).install(|| integrator::render(&s, &embree, &|_| {}).unwrap().0);
    let n1 = pool(1).install(|| integrator::render(&s, &bvh, &|_| {}).unwrap().0);
    let n3 = pool(3).install(|| integrator::render(&s, &bvh, &|_| {}).unwrap().0);
    assert!(common::same_bits(&e1, &e3) && common::same_bits(&n1, &n3));
    // The backends trace the same light points: their images agree but for the last bits.
    let worst = e1.rgba.iter().zip(&n1.rgba).map(|(a, b)| (a[0] - b[0]).abs()).fold(0.0f32, f32::max);
    assert!(worst < 1e-3, "Embree vs native: {worst}");
}

#[test]
fn bad_area_lights_are_refused_at_their_line() {
    let base = "[camera]\neye = [0, 0, 5]\ntarget = [0, 0, 0]\nfov_deg = 40\n[[lights]]\n";
    for (light, expected) in [
        (
            "type = \"quad\"\ncorner = [0, 0, 0]\nedge1 = [1, 0, 0]\nedge2 = [0, 1, 0]\nradius = 1\nradiance = 1\n",
            "10:10: light 0: a quad light has no `radius`",
        ),
        ("type = \"disk\"\ncenter = [0, 0, 0]\nnormal = [0, 1, 0]\nradius = 0\nradiance = 1\n", "radius 0 must be > 0"),
        ("type = \"sphere\"\ncenter = [0, 0, 0]\nradius = 1\n", "missing `radiance`"),
        ("type = \"sphere\"\ncenter = [0, 0, 0]\nradius = 1\nradiance = 1\nlight_samples = 0\n", "light_samples 0"),
        ("type = \"quad\"\ncorner = [0, 0, 0]\nedge1 = [1, 0, 0]\nedge2 = [2, 0, 0]\nradiance = 1\n", "span no area"),
        ("type = \"point\"\nposition = [0, 0, 0]\nintensity = 1\nradiance = 1\n", "a point light has no `radiance`"),
    ] {
        let e = from_toml_str(&format!("{base}{light}"), Path::new("bad.toml")).expect_err(light).to_string();
        assert!(e.starts_with("bad.toml:") && e.contains(expected) && !e.contains('\n'), "{e}");
    }
}

#[test]
fn an_emissive_mesh_lights_like_the_quad_light_of_the_same_square() {
    // A 1 × 1 m square at height 2 above the receiver point, radiance 3: as an emissive mesh
    // (two-sided, one sample per shading point) and as a two-sided quad light. Each quadrant
    // of it (a = b = 1/2, height c = 2) has the form factor
    // F = (a/√(a²+c²)·atan(b/√(a²+c²)) + b/√(b²+c²)·atan(a/√(b²+c²)))/2π, and E = π·L·4F.
    let (l, a, c): (f64, f64, f64) = (3.0, 0.5, 2.0);
    let k = a / (a * a + c * c).sqrt();
    let exact = PI * l * 4.0 * (2.0 * k * k.atan()) / (2.0 * PI);
    let square = "positions = [[-0.5, 2, -0.5], [0.5, 2, -0.5], [0.5, 2, 0.5], [-0.5, 2, 0.5]]\n\
                  indices = [[0, 1, 2], [0, 2, 3]]\n";
    let mesh =
        format!("[materials.glow]\nemission = {l}\n[[objects]]\ntype = \"triangles\"\n{square}material = \"glow\"\n");
    let quad = format!(
        "[[lights]]\ntype = \"quad\"\ncorner = [-0.5, 2, -0.5]\nedge1 = [1, 0, 0]\nedge2 = [0, 0, 1]\n\
         radiance = {l}\ntwo_sided = true\n"
    );
    let view = looking_down(1.0, 0.01, 32, 4);
    let sixteen = format!("mesh_light_samples = 16\n{mesh}");
    let mut errors = Vec::new();
    for (what, rest) in [("mesh", &mesh), ("quad", &quad), ("mesh, 16 light samples", &sixteen)] {
        let e = irradiance_estimates(&common::render(&scene(&on_floor(&format!("{view}{rest}")))).0);
        let (mean, se) = mean_and_standard_error(&e);
        assert!((mean - exact).abs() <= 3.0 * se, "{what}: {mean} vs {exact} ± {se}");
        errors.push(rms_error(&e, exact));
    }
    // 16 stratified samples per shading point instead of 1: at least 4× (1/√16) less error.
    assert!(errors[2] <= 0.25 * errors[0], "rms error 1 sample {} vs 16 samples {}", errors[0], errors[2]);
    let bad = on_floor(&format!("{view}mesh_light_samples = 0\n{mesh}"));
    let e = from_toml_str(&bad, Path::new("bad.toml")).expect_err("0 samples").to_string();
    assert!(e.starts_with("bad.toml:") && e.contains("mesh_light_samples 0 must lie in 1..=4096"), "{e}");
    // With `mesh_lights = false` the square glows but lights nothing.
    let off = on_floor(&format!("{}mesh_lights = false\n{mesh}", view));
    assert!(common::render(&scene(&off)).0.rgba.iter().all(|p| p[..3] == [0.0; 3]));
}
