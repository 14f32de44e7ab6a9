//! Scenes the benchmarks trace: procedural ones the project makes itself, and the Stanford
//! meshes when the test data is there (`../shared/data/meshes` or `$STRAHL_TEST_DATA`), loaded
//! as scenes of their own with [`strahl::scene::from_mesh_file`].

#![allow(dead_code)]

use std::path::{Path, PathBuf};

use strahl::math::{Aabb, Vec3};
use strahl::scene::{Scene, procedural};

/// Every scene name [`load`] knows.
pub const NAMES: [&str; 6] = ["spheres", "icosphere", "triangles", "bunny", "dragon-res2", "dragon"];

/// The shared test-data folder, if it is there.
pub fn data_dir() -> Option<PathBuf> {
    let dir = std::env::var_os("STRAHL_TEST_DATA")
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/data/meshes"));
    dir.is_dir().then_some(dir)
}

/// The scene called `name`: `None` when its file is missing.
pub fn load(name: &str) -> Option<Scene> {
    let mesh_scene = |file: &str| -> Option<Scene> {
        let path = data_dir()?.join("stanford").join(file);
        let loaded = strahl::scene::from_mesh_file(&path).unwrap_or_else(|e| panic!("{e}"));
        Some(loaded.scene)
    };
    let b = Aabb::new(Vec3::splat(-10.0), Vec3::splat(10.0));
    match name {
        // 1000 random spheres.
        "spheres" => Some(Scene { spheres: procedural::random_spheres(1000, b, (0.1, 1.0), 1), ..Default::default() }),
        // An 82k-triangle icosphere.
        "icosphere" => Some(Scene { meshes: vec![procedural::icosphere(6)], ..Default::default() }),
        // 100k random small triangles, overlapping.
        "triangles" => {
            Some(Scene { meshes: vec![procedural::random_triangles(100_000, b, 0.5, 2)], ..Default::default() })
        }
        "bunny" => mesh_scene("bun_zipper.ply"),
        "dragon-res2" => mesh_scene("dragon_vrip_res2.ply.gz"),
        "dragon" => mesh_scene("dragon_vrip.ply.gz"),
        _ => panic!("unknown scene '{name}' (known: {NAMES:?})"),
    }
}
