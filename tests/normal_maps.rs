//! glTF `normalTexture` (src/normal_map.rs, src/scene/tangents.rs) on small files written by
//! `tools/gltf/normal_map_assets.py` with pygltflib (not strahl's code): a Lambertian quad
//! (x, y in [-1, 1], z = 0, facing +z, tangent +x and bitangent +y) whose constant normal map
//! tilts its normal to `n` (from the texel), under a directional light of irradiance `E`, seen
//! from z = 4. The radiance read back from the EXR is the closed form `ρ/π·E·max(0, l·n)`
//! (`l` towards the light): one light, no other surface, so no noise at all.

mod common;

use std::path::{Path, PathBuf};

use common::{TempDir, channel, read_exr, strahl, text};

const ALBEDO: f64 = 0.5;
const TEXEL: [f64; 3] = [166.0, 191.0, 223.0];
const E: f64 = 2.0;
const SIZE: usize = 32;

/// The assets, written into `dir`; `None` (with a skip line) without pygltflib.
fn assets(dir: &TempDir) -> Option<PathBuf> {
    common::gltf_assets(dir, "normal_map_assets.py", "normal_maps")
}

/// The unit normal the texel encodes (tangent space = world space on this quad).
fn mapped() -> [f64; 3] {
    let n = TEXEL.map(|c| 2.0 * c / 255.0 - 1.0);
    let len = n.iter().map(|x| x * x).sum::<f64>().sqrt();
    n.map(|x| x / len)
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// `gltf` under a directional light coming from `towards_light` (unit), rendered by
/// `integrator` with the passes `passes`: the EXR's channels.
fn render(dir: &TempDir, gltf: &Path, towards_light: [f64; 3], integrator: &str) -> Vec<(String, Vec<f32>)> {
    let [x, y, z] = towards_light.map(|c| -c);
    let toml = format!(
        r#"
[camera]
eye = [0, 0, 4]
target = [0, 0, 0]
fov_deg = 40
[image]
width = {SIZE}
height = {SIZE}
spp = 1
max_depth = 2
background = [0, 0, 0]
[output]
passes = ["combined", "normal"]
[[lights]]
type = "directional"
direction = [{x}, {y}, {z}]
irradiance = {E}
[[objects]]
type = "gltf"
path = "{}"
"#,
        gltf.display()
    );
    let scene = dir.write("scene.toml", toml);
    let out = dir.path("out.exr");
    let run = strahl(&["render", scene.to_str().unwrap(), "-o", out.to_str().unwrap(), "--integrator", integrator]);
    assert!(run.status.success(), "{}", text(&run.stderr));
    assert!(!text(&run.stderr).contains("normalTexture"), "{}", text(&run.stderr));
    let (w, h, channels) = read_exr(&out);
    assert_eq!((w, h), (SIZE, SIZE));
    channels
}

/// The pixels of the image's central half, all on the quad.
fn centre() -> impl Iterator<Item = usize> {
    (SIZE / 4..3 * SIZE / 4).flat_map(|y| (SIZE / 4..3 * SIZE / 4).map(move |x| y * SIZE + x))
}

/// Asserts every central pixel's `pass` channels equal `want`.
fn assert_pixels(channels: &[(String, Vec<f32>)], pass: &str, names: [&str; 3], want: [f64; 3], what: &str) {
    for (c, name) in names.iter().enumerate() {
        let values = channel(channels, &format!("ViewLayer.{pass}.{name}"));
        for p in centre() {
            let got = values[p] as f64;
            assert!(
                (got - want[c]).abs() <= 1e-4 * want[c].abs().max(1e-2),
                "{what}: pixel {p} {pass}.{name}: {got} vs {}",
                want[c]
            );
        }
    }
}

fn lambert(cos: f64) -> [f64; 3] {
    [ALBEDO / std::f64::consts::PI * E * cos.max(0.0); 3]
}

const RGB: [&str; 3] = ["R", "G", "B"];

#[test]
fn a_constant_normal_map_tilts_the_lambert_cosine_by_its_angle() {
    // Light straight above: L = ρ/π·E·cos(tilt) = ρ/π·E·n_z (unmapped it would be ρ/π·E),
    // with TANGENT given and with MikkTSpace's tangents alike, for both integrators.
    let dir = TempDir::new("normal-maps-tilt");
    let Some(assets) = assets(&dir) else { return };
    let n = mapped();
    assert!((n[2] - 0.789).abs() < 1e-3, "the asset tilts by {:.1}°", n[2].acos().to_degrees());
    for file in ["tangent.gltf", "mikktspace.gltf"] {
        for integrator in ["path", "whitted"] {
            let channels = render(&dir, &assets.join(file), [0.0, 0.0, 1.0], integrator);
            assert_pixels(&channels, "Combined", RGB, lambert(n[2]), &format!("{file} {integrator}"));
        }
    }
}

#[test]
fn the_tilt_follows_the_tangent_and_the_bitangent_sign() {
    // Light from the mapped normal's own direction: L = ρ/π·E (cos 1) when T = +x and
    // B = +y; B = −y (TANGENT w = −1) mirrors the normal's y, giving cos = n_x² − n_y² + n_z².
    let dir = TempDir::new("normal-maps-direction");
    let Some(assets) = assets(&dir) else { return };
    let n = mapped();
    for file in ["tangent.gltf", "mikktspace.gltf"] {
        let channels = render(&dir, &assets.join(file), n, "path");
        assert_pixels(&channels, "Combined", RGB, lambert(1.0), file);
    }
    let channels = render(&dir, &assets.join("flipped.gltf"), n, "path");
    let mirrored = [n[0], -n[1], n[2]];
    assert_pixels(&channels, "Combined", RGB, lambert(dot(n, mirrored)), "flipped.gltf");
}

#[test]
fn tangent_given_and_mikktspace_render_the_same_image() {
    let dir = TempDir::new("normal-maps-same");
    let Some(assets) = assets(&dir) else { return };
    let light = [0.3f64, -0.4, 0.866];
    let len = dot(light, light).sqrt();
    let light = light.map(|c| c / len);
    let a = render(&dir, &assets.join("tangent.gltf"), light, "path");
    let b = render(&dir, &assets.join("mikktspace.gltf"), light, "path");
    for c in RGB {
        let name = format!("ViewLayer.Combined.{c}");
        let (a, b) = (channel(&a, &name), channel(&b, &name));
        let worst = a.iter().zip(b).map(|(x, y)| (x - y).abs()).fold(0.0f32, f32::max);
        assert!(worst <= 1e-6, "{name}: differ by up to {worst}");
    }
}

#[test]
fn scale_zero_leaves_the_normal_unperturbed() {
    let dir = TempDir::new("normal-maps-scale0");
    let Some(assets) = assets(&dir) else { return };
    let n = mapped();
    let channels = render(&dir, &assets.join("scale0.gltf"), n, "path");
    assert_pixels(&channels, "Combined", RGB, lambert(n[2]), "scale0.gltf");
    assert_pixels(&channels, "Normal", ["X", "Y", "Z"], [0.0, 0.0, 1.0], "scale0.gltf");
}

#[test]
fn the_normal_pass_shows_the_mapped_normal() {
    // As Cycles' Normal pass does: the shading normal after normal mapping, in world space.
    let dir = TempDir::new("normal-maps-pass");
    let Some(assets) = assets(&dir) else { return };
    let channels = render(&dir, &assets.join("mikktspace.gltf"), [0.0, 0.0, 1.0], "path");
    assert_pixels(&channels, "Normal", ["X", "Y", "Z"], mapped(), "mikktspace.gltf");
}
