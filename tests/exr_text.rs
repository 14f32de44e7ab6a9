//! Text outside Latin-1 never loses a render: a scene path, object and material names in
//! Cyrillic and a glTF file named `Unicode❤♻Test.glb` with Unicode names render, and the EXR
//! carries them as UTF-8, read back by Python's OpenEXR (which decodes string attributes as
//! UTF-8) and, for Cryptomatte, hashed by Python's `mmh3` (tests/cryptomatte_check.py); a merge
//! of such parts keeps them. Skips with a message when Python's OpenEXR, mmh3 or numpy is
//! missing.

mod common;

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::process::Command;

use common::{TempDir, strahl, text};

fn python_readers() -> bool {
    let ok =
        Command::new("python3").args(["-c", "import OpenEXR, mmh3, numpy"]).output().is_ok_and(|o| o.status.success());
    if !ok {
        common::skip("Python's OpenEXR, mmh3 and numpy are not installed (make test-deps installs them)");
    }
    ok
}

/// The string attributes of the EXR at `path` as Python's OpenEXR reads them.
fn string_attributes(path: &Path) -> HashMap<String, String> {
    let script = "import json, sys, OpenEXR\n\
                  with OpenEXR.File(sys.argv[1]) as f:\n    \
                  print(json.dumps({k: v for k, v in f.header().items() if isinstance(v, str)}))";
    let o = Command::new("python3").args(["-c", script]).arg(path).output().unwrap();
    assert!(o.status.success(), "{}", text(&o.stderr));
    serde_json::from_slice(&o.stdout).unwrap()
}

/// Renders `scene` small with the object and material passes and Cryptomatte into `out`.
fn render(scene: &Path, out: &Path, extra: &[&str]) {
    let mut args = vec!["render", scene.to_str().unwrap(), "-o", out.to_str().unwrap()];
    args.extend(["--width", "48", "--height", "36", "--spp", "1", "--threads", "2"]);
    args.extend(["--passes", "default,object_index,material_index,crypto_object,crypto_material"]);
    args.extend(extra);
    let o = strahl(&args);
    assert!(o.status.success(), "render {args:?}: {}", text(&o.stderr));
}

/// Runs tests/cryptomatte_check.py on `exr` (ids from mmh3 of the UTF-8 names, mattes equal to
/// the object-index coverage) and returns its report.
fn cryptomatte_check(exr: &Path) -> String {
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/cryptomatte_check.py");
    let o = Command::new("python3").arg(&script).arg(exr).output().unwrap();
    let report = text(&o.stdout);
    assert!(o.status.success(), "{report}\n{}", text(&o.stderr));
    report
}

/// The manifest of the Cryptomatte pass whose name ends with `pass`.
fn manifest(attributes: &HashMap<String, String>, pass: &str) -> HashMap<String, String> {
    let key = attributes
        .iter()
        .find(|(k, v)| k.ends_with("/name") && v.ends_with(pass))
        .map(|(k, _)| k.trim_end_matches("/name").to_string())
        .unwrap_or_else(|| panic!("no Cryptomatte pass {pass}"));
    serde_json::from_str(&attributes[&format!("{key}/manifest")]).unwrap()
}

const SCENE: &str = r#"
[camera]
eye = [0, 1, 6]
target = [0, 0.8, 0]
up = [0, 1, 0]
fov_deg = 45

[image]
width = 48
height = 36
background = [0.2, 0.3, 0.4]
ambient = 0.2

[materials."сталь"]
diffuse = [0.7, 0.7, 0.75]

[materials."пол"]
diffuse = 0.5

[[lights]]
type = "point"
position = [2, 5, 4]
intensity = 60

[[objects]]
type = "sphere"
name = "шар"
center = [0, 1, 0]
radius = 1
material = "сталь"

[[objects]]
type = "plane"
name = "земля ☀"
normal = [0, 1, 0]
distance = 0
material = "пол"
"#;

#[test]
fn cyrillic_scene_path_and_names_render_and_read_back_as_utf8() {
    if !python_readers() {
        return;
    }
    let dir = TempDir::new("cyrillic");
    let scene = dir.write("сцена.toml", SCENE);
    let out = dir.path("кадр.exr");
    render(&scene, &out, &[]);
    let attributes = string_attributes(&out);
    assert_eq!(attributes["strahl/scene"], "сцена.toml");
    let objects = manifest(&attributes, "CryptoObject");
    assert!(objects.contains_key("шар") && objects.contains_key("земля ☀"), "{objects:?}");
    let materials = manifest(&attributes, "CryptoMaterial");
    assert!(materials.contains_key("сталь") && materials.contains_key("пол"), "{materials:?}");
    let report = cryptomatte_check(&out);
    assert!(report.contains("object 'шар': ") && report.contains("object 'земля ☀': "), "{report}");

    // Two tiles of it merge into the same bytes, names and all.
    let parts: Vec<PathBuf> = (1..=2).map(|i| dir.path(&format!("часть{i}.exr"))).collect();
    for (i, part) in parts.iter().enumerate() {
        render(&scene, part, &["--tile", &format!("{}/2", i + 1)]);
    }
    let merged = dir.path("целое.exr");
    let o = strahl(&["merge", merged.to_str().unwrap(), parts[0].to_str().unwrap(), parts[1].to_str().unwrap()]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    assert!(std::fs::read(&merged).unwrap() == std::fs::read(&out).unwrap(), "the merged tiles differ from the render");
}

/// A GLB of one red triangle facing a camera, under a point light, with Unicode names.
fn unicode_glb() -> Vec<u8> {
    let positions: Vec<u8> = [[-1.0f32, -1.0, 0.0], [1.0, -1.0, 0.0], [0.0, 1.0, 0.0]]
        .iter()
        .flatten()
        .flat_map(|v| v.to_le_bytes())
        .collect();
    let json = r#"{"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[0,1,2]}],
        "nodes":[{"name":"Узел ❤","mesh":0},{"name":"Камера","camera":0,"translation":[0,0,3]},
                 {"name":"Лампа","translation":[0,0,3],"extensions":{"KHR_lights_punctual":{"light":0}}}],
        "meshes":[{"name":"Сетка ♻","primitives":[{"attributes":{"POSITION":0},"material":0}]}],
        "materials":[{"name":"Краска ❤","pbrMetallicRoughness":{"baseColorFactor":[0.8,0.2,0.2,1]}}],
        "cameras":[{"type":"perspective","perspective":{"yfov":0.9,"znear":0.1}}],
        "extensionsUsed":["KHR_lights_punctual"],
        "extensions":{"KHR_lights_punctual":{"lights":[{"type":"point","intensity":40}]}},
        "accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[-1,-1,0],"max":[1,1,0]}],
        "bufferViews":[{"buffer":0,"byteOffset":0,"byteLength":36}],
        "buffers":[{"byteLength":36}]}"#;
    let mut json = json.as_bytes().to_vec();
    while json.len() % 4 != 0 {
        json.push(b' ');
    }
    let total = 12 + 8 + json.len() + 8 + positions.len();
    let mut glb = b"glTF".to_vec();
    glb.extend(2u32.to_le_bytes());
    glb.extend((total as u32).to_le_bytes());
    glb.extend((json.len() as u32).to_le_bytes());
    glb.extend(b"JSON");
    glb.extend(&json);
    glb.extend((positions.len() as u32).to_le_bytes());
    glb.extend(b"BIN\0");
    glb.extend(&positions);
    glb
}

#[test]
fn a_gltf_named_in_unicode_renders_and_reads_back_as_utf8() {
    if !python_readers() {
        return;
    }
    let dir = TempDir::new("unicode-glb");
    let glb = dir.write("Unicode❤♻Test.glb", unicode_glb());
    let out = dir.path("out.exr");
    render(&glb, &out, &[]);
    let attributes = string_attributes(&out);
    assert_eq!(attributes["strahl/scene"], "Unicode❤♻Test.glb");
    let objects = manifest(&attributes, "CryptoObject");
    let materials = manifest(&attributes, "CryptoMaterial");
    // Whatever names the importer gives, they are the glTF's Unicode ones, intact.
    let all: Vec<&String> = objects.keys().chain(materials.keys()).collect();
    assert!(all.iter().any(|n| n.contains('❤') || n.contains('♻')), "{all:?}");
    assert!(all.iter().all(|n| !n.contains('\u{fffd}')), "{all:?}");
    cryptomatte_check(&out);
}
