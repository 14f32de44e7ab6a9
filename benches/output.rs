//! The output phase: encoding a rendered 1920×1080 frame of the shipped Whitted scene, default
//! passes (11 float channels), as OpenEXR ZIP into memory on 1 and 2 threads (criterion's
//! "bytes" are the film's raw floats), and its sRGB PNG preview. Disk time is not included:
//! `strahl render` prints the whole output phase, file system included.

use std::io::Cursor;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use strahl::accel::embree::{BuildOptions, Device, EmbreeAccel};
use strahl::integrator;
use strahl::output::exr::{ExrOptions, encode_to};

fn output(c: &mut Criterion) {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/whitted.toml");
    let mut scene = strahl::scene::load(path).expect("the shipped scene loads").scene;
    scene.image.width = 1920;
    scene.image.height = 1080;
    scene.image.spp = 1;
    let device = Device::new().expect("an Embree device");
    let accel = EmbreeAccel::build(&device, &scene, BuildOptions::default()).expect("the scene builds");
    let (film, _) = integrator::render(&scene, &accel, &|_| {}).expect("renders");
    let options = ExrOptions::default();
    let raw: usize = film.buffers().iter().map(|(data, _)| data.len() * 4).sum();
    let mut group = c.benchmark_group("output");
    group.sample_size(10);
    group.throughput(Throughput::Bytes(raw as u64));
    for threads in [1usize, 2] {
        group.bench_function(format!("exr_zip_1920x1080_threads{threads}"), |b| {
            b.iter(|| {
                let mut out = Cursor::new(Vec::with_capacity(32 << 20));
                encode_to(&film, &options, threads, &mut out).expect("encodes");
                out.into_inner().len()
            })
        });
    }
    group.throughput(Throughput::Elements(film.rgba.len() as u64));
    group.bench_function("png_1920x1080", |b| {
        b.iter(|| strahl::output::png::encode(&film, 0.0).expect("encodes").len())
    });
    group.finish();
}

criterion_group!(benches, output);
criterion_main!(benches);
