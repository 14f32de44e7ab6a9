//! The TOML scene format: every section parses into the expected `Scene` values (materials
//! resolved by name, transforms applied in the documented order, planes in Hesse normal form),
//! and bad input is refused with one line `file:line:column: problem`.

use std::path::Path;

use strahl::geometry::Plane;
use strahl::light::Light;
use strahl::material::{Material, Texture};
use strahl::math::Vec3;
use strahl::scene::{Scene, SceneError, from_toml_str};

const CAMERA: &str = "[camera]\neye = [0, 1, 5]\ntarget = [0, 0, 0]\nfov_deg = 40\n";

fn parse(text: &str) -> Result<Scene, SceneError> {
    from_toml_str(text, Path::new("scenes/test.toml")).map(|l| l.scene)
}

/// A scene with the standard camera, a material `m`, and `rest`.
fn with_camera(rest: &str) -> Scene {
    let text = format!("{CAMERA}[materials.m]\ndiffuse = 0.5\n{rest}");
    parse(&text).unwrap_or_else(|e| panic!("{e}\n--- in ---\n{text}"))
}

/// The one-line error for `text`.
fn error(text: &str) -> String {
    match parse(text) {
        Ok(_) => panic!("accepted:\n{text}"),
        Err(e) => {
            let line = e.to_string();
            assert!(!line.contains('\n'), "not one line: {line:?}");
            line
        }
    }
}

/// The error for the standard camera, a material `m`, and `rest`; and its line number, which
/// `rest` gives by marking the offending line with `# <-`.
fn error_in(rest: &str) -> (String, usize) {
    let text = format!("{CAMERA}[materials.m]\ndiffuse = 0.5\n{rest}");
    let line = text.lines().position(|l| l.contains("# <-")).map(|i| i + 1).expect("a line marked # <-");
    (error(&text), line)
}

/// Asserts that `message` is `scenes/test.toml:LINE:COL: …` at `line` and contains `needle`.
fn assert_at(message: &str, line: usize, needle: &str) {
    let prefix = format!("scenes/test.toml:{line}:");
    assert!(message.starts_with(&prefix), "expected {prefix}…, got {message:?}");
    assert!(message.contains(needle), "expected {needle:?} in {message:?}");
}

fn close(a: Vec3, b: Vec3) -> bool {
    (a - b).length() <= 1e-6 * b.length().max(1.0)
}

#[test]
fn camera_and_image_with_defaults() {
    let s = with_camera("");
    assert_eq!(s.camera.eye, Vec3::new(0.0, 1.0, 5.0));
    assert_eq!(s.camera.target, Vec3::ZERO);
    assert_eq!(s.camera.up, Vec3::Y, "up defaults to +y");
    assert_eq!(s.camera.fov_deg, 40.0);
    assert_eq!(s.image, strahl::scene::ImageSpec::default());

    let s = with_camera(
        "[image]\nwidth = 320\nheight = 200\nspp = 16\nmax_depth = 3\nbackground = [0.1, 0.2, 0.3]\nambient = 0.25\n",
    );
    assert_eq!((s.image.width, s.image.height, s.image.spp, s.image.max_depth), (320, 200, 16, 3));
    assert_eq!(s.image.background, Vec3::new(0.1, 0.2, 0.3));
    assert_eq!(s.image.ambient, Vec3::splat(0.25), "one number is a grey");
}

#[test]
fn materials_resolve_by_name() {
    let s = parse(&format!(
        "{CAMERA}
[materials.tiles]
checker = {{ even = [1, 1, 1], odd = 0.1, size = 0.5 }}

[materials.glass]
specular = 0.2
shininess = 400
transmission = 1
ior = 1.5
mirror = [0.1, 0.2, 0.3]

[materials.lamp]
emission = [10, 9, 8]

[[objects]]
type = \"sphere\"
center = [0, 0, 0]
radius = 1
material = \"lamp\"

[[objects]]
type = \"plane\"
normal = [0, 1, 0]
distance = 0
material = \"tiles\"
"
    ))
    .unwrap();
    // Materials are numbered in name order.
    let names: Vec<&str> = s.materials.iter().map(|m| m.name.as_str()).collect();
    assert_eq!(names, ["glass", "lamp", "tiles"]);
    assert_eq!(s.spheres[0].material, 1);
    assert_eq!(s.planes[0].material, 2);
    assert_eq!(
        s.materials[0],
        Material {
            name: "glass".into(),
            diffuse: Texture::Constant(Vec3::ZERO),
            specular: Vec3::splat(0.2),
            shininess: 400.0,
            mirror: Vec3::new(0.1, 0.2, 0.3),
            transmission: Vec3::ONE,
            ior: 1.5,
            emission: Vec3::ZERO,
            emission_one_sided: false,
            area_light: false,
            pbr: None,
            coverage: None,
        }
    );
    assert_eq!(s.materials[1].emission, Vec3::new(10.0, 9.0, 8.0));
    assert_eq!(s.materials[1].ior, 1.5, "ior defaults to 1.5");
    assert_eq!(s.materials[2].diffuse, Texture::Checker { even: Vec3::ONE, odd: Vec3::splat(0.1), size: 0.5 });
}

#[test]
fn lights_in_physical_units() {
    let s = with_camera(
        "[[lights]]\ntype = \"point\"\nposition = [1, 2, 3]\nintensity = [10, 20, 30]\n\n\
         [[lights]]\ntype = \"directional\"\ndirection = [0, -2, 0]\nirradiance = 3\n",
    );
    assert_eq!(
        s.lights,
        [
            Light::Point { position: Vec3::new(1.0, 2.0, 3.0), intensity: Vec3::new(10.0, 20.0, 30.0) },
            Light::Directional { direction: -Vec3::Y, irradiance: Vec3::splat(3.0) },
        ]
    );
}

#[test]
fn sphere_is_scaled_then_moved() {
    let s = with_camera(
        "[[objects]]\ntype = \"sphere\"\ncenter = [1, 0, 0]\nradius = 0.5\nscale = 2\n\
         rotate_deg = [0, 0, 90]\ntranslate = [0, 0, -1]\nmaterial = \"m\"\n",
    );
    // (1, 0, 0) ×2 → (2, 0, 0), 90° about z → (0, 2, 0), moved → (0, 2, −1); radius ×2.
    assert!(close(s.spheres[0].center, Vec3::new(0.0, 2.0, -1.0)), "{}", s.spheres[0].center);
    assert_eq!(s.spheres[0].radius, 1.0);
    assert_eq!(s.spheres[0].material, 0);
}

#[test]
fn plane_in_hesse_normal_form() {
    // normal + distance: the normal is normalised, the distance is from the origin along it.
    let s = with_camera("[[objects]]\ntype = \"plane\"\nnormal = [0, 2, 0]\ndistance = -1.5\nmaterial = \"m\"\n");
    assert_eq!(s.planes, [Plane { normal: Vec3::Y, dist: -1.5, material: 0 }]);
    // point + normal: d = n·p.
    let s = with_camera("[[objects]]\ntype = \"plane\"\nnormal = [1, 1, 0]\npoint = [2, 0, 7]\nmaterial = \"m\"\n");
    let n = Vec3::new(1.0, 1.0, 0.0).normalize();
    assert!(close(s.planes[0].normal, n));
    assert!((s.planes[0].dist - 2.0 / 2f32.sqrt()).abs() < 1e-6);
    // Transformed: y = 1 rotated 90° about x becomes z = 1, then moved by 2 along z: z = 3.
    let s = with_camera(
        "[[objects]]\ntype = \"plane\"\nnormal = [0, 1, 0]\ndistance = 1\nrotate_deg = [90, 0, 0]\n\
         translate = [5, 5, 2]\nmaterial = \"m\"\n",
    );
    assert!(close(s.planes[0].normal, Vec3::Z), "{}", s.planes[0].normal);
    assert!((s.planes[0].dist - 3.0).abs() < 1e-6, "{}", s.planes[0].dist);
}

#[test]
fn triangles_with_normals_and_colors_under_a_non_uniform_scale() {
    let s = with_camera(
        "[[objects]]
type = \"triangles\"
name = \"ramp\"
positions = [[0, 0, 0], [1, 0, 0], [0, 1, 1]]
indices = [[0, 1, 2]]
normals = [[0, -1, 1], [0, -1, 1], [0, -1, 1]]
colors = [[1, 0, 0], [0, 1, 0], [0, 0, 1]]
scale = [1, 2, 1]
translate = [0, 0, 3]
material = \"m\"
",
    );
    let m = &s.meshes[0];
    assert_eq!(m.name, "ramp");
    assert_eq!(m.positions, [Vec3::new(0.0, 0.0, 3.0), Vec3::new(1.0, 0.0, 3.0), Vec3::new(0.0, 2.0, 4.0)]);
    assert_eq!(m.indices, [[0, 1, 2]]);
    assert_eq!(m.colors.as_ref().unwrap()[1], Vec3::Y);
    // The normal stays perpendicular to the stretched triangle: the inverse transpose, which
    // here agrees with the cross product of the transformed edges.
    let [a, b, c] = m.triangle(0);
    let geometric = (b - a).cross(c - a).normalize();
    let n = m.normals.as_ref().unwrap()[0];
    assert!(close(n, geometric), "{n} vs {geometric}");
    assert!(close(n, Vec3::new(0.0, -1.0, 2.0).normalize()));
}

#[test]
fn mirroring_keeps_triangles_facing_their_normals() {
    let s = with_camera(
        "[[objects]]\ntype = \"triangles\"\npositions = [[0, 0, 0], [1, 0, 0], [0, 1, 0]]\n\
         indices = [[0, 1, 2]]\nnormals = [[0, 0, 1], [0, 0, 1], [0, 0, 1]]\nscale = [1, 1, -1]\nmaterial = \"m\"\n",
    );
    let m = &s.meshes[0];
    let [a, b, c] = m.triangle(0);
    let n = m.normals.as_ref().unwrap()[0];
    assert_eq!(n, -Vec3::Z);
    assert!((b - a).cross(c - a).dot(n) > 0.0, "winding flipped with the mirror");
}

#[test]
fn random_spheres_are_deterministic_and_inside_their_bounds() {
    let text = "[materials.a]\ndiffuse = 0.1\n[materials.b]\ndiffuse = 0.2\n\
                [[objects]]\ntype = \"random_spheres\"\ncount = 2000\nseed = 7\n\
                bounds = [[-1, 0, -1], [1, 2, 1]]\nradii = [0.01, 0.05]\nmaterials = [\"b\", \"a\"]\n\
                translate = [10, 0, 0]\n";
    let s = with_camera(text);
    assert_eq!(s.spheres.len(), 2000);
    assert_eq!(s.spheres, with_camera(text).spheres);
    for (i, sp) in s.spheres.iter().enumerate() {
        assert!(sp.center.cmpge(Vec3::new(9.0, 0.0, -1.0)).all() && sp.center.cmple(Vec3::new(11.0, 2.0, 1.0)).all());
        assert!((0.01..=0.05).contains(&sp.radius));
        // Materials cycle in the listed order: b (id 1), a (id 0), b, ...
        assert_eq!(sp.material, if i % 2 == 0 { 1 } else { 0 });
    }
}

#[test]
fn every_shipped_scene_loads() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    let mut names = Vec::new();
    for entry in std::fs::read_dir(&dir).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "toml") {
            let s = strahl::scene::load(&path).unwrap_or_else(|e| panic!("{e}")).scene;
            let lit = !s.lights.is_empty() || !s.area_lights.is_empty();
            assert!(lit && !s.materials.is_empty(), "{}", path.display());
            names.push(path.file_stem().unwrap().to_string_lossy().into_owned());
        }
    }
    names.sort();
    assert_eq!(names, ["blob", "cornell", "cornell-path", "lecture", "spheres", "whitted"]);
    // The path-traced Cornell box: the same box, chosen for the path tracer.
    let path = strahl::scene::load(dir.join("cornell-path.toml")).unwrap().scene;
    assert_eq!(path.render.integrator, strahl::scene::IntegratorKind::Path);
    assert_eq!(path.image.ambient, Vec3::ZERO);
    let cornell = strahl::scene::load(dir.join("cornell.toml")).unwrap().scene;
    // The published floor corner (549.6, 0, 559.2) mm, in metres.
    assert!(close(cornell.meshes[0].positions[3], Vec3::new(0.5496, 0.0, 0.5592)));
    assert_eq!(cornell.spheres.len(), 2);
    assert!((cornell.spheres[0].radius - 0.1).abs() < 1e-7);
    // The published light: the 130 × 105 mm opening as a quad light facing down, and no
    // point light; its visible geometry is the last mesh.
    assert!(cornell.lights.is_empty());
    let [light] = cornell.area_lights[..] else { panic!("{:?}", cornell.area_lights) };
    assert!((light.area() - 0.130 * 0.105).abs() < 1e-9);
    let quad = cornell.meshes.last().unwrap();
    assert_eq!((cornell.mesh_name(cornell.meshes.len() - 1), quad.indices.len()), ("area light 0", 2));
    assert!(strahl::scene::load(dir.join("spheres.toml")).unwrap().scene.spheres.len() >= 1000);
}

// ----- errors: one line, the file, the line and column, the problem -----

#[test]
fn unknown_keys_are_rejected_in_every_table() {
    for (table, key_line) in [
        ("top", "colour = 1 # <-"),
        ("camera", "[camera]\neye = [0, 1, 5]\ntarget = [0, 0, 0]\nfov_deg = 40\nfocal = 3 # <-"),
        ("image", "[image]\nwidht = 3 # <-"),
        ("material", "[materials.x]\ndifuse = 0.5 # <-"),
        ("checker", "[materials.x]\nchecker = { even = 1, odd = 0, size = 1, phase = 2 } # <-"),
        ("light", "[[lights]]\ntype = \"point\"\nposition = [0, 0, 0]\nintensity = 1\ncolour = 1 # <-"),
        ("object", "[[objects]]\ntype = \"sphere\"\ncenter = [0, 0, 0]\nradius = 1\nmaterial = \"m\"\nradus = 2 # <-"),
    ] {
        let text = if table == "camera" {
            key_line.to_string()
        } else if table == "top" {
            format!("{key_line}\n{CAMERA}")
        } else {
            format!("{CAMERA}[materials.m]\ndiffuse = 0.5\n{key_line}")
        };
        let line = text.lines().position(|l| l.contains("# <-")).unwrap() + 1;
        let e = error(&text);
        assert_at(&e, line, "unknown field");
    }
}

#[test]
fn a_key_of_another_object_type_is_rejected() {
    let (e, line) = error_in(
        "[[objects]]\ntype = \"sphere\"\ncenter = [0, 0, 0]\nradius = 1\nnormal = [0, 1, 0] # <-\nmaterial = \"m\"\n",
    );
    assert_at(&e, line, "object 0 (sphere): a sphere has no `normal`");
    let (e, line) =
        error_in("[[lights]]\ntype = \"point\"\nposition = [0, 0, 0]\nintensity = 1\ndirection = [0, 1, 0] # <-\n");
    assert_at(&e, line, "light 0: a point light has no `direction`");
}

#[test]
fn toml_syntax_errors_have_line_and_column() {
    let e = error("[camera]\neye = [0, 1, 5]\ntarget = [0, 0 0]\n");
    assert!(e.starts_with("scenes/test.toml:3:"), "{e}");
    let e = error("[camera\neye = 1\n");
    assert!(e.starts_with("scenes/test.toml:1:8:"), "{e}");
}

#[test]
fn unknown_material_names_the_material_and_the_known_ones() {
    let (e, line) =
        error_in("[[objects]]\ntype = \"sphere\"\ncenter = [0, 0, 0]\nradius = 1\nmaterial = \"gold\" # <-\n");
    assert_at(&e, line, "unknown material 'gold' (known: m)");
    // Column of the value: `material = "gold"` → column 12.
    assert!(e.starts_with(&format!("scenes/test.toml:{line}:12:")), "{e}");
}

#[test]
fn image_size_and_samples_must_be_positive() {
    let (e, line) = error_in("[image]\nwidth = 0 # <-\n");
    assert_at(&e, line, "width must be at least 1");
    let (e, line) = error_in("[image]\nheight = 0 # <-\n");
    assert_at(&e, line, "height must be at least 1");
    let (e, line) = error_in("[image]\nspp = 0 # <-\n");
    assert_at(&e, line, "spp (samples per pixel) must be at least 1");
    let (e, line) = error_in("[image]\nwidth = -3 # <-\n");
    assert_at(&e, line, "expected u32");
}

#[test]
fn degenerate_cameras_are_refused() {
    let e = error("[camera]\neye = [0, 1, 5]\ntarget = [0, 11, 5]\nup = [0, 1, 0]\nfov_deg = 40\n");
    assert_at(&e, 4, "camera: up [0, 1, 0] is parallel to the view direction");
    let e = error("[camera]\neye = [1, 2, 3]\ntarget = [1, 2, 3]\nfov_deg = 40\n");
    assert_at(&e, 3, "eye and target are both [1, 2, 3]");
    // Finite in f32 but beyond the range strahl traces (docs/scene-format.md).
    let e = error("[camera]\neye = [3e38, 0, 0]\ntarget = [-3e38, 0, 0]\nfov_deg = 40\n");
    assert_at(&e, 2, "camera: eye [3e38, 0, 0] lies beyond ±1e9, the range strahl traces");
    let e = error("[camera]\neye = [0, 0, 0]\ntarget = [0, 0, -5e18]\nfov_deg = 40\n");
    assert_at(&e, 3, "camera: target [0, 0, -5e18] lies beyond ±1e9, the range strahl traces");
    let e = error("[camera]\neye = [0, 1, 5]\ntarget = [0, 0, 0]\nfov_deg = 40\naperture = 1e30\n");
    assert_at(&e, 5, "camera: aperture 1e30 is beyond ±1e9, the range strahl traces");
    let e = error("[camera]\neye = [0, 1, 5]\ntarget = [0, 0, 0]\nfov_deg = 40\nfocus_distance = 2e9\n");
    assert_at(&e, 5, "camera: focus_distance 2e9 is beyond ±1e9, the range strahl traces");
    let e = error("[camera]\neye = [0, 1, 5]\ntarget = [0, 0, 0]\nfov_deg = 180\n");
    assert_at(&e, 4, "fov_deg 180 must lie between 0 and 180");
}

#[test]
fn spheres_need_a_positive_radius_and_a_uniform_scale() {
    for r in ["0", "-1"] {
        let (e, line) = error_in(&format!(
            "[[objects]]\ntype = \"sphere\"\ncenter = [0, 0, 0]\nradius = {r} # <-\nmaterial = \"m\"\n"
        ));
        assert_at(&e, line, &format!("object 0 (sphere): radius {r} must be > 0"));
    }
    let (e, line) = error_in(
        "[[objects]]\ntype = \"sphere\"\nname = \"egg\"\ncenter = [0, 0, 0]\nradius = 1\nscale = [1, 2, 1] # <-\nmaterial = \"m\"\n",
    );
    assert_at(&e, line, "object 'egg' (sphere): a sphere cannot take the non-uniform scale [1, 2, 1]");
}

#[test]
fn non_finite_numbers_are_refused() {
    let (e, line) =
        error_in("[[objects]]\ntype = \"sphere\"\ncenter = [0, nan, 0] # <-\nradius = 1\nmaterial = \"m\"\n");
    assert_at(&e, line, "center [0, NaN, 0] is not finite");
    let (e, line) = error_in("[[lights]]\ntype = \"point\"\nposition = [0, 0, 0]\nintensity = inf # <-\n");
    assert_at(&e, line, "intensity [inf, inf, inf] is not finite");
    let (e, line) = error_in("[image]\nbackground = [1e39, 0, 0] # <-\n");
    assert_at(&e, line, "background [1e39, 0, 0] is not finite");
    let e = error(&CAMERA.replace("fov_deg = 40", "fov_deg = -inf"));
    assert_at(&e, 4, "fov_deg -inf is not a finite number");
}

#[test]
fn mesh_indices_and_arrays_are_checked() {
    let (e, line) = error_in(
        "[[objects]]\ntype = \"triangles\"\npositions = [[0, 0, 0], [1, 0, 0], [0, 1, 0]]\nindices = [[0, 1, 3]] # <-\nmaterial = \"m\"\n",
    );
    assert_at(&e, line, "triangle 0 has index [0, 1, 3] out of range (the mesh has 3 vertices)");
    let (e, line) = error_in(
        "[[objects]]\ntype = \"triangles\"\npositions = [[0, 0, 0], [1, 0, 0], [0, 1, 0]]\nindices = [[0, 1, 2]]\nnormals = [[0, 0, 1]] # <-\nmaterial = \"m\"\n",
    );
    assert_at(&e, line, "1 normals for 3 vertices");
    let (e, line) = error_in(
        "[[objects]]\ntype = \"triangles\"\npositions = [[0, 0, 0], [1, 0, 0], [0, 1, 0]]\nindices = [[0, 1, -2]] # <-\nmaterial = \"m\"\n",
    );
    assert_at(&e, line, "expected u32");
}

#[test]
fn reflectances_above_one_are_refused() {
    let (e, line) = error_in("[materials.hot]\ndiffuse = [0.5, 1.2, 0.5] # <-\n");
    assert_at(&e, line, "material 'hot': diffuse [0.5, 1.2, 0.5] is a reflectance and must lie in [0, 1]");
    let (e, line) = error_in("[materials.both]\ndiffuse = 0.5\nchecker = { even = 1, odd = 0, size = 1 } # <-\n");
    assert_at(&e, line, "give either `diffuse` or `checker`");
}

#[test]
fn missing_and_conflicting_keys() {
    let e = error("[image]\nwidth = 3\n");
    assert!(e.starts_with("scenes/test.toml:") && e.contains("missing field `camera`"), "{e}");
    let (e, line) = error_in("[[objects]] # <-\ntype = \"sphere\"\ncenter = [0, 0, 0]\nmaterial = \"m\"\n");
    assert!(e.contains("object 0 (sphere): missing `radius`"), "{e}");
    assert!(
        e.starts_with(&format!("scenes/test.toml:{}:", line + 1))
            || e.starts_with(&format!("scenes/test.toml:{line}:"))
    );
    let (e, line) = error_in(
        "[[objects]]\ntype = \"plane\"\nnormal = [0, 1, 0]\ndistance = 0\npoint = [0, 0, 0] # <-\nmaterial = \"m\"\n",
    );
    assert_at(&e, line, "give either `distance` or `point`");
    let (e, line) = error_in("[[objects]]\ntype = \"cube\" # <-\n");
    assert_at(&e, line, "unknown variant `cube`");
}

#[test]
fn material_names_cannot_contain_a_slash() {
    // `FILE/NAME` is how the materials of mesh files are named.
    let (e, line) = error_in("[materials.\"a/b\"] # <-\ndiffuse = 0.5\n");
    assert_at(&e, line, "material 'a/b': a material name cannot contain '/' (kept for the materials of mesh files)");
}

#[test]
fn missing_file_names_it() {
    let e = strahl::scene::load("scenes/does-not-exist.toml").unwrap_err();
    assert!(matches!(e, SceneError::Read { .. }));
    assert!(e.to_string().starts_with("scenes/does-not-exist.toml: cannot read the scene: "), "{e}");
}

#[test]
fn the_documented_example_is_a_valid_scene() {
    let doc = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/scene-format.md")).unwrap();
    let start = doc.find("```toml\n").expect("a toml example") + "```toml\n".len();
    let example = &doc[start..start + doc[start..].find("```").unwrap()];
    let s = from_toml_str(example, Path::new("docs/scene-format.md")).unwrap_or_else(|e| panic!("{e}")).scene;
    assert_eq!((s.image.width, s.image.height, s.image.spp), (640, 480, 4));
    assert_eq!((s.materials.len(), s.lights.len(), s.planes.len(), s.meshes.len()), (4, 2, 1, 1));
    assert_eq!(s.spheres.len(), 1 + 5000);
    assert_eq!(s.planes[0], Plane { normal: Vec3::Y, dist: -0.5, material: 1 });
    // The quad: scaled ×2 in x, turned 30° about y, moved to (−3, 0, −2).
    let (sin, cos) = 30f32.to_radians().sin_cos();
    assert!(close(s.meshes[0].positions[1], Vec3::new(-3.0 + 2.0 * cos, 0.0, -2.0 - 2.0 * sin)));
}
