//! A fingerprint of a scene and its settings: 64-bit XXH3 over everything that decides the
//! pixels (camera, image and output settings, materials and their textures, lights, every
//! primitive and its name), as 16 hex digits. Two renders with the same fingerprint render the
//! same pixels, and any change to the scene changes it, so a merge or a resume can refuse
//! pieces of a different scene. It is stable across runs, platforms (little-endian, as every
//! platform strahl is built for) and thread counts (it hashes values, never addresses, in a
//! fixed order and a fixed split), but not promised across strahl versions.
//!
//! What is fed, in this order, every part preceded by its length so that no two different
//! scenes feed the same bytes:
//!
//! - the `Debug` text of the small settings: camera, image, output, lights, area lights,
//!   object names (every field, including fields added later), and the `[render]` settings
//!   (the integrator) unless they are the default (Whitted's, which thus fingerprints as
//!   before); the environment, if there is one, its map's texels as bytes;
//! - per material its `Debug` text with the texels of its image left out, then the image's
//!   texels as bytes;
//! - the spheres, planes, meshes, prototypes and instances, field by field, as bytes.
//!
//! Bulk arrays (texels, positions, indices, normals, colours, texture coordinates, materials
//! per triangle) are cut into [`CHUNK`]-byte pieces, and spheres, planes and instances into
//! pieces of 65,536, hashed in parallel on the current rayon pool, their digests fed in order.
//! An image's texels are hashed once per process (a render fingerprints its scene before and
//! after rendering): an 8192² 16-bit texture (805 MB of f32 texels) took 52 s of CPU
//! formatted as text, 85 % of its render; as bytes 0.2 s.
//!
//! XXH3 (the `xxhash-rust` crate, a specified algorithm whose output is fixed) is for telling
//! scenes apart, not for security. [`Fnv1a`] stays for the checksum of checkpoints, fed as
//! they are written and read.

use std::collections::HashMap;
use std::fmt::Write as _;
use std::sync::{Arc, LazyLock, Mutex, Weak};

use rayon::prelude::*;
use xxhash_rust::xxh3::{Xxh3, xxh3_64};

use super::{Mesh, RenderSpec, Scene};
use crate::material::Material;
use crate::texture::Image;

/// The pieces bulk arrays are cut into, each hashed on its own (in parallel).
pub const CHUNK: usize = 1 << 20;

/// 64-bit FNV-1a, fed bytes and formatted text: the checksum of checkpoints, fed as they are
/// written and read.
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

/// The hasher of [`scene_hash`], with the framing of the module docs.
struct Feed {
    h: Xxh3,
    /// Text being gathered for [`Feed::text`].
    buffer: String,
}

/// The digests of the images whose texels this process has hashed, by address, each with a
/// [`Weak`] to its image. While the `Weak` lives the image cannot change (`Arc::get_mut`
/// refuses, `Arc::make_mut` moves it to a new allocation) and its address cannot be reused,
/// so an image at a listed address, alive in the caller's hands, is the one hashed.
static TEXELS: LazyLock<Mutex<Digests>> = LazyLock::new(Default::default);

/// Texel digests by image address, each with a `Weak` that keeps the address ([`TEXELS`]).
type Digests = HashMap<usize, (Weak<Image>, u64)>;

/// The digest of `image`'s texels ([`digest`]), computed once per image and process (a render
/// fingerprints its scene before and after rendering; materials share images).
fn texels_digest(image: &Arc<Image>) -> u64 {
    let key = Arc::as_ptr(image) as usize;
    if let Some(&(_, d)) = TEXELS.lock().unwrap_or_else(|p| p.into_inner()).get(&key) {
        return d;
    }
    // Outside the lock: hashing 805 MB takes a while and runs on the rayon pool.
    let d = digest(bytemuck::cast_slice(&image.texels));
    let mut known = TEXELS.lock().unwrap_or_else(|p| p.into_inner());
    known.retain(|_, (w, _)| w.strong_count() > 0);
    known.insert(key, (Arc::downgrade(image), d));
    d
}

impl Feed {
    fn u64(&mut self, x: u64) {
        self.h.update(&x.to_le_bytes());
    }

    /// The `Debug` text of `value`, with its length.
    fn text(&mut self, value: &dyn std::fmt::Debug) {
        self.buffer.clear();
        let _ = write!(self.buffer, "{value:?}");
        self.u64(self.buffer.len() as u64);
        self.h.update(self.buffer.as_bytes());
    }

    /// A bulk array: its length, then the digests of its [`CHUNK`]s, hashed in parallel.
    fn bulk<T: bytemuck::Pod + Sync>(&mut self, items: &[T]) {
        self.u64(digest(bytemuck::cast_slice(items)));
    }

    /// An optional bulk array: whether it is there, then [`Feed::bulk`].
    fn optional<T: bytemuck::Pod + Sync>(&mut self, items: Option<&Vec<T>>) {
        self.u64(items.is_some() as u64);
        if let Some(items) = items {
            self.bulk(items);
        }
    }

    fn material(&mut self, m: &Material) {
        let images = m.images();
        if images.is_empty() {
            return self.text(m);
        }
        // The material as it prints, but with the images' texels left out ...
        self.text(&m.without_texels());
        // ... and the texels as bytes.
        for image in images {
            self.u64(texels_digest(image));
        }
    }

    fn mesh(&mut self, m: &Mesh) {
        self.text(&(&m.name, m.material));
        self.bulk(&m.positions);
        self.bulk(&m.indices);
        self.optional(m.normals.as_ref());
        self.optional(m.colors.as_ref());
        self.optional(m.uvs.as_ref());
        self.optional(m.triangle_materials.as_ref());
        // Hashed only when present (tagged 2), so that the hash of a mesh without it is unchanged.
        if let Some(uvs1) = &m.uvs1 {
            self.u64(2);
            self.bulk(uvs1);
        }
        // Likewise (tagged 3 and 4).
        if let Some(tangents) = &m.tangents {
            self.u64(3);
            self.bulk(tangents);
        }
        if let Some(alphas) = &m.alphas {
            self.u64(4);
            self.bulk(alphas);
        }
    }
}

/// XXH3 of `bytes` cut into [`CHUNK`]s hashed in parallel, their digests hashed in order, with
/// the length.
fn digest(bytes: &[u8]) -> u64 {
    let digests: Vec<u64> = bytes.par_chunks(CHUNK).map(xxh3_64).collect();
    let mut h = Xxh3::new();
    h.update(&(bytes.len() as u64).to_le_bytes());
    h.update(bytemuck::cast_slice(&digests));
    h.digest()
}

/// The fingerprint of `scene` (see the module docs).
pub fn scene_hash(scene: &Scene) -> u64 {
    let mut f = Feed { h: Xxh3::new(), buffer: String::new() };
    f.text(&scene.camera);
    f.text(&scene.image);
    f.text(&scene.output);
    f.text(&scene.lights);
    f.text(&scene.area_lights);
    f.text(&scene.names);
    // The Whitted integrator's settings feed nothing, so its fingerprints stay as they were.
    if scene.render != RenderSpec::default() {
        f.text(&scene.render);
    }
    // A scene without an environment feeds nothing, so its fingerprint stays as it was.
    if let Some(env) = &scene.environment {
        f.text(env);
        if let crate::light::environment::EnvironmentSource::Map(m) = &env.source {
            f.u64(digest(bytemuck::cast_slice(&m.image.texels)));
        }
    }
    f.u64(scene.materials.len() as u64);
    for m in &scene.materials {
        f.material(m);
    }
    f.u64(records(&scene.spheres, |h, s| {
        h.update(bytemuck::cast_slice(&s.center.to_array()));
        h.update(&s.radius.to_le_bytes());
        h.update(&s.material.to_le_bytes());
    }));
    f.u64(records(&scene.planes, |h, p| {
        h.update(bytemuck::cast_slice(&p.normal.to_array()));
        h.update(&p.dist.to_le_bytes());
        h.update(&p.material.to_le_bytes());
    }));
    for meshes in [&scene.meshes, &scene.prototypes] {
        f.u64(meshes.len() as u64);
        for m in meshes {
            f.mesh(m);
        }
    }
    f.u64(records(&scene.instances, |h, inst| {
        h.update(&(inst.name.len() as u64).to_le_bytes());
        h.update(inst.name.as_bytes());
        h.update(&inst.prototype.to_le_bytes());
        h.update(bytemuck::cast_slice(&inst.transform.affine().to_cols_array()));
        h.update(&inst.material.map_or(u64::MAX, u64::from).to_le_bytes());
    }));
    f.h.digest()
}

/// Records fed field by field (spheres, planes, instances: millions of them at most), in
/// pieces of [`RECORDS`] hashed in parallel; the count and the pieces' digests, in order.
fn records<T: Sync>(items: &[T], feed: impl Fn(&mut Xxh3, &T) + Sync) -> u64 {
    let digests: Vec<u64> = items
        .par_chunks(RECORDS)
        .map(|piece| {
            let mut h = Xxh3::new();
            piece.iter().for_each(|item| feed(&mut h, item));
            h.digest()
        })
        .collect();
    let mut h = Xxh3::new();
    h.update(&(items.len() as u64).to_le_bytes());
    h.update(bytemuck::cast_slice(&digests));
    h.digest()
}

/// The records hashed in one piece by [`records`].
const RECORDS: usize = 1 << 16;

/// [`scene_hash`] as the 16 hex digits the EXR header and `strahl` print.
pub fn scene_hash_hex(scene: &Scene) -> String {
    format!("{:016x}", scene_hash(scene))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::material::Texture;
    use crate::math::{Vec2, Vec3};
    use crate::scene::procedural::whitted_showcase;
    use crate::scene::{Instance, transform::Transform};
    use crate::texture::{ImageTexture, Wrap};

    /// The showcase with an image texture on material 0, a textured mesh and an instance.
    fn scene() -> Scene {
        let mut s = whitted_showcase(32, 24, 1);
        let texels = (0..3 * CHUNK / 12 + 7).map(|i| Vec3::splat(i as f32 / 1e6)).collect::<Vec<_>>();
        let image = Image::from_texels("tex.png", texels.len(), 1, texels).unwrap();
        let texture = ImageTexture {
            image: image.into(),
            wrap_u: Wrap::Repeat,
            wrap_v: Wrap::Clamp,
            factor: Vec3::ONE,
            mipmaps: true,
        };
        s.materials[0].diffuse = Texture::Image(crate::material::TextureSlot::plain(texture));
        s.meshes[0].uvs = Some(vec![Vec2::ZERO; s.meshes[0].positions.len()]);
        s.prototypes.push(s.meshes[0].clone());
        s.instances.push(Instance {
            name: "copy".into(),
            prototype: 0,
            transform: Transform::default(),
            material: None,
        });
        s
    }

    #[test]
    fn changes_with_the_scene_and_settings_only() {
        let a = scene();
        assert_eq!(scene_hash(&a), scene_hash(&a.clone()));
        // The same values in new allocations (a texture decoded again): the same fingerprint.
        let mut again = a.clone();
        let Texture::Image(t) = &mut again.materials[0].diffuse else { unreachable!() };
        t.texture.image = std::sync::Arc::new((*t.texture.image).clone());
        assert_eq!(scene_hash(&a), scene_hash(&again));
        // On one thread as on several.
        let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
        assert_eq!(one.install(|| scene_hash(&a)), scene_hash(&a));
        assert_eq!(scene_hash_hex(&a).len(), 16);

        let texel = |s: &mut Scene, i: usize| {
            let Texture::Image(t) = &mut s.materials[0].diffuse else { unreachable!() };
            std::sync::Arc::make_mut(&mut t.texture.image).texels[i].y += 1e-6;
        };
        type Change = Box<dyn Fn(&mut Scene)>;
        let changes: Vec<(&str, Change)> = vec![
            ("spp", Box::new(|s| s.image.spp = 2)),
            ("transparent", Box::new(|s| s.output.transparent = true)),
            ("adaptive sampling", Box::new(|s| s.render.set_adaptive_threshold(0.01))),
            ("vertex", Box::new(|s| s.meshes[0].positions[0].x += 1e-6)),
            ("first texel", Box::new(move |s| texel(s, 0))),
            ("last texel", Box::new(move |s| texel(s, 3 * CHUNK / 12 + 6))),
            (
                "wrap",
                Box::new(|s| {
                    let Texture::Image(t) = &mut s.materials[0].diffuse else { unreachable!() };
                    t.texture.wrap_u = Wrap::Clamp;
                }),
            ),
            (
                "texture name",
                Box::new(|s| {
                    let Texture::Image(t) = &mut s.materials[0].diffuse else { unreachable!() };
                    std::sync::Arc::make_mut(&mut t.texture.image).name = "other.png".into();
                }),
            ),
            ("uv", Box::new(|s| s.meshes[0].uvs.as_mut().unwrap()[1].x = 0.5)),
            ("no uvs", Box::new(|s| s.meshes[0].uvs = None)),
            ("sphere radius", Box::new(|s| s.spheres[2].radius *= 1.0 + 1e-6)),
            ("plane", Box::new(|s| s.planes[0].dist = -1e-6)),
            ("light", Box::new(|s| s.lights.swap(0, 1))),
            ("material name", Box::new(|s| s.materials[1].name.push('x'))),
            ("sphere name", Box::new(|s| s.names.spheres.push("ball".into()))),
            ("prototype", Box::new(|s| s.prototypes[0].positions[3].z += 1e-6)),
            (
                "instance",
                Box::new(|s| {
                    s.instances[0].transform =
                        Transform::new(glam::DVec3::X * 1e-6, glam::DVec3::ZERO, glam::DVec3::ONE)
                }),
            ),
            ("instance material", Box::new(|s| s.instances[0].material = Some(1))),
            // The same bytes moved from one array to the next must not collide.
            (
                "split",
                Box::new(|s| {
                    let last = s.meshes[0].indices.pop().unwrap();
                    s.prototypes[0].indices.insert(0, last);
                }),
            ),
        ];
        // An image changed in place after it was hashed (its only owner): hashed anew.
        let mut c = scene();
        let before = scene_hash(&c);
        texel(&mut c, 5);
        assert_ne!(scene_hash(&c), before, "a texture changed after hashing");

        let mut seen = vec![scene_hash(&a)];
        for (what, change) in changes {
            let mut b = a.clone();
            change(&mut b);
            let h = scene_hash(&b);
            assert!(!seen.contains(&h), "{what}: the fingerprint did not change");
            seen.push(h);
        }
    }
}
