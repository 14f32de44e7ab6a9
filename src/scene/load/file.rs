//! Scene files: the TOML schema (see `docs/scene-format.md`) and its loading, with the mesh
//! files it names, into a [`Loaded`] scene.
//!
//! Every table rejects unknown keys. Every error is one line naming the file, and the line and
//! column of the offending value where there is one: TOML syntax and type errors come from the
//! `toml` crate's spans, and the checks done here keep the span of each value (`Spanned`) so a
//! radius ≤ 0 or an unknown material name points at itself. A mesh file's errors and warnings
//! are located at the object's `path` and end in the mesh file's own `path:line: problem`.
//! The objects are in `file/objects.rs`.

mod environment;
mod objects;
mod pbr;

use std::collections::BTreeMap;
use std::ops::Range;
use std::path::{Path, PathBuf};

use glam::DVec3;
use serde::Deserialize;
use serde::de::{self, Deserializer, SeqAccess, Visitor};
use toml::Spanned;

pub use objects::ObjectSummary;
use objects::{ObjectContext, ObjectFile};

use crate::light::Light;
use crate::light::area::{AreaLight, MAX_LIGHT_SAMPLES, Shape};
use crate::material::{Material, Texture};
use crate::math::Vec3;
use crate::output::passes::{MAX_CRYPTO_LEVELS, OutputSpec, PassSet};
use crate::scene::Lens;
use crate::scene::{AdaptiveSpec, CameraSpec, ImageSpec, IntegratorKind, RenderSpec, Scene};
use crate::sys::read::{MAX_SCENE_BYTES, ReadError, read_regular};

/// Most spheres a scene may have, all `random_spheres` objects and `sphere`s together (a typo
/// should not exhaust memory: 25 objects of 10,000,000 each took 5 GB before the total was
/// bounded).
pub const MAX_RANDOM_SPHERES: u64 = 10_000_000;
/// Most pixels an image may have (32768 × 32768): a sanity bound on the numbers (pixel
/// indices, EXR windows). What a render may really take is bounded by its memory estimate
/// against `--max-memory` ([`crate::job::memory`]), and a region of a larger frame needs only the
/// region's film. Measured: 16384 × 16384 renders on a 24 GB machine (docs/performance.md).
pub const MAX_PIXELS: u64 = 1 << 30;
/// Most samples per pixel (256 × 256 strata): beyond it noise no longer falls visibly, and a
/// typo such as `spp = 4294967295` would never finish.
pub const MAX_SPP: u32 = 1 << 16;

/// Why a scene file could not be loaded. Displays as one line naming the file.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// The file could not be read: missing, not a regular file, larger than
    /// [`MAX_SCENE_BYTES`] (see [`crate::sys::read`]). The OS error is part of the message, not a
    /// separate source, so that it is printed once.
    #[error("{}: cannot read the scene: {problem}", path.display())]
    Read { path: PathBuf, problem: ReadError },
    /// A problem at a place in the file (1-based line and column, in characters).
    #[error("{}:{line}:{column}: {message}", path.display())]
    At { path: PathBuf, line: usize, column: usize, message: String },
    /// A problem with no place in the file.
    #[error("{}: {message}", path.display())]
    Invalid { path: PathBuf, message: String },
    /// A mesh file loaded as a scene of its own ([`from_mesh_file`]) could not be read.
    #[error(transparent)]
    Mesh(#[from] crate::scene::load::MeshError),
}

/// A loaded scene file: the scene, what the user should be told about it, and what each of its
/// objects added.
#[derive(Clone, Debug)]
pub struct Loaded {
    pub scene: Scene,
    /// One line each, `scene.toml:LINE:COLUMN: object 'name' (mesh): mesh-file:LINE: …`: a
    /// missing MTL library, degenerate triangles dropped, statements skipped in a mesh file.
    pub warnings: Vec<String>,
    /// One per `[[objects]]` entry, in file order.
    pub objects: Vec<ObjectSummary>,
}

/// Loads the scene file at `path`, and the mesh files it names. Only a regular file of at most
/// [`MAX_SCENE_BYTES`] is read.
pub fn load(path: impl AsRef<Path>) -> Result<Loaded, SceneError> {
    let path = path.as_ref();
    let bytes = read_regular(path, MAX_SCENE_BYTES, crate::sys::read::SCENE_TOO_LARGE_HINT)
        .map_err(|problem| SceneError::Read { path: path.into(), problem })?;
    let text = String::from_utf8(bytes).map_err(|e| {
        let offset = e.utf8_error().valid_up_to();
        let bytes = e.as_bytes();
        let valid = std::str::from_utf8(&bytes[..offset]).unwrap_or_default();
        let (line, column) = line_column(valid, offset);
        SceneError::At { path: path.into(), line, column, message: "not UTF-8 text (TOML is UTF-8)".into() }
    })?;
    from_toml_str(&text, path)
}

/// A scene of one mesh file (OBJ or PLY, optionally gzip'd; see [`crate::scene::load::load_mesh`]),
/// for looking at geometry without writing a scene file (`strahl info`, `crosscheck` and
/// `bench` take one): what a scene file with one `type = "mesh"` object naming `path` would
/// load (the file's materials named `FILE/NAME`, its warnings), with a camera framing the mesh
/// ([`CameraSpec::framing`], the default 40° field of view), the default image settings and no
/// lights.
pub fn from_mesh_file(path: impl AsRef<Path>) -> Result<Loaded, SceneError> {
    let path = path.as_ref();
    let (mut scene, report, summary) = objects::mesh_file_scene(path)?;
    scene.camera = CameraSpec::framing(scene.bounds(), CameraSpec::default().fov_deg);
    crate::scene::magnitude::check(path, &scene)?;
    Ok(Loaded { scene, warnings: report.warnings, objects: vec![summary] })
}

/// Parses a scene from TOML text; `path` names it in errors and warnings, and relative paths in
/// it (mesh files) are resolved against `path`'s directory.
pub fn from_toml_str(text: &str, path: &Path) -> Result<Loaded, SceneError> {
    let locate = |problem: Problem| match problem.span {
        Some(span) => {
            let (line, column) = line_column(text, span.start);
            SceneError::At { path: path.into(), line, column, message: problem.message }
        }
        None => SceneError::Invalid { path: path.into(), message: problem.message },
    };
    let file: SceneFile = toml::from_str(text)
        .map_err(|e| locate(Problem { span: e.span(), message: e.message().trim().replace('\n', "; ") }))?;
    let base = path.parent().unwrap_or(Path::new(""));
    let (scene, warnings, objects) = file.into_scene(base).map_err(locate)?;
    crate::scene::magnitude::check(path, &scene)?;
    let warnings = warnings.into_iter().map(|w| locate(w).to_string()).collect();
    Ok(Loaded { scene, warnings, objects })
}

/// 1-based line and column (in characters) of byte `offset` in `text`.
fn line_column(text: &str, offset: usize) -> (usize, usize) {
    let mut offset = offset.min(text.len());
    while !text.is_char_boundary(offset) {
        offset -= 1;
    }
    let before = &text[..offset];
    let line = before.matches('\n').count() + 1;
    let line_start = before.rfind('\n').map_or(0, |i| i + 1);
    (line, before[line_start..].chars().count() + 1)
}

/// What the image settings must satisfy, as `(field, problem)`: also checked by the command
/// after its `--width`/`--height`/`--spp` overrides.
pub fn image_problem(image: &ImageSpec) -> Option<(&'static str, String)> {
    let pixels = image.width as u64 * image.height as u64;
    if image.width == 0 {
        Some(("width", "width must be at least 1 pixel".into()))
    } else if image.height == 0 {
        Some(("height", "height must be at least 1 pixel".into()))
    } else if pixels > MAX_PIXELS {
        Some((
            "width",
            format!("{} × {} pixels is more than the {MAX_PIXELS} strahl renders", image.width, image.height),
        ))
    } else if image.spp == 0 {
        Some(("spp", "spp (samples per pixel) must be at least 1".into()))
    } else if image.spp > MAX_SPP {
        Some(("spp", format!("spp {} is more than the {MAX_SPP} samples per pixel strahl takes", image.spp)))
    } else if image.max_depth > crate::scene::MAX_DEPTH_LIMIT {
        let limit = crate::scene::MAX_DEPTH_LIMIT;
        Some(("max_depth", format!("max_depth {} is more than the {limit} bounces strahl follows", image.max_depth)))
    } else if !(1..=MAX_LIGHT_SAMPLES).contains(&image.mesh_light_samples) {
        let n = image.mesh_light_samples;
        Some(("mesh_light_samples", format!("mesh_light_samples {n} must lie in 1..={MAX_LIGHT_SAMPLES}")))
    } else if !image.background.is_finite() || image.background.min_element() < 0.0 {
        Some(("background", format!("background {} must be finite and ≥ 0", image.background)))
    } else if !image.ambient.is_finite() || image.ambient.min_element() < 0.0 {
        Some(("ambient", format!("ambient {} must be finite and ≥ 0", image.ambient)))
    } else {
        None
    }
}

/// What the camera must satisfy for the lecture's basis `w = (e−z)/|e−z|`, `u = up×w`,
/// `v = w×u` to exist, and for its rays to stay inside the range strahl traces
/// ([`super::magnitude`]), as `(field, problem)`.
pub fn camera_problem(camera: &CameraSpec) -> Option<(&'static str, String)> {
    // First: inside the range, the eye and target are at most 3.5e9 apart, so every length
    // below is finite.
    if let Some(problem) = crate::scene::magnitude::camera_problem(camera) {
        return Some(problem);
    }
    let w = (camera.eye - camera.target).normalize_or_zero();
    if w == Vec3::ZERO || !w.is_finite() {
        Some(("target", format!("eye and target are both {}: the camera has no view direction", camera.eye)))
    } else if camera.up.cross(w).length() <= 1e-6 * camera.up.length() {
        Some((
            "up",
            format!("up {} is parallel to the view direction {}", camera.up, (camera.target - camera.eye).normalize()),
        ))
    } else if !(camera.fov_deg > 0.0 && camera.fov_deg < 180.0) {
        Some(("fov_deg", format!("fov_deg {} must lie between 0 and 180 degrees", camera.fov_deg)))
    } else {
        None
    }
}

// ---------------------------------------------------------------------------------------------
// The schema, as serde reads it.

type V3 = Fixed<f64, 3>;

/// An array of exactly `N` elements: one more (`eye = [0, 1, 5, 6]`, `indices = [[0, 1, 2, 7]]`)
/// is an error at its place, not silently dropped as serde's `[T; N]` does with TOML.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Fixed<T, const N: usize>([T; N]);

impl<T, const N: usize> std::ops::Deref for Fixed<T, N> {
    type Target = [T; N];
    fn deref(&self) -> &[T; N] {
        &self.0
    }
}

impl<'de, T: Deserialize<'de>, const N: usize> Deserialize<'de> for Fixed<T, N> {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        struct FixedVisitor<T, const N: usize>(std::marker::PhantomData<T>);
        impl<'de, T: Deserialize<'de>, const N: usize> Visitor<'de> for FixedVisitor<T, N> {
            type Value = Fixed<T, N>;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                write!(f, "an array of {N} elements")
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Fixed<T, N>, A::Error> {
                let mut items = Vec::with_capacity(N);
                while items.len() < N {
                    match seq.next_element()? {
                        Some(x) => items.push(x),
                        None => {
                            let n = items.len();
                            return Err(de::Error::custom(format!("{n} elements where {N} are expected")));
                        }
                    }
                }
                if seq.next_element::<de::IgnoredAny>()?.is_some() {
                    return Err(de::Error::custom(format!("more than the {N} elements expected")));
                }
                let array: [T; N] = items.try_into().map_err(|_| de::Error::invalid_length(N, &self))?;
                Ok(Fixed(array))
            }
        }
        deserializer.deserialize_seq(FixedVisitor::<T, N>(std::marker::PhantomData))
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SceneFile {
    camera: Spanned<CameraFile>,
    image: Option<Spanned<ImageFile>>,
    #[serde(default)]
    materials: BTreeMap<String, Spanned<MaterialFile>>,
    #[serde(default)]
    lights: Vec<Spanned<LightFile>>,
    #[serde(default)]
    objects: Vec<Spanned<ObjectFile>>,
    output: Option<Spanned<OutputFile>>,
    render: Option<Spanned<RenderFile>>,
    environment: Option<Spanned<environment::EnvironmentFile>>,
}

/// `[render]`: the integrator (`"path"`, the default, or `"whitted"`), the path tracer's
/// `clamp` of indirect light, adaptive sampling (`adaptive_threshold`, 0 or absent: off;
/// `adaptive_min_samples`, 0 or absent: automatic), its `light_sampler` (`"tree"`, the
/// default, or `"power"`) and the `seed` of the sample sequences (0 to [`crate::scene::MAX_SEED`], default 0).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RenderFile {
    integrator: Option<Spanned<String>>,
    clamp: Option<Spanned<f64>>,
    adaptive_threshold: Option<Spanned<f64>>,
    adaptive_min_samples: Option<Spanned<u32>>,
    light_sampler: Option<Spanned<String>>,
    seed: Option<Spanned<u32>>,
}

impl RenderFile {
    fn to_spec(&self) -> Result<RenderSpec, Problem> {
        let mut spec = RenderSpec::default();
        if let Some(i) = &self.integrator {
            spec.integrator = IntegratorKind::parse(i.get_ref()).map_err(|m| at(i.span(), format!("render: {m}")))?;
        }
        if let Some(l) = &self.light_sampler {
            spec.light_sampler = crate::light::set::LightSampler::parse(l.get_ref())
                .map_err(|m| at(l.span(), format!("render: {m}")))?;
        }
        if let Some(c) = &self.clamp {
            spec.clamp = Some(*c.get_ref() as f32);
            if let Some(m) = spec.problem() {
                return Err(at(c.span(), format!("render: {m}")));
            }
        }
        if let Some(s) = &self.seed {
            spec.seed = *s.get_ref();
            if let Some(m) = spec.problem() {
                return Err(at(s.span(), format!("render: {m}")));
            }
        }
        let min_samples = self.adaptive_min_samples.as_ref().map_or(0, |m| *m.get_ref());
        if let Some(t) = self.adaptive_threshold.as_ref().filter(|t| *t.get_ref() != 0.0) {
            spec.adaptive = Some(AdaptiveSpec { threshold: *t.get_ref() as f32, min_samples });
            if let Some(m) = spec.problem() {
                return Err(at(t.span(), format!("render: {m}")));
            }
        }
        Ok(spec)
    }
}

/// `[output]`: passes, alpha, Cryptomatte levels (see [`crate::output::passes`]).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct OutputFile {
    passes: Option<Spanned<Vec<String>>>,
    transparent: Option<bool>,
    cryptomatte_levels: Option<Spanned<u32>>,
}

impl OutputFile {
    fn to_spec(&self) -> Result<OutputSpec, Problem> {
        let d = OutputSpec::default();
        let passes = match &self.passes {
            Some(p) => PassSet::parse(p.get_ref()).map_err(|m| at(p.span(), format!("output: {m}")))?,
            None => d.passes,
        };
        let crypto_levels = match &self.cryptomatte_levels {
            Some(l) if !(1..=MAX_CRYPTO_LEVELS).contains(l.get_ref()) => {
                let message = format!("output: cryptomatte_levels {} must lie in 1..={MAX_CRYPTO_LEVELS}", l.get_ref());
                return Err(at(l.span(), message));
            }
            Some(l) => *l.get_ref(),
            None => d.crypto_levels,
        };
        Ok(OutputSpec { passes, transparent: self.transparent.unwrap_or(d.transparent), crypto_levels })
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct CameraFile {
    eye: Spanned<V3>,
    target: Spanned<V3>,
    up: Option<Spanned<V3>>,
    fov_deg: Spanned<f64>,
    aperture: Option<Spanned<f64>>,
    focus_distance: Option<Spanned<f64>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ImageFile {
    width: Option<Spanned<u32>>,
    height: Option<Spanned<u32>>,
    spp: Option<Spanned<u32>>,
    max_depth: Option<Spanned<u32>>,
    background: Option<Spanned<Triple>>,
    ambient: Option<Spanned<Triple>>,
    mesh_lights: Option<bool>,
    mesh_light_samples: Option<Spanned<u32>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct MaterialFile {
    diffuse: Option<Spanned<Triple>>,
    checker: Option<Spanned<CheckerFile>>,
    specular: Option<Spanned<Triple>>,
    shininess: Option<Spanned<f64>>,
    mirror: Option<Spanned<Triple>>,
    transmission: Option<Spanned<Triple>>,
    ior: Option<Spanned<f64>>,
    emission: Option<Spanned<Triple>>,
    // The glTF metallic-roughness material (file/pbr.rs).
    base_color: Option<Spanned<Triple>>,
    base_color_texture: Option<Spanned<String>>,
    metallic: Option<Spanned<f64>>,
    roughness: Option<Spanned<f64>>,
    metallic_roughness_texture: Option<Spanned<String>>,
    emission_texture: Option<Spanned<String>>,
    clearcoat: Option<Spanned<f64>>,
    clearcoat_roughness: Option<Spanned<f64>>,
    sheen_color: Option<Spanned<Triple>>,
    sheen_roughness: Option<Spanned<f64>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct CheckerFile {
    even: Spanned<Triple>,
    odd: Spanned<Triple>,
    size: Spanned<f64>,
}

#[derive(Deserialize, Clone, Copy, Debug, PartialEq)]
#[serde(rename_all = "snake_case")]
enum LightKind {
    Point,
    Directional,
    Quad,
    Disk,
    Sphere,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct LightFile {
    #[serde(rename = "type")]
    kind: Spanned<LightKind>,
    position: Option<Spanned<V3>>,
    intensity: Option<Spanned<Triple>>,
    direction: Option<Spanned<V3>>,
    irradiance: Option<Spanned<Triple>>,
    corner: Option<Spanned<V3>>,
    edge1: Option<Spanned<V3>>,
    edge2: Option<Spanned<V3>>,
    center: Option<Spanned<V3>>,
    normal: Option<Spanned<V3>>,
    radius: Option<Spanned<f64>>,
    radiance: Option<Spanned<Triple>>,
    two_sided: Option<Spanned<bool>>,
    light_samples: Option<Spanned<u32>>,
}

/// A light of the scene file: a delta light or one with a shape.
enum AnyLight {
    Delta(Light),
    Area(AreaLight),
}

/// A colour or per-axis factor: one number for all three channels, or `[r, g, b]`.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Triple([f64; 3]);

impl<'de> Deserialize<'de> for Triple {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        struct TripleVisitor;
        impl<'de> Visitor<'de> for TripleVisitor {
            type Value = Triple;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a number or an array of 3 numbers")
            }
            fn visit_f64<E: de::Error>(self, v: f64) -> Result<Triple, E> {
                Ok(Triple([v; 3]))
            }
            fn visit_i64<E: de::Error>(self, v: i64) -> Result<Triple, E> {
                Ok(Triple([v as f64; 3]))
            }
            fn visit_u64<E: de::Error>(self, v: u64) -> Result<Triple, E> {
                Ok(Triple([v as f64; 3]))
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Triple, A::Error> {
                let mut v = [0.0; 3];
                for (i, x) in v.iter_mut().enumerate() {
                    *x = seq.next_element()?.ok_or_else(|| de::Error::invalid_length(i, &self))?;
                }
                if seq.next_element::<de::IgnoredAny>()?.is_some() {
                    return Err(de::Error::invalid_length(4, &self));
                }
                Ok(Triple(v))
            }
        }
        deserializer.deserialize_any(TripleVisitor)
    }
}

// ---------------------------------------------------------------------------------------------
// From the schema to a Scene, checking every value.

/// A problem and where it is in the file.
struct Problem {
    span: Option<Range<usize>>,
    message: String,
}

fn at(span: Range<usize>, message: impl Into<String>) -> Problem {
    Problem { span: Some(span), message: message.into() }
}

/// A number as a person would write it: `1e39` rather than forty digits.
fn num(x: f64) -> String {
    if x != 0.0 && x.is_finite() && !(1e-5..1e16).contains(&x.abs()) { format!("{x:e}") } else { format!("{x}") }
}

fn fmt3(v: [f64; 3]) -> String {
    format!("[{}, {}, {}]", num(v[0]), num(v[1]), num(v[2]))
}

/// A number that is finite in f32 (TOML allows `nan` and `inf`; 1e39 overflows f32).
fn is_finite32(x: f64) -> bool {
    x.is_finite() && (x as f32).is_finite()
}

fn number(value: &Spanned<f64>, what: &str) -> Result<f64, Problem> {
    let x = *value.get_ref();
    if is_finite32(x) { Ok(x) } else { Err(at(value.span(), format!("{what} {} is not a finite number", num(x)))) }
}

fn point(value: &Spanned<V3>, what: &str) -> Result<DVec3, Problem> {
    let v = value.get_ref().0;
    if v.iter().all(|&x| is_finite32(x)) {
        Ok(DVec3::from(v))
    } else {
        Err(at(value.span(), format!("{what} {} is not finite", fmt3(v))))
    }
}

/// A non-zero direction, normalised.
fn direction(value: &Spanned<V3>, what: &str) -> Result<DVec3, Problem> {
    let v = point(value, what)?;
    let n = v.normalize_or_zero();
    if n == DVec3::ZERO { Err(at(value.span(), format!("{what} {} has no direction", fmt3(v.into())))) } else { Ok(n) }
}

/// A colour with every channel finite, ≥ 0 and (for reflectances) ≤ `max`.
fn color(value: &Spanned<Triple>, what: &str, max: Option<f64>) -> Result<Vec3, Problem> {
    let v = value.get_ref().0;
    if !v.iter().all(|&x| is_finite32(x)) {
        return Err(at(value.span(), format!("{what} {} is not finite", fmt3(v))));
    }
    if v.iter().any(|&x| x < 0.0) {
        return Err(at(value.span(), format!("{what} {} must not be negative", fmt3(v))));
    }
    if let Some(max) = max.filter(|&m| v.iter().any(|&x| x > m)) {
        return Err(at(value.span(), format!("{what} {} is a reflectance and must lie in [0, {max}]", fmt3(v))));
    }
    Ok(DVec3::from(v).as_vec3())
}

fn optional_color(value: &Option<Spanned<Triple>>, what: &str, max: Option<f64>) -> Result<Vec3, Problem> {
    value.as_ref().map_or(Ok(Vec3::ZERO), |v| color(v, what, max))
}

/// A required key of a table at `span`.
fn required<'a, T>(value: &'a Option<Spanned<T>>, what: &str, span: &Range<usize>) -> Result<&'a Spanned<T>, Problem> {
    value.as_ref().ok_or_else(|| at(span.clone(), format!("missing `{what}`")))
}

impl SceneFile {
    /// The scene, the warnings of its mesh files, and what each object added.
    fn into_scene(self, base: &Path) -> Result<(Scene, Vec<Problem>, Vec<ObjectSummary>), Problem> {
        let camera = self.camera.get_ref().to_spec(&self.camera.span())?;
        let image = match &self.image {
            Some(image) => image.get_ref().to_spec(&image.span())?,
            None => ImageSpec::default(),
        };
        let output = self.output.as_ref().map_or(Ok(OutputSpec::default()), |o| o.get_ref().to_spec())?;
        let render = self.render.as_ref().map_or(Ok(RenderSpec::default()), |r| r.get_ref().to_spec())?;
        let environment = self.environment.as_ref().map(|e| e.get_ref().to_environment(&e.span(), base)).transpose()?;
        let mut scene = Scene { camera, image, output, render, environment, ..Default::default() };
        let mut material_ids = BTreeMap::new();
        for (i, (name, m)) in self.materials.iter().enumerate() {
            let material = m.get_ref().to_material(name, base).map_err(|p| prefix(p, &format!("material '{name}'")))?;
            if name.contains('/') {
                let message = "a material name cannot contain '/' (kept for the materials of mesh files)";
                return Err(at(m.span(), format!("material '{name}': {message}")));
            }
            scene.materials.push(material);
            material_ids.insert(name.as_str(), i as u32);
        }
        for (i, light) in self.lights.iter().enumerate() {
            match light.get_ref().to_light(&light.span()).map_err(|p| prefix(p, &format!("light {i}")))? {
                AnyLight::Delta(l) => scene.lights.push(l),
                AnyLight::Area(l) => scene.area_lights.push(l),
            }
        }
        let (mut warnings, mut objects) = (Vec::new(), Vec::new());
        let instanced = self.objects.iter().filter_map(|o| o.get_ref().instance_of()).collect();
        let placements = std::cell::RefCell::new(BTreeMap::new());
        for (i, object) in self.objects.iter().enumerate() {
            let ctx = ObjectContext {
                span: object.span(),
                index: i,
                materials: &material_ids,
                base,
                instanced: &instanced,
                placements: &placements,
            };
            let o = object.get_ref();
            let (summary, object_warnings) = o.add_to(&mut scene, &ctx).map_err(|p| prefix(p, &o.label(i)))?;
            warnings.extend(object_warnings.into_iter().map(|w| prefix(w, &o.label(i))));
            objects.push(summary);
        }
        crate::scene::emitters::add_emitters(&mut scene);
        Ok((scene, warnings, objects))
    }
}

fn prefix(mut p: Problem, what: &str) -> Problem {
    p.message = format!("{what}: {}", p.message);
    p
}

impl CameraFile {
    /// A lens length in metres: finite and at least `min` (absent: 0, the pinhole's).
    fn lens_value(&self, value: &Option<Spanned<f64>>, what: &str, min: f64) -> Result<f32, Problem> {
        let Some(v) = value else { return Ok(0.0) };
        let x = number(v, what)?;
        if !(x >= min && (x as f32).is_finite()) {
            let bound = if min > 0.0 { "> 0" } else { "≥ 0" };
            return Err(at(v.span(), format!("camera: {what} {x} must be finite and {bound} (metres)")));
        }
        Ok(x as f32)
    }

    fn to_spec(&self, span: &Range<usize>) -> Result<CameraSpec, Problem> {
        let spec = CameraSpec {
            eye: point(&self.eye, "eye")?.as_vec3(),
            target: point(&self.target, "target")?.as_vec3(),
            up: self.up.as_ref().map_or(Ok(DVec3::Y), |up| point(up, "up"))?.as_vec3(),
            fov_deg: number(&self.fov_deg, "fov_deg")? as f32,
            lens: Lens {
                aperture: self.lens_value(&self.aperture, "aperture", 0.0)?,
                focus_distance: self.lens_value(&self.focus_distance, "focus_distance", f64::MIN_POSITIVE)?,
                ..Lens::PINHOLE
            },
        };
        if let Some((field, message)) = camera_problem(&spec) {
            let field_span = match field {
                "eye" => Some(self.eye.span()),
                "target" => Some(self.target.span()),
                "up" => self.up.as_ref().map(|u| u.span()),
                "fov_deg" => Some(self.fov_deg.span()),
                "aperture" => self.aperture.as_ref().map(|a| a.span()),
                "focus_distance" => self.focus_distance.as_ref().map(|f| f.span()),
                _ => None,
            };
            return Err(at(field_span.unwrap_or_else(|| span.clone()), format!("camera: {message}")));
        }
        Ok(spec)
    }
}

impl ImageFile {
    fn to_spec(&self, span: &Range<usize>) -> Result<ImageSpec, Problem> {
        let d = ImageSpec::default();
        let int = |v: &Option<Spanned<u32>>, default: u32| v.as_ref().map_or(default, |v| *v.get_ref());
        let spec = ImageSpec {
            width: int(&self.width, d.width),
            height: int(&self.height, d.height),
            spp: int(&self.spp, d.spp),
            max_depth: int(&self.max_depth, d.max_depth),
            background: self.background.as_ref().map_or(Ok(d.background), |c| color(c, "background", None))?,
            ambient: self.ambient.as_ref().map_or(Ok(d.ambient), |c| color(c, "ambient", None))?,
            mesh_lights: self.mesh_lights.unwrap_or(d.mesh_lights),
            mesh_light_samples: int(&self.mesh_light_samples, d.mesh_light_samples),
        };
        if let Some((field, message)) = image_problem(&spec) {
            let field_span = match field {
                "width" => self.width.as_ref().map(|v| v.span()),
                "height" => self.height.as_ref().map(|v| v.span()),
                "spp" => self.spp.as_ref().map(|v| v.span()),
                "max_depth" => self.max_depth.as_ref().map(|v| v.span()),
                "mesh_light_samples" => self.mesh_light_samples.as_ref().map(|v| v.span()),
                _ => None,
            };
            return Err(at(field_span.unwrap_or_else(|| span.clone()), format!("image: {message}")));
        }
        Ok(spec)
    }
}

impl MaterialFile {
    fn to_material(&self, name: &str, base: &Path) -> Result<Material, Problem> {
        if let Some(material) = pbr::material(self, name, base)? {
            return Ok(material);
        }
        let diffuse = match (&self.diffuse, &self.checker) {
            (Some(_), Some(checker)) => {
                return Err(at(checker.span(), "give either `diffuse` or `checker`, not both"));
            }
            (Some(d), None) => Texture::Constant(color(d, "diffuse", Some(1.0))?),
            (None, Some(checker)) => {
                let c = checker.get_ref();
                let size = number(&c.size, "checker size")?;
                if size <= 0.0 {
                    return Err(at(c.size.span(), format!("checker size {size} must be > 0")));
                }
                Texture::Checker {
                    even: color(&c.even, "checker even", Some(1.0))?,
                    odd: color(&c.odd, "checker odd", Some(1.0))?,
                    size: size as f32,
                }
            }
            (None, None) => Texture::Constant(Vec3::ZERO),
        };
        let shininess = self.shininess.as_ref().map_or(Ok(0.0), |s| number(s, "shininess"))?;
        if shininess < 0.0 {
            return Err(at(self.shininess.as_ref().unwrap().span(), format!("shininess {shininess} must be ≥ 0")));
        }
        let ior = self.ior.as_ref().map_or(Ok(1.5), |s| number(s, "ior"))?;
        if ior <= 0.0 {
            return Err(at(self.ior.as_ref().unwrap().span(), format!("ior {ior} must be > 0")));
        }
        Ok(Material {
            name: name.to_string(),
            diffuse,
            specular: optional_color(&self.specular, "specular", Some(1.0))?,
            shininess: shininess as f32,
            mirror: optional_color(&self.mirror, "mirror", Some(1.0))?,
            transmission: optional_color(&self.transmission, "transmission", Some(1.0))?,
            ior: ior as f32,
            emission: optional_color(&self.emission, "emission", None)?,
            emission_one_sided: false,
            area_light: false,
            pbr: None,
            coverage: None,
        })
    }
}

impl LightFile {
    fn to_light(&self, span: &Range<usize>) -> Result<AnyLight, Problem> {
        let kind = *self.kind.get_ref();
        let v = |v: &Option<Spanned<V3>>| v.as_ref().map(|v| v.span());
        let c = |v: &Option<Spanned<Triple>>| v.as_ref().map(|v| v.span());
        let keys = [
            ("position", v(&self.position)),
            ("intensity", c(&self.intensity)),
            ("direction", v(&self.direction)),
            ("irradiance", c(&self.irradiance)),
            ("corner", v(&self.corner)),
            ("edge1", v(&self.edge1)),
            ("edge2", v(&self.edge2)),
            ("center", v(&self.center)),
            ("normal", v(&self.normal)),
            ("radius", self.radius.as_ref().map(|r| r.span())),
            ("radiance", c(&self.radiance)),
            ("two_sided", self.two_sided.as_ref().map(|r| r.span())),
            ("light_samples", self.light_samples.as_ref().map(|r| r.span())),
        ];
        const AREA: &str = "radiance, two_sided, light_samples";
        let (name, takes) = match kind {
            LightKind::Point => ("point", "position, intensity".to_string()),
            LightKind::Directional => ("directional", "direction, irradiance".to_string()),
            LightKind::Quad => ("quad", format!("corner, edge1, edge2, {AREA}")),
            LightKind::Disk => ("disk", format!("center, normal, radius, {AREA}")),
            LightKind::Sphere => ("sphere", format!("center, radius, {AREA}")),
        };
        let foreign = keys.into_iter().find(|(key, s)| s.is_some() && !takes.split(", ").any(|t| t == *key));
        if let Some((key, Some(key_span))) = foreign {
            return Err(at(key_span, format!("a {name} light has no `{key}` (it takes {takes})")));
        }
        let pos = |v: &Option<Spanned<V3>>, key: &str| Ok::<_, Problem>(point(required(v, key, span)?, key)?.as_vec3());
        let dir =
            |v: &Option<Spanned<V3>>, key: &str| Ok::<_, Problem>(direction(required(v, key, span)?, key)?.as_vec3());
        let radius = || {
            let r = required(&self.radius, "radius", span)?;
            let value = number(r, "radius")?;
            if !(value > 0.0 && (value as f32).is_finite()) {
                return Err(at(r.span(), format!("radius {value} must be > 0")));
            }
            Ok(value as f32)
        };
        let shape = match kind {
            LightKind::Point => {
                return Ok(AnyLight::Delta(Light::Point {
                    position: pos(&self.position, "position")?,
                    intensity: color(required(&self.intensity, "intensity", span)?, "intensity", None)?,
                }));
            }
            LightKind::Directional => {
                return Ok(AnyLight::Delta(Light::Directional {
                    direction: dir(&self.direction, "direction")?,
                    irradiance: color(required(&self.irradiance, "irradiance", span)?, "irradiance", None)?,
                }));
            }
            LightKind::Quad => Shape::Quad {
                corner: pos(&self.corner, "corner")?,
                edge1: pos(&self.edge1, "edge1")?,
                edge2: pos(&self.edge2, "edge2")?,
            },
            LightKind::Disk => Shape::Disk {
                center: pos(&self.center, "center")?,
                normal: dir(&self.normal, "normal")?.normalize(),
                radius: radius()?,
            },
            LightKind::Sphere => Shape::Sphere { center: pos(&self.center, "center")?, radius: radius()? },
        };
        let light = AreaLight {
            shape,
            radiance: color(required(&self.radiance, "radiance", span)?, "radiance", None)?,
            two_sided: self.two_sided.as_ref().is_some_and(|t| *t.get_ref()),
            samples: self.light_samples.as_ref().map_or(1, |n| *n.get_ref()),
        };
        if let Some(problem) = light.problem() {
            let at_key =
                if problem.starts_with("light_samples") { self.light_samples.as_ref().map(|n| n.span()) } else { None };
            return Err(at(at_key.unwrap_or_else(|| span.clone()), problem));
        }
        Ok(AnyLight::Area(light))
    }
}
