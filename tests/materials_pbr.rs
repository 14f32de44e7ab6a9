//! TOML's PBR materials (`base_color`, `metallic`, `roughness`, …) path-traced against closed
//! forms, and refused in one line when mixed with lecture keys.
//!
//! The furnace: a sphere under a uniform background of radiance 1, one scattering
//! (`max_depth = 1`, a convex object never sees itself), so every pixel on the sphere is the
//! BSDF's directional albedo `∫ f |cos θi| dωi` at its viewing angle:
//! - white (base colour 1), metallic 0, roughness 1: 1 at every angle (the specular layer's
//!   multiple scattering compensated, the diffuse base albedo-scaled beneath it);
//! - smooth (roughness 0) dielectric of base colour ρ: the mirror's Fresnel `F(μ)` plus the base
//!   beneath it, `ρ (1 − F(μ))`; at the sphere's centre (μ ≈ 1, `F = F₀ = 0.04`) `0.04 + 0.96 ρ`.

mod common;

use common::{TempDir, channel, fails, read_exr, strahl, text};

const SIZE: usize = 32;

/// Renders a sphere of radius 1 at the origin in `material` (TOML keys), seen from z = 4 with
/// a 35° field of view (the sphere fills most of the frame) under a white background.
fn furnace(dir: &TempDir, material: &str, spp: u32) -> Vec<(String, Vec<f32>)> {
    let toml = format!(
        r#"
[camera]
eye = [0, 0, 4]
target = [0, 0, 0]
fov_deg = 35
[image]
width = {SIZE}
height = {SIZE}
spp = {spp}
max_depth = 1
background = [1, 1, 1]
[render]
integrator = "path"
[materials.m]
{material}
[[objects]]
type = "sphere"
center = [0, 0, 0]
radius = 1
material = "m"
"#
    );
    let scene = dir.write("furnace.toml", toml);
    let out = dir.path("furnace.exr");
    let run = strahl(&["render", scene.to_str().unwrap(), "-o", out.to_str().unwrap(), "--integrator", "path"]);
    assert!(run.status.success(), "{}", text(&run.stderr));
    read_exr(&out).2
}

/// Pixels whose centre ray hits the sphere well inside its outline (the outline's pixels mix
/// in the background).
fn on_sphere() -> Vec<usize> {
    let t = (17.5f64).to_radians().tan();
    let mut v = Vec::new();
    for y in 0..SIZE {
        for x in 0..SIZE {
            let (sx, sy) =
                (((x as f64 + 0.5) / SIZE as f64 * 2.0 - 1.0) * t, (1.0 - (y as f64 + 0.5) / SIZE as f64 * 2.0) * t);
            // Distance of the ray (0,0,4) + s(sx, sy, −1) from the origin, over the radius.
            let d = 4.0 * (sx * sx + sy * sy).sqrt() / (1.0 + sx * sx + sy * sy).sqrt();
            if d < 0.95 {
                v.push(y * SIZE + x);
            }
        }
    }
    v
}

#[test]
fn a_white_rough_dielectric_reflects_all_it_receives() {
    let dir = TempDir::new("materials-furnace-white");
    let ch = furnace(&dir, "base_color = [1, 1, 1]\nmetallic = 0\nroughness = 1", 64);
    let pixels = on_sphere();
    assert!(pixels.len() > 300, "{}", pixels.len());
    for c in ["R", "G", "B"] {
        let v = channel(&ch, &format!("ViewLayer.Combined.{c}"));
        let mean = pixels.iter().map(|&i| v[i] as f64).sum::<f64>() / pixels.len() as f64;
        // The furnace figures of bsdf::gltf hold to 0.005 at every angle; the estimate's
        // standard error over ~500 pixels × 64 samples is far below that.
        assert!((mean - 1.0).abs() < 0.005, "{c}: mean {mean}");
    }
}

#[test]
fn a_smooth_dielectric_shows_fresnel_plus_the_base_beneath() {
    let dir = TempDir::new("materials-furnace-smooth");
    let rho = [0.5, 0.25, 0.75];
    let ch = furnace(&dir, "base_color = [0.5, 0.25, 0.75]\nmetallic = 0\nroughness = 0", 256);
    // The four pixels around the centre see the sphere within 1° of its normal.
    let centre = [
        (SIZE / 2 - 1) * SIZE + SIZE / 2 - 1,
        (SIZE / 2 - 1) * SIZE + SIZE / 2,
        (SIZE / 2) * SIZE + SIZE / 2 - 1,
        (SIZE / 2) * SIZE + SIZE / 2,
    ];
    for (k, c) in ["R", "G", "B"].iter().enumerate() {
        let v = channel(&ch, &format!("ViewLayer.Combined.{c}"));
        let mean = centre.iter().map(|&i| v[i] as f64).sum::<f64>() / 4.0;
        let want = 0.04 + 0.96 * rho[k];
        assert!((mean - want).abs() < 0.01, "{c}: {mean} vs {want}");
    }
}

#[test]
fn a_smooth_metal_reflects_its_base_colour_at_normal_incidence() {
    // Deterministic: one specular lobe, F(1) = F₀ = base colour.
    let dir = TempDir::new("materials-furnace-metal");
    let ch = furnace(&dir, "base_color = [0.9, 0.6, 0.3]\nmetallic = 1\nroughness = 0", 1);
    let i = (SIZE / 2) * SIZE + SIZE / 2;
    for (k, c) in ["R", "G", "B"].iter().enumerate() {
        let got = channel(&ch, &format!("ViewLayer.Combined.{c}"))[i] as f64;
        let want = [0.9, 0.6, 0.3][k];
        assert!((got - want).abs() < 1e-5, "{c}: {got} vs {want}");
    }
}

#[test]
fn lecture_and_pbr_keys_do_not_mix() {
    let dir = TempDir::new("materials-mix");
    let toml = "[camera]\neye = [0, 0, 4]\ntarget = [0, 0, 0]\nfov_deg = 35\n[materials.m]\nbase_color = [1, 1, 1]\nmirror = [1, 1, 1]\n";
    let scene = dir.write("mix.toml", toml);
    let out = dir.path("mix.exr");
    let e = fails(&dir, &["render", scene.to_str().unwrap(), "-o", out.to_str().unwrap(), "--integrator", "path"]);
    assert!(e.contains("mix.toml") && e.contains("`mirror` is a lecture material's key"), "{e}");
    let toml = "[camera]\neye = [0, 0, 4]\ntarget = [0, 0, 0]\nfov_deg = 35\n[materials.m]\nmetallic = 1.5\n";
    let scene = dir.write("range.toml", toml);
    let e = fails(&dir, &["render", scene.to_str().unwrap(), "-o", out.to_str().unwrap(), "--integrator", "path"]);
    assert!(e.contains("range.toml") && e.contains("metallic 1.5 must lie in [0, 1]"), "{e}");
}
