//! Whole-frame rendering throughput of the Whitted integrator over Embree, in rays per
//! second (primary + shadow + reflected + refracted; criterion's "elements").
//!
//! The scene is `procedural::whitted_showcase`: a checkered floor plane, a mirror ball, a
//! glass ball, a glossy icosphere mesh (1280 triangles) and three diffuse balls under a point
//! and a directional light, at 320×240 and 1 and 4 samples per pixel, on 1 and 2 threads.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use strahl::accel::embree::{BuildOptions, Device, EmbreeAccel};
use strahl::integrator;
use strahl::scene::procedural::whitted_showcase;

fn render(c: &mut Criterion) {
    let device = Device::new().expect("an Embree device");
    let mut group = c.benchmark_group("render");
    group.sample_size(10);
    for spp in [1u32, 4] {
        let scene = whitted_showcase(320, 240, spp);
        let accel = EmbreeAccel::build(&device, &scene, BuildOptions::default()).expect("the scene builds");
        for threads in [1usize, 2] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .start_handler(|_| strahl::accel::embree::enable_flush_to_zero())
                .build()
                .expect("a thread pool");
            // The ray count is deterministic: one render gives it for every iteration.
            let (_, counts) = pool.install(|| integrator::render(&scene, &accel, &|_| {})).expect("renders");
            group.throughput(Throughput::Elements(counts.total()));
            group.bench_function(format!("showcase_320x240_spp{spp}_threads{threads}"), |b| {
                b.iter(|| pool.install(|| integrator::render(&scene, &accel, &|_| {})).expect("renders"))
            });
        }
    }
    group.finish();
}

criterion_group!(benches, render);
criterion_main!(benches);
