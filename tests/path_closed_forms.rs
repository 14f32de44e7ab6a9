//! The path tracer against closed forms: every estimate within 3 standard errors of the exact
//! value (the noise measured from the image itself), so a wrong MIS weight, density or
//! throughput fails.
//!
//! - A closed Lambertian enclosure of albedo ρ whose surface emits `L_e`: radiance is the same
//!   everywhere, `L = L_e + ρ·L`, so after `d` bounces `L_e·(1 − ρ^(d+1))/(1 − ρ)`; both with the
//!   walls sampled as a light (NEE + BSDF sampling, MIS) and found by BSDF sampling alone.
//! - A quad light over a diffuse plane, at max depth 1: `L = ρ·L_light·F`, F the form factor of
//!   the rectangle to a parallel point, and the same as the Whitted integrator's estimate.
//! - A quad light seen through a mirror (`k_r·L` exactly) and through a glass sphere on its
//!   axis (`L·(1 − R)/(1 + R)`, `R = ((η − 1)/(η + 1))²`, the sum over the internal
//!   reflections at normal incidence).

mod common;

use std::path::Path;

use strahl::scene::{IntegratorKind, Scene};

fn scene(toml: &str) -> Scene {
    strahl::scene::load::file::from_toml_str(toml, Path::new("closed-form.toml")).unwrap().scene
}

fn red(scene: &Scene) -> Vec<f64> {
    let (film, _) = common::render(scene);
    film.rgba.iter().map(|p| p[0] as f64).collect()
}

/// A closed cube of side 2 around the camera, albedo `rho`, emitting 1 (both sides, as
/// emissive meshes do).
fn enclosure(rho: f64, depth: u32, mesh_lights: bool) -> Scene {
    scene(&format!(
        r#"
[render]
integrator = "path"
[camera]
eye = [0.1, 0.2, 0.3]
target = [0.5, -0.3, -1]
fov_deg = 100
[image]
width = 16
height = 16
spp = 64
max_depth = {depth}
mesh_lights = {mesh_lights}
[materials.wall]
diffuse = [{rho}, {rho}, {rho}]
emission = [1, 1, 1]
[[objects]]
type = "triangles"
positions = [[-1,-1,-1],[1,-1,-1],[1,1,-1],[-1,1,-1],[-1,-1,1],[1,-1,1],[1,1,1],[-1,1,1]]
indices = [[0,1,2],[0,2,3],[4,6,5],[4,7,6],[0,4,5],[0,5,1],[3,2,6],[3,6,7],[0,3,7],[0,7,4],[1,5,6],[1,6,2]]
material = "wall"
"#
    ))
}

#[test]
fn a_closed_emitting_lambertian_enclosure_has_the_radiance_of_the_geometric_series() {
    for (rho, depth, mesh_lights) in [(0.5, 1, true), (0.5, 2, true), (0.6, 6, true), (0.5, 2, false), (0.3, 5, false)]
    {
        let want = (1.0 - f64::powi(rho, depth as i32 + 1)) / (1.0 - rho);
        let (mean, se) = common::mean_and_error(&red(&enclosure(rho, depth, mesh_lights)));
        eprintln!("ρ {rho} depth {depth} NEE {mesh_lights}: {mean} ± {se} (exact {want})");
        assert!(
            (mean - want).abs() <= 3.0 * se + 1e-6,
            "ρ {rho} depth {depth} NEE {mesh_lights}: {mean} ± {se} vs {want}"
        );
        assert!(se < 0.02 * want, "the test is too noisy to tell: ± {se}");
    }
    // Depth 0: the walls' emission only, exactly.
    assert!(red(&enclosure(0.5, 0, true)).iter().all(|&v| v == 1.0));
}

#[test]
fn the_clamp_limits_indirect_light_only() {
    // With every contribution that scattered twice or more clamped to 1e-3 (at most two such
    // per sample at depth 2: NEE at the second vertex, emission found at the third), what is
    // left is the direct light, L_e·(1 + ρ), unbiased, plus at most 0.002.
    let mut scene = enclosure(0.5, 2, true);
    scene.render.clamp = Some(1e-3);
    let (mean, se) = common::mean_and_error(&red(&scene));
    eprintln!("clamped: {mean} ± {se} (direct light 1.5, unclamped 1.75)");
    assert!(mean >= 1.5 - 3.0 * se && mean <= 1.502 + 3.0 * se, "{mean} ± {se}");
}

fn lit_plane(integrator: &str, light_samples: u32, spp: u32) -> Scene {
    scene(&format!(
        r#"
[render]
integrator = "{integrator}"
[camera]
eye = [0.3, 0.5, 3]
target = [0.3, 0, 0.1]
fov_deg = 4
[image]
width = 12
height = 12
spp = {spp}
max_depth = 1
[materials.floor]
diffuse = [0.8, 0.8, 0.8]
[[lights]]
type = "quad"
corner = [-0.5, 1, -0.5]
edge1 = [1, 0, 0]
edge2 = [0, 0, 1]
radiance = [5, 5, 5]
light_samples = {light_samples}
[[objects]]
type = "plane"
normal = [0, 1, 0]
distance = 0
material = "floor"
"#
    ))
}

/// A render's red channel against a closed form, pixel by pixel.
struct Residuals {
    /// The mean of (red − closed form) and its standard error.
    bias: f64,
    se: f64,
    /// The mean red.
    mean: f64,
    /// Each pixel's nearest hit (x, z), where the closed form was taken.
    hits: Vec<(f64, f64)>,
}

/// Renders `scene` with its position pass and takes every pixel's red against `want(x, z)` at
/// the pixel's nearest hit (the closed form varies by < 0.1 % over a pixel in these scenes).
fn residuals(scene: &Scene, want: impl Fn(f64, f64) -> f64) -> Residuals {
    let mut scene = scene.clone();
    scene.output.passes = strahl::output::passes::PassSet::parse(&["combined", "position"]).unwrap();
    let (film, _) = common::render(&scene);
    let position = &film.aovs.iter().find(|a| a.pass == strahl::output::passes::Pass::Position).unwrap().data;
    let hits: Vec<(f64, f64)> = position.chunks_exact(3).map(|p| (p[0] as f64, p[2] as f64)).collect();
    let diffs: Vec<f64> = film.rgba.iter().zip(&hits).map(|(p, &(x, z))| p[0] as f64 - want(x, z)).collect();
    let (bias, se) = common::mean_and_error(&diffs);
    let mean = film.rgba.iter().map(|p| p[0] as f64).sum::<f64>() / film.rgba.len() as f64;
    Residuals { bias, se, mean, hits }
}

#[test]
fn direct_light_of_a_quad_on_a_plane_is_the_form_factor_and_whitteds() {
    // Every pixel's expected value: ρ·L·F at its nearest hit point (F varies by < 0.1 % over
    // the pixel at this field of view).
    let path = lit_plane("path", 1, 64);
    assert_eq!(path.render.integrator, IntegratorKind::Path);
    let want = |x, z| 0.8 * 5.0 * common::form_factor(-0.5, 0.5, -0.5, 0.5, 1.0, x, z);
    let Residuals { bias, se, mean: mean_value, .. } = residuals(&path, want);
    eprintln!("path: mean {mean_value}, mean residual {bias} ± {se}");
    assert!(bias.abs() <= 3.0 * se + 1e-6 * mean_value, "path vs form factor: {bias} ± {se}");
    assert!(se < 0.01 * mean_value, "too noisy to tell: ± {se} of {mean_value}");
    // The Whitted integrator's estimate of the same (16 light samples per hit), pixel by
    // pixel: the mean of the differences within 3 of their standard errors.
    let whitted = red(&lit_plane("whitted", 16, 16));
    let diffs: Vec<f64> = red(&path).iter().zip(&whitted).map(|(p, w)| p - w).collect();
    let (d, d_se) = common::mean_and_error(&diffs);
    eprintln!("path − whitted: {d} ± {d_se}");
    assert!(d.abs() <= 3.0 * d_se, "path − whitted: {d} ± {d_se}");
    assert!(d_se < 0.01 * mean_value, "too noisy to tell: ± {d_se}");
}

fn through(object: &str) -> Scene {
    scene(&format!(
        r#"
[render]
integrator = "path"
[camera]
eye = [0, 0, 3]
target = [0, 0, 0]
fov_deg = 2
[image]
width = 8
height = 8
spp = 256
max_depth = 8
[materials.mirror]
mirror = [0.9, 0.9, 0.9]
[materials.glass]
transmission = [1, 1, 1]
ior = 1.5
[[lights]]
type = "quad"
corner = [-1, -1, -2]
edge1 = [2, 0, 0]
edge2 = [0, 2, 0]
radiance = [4, 2, 1]
{object}
"#
    ))
}

#[test]
fn a_quad_light_seen_through_a_mirror_and_a_glass_sphere() {
    // The light faces +z (edge1 × edge2 = x × y): seen directly it is L.
    let direct = common::render(&through("")).0;
    assert!(direct.rgba.iter().all(|p| p[..3] == [4.0, 2.0, 1.0]), "{:?}", direct.rgba[0]);
    // The camera looks at a mirror plane tilted 45° that shows a light above it: k_r·L.
    let mirror = scene(
        r#"
[render]
integrator = "path"
[camera]
eye = [0, 0, 3]
target = [0, 0, 0]
fov_deg = 2
[image]
width = 8
height = 8
spp = 4
max_depth = 8
[materials.mirror]
mirror = [0.9, 0.9, 0.9]
[[lights]]
type = "quad"
corner = [-1, 2, -1]
edge1 = [2, 0, 0]
edge2 = [0, 0, 2]
radiance = [4, 2, 1]
[[objects]]
type = "plane"
normal = [0, 1, 1]
distance = 0
material = "mirror"
"#,
    );
    // edge1 × edge2 = x × z = −y: the light faces down, where the mirror sends the camera's
    // rays (−z reflected about (0, 1, 1)/√2 is +y).
    let film = common::render(&mirror).0;
    for p in &film.rgba {
        for (c, want) in p[..3].iter().zip([3.6f32, 1.8, 0.9]) {
            assert!((c - want).abs() < 1e-5, "mirror: {:?}", &p[..3]);
        }
    }
    // Through a glass sphere of radius 0.5 at the origin, on its axis: (1 − R)/(1 + R) of L,
    // within the noise of the discrete choices between reflection and refraction.
    let glass = through("[[objects]]\ntype = \"sphere\"\ncenter = [0, 0, 0]\nradius = 0.5\nmaterial = \"glass\"");
    let film = common::render(&glass).0;
    let r = (0.5f64 / 2.5).powi(2);
    let factor = (1.0 - r) / (1.0 + r);
    let values: Vec<f64> = film.rgba.iter().map(|p| p[0] as f64).collect();
    assert!(film.rgba.iter().all(|p| p.iter().all(|c| c.is_finite())));
    let (mean, se) = common::mean_and_error(&values);
    eprintln!("glass: {mean} ± {se}, on the axis {}", 4.0 * factor);
    // The pixels are not all on the axis: at 2° the outermost ray meets the sphere at
    // 3·tan(1°)/0.5 = 0.1 of its radius, where the transmission differs by < 0.1 %.
    assert!((mean - 4.0 * factor).abs() <= 3.0 * se + 0.002 * 4.0, "glass: {mean} ± {se} vs {}", 4.0 * factor);
    assert!(mean > 3.0, "the light shows through the glass: {mean}");
}

/// A glass sphere (PBR transmission 1, IOR 1.5) of radius 1 that absorbs (`KHR_materials_volume`:
/// half the light left after a distance 1, σ_a = ln 2), seen head-on from afar in a uniform
/// environment of 1. Along the axis every path is specular: reflected at the front (R), or
/// refracted in and crossing the sphere (a = e^(−2σ_a) per crossing) any number of times
/// before it leaves, so the centre pixel is `R + (1 − R)²·a / (1 − R·a)`, R = 0.04 the Fresnel
/// reflectance at normal incidence. Without absorption (a = 1) it would be 1.
#[test]
fn an_absorbing_glass_sphere_transmits_the_beer_lambert_series() {
    let mut s = scene(
        "[render]\nintegrator = \"path\"\n\
         [camera]\neye = [0, 0, 20]\ntarget = [0, 0, 0]\nfov_deg = 0.3\n\
         [image]\nwidth = 3\nheight = 3\nspp = 4096\nmax_depth = 64\nbackground = 1\n\
         [materials.glass]\nbase_color = 1\nmetallic = 0\nroughness = 0\ntransmission = 1\nior = 1.5\n\
         [[objects]]\ntype = \"sphere\"\ncenter = [0, 0, 0]\nradius = 1\nmaterial = \"glass\"\n",
    );
    let pbr = s.materials[0].pbr.as_mut().expect("a PBR material");
    (pbr.thickness, pbr.attenuation_color, pbr.attenuation_distance) = (1.0, strahl::Vec3::splat(0.5), 1.0);
    let (film, _) = common::render(&s);
    let centre = film.rgba[film.index(1, 1)];
    let (r, a) = (0.04f64, 0.25f64);
    let want = r + (1.0 - r).powi(2) * a / (1.0 - r * a);
    for (c, &got) in centre[..3].iter().enumerate() {
        assert!((got as f64 - want).abs() < 0.01 * want, "channel {c}: {got} vs {want:.5}");
    }
}

/// A floor (ρ = 0.8) under a 1 × 1 emissive quad at height 1 whose emission texture is white
/// on its −x half and black on its +x half (64 × 4 texels, bilinear, repeating), emission 5;
/// the quad is an OBJ with texture coordinates, facing down by its winding (`flip`: up).
fn textured_lamp(dir: &common::TempDir, flip: bool) -> Scene {
    let png = image::RgbImage::from_fn(64, 4, |i, _| image::Rgb(if i < 32 { [255; 3] } else { [0; 3] }));
    png.save(dir.path("half.png")).unwrap();
    let faces = if flip { "f 1/1 4/4 3/3 2/2" } else { "f 1/1 2/2 3/3 4/4" };
    let obj =
        format!("v -0.5 1 -0.5\nv 0.5 1 -0.5\nv 0.5 1 0.5\nv -0.5 1 0.5\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n{faces}\n");
    dir.write("lamp.obj", obj.as_bytes());
    let toml = r#"
[render]
integrator = "path"
[camera]
eye = [0.3, 0.5, 3]
target = [0.3, 0, 0.1]
fov_deg = 4
[image]
width = 12
height = 12
spp = 64
max_depth = 1
[materials.floor]
diffuse = [0.8, 0.8, 0.8]
[materials.lamp]
emission = [5, 5, 5]
emission_texture = "half.png"
[[objects]]
type = "plane"
normal = [0, 1, 0]
distance = 0
material = "floor"
[[objects]]
type = "mesh"
path = "lamp.obj"
material = "lamp"
"#;
    strahl::scene::load::file::from_toml_str(toml, &dir.path("lamp.toml")).unwrap().scene
}

/// The texture's value at `u` (bilinear between texel centres, repeating), as
/// `strahl::texture` filters it.
fn half_white(u: f64) -> f64 {
    let x = u * 64.0 - 0.5;
    let i = x.floor();
    let f = x - i;
    let white = |i: f64| if (i.rem_euclid(64.0)) < 32.0 { 1.0 } else { 0.0 };
    (1.0 - f) * white(i) + f * white(i + 1.0)
}

#[test]
fn light_sampling_of_a_textured_emitter_sees_the_texture_and_one_sided_emitters_light_one_side() {
    let dir = common::TempDir::new("textured-lamp");
    let scene = textured_lamp(&dir, false);
    // ρ·5·Σ L(u_k)·F_k over 256 strips of the quad across x (u = x + 0.5); the texture's
    // kinks lie on strip edges, so the midpoint rule is exact on its linear pieces.
    let strips = 256;
    let want_at = |x: f64, z: f64| {
        (0..strips)
            .map(|k| {
                let (x0, x1) = (-0.5 + k as f64 / strips as f64, -0.5 + (k + 1) as f64 / strips as f64);
                half_white(0.5 * (x0 + x1) + 0.5) * common::form_factor(x0, x1, -0.5, 0.5, 1.0, x, z)
            })
            .sum::<f64>()
            * 0.8
            * 5.0
    };
    let Residuals { bias, se, mean: mean_value, hits } = residuals(&scene, want_at);
    let n = hits.len() as f64;
    let mean_texel =
        hits.iter().map(|&(x, z)| 0.8 * 2.5 * common::form_factor(-0.5, 0.5, -0.5, 0.5, 1.0, x, z) / n).sum::<f64>();
    eprintln!("textured lamp: mean {mean_value} (the mean texel would give {mean_texel}), residual {bias} ± {se}");
    assert!(bias.abs() <= 3.0 * se + 1e-6 * mean_value, "textured emitter vs the form factors: {bias} ± {se}");
    assert!(se < 0.01 * mean_value && (mean_texel - mean_value) > 0.2 * mean_value, "cannot tell: ± {se}");

    // One-sided: facing the floor it lights it as before; turned away, not at all (neither
    // light sampling nor BSDF sampling may find its back).
    for flip in [false, true] {
        let mut scene = textured_lamp(&dir, flip);
        let lamp = scene.materials.iter().position(|m| m.name.ends_with("lamp")).unwrap();
        scene.materials[lamp].emission_one_sided = true;
        let values = red(&scene);
        let mean = values.iter().sum::<f64>() / values.len() as f64;
        if flip {
            assert!(values.iter().all(|&v| v == 0.0), "the back of a one-sided emitter lights the floor: {mean}");
        } else {
            assert!(
                (mean - mean_value).abs() < 0.05 * mean_value,
                "one-sided, facing the floor: {mean} vs {mean_value}"
            );
        }
    }
}
