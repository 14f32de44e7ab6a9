//! The memory budget: what a render will need, estimated from the loaded scene and the image
//! before anything large is allocated (the BVHs, the film, the output), so that a render that
//! cannot fit is refused up front instead of taking a farm node down.
//!
//! ```text
//! total = base + geometry + textures + BVH + film + output
//! ```
//!
//! - **base**: [`BASE_BYTES`], the process, Embree's device and the thread pool.
//! - **geometry**: the scene's arrays as they are (positions, indices, normals, colours, texture
//!   coordinates, per-triangle materials; spheres, planes, instances), counted exactly.
//! - **textures**: the decoded texels, 12 bytes each, every image once.
//! - **BVH**: [`BVH_BYTES_PER_PRIMITIVE`] per triangle (meshes and prototypes, each once) and per
//!   sphere, [`BVH_BYTES_PER_INSTANCE`] per instance: measured on the Stanford dragon (871,306
//!   triangles): Embree's BVH 48 MB, the native one 43 MB, i.e. 55 and 49 bytes per triangle.
//! - **film**: 4 bytes per float per pixel of the region, over every pass (RGBA, Z, N, albedo,
//!   and the AOVs with their floats per pixel, Cryptomatte included).
//! - **output**: a quarter of the film (the compressed EXR blocks kept while rendering, at most
//!   a sixteenth of the film, 32 to 256 MB, [`crate::output::exr_stream`]; the encoder's per-block
//!   buffers and the PNG) plus
//!   [`OUTPUT_BASE_BYTES`]. Measured: 3840 × 2160, default passes (44 bytes of film per pixel):
//!   441 MB peak against 136 MB at 1920 × 1080, 53 bytes per pixel in all; 16384 × 16384,
//!   12.0 GB, 44.6 bytes per pixel.
//!
//! Nothing here grows with the sample count: samples are accumulated into the film's pixel as
//! they are drawn, and Cryptomatte's per-pixel id counts live on the rendering thread for one
//! pixel at a time (at most `spp` entries, bounded by the `spp` cap). So `spp × pixels` costs
//! time, not memory; the time is shown by the progress bar, and a long render can be stopped
//! and resumed (`--checkpoint-every`, `--resume`).
//!
//! The estimate errs high; it does not count the load's transient buffers (bounded by the
//! file limits of [`crate::sys::read`]).

use std::collections::HashSet;

use crate::material::Texture;
use crate::output::passes::Pass;
use crate::scene::Scene;

/// The process, Embree's device and the thread pool (measured: 30–37 MB for the smallest scene).
pub const BASE_BYTES: u64 = 40 << 20;
/// BVH memory per triangle or sphere (measured 49–55 on the dragon, rounded up).
pub const BVH_BYTES_PER_PRIMITIVE: u64 = 64;
/// BVH memory per instance (the top level's node and the instance record).
pub const BVH_BYTES_PER_INSTANCE: u64 = 256;
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

/// `n` bytes as whole megabytes (10⁶ bytes), e.g. `42 MB`.
pub fn megabytes(n: u64) -> String {
    format!("{} MB", n.div_ceil(1_000_000))
}

/// The estimate for rendering `pixels` pixels (the region) of `scene`.
pub fn estimate(scene: &Scene, pixels: u64) -> Estimate {
    let size = |n: usize, each: usize| (n * each) as u64;
    let meshes = scene.meshes.iter().chain(&scene.prototypes);
    let geometry = meshes
        .clone()
        .map(|m| {
            size(m.positions.len(), 12)
                + size(m.indices.len(), 12)
                + m.normals.as_ref().map_or(0, |v| size(v.len(), 12))
                + m.colors.as_ref().map_or(0, |v| size(v.len(), 12))
                + m.uvs.as_ref().map_or(0, |v| size(v.len(), 8))
                + m.triangle_materials.as_ref().map_or(0, |v| size(v.len(), 4))
        })
        .sum::<u64>()
        + size(scene.spheres.len(), std::mem::size_of::<crate::geometry::Sphere>())
        + size(scene.planes.len(), std::mem::size_of::<crate::geometry::Plane>())
        + size(scene.instances.len(), std::mem::size_of::<crate::scene::Instance>());
    let mut seen = HashSet::new();
    let textures = scene
        .materials
        .iter()
        .filter_map(|m| match &m.diffuse {
            Texture::Image(t) => seen.insert(std::sync::Arc::as_ptr(&t.image)).then(|| t.image.size_bytes() as u64),
            _ => None,
        })
        .sum();
    let primitives = meshes.map(|m| m.indices.len() as u64).sum::<u64>() + scene.spheres.len() as u64;
    let bvh = primitives * BVH_BYTES_PER_PRIMITIVE + scene.instances.len() as u64 * BVH_BYTES_PER_INSTANCE;
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

/// The machine's physical memory (`MemTotal` of `/proc/meminfo`), if it can be read.
pub fn physical_memory() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemTotal:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024)
}

/// The default `--max-memory`: three quarters of the physical memory (the rest for the system
/// and the render's own transient buffers), or no limit when it cannot be read.
pub fn default_limit() -> Option<u64> {
    physical_memory().map(|m| m / 4 * 3)
}

/// Parses a size: a number of bytes with an optional suffix `K`, `M`, `G`, `T` (powers of
/// 1024; `KiB`, `MB`, … read the same way, case-insensitive): `512M`, `24G`, `1.5G`.
pub fn parse_size(text: &str) -> Result<u64, String> {
    let t = text.trim();
    let split = t.find(|c: char| !(c.is_ascii_digit() || c == '.')).unwrap_or(t.len());
    let (number, unit) = t.split_at(split);
    let value: f64 = number.parse().map_err(|_| format!("'{text}' is not a size (e.g. 512M, 24G)"))?;
    let shift = match unit.trim().to_ascii_lowercase().trim_end_matches("ib").trim_end_matches('b') {
        "" => 0,
        "k" => 10,
        "m" => 20,
        "g" => 30,
        "t" => 40,
        _ => return Err(format!("'{text}': unknown unit '{unit}' (use K, M, G or T)")),
    };
    let bytes = value * (1u64 << shift) as f64;
    if !(bytes.is_finite() && bytes >= 1.0 && bytes < u64::MAX as f64) {
        return Err(format!("'{text}' is not a size of at least one byte"));
    }
    Ok(bytes as u64)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Vec3;
    use crate::scene::Mesh;

    #[test]
    fn sizes_parse_with_binary_units() {
        assert_eq!(parse_size("512M"), Ok(512 << 20));
        assert_eq!(parse_size("24G"), Ok(24 << 30));
        assert_eq!(parse_size("1.5g"), Ok(3 << 29));
        assert_eq!(parse_size("100"), Ok(100));
        assert_eq!(parse_size("2GiB"), Ok(2 << 30));
        for bad in ["", "G", "-1G", "3X", "0"] {
            assert!(parse_size(bad).is_err(), "{bad}");
        }
    }

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
        assert_eq!(e.geometry, 3 * 12 + 1000 * 12 + 3 * 12);
        assert_eq!(e.bvh, 1000 * BVH_BYTES_PER_PRIMITIVE);
        // Default passes: RGBA, Z, N, albedo: 11 floats per pixel.
        assert_eq!(e.film, 1920 * 1080 * 44);
        assert_eq!(e.output, e.film / 4 + OUTPUT_BASE_BYTES);
        assert_eq!(e.total(), e.base + e.geometry + e.bvh + e.film + e.output);
    }
}
