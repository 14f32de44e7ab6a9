//! A fingerprint of a scene and its settings: 64-bit FNV-1a over everything that decides the
//! pixels (camera, image and output settings, materials, lights, every primitive and its
//! name), as 16 hex digits. Two renders with the same fingerprint render the same pixels, so
//! a merge or a resume can refuse pieces of a different scene. It is stable across runs,
//! platforms and thread counts (it hashes values, not addresses), but not promised across
//! strahl versions.
//!
//! FNV-1a is written out here (5 lines) rather than taken from a crate: it is not for
//! security, only for telling scenes apart, and must never change with a dependency.

use std::fmt::Write as _;

use super::Scene;

/// 64-bit FNV-1a, fed bytes and formatted text (also the checksum of checkpoints, fed as they
/// are written and read).
pub struct Fnv1a(u64);

impl Default for Fnv1a {
    fn default() -> Self {
        Fnv1a(0xcbf2_9ce4_8422_2325)
    }
}

impl Fnv1a {
    /// The hash of the bytes fed so far.
    pub fn value(&self) -> u64 {
        self.0
    }

    /// Feeds `bytes`.
    pub fn bytes(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 = (self.0 ^ b as u64).wrapping_mul(0x0000_0100_0000_01b3);
        }
    }
}

impl std::fmt::Write for Fnv1a {
    fn write_str(&mut self, s: &str) -> std::fmt::Result {
        self.bytes(s.as_bytes());
        Ok(())
    }
}

/// The fingerprint of `scene` (see the module docs).
pub fn scene_hash(scene: &Scene) -> u64 {
    let mut h = Fnv1a(0xcbf2_9ce4_8422_2325);
    let _ = write!(
        h,
        "{:?}{:?}{:?}{:?}{:?}{:?}{:?}{:?}",
        scene.camera,
        scene.image,
        scene.output,
        scene.materials,
        scene.lights,
        scene.spheres,
        scene.planes,
        scene.names
    );
    // Only when there are any: scenes without area lights keep the fingerprints they had.
    if !scene.area_lights.is_empty() {
        let _ = write!(h, "area {:?}", scene.area_lights);
    }
    for m in &scene.meshes {
        let _ = write!(h, "mesh {:?} {} {:?}", m.name, m.material, m.triangle_materials);
        h.bytes(bytemuck::cast_slice(&m.positions));
        h.bytes(bytemuck::cast_slice(&m.indices));
        for (tag, v) in [("n", &m.normals), ("c", &m.colors)] {
            let _ = write!(h, "{tag}{}", v.as_ref().map_or(0, |v| v.len()));
            h.bytes(v.as_ref().map_or(&[], |v| bytemuck::cast_slice(v)));
        }
        let _ = write!(h, "uv{}", m.uvs.as_ref().map_or(0, |v| v.len()));
        h.bytes(m.uvs.as_ref().map_or(&[], |v| bytemuck::cast_slice(v)));
    }
    h.0
}

/// [`scene_hash`] as the 16 hex digits the EXR header and `strahl` print.
pub fn scene_hash_hex(scene: &Scene) -> String {
    format!("{:016x}", scene_hash(scene))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::procedural::whitted_showcase;

    #[test]
    fn changes_with_the_scene_and_settings_only() {
        let a = whitted_showcase(32, 24, 1);
        assert_eq!(scene_hash(&a), scene_hash(&a.clone()));
        let mut b = a.clone();
        b.image.spp = 2;
        assert_ne!(scene_hash(&a), scene_hash(&b));
        let mut c = a.clone();
        c.meshes[0].positions[0].x += 1e-6;
        assert_ne!(scene_hash(&a), scene_hash(&c));
        let mut d = a.clone();
        d.output.transparent = true;
        assert_ne!(scene_hash(&a), scene_hash(&d));
        assert_eq!(scene_hash_hex(&a).len(), 16);
    }
}
