//! The memory budget: what a render will need, estimated from the loaded scene and the image
//! before anything large is allocated (the BVHs, the film, the output), so that a render that
//! cannot fit is refused up front instead of taking a farm node down; and the budget itself,
//! `--max-memory`, by default the smallest limit the process runs under
//! ([`crate::sys::memory::default_limit`]).
//!
//! ```text
//! total = base + geometry + textures + BVH + film + output
//! ```
//!
//! - **base**: [`BASE_BYTES`], the process, Embree's device and the thread pool.
//! - **geometry**: the scene's arrays as they are (positions, indices, normals, colours, texture
//!   coordinates, per-triangle materials; spheres, planes, instances), counted exactly, and
//!   every name the scene holds (one per sphere of a `random_spheres` object) at
//!   [`STRING_BYTES`] plus its length.
//! - **textures**: the decoded texels, 12 bytes each, every image once.
//! - **BVH**: the peak of either backend's build (both backends' with the `disagreement`
//!   pass), which holds its temporaries and the finished
//!   tree at once: [`TRIANGLE_BUILD_BYTES`] per triangle (meshes and prototypes, each once),
//!   [`SPHERE_BUILD_BYTES`] per sphere, [`MESH_BUILD_BYTES`] per mesh and
//!   [`BVH_BYTES_PER_INSTANCE`] per instance, plus Embree's own copy of every vertex and index
//!   buffer (12 bytes per vertex and per triangle), and each backend's copy of the meshes whose
//!   alpha or back faces decide their hits ([`crate::scene::alpha::AlphaTest::size_for`]). Measured (peak RSS, `/usr/bin/time`, 2
//!   threads) with 1 to 6 Stanford dragons (871,306 triangles each) as separate meshes: every
//!   dragon adds 124.8 MB to Embree's peak and 108.7 MB to the native one's, of which 19.6 MB
//!   are its arrays once loaded: 121 and 102 bytes per triangle beyond the geometry (Embree's
//!   includes its 18-byte copy). 2,000,000 random spheres: 218 and 175 bytes per sphere in
//!   all, 68 of them the sphere and its name. 50,000 one-triangle meshes: about 600 bytes per
//!   Embree geometry. (The finished trees alone are smaller: 55 and 49 bytes per triangle.)
//! - **film**: 4 bytes per float per pixel of the region, over every pass (RGBA, Z, N, albedo,
//!   and the AOVs with their floats per pixel, Cryptomatte included).
//! - **output**: a quarter of the film (the compressed EXR blocks kept while rendering, at most
//!   a sixteenth of the film, 32 to 256 MB, [`crate::output::exr_stream`]; the encoder's per-block
//!   buffers and the PNG) plus
//!   [`OUTPUT_BASE_BYTES`]. Measured: 3840 × 2160, default passes (44 bytes of film per pixel):
//!   441 MB peak against 136 MB at 1920 × 1080, 53 bytes per pixel in all; 16384 × 16384,
//!   12.0 GB, 44.6 bytes per pixel.
//!
//! The parts are added although the BVH's temporaries are freed before the film is made: the
//! sum errs high. Six dragons at 320 × 240: estimated 850 MB, peak 760 MB (Embree) and 677 MB
//! (native); `tests/memory.rs` checks the estimate against the peak of real renders.
//!
//! Nothing here grows with the sample count: samples are accumulated into the film's pixel as
//! they are drawn, and Cryptomatte's per-pixel id counts live on the rendering thread for one
//! pixel at a time (at most `spp` entries, bounded by the `spp` cap). So `spp × pixels` costs
//! time, not memory; the time is shown by the progress bar, and a long render can be stopped
//! and resumed (`--checkpoint-every`, `--resume`).
//!
//! Not counted: the load's transient buffers (a mesh file's bytes while it is parsed, an image
//! file's while it is decoded; bounded by the file limits of [`crate::sys::read`]), freed
//! before the budget is checked, and whatever grows with the thread count beyond the base.

use std::collections::HashSet;

use crate::output::passes::Pass;
use crate::scene::Scene;
pub use crate::sys::memory::{BASE_BYTES, BVH_BYTES_PER_INSTANCE, Limit, default_limit, megabytes, parse_size};

/// The peak of a BVH build per triangle, beyond the scene's arrays and Embree's copy of them
/// (measured 103 for Embree, 102 for the native BVH, on the dragon; rounded up).
pub const TRIANGLE_BUILD_BYTES: u64 = 112;
/// The peak of a BVH build per sphere, beyond the sphere and its name (measured 150 for
/// Embree's user geometry, 107 for the native BVH; rounded up).
pub const SPHERE_BUILD_BYTES: u64 = 160;
/// Per mesh (and prototype): Embree's geometry object and buffers' headers, the native BVH's
/// records (measured about 600 bytes per mesh with Embree).
pub const MESH_BUILD_BYTES: u64 = 1 << 10;
/// A string's own bytes besides its text: the `String` (24) and the allocator's header and
/// rounding (up to 24).
pub const STRING_BYTES: u64 = 48;
/// The output's fixed part (encoder state, compression buffers per thread).
pub const OUTPUT_BASE_BYTES: u64 = 16 << 20;

/// The estimated memory of a render, bytes, by what needs it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Estimate {
    pub base: u64,
    pub geometry: u64,
    pub textures: u64,
    pub bvh: u64,
    pub film: u64,
    pub output: u64,
}

impl Estimate {
    /// The sum of the parts.
    pub fn total(&self) -> u64 {
        self.base + self.geometry + self.textures + self.bvh + self.film + self.output
    }
}

impl std::fmt::Display for Estimate {
    /// `812 MB (geometry 16 MB, textures 0 MB, BVH 56 MB, film 365 MB, output 107 MB, base 42 MB)`.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} (geometry {}, textures {}, BVH {}, film {}, output {}, base {})",
            megabytes(self.total()),
            megabytes(self.geometry),
            megabytes(self.textures),
            megabytes(self.bvh),
            megabytes(self.film),
            megabytes(self.output),
            megabytes(self.base)
        )
    }
}

/// The estimate for rendering `pixels` pixels (the region) of `scene`.
pub fn estimate(scene: &Scene, pixels: u64) -> Estimate {
    let size = |n: usize, each: usize| (n * each) as u64;
    let text = |s: &String| STRING_BYTES + s.len() as u64;
    let meshes = scene.meshes.iter().chain(&scene.prototypes);
    let names = &scene.names;
    let geometry = meshes
        .clone()
        .map(|m| {
            size(m.positions.len(), 12)
                + size(m.indices.len(), 12)
                + m.normals.as_ref().map_or(0, |v| size(v.len(), 12))
                + m.colors.as_ref().map_or(0, |v| size(v.len(), 12))
                + m.uvs.as_ref().map_or(0, |v| size(v.len(), 8))
                + m.uvs1.as_ref().map_or(0, |v| size(v.len(), 8))
                + m.tangents.as_ref().map_or(0, |v| size(v.len(), 16))
                + m.triangle_materials.as_ref().map_or(0, |v| size(v.len(), 4))
                + text(&m.name)
        })
        .sum::<u64>()
        + size(scene.spheres.len(), std::mem::size_of::<crate::geometry::Sphere>())
        + size(scene.planes.len(), std::mem::size_of::<crate::geometry::Plane>())
        + size(scene.instances.len(), std::mem::size_of::<crate::scene::Instance>())
        + scene.instances.iter().map(|i| text(&i.name)).sum::<u64>()
        + scene.materials.iter().map(|m| text(&m.name)).sum::<u64>()
        + names.meshes.iter().chain(&names.spheres).chain(&names.planes).map(text).sum::<u64>();
    let mut seen = HashSet::new();
    let textures = scene
        .materials
        .iter()
        .flat_map(|m| m.images())
        .filter(|&image| seen.insert(std::sync::Arc::as_ptr(image)))
        .map(|image| image.size_bytes() as u64)
        .sum();
    let triangles = meshes.clone().map(|m| m.indices.len() as u64).sum::<u64>();
    let vertices = meshes.clone().map(|m| m.positions.len() as u64).sum::<u64>();
    let embree_copy = 12 * (vertices + triangles);
    let one_bvh = triangles * TRIANGLE_BUILD_BYTES
        + scene.spheres.len() as u64 * SPHERE_BUILD_BYTES
        + meshes.count() as u64 * MESH_BUILD_BYTES
        + scene.instances.len() as u64 * BVH_BYTES_PER_INSTANCE
        + embree_copy
        + crate::scene::alpha::AlphaTest::size_for(scene) as u64;
    // The disagreement pass keeps both backends' BVHs.
    let bvh = if scene.output.passes.contains(Pass::Disagreement) { 2 * one_bvh } else { one_bvh };
    let floats: u64 = scene
        .output
        .passes
        .iter()
        .map(|p| match p {
            Pass::Combined => 4,
            Pass::Depth => 1,
            Pass::Normal | Pass::Albedo => 3,
            aov => aov.floats_per_pixel(scene.output.crypto_levels) as u64,
        })
        .sum::<u64>()
        .max(4);
    let film = pixels.saturating_mul(4 * floats);
    Estimate { base: BASE_BYTES, geometry, textures, bvh, film, output: film / 4 + OUTPUT_BASE_BYTES }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Vec3;
    use crate::scene::Mesh;

    #[test]
    fn the_estimate_counts_what_the_scene_holds() {
        let mut scene = Scene::default();
        scene.meshes.push(Mesh {
            positions: vec![Vec3::ZERO; 3],
            indices: vec![[0, 1, 2]; 1000],
            normals: Some(vec![Vec3::Z; 3]),
            ..Mesh::default()
        });
        let e = estimate(&scene, 1920 * 1080);
        assert_eq!(e.geometry, 3 * 12 + 1000 * 12 + 3 * 12 + STRING_BYTES);
        assert_eq!(e.bvh, 1000 * TRIANGLE_BUILD_BYTES + MESH_BUILD_BYTES + 12 * (3 + 1000));
        // Default passes: RGBA, Z, N, albedo: 11 floats per pixel.
        assert_eq!(e.film, 1920 * 1080 * 44);
        assert_eq!(e.output, e.film / 4 + OUTPUT_BASE_BYTES);
        assert_eq!(e.total(), e.base + e.geometry + e.bvh + e.film + e.output);
    }
}
