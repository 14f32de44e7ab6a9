//! What the tests share: an Embree backend for a scene, a render call, the lecture's
//! pinhole camera and ray–triangle intersection written out again in f64 as independent
//! references, the shared mesh data folder, temporary folders, running the `strahl` binary and
//! reading back the EXR it writes.

#![allow(dead_code)] // each test file uses a different subset

use std::ffi::OsStr;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};

use exr::prelude::{FlatSamples, ReadChannels, ReadLayers};
use glam::DVec3;
use strahl::accel::embree::{BuildOptions, Device, EmbreeAccel};
use strahl::integrator::{self, RayCounts};
use strahl::output::film::Film;
use strahl::scene::{CameraSpec, Scene};

pub fn accel(scene: &Scene) -> EmbreeAccel {
    let device = Device::new().expect("an Embree device");
    EmbreeAccel::build(&device, scene, BuildOptions::default()).expect("the scene builds")
}

/// Renders `scene` with Embree on the current rayon pool.
pub fn render(scene: &Scene) -> (Film, RayCounts) {
    integrator::render(scene, &accel(scene), &|_| {}).expect("the scene renders")
}

/// The mean of `values` and its standard error, the values being independent estimates of
/// the same quantity (a converged image's pixels, say).
pub fn mean_and_error(values: &[f64]) -> (f64, f64) {
    let n = values.len() as f64;
    let mean = values.iter().sum::<f64>() / n;
    let var = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0);
    (mean, (var / n).sqrt())
}

/// `|a − b| / |b|`.
pub fn rel(a: f32, b: f64) -> f64 {
    ((a as f64) - b).abs() / b.abs()
}

/// The lecture's pixel-centre ray direction (unit), computed from scratch in f64:
/// `w = (e−z)/|e−z|`, `u = up×w`, `v = w×u`, `t = tan(fov/2)`, `r = t·W/H`,
/// `u = l + (r−l)(x+0.5)/W`, `v = t + (b−t)(y+0.5)/H`, `s = u·u + v·v − w`.
pub fn lecture_ray(cam: &CameraSpec, width: u32, height: u32, x: u32, y: u32) -> (DVec3, DVec3) {
    let (e, z, up) = (cam.eye.as_dvec3(), cam.target.as_dvec3(), cam.up.as_dvec3());
    let w = (e - z).normalize();
    let u = up.cross(w).normalize();
    let v = w.cross(u);
    let t = (cam.fov_deg as f64).to_radians().mul_add(0.5, 0.0).tan();
    let (b, r) = (-t, t * width as f64 / height as f64);
    let l = -r;
    let su = l + (r - l) * (x as f64 + 0.5) / width as f64;
    let sv = t + (b - t) * (y as f64 + 0.5) / height as f64;
    (e, (su * u + sv * v - w).normalize())
}

/// The view-axis depth (Blender's Depth, the film's `depth`) of the point at parameter `t` of the
/// ray from the eye along `dir` (any length) of the camera `cam`: `t·(dir·f)`, with `f` the unit
/// view direction.
pub fn axis_depth(cam: &CameraSpec, dir: DVec3, t: f64) -> f64 {
    t * dir.dot((cam.target.as_dvec3() - cam.eye.as_dvec3()).normalize())
}

/// The Cryptomatte matte of object `name` in the EXR at `path` (its `channels`, read by
/// [`read_exr`]), as a compositor's pick computes it: the name's id from the file's own
/// `ViewLayer.CryptoObject` manifest, and at each pixel the summed coverage of the ranks
/// holding that id, over every `CryptoObjectNN` layer. `None` when the manifest lacks the name.
pub fn crypto_matte(path: &Path, channels: &[(String, Vec<f32>)], name: &str) -> Option<Vec<f32>> {
    use exr::meta::attribute::{AttributeValue, Text};
    let image = read_exr_image(path);
    let attrs = &image.layer_data[0].attributes.other;
    let text = |v: &AttributeValue| match v {
        AttributeValue::Text(t) => t.to_string(),
        other => panic!("{other:?} is not text"),
    };
    let key = attrs
        .iter()
        .find(|(k, v)| k.to_string().ends_with("/name") && text(v) == "ViewLayer.CryptoObject")
        .map(|(k, _)| k.to_string().replace("/name", "/manifest"))
        .expect("a CryptoObject manifest");
    let manifest: std::collections::HashMap<String, String> =
        serde_json::from_str(&text(&attrs[&Text::from(key.as_str())])).unwrap();
    let id = u32::from_str_radix(manifest.get(name)?, 16).unwrap();
    let pixels = channels[0].1.len();
    let mut matte = vec![0.0f32; pixels];
    for layer in (0..).map(|k| format!("ViewLayer.CryptoObject{k:02}")) {
        let Some((_, r)) = channels.iter().find(|(n, _)| *n == format!("{layer}.r")) else { break };
        let c = |s: &str| channel(channels, &format!("{layer}.{s}"));
        let (g, b, a) = (c("g"), c("b"), c("a"));
        for i in 0..pixels {
            matte[i] += if r[i].to_bits() == id { g[i] } else { 0.0 } + if b[i].to_bits() == id { a[i] } else { 0.0 };
        }
    }
    Some(matte)
}

/// The form factor from a point to a parallel rectangle of sides `a`, `b` at height `h` with
/// one corner straight above it (the differential area to a parallel rectangle, Howell's
/// catalogue of configuration factors):
/// `F = (1/2π)[a/√(a²+h²)·atan(b/√(a²+h²)) + b/√(b²+h²)·atan(a/√(b²+h²))]`.
pub fn corner_form_factor(a: f64, b: f64, h: f64) -> f64 {
    let (ra, rb) = ((a * a + h * h).sqrt(), (b * b + h * h).sqrt());
    (a / ra * (b / ra).atan() + b / rb * (a / rb).atan()) / (2.0 * std::f64::consts::PI)
}

/// The form factor to the rectangle `[x0, x1] × [z0, z1]` at height `h` from the point
/// `(px, pz)` below it, by adding and subtracting rectangles with a corner above the point.
pub fn form_factor(x0: f64, x1: f64, z0: f64, z1: f64, h: f64, px: f64, pz: f64) -> f64 {
    let signed = |x: f64, z: f64| {
        let (dx, dz) = (x - px, z - pz);
        dx.signum() * dz.signum() * corner_form_factor(dx.abs(), dz.abs(), h)
    };
    signed(x1, z1) - signed(x0, z1) - signed(x1, z0) + signed(x0, z0)
}

/// Films compared bit for bit (so `-0.0 ≠ 0.0` and NaNs compare too).
pub fn same_bits(a: &Film, b: &Film) -> bool {
    let bits3 = |v: &[glam::Vec3]| v.iter().flat_map(|x| x.to_array()).map(f32::to_bits).collect::<Vec<_>>();
    a.width == b.width
        && a.height == b.height
        && a.rgba.iter().flatten().map(|x| x.to_bits()).eq(b.rgba.iter().flatten().map(|x| x.to_bits()))
        && a.depth.iter().map(|x| x.to_bits()).eq(b.depth.iter().map(|x| x.to_bits()))
        && bits3(&a.normal) == bits3(&b.normal)
        && bits3(&a.albedo) == bits3(&b.albedo)
}

/// Ray–triangle (Möller–Trumbore) in f64: `Ok(Some(t))` for a hit, `Ok(None)` for a miss,
/// `Err(t)` when the ray meets the triangle's plane at `t` within `margin` (in barycentric
/// terms) of the triangle's outline, where f32 and f64 may disagree on hit or miss.
pub fn triangle_hit(org: DVec3, dir: DVec3, [a, b, c]: [DVec3; 3], margin: f64) -> Result<Option<f64>, f64> {
    let (e1, e2) = (b - a, c - a);
    let p = dir.cross(e2);
    let det = e1.dot(p);
    if det.abs() < 1e-12 {
        return Ok(None);
    }
    let s = org - a;
    let u = s.dot(p) / det;
    let q = s.cross(e1);
    let v = dir.dot(q) / det;
    let t = e2.dot(q) / det;
    if t <= 1e-9 {
        return Ok(None);
    }
    // > 0 inside the triangle, < 0 outside.
    let inside_by = u.min(v).min(1.0 - u - v);
    if inside_by.abs() < margin {
        return Err(t);
    }
    Ok((inside_by > 0.0).then_some(t))
}

/// The shared test meshes: `../shared/data/meshes` beside the crate, or `$STRAHL_TEST_DATA`.
/// When the folder is missing, a test that needs it fails under CI (`CI` set) and is skipped
/// loudly elsewhere (`None`).
pub fn data_dir() -> Option<PathBuf> {
    let dir = std::env::var_os("STRAHL_TEST_DATA")
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/data/meshes"));
    if dir.is_dir() {
        return Some(dir);
    }
    if std::env::var_os("CI").is_some() {
        panic!("test data folder {} is missing (set STRAHL_TEST_DATA)", dir.display());
    }
    skip(&format!("test data folder {} is missing (set STRAHL_TEST_DATA)", dir.display()));
    None
}

/// Says that the running test skips a check, and why: a line `SKIPPED: BINARY::TEST: WHY` on
/// stderr (which `cargo test` shows only with `--nocapture`), and the same line appended to the
/// file `$STRAHL_SKIP_LOG` when it is set: `make test` sets it and lists the file's lines at the
/// end, so that no skip goes unseen.
pub fn skip(why: &str) {
    let thread = std::thread::current();
    let test = thread.name().filter(|n| *n != "main").unwrap_or("(a test)");
    let line = format!("SKIPPED: {}::{test}: {why}\n", env!("CARGO_CRATE_NAME"));
    eprint!("{line}");
    if let Some(log) = std::env::var_os("STRAHL_SKIP_LOG") {
        use std::io::Write;
        let file = std::fs::OpenOptions::new().create(true).append(true).open(&log);
        // One write of one short line: O_APPEND keeps the lines of parallel tests whole.
        if let Err(e) = file.and_then(|mut f| f.write_all(line.as_bytes())) {
            eprintln!("cannot append to STRAHL_SKIP_LOG {}: {e}", Path::new(&log).display());
        }
    }
}

/// Whether Blender is installed with the numpy its glTF importer and exporter need; if not,
/// says so in a skip line ending in `then` (what goes untested), or fails when
/// `STRAHL_REQUIRE_BLENDER=1` (`make test-cycles` sets it). Asked of Blender once per test
/// binary.
pub fn blender_installed(then: &str) -> bool {
    static MISSING: std::sync::OnceLock<Option<&str>> = std::sync::OnceLock::new();
    let missing = *MISSING.get_or_init(|| {
        let numpy = ["-b", "--factory-startup", "--python-exit-code", "1", "--python-expr", "import numpy"];
        match Command::new("blender").args(numpy).output() {
            Err(_) => Some("blender is not installed"),
            Ok(o) if !o.status.success() => {
                Some("Blender's Python cannot import numpy, which its glTF importer and exporter need")
            }
            Ok(_) => None,
        }
    });
    let Some(missing) = missing else { return true };
    assert!(std::env::var("STRAHL_REQUIRE_BLENDER").as_deref() != Ok("1"), "STRAHL_REQUIRE_BLENDER=1 but {missing}");
    skip(&format!("{missing} (apt-get install blender python3-numpy; make test-cycles installs them): {then}"));
    false
}

/// Cycles' render of the glTF file `src` by Blender's importer (tools/blender/render_gltf.py,
/// headless): `size`² pixels, `spp` samples, `depth` scatterings, the camera at `view` (eye,
/// target, vertical field of view in degrees, as the script's arguments) and the script's
/// `flags`; returns `out_dir/cycles.exr`. Call after [`blender_installed`].
pub fn cycles_render_gltf(
    src: &Path,
    out_dir: &Path,
    (size, spp, depth): (usize, u32, u32),
    view: &[String],
    flags: &[String],
) -> PathBuf {
    let mut args: Vec<std::ffi::OsString> = vec![src.into(), out_dir.into()];
    args.extend([size, spp as usize, depth as usize].map(|n| n.to_string().into()));
    args.extend(view.iter().chain(flags).map(Into::into));
    let exr = out_dir.join("cycles.exr");
    run_blender_script("tools/blender/render_gltf.py", &args, &[&exr]);
    exr
}

/// Runs the repository's Blender script `script` (a path below the crate's root) headless,
/// `args` after `--`, and asserts that Blender succeeded and that each of `outputs` is a file
/// (Blender's output in the message otherwise). Call after [`blender_installed`].
pub fn run_blender_script(script: &str, args: &[std::ffi::OsString], outputs: &[&Path]) {
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join(script);
    let out = Command::new("blender")
        .args(["-b", "--factory-startup", "--python"])
        .arg(&script)
        .arg("--")
        .args(args)
        .output()
        .expect("blender runs");
    assert!(
        out.status.success() && outputs.iter().all(|p| p.is_file()),
        "blender failed:\n{}\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}

/// Runs the asset script `tools/gltf/SCRIPT` (pygltflib, not strahl's code) into
/// `dir/assets`; returns that folder, or `None` (with a skip line naming `test`) when python3
/// or its pygltflib is missing. A script that fails otherwise fails the test.
pub fn gltf_assets(dir: &TempDir, script: &str, test: &str) -> Option<PathBuf> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tools/gltf").join(script);
    let out = dir.path("assets");
    match Command::new("python3").arg(&path).arg(&out).output() {
        Ok(o) if o.status.success() => Some(out),
        Ok(o) if text(&o.stderr).contains("No module named") => {
            skip(&format!("{test}: python3 has no pygltflib (pip install pygltflib)"));
            None
        }
        Ok(o) => panic!("{script} failed: {}", text(&o.stderr)),
        Err(e) => {
            skip(&format!("{test}: cannot run python3: {e}"));
            None
        }
    }
}

/// A fresh directory under the system's temporary directory, removed on drop.
pub struct TempDir(pub PathBuf);

impl TempDir {
    pub fn new(tag: &str) -> Self {
        // The test binary's name keeps test files that use the same tag apart.
        let dir =
            std::env::temp_dir().join(format!("strahl-{}-{tag}-{}", env!("CARGO_CRATE_NAME"), std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        TempDir(dir)
    }

    pub fn path(&self, name: &str) -> PathBuf {
        self.0.join(name)
    }

    /// Writes `bytes` to the file `name` in the directory; returns its path.
    pub fn write(&self, name: &str, bytes: impl AsRef<[u8]>) -> PathBuf {
        let path = self.path(name);
        std::fs::write(&path, bytes).unwrap();
        path
    }

    /// The names in the directory, sorted.
    pub fn entries(&self) -> Vec<String> {
        let mut v: Vec<String> =
            std::fs::read_dir(&self.0).unwrap().map(|e| e.unwrap().file_name().into_string().unwrap()).collect();
        v.sort();
        v
    }

    /// strahl's temporaries in the directory (`.strahl-….tmp`), sorted.
    pub fn temporaries(&self) -> Vec<String> {
        self.entries().into_iter().filter(|e| e.starts_with(".strahl-") && e.ends_with(".tmp")).collect()
    }

    /// [`TempDir::temporaries`] that hold bytes: an output, a checkpoint or a scratch file
    /// being written. The empty one that the start-up check of an output's folder creates and
    /// removes at once is not among them, so a test that waits for a write is not fooled by it.
    pub fn written_temporaries(&self) -> Vec<String> {
        self.temporaries().into_iter().filter(|e| std::fs::metadata(self.path(e)).is_ok_and(|m| m.len() > 0)).collect()
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// The EXR at `path` as the `exr` crate reads it: every layer, channel and attribute.
pub fn read_exr_image(path: &Path) -> exr::image::FlatImage {
    exr::prelude::read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .all_layers()
        .all_attributes()
        .from_file(path)
        .unwrap()
}

/// Every channel of the EXR at `path`, by name, in file order.
pub fn read_exr(path: &Path) -> (usize, usize, Vec<(String, Vec<f32>)>) {
    let image = read_exr_image(path);
    assert_eq!(image.layer_data.len(), 1);
    let layer = &image.layer_data[0];
    (layer.size.0, layer.size.1, float_channels(layer))
}

/// A layer's channels, by name, in file order; each must be float32.
pub fn float_channels(layer: &exr::image::Layer<exr::image::AnyChannels<FlatSamples>>) -> Vec<(String, Vec<f32>)> {
    layer
        .channel_data
        .list
        .iter()
        .map(|c| {
            let values = match &c.sample_data {
                FlatSamples::F32(v) => v.clone(),
                other => panic!("channel {} is not float32: {other:?}", c.name),
            };
            (c.name.to_string(), values)
        })
        .collect()
}

/// The channel `name` of [`read_exr`]'s list.
pub fn channel<'a>(channels: &'a [(String, Vec<f32>)], name: &str) -> &'a [f32] {
    &channels.iter().find(|(n, _)| n == name).unwrap_or_else(|| panic!("no channel {name}")).1
}

/// Runs the `strahl` binary with `args`, with `SOURCE_DATE_EPOCH` set so that its EXRs are
/// the same bytes on every run (no date or render time in the header).
pub fn strahl(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_strahl"))
        .args(args)
        .env("SOURCE_DATE_EPOCH", "1700000000")
        .output()
        .expect("strahl runs")
}

/// What a measured run of `strahl` ([`run_measured`]) did.
pub struct Measured {
    pub status: Option<i32>,
    /// Its stderr, trailing whitespace removed.
    pub stderr: String,
    /// Wall time, seconds.
    pub seconds: f64,
    /// Peak resident memory of the child in bytes (`getrusage` as `/usr/bin/time` reports it);
    /// `None` without `/usr/bin/time`, which is said as a skipped check.
    pub peak_bytes: Option<u64>,
}

impl Measured {
    /// [`Measured::peak_bytes`] in MiB.
    pub fn peak_mib(&self) -> Option<f64> {
        self.peak_bytes.map(|b| b as f64 / (1024.0 * 1024.0))
    }
}

/// Runs `strahl args` with `env` (and `SOURCE_DATE_EPOCH`, as [`strahl`]) under `/usr/bin/time`
/// when there is one, its stdout discarded, and kills it after `limit_seconds` so that a hang
/// fails the test instead of stalling the suite. The one runner of every test that measures
/// strahl's memory.
pub fn run_measured(args: &[&str], env: &[(&str, &str)], limit_seconds: u64) -> Measured {
    use std::sync::atomic::{AtomicU32, Ordering};
    use std::time::{Duration, Instant};
    static RUN: AtomicU32 = AtomicU32::new(0);
    let rss_file = std::env::temp_dir().join(format!(
        "strahl-test-rss-{}-{}",
        std::process::id(),
        RUN.fetch_add(1, Ordering::Relaxed)
    ));
    let time = Path::new("/usr/bin/time");
    let mut cmd = if time.exists() {
        let mut c = Command::new(time);
        c.args(["-f", "%M", "-o"]).arg(&rss_file).arg(env!("CARGO_BIN_EXE_strahl"));
        c
    } else {
        skip("/usr/bin/time is missing: peak memory not measured");
        Command::new(env!("CARGO_BIN_EXE_strahl"))
    };
    cmd.args(args).env("SOURCE_DATE_EPOCH", "1700000000").envs(env.iter().copied());
    let start = Instant::now();
    let mut child = cmd.stdout(Stdio::null()).stderr(Stdio::piped()).spawn().expect("strahl runs");
    // stderr is read on its own thread, so that a chatty child cannot block on a full pipe.
    let mut pipe = child.stderr.take().expect("piped stderr");
    let reader = std::thread::spawn(move || {
        let mut s = Vec::new();
        std::io::Read::read_to_end(&mut pipe, &mut s).map(|_| s)
    });
    let status = loop {
        if let Some(status) = child.try_wait().unwrap() {
            break status;
        }
        if start.elapsed() > Duration::from_secs(limit_seconds) {
            child.kill().unwrap();
            child.wait().unwrap();
            panic!("strahl {args:?} still running after {limit_seconds} s: a hang");
        }
        std::thread::sleep(Duration::from_millis(5));
    };
    let seconds = start.elapsed().as_secs_f64();
    let stderr = reader.join().unwrap().unwrap();
    let kib = std::fs::read_to_string(&rss_file).ok().and_then(|s| s.lines().last()?.trim().parse::<u64>().ok());
    let _ = std::fs::remove_file(&rss_file);
    Measured {
        status: status.code(),
        stderr: String::from_utf8_lossy(&stderr).trim_end().to_string(),
        seconds,
        peak_bytes: kib.map(|k| k * 1024),
    }
}

/// Starts `strahl args` in the background with the test hook `env` set (`STRAHL_TEST_…`, a
/// delay that leaves time to interrupt it), its output discarded.
pub fn spawn_strahl<S: AsRef<OsStr>>(args: impl IntoIterator<Item = S>, env: (&str, &str)) -> Child {
    Command::new(env!("CARGO_BIN_EXE_strahl"))
        .args(args)
        .env(env.0, env.1)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("strahl starts")
}

/// Sends `signal` (`-TERM`, `-INT`) to `child` with the shell's built-in kill: a minimal root
/// (the Embree 4 run's) may have no /bin/kill.
pub fn send_signal(child: &Child, signal: &str) {
    let sent = Command::new("sh").args(["-c", &format!("kill {signal} {}", child.id())]).status().unwrap();
    assert!(sent.success(), "kill {signal} failed");
}

pub fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

/// Runs `strahl` with `args`, expecting it to fail without writing anything into `dir`: exit
/// status 1 and one line `error: …` on stderr, which it returns (without the line break).
pub fn fails(dir: &TempDir, args: &[&str]) -> String {
    let before = dir.entries();
    let out = strahl(args);
    let stderr = text(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "exit status for {args:?}; stderr {stderr:?}");
    assert_eq!(stderr.lines().count(), 1, "one line: {stderr:?}");
    assert!(stderr.starts_with("error: "), "{stderr:?}");
    assert_eq!(dir.entries(), before, "nothing written for {args:?}");
    stderr.trim_end().to_string()
}

/// The standard error of each `block` × `block` block's mean in a `size` × `size` image (row
/// by row), from the image itself: in a smooth region a pixel's difference from the mean of
/// its four neighbours has variance `σ²·(1 + 1/4)`, and a block of `n` pixels has `σ/√n`
/// (edges inside a block only make this larger, so a test using it is conservative there);
/// over the block's pixels that have four neighbours.
pub fn block_sigmas(img: &[f64], size: usize, block: usize) -> Vec<f64> {
    let n = size / block;
    let (mut sums, mut counts) = (vec![0.0; n * n], vec![0usize; n * n]);
    for y in 1..size - 1 {
        for x in 1..size - 1 {
            let i = y * size + x;
            let around = (img[i - 1] + img[i + 1] + img[i - size] + img[i + size]) / 4.0;
            let k = (y / block) * n + x / block;
            sums[k] += (img[i] - around).powi(2) / 1.25;
            counts[k] += 1;
        }
    }
    sums.iter().zip(&counts).map(|(s, &c)| (s / c as f64).sqrt() / ((block * block) as f64).sqrt()).collect()
}

/// The mean of each `block` × `block` block of a `size` × `size` image (row by row).
pub fn block_means(img: &[f64], size: usize, block: usize) -> Vec<f64> {
    let n = size / block;
    let mut means = vec![0.0; n * n];
    for y in 0..size {
        for x in 0..size {
            means[(y / block) * n + x / block] += img[y * size + x] / (block * block) as f64;
        }
    }
    means
}

/// Two renders of one image compared in blocks within their noise ([`block_means`],
/// [`block_sigmas`]): `strahl` against `other` (named `name` in the messages).
pub struct BlockComparison {
    /// The largest |z| of a block, signed, and that block.
    pub worst: (f64, usize),
    /// A line for every block beyond 4 σ.
    pub failing: Vec<String>,
    /// The image means.
    pub means: (f64, f64),
    /// (strahl − other) / other of the image means.
    pub relative: f64,
    /// The difference of the image means over its standard error (from the blocks').
    pub z_image: f64,
}

/// Compares `strahl` with `other`, both `size × size` values, in blocks of `block × block`.
pub fn compare_blocks(strahl: &[f64], other: &[f64], size: usize, block: usize, name: &str) -> BlockComparison {
    let (sigma_s, sigma_o) = (block_sigmas(strahl, size, block), block_sigmas(other, size, block));
    let (ms, mo) = (block_means(strahl, size, block), block_means(other, size, block));
    let n = size / block;
    let mut worst = (0.0f64, 0);
    let mut failing = Vec::new();
    for k in 0..ms.len() {
        let z = (ms[k] - mo[k]) / (sigma_s[k].powi(2) + sigma_o[k].powi(2)).sqrt();
        if z.abs() > worst.0.abs() {
            worst = (z, k);
        }
        if z.abs() > 4.0 {
            let (a, b) = (ms[k], mo[k]);
            failing.push(format!("block {k} (x {}, y {}): strahl {a:.4}, {name} {b:.4}, z {z:.1}", k % n, k / n));
        }
    }
    let (sum_s, sum_o) = (strahl.iter().sum::<f64>(), other.iter().sum::<f64>());
    let relative = (sum_s - sum_o) / sum_o;
    // The image mean is the mean of the block means, its standard error from the blocks'.
    let var: f64 = sigma_s.iter().chain(&sigma_o).map(|s| s * s).sum();
    let z_image = (sum_s - sum_o) / strahl.len() as f64 / (var.sqrt() / ms.len() as f64);
    let means = (sum_s / strahl.len() as f64, sum_o / other.len() as f64);
    BlockComparison { worst, failing, means, relative, z_image }
}
