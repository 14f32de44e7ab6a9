//! Scenes the benchmarks trace: procedural ones the project makes itself, and the Stanford
//! meshes when the test data is there (read with the stop-gap PLY reader until `strahl::io`
//! lands).

#![allow(dead_code)]

#[path = "../tests/common/ply_stopgap.rs"]
mod ply_stopgap;

use strahl::math::{Aabb, Vec3};
use strahl::scene::{Scene, procedural};

/// Every scene name [`load`] knows.
pub const NAMES: [&str; 6] = ["spheres", "icosphere", "triangles", "bunny", "dragon-res2", "dragon"];

/// The scene called `name`: `None` when its file is missing.
pub fn load(name: &str) -> Option<Scene> {
    let mesh_scene = |file: &str| -> Option<Scene> {
        let path = ply_stopgap::stanford(file)?;
        let mesh = ply_stopgap::load(&path).unwrap_or_else(|e| panic!("{e}"));
        Some(Scene { meshes: vec![mesh], ..Default::default() })
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
