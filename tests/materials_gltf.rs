//! glTF materials as the path tracer shades them (`bsdf::gltf` through `strahl::shading`), on
//! small files written by `tools/gltf/materials_assets.py` with pygltflib (not strahl's code):
//! pixel values read back from the EXR against closed forms, and the extensions strahl does
//! not render named in its warnings.
//!
//! Every scene looks at the quad (x, y in [-1, 1], z = 0, facing +z) from z = 4 along −z with
//! a 40° vertical field of view; the quad's quadrants show the texture's quadrants.

mod common;

use std::path::{Path, PathBuf};

use common::{TempDir, channel, read_exr, strahl, text};
use strahl::texture::srgb_to_linear;

const QUADRANTS: [[u8; 3]; 4] = [[255, 0, 0], [0, 128, 0], [0, 0, 64], [200, 200, 200]];
const BASE: [f64; 3] = [0.9, 0.8, 0.7];
const VERTEX_COLOR: [f64; 3] = [1.0, 0.5, 0.25];
const EMISSIVE: [f64; 3] = [0.5, 1.0, 0.25];
const STRENGTH: f64 = 4.0;
const SIZE: u32 = 64;

/// The assets, written into `dir`; `None` (with a skip line) without pygltflib.
fn assets(dir: &TempDir) -> Option<PathBuf> {
    common::gltf_assets(dir, "materials_assets.py", "materials_gltf")
}

/// A TOML scene showing `gltf` with the given background, rendered by `integrator`; the
/// channels of its EXR and strahl's stderr.
fn render(dir: &TempDir, gltf: &Path, background: f32, integrator: &str) -> (Vec<(String, Vec<f32>)>, String) {
    let toml = format!(
        r#"
[camera]
eye = [0, 0, 4]
target = [0, 0, 0]
fov_deg = 40
[image]
width = {SIZE}
height = {SIZE}
spp = 4
max_depth = 3
background = [{background}, {background}, {background}]
[render]
integrator = "{integrator}"
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
    let (w, h, channels) = read_exr(&out);
    assert_eq!((w, h), (SIZE as usize, SIZE as usize));
    (channels, text(&run.stderr))
}

/// The pixel that sees the quad's point (x, y, 0).
fn pixel_of(x: f64, y: f64) -> usize {
    let half = 4.0 * 20f64.to_radians().tan();
    let n = SIZE as f64;
    let (px, py) = ((x / half * 0.5 + 0.5) * n, (0.5 - y / half * 0.5) * n);
    py as usize * SIZE as usize + px as usize
}

/// The quadrants' centres, top-left, top-right, bottom-left, bottom-right.
const CENTRES: [(f64, f64); 4] = [(-0.5, 0.5), (0.5, 0.5), (-0.5, -0.5), (0.5, -0.5)];

fn rgb(channels: &[(String, Vec<f32>)], pixel: usize) -> [f64; 3] {
    ["R", "G", "B"].map(|c| channel(channels, &format!("ViewLayer.Combined.{c}"))[pixel] as f64)
}

fn texel(q: usize) -> [f64; 3] {
    QUADRANTS[q].map(|c| srgb_to_linear(c as f64 / 255.0))
}

#[test]
fn a_textured_metal_reflects_its_texture_times_factor_times_vertex_colour() {
    // Metallic 1, roughness 0: a mirror whose Fresnel reflectance at normal incidence is the
    // base colour (Schlick's F(1) = F₀; the pixels seen here are within 10° of the normal,
    // where (1 − cos θ)⁵ < 10⁻⁹), reflecting the white background: radiance = base colour =
    // baseColorTexture · baseColorFactor · COLOR_0.
    let dir = TempDir::new("materials-metal");
    let Some(assets) = assets(&dir) else { return };
    let (channels, _) = render(&dir, &assets.join("metal_texture.gltf"), 1.0, "path");
    for (q, &(x, y)) in CENTRES.iter().enumerate() {
        let got = rgb(&channels, pixel_of(x, y));
        let t = texel(q);
        for c in 0..3 {
            let want = t[c] * BASE[c] * VERTEX_COLOR[c];
            assert!((got[c] - want).abs() <= 1e-5 * want.max(1e-3), "quadrant {q} channel {c}: {} vs {want}", got[c]);
        }
    }
}

#[test]
fn an_emissive_texture_emits_texture_times_factor_times_strength() {
    // A black quad whose emission is emissiveTexture · emissiveFactor · emissiveStrength, on a
    // black background: the camera sees that radiance and nothing else.
    let dir = TempDir::new("materials-emissive");
    let Some(assets) = assets(&dir) else { return };
    let (channels, _) = render(&dir, &assets.join("emissive_texture.gltf"), 0.0, "path");
    for (q, &(x, y)) in CENTRES.iter().enumerate() {
        let got = rgb(&channels, pixel_of(x, y));
        let t = texel(q);
        for c in 0..3 {
            let want = t[c] * EMISSIVE[c] * STRENGTH;
            assert!((got[c] - want).abs() <= 1e-5 * want.max(1e-3), "quadrant {q} channel {c}: {} vs {want}", got[c]);
        }
    }
}

#[test]
fn the_whitted_integrator_shows_an_emissive_texture_by_its_mean() {
    // The lecture form's emission is constant: emissiveFactor · strength · the texture's mean.
    let dir = TempDir::new("materials-emissive-whitted");
    let Some(assets) = assets(&dir) else { return };
    let (channels, _) = render(&dir, &assets.join("emissive_texture.gltf"), 0.0, "whitted");
    let mean: Vec<f64> = (0..3).map(|c| (0..4).map(|q| texel(q)[c]).sum::<f64>() / 4.0).collect();
    for &(x, y) in &CENTRES {
        let got = rgb(&channels, pixel_of(x, y));
        for c in 0..3 {
            let want = mean[c] * EMISSIVE[c] * STRENGTH;
            assert!((got[c] - want).abs() <= 1e-5 * want.max(1e-3), "channel {c}: {} vs {want}", got[c]);
        }
    }
}

#[test]
fn extensions_are_read_or_named_in_a_warning() {
    let dir = TempDir::new("materials-extensions");
    let Some(assets) = assets(&dir) else { return };
    let path = assets.join("extensions.gltf");
    let (_, stderr) = render(&dir, &path, 0.0, "path");
    for warning in
        ["material 0: occlusionTexture ignored", "material 0: extension KHR_materials_iridescence is not supported"]
    {
        assert!(stderr.contains(warning), "no warning {warning:?} in:\n{stderr}");
    }
    for read in [
        "KHR_materials_sheen:",
        "KHR_materials_volume:",
        "sheenColor",
        "clearcoatFactor",
        "clearcoatTexture",
        "specularTexture",
    ] {
        assert!(!stderr.contains(read), "{read:?} is read, yet warned about:\n{stderr}");
    }
    let scene = strahl::scene::from_gltf_file(&path, None).unwrap().scene;
    let pbr = scene.materials.iter().find_map(|m| m.pbr.as_deref()).expect("a PBR material");
    assert_eq!((pbr.factors.clearcoat, pbr.factors.clearcoat_roughness), (0.5, 0.25));
    assert_eq!((pbr.factors.sheen_color.to_array(), pbr.factors.sheen_roughness), ([0.2, 0.3, 0.4], 0.6));
    assert_eq!(pbr.factors.specular, 0.7);
    let textures = &pbr.extension_textures;
    assert!(textures.clearcoat.is_some() && textures.specular.is_some(), "{textures:?}");
    assert_eq!(
        (pbr.thickness, pbr.attenuation_color.to_array(), pbr.attenuation_distance),
        (0.1, [0.5, 0.25, 1.0], 2.0)
    );
    let sigma = pbr.sigma_a().unwrap();
    assert!((sigma.x as f64 - 2f64.ln() / 2.0).abs() < 1e-6 && sigma.z == 0.0, "{sigma}");
}

#[test]
fn the_metallic_roughness_texture_gives_metalness_in_blue_and_roughness_in_green_linearly() {
    // Quadrants (G, B) = (255, 0), (0, 255), (255, 255), (0, 128) over factors 1, 1.
    let dir = TempDir::new("materials-mr");
    let Some(assets) = assets(&dir) else { return };
    let path = assets.join("metal_roughness_texture.gltf");
    let scene = strahl::scene::from_gltf_file(&path, None).unwrap().scene;
    let pbr = scene.materials.iter().find_map(|m| m.pbr.as_deref()).expect("a PBR material");
    // Strahl's texture coordinates of the quadrants' centres (bottom-left origin).
    let uv = [(0.25, 0.75), (0.75, 0.75), (0.25, 0.25), (0.75, 0.25)];
    let want = [(0.0, 1.0), (1.0, 0.0), (1.0, 1.0), (128.0 / 255.0, 0.0)];
    for (q, &(u, v)) in uv.iter().enumerate() {
        let uv = glam::Vec2::new(u, v);
        let p = pbr.params_at([uv, uv], glam::Vec3::ONE);
        assert_eq!((p.metallic, p.roughness), want[q], "quadrant {q}");
    }
    // Rendered in the furnace: the smooth metal quadrant (top right) is a mirror of
    // reflectance F(1) = base colour 0.5.
    let (channels, _) = render(&dir, &path, 1.0, "path");
    let got = rgb(&channels, pixel_of(CENTRES[1].0, CENTRES[1].1));
    for (c, g) in got.iter().enumerate() {
        assert!((g - 0.5).abs() < 1e-5, "channel {c}: {g}");
    }
}

#[test]
fn khr_texture_transform_offsets_scales_and_rotates_the_texture_coordinates() {
    let dir = TempDir::new("materials-transform");
    let Some(assets) = assets(&dir) else { return };
    let base_at = |file: &str, q: usize| {
        let scene = strahl::scene::from_gltf_file(&assets.join(file), None).unwrap().scene;
        let pbr = scene.materials.iter().find_map(|m| m.pbr.clone()).expect("a PBR material");
        // The quad's quadrant centres in strahl's texture coordinates (bottom-left origin).
        let (x, y) = CENTRES[q];
        let uv = glam::Vec2::new((x as f32 + 1.0) / 2.0, (y as f32 + 1.0) / 2.0);
        pbr.base_color_at([uv, uv], glam::Vec3::ONE).to_array().map(f64::from)
    };
    let close = |a: [f64; 3], b: [f64; 3]| (0..3).all(|c| (a[c] - b[c]).abs() < 1e-6);
    // Offset (0.5, 0), scale 0.5: the image's top-right quadrant everywhere.
    for q in 0..4 {
        let got = base_at("transform_offset_scale.gltf", q);
        assert!(close(got, texel(1)), "quadrant {q}: {got:?}");
    }
    // Offset (0, 1), rotation π/2: glTF (u, v) → (v, 1 − u), the image turned a quarter
    // clockwise; the quad's top-left quadrant (u, v = ¼, ¼) shows the image's bottom-left
    // (¼, ¾), its top-right (¾, ¼) the top-left (¼, ¼), its bottom-left (¼, ¾) the
    // bottom-right (¾, ¾), its bottom-right the top-right.
    for (q, image_q) in [(0, 2), (1, 0), (2, 3), (3, 1)] {
        let got = base_at("transform_rotation.gltf", q);
        assert!(close(got, texel(image_q)), "quadrant {q}: {got:?} vs {:?}", texel(image_q));
    }
}
