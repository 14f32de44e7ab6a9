//! What a glTF file asks of its reader before anything is built from it: `asset.minVersion`,
//! `extensionsRequired` and `extensionsUsed`, read from the file's JSON as it is (the `gltf`
//! crate's own check knows only the extensions it parses, and names none of the others).
//!
//! The rule:
//! - `asset.minVersion` above 2.0 is refused (strahl reads glTF 2.0).
//! - A required extension is supported when the `gltf` crate parses it (its enabled features,
//!   [`gltf::json::extensions::ENABLED_EXTENSIONS`]) or strahl reads it itself
//!   ([`STRAHL_EXTENSIONS`]); the compressions and encodings in [`REFUSED`] are refused naming
//!   what they are; any other required extension is refused by name.
//! - A used (not required) extension that strahl does not read is warned about by name: the
//!   file renders without it. Draco and meshopt files that also carry uncompressed data read
//!   that data.
//!
//! Also here: `EXT_mesh_gpu_instancing`'s accessors per node ([`Extensions::instancing`]), read
//! from the node's JSON since the crate keeps no unknown extension.

use std::collections::HashMap;

use serde_json::Value;

/// Extensions strahl reads: instancing here, the lights and materials in `scene::load::gltf`
/// (clearcoat and sheen from the material's JSON, the others through the `gltf` crate's
/// features, whose own list of enabled extensions does not name them all).
pub const STRAHL_EXTENSIONS: &[&str] = &[
    "EXT_mesh_gpu_instancing",
    "KHR_lights_punctual",
    "KHR_materials_clearcoat",
    "KHR_materials_emissive_strength",
    "KHR_materials_ior",
    "KHR_materials_sheen",
    "KHR_materials_specular",
    "KHR_materials_transmission",
    "KHR_materials_unlit",
    "KHR_materials_volume",
    "KHR_texture_transform",
];

/// The end of the message refusing a required extension.
const REQUIRED: &str = "strahl does not support this required extension";

/// Extensions that are refused when required and warned about when used, with what they are.
pub const REFUSED: &[(&str, &str)] = &[
    ("KHR_draco_mesh_compression", "Draco-compressed meshes"),
    ("EXT_meshopt_compression", "meshopt-compressed buffers"),
    ("KHR_texture_basisu", "KTX2 / Basis Universal textures"),
    ("KHR_mesh_quantization", "quantized vertex attributes (integer positions, normals and texture coordinates)"),
];

/// `EXT_mesh_gpu_instancing` on a node: its accessors (`TRANSLATION`, `ROTATION`, `SCALE`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Instancing {
    pub translation: Option<usize>,
    pub rotation: Option<usize>,
    pub scale: Option<usize>,
}

/// What [`read_extensions`] found.
#[derive(Clone, Debug, Default)]
pub struct Extensions {
    /// One line each, naming the extension (the file name is added by the caller).
    pub warnings: Vec<String>,
    /// Node index → its `EXT_mesh_gpu_instancing` accessors.
    pub instancing: HashMap<usize, Instancing>,
}

/// Whether strahl reads `name`.
fn supported(name: &str) -> bool {
    STRAHL_EXTENSIONS.contains(&name) || gltf::json::extensions::ENABLED_EXTENSIONS.contains(&name)
}

/// The JSON of a `.gltf` or `.glb` file's bytes; `None` when it does not parse (the real
/// parse then reports it).
fn json_of(bytes: &[u8]) -> Option<Value> {
    if bytes.starts_with(b"glTF") {
        let glb = gltf::Glb::from_slice(bytes).ok()?;
        serde_json::from_slice(&glb.json).ok()
    } else {
        serde_json::from_slice(bytes).ok()
    }
}

/// Checks a file's version and extensions (see the module's rule) and reads its instancing.
pub fn read_extensions(bytes: &[u8]) -> Result<Extensions, String> {
    let Some(json) = json_of(bytes) else { return Ok(Extensions::default()) };
    check_min_version(&json)?;
    let names = |key: &str| -> Vec<String> {
        json.get(key)
            .and_then(Value::as_array)
            .map(|a| a.iter().filter_map(Value::as_str).map(str::to_string).collect())
            .unwrap_or_default()
    };
    let (required, used) = (names("extensionsRequired"), names("extensionsUsed"));
    let mut out = Extensions::default();
    for name in &required {
        if let Some((_, what)) = REFUSED.iter().find(|(n, _)| *n == name.as_str()) {
            return Err(format!("extensionsRequired: {name} ({what}): {REQUIRED}"));
        }
        if !supported(name) {
            return Err(format!("extensionsRequired: {name}: {REQUIRED}"));
        }
    }
    for name in used.iter().filter(|n| !required.contains(n)) {
        if let Some((_, what)) = REFUSED.iter().find(|(n, _)| *n == name.as_str()) {
            out.warnings
                .push(format!("extensionsUsed: {name} ({what}) is not supported; the file's fallback data is read"));
        } else if !supported(name) {
            out.warnings.push(format!("extensionsUsed: {name} is not supported; ignored"));
        }
    }
    out.instancing = instancing(&json)?;
    Ok(out)
}

/// `asset.minVersion` must be at most 2.0 (a `MAJOR.MINOR` string).
fn check_min_version(json: &Value) -> Result<(), String> {
    let Some(v) = json.get("asset").and_then(|a| a.get("minVersion")) else { return Ok(()) };
    let parsed = v.as_str().and_then(|s| {
        let (major, minor) = s.split_once('.')?;
        Some((major.parse::<u32>().ok()?, minor.parse::<u32>().ok()?))
    });
    match parsed {
        Some((major, minor)) if (major, minor) <= (2, 0) => Ok(()),
        Some(_) => {
            Err(format!("asset.minVersion {v}: the file needs a glTF version above 2.0, which strahl does not read"))
        }
        None => Err(format!("asset.minVersion {v}: not a MAJOR.MINOR version")),
    }
}

/// Every node's `EXT_mesh_gpu_instancing` attributes (accessor indices; they are checked
/// against the file's accessors when read).
fn instancing(json: &Value) -> Result<HashMap<usize, Instancing>, String> {
    let mut out = HashMap::new();
    let Some(nodes) = json.get("nodes").and_then(Value::as_array) else { return Ok(out) };
    for (i, node) in nodes.iter().enumerate() {
        let Some(ext) = node.get("extensions").and_then(|e| e.get("EXT_mesh_gpu_instancing")) else { continue };
        let what = format!("node {i}: EXT_mesh_gpu_instancing");
        let Some(attributes) = ext.get("attributes").and_then(Value::as_object) else {
            return Err(format!("{what}: has no attributes object"));
        };
        let mut inst = Instancing::default();
        for (key, value) in attributes {
            let Some(index) = value.as_u64().and_then(|v| usize::try_from(v).ok()) else {
                return Err(format!("{what}: attribute {key:?} is not an accessor index"));
            };
            match key.as_str() {
                "TRANSLATION" => inst.translation = Some(index),
                "ROTATION" => inst.rotation = Some(index),
                "SCALE" => inst.scale = Some(index),
                _ => {} // custom attributes (`_ID`, …) are the application's
            }
        }
        out.insert(i, inst);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn read(json: &str) -> Result<Extensions, String> {
        read_extensions(json.as_bytes())
    }

    #[test]
    fn refusals_name_the_extension() {
        for (name, _) in REFUSED {
            let e = read(&format!(
                r#"{{"asset":{{"version":"2.0"}},"extensionsRequired":["{name}"],"extensionsUsed":["{name}"]}}"#
            ))
            .unwrap_err();
            assert!(e.contains(name), "{e}");
        }
        let e = read(r#"{"asset":{"version":"2.0"},"extensionsRequired":["VENDOR_x"]}"#).unwrap_err();
        assert_eq!(e, "extensionsRequired: VENDOR_x: strahl does not support this required extension");
    }

    #[test]
    fn unknown_used_extensions_are_warned_about() {
        let ok = read(r#"{"asset":{"version":"2.0"},"extensionsUsed":["VENDOR_x","KHR_lights_punctual","EXT_mesh_gpu_instancing"]}"#)
            .unwrap();
        assert_eq!(ok.warnings, ["extensionsUsed: VENDOR_x is not supported; ignored"]);
    }

    #[test]
    fn min_version() {
        assert!(read(r#"{"asset":{"version":"2.0","minVersion":"2.0"}}"#).is_ok());
        let e = read(r#"{"asset":{"version":"2.1","minVersion":"2.1"}}"#).unwrap_err();
        assert!(e.starts_with("asset.minVersion \"2.1\""), "{e}");
        assert!(read(r#"{"asset":{"version":"2.0","minVersion":"two"}}"#).is_err());
    }

    #[test]
    fn instancing_attributes_are_read() {
        let ok = read(
            r#"{"asset":{"version":"2.0"},"nodes":[{},{"extensions":{"EXT_mesh_gpu_instancing":{"attributes":{"TRANSLATION":3,"_ID":4}}}}]}"#,
        )
        .unwrap();
        assert_eq!(ok.instancing[&1], Instancing { translation: Some(3), ..Default::default() });
        let e = read(
            r#"{"asset":{"version":"2.0"},"nodes":[{"extensions":{"EXT_mesh_gpu_instancing":{"attributes":{"SCALE":-1}}}}]}"#,
        );
        assert!(e.unwrap_err().contains("node 0"));
    }
}
