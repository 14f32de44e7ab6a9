//! The header attributes strahl writes into its EXRs, beyond the channels and Cryptomatte.
//!
//! | attribute | type | value |
//! |---|---|---|
//! | `software` | string | `strahl VERSION` (OpenEXR standard attribute) |
//! | `capDate` | string | the date the render finished, `YYYY:MM:DD hh:mm:ss`, UTC (standard) |
//! | `utcOffset` | float | 0: `capDate` is UTC (standard) |
//! | `Date` | string | the same date as Blender writes it, `YYYY/MM/DD hh:mm:ss` |
//! | `renderTimeSeconds` | float | wall time of rendering, seconds (as pbrt-v4 writes it) |
//! | `RenderTime` | string | the same as Blender writes it, `MM:SS.ss` |
//! | `samplesPerPixel` | int | samples per pixel (as pbrt-v4) |
//! | `strahl/maxDepth` | int | longest chain of reflected/refracted rays |
//! | `strahl/integrator` | string | `whitted` or `path` |
//! | `strahl/lightSampler` | string | the path tracer's light selection, `tree` or `power` (path tracer only) |
//! | `strahl/clamp` | float | the path tracer's clamp of indirect samples (only when set) |
//! | `strahl/adaptiveThreshold` | float | adaptive sampling's noise threshold (only when on) |
//! | `strahl/seed` | int | the seed of the sample sequences (only when not 0) |
//! | `strahl/backend` | string | `embree` or `native` |
//! | `strahl/scene` | string | the scene file's name, without its folder ([`scene_entry`]) |
//! | `strahl/sceneHash` | string | [`crate::scene::hash::scene_hash_hex`]: 16 hex digits |
//! | `strahl/transparent` | int | 1 for a transparent render (alpha = coverage), else 0 |
//! | `strahl/renderKey` | string | what the file is the render of ([`RENDER_KEY`]) |
//! | `Scene`, `File` | string | the scene file's name without its extension, and with it (Blender: the scene's name and the `.blend` file) |
//! | `Camera` | string | the camera's name, when the scene file gives one (a glTF camera's node name) |
//! | `Frame` | string | the frame number (`--frame`, default 1), at least 3 digits: `001` |
//! | `Time` | string | that frame's SMPTE timecode `hh:mm:ss:ff` at `--fps` (default 24): frame 1 is `00:00:00:01`, as Blender writes it |
//! | `cycles.ViewLayer.samples` | string | samples per pixel, under the key Blender's image editor and Cycles' files show it (the view layer's name in place of `ViewLayer` under `--layer-name`) |
//! | `cycles.ViewLayer.render_time` | string | the render time, as `RenderTime` (likewise) |
//! | `BlenderMultiChannel` | string | `Blender V2.55.1 and newer`, in the `blender` layout only: the key Blender writes into its multilayer files |
//! | `worldToCamera` | m44f | world → camera space (below) |
//! | `worldToNDC` | m44f | world → normalised device coordinates (below) |
//!
//! `screenWindowCenter = (0, 0)`, `screenWindowWidth = 1` and `pixelAspectRatio = 1` (square
//! pixels) are always written, as OpenEXR requires.
//!
//! **The camera matrices follow OpenEXR's definition** (ImfStandardAttributes.h): Imath
//! matrices for row vectors, `p' = [x y z 1] · M`, stored row by row, so the translation is in
//! elements 12–14. Camera space is left-handed: origin at the eye, `+x` right and `+y` up in
//! the image, `+z` along the view direction (RenderMan's and pbrt-v4's camera space): with the
//! lecture's basis, `x = u·(p−e)`, `y = v·(p−e)`, `z = −w·(p−e)`. NDC is `(0, 0)` at the
//! display window's top-left corner and `(1, 1)` at its bottom-right, `x` right, `y` down:
//! `[X Y Z W] = [p 1] · worldToNDC`, then `(X/W, Y/W)` (Z is discarded). pbrt-v4 writes the
//! same spaces but copies its own column-vector matrices element by element, so its files hold
//! the transpose of these: a reader of both must transpose pbrt-v4's.
//!
//! **Reproducible bytes.** The date and render times are the only attributes that change
//! from one run to the next. When the environment variable `SOURCE_DATE_EPOCH` (the
//! reproducible-builds convention: seconds since 1970) is set, the date is that time and the
//! render times are left out, so the same scene gives the same bytes on every run.

use std::io::{BufReader, Read};
use std::path::Path;
use std::time::{SystemTime, UNIX_EPOCH};

use glam::DVec3;

use super::exr::{Attribute, VIEW_LAYER};
use crate::camera::Camera;
use crate::scene::Scene;

/// The attribute naming what the file is a render of: strahl's version, the scene/settings
/// hash, the tile size, the backend and how the EXR is written (layout, compression, sample
/// type); not the region, which the data window says, so that the parts of one frame carry the
/// same key and their merge is the bytes of the whole frame rendered at once. A render with
/// `--resume` whose EXR carries its own key and data window has nothing to do
/// ([`crate::job::RenderJob::complete`]).
pub const RENDER_KEY: &str = "strahl/renderKey";

/// The text attribute `name` of the first header of the EXR at `path` and that header's data
/// window (in the display window's coordinates), when the file is a regular file whose headers
/// read within 64 MB; `None` otherwise (not an EXR, damaged, no such attribute).
pub fn read_text_attribute(path: &Path, name: &str) -> Option<(String, crate::output::region::Region)> {
    let (file, _) = crate::sys::read::open_regular(path, u64::MAX, "").ok()?;
    let reader = BufReader::new(file.take(64 << 20));
    let meta = exr::meta::MetaData::read_from_buffered(reader, false).ok()?;
    let header = meta.headers.first()?;
    let exr::meta::attribute::AttributeValue::Text(t) =
        header.own_attributes.other.get(&exr::prelude::Text::from(name))?
    else {
        return None;
    };
    let (origin, display) = (header.own_attributes.layer_position, header.shared_attributes.display_window.position);
    let x0 = u32::try_from(origin.0 as i64 - display.0 as i64).ok()?;
    let y0 = u32::try_from(origin.1 as i64 - display.1 as i64).ok()?;
    let (w, h) = (u32::try_from(header.layer_size.0).ok()?, u32::try_from(header.layer_size.1).ok()?);
    let region = crate::output::region::Region { x0, y0, x1: x0.checked_add(w)?, y1: y0.checked_add(h)? };
    Some((String::from_utf8_lossy(t.as_slice()).into_owned(), region))
}

/// What the header records about one render beyond the scene itself.
#[derive(Clone, Debug, Default)]
pub struct RenderInfo {
    /// The scene file as given.
    pub scene_file: String,
    /// `embree` or `native`.
    pub backend: String,
    /// Wall time of rendering.
    pub render_seconds: f64,
    /// The frame number and frames per second (`Frame`, `Time`).
    pub frame: u32,
    pub fps: u32,
    /// The view layer the channels are named under (`--layer-name`; `None`: `ViewLayer`).
    pub layer: Option<String>,
}

/// The attributes of the module docs for `scene`, rendered as `info` says. A render makes
/// them before it starts (so that the writer can check them,
/// [`crate::output::exr::check_encodable`]) and puts the date and time it ends in with [`finish`].
pub fn attributes(scene: &Scene, info: &RenderInfo) -> Vec<(String, Attribute)> {
    let text = |s: &str| Attribute::Text(s.to_string());
    let mut out = vec![
        ("software".into(), text(&format!("strahl {}", env!("CARGO_PKG_VERSION")))),
        ("utcOffset".into(), Attribute::Float(0.0)),
        ("samplesPerPixel".into(), Attribute::Int(scene.image.spp as i32)),
        ("strahl/maxDepth".into(), Attribute::Int(scene.image.max_depth as i32)),
        ("strahl/integrator".into(), text(scene.render.integrator.name())),
        ("strahl/backend".into(), text(&info.backend)),
        ("strahl/scene".into(), text(&scene_entry(&info.scene_file))),
        ("strahl/sceneHash".into(), text(&crate::scene::hash::scene_hash_hex(scene))),
        ("strahl/transparent".into(), Attribute::Int(scene.output.transparent as i32)),
        ("Scene".into(), text(&scene_stem(&info.scene_file))),
        ("File".into(), text(&scene_entry(&info.scene_file))),
        ("Frame".into(), text(&format!("{:03}", info.frame))),
        ("Time".into(), text(&timecode(info.frame, info.fps))),
        (format!("cycles.{}.samples", info.layer.as_deref().unwrap_or(VIEW_LAYER)), text(&scene.image.spp.to_string())),
    ];
    if scene.render.integrator == crate::scene::IntegratorKind::Path {
        out.push(("strahl/lightSampler".into(), text(scene.render.light_sampler.name())));
        if let Some(clamp) = scene.render.clamp {
            out.push(("strahl/clamp".into(), Attribute::Float(clamp)));
        }
        if let Some(adaptive) = &scene.render.adaptive {
            out.push(("strahl/adaptiveThreshold".into(), Attribute::Float(adaptive.threshold)));
        }
    }
    if scene.render.seed != 0 {
        out.push(("strahl/seed".into(), Attribute::Int(scene.render.seed as i32)));
    }
    if let Some(name) = &scene.names.camera {
        out.push(("Camera".into(), text(name)));
    }
    if let Ok(camera) = Camera::new(&scene.camera, scene.image.width, scene.image.height) {
        let (to_camera, to_ndc) = camera_matrices(&camera);
        out.push(("worldToCamera".into(), Attribute::Matrix(to_camera)));
        out.push(("worldToNDC".into(), Attribute::Matrix(to_ndc)));
    }
    finish(&mut out, info.render_seconds);
    out
}

/// Puts into `attributes` (of [`attributes`]) the date of now and the render time
/// `render_seconds`, in place of those it had (see the module docs for `SOURCE_DATE_EPOCH`).
pub fn finish(attributes: &mut Vec<(String, Attribute)>, render_seconds: f64) {
    let text = |s: &str| Attribute::Text(s.to_string());
    let fixed_date = std::env::var("SOURCE_DATE_EPOCH").ok().and_then(|s| s.trim().parse::<u64>().ok());
    let seconds = fixed_date.unwrap_or_else(|| SystemTime::now().duration_since(UNIX_EPOCH).map_or(0, |d| d.as_secs()));
    let (y, mo, d, h, mi, s) = civil_utc(seconds);
    let mut run = vec![
        ("capDate".to_string(), text(&format!("{y:04}:{mo:02}:{d:02} {h:02}:{mi:02}:{s:02}"))),
        ("Date".to_string(), text(&format!("{y:04}/{mo:02}/{d:02} {h:02}:{mi:02}:{s:02}"))),
    ];
    if fixed_date.is_none() {
        run.push(("renderTimeSeconds".into(), Attribute::Float(render_seconds as f32)));
        run.push(("RenderTime".into(), text(&render_time_text(render_seconds))));
        // Under the layer of the `cycles.LAYER.samples` key [`attributes`] wrote.
        let samples = attributes.iter().find(|(n, _)| n.starts_with("cycles.") && n.ends_with(".samples"));
        if let Some(key) = samples.map(|(n, _)| n.replace(".samples", ".render_time")) {
            run.push((key, text(&render_time_text(render_seconds))));
        }
    }
    for (name, value) in run {
        match attributes.iter_mut().find(|(n, _)| *n == name) {
            Some(entry) => entry.1 = value,
            None => attributes.push((name, value)),
        }
    }
}

/// The `strahl/scene` entry of the scene file `path`: its file name, however the folder was
/// spelled (relative, absolute, through a link) and wherever it lies, so that a frame rendered
/// in one process, or as a farm's tiles from an absolute path, or on another machine, has the
/// same bytes; `strahl/sceneHash` identifies what the scene holds.
pub fn scene_entry(path: &str) -> String {
    std::path::Path::new(path).file_name().map_or_else(|| path.to_string(), |n| n.to_string_lossy().into_owned())
}

/// The scene file's name without its folder and extension (the header's `Scene`).
pub fn scene_stem(path: &str) -> String {
    std::path::Path::new(path).file_stem().map_or_else(|| path.to_string(), |n| n.to_string_lossy().into_owned())
}

/// Frame `frame` at `fps` frames per second as an SMPTE timecode `hh:mm:ss:ff`, as Blender
/// writes `Time` (frame `f` lies at `f / fps` seconds: frame 1 is `00:00:00:01`).
pub fn timecode(frame: u32, fps: u32) -> String {
    let fps = fps.max(1);
    let seconds = frame / fps;
    format!("{:02}:{:02}:{:02}:{:02}", seconds / 3600, seconds / 60 % 60, seconds % 60, frame % fps)
}

/// `seconds` as Blender writes `RenderTime`: `MM:SS.ss`.
pub fn render_time_text(seconds: f64) -> String {
    format!("{:02}:{:05.2}", (seconds / 60.0).floor(), seconds % 60.0)
}

/// `worldToCamera` and `worldToNDC` of `camera` as the module docs define them, row-major
/// Imath matrices for row vectors.
pub fn camera_matrices(camera: &Camera) -> ([f32; 16], [f32; 16]) {
    let (u, v, w) = camera.basis();
    let (u, v, w, e) = (u.as_dvec3(), v.as_dvec3(), w.as_dvec3(), camera.eye().as_dvec3());
    // Columns of the row-vector matrix: camera x, y, z as linear functions of [p 1].
    let column = |axis: DVec3| [axis.x, axis.y, axis.z, -axis.dot(e)];
    let (cx, cy, cz) = (column(u), column(v), column(-w));
    let (l, r, b, t) = camera.edges();
    // NDC before the division by W = z: X = (x − l·z)/(r − l), Y = (y − t·z)/(b − t), Z = 1.
    let (a, bx) = (1.0 / (r - l), -l / (r - l));
    let (c, by) = (1.0 / (b - t), -t / (b - t));
    let mut to_camera = [0f32; 16];
    let mut to_ndc = [0f32; 16];
    for i in 0..4 {
        to_camera[4 * i] = cx[i] as f32;
        to_camera[4 * i + 1] = cy[i] as f32;
        to_camera[4 * i + 2] = cz[i] as f32;
        to_camera[4 * i + 3] = if i == 3 { 1.0 } else { 0.0 };
        let one = if i == 3 { 1.0 } else { 0.0 };
        if camera.is_orthographic() {
            // No division: X = (x − l)/(r − l), Y = (y − t)/(b − t), Z = W = 1.
            to_ndc[4 * i] = (a * cx[i] + bx * one) as f32;
            to_ndc[4 * i + 1] = (c * cy[i] + by * one) as f32;
            to_ndc[4 * i + 3] = one as f32;
        } else {
            to_ndc[4 * i] = (a * cx[i] + bx * cz[i]) as f32;
            to_ndc[4 * i + 1] = (c * cy[i] + by * cz[i]) as f32;
            to_ndc[4 * i + 3] = cz[i] as f32;
        }
        to_ndc[4 * i + 2] = one as f32;
    }
    (to_camera, to_ndc)
}

/// Applies a row-major row-vector matrix to the point `p`: `[p 1] · m`.
pub fn transform_point(m: &[f32; 16], p: DVec3) -> [f64; 4] {
    let row = [p.x, p.y, p.z, 1.0];
    std::array::from_fn(|j| (0..4).map(|i| row[i] * m[4 * i + j] as f64).sum())
}

/// `(year, month, day, hour, minute, second)` in UTC of `seconds` since 1970-01-01 (Howard
/// Hinnant's days-to-civil algorithm; ten lines rather than a date crate for one timestamp).
fn civil_utc(seconds: u64) -> (i64, u32, u32, u32, u32, u32) {
    let days = (seconds / 86400) as i64;
    let rem = seconds % 86400;
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = (doy - (153 * mp + 2) / 5 + 1) as u32;
    let month = if mp < 10 { mp + 3 } else { mp - 9 } as u32;
    let year = yoe + era * 400 + (month <= 2) as i64;
    (year, month, day, (rem / 3600) as u32, (rem / 60 % 60) as u32, (rem % 60) as u32)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Vec2;
    use crate::math::Vec3;
    use crate::scene::CameraSpec;

    #[test]
    fn timecodes_as_blender_writes_them() {
        assert_eq!(timecode(1, 24), "00:00:00:01"); // the Cycles reference file's frame 1
        assert_eq!(timecode(24, 24), "00:00:01:00");
        assert_eq!(timecode(25 * 3661 + 7, 25), "01:01:01:07");
    }

    #[test]
    fn civil_dates() {
        assert_eq!(civil_utc(0), (1970, 1, 1, 0, 0, 0));
        assert_eq!(civil_utc(951_782_400), (2000, 2, 29, 0, 0, 0));
        assert_eq!(civil_utc(1_795_561_200), (2026, 11, 24, 23, 0, 0));
    }

    #[test]
    fn a_point_on_a_pixel_ray_lands_on_that_pixel_and_its_distance() {
        let spec = CameraSpec {
            eye: Vec3::new(1.0, 2.0, 3.0),
            target: Vec3::new(-1.0, 0.5, -2.0),
            up: Vec3::Y,
            fov_deg: 50.0,
            lens: Default::default(),
        };
        let camera = Camera::new(&spec, 64, 48).unwrap();
        let (to_camera, to_ndc) = camera_matrices(&camera);
        for (x, y) in [(0, 0), (63, 0), (17, 30), (63, 47)] {
            let ray = camera.ray(x, y, Vec2::splat(0.5));
            let p = ray.org.as_dvec3() + 7.5 * ray.dir.as_dvec3();
            let c = transform_point(&to_camera, p);
            assert!((DVec3::new(c[0], c[1], c[2]).length() - 7.5).abs() < 1e-5);
            assert!(c[2] > 0.0, "in front of the camera: +z");
            let n = transform_point(&to_ndc, p);
            let (nx, ny) = (n[0] / n[3], n[1] / n[3]);
            assert!((nx - (x as f64 + 0.5) / 64.0).abs() < 1e-5, "pixel ({x}, {y}): ndc x {nx}");
            assert!((ny - (y as f64 + 0.5) / 48.0).abs() < 1e-5, "pixel ({x}, {y}): ndc y {ny}");
        }
        // +x is right in the image, +y up.
        let right = camera.ray(63, 24, Vec2::splat(0.5));
        assert!(transform_point(&to_camera, (right.org + right.dir).as_dvec3())[0] > 0.0);
        let top = camera.ray(32, 0, Vec2::splat(0.5));
        assert!(transform_point(&to_camera, (top.org + top.dir).as_dvec3())[1] > 0.0);
    }
}
