//! glTF 2.0 import (`.gltf` with external or base64-embedded buffers, and `.glb`), with the
//! `gltf` crate for parsing and validating the JSON and reading accessors.
//!
//! [`load_gltf`] reads the default scene (else scene 0) into strahl's terms; the mapping is
//! written down in `docs/scene-format.md` ("glTF files"):
//! - **Meshes**: each glTF mesh becomes one [`Mesh`] in its own (object) space, its
//!   primitives of modes triangles, strips and fans merged ([`gltf_modes`]; a material per
//!   triangle when they differ); other modes are skipped with a warning naming the primitive.
//!   Indexed and non-indexed primitives, sparse accessors ([`gltf_sparse`]), morph targets at
//!   their default weights ([`gltf_morph`]), `NORMAL`, `TEXCOORD_0` (its `v` turned into
//!   strahl's bottom-left convention, `1 − v`) and `COLOR_0` (RGB, and its alpha for the alpha test). Where a
//!   primitive's material has a `normalTexture` (or a `clearcoatNormalTexture`), its `TANGENT` (ignored, as glTF asks, when it
//!   has no `NORMAL`), else MikkTSpace tangents ([`crate::scene::tangents`]).
//! - **Nodes**: the node hierarchy with TRS or matrix transforms, composed in f64; each node
//!   with a mesh is a [`MeshNode`] (the mesh and the node's object-to-world transform), one
//!   per instance of `EXT_mesh_gpu_instancing` ([`gltf_instancing`]), so a mesh used by
//!   several nodes or instances is stored once.
//! - **Cameras** (perspective: `yfov`, optional `aspectRatio`; orthographic: `xmag`, `ymag`),
//!   looking along the node's −z with +y up, and **lights** (`KHR_lights_punctual`) in world
//!   space. Photometric units are read as strahl's radiometric ones, one for one: a point
//!   light's candela as W/sr, a directional light's lux as W/m² (the 683 lm/W of photopic
//!   vision is *not* applied, so a glTF light of intensity `I` renders like a TOML light of
//!   intensity `I`). Spot lights become point lights (their cone is ignored, with a warning);
//!   `range` is ignored.
//! - **Materials**: see [`material_of`].
//!
//! Everything is checked before use, so bad input is a one-line error naming the file and the
//! glTF element (`accessor 3`), never a panic: the version and extensions the file asks for
//! ([`read_extensions`], naming what is missing), the crate's validation (indices into arrays,
//! required fields), then here every accessor's bytes against its buffer view and buffer, its
//! component type and dimensions against what the attribute needs (the crate's readers assume
//! them), and vertex indices against the vertex count.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use glam::{DMat4, DQuat, DVec3};
use gltf::accessor::{DataType, Dimensions};
use gltf::mesh::Mode;

use super::MeshError;
use super::gltf_extensions::{Instancing, read_extensions};
use super::gltf_instancing;
use super::gltf_modes;
use super::gltf_morph::{self, MeshSlots};
use super::gltf_sparse;
use crate::bsdf::PbrParams;
use crate::light::Light;
use crate::material::{AlphaMode, Coverage, Material, Pbr, TextureSlot};
use crate::math::{Vec2, Vec3, Vec4};
use crate::scene::transform::Transform;
use crate::scene::{CameraSpec, Mesh};
use crate::texture::{Encoding, Image, ImageTexture, Wrap, open_shared_as};

/// A node that places a mesh: `GltfFile::meshes[mesh]` through `transform` (object to world).
#[derive(Clone, Debug)]
pub struct MeshNode {
    /// The glTF node's index.
    pub node: usize,
    /// The glTF node's name, if it has one.
    pub name: Option<String>,
    pub mesh: usize,
    /// The instance's index in the node's `EXT_mesh_gpu_instancing` accessors, if it has them.
    pub instance: Option<usize>,
    pub transform: Transform,
}

/// A camera (perspective or orthographic) placed by a node.
#[derive(Clone, Debug)]
pub struct GltfCamera {
    /// The glTF camera's index (in the file's `cameras`).
    pub index: usize,
    /// The camera's own name.
    pub name: Option<String>,
    /// The name of the node that places it (Blender names the two apart once either is renamed).
    pub node_name: Option<String>,
    pub spec: CameraSpec,
    /// Width over height, when the file gives it.
    pub aspect_ratio: Option<f32>,
}

/// What a glTF file holds, in strahl's terms.
#[derive(Clone, Debug, Default)]
pub struct GltfFile {
    /// One per glTF mesh (empty for meshes with no triangles), in object space. Their material
    /// indices index [`Self::materials`].
    pub meshes: Vec<Mesh>,
    pub materials: Vec<Material>,
    /// The nodes of the scene that place a mesh with triangles, in depth-first order.
    pub nodes: Vec<MeshNode>,
    /// The scene's cameras, in depth-first node order.
    pub cameras: Vec<GltfCamera>,
    /// The scene's lights, in world space.
    pub lights: Vec<Light>,
    /// One line each, naming the file and the element.
    pub warnings: Vec<String>,
    /// The files read besides the glTF file itself: external buffers and images.
    pub files: Vec<PathBuf>,
}

impl GltfFile {
    /// Triangles the nodes place (instances counted each time).
    pub fn placed_triangles(&self) -> usize {
        self.nodes.iter().map(|n| self.meshes[n.mesh].indices.len()).sum()
    }
}

/// Whether `path` names a glTF file (`.gltf` or `.glb`, any case).
pub fn is_gltf(path: &Path) -> bool {
    path.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("gltf") || e.eq_ignore_ascii_case("glb"))
}

/// Deepest node hierarchy followed.
const MAX_NODE_DEPTH: usize = 1024;

/// Reads the glTF or GLB file at `path`. Image files are shared with every other material
/// naming them ([`open_shared`]); images embedded in the file are decoded once per file.
pub fn load_gltf(path: &Path) -> Result<GltfFile, MeshError> {
    let io = |problem| MeshError::Io { path: path.to_owned(), problem };
    let cap = crate::sys::read::max_mesh_bytes().map_err(io)?;
    let bytes = crate::sys::read::read_regular(path, cap, crate::sys::read::MESH_LIMIT_HINT).map_err(io)?;
    parse_gltf(path, bytes)
}

/// gltf-json 1.4's validation indexes the accessors with a primitive's POSITION index before
/// checking it (its `mesh.rs`, `primitive_validate_hook`) and panics on one out of range, which
/// the fuzz target `gltf` found: check those indices first. A file whose JSON does not parse is
/// left to the real parse, which reports it.
fn check_position_accessors(bytes: &[u8]) -> Result<(), String> {
    use gltf::json::mesh::Semantic;
    use gltf::json::validation::Checked;
    let glb;
    let json: &[u8] = if bytes.starts_with(b"glTF") {
        let Ok(parsed) = gltf::Glb::from_slice(bytes) else { return Ok(()) };
        glb = parsed;
        &glb.json
    } else {
        bytes
    };
    let Ok(root) = gltf::json::Root::from_slice(json) else { return Ok(()) };
    for (m, mesh) in root.meshes.iter().enumerate() {
        for (p, primitive) in mesh.primitives.iter().enumerate() {
            let position = primitive.attributes.get(&Checked::Valid(Semantic::Positions));
            if let Some(i) = position.map(|i| i.value()).filter(|&i| i >= root.accessors.len()) {
                let n = root.accessors.len();
                return Err(format!("mesh {m} primitive {p}: POSITION names accessor {i}, but the file has {n}"));
            }
        }
    }
    Ok(())
}

/// [`load_gltf`] of a file's `bytes` (external buffers and images are read relative to
/// `path`'s folder): what the fuzz target `gltf` calls. The bytes are dropped once parsed (a
/// GLB's binary chunk is copied out of them), before the meshes are built.
///
/// Before anything is built from what the file declares: a GLB's header must give the file's
/// own length; every mesh must have a primitive (the specification asks for one at least);
/// the scene's nodes must form a forest ([`check_hierarchy`]: a node with two parents, or in a
/// cycle, is refused naming it), so the placements are counted before they are made; and the
/// meshes and placements, sized from their accessors' counts, must fit in what is left of the
/// memory budget ([`crate::sys::read::check_memory`]).
pub fn parse_gltf(path: &Path, bytes: Vec<u8>) -> Result<GltfFile, MeshError> {
    let err = |problem: String| MeshError::Invalid { path: path.to_owned(), problem };
    check_glb_length(&bytes).map_err(err)?;
    let extensions = read_extensions(&bytes).map_err(err)?;
    check_position_accessors(&bytes).map_err(err)?;
    let gltf::Gltf { document, blob } =
        gltf::Gltf::from_slice_without_validation(&bytes).map_err(|e| err(gltf_error(&e)))?;
    validate(&document).map_err(|e| err(gltf_error(&e)))?;
    drop(bytes);
    if let Some(mesh) = document.meshes().find(|m| m.primitives().len() == 0) {
        return Err(err(format!("mesh {}: has no primitives (glTF asks for at least one)", mesh.index())));
    }
    let scene = document.default_scene().or_else(|| document.scenes().next());
    let Some(scene) = scene else {
        return Err(err("the file has no scene".into()));
    };
    let mut hierarchy = check_hierarchy(&document, &scene).map_err(err)?;
    let instances = gltf_instancing::declared_placements(&document, &extensions.instancing).map_err(err)?;
    hierarchy.placements = hierarchy.placements.saturating_add(instances);
    check_budget(&document, &hierarchy).map_err(err)?;
    let base = path.parent().unwrap_or(Path::new(""));
    let mut out = GltfFile { warnings: extensions.warnings, ..GltfFile::default() };
    let buffers = read_buffers(&document, base, blob, &mut out.files).map_err(err)?;
    let instancing = &extensions.instancing;
    let mut reader = Reader { doc: &document, buffers: &buffers, base, images: HashMap::new(), out, instancing };
    reader.materials().map_err(err)?;
    let mut meshes = MeshSlots::new(document.meshes().len());
    for node in scene.nodes() {
        reader.node(&node, &Transform::default(), &mut meshes).map_err(err)?;
    }
    let mut out = reader.out;
    out.meshes = meshes.meshes.into_iter().map(Option::unwrap_or_default).collect();
    let file = path.display().to_string();
    out.warnings.iter_mut().for_each(|w| *w = format!("{file}: {w}"));
    Ok(out)
}

/// The `gltf` crate's validation of the whole document, less its check of
/// `extensionsRequired`, which [`read_extensions`] made (naming the extensions, and knowing
/// those strahl reads itself).
fn validate(document: &gltf::Document) -> Result<(), gltf::Error> {
    use gltf::json::validation::Validate;
    let root = document.as_json();
    let mut errors = Vec::new();
    root.validate(root, gltf::json::Path::new, &mut |path, error| {
        let path = path();
        if !path.as_str().starts_with("extensionsRequired") {
            errors.push((path, error));
        }
    });
    if errors.is_empty() { Ok(()) } else { Err(gltf::Error::Validation(errors)) }
}

/// A GLB's header (magic `glTF`, version, length) must give the length of the file itself:
/// bytes past it would be ignored, and a length past the end means a cut file.
fn check_glb_length(bytes: &[u8]) -> Result<(), String> {
    if !bytes.starts_with(b"glTF") {
        return Ok(());
    }
    let Some(length) = bytes.get(8..12) else {
        return Err(format!("not a valid GLB file: {} bytes, less than its 12-byte header", bytes.len()));
    };
    let length = u32::from_le_bytes(length.try_into().expect("4 bytes")) as u64;
    if length != bytes.len() as u64 {
        return Err(format!("not a valid GLB file: its header says {length} bytes, but the file has {}", bytes.len()));
    }
    Ok(())
}

/// What the scene's node hierarchy places, found before anything is built.
struct Hierarchy {
    /// Nodes that place a mesh (each becomes a flattened mesh or an instance).
    placements: u64,
    /// The meshes they place, each once.
    meshes: Vec<usize>,
}

/// Walks the scene's nodes once, without recursion: every node may be reached once only, so a
/// node that is the child of two nodes, listed twice among the roots, or in a cycle is refused
/// naming it (glTF gives a node one parent at most, and the scene's nodes are roots), and a
/// hierarchy deeper than [`MAX_NODE_DEPTH`] too. Then the nodes form a forest and each places
/// its mesh once: a file cannot multiply its placements (24 levels of nodes each the child of
/// the two above would make 2²⁴).
fn check_hierarchy(doc: &gltf::Document, scene: &gltf::Scene) -> Result<Hierarchy, String> {
    let nodes: Vec<gltf::Node> = doc.nodes().collect();
    let mut parent_of: Vec<Option<Option<usize>>> = vec![None; nodes.len()];
    let mut stack: Vec<(usize, Option<usize>, usize)> = scene.nodes().map(|n| (n.index(), None, 0)).collect();
    stack.reverse();
    let mut mesh_used = vec![false; doc.meshes().len()];
    let mut placements = 0;
    let name = |parent: Option<usize>| parent.map_or_else(|| "the scene's roots".to_string(), |p| format!("node {p}"));
    while let Some((i, parent, depth)) = stack.pop() {
        if let Some(first) = parent_of[i] {
            return Err(format!(
                "node {i}: is reached from both {} and {} (a glTF node has one parent at most, and no cycle)",
                name(first),
                name(parent)
            ));
        }
        parent_of[i] = Some(parent);
        if depth > MAX_NODE_DEPTH {
            return Err(format!("node {i}: the node hierarchy is deeper than {MAX_NODE_DEPTH}"));
        }
        if let Some(mesh) = nodes[i].mesh() {
            placements += 1;
            mesh_used[mesh.index()] = true;
        }
        stack
            .extend(nodes[i].children().map(|c| (c.index(), Some(i), depth + 1)).collect::<Vec<_>>().into_iter().rev());
    }
    let meshes = (0..mesh_used.len()).filter(|&m| mesh_used[m]).collect();
    Ok(Hierarchy { placements, meshes })
}

/// A number of an extension's JSON object, `default` when absent or not a number.
fn json_number(value: &serde_json::Value, key: &str, default: f32) -> f32 {
    value.get(key).and_then(serde_json::Value::as_f64).map_or(default, |x| x as f32)
}

/// An RGB array of an extension's JSON object, `default` when absent or not three numbers.
fn json_colour(value: &serde_json::Value, key: &str, default: Vec3) -> Vec3 {
    let Some(a) = value.get(key).and_then(serde_json::Value::as_array) else { return default };
    match a.iter().map(serde_json::Value::as_f64).collect::<Option<Vec<f64>>>().as_deref() {
        Some(&[r, g, b]) => Vec3::new(r as f32, g as f32, b as f32),
        _ => default,
    }
}

/// Bytes a vertex can take while a mesh is read: position, normal, colour (12 each) and
/// texture coordinates (8), every primitive's arrays filled for all of them.
const VERTEX_BYTES: u64 = 44;
/// Bytes of a triangle: three indices and its material.
const TRIANGLE_BYTES: u64 = 16;
/// Bytes of a placement: the node's record, the scene's instance (with its name) and its part
/// of the BVH ([`crate::sys::memory::BVH_BYTES_PER_INSTANCE`]).
const PLACEMENT_BYTES: u64 = (std::mem::size_of::<MeshNode>() + std::mem::size_of::<crate::scene::Instance>() + 64)
    as u64
    + crate::sys::memory::BVH_BYTES_PER_INSTANCE;

/// Refuses a file whose placed meshes (sized from their accessors' counts, twice: the file's
/// copy and the scene's) and placements do not fit in what is left of the memory budget.
fn check_budget(doc: &gltf::Document, hierarchy: &Hierarchy) -> Result<(), String> {
    let meshes: Vec<gltf::Mesh> = doc.meshes().collect();
    let (mut vertices, mut triangles) = (0u64, 0u64);
    for &m in &hierarchy.meshes {
        for primitive in meshes[m].primitives() {
            let n = primitive.get(&gltf::Semantic::Positions).map_or(0, |a| a.count() as u64);
            vertices = vertices.saturating_add(n);
            let corners = primitive.indices().map_or(n, |a| a.count() as u64);
            triangles = triangles.saturating_add(gltf_modes::triangle_count(primitive.mode(), corners));
        }
    }
    // A node whose morph weights differ from its mesh's may build another copy of the mesh.
    for node in doc.nodes().filter(|n| n.weights().is_some()) {
        for primitive in node.mesh().iter().flat_map(|m| m.primitives()) {
            let n = primitive.get(&gltf::Semantic::Positions).map_or(0, |a| a.count() as u64);
            vertices = vertices.saturating_add(n);
            let corners = primitive.indices().map_or(n, |a| a.count() as u64);
            triangles = triangles.saturating_add(gltf_modes::triangle_count(primitive.mode(), corners));
        }
    }
    let bytes = vertices
        .saturating_mul(VERTEX_BYTES)
        .saturating_add(triangles.saturating_mul(TRIANGLE_BYTES))
        .saturating_mul(2)
        .saturating_add(hierarchy.placements.saturating_mul(PLACEMENT_BYTES));
    let what = format!("its {} mesh placements of {vertices} vertices and {triangles} triangles", hierarchy.placements);
    crate::sys::read::check_memory(bytes, what).map_err(|e| e.to_string())
}

/// The crate's error as one line; validation paths (`accessors[3].count`) become
/// `accessor 3: count`.
fn gltf_error(e: &gltf::Error) -> String {
    match e {
        gltf::Error::Validation(problems) => {
            let (path, problem) = &problems[0];
            let path = path.to_string();
            if path.starts_with("extensionsRequired") {
                return format!("{path}: strahl does not support this required extension");
            }
            let more = match problems.len() {
                1 => String::new(),
                n => format!(" (and {} more problems)", n - 1),
            };
            format!("{}: {problem}{more}", element_of_path(&path))
        }
        gltf::Error::Deserialize(e) => format!("not valid glTF JSON: {e}"),
        gltf::Error::Binary(e) => format!("not a valid GLB file: {e}"),
        e => e.to_string(),
    }
}

/// `accessors[3].count` → `accessor 3: count`; `extensionsRequired[0] = "X"` stays.
fn element_of_path(path: &str) -> String {
    let singular = |plural: &str| match plural {
        "meshes" => "mesh".to_string(),
        p => p.strip_suffix('s').unwrap_or(p).to_string(),
    };
    if let Some((head, rest)) = path.split_once('[') {
        if let Some((index, tail)) = rest.split_once(']') {
            if index.bytes().all(|b| b.is_ascii_digit()) && head.bytes().all(|b| b.is_ascii_alphabetic()) {
                let tail = tail.strip_prefix('.').unwrap_or(tail);
                return if tail.is_empty() {
                    format!("{} {index}", singular(head))
                } else {
                    format!("{} {index}: {tail}", singular(head))
                };
            }
        }
    }
    path.to_string()
}

/// Every buffer's bytes: the GLB binary chunk, a base64 `data:` URI or a file next to the
/// glTF file. A buffer shorter than its `byteLength` is an error naming it. A file named by
/// several buffers is read once, and the files read together may hold no more than the mesh
/// limit ([`crate::sys::read::max_mesh_bytes`]): a small file naming a large one many times cannot
/// make strahl read more than that.
fn read_buffers(
    doc: &gltf::Document,
    base: &Path,
    mut blob: Option<Vec<u8>>,
    files: &mut Vec<PathBuf>,
) -> Result<Vec<Arc<Vec<u8>>>, String> {
    let cap = crate::sys::read::max_mesh_bytes().map_err(|e| e.to_string())?;
    let mut read: HashMap<PathBuf, Arc<Vec<u8>>> = HashMap::new();
    let mut total = 0u64;
    let mut buffers = Vec::new();
    for buffer in doc.buffers() {
        let what = format!("buffer {}", buffer.index());
        let data = match buffer.source() {
            gltf::buffer::Source::Bin => Arc::new(
                blob.take().ok_or_else(|| format!("{what}: refers to the GLB binary chunk, which is missing"))?,
            ),
            gltf::buffer::Source::Uri(uri) if uri.starts_with("data:") => {
                Arc::new(data_uri(uri).map_err(|e| format!("{what}: {e}"))?)
            }
            gltf::buffer::Source::Uri(uri) => {
                let file = uri_file(uri, base).map_err(|e| format!("{what}: {e}"))?;
                match read.get(&file) {
                    Some(data) => data.clone(),
                    None => {
                        let data = crate::sys::read::read_regular(&file, cap, crate::sys::read::MESH_LIMIT_HINT)
                            .map_err(|e| format!("{what}: {}: {e}", file.display()))?;
                        total += data.len() as u64;
                        if total > cap {
                            return Err(format!(
                                "{what}: {}: the buffers' files hold more than the limit of {cap} bytes together{}",
                                file.display(),
                                crate::sys::read::MESH_LIMIT_HINT
                            ));
                        }
                        files.push(file.clone());
                        read.entry(file).or_insert(Arc::new(data)).clone()
                    }
                }
            }
        };
        if data.len() < buffer.length() {
            return Err(format!("{what}: holds {} bytes but byteLength says {}", data.len(), buffer.length()));
        }
        buffers.push(data);
    }
    Ok(buffers)
}

/// The bytes of a base64 `data:` URI.
fn data_uri(uri: &str) -> Result<Vec<u8>, String> {
    let rest = uri.strip_prefix("data:").unwrap_or(uri);
    let (_, data) = rest.split_once(";base64,").ok_or_else(|| "a data: URI that is not base64".to_string())?;
    base64::decode(data).map_err(|e| format!("the data: URI is not valid base64: {e}"))
}

/// The file a URI names: a (percent-encoded) path relative to `base`. glTF's URIs are relative
/// references, so an absolute path (`/etc/passwd`, `%2Fetc%2Fpasswd`) and a URI with a scheme
/// (`file:`, `http://`, a drive `C:`: a colon in the first segment) are refused, before and
/// after decoding, whatever `--confine` says; `../` may climb out of the file's folder
/// (`--confine` bounds where to).
fn uri_file(uri: &str, base: &Path) -> Result<PathBuf, String> {
    let decoded = urlencoding::decode(uri).map_err(|_| format!("URI {uri:?} is not valid percent-encoding"))?;
    for text in [uri, decoded.as_ref()] {
        let first = text.split(['/', '\\']).next().unwrap_or("");
        if text.starts_with(['/', '\\']) || first.contains(':') {
            return Err(format!(
                "URI {uri:?}: only paths relative to the glTF file and data: URIs are read (not absolute paths or other schemes)"
            ));
        }
    }
    if decoded.contains('\0') {
        return Err(format!("URI {uri:?}: a path with a NUL byte"));
    }
    Ok(base.join(decoded.as_ref()))
}

struct Reader<'a> {
    doc: &'a gltf::Document,
    buffers: &'a [Arc<Vec<u8>>],
    base: &'a Path,
    /// Decoded glTF images by source (`view N`, or the URI), shared by every texture whose
    /// image names the same source.
    images: HashMap<String, Arc<Image>>,
    out: GltfFile,
    /// `EXT_mesh_gpu_instancing` by node index.
    instancing: &'a HashMap<usize, Instancing>,
}

/// `KHR_texture_transform` as a texture's `textureInfo` gives it.
struct UvTransform {
    offset: [f32; 2],
    scale: [f32; 2],
    rotation: f32,
    /// Replaces the `textureInfo`'s `texCoord` when given.
    tex_coord: Option<u32>,
}

/// The extension's JSON form, where the gltf crate leaves a `textureInfo` as JSON.
type TextureTransformJson = gltf::json::extensions::texture::TextureTransform;

impl From<TextureTransformJson> for UvTransform {
    fn from(t: TextureTransformJson) -> UvTransform {
        UvTransform { offset: t.offset.0, scale: t.scale.0, rotation: t.rotation.0, tex_coord: t.tex_coord }
    }
}

/// `KHR_texture_transform`'s affine map of glTF texture coordinates (see `Reader::texture`).
fn uv_transform([ou, ov]: [f32; 2], [su, sv]: [f32; 2], rotation: f32) -> [[f32; 3]; 2] {
    let (sin, cos) = rotation.sin_cos();
    [[cos * su, sin * sv, ou], [-sin * su, cos * sv, ov]]
}

/// The material of primitives that name none: strahl's default grey (glTF's own default, a
/// rough white metal, has no Whitted counterpart).
fn default_material() -> Material {
    Material { name: "gltf default".into(), ..Material::default() }
}

impl Reader<'_> {
    fn warn(&mut self, message: String) {
        self.out.warnings.push(message);
    }

    /// Every material as a [`Pbr`] with its lecture form ([`Pbr::lecture_form`]); what strahl
    /// does not render is warned about by name (module docs of [`crate::material`]).
    fn materials(&mut self) -> Result<(), String> {
        let doc = self.doc;
        for material in doc.materials() {
            let i = material.index().unwrap_or(0);
            let what = format!("material {i}");
            // Blender's importer's name for an unnamed material.
            let name = material.name().map_or_else(|| format!("Material_{i}"), str::to_string);
            let pbr = self.pbr(&material, &what)?;
            let coverage = self.coverage(&material, &what)?;
            let m = Material {
                pbr: Some(Box::new(pbr.clone())),
                coverage: coverage.map(Box::new),
                // A one-sided emitter (Blender's one-sided area light) emits from its front.
                emission_one_sided: !material.double_sided(),
                ..pbr.lecture_form(name)
            };
            if let Some(problem) = m.problem() {
                return Err(format!("{what}: {problem}"));
            }
            self.out.materials.push(m);
        }
        Ok(())
    }

    /// The glTF material `material` and the extensions strahl reads, with a warning for each
    /// part it ignores.
    fn pbr(&mut self, material: &gltf::Material, what: &str) -> Result<Pbr, String> {
        let pbr = material.pbr_metallic_roughness();
        let [r, g, b, _] = pbr.base_color_factor();
        let [er, eg, eb] = material.emissive_factor();
        let mut out = Pbr {
            factors: PbrParams {
                base_color: Vec3::new(r, g, b),
                metallic: pbr.metallic_factor(),
                roughness: pbr.roughness_factor(),
                ior: material.ior().unwrap_or(1.5),
                ..PbrParams::default()
            },
            emission: Vec3::new(er, eg, eb) * material.emissive_strength().unwrap_or(1.0),
            unlit: material.unlit(),
            ..Pbr::default()
        };
        if let Some(info) = pbr.base_color_texture() {
            out.base_color_texture = Some(self.info_texture(&info, Encoding::Srgb, what)?);
        }
        if let Some(info) = pbr.metallic_roughness_texture() {
            out.metallic_roughness_texture = Some(self.info_texture(&info, Encoding::Linear, what)?);
        }
        if let Some(info) = material.emissive_texture() {
            out.emissive_texture = Some(self.info_texture(&info, Encoding::Srgb, what)?);
        }
        if let Some(normal) = material.normal_texture() {
            self.normal_texture(&normal, &mut out, what)?;
        }
        if material.occlusion_texture().is_some() {
            self.warn(format!("{what}: occlusionTexture ignored (the path tracer computes occlusion)"));
        }
        let textures = &mut out.extension_textures;
        if let Some(t) = material.transmission() {
            out.factors.transmission = t.transmission_factor();
            if let Some(info) = t.transmission_texture() {
                textures.transmission = Some(self.info_texture(&info, Encoding::Linear, what)?);
            }
        }
        if let Some(v) = material.volume() {
            // thicknessTexture: a ray tracer measures the distance inside (ExtensionTextures).
            out.thickness = v.thickness_factor();
            out.attenuation_color = Vec3::from(v.attenuation_color());
            out.attenuation_distance = v.attenuation_distance();
        }
        if let Some(sp) = material.specular() {
            out.factors.specular = sp.specular_factor();
            out.factors.specular_color = Vec3::from(sp.specular_color_factor());
            if let Some(info) = sp.specular_texture() {
                textures.specular = Some(self.info_texture(&info, Encoding::Alpha, what)?);
            }
            if let Some(info) = sp.specular_color_texture() {
                textures.specular_color = Some(self.info_texture(&info, Encoding::Srgb, what)?);
            }
        }
        for (name, value) in material.extensions().into_iter().flatten() {
            match name.as_str() {
                "KHR_materials_clearcoat" => {
                    out.factors.clearcoat = json_number(value, "clearcoatFactor", 0.0);
                    out.factors.clearcoat_roughness = json_number(value, "clearcoatRoughnessFactor", 0.0);
                    textures.clearcoat = self.json_texture(value, "clearcoatTexture", Encoding::Linear, what)?;
                    textures.clearcoat_roughness =
                        self.json_texture(value, "clearcoatRoughnessTexture", Encoding::Linear, what)?;
                    out.clearcoat_normal_texture =
                        self.json_texture(value, "clearcoatNormalTexture", Encoding::Linear, what)?;
                    out.clearcoat_normal_scale =
                        value.get("clearcoatNormalTexture").map_or(1.0, |info| json_number(info, "scale", 1.0));
                    if let (Some(base), Some(coat)) = (&out.normal_texture, &out.clearcoat_normal_texture) {
                        if base.tex_coord.min(1) != coat.tex_coord.min(1) {
                            self.warn(format!(
                                "{what}: {name}: clearcoatNormalTexture reads TEXCOORD_{} but normalTexture \
                                 TEXCOORD_{}: the coat is mapped with the tangents of the latter",
                                coat.tex_coord, base.tex_coord
                            ));
                        }
                    }
                }
                "KHR_materials_sheen" => {
                    out.factors.sheen_color = json_colour(value, "sheenColorFactor", Vec3::ZERO);
                    out.factors.sheen_roughness = json_number(value, "sheenRoughnessFactor", 0.0);
                    textures.sheen_color = self.json_texture(value, "sheenColorTexture", Encoding::Srgb, what)?;
                    textures.sheen_roughness =
                        self.json_texture(value, "sheenRoughnessTexture", Encoding::Alpha, what)?;
                }
                other => self.warn(format!("{what}: extension {other} is not supported; ignored")),
            }
        }
        Ok(out)
    }

    /// `normalTexture` (linear) with its `scale`, `texCoord` and `KHR_texture_transform`, into `out`.
    fn normal_texture(
        &mut self,
        normal: &gltf::material::NormalTexture,
        out: &mut Pbr,
        what: &str,
    ) -> Result<(), String> {
        let transform = match normal.extension_value("KHR_texture_transform") {
            Some(value) => Some(
                serde_json::from_value::<TextureTransformJson>(value.clone())
                    .map_err(|e| format!("{what}: normalTexture: KHR_texture_transform: {e}"))?
                    .into(),
            ),
            None => None,
        };
        out.normal_texture =
            Some(self.texture(&normal.texture(), normal.tex_coord(), transform, Encoding::Linear, what)?);
        out.normal_scale = normal.scale();
        Ok(())
    }

    /// Which hits on the material's surface exist ([`crate::scene::alpha`]): `alphaMode`,
    /// `alphaCutoff` (default 0.5), the base colour's alpha (factor, and the base colour
    /// texture's alpha plane), `doubleSided`.
    fn coverage(&mut self, material: &gltf::Material, what: &str) -> Result<Option<Coverage>, String> {
        let mode = match material.alpha_mode() {
            gltf::material::AlphaMode::Opaque => AlphaMode::Opaque,
            gltf::material::AlphaMode::Mask => AlphaMode::Mask { cutoff: material.alpha_cutoff().unwrap_or(0.5) },
            gltf::material::AlphaMode::Blend => AlphaMode::Blend,
        };
        let pbr = material.pbr_metallic_roughness();
        let texture = match (mode, pbr.base_color_texture()) {
            (AlphaMode::Opaque, _) | (_, None) => None,
            (_, Some(info)) => Some(self.info_texture(&info, Encoding::Alpha, what)?),
        };
        let coverage = Coverage::of(mode, pbr.base_color_factor()[3], texture, material.double_sided());
        if let Some(problem) = coverage.as_ref().and_then(Coverage::problem) {
            return Err(format!("{what}: {problem}"));
        }
        Ok(coverage)
    }

    /// A texture of a `textureInfo` the gltf crate reads (validated by it), with its
    /// `texCoord` and `KHR_texture_transform`.
    fn info_texture(
        &mut self,
        info: &gltf::texture::Info,
        encoding: Encoding,
        what: &str,
    ) -> Result<TextureSlot, String> {
        let transform = info.texture_transform().map(|t| UvTransform {
            offset: t.offset(),
            scale: t.scale(),
            rotation: t.rotation(),
            tex_coord: t.tex_coord(),
        });
        self.texture(&info.texture(), info.tex_coord(), transform, encoding, what)
    }

    /// The texture of the `textureInfo` named `key` in an extension's JSON object `value`
    /// (`KHR_materials_clearcoat`, `_sheen`: extensions the gltf crate leaves as JSON, so
    /// their texture index is checked here), `None` when it has none.
    fn json_texture(
        &mut self,
        value: &serde_json::Value,
        key: &str,
        encoding: Encoding,
        what: &str,
    ) -> Result<Option<TextureSlot>, String> {
        let Some(info) = value.get(key) else { return Ok(None) };
        let info: gltf::json::texture::Info =
            serde_json::from_value(info.clone()).map_err(|e| format!("{what}: {key}: {e}"))?;
        let index = info.index.value();
        let count = self.doc.textures().len();
        let texture = self
            .doc
            .textures()
            .nth(index)
            .ok_or_else(|| format!("{what}: {key}: texture {index} does not exist (the file has {count})"))?;
        let transform = info.extensions.and_then(|e| e.texture_transform).map(UvTransform::from);
        self.texture(&texture, info.tex_coord, transform, encoding, what).map(Some)
    }

    /// A material's texture: its image (decoded once per file and encoding) with its sampler's
    /// wrap modes, the texture coordinate set it reads, and its `KHR_texture_transform`:
    /// `uv' = T(offset) · R(rotation) · S(scale) · uv` in glTF's coordinates (u right, v down
    /// the image), the rotation turning the image clockwise on the surface:
    ///
    /// ```text
    /// u' =  cos·s_u·u + sin·s_v·v + o_u
    /// v' = −sin·s_u·u + cos·s_v·v + o_v
    /// ```
    ///
    /// This is the sign of the Khronos sample model TextureTransformTest (its arrow then points
    /// at the green marker; tests/khronos_models.rs), of the Khronos sample viewer, three.js
    /// and Blender's importer. The GLSL sketch in the extension's text,
    /// `mat3(cos, sin, 0, −sin, cos, 0, 0, 0, 1)` read column-major, gives the opposite sign,
    /// which points the sample model's arrow at its red "wrong direction" marker.
    ///
    /// and its `texCoord`, when given, in place of the texture's.
    fn texture(
        &mut self,
        texture: &gltf::Texture,
        tex_coord: u32,
        transform: Option<UvTransform>,
        encoding: Encoding,
        what: &str,
    ) -> Result<TextureSlot, String> {
        let mut tex_coord = transform.as_ref().and_then(|t| t.tex_coord).unwrap_or(tex_coord);
        let matrix = transform.map(|t| uv_transform(t.offset, t.scale, t.rotation));
        if matrix.is_some_and(|m| !m.iter().flatten().all(|x| x.is_finite())) {
            return Err(format!(
                "{what}: texture {}: KHR_texture_transform has a value that is not finite",
                texture.index()
            ));
        }
        if tex_coord > 1 {
            self.warn(format!("{what}: texture {} uses TEXCOORD_{tex_coord}; TEXCOORD_0 is used", texture.index()));
            tex_coord = 0;
        }
        let image = texture.source();
        let index = image.index();
        let key = match image.source() {
            gltf::image::Source::View { view, .. } => format!("{encoding:?} view {}", view.index()),
            gltf::image::Source::Uri { uri, .. } => format!("{encoding:?} {uri}"),
        };
        let decoded = match self.images.get(&key) {
            Some(decoded) => decoded.clone(),
            None => {
                let decoded = self
                    .image(&image, encoding)
                    .map_err(|e| format!("{what}: texture {}: image {index}: {e}", texture.index()))?;
                self.images.insert(key, decoded.clone());
                decoded
            }
        };
        let wrap = |mode| match mode {
            gltf::texture::WrappingMode::Repeat => Wrap::Repeat,
            gltf::texture::WrappingMode::ClampToEdge => Wrap::Clamp,
            gltf::texture::WrappingMode::MirroredRepeat => Wrap::MirroredRepeat,
        };
        let sampler = texture.sampler();
        let texture = ImageTexture {
            image: decoded,
            wrap_u: wrap(sampler.wrap_s()),
            wrap_v: wrap(sampler.wrap_t()),
            factor: Vec3::ONE,
            mipmaps: !matches!(
                sampler.min_filter(),
                Some(gltf::texture::MinFilter::Nearest | gltf::texture::MinFilter::Linear)
            ),
        };
        Ok(TextureSlot { texture, tex_coord, transform: matrix })
    }

    fn image(&mut self, image: &gltf::Image, encoding: Encoding) -> Result<Arc<Image>, String> {
        match image.source() {
            gltf::image::Source::View { view, .. } => {
                let bytes = self.view_bytes(&view)?;
                Ok(Arc::new(Image::decode_as(bytes, &format!("buffer view {}", view.index()), encoding)?))
            }
            gltf::image::Source::Uri { uri, .. } if uri.starts_with("data:") => {
                Ok(Arc::new(Image::decode_as(&data_uri(uri)?, "its data: URI", encoding)?))
            }
            gltf::image::Source::Uri { uri, .. } => {
                let file = uri_file(uri, self.base)?;
                let image = open_shared_as(&file, encoding)?;
                self.out.files.push(file);
                Ok(image)
            }
        }
    }

    fn view_bytes(&self, view: &gltf::buffer::View) -> Result<&[u8], String> {
        let buffer: &[u8] = &self.buffers[view.buffer().index()];
        let (start, length) = (view.offset(), view.length());
        start.checked_add(length).and_then(|end| buffer.get(start..end)).ok_or_else(|| {
            format!(
                "buffer view {}: bytes {start}..+{length} lie outside buffer {} ({} bytes)",
                view.index(),
                view.buffer().index(),
                buffer.len()
            )
        })
    }

    /// Checks that accessor `a` can be read as `count` elements of the given types from its
    /// buffer view: its bytes inside the view, the view inside its buffer.
    fn check_accessor(
        &self,
        a: &gltf::Accessor,
        types: &[DataType],
        dims: &[Dimensions],
        what: &str,
    ) -> Result<(), String> {
        let name = format!("accessor {}", a.index());
        if !types.contains(&a.data_type()) || !dims.contains(&a.dimensions()) {
            return Err(format!(
                "{name} ({what}): {:?} {:?} is not a type strahl reads for it",
                a.dimensions(),
                a.data_type()
            ));
        }
        if let Some(sparse) = a.sparse() {
            let named = format!("{name} ({what})");
            gltf_sparse::check_sparse(a, &sparse, |v| self.view_bytes(v), &named)?;
            if a.view().is_none() {
                return Ok(()); // zeros, then the sparse values
            }
        }
        let Some(view) = a.view() else {
            return Err(format!("{name} ({what}): has no bufferView (all-zero accessors are not supported)"));
        };
        let view_bytes = self.view_bytes(&view)?;
        let element = a.size();
        let stride = view.stride().unwrap_or(element);
        if a.count() == 0 {
            return Ok(());
        }
        let needed = (a.count() - 1)
            .checked_mul(stride)
            .and_then(|n| n.checked_add(element))
            .and_then(|n| n.checked_add(a.offset()));
        match needed {
            Some(n) if n <= view_bytes.len() => Ok(()),
            _ => Err(format!(
                "{name} ({what}): {} elements of {element} bytes (stride {stride}) from byte {} need more than the {} bytes of buffer view {}",
                a.count(),
                a.offset(),
                view_bytes.len(),
                view.index()
            )),
        }
    }

    /// Places `node` and its children (a forest, [`check_hierarchy`] made sure).
    fn node(&mut self, node: &gltf::Node, parent: &Transform, meshes: &mut MeshSlots) -> Result<(), String> {
        let what = format!("node {}", node.index());
        let local = match node.transform() {
            gltf::scene::Transform::Matrix { matrix } => DMat4::from_cols_array_2d(&matrix.map(|c| c.map(f64::from))),
            gltf::scene::Transform::Decomposed { translation, rotation, scale } => {
                let [x, y, z, w] = rotation.map(f64::from);
                let q = DQuat::from_xyzw(x, y, z, w);
                let q = if q.length() > 0.0 { q.normalize() } else { q };
                DMat4::from_scale_rotation_translation(
                    DVec3::from(scale.map(f64::from)),
                    q,
                    DVec3::from(translation.map(f64::from)),
                )
            }
        };
        let local = match Transform::from_matrix(local) {
            Ok(t) => t,
            Err(problem) => {
                self.warn(format!("{what}: skipped with its children: {problem}"));
                return Ok(());
            }
        };
        let world = local.then(parent);
        if let Some(mesh) = node.mesh() {
            let weights = gltf_morph::weights(node, &mesh);
            let index = meshes.slot(mesh.index(), weights, mesh.weights().unwrap_or(&[]));
            if meshes.meshes[index].is_none() {
                meshes.meshes[index] = Some(self.mesh(&mesh, weights)?);
            }
            if meshes.meshes[index].as_ref().is_some_and(|m| !m.indices.is_empty()) {
                self.place(node, index, &world)?;
            }
        }
        if let Some(camera) = node.camera() {
            self.camera(&camera, node, &world);
        }
        if let Some(light) = node.light() {
            self.light(&light, &world, &what)?;
        }
        for child in node.children() {
            self.node(&child, &world, meshes)?;
        }
        Ok(())
    }

    /// Places mesh slot `mesh` by `node`: once, or once per `EXT_mesh_gpu_instancing` instance.
    fn place(&mut self, node: &gltf::Node, mesh: usize, world: &Transform) -> Result<(), String> {
        let Some(inst) = self.instancing.get(&node.index()) else {
            let name = node.name().map(str::to_string);
            self.out.nodes.push(MeshNode { node: node.index(), name, mesh, instance: None, transform: *world });
            return Ok(());
        };
        let check =
            |a: &gltf::Accessor, t: &[DataType], d: &[Dimensions], what: &str| self.check_accessor(a, t, d, what);
        let (placed, skipped) =
            gltf_instancing::instance_transforms(self.doc, self.buffers, node.index(), inst, check)?;
        for (k, t) in placed {
            let (name, transform) = (node.name().map(str::to_string), t.then(world));
            self.out.nodes.push(MeshNode { node: node.index(), name, mesh, instance: Some(k), transform });
        }
        if skipped > 0 {
            self.warn(format!(
                "node {}: EXT_mesh_gpu_instancing: {skipped} instances with a singular transform skipped",
                node.index()
            ));
        }
        Ok(())
    }

    /// A perspective camera (`yfov`, `aspectRatio`) or an orthographic one (`ymag` the half
    /// height of its view, `xmag / ymag` its aspect ratio), at the node's origin looking along
    /// its −z with +y up.
    fn camera(&mut self, camera: &gltf::Camera, node: &gltf::Node, world: &Transform) {
        let eye = world.point_f64(DVec3::ZERO);
        let forward = world.vector_f64(-DVec3::Z).normalize();
        let up = world.vector_f64(DVec3::Y).normalize();
        let mut spec = CameraSpec {
            eye: eye.as_vec3(),
            target: (eye + forward).as_vec3(),
            up: up.as_vec3(),
            fov_deg: CameraSpec::default().fov_deg,
            lens: Default::default(),
        };
        let aspect_ratio = match camera.projection() {
            gltf::camera::Projection::Perspective(p) => {
                spec.fov_deg = p.yfov().to_degrees();
                p.aspect_ratio()
            }
            gltf::camera::Projection::Orthographic(o) => {
                let (xmag, ymag) = (o.xmag(), o.ymag());
                if !(xmag.is_finite() && ymag.is_finite() && xmag != 0.0 && ymag != 0.0) {
                    let what = format!("camera {}: orthographic xmag {xmag}, ymag {ymag}", camera.index());
                    self.warn(format!("{what} are not finite and non-zero; skipped"));
                    return;
                }
                spec.lens.ortho_half_height = ymag.abs();
                Some(xmag.abs() / ymag.abs())
            }
        };
        let (name, node_name) = (camera.name().map(str::to_string), node.name().map(str::to_string));
        self.out.cameras.push(GltfCamera { index: camera.index(), name, node_name, spec, aspect_ratio });
    }

    fn light(&mut self, light: &gltf::khr_lights_punctual::Light, world: &Transform, what: &str) -> Result<(), String> {
        use gltf::khr_lights_punctual::Kind;
        let colour = Vec3::from(light.color()) * light.intensity();
        let position = world.point_f64(DVec3::ZERO).as_vec3();
        let l = match light.kind() {
            Kind::Point => Light::Point { position, intensity: colour },
            Kind::Spot { .. } => {
                self.warn(format!(
                    "light {}: a spot light is rendered as a point light (its cone is ignored)",
                    light.index()
                ));
                Light::Point { position, intensity: colour }
            }
            Kind::Directional => {
                let direction = world.vector_f64(-DVec3::Z).normalize().as_vec3();
                Light::Directional { direction, irradiance: colour }
            }
        };
        if let Some(problem) = l.problem() {
            return Err(format!("{what}: light {}: {problem}", light.index()));
        }
        self.out.lights.push(l);
        Ok(())
    }

    /// Glue all triangle primitives of `mesh` (triangles, strips and fans), morphed by
    /// `weights`, into one strahl mesh.
    fn mesh(&mut self, mesh: &gltf::Mesh, weights: &[f32]) -> Result<Mesh, String> {
        let mut out = Mesh {
            // Blender's importer's name for an unnamed mesh.
            name: mesh.name().map_or_else(|| format!("Mesh_{}", mesh.index()), str::to_string),
            ..Mesh::default()
        };
        let (mut normals, mut colors, mut uvs, mut uvs1) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        let (mut any_normals, mut any_colors, mut any_uvs, mut any_uvs1) = (false, false, false, false);
        let (mut alphas, mut any_alphas) = (Vec::new(), false);
        let mut materials = Vec::new();
        // Tangents, for the primitives whose material has a normal map: `TANGENT`, or the
        // triangles and texture coordinate set MikkTSpace computes them from.
        let (mut tangents, mut any_tangents, mut mikktspace) = (Vec::new(), false, Vec::new());
        for primitive in mesh.primitives() {
            let what = format!("mesh {} primitive {}", mesh.index(), primitive.index());
            if !matches!(primitive.mode(), Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan) {
                self.warn(format!("{what}: mode {:?} is not triangles; skipped", primitive.mode()));
                continue;
            }
            let Some(positions) = primitive.get(&gltf::Semantic::Positions) else {
                self.warn(format!("{what}: has no POSITION; skipped"));
                continue;
            };
            let f32v3 = (&[DataType::F32][..], &[Dimensions::Vec3][..]);
            self.check_accessor(&positions, f32v3.0, f32v3.1, &format!("{what} POSITION"))?;
            let buffers = self.buffers;
            let reader = primitive.reader(|b| buffers.get(b.index()).map(|d| d.as_slice()));
            let first = out.positions.len();
            let mut p: Vec<Vec3> = reader.read_positions().into_iter().flatten().map(Vec3::from).collect();
            let n = p.len();
            let check = |a: &gltf::Accessor, t: &[DataType], d: &[Dimensions], name: &str| {
                self.check_accessor(a, t, d, &format!("{what} {name}"))
            };
            gltf_morph::displace(&primitive, self.buffers, weights, gltf_morph::Attribute::Position, &mut p, check)?;
            out.positions.extend(p);
            if let Some(a) = primitive.get(&gltf::Semantic::Normals) {
                self.check_accessor(&a, f32v3.0, f32v3.1, &format!("{what} NORMAL"))?;
                if a.count() != n {
                    return Err(format!("{what}: NORMAL has {} elements for {n} positions", a.count()));
                }
                let mut v: Vec<Vec3> = reader.read_normals().into_iter().flatten().map(Vec3::from).collect();
                gltf_morph::displace(&primitive, self.buffers, weights, gltf_morph::Attribute::Normal, &mut v, check)?;
                normals.extend(v.into_iter().map(Vec3::normalize_or_zero));
                any_normals = true;
            } else {
                normals.extend(std::iter::repeat_n(Vec3::ZERO, n));
            }
            if let Some(a) = primitive.get(&gltf::Semantic::Colors(0)) {
                let types = [DataType::F32, DataType::U8, DataType::U16];
                self.check_accessor(&a, &types, &[Dimensions::Vec3, Dimensions::Vec4], &format!("{what} COLOR_0"))?;
                if a.count() != n {
                    return Err(format!("{what}: COLOR_0 has {} elements for {n} positions", a.count()));
                }
                colors.extend(reader.read_colors(0).into_iter().flat_map(|c| c.into_rgb_f32()).map(Vec3::from));
                any_colors = true;
                if a.dimensions() == Dimensions::Vec4 {
                    alphas.extend(reader.read_colors(0).into_iter().flat_map(|c| c.into_rgba_f32()).map(|c| c[3]));
                    any_alphas = true;
                } else {
                    alphas.extend(std::iter::repeat_n(1.0, n));
                }
            } else {
                colors.extend(std::iter::repeat_n(Vec3::ONE, n));
                alphas.extend(std::iter::repeat_n(1.0, n));
            }
            for (set, uvs, any) in [(0, &mut uvs, &mut any_uvs), (1, &mut uvs1, &mut any_uvs1)] {
                let Some(a) = primitive.get(&gltf::Semantic::TexCoords(set)) else {
                    uvs.extend(std::iter::repeat_n(Vec2::ZERO, n));
                    continue;
                };
                let types = [DataType::F32, DataType::U8, DataType::U16];
                self.check_accessor(&a, &types, &[Dimensions::Vec2], &format!("{what} TEXCOORD_{set}"))?;
                if a.count() != n {
                    return Err(format!("{what}: TEXCOORD_{set} has {} elements for {n} positions", a.count()));
                }
                // glTF's (0, 0) is the image's top-left; strahl's (OBJ's) its bottom-left.
                uvs.extend(
                    reader
                        .read_tex_coords(set)
                        .into_iter()
                        .flat_map(|t| t.into_f32())
                        .map(|[u, v]| Vec2::new(u, 1.0 - v)),
                );
                *any = true;
            }
            let triangles_before = out.indices.len();
            let corners: Vec<u32> = match primitive.indices() {
                Some(a) => {
                    self.check_accessor(
                        &a,
                        &[DataType::U8, DataType::U16, DataType::U32],
                        &[Dimensions::Scalar],
                        &format!("{what} indices"),
                    )?;
                    let idx: Vec<u32> = reader.read_indices().into_iter().flat_map(|i| i.into_u32()).collect();
                    if let Some(bad) = idx.iter().position(|&i| i as usize >= n) {
                        return Err(format!(
                            "accessor {} ({what} indices): index {bad} is {}, out of range for {n} vertices",
                            a.index(),
                            idx[bad]
                        ));
                    }
                    idx
                }
                None => (0..n as u32).collect(),
            };
            let Some(triangles) = gltf_modes::triangles(primitive.mode(), &corners) else {
                return Err(match primitive.indices() {
                    Some(a) => format!(
                        "accessor {} ({what} indices): {} indices are not whole triangles",
                        a.index(),
                        corners.len()
                    ),
                    None => format!("{what}: {n} vertices without indices are not whole triangles"),
                });
            };
            let base = first as u32;
            out.indices.extend(triangles.into_iter().map(|t| t.map(|i| i + base)));
            let material = primitive.material().index().map_or(u32::MAX, |i| i as u32);
            let normal_set = self.out.materials.get(material as usize).and_then(|m| m.pbr.as_deref());
            let normal_set = normal_set.and_then(|p| p.tangent_set());
            match (normal_set, primitive.get(&gltf::Semantic::Tangents)) {
                // Without NORMAL, glTF asks for flat normals and its TANGENT to be ignored.
                (Some(_), Some(a)) if primitive.get(&gltf::Semantic::Normals).is_some() => {
                    self.check_accessor(&a, &[DataType::F32], &[Dimensions::Vec4], &format!("{what} TANGENT"))?;
                    if a.count() != n {
                        return Err(format!("{what}: TANGENT has {} elements for {n} positions", a.count()));
                    }
                    tangents.extend(reader.read_tangents().into_iter().flatten().map(Vec4::from));
                    any_tangents = true;
                }
                (Some(set), _) => {
                    tangents.extend(std::iter::repeat_n(Vec4::ZERO, n));
                    any_tangents = true;
                    if primitive.get(&gltf::Semantic::TexCoords(set)).is_some() {
                        mikktspace.push((what, triangles_before..out.indices.len(), set));
                    } else {
                        self.warn(format!("{what}: has no TEXCOORD_{set} for its normalTexture, which is ignored"));
                    }
                }
                (None, _) => tangents.extend(std::iter::repeat_n(Vec4::ZERO, n)),
            }
            materials.extend(std::iter::repeat_n(material, out.indices.len() - triangles_before));
        }
        if let Some(problem) = crate::scene::mesh::triangles_problem(&out.positions, &out.indices) {
            return Err(format!("mesh {}: {problem}", mesh.index()));
        }
        if materials.contains(&u32::MAX) {
            let id = self.out.materials.iter().position(|m| m.name == "gltf default").unwrap_or_else(|| {
                self.out.materials.push(default_material());
                self.out.materials.len() - 1
            }) as u32;
            materials.iter_mut().filter(|m| **m == u32::MAX).for_each(|m| *m = id);
        }
        out.normals = any_normals.then_some(normals);
        out.colors = any_colors.then_some(colors);
        out.alphas = any_alphas.then_some(alphas);
        out.uvs = any_uvs.then_some(uvs);
        out.uvs1 = any_uvs1.then_some(uvs1);
        out.tangents = any_tangents.then_some(tangents);
        for (what, triangles, set) in mikktspace {
            if !crate::scene::tangents::mikktspace(&mut out, triangles, set) {
                self.warn(format!("{what}: MikkTSpace found no tangents; its normalTexture is ignored"));
            }
        }
        match materials.first() {
            Some(&first) if materials.iter().all(|&m| m == first) => out.material = first,
            Some(_) => out.triangle_materials = Some(materials),
            None => {}
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn validation_paths_name_the_element() {
        assert_eq!(element_of_path("accessors[3].count"), "accessor 3: count");
        assert_eq!(element_of_path("meshes[0]"), "mesh 0");
    }
}
