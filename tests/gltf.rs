//! glTF import: files written here by a small builder (independent of strahl's reader: raw
//! JSON and little-endian bytes, embedded as base64 or in a GLB), rendered and compared with
//! the same scene written by hand in TOML; image textures checked against the analytic texel
//! colours (sRGB decoded exactly); and bad files refused with one line naming the element.

mod common;

use common::{TempDir, channel, fails, read_exr, render, same_bits, strahl, text};
use strahl::scene::{from_gltf_file, from_toml_str};
use strahl::texture::srgb_to_linear;

/// A glTF document under construction: one binary buffer, its views and accessors, and the
/// JSON of the other top-level arrays.
#[derive(Clone, Default)]
struct Gltf {
    bin: Vec<u8>,
    views: Vec<String>,
    accessors: Vec<String>,
    meshes: Vec<String>,
    nodes: Vec<String>,
    roots: Vec<usize>,
    cameras: Vec<String>,
    materials: Vec<String>,
    textures: Vec<String>,
    images: Vec<String>,
    samplers: Vec<String>,
    lights: Vec<String>,
    extra_top: Vec<String>,
}

impl Gltf {
    /// Appends `bytes` as a buffer view and an accessor over it; returns the accessor.
    fn accessor(&mut self, bytes: &[u8], count: usize, ty: &str, component: u32, minmax: &str) -> usize {
        while self.bin.len() % 4 != 0 {
            self.bin.push(0);
        }
        let view = self.views.len();
        self.views.push(format!(r#"{{"buffer":0,"byteOffset":{},"byteLength":{}}}"#, self.bin.len(), bytes.len()));
        self.bin.extend_from_slice(bytes);
        self.accessors.push(format!(
            r#"{{"bufferView":{view},"componentType":{component},"count":{count},"type":"{ty}"{minmax}}}"#
        ));
        self.accessors.len() - 1
    }

    fn vec3(&mut self, v: &[[f32; 3]]) -> usize {
        let bytes: Vec<u8> = v.iter().flatten().flat_map(|x| x.to_le_bytes()).collect();
        let (mut lo, mut hi) = ([f32::MAX; 3], [f32::MIN; 3]);
        for p in v {
            for i in 0..3 {
                lo[i] = lo[i].min(p[i]);
                hi[i] = hi[i].max(p[i]);
            }
        }
        self.accessor(&bytes, v.len(), "VEC3", 5126, &format!(r#","min":{lo:?},"max":{hi:?}"#))
    }

    fn vec2(&mut self, v: &[[f32; 2]]) -> usize {
        let bytes: Vec<u8> = v.iter().flatten().flat_map(|x| x.to_le_bytes()).collect();
        self.accessor(&bytes, v.len(), "VEC2", 5126, "")
    }

    fn indices(&mut self, idx: &[u16]) -> usize {
        let bytes: Vec<u8> = idx.iter().flat_map(|x| x.to_le_bytes()).collect();
        self.accessor(&bytes, idx.len(), "SCALAR", 5123, "")
    }

    /// A mesh of one triangle primitive; returns the mesh.
    fn mesh(&mut self, positions: &[[f32; 3]], indices: Option<&[u16]>, extra: &str) -> usize {
        let p = self.vec3(positions);
        let indices = indices.map(|i| format!(r#","indices":{}"#, self.indices(i))).unwrap_or_default();
        self.meshes.push(format!(r#"{{"primitives":[{{"attributes":{{"POSITION":{p}{extra}}}{indices}}}]}}"#));
        self.meshes.len() - 1
    }

    fn node(&mut self, json: String, root: bool) -> usize {
        self.nodes.push(json);
        if root {
            self.roots.push(self.nodes.len() - 1);
        }
        self.nodes.len() - 1
    }

    /// The document with the buffer embedded as a base64 data URI.
    fn json(&self) -> String {
        let uri = format!("data:application/octet-stream;base64,{}", base64::encode(&self.bin));
        self.json_with_buffer(&format!(r#"{{"byteLength":{},"uri":"{uri}"}}"#, self.bin.len()))
    }

    fn json_with_buffer(&self, buffer: &str) -> String {
        let list = |name: &str, items: &[String]| {
            if items.is_empty() { String::new() } else { format!(r#","{name}":[{}]"#, items.join(",")) }
        };
        let lights = if self.lights.is_empty() {
            String::new()
        } else {
            format!(
                r#","extensionsUsed":["KHR_lights_punctual"],"extensions":{{"KHR_lights_punctual":{{"lights":[{}]}}}}"#,
                self.lights.join(",")
            )
        };
        format!(
            r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":{:?}}}],"buffers":[{buffer}]{}{}{}{}{}{}{}{}{}{lights}{}}}"#,
            self.roots,
            list("bufferViews", &self.views),
            list("accessors", &self.accessors),
            list("meshes", &self.meshes),
            list("nodes", &self.nodes),
            list("cameras", &self.cameras),
            list("materials", &self.materials),
            list("textures", &self.textures),
            list("images", &self.images),
            list("samplers", &self.samplers),
            self.extra_top.iter().map(|s| format!(",{s}")).collect::<String>(),
        )
    }

    /// The document as a GLB: header, JSON chunk, BIN chunk.
    fn glb(&self) -> Vec<u8> {
        let mut json = self.json_with_buffer(&format!(r#"{{"byteLength":{}}}"#, self.bin.len())).into_bytes();
        while json.len() % 4 != 0 {
            json.push(b' ');
        }
        let mut bin = self.bin.clone();
        while bin.len() % 4 != 0 {
            bin.push(0);
        }
        let total = 12 + 8 + json.len() + 8 + bin.len();
        let mut out = Vec::new();
        out.extend_from_slice(b"glTF");
        out.extend_from_slice(&2u32.to_le_bytes());
        out.extend_from_slice(&(total as u32).to_le_bytes());
        out.extend_from_slice(&(json.len() as u32).to_le_bytes());
        out.extend_from_slice(b"JSON");
        out.extend_from_slice(&json);
        out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
        out.extend_from_slice(b"BIN\0");
        out.extend_from_slice(&bin);
        out
    }
}

const QUAD: [[f32; 3]; 4] = [[-1.0, -1.0, 0.0], [1.0, -1.0, 0.0], [1.0, 1.0, 0.0], [-1.0, 1.0, 0.0]];
const QUAD_INDICES: [u16; 6] = [0, 1, 2, 0, 2, 3];
const TRIANGLE: [[f32; 3]; 3] = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];

/// The field of view in degrees strahl makes of `yfov` radians, printed so that TOML reads the
/// same f32 back.
fn fov_deg(yfov: f32) -> String {
    format!("{:?}", yfov.to_degrees())
}

/// A scene of a quad and a triangle under a node hierarchy (a parent with TRS, a child with a
/// matrix, a non-indexed primitive), a camera, a point light and a sun; and the same scene in
/// TOML.
fn hierarchy_scene() -> (Gltf, String) {
    let mut g = Gltf::default();
    g.materials.push(r#"{"name":"red","pbrMetallicRoughness":{"baseColorFactor":[0.8,0.2,0.1,1],"metallicFactor":0,"roughnessFactor":1}}"#.into());
    g.materials.push(r#"{"name":"grey","pbrMetallicRoughness":{"baseColorFactor":[0.5,0.5,0.5,1],"metallicFactor":0,"roughnessFactor":1}}"#.into());
    let quad = g.mesh(&QUAD, Some(&QUAD_INDICES), "");
    g.meshes[quad] = g.meshes[quad].replace(r#""indices""#, r#""material":1,"indices""#);
    let tri = g.mesh(&TRIANGLE, None, "");
    g.meshes[tri] = g.meshes[tri].replace("}}]}", r#"},"material":0}]}"#);
    // Child: a matrix translating by (0.25, 0, 0.5); parent: scale 2, translate (0, -0.5, 0).
    let child = g.node(format!(r#"{{"mesh":{tri},"matrix":[1,0,0,0, 0,1,0,0, 0,0,1,0, 0.25,0,0.5,1]}}"#), false);
    g.node(format!(r#"{{"mesh":{quad},"children":[{child}],"translation":[0,-0.5,0],"scale":[2,2,2]}}"#), true);
    let yfov = 0.7f32;
    g.cameras
        .push(format!(r#"{{"type":"perspective","perspective":{{"yfov":{yfov},"znear":0.1,"aspectRatio":1.5}}}}"#));
    g.node(r#"{"camera":0,"translation":[0,0,6]}"#.into(), true);
    g.lights.push(r#"{"type":"point","intensity":20,"color":[1,0.5,0.25]}"#.into());
    g.lights.push(r#"{"type":"directional","intensity":2}"#.into());
    g.node(r#"{"extensions":{"KHR_lights_punctual":{"light":0}},"translation":[1,2,3]}"#.into(), true);
    // The sun shines along its node's −z: rotated −90° about x it points down (−y).
    let s = std::f32::consts::FRAC_1_SQRT_2;
    g.node(format!(r#"{{"extensions":{{"KHR_lights_punctual":{{"light":1}}}},"rotation":[{},0,0,{s}]}}"#, -s), true);
    let toml = format!(
        r#"
[camera]
eye = [0, 0, 6]
target = [0, 0, 5]
fov_deg = {fov}
[image]
width = 640
height = 427
[materials.red]
diffuse = [0.8, 0.2, 0.1]
[materials.grey]
diffuse = 0.5
[[lights]]
type = "point"
position = [1, 2, 3]
intensity = [20, 10, 5]
[[lights]]
type = "directional"
direction = [0, -1, 0]
irradiance = 2
[[objects]]
type = "triangles"
material = "grey"
positions = [[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]]
indices = [[0, 1, 2], [0, 2, 3]]
scale = 2
translate = [0, -0.5, 0]
[[objects]]
type = "triangles"
material = "red"
positions = [[0.5, -0.5, 1], [2.5, -0.5, 1], [0.5, 1.5, 1]]
indices = [[0, 1, 2]]
"#,
        fov = fov_deg(yfov)
    );
    (g, toml)
}

#[test]
fn a_hierarchy_renders_like_the_same_scene_in_toml() {
    let dir = TempDir::new("gltf-hierarchy");
    let (g, toml) = hierarchy_scene();
    let path = dir.write("h.gltf", g.json());
    let loaded = from_gltf_file(&path, None).unwrap();
    assert!(loaded.warnings.is_empty(), "{:?}", loaded.warnings);
    let expected = from_toml_str(&toml, &dir.path("h.toml")).unwrap().scene;
    assert_eq!(loaded.scene.camera, expected.camera);
    assert_eq!((loaded.scene.image.width, loaded.scene.image.height), (640, 427));
    // Light direction and colour come out exact; the sun's direction to within rounding.
    assert_eq!(loaded.scene.lights[0], expected.lights[0]);
    // The Whitted integrator, which renders a glTF material in its lecture form (as the
    // scene by hand has it); the path tracer shades glTF materials with the glTF BSDF.
    let (a, _) = render(&whitted(loaded.scene.clone()));
    let (b, _) = render(&whitted(expected.clone()));
    let mut hit = 0;
    for i in 0..a.depth.len() {
        assert_eq!(a.depth[i].to_bits(), b.depth[i].to_bits(), "Z at {i}");
        assert_eq!(a.normal[i], b.normal[i], "N at {i}");
        for c in 0..3 {
            let (x, y) = (a.rgba[i][c], b.rgba[i][c]);
            assert!((x - y).abs() <= 1e-4 * y.abs().max(1e-3), "RGB at {i}: {x} vs {y}");
        }
        hit += a.depth[i].is_finite() as usize;
    }
    assert!(hit > 10_000, "the objects cover the frame ({hit} pixels)");
}

/// Two cameras, each named apart from its node (as Blender writes them once either is renamed):
/// `--camera` finds each by its index, its own name and its node's name, and a name that matches
/// none is refused in one line listing the cameras there are.
#[test]
fn a_camera_is_found_by_index_name_or_node_name() {
    let dir = TempDir::new("gltf-camera-names");
    let (mut g, _) = hierarchy_scene();
    g.cameras[0] = g.cameras[0].replacen('{', r#"{"name":"FrontLens","#, 1);
    g.nodes
        .iter_mut()
        .filter(|n| n.contains(r#""camera":0"#))
        .for_each(|n| *n = n.replacen('{', r#"{"name":"Front","#, 1));
    g.cameras.push(r#"{"name":"SideLens","type":"perspective","perspective":{"yfov":0.5,"znear":0.1}}"#.into());
    g.node(r#"{"name":"Side","camera":1,"translation":[6,0,0],"rotation":[0,0.7071068,0,0.7071068]}"#.into(), true);
    let path = dir.write("cams.gltf", g.json());
    let front = from_gltf_file(&path, None).unwrap().scene.camera;
    let side = from_gltf_file(&path, Some("1")).unwrap().scene.camera;
    assert_ne!(front, side);
    for (wanted, expected) in
        [("0", &front), ("FrontLens", &front), ("Front", &front), ("SideLens", &side), ("Side", &side)]
    {
        assert_eq!(&from_gltf_file(&path, Some(wanted)).unwrap().scene.camera, expected, "--camera {wanted}");
    }
    let out = dir.path("x.exr");
    let err = fails(&dir, &["render", path.to_str().unwrap(), "--camera", "2", "-o", out.to_str().unwrap()]);
    assert!(err.contains(r#"no camera matches --camera "2" (by index, name or node name)"#), "{err}");
    assert!(err.contains(r#"index 0, name "FrontLens", node "Front"; index 1, name "SideLens", node "Side""#), "{err}");
}

#[test]
fn glb_and_gltf_with_base64_load_the_same() {
    let dir = TempDir::new("gltf-glb");
    let (g, _) = hierarchy_scene();
    let a = from_gltf_file(&dir.write("h.gltf", g.json()), None).unwrap().scene;
    let b = from_gltf_file(&dir.write("h.glb", g.glb()), None).unwrap().scene;
    assert_eq!(a.meshes, b.meshes);
    assert!(same_bits(&render(&a).0, &render(&b).0));
}

/// Objects and materials carry the names Blender's glTF importer gives them (so Cycles'
/// Cryptomatte names): a node by its name, else by its mesh's (`Mesh_N` unnamed); a material by
/// its name (`Material_N` unnamed), without the file's name; the same for `.gltf` and `.glb`.
#[test]
fn objects_and_materials_are_named_as_blenders_importer_names_them() {
    let dir = TempDir::new("gltf-names");
    let (mut g, _) = hierarchy_scene();
    // The quad's node (the parent, the last mesh node added) is named; the triangle's is not.
    let parent = g.nodes.iter().position(|n| n.contains("children")).unwrap();
    g.nodes[parent] = g.nodes[parent].replacen('{', r#"{"name":"Floor","#, 1);
    g.materials[1] = g.materials[1].replace(r#""name":"grey","#, "");
    for file in ["n.gltf", "n.glb"] {
        let path = if file.ends_with("glb") { dir.write(file, g.glb()) } else { dir.write(file, g.json()) };
        let scene = from_gltf_file(&path, None).unwrap().scene;
        let ids = strahl::output::ids::ObjectIds::new(&scene);
        let mut names = ids.object_names.clone();
        names.sort();
        assert_eq!(names, ["Floor", "Mesh_1"], "{file}");
        let materials: Vec<&str> = scene.materials.iter().map(|m| m.name.as_str()).collect();
        assert_eq!(materials, ["red", "Material_1"], "{file}");
    }
}

#[test]
fn a_gltf_object_in_a_toml_scene_takes_its_transform() {
    let dir = TempDir::new("gltf-object");
    let mut g = Gltf::default();
    g.mesh(&TRIANGLE, None, "");
    g.node(r#"{"mesh":0}"#.into(), true);
    dir.write("t.gltf", g.json());
    let toml = r#"
[camera]
eye = [0, 0, 5]
target = [0, 0, 0]
fov_deg = 30
[[objects]]
type = "gltf"
path = "t.gltf"
translate = [1, 0, 0]
scale = 2
"#;
    let loaded = from_toml_str(toml, &dir.path("s.toml")).unwrap();
    let mesh = &loaded.scene.meshes[0];
    assert_eq!(
        mesh.positions,
        vec![glam::Vec3::new(1.0, 0.0, 0.0), glam::Vec3::new(3.0, 0.0, 0.0), glam::Vec3::new(1.0, 2.0, 0.0)]
    );
    assert_eq!(loaded.objects[0].kind, "gltf");
    assert_eq!(loaded.scene.materials[mesh.material as usize].name, "t.gltf/gltf default");
}

/// An 8×8 PNG of 2×2 cells of 4×4 texels, sRGB-encoded: top-left `a`, top-right `b`,
/// bottom-left `c`, bottom-right `d`.
fn checker_png(cells: [[u8; 3]; 4]) -> Vec<u8> {
    let img = image::RgbImage::from_fn(8, 8, |x, y| image::Rgb(cells[(y / 4 * 2 + x / 4) as usize]));
    let mut bytes = Vec::new();
    img.write_to(&mut std::io::Cursor::new(&mut bytes), image::ImageFormat::Png).unwrap();
    bytes
}

const CELLS: [[u8; 3]; 4] = [[255, 0, 0], [0, 128, 0], [0, 0, 64], [200, 200, 200]];

/// The linear albedo of a cell: sRGB decoded in f64, rounded once.
fn linear(c: [u8; 3]) -> [f32; 3] {
    c.map(|x| srgb_to_linear(x as f64 / 255.0) as f32)
}

/// A textured quad facing the camera, 2 wide by 1 high, with texture coordinates from
/// `(0, 0)` to `(u_max, 1)` and the given sampler wrap mode along u; the default light.
fn textured_quad(dir: &TempDir, u_max: f32, wrap_s: u32) -> std::path::PathBuf {
    let mut g = Gltf::default();
    let positions = [[-2.0, -1.0, 0.0], [2.0, -1.0, 0.0], [2.0, 1.0, 0.0], [-2.0, 1.0, 0.0]];
    // glTF texture coordinates: (0, 0) is the image's top-left.
    let uv = g.vec2(&[[0.0, 1.0], [u_max, 1.0], [u_max, 0.0], [0.0, 0.0]]);
    g.mesh(&positions, Some(&QUAD_INDICES), &format!(r#","TEXCOORD_0":{uv}"#));
    g.meshes[0] = g.meshes[0].replace(r#""indices""#, r#""material":0,"indices""#);
    g.materials.push(
        r#"{"pbrMetallicRoughness":{"baseColorTexture":{"index":0},"metallicFactor":0,"roughnessFactor":1}}"#.into(),
    );
    g.textures.push(r#"{"source":0,"sampler":0}"#.into());
    g.images.push(r#"{"uri":"checker.png"}"#.into());
    g.samplers.push(format!(r#"{{"wrapS":{wrap_s},"wrapT":33071}}"#));
    g.cameras.push(r#"{"type":"perspective","perspective":{"yfov":0.5,"znear":0.1,"aspectRatio":2}}"#.into());
    g.node(r#"{"mesh":0}"#.into(), true);
    g.node(r#"{"camera":0,"translation":[0,0,5]}"#.into(), true);
    dir.write("checker.png", checker_png(CELLS));
    dir.write(&format!("quad-{wrap_s}.gltf"), g.json())
}

/// The pixel of the 640×320 image that sees the quad's point `(x, y, 0)` (camera at z = 5,
/// yfov 0.5 rad).
fn pixel_of(x: f64, y: f64) -> usize {
    let t = (0.5f64 * 0.5).tan();
    let (w, h) = (640.0, 320.0);
    let r = t * w / h;
    let (px, py) = ((x / 5.0 / (2.0 * r) + 0.5) * w, (0.5 - y / 5.0 / (2.0 * t)) * h);
    py as usize * 640 + px as usize
}

#[test]
fn a_checker_texture_gives_the_analytic_texel_colours() {
    let dir = TempDir::new("gltf-checker");
    let path = textured_quad(&dir, 1.0, 33071);
    let out = dir.path("q.exr");
    // The Whitted integrator: direct light only (the path tracer adds the glTF material's
    // dielectric reflection of the background to this closed form).
    let run = strahl(&["render", path.to_str().unwrap(), "-o", out.to_str().unwrap(), "--integrator", "whitted"]);
    assert!(run.status.success(), "{}", text(&run.stderr));
    let (w, h, ch) = read_exr(&out);
    assert_eq!((w, h), (640, 320));
    // Cell interiors, a quarter of the quad in from each corner: u, v = ¼ or ¾.
    let at = [(-1.0, 0.5, 0), (1.0, 0.5, 1), (-1.0, -0.5, 2), (1.0, -0.5, 3)];
    for (x, y, cell) in at {
        let i = pixel_of(x, y);
        let want = linear(CELLS[cell]);
        for (c, name) in ["ViewLayer.DiffCol.R", "ViewLayer.DiffCol.G", "ViewLayer.DiffCol.B"].iter().enumerate() {
            assert_eq!(channel(&ch, name)[i], want[c], "{name} of cell {cell}");
        }
        // The default light shines along the view: radiance = albedo·cosθ, cosθ = 1 up to
        // the pixel's tiny off-axis angle on this flat quad (the light is directional, so
        // cosθ = 1 exactly).
        for (c, name) in ["ViewLayer.Combined.R", "ViewLayer.Combined.G", "ViewLayer.Combined.B"].iter().enumerate() {
            let got = channel(&ch, name)[i];
            assert!((got - want[c]).abs() <= 1e-6, "{name} of cell {cell}: {got} vs {}", want[c]);
        }
    }
}

/// A base-colour texture with `texCoord` 1 reads `TEXCOORD_1`: the quad's first set points every
/// vertex at one cell, its second spans the texture, so each cell shows only through the second.
#[test]
fn a_texture_reads_the_coordinate_set_it_names() {
    let dir = TempDir::new("gltf-texcoord1");
    dir.write("checker.png", checker_png(CELLS));
    let mut g = Gltf::default();
    let positions = [[-2.0, -1.0, 0.0], [2.0, -1.0, 0.0], [2.0, 1.0, 0.0], [-2.0, 1.0, 0.0]];
    let first = g.vec2(&[[0.75, 0.75]; 4]);
    let second = g.vec2(&[[0.0, 1.0], [1.0, 1.0], [1.0, 0.0], [0.0, 0.0]]);
    g.mesh(&positions, Some(&QUAD_INDICES), &format!(r#","TEXCOORD_0":{first},"TEXCOORD_1":{second}"#));
    g.meshes[0] = g.meshes[0].replace(r#""indices""#, r#""material":0,"indices""#);
    g.textures.push(r#"{"source":0,"sampler":0}"#.into());
    g.images.push(r#"{"uri":"checker.png"}"#.into());
    g.samplers.push(r#"{"wrapS":33071,"wrapT":33071}"#.into());
    g.cameras.push(r#"{"type":"perspective","perspective":{"yfov":0.5,"znear":0.1,"aspectRatio":2}}"#.into());
    g.node(r#"{"mesh":0}"#.into(), true);
    g.node(r#"{"camera":0,"translation":[0,0,5]}"#.into(), true);
    let at = [(-1.0, 0.5, 0), (1.0, 0.5, 1), (-1.0, -0.5, 2), (1.0, -0.5, 3)];
    for set in [0, 1] {
        let mut g = Gltf { materials: vec![], ..g.clone() };
        g.materials.push(format!(
            r#"{{"pbrMetallicRoughness":{{"baseColorTexture":{{"index":0,"texCoord":{set}}},"metallicFactor":0,"roughnessFactor":1}}}}"#
        ));
        let file = dir.write(&format!("set{set}.gltf"), g.json());
        let loaded = from_gltf_file(&file, None).unwrap();
        assert!(loaded.warnings.iter().all(|w| !w.contains("TEXCOORD")), "{:?}", loaded.warnings);
        let mut scene = whitted(loaded.scene);
        (scene.image.width, scene.image.height) = (640, 320);
        let (film, _) = render(&scene);
        for (x, y, cell) in at {
            // Set 0 is (0.75, 0.75) everywhere: the bottom-right cell, 3.
            let want = linear(CELLS[if set == 1 { cell } else { 3 }]);
            assert_eq!(film.albedo[pixel_of(x, y)].to_array(), want, "texCoord {set}, cell {cell}");
        }
    }
}

#[test]
fn each_wrap_mode_continues_the_texture_its_own_way() {
    let dir = TempDir::new("gltf-wrap");
    // u runs 0 → 2 across the quad: the right half (x > 0) is the second copy along u, where
    // the top row shows cells a (u ∈ 1..1.5 under repeat) and b (1.5..2) — or the mirror
    // image, or the edge column (b) when clamped.
    let (a, b) = (linear(CELLS[0]), linear(CELLS[1]));
    for (mode, left, right) in [(10497, a, b), (33648, b, a), (33071, b, b)] {
        let path = textured_quad(&dir, 2.0, mode);
        let scene = from_gltf_file(&path, None).unwrap().scene;
        let (film, _) = render(&scene);
        // x = 0.5 is u = 1.25; x = 1.5 is u = 1.75; y = 0.5 is the top row of cells.
        assert_eq!(film.albedo[pixel_of(0.5, 0.5)].to_array(), left, "wrap {mode} at u = 1.25");
        assert_eq!(film.albedo[pixel_of(1.5, 0.5)].to_array(), right, "wrap {mode} at u = 1.75");
        // The first copy is the same under every mode.
        assert_eq!(film.albedo[pixel_of(-1.5, 0.5)].to_array(), a, "wrap {mode} at u = 0.25");
    }
}

// ---------------------------------------------------------------------------------------------
// Bad input: one line naming the file and the element, exit status 1, nothing written.

fn refuse(dir: &TempDir, name: &str, contents: &[u8]) -> String {
    let path = dir.write(name, contents);
    let out = dir.path("out.exr");
    let e = fails(dir, &["render", path.to_str().unwrap(), "-o", out.to_str().unwrap()]);
    assert!(e.contains(name), "{e}");
    e
}

#[test]
fn bad_files_are_refused_naming_the_element() {
    let dir = TempDir::new("gltf-bad");
    let e = refuse(&dir, "syntax.gltf", br#"{"asset":{"version":"2.0"}, "nodes": [ }"#);
    assert!(e.contains("not valid glTF JSON"), "{e}");

    // A POSITION accessor that does not exist (found by `make fuzz`: the gltf crate's own
    // validation indexed it and panicked), as glTF JSON and inside a GLB.
    let json = br#"{"asset":{"version":"2.0"},"meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}]}"#;
    let e = refuse(&dir, "position.gltf", json);
    assert!(e.ends_with("mesh 0 primitive 0: POSITION names accessor 0, but the file has 0"), "{e}");
    let mut glb = b"glTF".to_vec();
    let padded = json.len().div_ceil(4) * 4;
    glb.extend(2u32.to_le_bytes());
    glb.extend(((12 + 8 + padded) as u32).to_le_bytes());
    glb.extend((padded as u32).to_le_bytes());
    glb.extend(b"JSON");
    glb.extend(json);
    glb.resize(12 + 8 + padded, b' ');
    let e = refuse(&dir, "position.glb", &glb);
    assert!(e.ends_with("POSITION names accessor 0, but the file has 0"), "{e}");

    // A buffer shorter than an accessor claims.
    let mut g = Gltf::default();
    g.mesh(&TRIANGLE, None, "");
    g.node(r#"{"mesh":0}"#.into(), true);
    let json = g.json().replace(r#""count":3,"type":"VEC3""#, r#""count":30,"type":"VEC3""#);
    let e = refuse(&dir, "short.gltf", json.as_bytes());
    assert!(e.contains("accessor 0"), "{e}");

    // Indices out of range.
    let mut g = Gltf::default();
    g.mesh(&TRIANGLE, Some(&[0, 1, 7]), "");
    g.node(r#"{"mesh":0}"#.into(), true);
    let e = refuse(&dir, "range.gltf", g.json().as_bytes());
    assert!(e.contains("accessor 1") && e.contains("out of range"), "{e}");

    // A required extension strahl does not support.
    let mut g = Gltf::default();
    g.mesh(&TRIANGLE, None, "");
    g.node(r#"{"mesh":0}"#.into(), true);
    g.extra_top.push(
        r#""extensionsRequired":["KHR_draco_mesh_compression"],"extensionsUsed":["KHR_draco_mesh_compression"]"#.into(),
    );
    let e = refuse(&dir, "ext.gltf", g.json().as_bytes());
    assert!(e.contains("KHR_draco_mesh_compression") && e.contains("does not support"), "{e}");

    // A missing texture file, and a texture that is not an image.
    let quad = std::fs::read_to_string(textured_quad(&dir, 1.0, 10497)).unwrap();
    std::fs::remove_file(dir.path("quad-10497.gltf")).unwrap();
    let e = refuse(&dir, "missing.gltf", quad.replace("checker.png", "nowhere.png").as_bytes());
    assert!(e.contains("image 0") && e.contains("nowhere.png"), "{e}");
    dir.write("text.png", "this is not a PNG");
    let e = refuse(&dir, "notimage.gltf", quad.replace("checker.png", "text.png").as_bytes());
    assert!(e.contains("image 0") && e.contains("text.png"), "{e}");

    // A GLB cut short.
    let (g, _) = hierarchy_scene();
    let glb = g.glb();
    let e = refuse(&dir, "cut.glb", &glb[..glb.len() - 40]);
    assert!(e.contains("cut.glb"), "{e}");
}

/// `scene` for the Whitted integrator.
fn whitted(mut scene: strahl::scene::Scene) -> strahl::scene::Scene {
    scene.render.integrator = strahl::scene::IntegratorKind::Whitted;
    scene
}

/// The header keys Blender writes into a render (its stamp): `Camera` is the glTF camera's
/// node name (Blender's importer names the camera object after it), `Scene` and `File` the
/// scene file's, `Frame` and `Time` from `--frame` and `--fps`; and every key of Cycles' own
/// multilayer file (../shared/data/reference) is in strahl's.
#[test]
fn the_header_carries_the_keys_blender_writes() {
    let dir = TempDir::new("gltf-header");
    let (mut g, _) = hierarchy_scene();
    g.nodes
        .iter_mut()
        .filter(|n| n.contains(r#""camera":0"#))
        .for_each(|n| *n = n.replacen('{', r#"{"name":"Front Cam","#, 1));
    let path = dir.write("shot 12.gltf", g.json());
    let out = dir.path("shot.exr");
    let args =
        ["render", path.to_str().unwrap(), "--width", "8", "--height", "6", "--spp", "3", "--integrator", "whitted"];
    // Without SOURCE_DATE_EPOCH, so that the date and render times are written as well.
    let run = std::process::Command::new(env!("CARGO_BIN_EXE_strahl"))
        .args([&args[..], &["--frame", "37", "--fps", "25", "-o", out.to_str().unwrap()]].concat())
        .env_remove("SOURCE_DATE_EPOCH")
        .output()
        .unwrap();
    assert!(run.status.success(), "{}", text(&run.stderr));
    let image = common::read_exr_image(&out);
    let text_of = |image: &exr::image::FlatImage, key: &str| {
        image.layer_data[0].attributes.other.get(&exr::prelude::Text::from(key)).map(|v| match v {
            exr::meta::attribute::AttributeValue::Text(t) => t.to_string(),
            other => format!("{other:?}"),
        })
    };
    let get = |key: &str| text_of(&image, key).unwrap_or_else(|| panic!("no {key} in the header"));
    assert_eq!(get("Camera"), "Front Cam");
    assert_eq!((get("Scene"), get("File")), ("shot 12".to_string(), "shot 12.gltf".to_string()));
    assert_eq!((get("Frame"), get("Time")), ("037".to_string(), "00:00:01:12".to_string()));
    assert_eq!(get("cycles.ViewLayer.samples"), "3");
    assert_eq!(get("BlenderMultiChannel"), "Blender V2.55.1 and newer");
    // Nuke's layout is no Blender multilayer file.
    let nuke = dir.path("nuke.exr");
    let run = strahl(&[&args[..], &["--exr-layout", "nuke", "-o", nuke.to_str().unwrap()]].concat());
    assert!(run.status.success(), "{}", text(&run.stderr));
    assert_eq!(text_of(&common::read_exr_image(&nuke), "BlenderMultiChannel"), None);

    let Some(data) = common::data_dir() else { return };
    let reference = data.join("../reference/blender-3.4-cycles-multilayer-cryptomatte.exr");
    let cycles = common::read_exr_image(&reference);
    for key in cycles.layer_data[0].attributes.other.keys().map(|k| k.to_string()) {
        // Cycles' scene-synchronisation and total times: strahl has no such phases to time.
        if key.starts_with("cryptomatte/") || key.ends_with(".synchronization_time") || key.ends_with(".total_time") {
            continue;
        }
        assert!(text_of(&image, &key).is_some(), "Cycles writes {key}, strahl does not");
    }
}
