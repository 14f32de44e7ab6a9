//! The textures of glTF's material extensions (`transmissionTexture`, `specularTexture`,
//! `specularColorTexture`, `clearcoatTexture`, `clearcoatRoughnessTexture`,
//! `sheenColorTexture`, `sheenRoughnessTexture`), on files written by
//! `tools/gltf/extension_texture_assets.py` with pygltflib (not strahl's code).
//!
//! Each texture is half one texel value, half another, over a quad; its twin is the same quad
//! cut in two, each half with the factors the texture's half gives (sRGB-decoded for the colour
//! textures) and no texture. Path traced under a directional light, each half of the textured
//! quad must render as the twin's half does (within 0.2 %: both draw the same samples, so only
//! rounding separates them), and the two halves must differ (by more than 5 %), so a texture
//! that is ignored, read in the wrong channel or the wrong colour space fails.

mod common;

use std::path::{Path, PathBuf};
use std::sync::Arc;

use common::{TempDir, channel, read_exr, strahl, text};

const SIZE: usize = 64;

/// The assets, written into `dir`; `None` (with a skip line) without pygltflib.
fn assets(dir: &TempDir) -> Option<PathBuf> {
    common::gltf_assets(dir, "extension_texture_assets.py", "gltf_extension_textures")
}

/// The quad of `gltf` seen from z = 4 (40° field of view) under a directional light arriving
/// 60° off its normal, on a black background, path traced: the Combined channels and stderr.
fn render(dir: &TempDir, gltf: &Path) -> ([Vec<f32>; 3], String) {
    let toml = format!(
        r#"
[camera]
eye = [0, 0, 4]
target = [0, 0, 0]
fov_deg = 40
[image]
width = {SIZE}
height = {SIZE}
spp = 16
max_depth = 4
background = [0, 0, 0]
[[lights]]
type = "directional"
direction = [0, -0.8660254, -0.5]
irradiance = [3.14159265, 3.14159265, 3.14159265]
[[objects]]
type = "gltf"
path = "{}"
"#,
        gltf.display()
    );
    let name = gltf.file_stem().unwrap().to_str().unwrap();
    let scene = dir.write(&format!("{name}.toml"), toml);
    let out = dir.path(&format!("{name}.exr"));
    let run = strahl(&["render", scene.to_str().unwrap(), "-o", out.to_str().unwrap(), "--integrator", "path"]);
    assert!(run.status.success(), "{name}: {}", text(&run.stderr));
    let (w, h, channels) = read_exr(&out);
    assert_eq!((w, h), (SIZE, SIZE));
    let rgb = ["R", "G", "B"].map(|c| channel(&channels, &format!("ViewLayer.Combined.{c}")).to_vec());
    (rgb, text(&run.stderr))
}

/// The mean RGB over the 7 × 7 pixels around the one that sees the quad's point (x, y, 0).
fn block(rgb: &[Vec<f32>; 3], x: f64, y: f64) -> [f64; 3] {
    let half = 4.0 * 20f64.to_radians().tan();
    let n = SIZE as f64;
    let (px, py) = (((x / half * 0.5 + 0.5) * n) as usize, ((0.5 - y / half * 0.5) * n) as usize);
    let mut sum = [0.0; 3];
    for j in py - 3..=py + 3 {
        for i in px - 3..=px + 3 {
            for c in 0..3 {
                sum[c] += rgb[c][j * SIZE + i] as f64;
            }
        }
    }
    sum.map(|s| s / 49.0)
}

/// The centres of the quad's left and right halves.
const LEFT: (f64, f64) = (-0.5, 0.0);
const RIGHT: (f64, f64) = (0.5, 0.0);

fn halves(rgb: &[Vec<f32>; 3]) -> [[f64; 3]; 2] {
    [block(rgb, LEFT.0, LEFT.1), block(rgb, RIGHT.0, RIGHT.1)]
}

fn close(a: [f64; 3], b: [f64; 3]) -> bool {
    (0..3).all(|c| (a[c] - b[c]).abs() <= 2e-3 * b[c].abs().max(0.01))
}

fn differ(a: [f64; 3], b: [f64; 3]) -> bool {
    (0..3).any(|c| (a[c] - b[c]).abs() > 0.05 * a[c].abs().max(b[c].abs()).max(0.01))
}

/// Renders `CASE.gltf` and `CASE_twin.gltf`; the textured file's halves, the twin's halves.
fn case(dir: &TempDir, assets: &Path, name: &str) -> ([[f64; 3]; 2], [[f64; 3]; 2], String) {
    let (textured, stderr) = render(dir, &assets.join(format!("{name}.gltf")));
    let (twin, _) = render(dir, &assets.join(format!("{name}_twin.gltf")));
    let (got, want) = (halves(&textured), halves(&twin));
    eprintln!("{name}: textured {got:?}, twin {want:?}");
    assert!(differ(want[0], want[1]), "{name}: the twin's halves render alike ({want:?}): the case proves nothing");
    (got, want, stderr)
}

fn each_half_renders_as_its_twin(name: &str) {
    let dir = TempDir::new(&format!("ext-tex-{name}"));
    let Some(assets) = assets(&dir) else { return };
    let (got, want, stderr) = case(&dir, &assets, name);
    for (side, (g, w)) in ["left", "right"].iter().zip(got.iter().zip(&want)) {
        assert!(close(*g, *w), "{name}, {side} half: {g:?}, its twin {w:?}");
    }
    assert!(!stderr.contains("ignored"), "{name}: a texture is warned about:\n{stderr}");
}

#[test]
fn transmission_texture_multiplies_transmission_factor_by_red() {
    each_half_renders_as_its_twin("transmission");
}

#[test]
fn specular_texture_multiplies_specular_factor_by_alpha() {
    each_half_renders_as_its_twin("specular");
}

#[test]
fn specular_color_texture_multiplies_specular_color_factor_by_srgb_decoded_rgb() {
    each_half_renders_as_its_twin("specular_color");
}

#[test]
fn clearcoat_texture_multiplies_clearcoat_factor_by_red() {
    each_half_renders_as_its_twin("clearcoat");
}

#[test]
fn clearcoat_roughness_texture_multiplies_clearcoat_roughness_factor_by_green() {
    each_half_renders_as_its_twin("clearcoat_roughness");
}

#[test]
fn sheen_color_texture_multiplies_sheen_color_factor_by_srgb_decoded_rgb() {
    each_half_renders_as_its_twin("sheen_color");
}

#[test]
fn sheen_roughness_texture_multiplies_sheen_roughness_factor_by_alpha() {
    each_half_renders_as_its_twin("sheen_roughness");
}

/// The texture coordinate set (`texCoord` 1, here the first set mirrored left to right) and
/// `KHR_texture_transform` (its `texCoord`, its offset and scale) are honoured as for the core
/// textures.
#[test]
fn extension_textures_honour_tex_coord_and_texture_transform() {
    let dir = TempDir::new("ext-tex-texcoord");
    let Some(assets) = assets(&dir) else { return };
    let (_, want, _) = case(&dir, &assets, "transmission");
    for (file, expected) in [
        ("transmission_texcoord1.gltf", [want[1], want[0]]),
        ("transmission_transform_texcoord1.gltf", [want[1], want[0]]),
        ("transmission_transform.gltf", [want[1], want[1]]),
    ] {
        let (rgb, stderr) = render(&dir, &assets.join(file));
        let got = halves(&rgb);
        for side in 0..2 {
            assert!(close(got[side], expected[side]), "{file}, half {side}: {:?} vs {:?}", got[side], expected[side]);
        }
        assert!(!stderr.contains("TEXCOORD"), "{file}: {stderr}");
    }
    // texCoord 2 is a set strahl does not read: TEXCOORD_0 is read instead, as the warning says.
    let (rgb, stderr) = render(&dir, &assets.join("transmission_texcoord2.gltf"));
    let got = halves(&rgb);
    for side in 0..2 {
        assert!(close(got[side], want[side]), "texCoord 2, half {side}: {:?} vs {:?}", got[side], want[side]);
    }
    assert!(stderr.contains("uses TEXCOORD_2; TEXCOORD_0 is used"), "{stderr}");
}

/// Ray tracers measure the distance inside: `thicknessTexture` is not read (no image decoded,
/// no warning), as `KHR_materials_volume` asks of them.
#[test]
fn the_thickness_texture_is_left_to_rasterisers() {
    let dir = TempDir::new("ext-tex-thickness");
    let Some(assets) = assets(&dir) else { return };
    let loaded = strahl::scene::from_gltf_file(&assets.join("thickness.gltf"), None).unwrap();
    assert!(loaded.warnings.iter().all(|w| !w.contains("thicknessTexture")), "{:?}", loaded.warnings);
    let m = loaded.scene.materials.iter().find(|m| m.pbr.is_some()).unwrap();
    assert!(m.images().is_empty(), "an image was decoded for the thickness texture");
    assert_eq!(m.pbr.as_ref().unwrap().thickness, 0.5);
}

/// Textures that name one image in one encoding share its decoded copy: the two alpha-channel
/// textures one plane, the three linear ones (the coat's normal map among them) another.
#[test]
fn textures_of_one_image_share_its_decoded_copy() {
    let dir = TempDir::new("ext-tex-shared");
    let Some(assets) = assets(&dir) else { return };
    let loaded = strahl::scene::from_gltf_file(&assets.join("shared.gltf"), None).unwrap();
    assert!(loaded.warnings.iter().all(|w| !w.contains("clearcoatNormalTexture")), "{:?}", loaded.warnings);
    let scene = loaded.scene;
    let pbr = scene.materials.iter().find_map(|m| m.pbr.as_deref()).unwrap();
    let t = &pbr.extension_textures;
    let image = |slot: &Option<strahl::material::TextureSlot>| slot.as_ref().expect("a texture").texture.image.clone();
    assert!(Arc::ptr_eq(&image(&t.specular), &image(&t.sheen_roughness)));
    assert!(Arc::ptr_eq(&image(&t.clearcoat), &image(&t.clearcoat_roughness)));
    assert!(Arc::ptr_eq(&image(&t.clearcoat), &image(&pbr.clearcoat_normal_texture)));
    assert_eq!(pbr.clearcoat_normal_scale, 1.0);
    assert!(!Arc::ptr_eq(&image(&t.specular), &image(&t.clearcoat)));
    // The alpha plane holds α (40 and 80 of 255), the linear one the bytes as they are.
    let uv = glam::Vec2::new(0.25, 0.5);
    let p = pbr.params_at([uv, uv], glam::Vec3::ONE);
    assert!((p.specular - 40.0 / 255.0).abs() < 1e-6, "{}", p.specular);
    assert!((p.sheen_roughness - 40.0 / 255.0).abs() < 1e-6, "{}", p.sheen_roughness);
    assert!((p.clearcoat - 10.0 / 255.0).abs() < 1e-6, "{}", p.clearcoat);
    assert!((p.clearcoat_roughness - 20.0 / 255.0).abs() < 1e-6, "{}", p.clearcoat_roughness);
}

/// A texture index the gltf crate does not check (the extension is JSON to it) is checked here.
#[test]
fn an_extension_texture_index_out_of_range_is_an_error_naming_it() {
    let dir = TempDir::new("ext-tex-bad");
    let Some(assets) = assets(&dir) else { return };
    let path = assets.join("bad_index.gltf");
    let Err(err) = strahl::scene::from_gltf_file(&path, None) else { panic!("bad_index.gltf was accepted") };
    let err = err.to_string();
    assert!(err.contains("bad_index.gltf") && err.contains("clearcoatTexture: texture 7 does not exist"), "{err}");
}
