//! The tools that check and time the backends rather than render: the standard ray sets
//! ([`workload`]), the cross-check of Embree's hits against the native BVH's ([`crosscheck`])
//! and the throughput benchmark ([`bench`](mod@bench), beside Embree's own loops in
//! [`crate::accel::embree::raw_bench`]).

use crate::scene::Scene;

pub mod bench;
pub mod crosscheck;
pub mod workload;

/// The scene's geometry in one line, as `crosscheck` and `bench` print it: its triangles as rays
/// see them (an instanced scene's, with how many are stored once and the instances placing
/// them), spheres and planes.
pub fn geometry_line(scene: &Scene) -> String {
    let own = scene.triangle_count();
    let triangles = if scene.instances.is_empty() {
        format!("{own} triangles")
    } else {
        format!(
            "{} triangles as rays see them ({} stored once, {} instances)",
            own + scene.instanced_triangle_count(),
            own + scene.prototype_triangle_count(),
            scene.instances.len()
        )
    };
    format!("{triangles}, {} spheres, {} planes", scene.spheres.len(), scene.planes.len())
}
