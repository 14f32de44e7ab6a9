//! `strahl::job` used as a library, without the command line: a shipped scene rendered to
//! memory through a `RenderJob` has, float for float, the pixels `strahl render` writes to
//! its EXR (both backends), and a job given an output writes those pixels itself.

mod common;

use std::path::{Path, PathBuf};

use common::{TempDir, channel, read_exr, strahl, text};
use strahl::job::{Backend, Observer, Output, RenderJob, Settings};
use strahl::output::exr::{Compression, Layout};
use strahl::output::film::Film;

const W: u32 = 40;
const H: u32 = 30;

fn cornell() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell.toml")
}

/// The settings of `strahl render cornell.toml --width 40 --height 30 --spp 2 --threads 2`.
fn settings(backend: Backend) -> Settings {
    Settings { width: Some(W), height: Some(H), spp: Some(2), backend, threads: Some(2), ..Settings::default() }
}

/// The job of `settings` on the Cornell box, loaded as the command loads it.
fn job(settings: Settings) -> RenderJob {
    let path = cornell();
    let loaded = strahl::scene::load(&path).unwrap_or_else(|e| panic!("{e}"));
    RenderJob::new(&path, loaded.scene, settings).unwrap_or_else(|e| panic!("{e:#}"))
}

/// Asserts that `film` holds, bit for bit, the RGBA, depth, normal and albedo of the EXR at
/// `exr` (Blender's channel names, float32), and that the image is lit.
fn assert_film_is_exr(film: &Film, exr: &Path) {
    let (w, h, channels) = read_exr(exr);
    assert_eq!((w, h), (W as usize, H as usize));
    let named = |layer: &str, c: &str| channel(&channels, &format!("ViewLayer.{layer}.{c}"));
    let (r, g, b, a) = (named("Combined", "R"), named("Combined", "G"), named("Combined", "B"), named("Combined", "A"));
    let z = named("Depth", "Z");
    let n = [named("Normal", "X"), named("Normal", "Y"), named("Normal", "Z")];
    let albedo = [named("DiffCol", "R"), named("DiffCol", "G"), named("DiffCol", "B")];
    let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    for y in 0..H {
        for x in 0..W {
            let (i, k) = (film.index(x, y), (y * W + x) as usize);
            let at = format!("pixel ({x}, {y})");
            assert_eq!(bits(&film.rgba[i]), bits(&[r[k], g[k], b[k], a[k]]), "RGBA of {at}");
            assert_eq!(film.depth[i].to_bits(), z[k].to_bits(), "depth of {at}");
            assert_eq!(bits(&film.normal[i].to_array()), bits(&n.map(|c| c[k])), "normal of {at}");
            assert_eq!(bits(&film.albedo[i].to_array()), bits(&albedo.map(|c| c[k])), "albedo of {at}");
        }
    }
    // Real values: the box fills most of the frame (finite depths: 877 of the 1200 pixels)
    // and is lit (its walls reflect the area light: 606 pixels above 0.01 in every channel).
    let (hits, n) = (film.depth.iter().filter(|d| d.is_finite() && **d > 0.0).count(), film.depth.len());
    assert!(hits > n / 2, "{hits} of {n} pixels hit");
    let lit = film.rgba.iter().filter(|p| p[0] > 0.01 && p[1] > 0.01 && p[2] > 0.01).count();
    assert!(lit > n / 3, "{lit} of {n} pixels lit");
}

#[test]
fn a_job_renders_to_memory_the_pixels_the_command_writes() {
    let dir = TempDir::new("memory");
    for (backend, name) in [(Backend::Embree, "embree"), (Backend::Native, "native")] {
        let exr = dir.path(&format!("{name}.exr"));
        let (w, h) = (W.to_string(), H.to_string());
        let scene = cornell();
        let args = ["render", scene.to_str().unwrap(), "-o", exr.to_str().unwrap(), "--backend", name];
        let out = strahl(&[&args[..], &["--width", &w, "--height", &h, "--spp", "2", "--threads", "2"]].concat());
        assert!(out.status.success(), "strahl failed: {}", text(&out.stderr));

        let job = job(settings(backend));
        let pixels = std::sync::atomic::AtomicU64::new(0);
        let observer = Observer {
            progress: &|n| {
                pixels.fetch_add(n, std::sync::atomic::Ordering::Relaxed);
            },
            note: &|line| panic!("a render to memory has nothing to say, said {line:?}"),
        };
        let rendered = job.render(&observer).unwrap();
        assert_eq!(pixels.into_inner(), (W * H) as u64);
        assert_eq!(rendered.rays.primary, (W * H * 2) as u64);
        assert_film_is_exr(&rendered.film, &exr);
        assert!(job.write(&mut { rendered }, &Observer::quiet()).is_err(), "a job without an output writes nothing");
    }
    assert_eq!(dir.entries(), ["embree.exr", "native.exr"]);
}

#[test]
fn a_job_with_an_output_writes_its_pixels_and_leaves_no_checkpoint() {
    let dir = TempDir::new("output");
    let output = Output {
        exr: dir.path("job.exr"),
        png: Some(dir.path("job.png")),
        exposure: 0.0,
        layout: Layout::Blender,
        layer_name: None,
        half: false,
        compression: Compression::Zip,
        checkpoint_every: 0.0,
        resume: false,
        frame: 1,
        fps: 24,
    };
    output.check().unwrap();
    let job = job(Settings { output: Some(output), ..settings(Backend::Native) });
    let mut rendered = job.render(&Observer::quiet()).unwrap();
    let lines = std::sync::Mutex::new(Vec::new());
    let observer = Observer { progress: &|_| {}, note: &|line| lines.lock().unwrap().push(line.to_string()) };
    job.write(&mut rendered, &observer).unwrap();
    let shown = |name: &str| format!("writing {} ...", dir.path(name).display());
    assert_eq!(lines.into_inner().unwrap(), [shown("job.exr"), shown("job.png")]);
    assert_eq!(dir.entries(), ["job.exr", "job.png"], "the checkpoint saved after every tile is removed");
    assert_film_is_exr(&rendered.film, &dir.path("job.exr"));
    let summary = job.summary(&rendered, 0.5).to_string();
    assert!(summary.starts_with(&format!("{}: 40 × 30 pixels, 2 spp, max depth ", cornell().display())), "{summary}");
    assert!(summary.contains("backend: native") && summary.contains(" in 0.500 s\n"), "{summary}");
}

#[test]
fn a_jobs_settings_are_checked_against_its_scene() {
    let path = cornell();
    let err = |settings: Settings| {
        let loaded = strahl::scene::load(&path).unwrap();
        RenderJob::new(&path, loaded.scene, settings).err().map(|e| format!("{e:#}")).unwrap_or_default()
    };
    let shown = path.display();
    let outside = Settings { region: Some("0,0,50,10".into()), ..settings(Backend::Embree) };
    assert!(err(outside).starts_with(&format!("{shown}: --region ")));
    assert_eq!(
        err(Settings { passes: Some(vec!["shine".into()]), ..settings(Backend::Embree) }).split(':').next(),
        Some("--passes")
    );
    let tiny = Settings { max_memory: Some(1000), ..settings(Backend::Embree) };
    assert!(err(tiny).contains("more than --max-memory"));
    let mut output = Output {
        exr: path.clone(),
        png: None,
        exposure: 0.0,
        layout: Layout::Nuke,
        layer_name: None,
        half: true,
        compression: Compression::Piz,
        checkpoint_every: 60.0,
        resume: false,
        frame: 1,
        fps: 24,
    };
    assert!(output.check().unwrap_err().to_string().contains("must have the extension .exr"));
    output.exr = path.with_extension("exr");
    output.checkpoint_every = f64::NAN;
    let nan = Settings { output: Some(output), ..settings(Backend::Embree) };
    assert_eq!(err(nan), "--checkpoint-every NaN is not a number of seconds from 0 to 1e9");
}
