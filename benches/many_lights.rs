//! The light tree against the choice by power on a scene of 20,000 emissive triangles
//! (`procedural::light_panel_room(100, …)`: a 40 × 40 m room under a ceiling of 100 × 100
//! small quads of 4 colours × 4 strengths, path traced at depth 3), over Embree: the RMSE
//! against a converged reference at equal samples and at equal time, and the tree's build
//! time and memory. Prints the table of docs/performance.md ("Many lights").
//!
//! The reference is the tree's render at `REF` samples per pixel with its first 64 samples
//! taken out (`(REF·I_REF − 64·I_64)/(REF − 64)`), so it shares no sample with the renders it
//! judges (each pixel's Sobol sequence is the same for every render; 4, 16 and 64 spp are its
//! prefixes). Wall-clock times on the machine's rayon pool.
//!
//! ```text
//! cargo bench --profile test --bench many_lights            # REF = 1024
//! STRAHL_MANY_LIGHTS_REF=4096 cargo bench --profile test --bench many_lights
//! ```

use std::time::Instant;

use strahl::accel::embree::{BuildOptions, Device, EmbreeAccel};
use strahl::integrator;
use strahl::integrator::lights::mesh_emitters;
use strahl::light::set::{LightSampler, LightSet};
use strahl::scene::Scene;
use strahl::scene::procedural::light_panel_room;

const WIDTH: u32 = 160;
const HEIGHT: u32 = 120;
const DEPTH: u32 = 3;

fn scene(sampler: LightSampler, spp: u32) -> Scene {
    let mut s = light_panel_room(100, 40.0, WIDTH, HEIGHT, spp, DEPTH);
    s.render.light_sampler = sampler;
    s
}

/// The image (RGB per pixel) and the seconds it took.
fn render(accel: &EmbreeAccel, sampler: LightSampler, spp: u32) -> (Vec<[f64; 3]>, f64) {
    let s = scene(sampler, spp);
    let t = Instant::now();
    let (film, _) = integrator::render(&s, accel, &|_| {}).expect("renders");
    let seconds = t.elapsed().as_secs_f64();
    (film.rgba.iter().map(|p| [p[0] as f64, p[1] as f64, p[2] as f64]).collect(), seconds)
}

fn rmse(a: &[[f64; 3]], b: &[[f64; 3]]) -> f64 {
    let sum: f64 = a.iter().zip(b).map(|(x, y)| (0..3).map(|c| (x[c] - y[c]).powi(2)).sum::<f64>()).sum();
    (sum / (3 * a.len()) as f64).sqrt()
}

fn main() {
    let reference_spp: u32 = std::env::var("STRAHL_MANY_LIGHTS_REF").ok().and_then(|v| v.parse().ok()).unwrap_or(1024);
    let s = scene(LightSampler::Tree, 1);
    let emitters = mesh_emitters(&s);
    let triangles: usize = emitters.iter().map(|e| e.triangle_count()).sum();
    let bounds = s.bounds();
    let radius = 0.5 * (bounds.max - bounds.min).length();
    let time = |sampler| {
        let t = Instant::now();
        let set = LightSet::new(&s.lights, &s.area_lights, emitters.clone(), None, radius, sampler);
        (set, t.elapsed().as_secs_f64())
    };
    let (_, power_build) = time(LightSampler::Power);
    let (set, tree_build) = time(LightSampler::Tree);
    let tree = set.tree().expect("a tree");
    println!(
        "{triangles} emissive triangles: tree of {} nodes, depth {}, {:.2} MB, built in {:.1} ms (power table {:.1} ms)",
        tree.node_count(),
        tree.depth(),
        tree.memory_bytes() as f64 / 1e6,
        tree_build * 1e3,
        power_build * 1e3
    );

    let device = Device::new().expect("an Embree device");
    let accel = EmbreeAccel::build(&device, &s, BuildOptions::default()).expect("the scene builds");
    let (full, ref_seconds) = render(&accel, LightSampler::Tree, reference_spp);
    let (prefix, _) = render(&accel, LightSampler::Tree, 64);
    let (n, k) = (reference_spp as f64, 64.0);
    let reference: Vec<[f64; 3]> =
        full.iter().zip(&prefix).map(|(f, p)| [0, 1, 2].map(|c| (n * f[c] - k * p[c]) / (n - k))).collect();
    let mean = reference.iter().map(|p| (p[0] + p[1] + p[2]) / 3.0).sum::<f64>() / reference.len() as f64;
    println!(
        "{WIDTH} x {HEIGHT}, depth {DEPTH}; reference: tree, samples 64..{reference_spp} ({ref_seconds:.1} s), mean {mean:.4}"
    );
    println!("| spp | tree RMSE | tree s | power RMSE | power s | power / tree RMSE |");
    println!("|---|---|---|---|---|---|");
    let mut at16 = None;
    for spp in [4u32, 16, 64] {
        let (t_img, t_s) = render(&accel, LightSampler::Tree, spp);
        let (p_img, p_s) = render(&accel, LightSampler::Power, spp);
        let (et, ep) = (rmse(&t_img, &reference), rmse(&p_img, &reference));
        println!("| {spp} | {et:.4} | {t_s:.2} | {ep:.4} | {p_s:.2} | {:.2} |", ep / et);
        if spp == 16 {
            at16 = Some((et, t_s, p_s));
        }
    }
    // Equal time: power given the samples it traces in the time the tree took for 16.
    let (et, t_s, p_s) = at16.unwrap();
    let spp_power = ((16.0 * t_s / p_s).round() as u32).clamp(1, 64);
    let (p_img, p_s2) = render(&accel, LightSampler::Power, spp_power);
    let ep = rmse(&p_img, &reference);
    println!(
        "equal time: tree 16 spp {t_s:.2} s RMSE {et:.4}; power {spp_power} spp {p_s2:.2} s RMSE {ep:.4} ({:.2}x the tree's)",
        ep / et
    );
}
