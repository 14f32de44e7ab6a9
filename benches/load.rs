//! Mesh loading throughput: the Stanford dragon as shipped (ASCII PLY, gzip) and
//! uncompressed, and the bunny as OBJ. Reported per file in MB/s of file read and, in the
//! second group, Mtriangles/s. Needs the shared test data (`../shared/data/meshes` or
//! `$STRAHL_TEST_DATA`); without it the benchmark says so and measures nothing.

mod scenes;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use scenes::data_dir;
use strahl::scene::load::{MeshOptions, load_mesh};

fn load(c: &mut Criterion) {
    let Some(root) = data_dir() else {
        eprintln!("benches/load: no test data (../shared/data/meshes or $STRAHL_TEST_DATA); nothing measured");
        return;
    };
    let dragon_gz = root.join("stanford/dragon_vrip.ply.gz");
    let plain = std::env::temp_dir().join(format!("strahl-bench-dragon-{}.ply", std::process::id()));
    std::fs::write(&plain, strahl::scene::load::mesh::read_file(&dragon_gz).expect("the dragon")).unwrap();
    let files = [
        ("dragon_vrip.ply.gz", dragon_gz),
        ("dragon_vrip.ply (uncompressed)", plain.clone()),
        ("stanford-bunny.obj", root.join("stanford/stanford-bunny.obj")),
    ];
    let options = MeshOptions::default();
    for (unit, per_file) in [("MB of file", true), ("triangles", false)] {
        let mut group = c.benchmark_group(format!("load ({unit})"));
        group.sample_size(10);
        for (name, path) in &files {
            let triangles = load_mesh(path, &options).unwrap().triangles_read as u64;
            let bytes = std::fs::metadata(path).unwrap().len();
            group.throughput(if per_file { Throughput::Bytes(bytes) } else { Throughput::Elements(triangles) });
            group.bench_function(*name, |b| b.iter(|| load_mesh(path, &options).unwrap()));
        }
        group.finish();
    }
    let _ = std::fs::remove_file(&plain);
}

criterion_group!(benches, load);
criterion_main!(benches);
