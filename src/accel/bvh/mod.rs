//! The native backend: a bounding volume hierarchy over the scene's triangles and spheres, in
//! safe Rust, tracing the same scenes as Embree so that each checks the other.
//!
//! - Build ([`build`]): binned SAH over primitive boxes, subtrees in parallel with rayon;
//!   deterministic, so the tree does not depend on the thread count.
//! - Layout ([`node`]): the binary tree collapsed into 8-wide nodes (eight child boxes in
//!   structure-of-arrays form, 256 bytes), in one flat array; triangles copied into leaf
//!   blocks of four ([`Triangle4`], with their ids) in tree order, so a leaf's triangles are
//!   contiguous. Both arrays, and the build's primitive references, on 2-MB pages where
//!   Linux grants them (`simd::huge_page_vec`), as Embree's BVH is.
//! - Traversal: a stack of node references, nearest child first, eight slab tests per node
//!   with a precomputed inverse direction and the near slab chosen by the direction's signs:
//!   one 8-wide AVX2 pass where the CPU has AVX2 (`simd`, which also prefetches the
//!   children a ray will visit), else two 4-wide passes with glam's `Vec4` ([`Kernel`]); leaves run the watertight triangle test four at a time
//!   ([`triangle::intersect4`]) and the lecture's sphere quadratic ([`sphere::intersect`], the
//!   function Embree's callbacks call too). The closest triangle hit's `t` is recomputed in
//!   f64 where the watertight test's own `t` may have lost digits ([`triangle::reported_t`]).
//!
//! Meshes with a material whose alpha or back faces decide its hits ([`crate::scene::alpha`])
//! make the tree trace with [`Filtered`]: the portable kernel, each leaf's triangles tested in
//! turn nearest first and a hit the [`AlphaTest`] refuses taken out of its block's copy
//! before the block is tested again; scenes without them trace as before.
//!
//! Planes are unbounded and stay outside the tree: like [`crate::accel::embree::EmbreeAccel`], every
//! query tests them first with [`plane::closest`] and shortens the ray to the nearest one. Hits
//! carry the same ids as Embree's ([`Scene::spheres_geom_id`] etc.), so the two compare one to
//! one.

pub mod build;
pub mod instance;
pub mod node;
mod simd;

use glam::Vec4;
use rayon::prelude::*;
use std::sync::Arc;

use crate::accel::{Accel, Hit, TraceError};
use crate::geometry::triangle::{self, RayFrame, RayFrame4, Triangle4};
use crate::geometry::{Plane, Sphere, plane, sphere};
use crate::math::{Aabb, Ray, Vec3};
use crate::scene::Scene;
use crate::scene::alpha::AlphaTest;
pub use build::Options as BuildOptions;
use build::PrimRef;
use node::{ChildRef, LeafSink, Node, WIDTH};

/// Input the native backend refuses, named as Embree's checks name it.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum Error {
    #[error("{object}: {problem}")]
    InvalidInput { object: String, problem: String },
}

use simd::{ArrayStack, STACK, StackItems};

/// The traversal stack: a fixed array for the usual trees ([`ArrayStack`], nothing to set up
/// per ray), a vector for deeper ones.
trait Stack<T: Copy> {
    fn push(&mut self, x: T);
    fn pop(&mut self) -> Option<T>;
}

impl<T: Copy> Stack<T> for Vec<T> {
    #[inline(always)]
    fn push(&mut self, x: T) {
        Vec::push(self, x)
    }
    #[inline(always)]
    fn pop(&mut self) -> Option<T> {
        Vec::pop(self)
    }
}

/// `1 + 2γ₃` (pbrt's γ_n = nε/(1 − nε), ε = 2⁻²⁴): scaling a slab test's exit distance by it
/// makes the test conservative against the rounding of `(bound − org)·inv` (Ize, "Robust BVH
/// Ray Traversal", JCGT 2013), so a ray through a box's face or corner is never culled.
const EXIT_SCALE: f32 = 1.0 + 2.0 * (3.0 * f32::EPSILON / 2.0) / (1.0 - 3.0 * f32::EPSILON / 2.0);

/// The native BVH over a scene's meshes and spheres, plus its planes.
pub struct Bvh {
    nodes: Vec<Node>,
    root: ChildRef,
    bounds: Aabb,
    /// Triangles in tree order, four per block.
    blocks: Vec<Block>,
    /// Spheres in tree order, with their index in the scene.
    spheres: Vec<Sphere>,
    sphere_ids: Vec<u32>,
    planes: Vec<Plane>,
    spheres_geom_id: u32,
    planes_geom_id: u32,
    /// Whether the tree is shallow enough for the fixed traversal stack.
    shallow: bool,
    /// The scene's instances: a second level of trees ([`instance`]), if it has any.
    instances: Option<Box<instance::Instances>>,
    /// The traversal kernel: AVX2 where the CPU has it.
    kernel: Traversal,
    /// The alpha and back-face test of the meshes that have one, if any does.
    alpha: Option<Arc<AlphaTest>>,
}

/// The kernel a [`Bvh`] traces with; the AVX2 one holds the proof that the CPU has AVX2.
#[derive(Clone, Copy, Debug)]
enum Traversal {
    Portable,
    #[cfg(target_arch = "x86_64")]
    Avx2(simd::Avx2),
}

impl Traversal {
    fn of(kernel: Kernel) -> Option<Traversal> {
        match kernel {
            Kernel::Portable => Some(Traversal::Portable),
            #[cfg(target_arch = "x86_64")]
            Kernel::Avx2 => simd::Avx2::detect().map(Traversal::Avx2),
        }
    }
}

/// The traversal kernels. Both run the same operations on the same values in the same order
/// (only the SIMD width of the slab test differs), so they find bit-identical hits.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kernel {
    /// glam's 4-wide vectors: two passes per 8-wide node, on any CPU.
    Portable,
    /// One 8-wide AVX2 pass per node, the whole traversal compiled for AVX2 (`simd`).
    #[cfg(target_arch = "x86_64")]
    Avx2,
}

impl Kernel {
    /// The fastest kernel this CPU runs.
    pub fn best() -> Kernel {
        #[cfg(target_arch = "x86_64")]
        if simd::Avx2::detect().is_some() {
            return Kernel::Avx2;
        }
        Kernel::Portable
    }

    /// Whether this CPU runs the kernel.
    pub fn is_supported(self) -> bool {
        Traversal::of(self).is_some()
    }

    /// `portable` or `avx2`, for reports.
    pub fn name(self) -> &'static str {
        match self {
            Kernel::Portable => "portable",
            #[cfg(target_arch = "x86_64")]
            Kernel::Avx2 => "avx2",
        }
    }
}

/// Four triangles of a leaf and their ids (176 bytes): the ids follow the corners, so
/// reporting a hit costs no further memory access. Packed at 16-byte alignment, a leaf's
/// blocks occupy fewer cache lines than at 64 (measured 3-5 % faster on random rays).
#[derive(Clone, Copy, Debug)]
#[repr(C, align(16))]
struct Block {
    triangles: Triangle4,
    geom_ids: [u32; 4],
    prim_ids: [u32; 4],
}

impl Block {
    const EMPTY: Block = Block { triangles: Triangle4::EMPTY, geom_ids: [u32::MAX; 4], prim_ids: [u32::MAX; 4] };
}

/// Sizes of a built [`Bvh`], for reports.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Stats {
    pub nodes: usize,
    pub leaves: usize,
    pub triangle_blocks: usize,
    pub triangles: usize,
    pub spheres: usize,
    pub depth: usize,
    pub bytes: usize,
    /// The surface-area cost of the tree in Embree's units (its `verbose=2` statistics):
    /// each inner node costs its area relative to the root's, each leaf that area times its
    /// blocks (or spheres). The expected node visits and block tests of a random ray.
    pub sah_nodes: f64,
    pub sah_leaves: f64,
}

/// Global triangle indices, which number the scene's triangles mesh after mesh.
struct TriangleIds {
    /// The global index of each mesh's first triangle.
    starts: Vec<usize>,
    /// The number of triangles.
    count: usize,
}

impl TriangleIds {
    fn new(scene: &Scene) -> Self {
        let mut count = 0;
        let starts = scene
            .meshes
            .iter()
            .map(|m| {
                count += m.indices.len();
                count - m.indices.len()
            })
            .collect();
        TriangleIds { starts, count }
    }

    /// `(mesh, triangle)` of global triangle index `i`: the last mesh starting at or before
    /// `i` (empty meshes start where the next one does).
    #[inline]
    fn locate(&self, i: usize) -> (u32, u32) {
        let m = self.starts.partition_point(|&s| s <= i) - 1;
        (m as u32, (i - self.starts[m]) as u32)
    }
}

/// The leaf sink of the collapse: copies each leaf's spheres into the sphere array and notes
/// the ranges of refs its triangle blocks take, in tree order; [`Leaves::blocks`] then fills
/// the blocks in parallel (gathering the triangles' corners is most of the collapse's time).
struct Leaves<'a> {
    refs: &'a [PrimRef],
    scene: &'a Scene,
    tri_ids: &'a TriangleIds,
    /// Each block's first ref and number of refs (1 to 4).
    block_refs: Vec<(u32, u32)>,
    spheres: Vec<Sphere>,
    sphere_ids: Vec<u32>,
}

impl Leaves<'_> {
    /// The triangle blocks, in the order the collapse emitted them.
    fn blocks(&self) -> Vec<Block> {
        simd::huge_page_vec(self.block_refs.len(), |blocks| {
            blocks.par_extend(self.block_refs.par_iter().map(|&(start, count)| {
                let mut block = Block::EMPTY;
                for (lane, r) in self.refs[start as usize..(start + count) as usize].iter().enumerate() {
                    let (mesh, tri) = self.tri_ids.locate(r.id() as usize);
                    block.triangles.set(lane, self.scene.meshes[mesh as usize].triangle(tri as usize));
                    (block.geom_ids[lane], block.prim_ids[lane]) = (mesh, tri);
                }
                block
            }))
        })
    }
}

impl LeafSink for Leaves<'_> {
    fn leaf(&mut self, start: usize, count: usize) -> ChildRef {
        let refs = &self.refs[start..start + count];
        if refs[0].is_sphere() {
            let first = self.spheres.len();
            for r in refs {
                let i = r.id() as usize - self.tri_ids.count;
                self.spheres.push(self.scene.spheres[i]);
                self.sphere_ids.push(i as u32);
            }
            ChildRef::leaf(first, count, true)
        } else {
            let first = self.block_refs.len();
            let end = start + count;
            self.block_refs.extend(
                (start..end).step_by(triangle::LANES).map(|b| (b as u32, (end - b).min(triangle::LANES) as u32)),
            );
            ChildRef::leaf(first, count.div_ceil(triangle::LANES), false)
        }
    }
}

/// A sphere's box, padded by a few ulps (as for Embree) so that rounding in the slab test can
/// never cull a ray the quadratic would hit.
fn sphere_bounds(s: &Sphere) -> Aabb {
    let pad = 4.0 * f32::EPSILON * (s.center.abs().max_element() + s.radius);
    let b = s.bounds();
    Aabb::new(b.min - Vec3::splat(pad), b.max + Vec3::splat(pad))
}

impl Bvh {
    /// Builds the BVH over `scene` on the current rayon pool; every object is validated first,
    /// as [`crate::accel::embree::EmbreeAccel::build`] does, and errors name it.
    pub fn build(scene: &Scene) -> Result<Bvh, Error> {
        Bvh::build_with(scene, &BuildOptions::default())
    }

    /// [`Bvh::build`] with tuned build options (for experiments; the default is what strahl
    /// uses).
    pub fn build_with(scene: &Scene, options: &BuildOptions) -> Result<Bvh, Error> {
        let invalid = |object: String, problem: String| Error::InvalidInput { object, problem };
        if let Some((i, p)) = scene.planes.iter().enumerate().find_map(|(i, p)| p.problem().map(|e| (i, e))) {
            return Err(invalid(format!("plane {i}"), p));
        }
        if let Some((i, p)) = scene.spheres.iter().enumerate().find_map(|(i, s)| s.problem().map(|e| (i, e))) {
            return Err(invalid(format!("sphere {i} of 'spheres'"), p));
        }
        if let Some((m, p)) = scene.meshes.iter().find_map(|m| m.problem().map(|e| (m, e))) {
            return Err(invalid(format!("mesh '{}'", m.name), p));
        }
        let n_tris = scene.triangle_count();
        let n = n_tris + scene.spheres.len();
        if n > u32::MAX as usize / 2 || n > node::MAX_LEAF_INDEX {
            return Err(invalid("scene".into(), format!("{n} primitives are more than the native BVH can index")));
        }
        let tri_ids = TriangleIds::new(scene);
        // On huge pages too: the build reads and partitions them all, over and over.
        let mut refs = simd::huge_page_vec(n, |refs| {
            for (m, mesh) in scene.meshes.iter().enumerate() {
                let start = tri_ids.starts[m];
                refs.par_extend(
                    mesh.indices
                        .par_iter()
                        .enumerate()
                        .map(|(t, _)| PrimRef::new(triangle::bounds(mesh.triangle(t)), (start + t) as u32, false)),
                );
            }
            refs.extend(
                scene
                    .spheres
                    .iter()
                    .enumerate()
                    .map(|(i, s)| PrimRef::new(sphere_bounds(s), (n_tris + i) as u32, true)),
            );
        });
        let tree = build::build(&mut refs, options);
        let mut leaves = Leaves {
            refs: &refs,
            scene,
            tri_ids: &tri_ids,
            block_refs: Vec::with_capacity(n_tris / 2),
            spheres: Vec::with_capacity(scene.spheres.len()),
            sphere_ids: Vec::with_capacity(scene.spheres.len()),
        };
        let (nodes, root, depth, bounds) = match &tree {
            Some(t) => {
                let (collapsed, root, depth) = node::collapse(t, &mut leaves);
                // The collapse grows its vector, so it is copied once onto huge pages (7 MB
                // for the full dragon).
                let nodes = simd::huge_page_vec(collapsed.len(), |nodes| nodes.extend_from_slice(&collapsed));
                (nodes, root, depth, t.bounds())
            }
            None => (Vec::new(), ChildRef::EMPTY, 0, Aabb::EMPTY),
        };
        let blocks = leaves.blocks();
        let alpha = AlphaTest::of_scene(scene).map(Arc::new);
        if nodes.len() > node::MAX_NODE_INDEX {
            return Err(invalid(
                "scene".into(),
                format!("{} nodes are more than the native BVH can index", nodes.len()),
            ));
        }
        Ok(Bvh {
            nodes,
            root,
            bounds,
            blocks,
            spheres: leaves.spheres,
            sphere_ids: leaves.sphere_ids,
            planes: scene.planes.clone(),
            spheres_geom_id: scene.spheres_geom_id(),
            planes_geom_id: scene.planes_geom_id(),
            shallow: (WIDTH - 1) * depth <= STACK,
            instances: instance::Instances::build(scene, alpha.clone())?.map(Box::new),
            kernel: Traversal::of(Kernel::best()).unwrap_or(Traversal::Portable),
            alpha: alpha.filter(|a| a.covers_any_mesh()),
        })
    }

    /// The traversal kernel in use.
    pub fn kernel(&self) -> Kernel {
        match self.kernel {
            Traversal::Portable => Kernel::Portable,
            #[cfg(target_arch = "x86_64")]
            Traversal::Avx2(_) => Kernel::Avx2,
        }
    }

    /// The same tree traced with `kernel` instead (for tests and benchmarks); `None` if this
    /// CPU cannot run it.
    pub fn with_kernel(mut self, kernel: Kernel) -> Option<Self> {
        self.kernel = Traversal::of(kernel)?;
        Some(self)
    }

    /// The bounds of everything in the tree (planes excluded).
    pub fn bounds(&self) -> Aabb {
        self.bounds
    }

    /// Node, leaf and primitive counts, depth and memory.
    pub fn stats(&self) -> Stats {
        struct Walk<'a> {
            bvh: &'a Bvh,
            root_area: f64,
            leaves: usize,
            sah_nodes: f64,
            sah_leaves: f64,
        }
        impl Walk<'_> {
            /// Visits `r` with box `b`; returns the number of inner levels below and at `r`.
            fn visit(&mut self, r: ChildRef, b: Aabb) -> usize {
                let rel = b.area() as f64 / self.root_area;
                if r.is_leaf() {
                    self.leaves += 1;
                    self.sah_leaves += rel * r.range().1 as f64;
                    return 0;
                }
                if r == ChildRef::EMPTY {
                    return 0;
                }
                self.sah_nodes += rel;
                let n = &self.bvh.nodes[r.index()];
                let below = (0..WIDTH).map(|i| self.visit(n.children[i], n.child_bounds(i))).max();
                1 + below.unwrap_or(0)
            }
        }
        let mut walk = Walk {
            bvh: self,
            root_area: (self.bounds.area() as f64).max(f64::MIN_POSITIVE),
            leaves: 0,
            sah_nodes: 0.0,
            sah_leaves: 0.0,
        };
        let depth = walk.visit(self.root, self.bounds);
        Stats {
            nodes: self.nodes.len(),
            leaves: walk.leaves,
            triangle_blocks: self.blocks.len(),
            triangles: self.blocks.iter().flat_map(|b| b.geom_ids).filter(|&m| m != u32::MAX).count(),
            spheres: self.spheres.len(),
            depth,
            bytes: self.nodes.len() * size_of::<Node>()
                + self.blocks.len() * size_of::<Block>()
                + self.spheres.len() * (size_of::<Sphere>() + 4),
            sah_nodes: walk.sah_nodes,
            sah_leaves: walk.sah_leaves,
        }
    }

    /// The closest plane hit, as [`crate::accel::embree::EmbreeAccel`] finds it.
    #[inline]
    fn plane_hit(&self, ray: &Ray) -> Option<Hit> {
        plane::closest(&self.planes, ray.org, ray.dir, ray.tnear, ray.tfar).map(|(t, i)| Hit {
            t,
            ng: self.planes[i as usize].normal,
            u: 0.0,
            v: 0.0,
            geom_id: self.planes_geom_id,
            prim_id: i,
        })
    }

    /// The closest hit in the tree within `(ray.tnear, tfar)`, with the kernel chosen at
    /// build time. (`tfar` comes apart from the ray: a shortened copy of the ray, read back
    /// right after it is written, stalled store forwarding for 15 % of a miss's time.)
    #[inline]
    fn intersect_tree(&self, ray: &Ray, tfar: f32) -> Option<Hit> {
        if let Some(alpha) = &self.alpha {
            return self.intersect_filtered(ray, tfar, alpha);
        }
        let found = match self.kernel {
            Traversal::Portable => {
                let r = TraversalRay::new(ray);
                self.intersect_by(ray, tfar, &r, &r)
            }
            #[cfg(target_arch = "x86_64")]
            Traversal::Avx2(avx2) => avx2.intersect(self, ray, tfar),
        };
        found.map(|f| self.hit_of(ray, tfar, f))
    }

    /// [`Bvh::intersect_tree`] with the alpha test ([`Filtered`]). Kept out of line, so the
    /// traversal of scenes without alpha is compiled as it was.
    #[inline(never)]
    fn intersect_filtered(&self, ray: &Ray, tfar: f32, alpha: &AlphaTest) -> Option<Hit> {
        let r = TraversalRay::new(ray);
        let found = self.intersect_by(ray, tfar, &r, &Filtered { boxes: &r, alpha, ray, geom: None });
        found.map(|f| self.hit_of(ray, tfar, f))
    }

    /// [`Bvh::occluded_tree`] with the alpha test, out of line as [`Bvh::intersect_filtered`].
    #[inline(never)]
    fn occluded_filtered(&self, ray: &Ray, alpha: &AlphaTest) -> bool {
        let r = TraversalRay::new(ray);
        self.occluded_by(ray, &r, &Filtered { boxes: &r, alpha, ray, geom: None })
    }

    /// The closest hit of `local` (a ray in this prototype's space) on instance `geom`, whose
    /// hits `alpha` decides from the caller's world-space ray `world`.
    fn intersect_instance(&self, local: &Ray, alpha: &AlphaTest, world: &Ray, geom: u32) -> Option<Hit> {
        if !traceable(local) {
            return None;
        }
        let r = TraversalRay::new(local);
        let found =
            self.intersect_by(local, local.tfar, &r, &Filtered { boxes: &r, alpha, ray: world, geom: Some(geom) });
        found.map(|f| self.hit_of(local, local.tfar, f))
    }

    /// Whether anything lies on `local` in this prototype, as [`Bvh::intersect_instance`].
    fn occluded_instance(&self, local: &Ray, alpha: &AlphaTest, world: &Ray, geom: u32) -> bool {
        if !traceable(local) {
            return false;
        }
        let r = TraversalRay::new(local);
        self.occluded_by(local, &r, &Filtered { boxes: &r, alpha, ray: world, geom: Some(geom) })
    }

    /// Whether anything in the tree lies on the ray within `(tnear, tfar)`.
    #[inline]
    fn occluded_tree(&self, ray: &Ray) -> bool {
        if let Some(alpha) = &self.alpha {
            return self.occluded_filtered(ray, alpha);
        }
        match self.kernel {
            Traversal::Portable => {
                let r = TraversalRay::new(ray);
                self.occluded_by(ray, &r, &r)
            }
            #[cfg(target_arch = "x86_64")]
            Traversal::Avx2(avx2) => avx2.occluded(self, ray),
        }
    }

    /// [`Bvh::intersect_tree`] with the slab test `boxes` (made from `r`): the stack and the
    /// axial variant chosen.
    #[inline(always)]
    fn intersect_by(&self, ray: &Ray, tfar: f32, r: &TraversalRay, boxes: &impl BoxTest) -> Option<Found> {
        let mut items = StackItems::<_, STACK>::new();
        match (self.shallow, r.axial) {
            (true, false) => self.intersect_with::<false>(ray, tfar, boxes, ArrayStack::new(&mut items)),
            (true, true) => self.intersect_with::<true>(ray, tfar, boxes, ArrayStack::new(&mut items)),
            (false, false) => self.intersect_with::<false>(ray, tfar, boxes, Vec::new()),
            (false, true) => self.intersect_with::<true>(ray, tfar, boxes, Vec::new()),
        }
    }

    /// [`Bvh::occluded_tree`] with the slab test `boxes` (made from `r`).
    #[inline(always)]
    fn occluded_by(&self, ray: &Ray, r: &TraversalRay, boxes: &impl BoxTest) -> bool {
        let mut items = StackItems::<_, STACK>::new();
        match (self.shallow, r.axial) {
            (true, false) => self.occluded_with::<false>(ray, boxes, ArrayStack::new(&mut items)),
            (true, true) => self.occluded_with::<true>(ray, boxes, ArrayStack::new(&mut items)),
            (false, false) => self.occluded_with::<false>(ray, boxes, Vec::new()),
            (false, true) => self.occluded_with::<true>(ray, boxes, Vec::new()),
        }
    }

    #[inline(always)]
    fn intersect_with<const AXIAL: bool>(
        &self,
        ray: &Ray,
        tfar: f32,
        r: &impl BoxTest,
        mut stack: impl Stack<(ChildRef, f32)>,
    ) -> Option<Found> {
        let mut best_t = tfar;
        let mut found = None;
        let mut frame = None;
        let mut cur = self.root;
        // The root's test comes before the loop, on its own: there it reads the ray as the
        // kernel just computed it, in registers, not from the stack slots the loop keeps it
        // in (loaded right after their store, each load waits for the store to forward). Half
        // the primary rays of a bench miss the root's children: for them that wait was a
        // tenth of their time (the dragon's: 44.9 -> 51.0 Mrays/CPU-s).
        if !cur.is_leaf() && cur != ChildRef::EMPTY {
            cur = self.visit_closest::<AXIAL>(&self.nodes[cur.index()], r, best_t, &mut stack)?;
        }
        loop {
            if cur.is_leaf() {
                let (first, count) = cur.range();
                if cur.is_spheres() {
                    for i in first..first + count {
                        let s = &self.spheres[i];
                        if let Some(t) = sphere::intersect(ray.org, ray.dir, s.center, s.radius, ray.tnear, best_t) {
                            best_t = t;
                            found = Some(Found::Sphere { index: i, t });
                        }
                    }
                } else {
                    // The triangle test's frame, made when the ray first reaches a leaf.
                    let frame = frame.get_or_insert_with(|| RayFrame4::new(&RayFrame::new(ray.org, ray.dir)));
                    if let Some((b, lane, hit)) =
                        r.intersect_blocks(&self.blocks[first..first + count], frame, ray.tnear, best_t)
                    {
                        best_t = hit.t;
                        found = Some(Found::Triangle { block: first + b, lane, hit });
                    }
                }
            } else if cur != ChildRef::EMPTY {
                if let Some(c) = self.visit_closest::<AXIAL>(&self.nodes[cur.index()], r, best_t, &mut stack) {
                    cur = c;
                    continue;
                }
            }
            // Pop the next subtree the ray may still reach before its closest hit so far.
            loop {
                let Some((c, entry)) = stack.pop() else {
                    return found;
                };
                if entry <= best_t * EXIT_SCALE {
                    cur = c;
                    break;
                }
            }
        }
    }

    /// One inner node of a closest-hit traversal: the slab tests of its children against
    /// `(tnear, best_t)`; returns the nearest child the ray enters, with the others pushed
    /// farthest first, or `None` when it enters none.
    #[inline(always)]
    fn visit_closest<const AXIAL: bool>(
        &self,
        node: &Node,
        r: &impl BoxTest,
        best_t: f32,
        stack: &mut impl Stack<(ChildRef, f32)>,
    ) -> Option<ChildRef> {
        let (entry, mask) = r.hit_boxes::<AXIAL>(node, best_t);
        if mask == 0 {
            return None;
        }
        let first = mask.trailing_zeros() as usize;
        let rest = mask & (mask - 1);
        if rest == 0 {
            // One child: descend.
            return Some(node.children[first]);
        }
        // Several children: fetch them all at once rather than one by one.
        let mut m = mask;
        while m != 0 {
            r.prefetch(self, node.children[m.trailing_zeros() as usize]);
            m &= m - 1;
        }
        if rest & (rest - 1) == 0 {
            // Two children: descend into the nearer, push the farther.
            let second = rest.trailing_zeros() as usize;
            let (c0, c1) = (node.children[first], node.children[second]);
            let (e0, e1) = (entry[first], entry[second]);
            return Some(if e1 < e0 {
                stack.push((c0, e0));
                c1
            } else {
                stack.push((c1, e1));
                c0
            });
        }
        // Three or more: sort by entry distance, push the others farthest first.
        let mut next = [(ChildRef::EMPTY, 0.0f32); WIDTH];
        let mut k = 0;
        let mut m = mask;
        while m != 0 {
            let lane = m.trailing_zeros() as usize;
            m &= m - 1;
            next[k] = (node.children[lane], entry[lane]);
            k += 1;
        }
        for i in 1..k {
            let mut j = i;
            while j > 0 && next[j].1 < next[j - 1].1 {
                next.swap(j, j - 1);
                j -= 1;
            }
        }
        for &c in next[1..k].iter().rev() {
            stack.push(c);
        }
        Some(next[0].0)
    }

    /// One inner node of an any-hit traversal: pushes the children the ray enters within
    /// `(tnear, tfar)`.
    #[inline(always)]
    fn push_entered<const AXIAL: bool>(
        &self,
        node: &Node,
        r: &impl BoxTest,
        tfar: f32,
        stack: &mut impl Stack<ChildRef>,
    ) {
        let (_, mut mask) = r.hit_boxes::<AXIAL>(node, tfar);
        while mask != 0 {
            r.prefetch(self, node.children[mask.trailing_zeros() as usize]);
            stack.push(node.children[mask.trailing_zeros() as usize]);
            mask &= mask - 1;
        }
    }

    #[inline(always)]
    fn occluded_with<const AXIAL: bool>(&self, ray: &Ray, r: &impl BoxTest, mut stack: impl Stack<ChildRef>) -> bool {
        let mut frame = None;
        let mut cur = self.root;
        // The root on its own, as in `intersect_with`.
        if !cur.is_leaf() && cur != ChildRef::EMPTY {
            self.push_entered::<AXIAL>(&self.nodes[cur.index()], r, ray.tfar, &mut stack);
            let Some(c) = stack.pop() else { return false };
            cur = c;
        }
        loop {
            if cur.is_leaf() {
                let (first, count) = cur.range();
                if cur.is_spheres() {
                    for s in &self.spheres[first..first + count] {
                        if sphere::intersect(ray.org, ray.dir, s.center, s.radius, ray.tnear, ray.tfar).is_some() {
                            return true;
                        }
                    }
                } else {
                    let frame = frame.get_or_insert_with(|| RayFrame4::new(&RayFrame::new(ray.org, ray.dir)));
                    if r.occluded_blocks(&self.blocks[first..first + count], frame, ray.tnear, ray.tfar) {
                        return true;
                    }
                }
            } else if cur != ChildRef::EMPTY {
                self.push_entered::<AXIAL>(&self.nodes[cur.index()], r, ray.tfar, &mut stack);
            }
            match stack.pop() {
                Some(c) => cur = c,
                None => return false,
            }
        }
    }

    /// The [`Hit`] of what the traversal found, with Embree's conventions.
    fn hit_of(&self, ray: &Ray, tfar: f32, found: Found) -> Hit {
        match found {
            Found::Triangle { block, lane, hit } => {
                let block = &self.blocks[block];
                let [p0, p1, p2] = block.triangles.get(lane);
                let (geom_id, prim_id) = (block.geom_ids[lane], block.prim_ids[lane]);
                let t = triangle::reported_t(ray.org, ray.dir, [p0, p1, p2], hit.t, ray.tnear, tfar);
                Hit { t, ng: triangle::normal(p0, p1, p2), u: hit.u, v: hit.v, geom_id, prim_id }
            }
            Found::Sphere { index, t } => {
                // Exactly what Embree's sphere callback reports.
                let s = &self.spheres[index];
                let ng = (ray.org - s.center) + t * ray.dir;
                let (u, v) = sphere::uv(ng / s.radius);
                Hit { t, ng, u, v, geom_id: self.spheres_geom_id, prim_id: self.sphere_ids[index] }
            }
        }
    }
}

/// What the closest-hit traversal found. The traversal returns this, not the [`Hit`]: the
/// kernel is a call (the AVX2 one cannot be inlined into its caller), and a [`Hit`] returned
/// through memory is stored field by field and reloaded whole, which can stall store
/// forwarding; [`Bvh::hit_of`] builds the hit in the inlined caller instead. (Measured in
/// docs/performance.md: a gain only while another process loads the second core.)
enum Found {
    Triangle { block: usize, lane: usize, hit: triangle::TriangleHit },
    Sphere { index: usize, t: f32 },
}

/// A ray prepared for the slab tests: the origin
/// and inverse direction broadcast to four lanes, and which slab of each axis the ray enters
/// first.
struct TraversalRay {
    org: [Vec4; 3],
    inv: [Vec4; 3],
    /// `inv·(1 + 2γ₃)`, for the far slabs (see [`EXIT_SCALE`]).
    inv_far: [Vec4; 3],
    /// Per axis, the index into [`Node::bounds`] of the near slab (`min` for a positive
    /// direction, `max` for a negative one) and of the far slab.
    near: [usize; 3],
    far: [usize; 3],
    tnear: Vec4,
    /// Whether some `1/d` is infinite or zero (an axis-parallel ray, or a direction component
    /// beyond what f32 inverts): then a slab test can meet `0·∞` and must ignore the NaN.
    axial: bool,
}

impl TraversalRay {
    #[inline(always)]
    fn new(ray: &Ray) -> Self {
        // 1/±0 = ±∞: the slab of an axis the ray runs parallel to is (−∞, ∞) from inside and
        // empty from outside; on its plane, 0·∞ = NaN, which the axial test ignores.
        // One division, sign and class tests for the three axes at once (the fourth lane, 1/1,
        // is masked out).
        let inv4 = Vec4::ONE / ray.dir.extend(1.0);
        let negative = inv4.is_negative_bitmask();
        let near = std::array::from_fn(|a| a + 3 * (negative >> a & 1) as usize);
        let far = std::array::from_fn(|a| a + 3 - 3 * (negative >> a & 1) as usize);
        let inv = [inv4.x, inv4.y, inv4.z];
        TraversalRay {
            org: [Vec4::splat(ray.org.x), Vec4::splat(ray.org.y), Vec4::splat(ray.org.z)],
            inv: inv.map(Vec4::splat),
            inv_far: inv.map(|i| Vec4::splat(i * EXIT_SCALE)),
            near,
            far,
            tnear: Vec4::splat(ray.tnear),
            // Some 1/d not finite, or zero.
            axial: (!inv4.abs().cmplt(Vec4::INFINITY).bitmask() | inv4.cmpeq(Vec4::ZERO).bitmask()) & 0b111 != 0,
        }
    }
}

/// What a traversal kernel computes with SIMD: the slab test of a node's eight children and
/// the triangle test of a leaf's blocks, as the traversal calls them.
/// The nearest hit over `blocks`, block after block, each block's hit (`test` up to the
/// current `tfar`) shortening the ray: ties go to the first block, then the lowest lane.
#[inline(always)]
fn nearest_in_blocks(
    blocks: &[Block],
    mut tfar: f32,
    mut test: impl FnMut(&Block, f32) -> Option<(usize, triangle::TriangleHit)>,
) -> Option<(usize, usize, triangle::TriangleHit)> {
    let mut best = None;
    for (i, block) in blocks.iter().enumerate() {
        if let Some((lane, hit)) = test(block, tfar) {
            tfar = hit.t;
            best = Some((i, lane, hit));
        }
    }
    best
}

trait BoxTest {
    /// Slab tests of the node's boxes against `(tnear, tfar)`: entry distances, and a bit
    /// mask of the boxes the ray enters. `AXIAL` must be the ray's [`TraversalRay::axial`]:
    /// the general test reduces the slabs in a balanced tree (a shorter dependency chain), the
    /// axial one in a chain that keeps the accumulated value where a slab gives NaN.
    fn hit_boxes<const AXIAL: bool>(&self, node: &Node, tfar: f32) -> ([f32; WIDTH], u32);

    /// Starts loading a child the traversal will visit into the cache (a hint: kernels
    /// without a prefetch instruction do nothing).
    #[inline(always)]
    fn prefetch(&self, _bvh: &Bvh, _child: ChildRef) {}

    /// The nearest triangle hit in a leaf's `blocks` within `(tnear, tfar)`: the block's index
    /// in `blocks`, the lane, the hit. Exactly what [`triangle::intersect4`] finds block after
    /// block, each block's hit shortening the ray (so ties go to the first block, then the
    /// lowest lane); kernels may test several blocks at once if they keep that rule.
    #[inline(always)]
    fn intersect_blocks(
        &self,
        blocks: &[Block],
        frame: &RayFrame4,
        tnear: f32,
        tfar: f32,
    ) -> Option<(usize, usize, triangle::TriangleHit)> {
        nearest_in_blocks(blocks, tfar, |block, tfar| triangle::intersect4(frame, &block.triangles, tnear, tfar))
    }

    /// Whether some triangle of a leaf's `blocks` lies on the ray within `(tnear, tfar)`.
    #[inline(always)]
    fn occluded_blocks(&self, blocks: &[Block], frame: &RayFrame4, tnear: f32, tfar: f32) -> bool {
        blocks.iter().any(|block| triangle::occluded4(frame, &block.triangles, tnear, tfar))
    }
}

impl BoxTest for TraversalRay {
    #[inline(always)]
    fn hit_boxes<const AXIAL: bool>(&self, node: &Node, tfar: f32) -> ([f32; WIDTH], u32) {
        let b = &node.bounds;
        let [ox, oy, oz] = self.org;
        let [ix, iy, iz] = self.inv;
        let [fx, fy, fz] = self.inv_far;
        let tfar = Vec4::splat(tfar * EXIT_SCALE);
        let mut entry = [0.0; WIDTH];
        let mut mask = 0;
        for c in 0..node::CHUNKS {
            let n = [(b[self.near[0]][c] - ox) * ix, (b[self.near[1]][c] - oy) * iy, (b[self.near[2]][c] - oz) * iz];
            let f = [(b[self.far[0]][c] - ox) * fx, (b[self.far[1]][c] - oy) * fy, (b[self.far[2]][c] - oz) * fz];
            let (t0, t1) = if AXIAL {
                (
                    keep_max(keep_max(keep_max(self.tnear, n[0]), n[1]), n[2]),
                    keep_min(keep_min(keep_min(tfar, f[0]), f[1]), f[2]),
                )
            } else {
                (n[0].max(n[1]).max(n[2].max(self.tnear)), f[0].min(f[1]).min(f[2].min(tfar)))
            };
            entry[4 * c..4 * c + 4].copy_from_slice(&t0.to_array());
            mask |= t0.cmple(t1).bitmask() << (4 * c);
        }
        (entry, mask)
    }
}

/// The portable kernel with the alpha test ([`AlphaTest::passes`]) on every triangle hit of a
/// covered mesh: a block's nearest hit that the test refuses is taken out of a copy of the
/// block (its corners set to NaN, which no ray hits) and the block tested again, so the
/// nearest hit the test accepts is found, ties to the lowest lane as before.
struct Filtered<'a> {
    boxes: &'a TraversalRay,
    alpha: &'a AlphaTest,
    /// The ray as the caller gave it (in world space): the test's input.
    ray: &'a Ray,
    /// The geometry id the test sees for every hit (an instance's, when the tree is its
    /// prototype's), else the hit block's own.
    geom: Option<u32>,
}

impl Filtered<'_> {
    /// The nearest hit in `block` within `(tnear, tfar)` that the test accepts.
    #[inline]
    fn nearest_accepted(
        &self,
        block: &Block,
        frame: &RayFrame4,
        tnear: f32,
        tfar: f32,
    ) -> Option<(usize, triangle::TriangleHit)> {
        let mut found = triangle::intersect4(frame, &block.triangles, tnear, tfar)?;
        let mut left = block.triangles;
        loop {
            let (lane, _) = found;
            if self.alpha.passes(self.geom.unwrap_or(block.geom_ids[lane]), block.prim_ids[lane], self.ray) {
                return Some(found);
            }
            left.set(lane, [Vec3::NAN; 3]);
            found = triangle::intersect4(frame, &left, tnear, tfar)?;
        }
    }
}

impl BoxTest for Filtered<'_> {
    #[inline(always)]
    fn hit_boxes<const AXIAL: bool>(&self, node: &Node, tfar: f32) -> ([f32; WIDTH], u32) {
        self.boxes.hit_boxes::<AXIAL>(node, tfar)
    }

    fn intersect_blocks(
        &self,
        blocks: &[Block],
        frame: &RayFrame4,
        tnear: f32,
        tfar: f32,
    ) -> Option<(usize, usize, triangle::TriangleHit)> {
        nearest_in_blocks(blocks, tfar, |block, tfar| self.nearest_accepted(block, frame, tnear, tfar))
    }

    fn occluded_blocks(&self, blocks: &[Block], frame: &RayFrame4, tnear: f32, tfar: f32) -> bool {
        blocks.iter().any(|block| self.nearest_accepted(block, frame, tnear, tfar).is_some())
    }
}

/// `max(acc, x)` per lane, keeping `acc` where `x` is NaN (a ray in a slab's plane, where
/// `(bound − org)·inv` is `0·∞`): such a slab does not restrict the interval.
#[inline(always)]
fn keep_max(acc: Vec4, x: Vec4) -> Vec4 {
    // On x86, glam's `max` is MAXPS, which returns its second operand when either is NaN:
    // one instruction instead of a compare and a blend.
    #[cfg(any(target_arch = "x86", target_arch = "x86_64"))]
    return x.max(acc);
    #[cfg(not(any(target_arch = "x86", target_arch = "x86_64")))]
    return Vec4::select(x.cmpgt(acc), x, acc);
}

/// `min(acc, x)` per lane, keeping `acc` where `x` is NaN.
#[inline(always)]
fn keep_min(acc: Vec4, x: Vec4) -> Vec4 {
    #[cfg(any(target_arch = "x86", target_arch = "x86_64"))]
    return x.min(acc);
    #[cfg(not(any(target_arch = "x86", target_arch = "x86_64")))]
    return Vec4::select(x.cmplt(acc), x, acc);
}

/// Rays that cannot be traced: a non-finite origin or direction (whose slab tests would be
/// NaN throughout). Both backends report no hit for them.
#[inline]
fn traceable(ray: &Ray) -> bool {
    ray.org.is_finite() && ray.dir.is_finite()
}

impl Accel for Bvh {
    fn name(&self) -> &'static str {
        "native"
    }

    /// The float mode of Embree's threads (flush-to-zero, denormals-are-zero; the Embree
    /// wrapper keeps the only code that sets it), so that shading gives the same bits under
    /// both backends.
    fn prepare_thread(&self) {
        crate::accel::embree::enable_flush_to_zero();
    }

    #[inline(always)]
    fn intersect(&self, ray: &Ray) -> Result<Option<Hit>, TraceError> {
        if !traceable(ray) {
            return Ok(None);
        }
        let plane_hit = self.plane_hit(ray);
        let hit = self.intersect_tree(ray, plane_hit.map_or(ray.tfar, |h| h.t)).or(plane_hit);
        let Some(instances) = &self.instances else { return Ok(hit) };
        let clipped = Ray { tfar: hit.map_or(ray.tfar, |h| h.t), ..*ray };
        Ok(instances.intersect(&clipped).or(hit))
    }

    fn occluded(&self, ray: &Ray) -> Result<bool, TraceError> {
        if !traceable(ray) {
            return Ok(false);
        }
        Ok(plane::closest(&self.planes, ray.org, ray.dir, ray.tnear, ray.tfar).is_some()
            || self.occluded_tree(ray)
            || self.instances.as_ref().is_some_and(|i| i.occluded(ray)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Mesh;

    #[test]
    fn the_stack_is_chosen_by_the_depth_the_stats_walk_finds() {
        // Chains of triangles at growing distances along x: the SAH peels them off one at a
        // time, so the depth grows with the length, through the fixed stack's limit.
        let (mut shallow, mut deep) = (0, 0);
        for n in (2..=1000).step_by(40) {
            let mut mesh = Mesh { name: "chain".into(), ..Default::default() };
            for k in 0..n {
                let (x, i) = (1.02f32.powi(k), mesh.positions.len() as u32);
                mesh.positions.extend([Vec3::new(x, -1.0, -1.0), Vec3::new(x, 1.0, -1.0), Vec3::new(x, 0.0, 1.0)]);
                mesh.indices.push([i, i + 1, i + 2]);
            }
            let scene = Scene { meshes: vec![mesh], ..Default::default() };
            let bvh = Bvh::build_with(&scene, &BuildOptions { max_leaf: 1, traversal_cost: 1.0 }).unwrap();
            let depth = bvh.stats().depth;
            assert_eq!(bvh.shallow, (WIDTH - 1) * depth <= STACK, "{n} triangles, depth {depth}");
            *(if bvh.shallow { &mut shallow } else { &mut deep }) += 1;
        }
        assert!(shallow > 0 && deep > 0, "{shallow} shallow, {deep} deep");
    }

    #[test]
    fn the_sah_is_the_expected_visits_and_block_tests_of_a_random_ray() {
        // Five copies of a unit right triangle (two blocks) and, nine further along x, one
        // (one block): the root (area 1 relative to itself) holds the two leaves, each box
        // 1 × 1 against the root's 10 × 1 (all flat in z: areas 2·1 and 2·10), so the leaves
        // cost 0.1 · 2 + 0.1 · 1.
        let mut mesh = Mesh { name: "two".into(), ..Default::default() };
        for x in [0.0, 0.0, 0.0, 0.0, 0.0, 9.0] {
            let i = mesh.positions.len() as u32;
            mesh.positions.extend([Vec3::new(x, 0.0, 0.0), Vec3::new(x + 1.0, 0.0, 0.0), Vec3::new(x, 1.0, 0.0)]);
            mesh.indices.push([i, i + 1, i + 2]);
        }
        let scene = Scene { meshes: vec![mesh], ..Default::default() };
        let stats = Bvh::build_with(&scene, &BuildOptions { max_leaf: 8, traversal_cost: 1.0 }).unwrap().stats();
        assert_eq!((stats.nodes, stats.leaves, stats.triangle_blocks), (1, 2, 3));
        assert!((stats.sah_nodes - 1.0).abs() < 1e-9, "{}", stats.sah_nodes);
        assert!((stats.sah_leaves - 0.3).abs() < 1e-6, "{}", stats.sah_leaves);
    }

    /// A node whose child 0 is the unit cube and child 5 the cube `[2, 3] × [0, 1] × [0, 1]`;
    /// the other lanes are empty.
    fn two_boxes() -> Node {
        let mut bounds = [[Vec4::INFINITY; node::CHUNKS]; 6];
        for slab in &mut bounds[3..] {
            *slab = [Vec4::NEG_INFINITY; node::CHUNKS];
        }
        for (lane, b) in
            [(0, Aabb::new(Vec3::ZERO, Vec3::ONE)), (5, Aabb::new(Vec3::X * 2.0, Vec3::new(3.0, 1.0, 1.0)))]
        {
            for axis in 0..3 {
                bounds[axis][lane / 4][lane % 4] = b.min[axis];
                bounds[axis + 3][lane / 4][lane % 4] = b.max[axis];
            }
        }
        Node { bounds, children: [ChildRef::EMPTY; WIDTH] }
    }

    /// The slab test of `ray` against [`two_boxes`]: the mask, and the entry distances of the
    /// boxes entered.
    fn slabs(ray: Ray) -> (u32, Vec<f32>) {
        let r = TraversalRay::new(&ray);
        let node = two_boxes();
        let (entry, mask) =
            if r.axial { r.hit_boxes::<true>(&node, ray.tfar) } else { r.hit_boxes::<false>(&node, ray.tfar) };
        (mask, (0..WIDTH).filter(|i| mask & (1 << i) != 0).map(|i| entry[i]).collect())
    }

    #[test]
    fn slab_test_against_analytic_entries() {
        // Oblique from (−1, ½, ½): enters the unit cube through x = 0 at t = 1; at x = 2 it is
        // at y = 1.25, above the second cube.
        let ray = Ray::new(Vec3::new(-1.0, 0.5, 0.5), Vec3::new(1.0, 0.25, 0.125));
        assert_eq!(slabs(ray), (0b1, vec![1.0]));
        // Ending before the box, or starting inside it (entry = tnear).
        assert_eq!(slabs(Ray { tfar: 0.99, ..ray }), (0, vec![]));
        assert_eq!(slabs(Ray { tnear: 1.5, ..ray }), (0b1, vec![1.5]));
        // Going back from x = 4, y = 1.6: over the second cube (y = 1.1 at its face x = 2),
        // into the unit cube through its face x = 1 at t = 3 (y = 0.85, z = 0.625).
        let back = Ray::new(Vec3::new(4.0, 1.6, 1.0), Vec3::new(-1.0, -0.25, -0.125));
        assert_eq!(slabs(back), (0b1, vec![3.0]));
        // Through the second cube's top edge (x = 2, y = 1 at t = 2): touching is entering.
        let touch = Ray::new(Vec3::new(4.0, 1.5, 1.0), Vec3::new(-1.0, -0.25, -0.125));
        assert_eq!(slabs(touch), (0b10_0001, vec![3.0, 2.0]));
    }

    #[test]
    fn slab_test_on_parallel_and_grazing_rays() {
        // Parallel to x through both cubes: entries 1 and 3.
        assert_eq!(slabs(Ray::new(Vec3::new(-1.0, 0.5, 0.5), Vec3::X)), (0b10_0001, vec![1.0, 3.0]));
        // Grazing: in the plane of both cubes' top faces (0·∞ in the y slab), and along their
        // common edge y = 1, z = 1: a box touched is entered (the test is conservative).
        assert_eq!(slabs(Ray::new(Vec3::new(-1.0, 1.0, 0.5), Vec3::X)), (0b10_0001, vec![1.0, 3.0]));
        assert_eq!(slabs(Ray::new(Vec3::new(-1.0, 1.0, 1.0), Vec3::X)), (0b10_0001, vec![1.0, 3.0]));
        // Parallel just above the faces, and parallel to a face outside the slab: missed.
        assert_eq!(slabs(Ray::new(Vec3::new(-1.0, 1.0001, 0.5), Vec3::X)), (0, vec![]));
        assert_eq!(slabs(Ray::new(Vec3::new(0.5, 0.5, -1.0), Vec3::Y)), (0, vec![]));
        // Straight down onto the top face: enters at t = 1 (a negative direction's near slab
        // is the max).
        assert_eq!(slabs(Ray::new(Vec3::new(2.5, 2.0, 0.5), -Vec3::Y)), (0b10_0000, vec![1.0]));
    }
}
