//! Criterion benchmarks of the two backends: BVH build time, and closest-hit throughput of
//! Embree single rays (`rtcIntersect1`), Embree packets (`rtcIntersect8`) and the native BVH
//! on the same primary and random rays, one thread. Scenes: procedural ones, and the Stanford
//! bunny and dragon when the test data is there (`STRAHL_TEST_DATA`).
//!
//! `cargo bench --bench accel [FILTER]`; throughput is reported in rays per second. For the
//! full table (1 and 2 threads, secondary rays, Mrays per CPU-second) run `strahl bench SCENE`.

mod scenes;

use std::time::Duration;

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use strahl::accel::bvh::Bvh;
use strahl::accel::embree::{BuildOptions, Device, DeviceOptions, EmbreeAccel};
use strahl::verify::bench::{pool, trace};
use strahl::verify::workload::{self, RayKind};

/// Rays per iteration: enough to average over the image, few enough for quick samples.
const RAYS: usize = 1 << 16;

fn accel(c: &mut Criterion) {
    let pool = pool(1).expect("a thread pool");
    let device = Device::with_options(DeviceOptions { threads: Some(1) }).expect("an Embree device");
    for name in ["spheres", "icosphere", "triangles", "bunny", "dragon"] {
        let Some(scene) = scenes::load(name) else {
            eprintln!("{name}: skipped (file not found)");
            continue;
        };
        let mut build = c.benchmark_group(format!("build/{name}"));
        build.sample_size(10).measurement_time(Duration::from_secs(5));
        build.bench_function("embree", |b| {
            b.iter(|| pool.install(|| EmbreeAccel::build(&device, &scene, BuildOptions::default()).unwrap()))
        });
        build.bench_function("native", |b| b.iter(|| pool.install(|| Bvh::build(&scene).unwrap())));
        build.finish();

        let embree = pool.install(|| EmbreeAccel::build(&device, &scene, BuildOptions::default())).unwrap();
        let native = pool.install(|| Bvh::build(&scene)).unwrap();
        for kind in [RayKind::Primary, RayKind::Random] {
            // A 256×256 primary image, or 64k random rays: the same for every engine.
            let rays = pool.install(|| workload::rays(&scene, kind, RAYS, 1, &embree)).unwrap();
            let mut hits = vec![None; rays.len()];
            let mut group = c.benchmark_group(format!("trace/{name}/{kind}"));
            group.throughput(Throughput::Elements(rays.len() as u64)).sample_size(20);
            group.bench_function(BenchmarkId::from_parameter("embree1"), |b| {
                b.iter(|| pool.install(|| trace(&embree, &rays, &mut hits, false)).unwrap())
            });
            group.bench_function(BenchmarkId::from_parameter("embree8"), |b| {
                b.iter(|| pool.install(|| trace(&embree, &rays, &mut hits, true)).unwrap())
            });
            group.bench_function(BenchmarkId::from_parameter("native"), |b| {
                b.iter(|| pool.install(|| trace(&native, &rays, &mut hits, false)).unwrap())
            });
            group.finish();
        }
    }
}

criterion_group!(benches, accel);
criterion_main!(benches);
