//! Adaptive sampling (`--adaptive-threshold`, Cycles' rule) on the path-traced Cornell box
//! (`scenes/cornell.toml` with `--integrator path`):
//! - the EXR is the same bytes on 1 and 2 threads, as 4 tiles merged, and interrupted and
//!   resumed, with pixels that stopped early among them;
//! - every pixel stops exactly where Cycles' test and dilation (inside the pixel's 16 × 16
//!   cell), recomputed here from the samples (recorded through the library, one by one, in a
//!   uniform render), first stop it, its error then is below the threshold, and its value is
//!   the mean of the samples it took;
//! - at an equal number of samples over the frame, its RMSE against a converged render is
//!   lower than uniform sampling's, and with a higher most samples per pixel lower still.

mod common;

use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::time::{Duration, Instant};

use common::{TempDir, channel, read_exr, send_signal, spawn_strahl, strahl, text};
use strahl::accel::{Accel, Hit, TraceError};
use strahl::camera::Camera;
use strahl::integrator::{CameraSample, Integrator, PathTracer, PixelSamples, RayCounts, TileJob, trace_tiles};
use strahl::math::{Ray, Vec2, Vec3};
use strahl::output::film::Film;
use strahl::output::region::Region;
use strahl::sampling::sobol::Sobol;
use strahl::scene::{IntegratorKind, Scene};

const W: u32 = 32;
const H: u32 = 32;
/// The most samples a pixel takes.
const SPP: u32 = 256; // as `adaptive` says
/// Cycles' default threshold, 0.01: at least 64 samples, tests after 80, 96, … 256.
const THRESHOLD: &str = "0.01";

fn cornell() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell.toml")
}

/// `strahl render` of the Cornell box, path-traced, at W × H with `extra` options.
fn args(out: &Path, extra: &[&str]) -> Vec<String> {
    let size = [W.to_string(), H.to_string()];
    let mut a: Vec<String> =
        ["render", cornell().to_str().unwrap(), "-o", out.to_str().unwrap()].into_iter().map(String::from).collect();
    for s in ["--integrator", "path", "--width", &size[0], "--height", &size[1]] {
        a.push(s.to_string());
    }
    a.extend(extra.iter().map(|s| s.to_string()));
    a
}

fn render(out: &Path, extra: &[&str]) -> Vec<u8> {
    let a = args(out, extra);
    let o = strahl(&a.iter().map(String::as_str).collect::<Vec<_>>());
    assert!(o.status.success(), "{}", text(&o.stderr));
    std::fs::read(out).unwrap()
}

/// The adaptive render's options.
fn adaptive(threads: &str) -> Vec<&str> {
    vec![
        "--spp",
        "256",
        "--adaptive-threshold",
        THRESHOLD,
        "--passes",
        "default,sample_count,variance",
        "--threads",
        threads,
    ]
}

/// The samples each pixel of `out` took, from its `Debug Sample Count` pass (Cycles' samples
/// ÷ spp).
fn sample_counts(out: &Path) -> Vec<u32> {
    let (_, _, channels) = read_exr(out);
    let counts = channel(&channels, "ViewLayer.Debug Sample Count.X");
    counts.iter().map(|&f| (f * SPP as f32).round() as u32).collect()
}

#[test]
fn the_same_bytes_on_any_threads_tiles_and_resume() {
    let dir = TempDir::new("adaptive-bytes");
    let one = render(&dir.path("one.exr"), &adaptive("1"));
    let whole = render(&dir.path("two.exr"), &adaptive("2"));
    assert!(one == whole, "1 and 2 threads differ");
    // Some pixels stopped early, some went on to the end: the test means something.
    let counts = sample_counts(&dir.path("two.exr"));
    let stopped = counts.iter().filter(|&&n| n < SPP).count();
    assert!(stopped > 50 && stopped < counts.len() - 20, "{stopped} of {} pixels stopped early", counts.len());

    // Four tiles, merged.
    let mut merge = vec!["merge".to_string(), dir.path("merged.exr").to_str().unwrap().to_string()];
    for i in 1..=4 {
        let part = dir.path(&format!("part{i}.exr"));
        let tile = format!("{i}/4");
        let mut extra = adaptive("2");
        extra.extend(["--tile", &tile]);
        render(&part, &extra);
        merge.push(part.to_str().unwrap().to_string());
    }
    let o = strahl(&merge.iter().map(String::as_str).collect::<Vec<_>>());
    assert!(o.status.success(), "{}", text(&o.stderr));
    assert!(std::fs::read(dir.path("merged.exr")).unwrap() == whole, "4 tiles merged differ from the whole");

    // Stopped by SIGTERM once the checkpoint holds 2 of its 4 tiles, then resumed.
    let out = dir.path("resumed.exr");
    let checkpoint = dir.path("resumed.exr.checkpoint");
    let mut slow = adaptive("1");
    slow.extend(["--checkpoint-every", "0"]);
    let mut child = spawn_strahl(args(&out, &slow), ("STRAHL_TEST_TILE_DELAY_MS", "300"));
    let start = Instant::now();
    while tiles_in(&checkpoint) < 2 {
        assert!(start.elapsed() < Duration::from_secs(120), "no checkpoint with 2 tiles");
        std::thread::sleep(Duration::from_millis(5));
    }
    send_signal(&child, "-TERM");
    let status = child.wait().unwrap();
    assert!(!status.success() && !out.exists(), "the render was stopped before it finished");
    let mut again = adaptive("2");
    again.push("--resume");
    assert!(render(&out, &again) == whole, "interrupted and resumed differs from the whole");
}

/// The finished tiles in a checkpoint (its documented layout), 0 when there is none.
fn tiles_in(path: &Path) -> u32 {
    let Ok(b) = std::fs::read(path) else { return 0 };
    if b.len() < 16 {
        return 0;
    }
    let key_len = u32::from_le_bytes(b[12..16].try_into().unwrap()) as usize;
    let at = 16 + key_len + 8;
    b.get(at..at + 4).map_or(0, |v| u32::from_le_bytes(v.try_into().unwrap()))
}

/// The path tracer, shading each camera ray on its own and keeping every pixel's samples in
/// order.
struct Recording<'a, A: Accel> {
    inner: PathTracer<'a, A>,
    samples: Mutex<Vec<Vec<Vec3>>>,
}

/// A pixel's Sobol sequence and its index.
struct Tagged {
    pixel: u64,
    sobol: Sobol,
}

impl PixelSamples for Tagged {
    fn begin(&mut self, sample: u32) {
        self.sobol.begin(sample)
    }
    fn pixel(&mut self) -> Vec2 {
        self.sobol.pixel()
    }
    fn lens(&mut self) -> Vec2 {
        self.sobol.lens()
    }
}

impl<A: Accel> Integrator for Recording<'_, A> {
    type Scratch = ();
    type Sampler = Tagged;

    fn sampler(&self, spp: u32, pixel: u64, lens: bool) -> Tagged {
        Tagged { pixel, sobol: self.inner.sampler(spp, pixel, lens) }
    }

    fn shade_round(
        &self,
        rays: &[Ray],
        hits: &[Option<Hit>],
        samplers: &mut [Tagged],
        counts: &mut RayCounts,
        scratch: &mut (),
        out: &mut [CameraSample],
    ) -> Result<(), TraceError> {
        for i in 0..rays.len() {
            let s = &mut samplers[i];
            let (r, h, o) = (&rays[i..i + 1], &hits[i..i + 1], &mut out[i..i + 1]);
            self.inner.shade_round(r, h, std::slice::from_mut(&mut s.sobol), counts, scratch, o)?;
            self.samples.lock().unwrap()[s.pixel as usize].push(o[0].radiance);
        }
        Ok(())
    }
}

/// The Cornell box as the command renders it, uniform, and every pixel's SPP samples.
fn recorded_samples() -> Vec<Vec<Vec3>> {
    let path = cornell();
    let mut scene: Scene = strahl::scene::load(&path).unwrap().scene;
    strahl::job::override_image(&path, &mut scene.image, [Some(W), Some(H), Some(SPP), None]).unwrap();
    scene.render.integrator = IntegratorKind::Path;
    let accel = common::accel(&scene);
    let camera = Camera::new(&scene.camera, W, H).unwrap();
    let recording =
        Recording { inner: PathTracer::new(&scene, &accel), samples: Mutex::new(vec![Vec::new(); (W * H) as usize]) };
    let region = Region::full(W, H);
    let film = Film::for_region(W, H, region, &scene.output);
    let tiles = region.tiles();
    let job = TileJob { tiles: &tiles, stop: None, progress: &|_| {}, on_tile: &|_, _| {} };
    trace_tiles(&scene, &accel, &camera, &recording, film, &job).unwrap();
    recording.samples.into_inner().unwrap()
}

/// Cycles' test, written out again from `kernel/film/adaptive_sampling.h`,
/// `integrator/adaptive_sampling.cpp` and `scene/integrator.cpp`, with its dilation kept
/// inside each pixel's 16 × 16 cell of the tile grid: for every pixel of the W × H image
/// (row by row, `samples[p]` its samples in order) the samples it takes and its error when it
/// stopped (`None` if it never did), for the user's `threshold`.
fn cycles_stops(samples: &[Vec<Vec3>], threshold: f32) -> Vec<(u32, Option<f32>)> {
    let min_samples = ((16.0f32 / threshold.powf(0.3)).ceil() as u32).max(4);
    let threshold = threshold * 5.0;
    let pixels = (W * H) as usize;
    let (mut i, mut a) = (vec![Vec3::ZERO; pixels], vec![Vec3::ZERO; pixels]);
    let mut stopped: Vec<Option<(u32, f32)>> = vec![None; pixels];
    for sample in 0..SPP {
        let sampling: Vec<usize> = (0..pixels).filter(|&p| stopped[p].is_none()).collect();
        for &p in &sampling {
            let x = samples[p][sample as usize];
            i[p] += x;
            if (sample & 0xaaaa_aaaa).count_ones() % 2 == 1 {
                a[p] += x * 2.0;
            }
        }
        if !(sample > min_samples && sample & 15 == 15) {
            continue;
        }
        let error = |p: usize| {
            let scale = 1.0 / (sample + 1) as f32;
            let (i, a) = (i[p], a[p]);
            let difference = ((i.x - a.x).abs() + (i.y - a.y).abs() + (i.z - a.z).abs()) * scale;
            let intensity = (i.x + i.y + i.z) * scale;
            let normalize = if intensity < 1.0 { intensity.sqrt() } else { intensity };
            difference / (0.0001 + normalize)
        };
        let unconverged: Vec<bool> = (0..pixels).map(|p| stopped[p].is_none() && error(p) >= threshold).collect();
        for &p in &sampling {
            let (x, y) = (p as u32 % W, p as u32 / W);
            let same_cell = |q: u32, r: u32| q / 16 == r / 16;
            let neighbour_unconverged = (y.saturating_sub(1)..=(y + 1).min(H - 1))
                .flat_map(|ny| (x.saturating_sub(1)..=(x + 1).min(W - 1)).map(move |nx| (nx, ny)))
                .filter(|&(nx, ny)| same_cell(nx, x) && same_cell(ny, y))
                .any(|(nx, ny)| unconverged[(ny * W + nx) as usize]);
            if !neighbour_unconverged {
                stopped[p] = Some((sample + 1, error(p)));
            }
        }
    }
    stopped.into_iter().map(|s| s.map_or((SPP, None), |(n, e)| (n, Some(e)))).collect()
}

#[test]
fn every_pixel_stops_where_cycles_test_says_below_the_threshold() {
    let dir = TempDir::new("adaptive-threshold");
    let out = dir.path("adaptive.exr");
    render(&out, &adaptive("2"));
    let (_, _, channels) = read_exr(&out);
    let rgb: Vec<&[f32]> =
        ["R", "G", "B"].iter().map(|c| channel(&channels, &format!("ViewLayer.Combined.{c}"))).collect();
    let variance: Vec<&[f32]> =
        ["R", "G", "B"].iter().map(|c| channel(&channels, &format!("ViewLayer.Variance.{c}"))).collect();
    let counts = sample_counts(&out);
    let threshold: f32 = THRESHOLD.parse().unwrap();
    let samples = recorded_samples();
    assert!(samples.iter().all(|s| s.len() == SPP as usize));
    let stops = cycles_stops(&samples, threshold);
    let mut stopped = 0;
    for (p, samples) in samples.iter().enumerate() {
        let (n, error) = stops[p];
        assert_eq!(counts[p], n, "pixel {p}: took {} samples, Cycles' test stops it after {n}", counts[p]);
        if let Some(error) = error {
            assert!(error < 5.0 * threshold, "pixel {p}: error {error}");
            stopped += 1;
        }
        // The value is the mean of the samples taken, summed in order.
        let taken = &samples[..n as usize];
        let mean = taken.iter().fold(Vec3::ZERO, |s, &x| s + x) / n as f32;
        for c in 0..3 {
            assert_eq!(rgb[c][p].to_bits(), mean[c].to_bits(), "pixel {p} channel {c}");
        }
        // The variance pass: the variance of that mean (f64 here, to 1e-4 relative).
        let m: Vec<f64> = (0..3).map(|c| taken.iter().map(|x| x[c] as f64).sum::<f64>() / n as f64).collect();
        for c in 0..3 {
            let s2: f64 = taken.iter().map(|x| (x[c] as f64 - m[c]).powi(2)).sum::<f64>() / (n as f64 - 1.0);
            let expected = s2 / n as f64;
            let got = variance[c][p] as f64;
            assert!(
                (got - expected).abs() <= 1e-4 * expected + 1e-12,
                "pixel {p}: variance {got}, expected {expected}"
            );
        }
    }
    assert!(stopped > 50, "only {stopped} pixels stopped early");
}

/// The RGB of the EXR at `out`, pixel by pixel, in f64.
fn beauty(out: &Path) -> Vec<[f64; 3]> {
    let (_, _, channels) = read_exr(out);
    let c: Vec<&[f32]> =
        ["R", "G", "B"].iter().map(|c| channel(&channels, &format!("ViewLayer.Combined.{c}"))).collect();
    (0..c[0].len()).map(|i| [c[0][i] as f64, c[1][i] as f64, c[2][i] as f64]).collect()
}

fn rmse(image: &[[f64; 3]], reference: &[[f64; 3]]) -> f64 {
    let squares: f64 = image.iter().zip(reference).flat_map(|(a, b)| (0..3).map(move |c| (a[c] - b[c]).powi(2))).sum();
    (squares / (3 * image.len()) as f64).sqrt()
}

/// The converged Cornell box at W × H and its own noise: rendered at twice the resolution and
/// box-filtered down 2 × 2 (4 × 1024 samples per pixel, from other pixels' Sobol sequences, so
/// independent of the images compared), and the mean over pixels and channels of its variance
/// (its variance pass, a sixteenth of the four sub-pixels' sum), which [`rmse`]'s squares
/// include and [`noise_free_rmse`] takes out.
fn reference(dir: &TempDir) -> (Vec<[f64; 3]>, f64) {
    let fine = dir.path("reference.exr");
    let scene = cornell();
    let a = ["render", scene.to_str().unwrap(), "-o", fine.to_str().unwrap(), "--integrator", "path"];
    let (w2, h2) = ((2 * W).to_string(), (2 * H).to_string());
    let size = ["--width", &w2, "--height", &h2, "--spp", "1024", "--threads", "2", "--passes", "default,variance"];
    let o = strahl(&[&a[..], &size].concat());
    assert!(o.status.success(), "{}", text(&o.stderr));
    let (_, _, channels) = read_exr(&fine);
    let variance: f64 = ["R", "G", "B"]
        .iter()
        .flat_map(|c| channel(&channels, &format!("ViewLayer.Variance.{c}")).iter().map(|&v| v as f64))
        .sum::<f64>()
        / 16.0
        / (3 * W * H) as f64;
    let fine = beauty(&fine);
    let reference = (0..W * H)
        .map(|i| {
            let (x, y) = ((i % W) as usize * 2, (i / W) as usize * 2);
            let at = |dx: usize, dy: usize| fine[(y + dy) * 2 * W as usize + x + dx];
            let four = [at(0, 0), at(1, 0), at(0, 1), at(1, 1)];
            [0, 1, 2].map(|c| four.iter().map(|p| p[c]).sum::<f64>() / 4.0)
        })
        .collect();
    (reference, variance)
}

/// The RMSE against the reference less the reference's own noise: `√(MSE − σ²_ref)`.
fn noise_free_rmse(image: &[[f64; 3]], (reference, variance): &(Vec<[f64; 3]>, f64)) -> f64 {
    (rmse(image, reference).powi(2) - variance).max(0.0).sqrt()
}

/// Against a converged render:
/// - at the samples the adaptive render took over the frame, spread evenly instead, the image
///   is further from it: adaptive sampling puts them where the noise is;
/// - allowed four times the samples (at most 1024 instead of 256), adaptive sampling comes
///   closer to it, by more than the 0.92 × a pixel-by-pixel rule (without the dilation)
///   reached: it stopped pixels whose first samples had missed the caustic and went no
///   further.
///
/// Measured (reference noise 0.0089 taken out): RMSE 0.0245 adaptive at most 256 (184.2
/// samples per pixel on average), 0.0306 uniform at 184; 0.0135 adaptive at most 1024. Without
/// the dilation: 0.0241 (100.0), 0.0371 uniform at 100, 0.0222 at most 1024.
#[test]
fn lower_rmse_than_uniform_sampling_and_lower_still_with_more_samples() {
    let dir = TempDir::new("adaptive-rmse");
    let reference = reference(&dir);
    let adaptive_out = dir.path("adaptive.exr");
    render(&adaptive_out, &adaptive("2"));
    let budget: u32 = sample_counts(&adaptive_out).iter().sum();
    let uniform_spp = (budget / (W * H)).to_string();
    let uniform_out = dir.path("uniform.exr");
    render(&uniform_out, &["--spp", &uniform_spp, "--threads", "2"]);
    let more_out = dir.path("adaptive-1024.exr");
    render(&more_out, &["--spp", "1024", "--adaptive-threshold", THRESHOLD, "--threads", "2"]);

    let rmse = |out: &Path| noise_free_rmse(&beauty(out), &reference);
    let (adaptive_rmse, uniform_rmse, more_rmse) = (rmse(&adaptive_out), rmse(&uniform_out), rmse(&more_out));
    eprintln!(
        "reference noise {:.4}; {:.1} samples per pixel: RMSE {adaptive_rmse:.4} adaptive, {uniform_rmse:.4} uniform \
         at {uniform_spp} spp; {more_rmse:.4} adaptive at most 1024",
        reference.1.sqrt(),
        budget as f64 / (W * H) as f64
    );
    assert!(adaptive_rmse < 0.85 * uniform_rmse, "adaptive {adaptive_rmse}, uniform {uniform_rmse}");
    assert!(more_rmse < 0.7 * adaptive_rmse, "at most 1024 samples {more_rmse}, at most 256 {adaptive_rmse}");
}

/// A threshold that is not a positive number, or adaptive sampling with the Whitted
/// integrator, is refused in one line before anything is rendered or written; in a scene
/// file, at its line and column.
#[test]
fn bad_thresholds_are_refused_in_one_line() {
    let dir = TempDir::new("adaptive-bad");
    let out = dir.path("out.exr");
    for (t, says) in [("-0.01", "adaptive_threshold -0.01 must be finite and > 0"), ("nan", "adaptive_threshold NaN")] {
        let a = args(&out, &["--adaptive-threshold", t]);
        let e = common::fails(&dir, &a.iter().map(String::as_str).collect::<Vec<_>>());
        assert!(e.contains(says), "{e}");
    }
    let mut a = args(&out, &["--adaptive-threshold", "0.01"]);
    a[5] = "whitted".into();
    let e = common::fails(&dir, &a.iter().map(String::as_str).collect::<Vec<_>>());
    assert!(e.contains("adaptive sampling is the path tracer's"), "{e}");
    // 0 is off: the same bytes as without the option.
    let off = render(&dir.path("off.exr"), &["--spp", "4", "--adaptive-threshold", "0"]);
    assert!(off == render(&dir.path("plain.exr"), &["--spp", "4"]));

    let scene = std::fs::read_to_string(cornell())
        .unwrap()
        .replace("integrator = \"whitted\"", "integrator = \"path\"\nadaptive_threshold = -1");
    let file = dir.write("bad.toml", scene);
    let e = common::fails(&dir, &["render", file.to_str().unwrap(), "-o", out.to_str().unwrap()]);
    assert!(e.contains("bad.toml:15:") && e.contains("adaptive_threshold -1 must be finite and > 0"), "{e}");
}

/// `--help` says it: the minimum (64 at T = 0.01, first test after 80 samples) can exceed
/// `--spp`, and then every pixel takes all `--spp` samples, as without adaptive sampling: at
/// `--spp 80` every pixel's sample count is 80 and the beauty is the uniform render's, bit for
/// bit.
#[test]
fn below_the_first_test_every_pixel_takes_all_samples_as_without_adaptive_sampling() {
    let help = strahl(&["render", "--help"]);
    let help = text(&help.stdout).split_whitespace().collect::<Vec<_>>().join(" ");
    assert!(
        help.contains("max(4, ceil(16/T^0.3))") && help.contains("The minimum can exceed `--spp`"),
        "render --help: {help}"
    );
    let dir = TempDir::new("below-first-test");
    let (adaptive, uniform) = (dir.path("adaptive.exr"), dir.path("uniform.exr"));
    render(&adaptive, &["--spp", "80", "--adaptive-threshold", THRESHOLD, "--passes", "default,sample_count"]);
    render(&uniform, &["--spp", "80", "--passes", "default"]);
    let (_, _, a) = read_exr(&adaptive);
    let (_, _, u) = read_exr(&uniform);
    let counts = channel(&a, "ViewLayer.Debug Sample Count.X");
    assert!(counts.iter().all(|&c| c == 1.0), "some pixel stopped before --spp");
    for c in ["R", "G", "B", "A"] {
        let name = format!("ViewLayer.Combined.{c}");
        let same = channel(&a, &name).iter().zip(channel(&u, &name)).all(|(x, y)| x.to_bits() == y.to_bits());
        assert!(same, "{name} differs from the uniform render's");
    }
}
