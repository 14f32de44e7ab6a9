//! The AVX2 traversal kernel: one 8-wide slab test per node instead of two 4-wide ones, a
//! leaf's triangle blocks tested two at a time (eight triangles per 8-wide pass, the odd block
//! with the 4-wide test), and the whole traversal compiled with AVX2 enabled, chosen at run
//! time where the CPU has it (`is_x86_feature_detected!`); the portable kernel stays for the
//! others.
//!
//! The triangle test is `triangle::intersect4`'s, lane for lane (no fused multiply-add), and
//! the nearest of the eight lanes is chosen with its rule (ties to the lowest lane, so to the
//! first block): the same hit as the two blocks tested in turn.
//!
//! The slab test is the portable one's, lane for lane: `t = (bound − org)·inv` for the near
//! slabs, `(bound − org)·(inv·(1 + 2γ₃))` for the far ones, the same max/min reduction trees
//! (the axial one keeping the accumulated value where a slab gives NaN, as MAXPS/MINPS do),
//! and `entry ≤ exit`. Same values, same order, so the same bits: both kernels visit the same
//! nodes and report the same hits (a test checks it on random and axis-parallel rays).
//!
//! This is the native backend's one module with `unsafe`: the intrinsics need it (on Rust
//! 1.86 they are `unsafe fn`s), and so does entering a function compiled for AVX2. Both are
//! sound only on a CPU with AVX2, which an [`Avx2`] value proves: its only constructor
//! checks. Measured on the full dragon, 1 thread, against the portable kernel: see the commit
//! message and docs/performance.md.
//!
//! The traversal stack of both kernels lives here too ([`ArrayStack`]): an array left
//! uninitialised, read only below the entries pushed (one `unsafe` read, measured: filling
//! it per ray cost a tenth of a primary ray), its count kept apart from it so that the count
//! stays in a register (measured: 1-2.6 % of every ray kind).
//!
//! And the memory the kernels read: [`huge_page_vec`] asks Linux for 2-MB pages under the
//! BVH's nodes and triangle blocks (one `madvise` call, as Embree does for its own BVH), so a
//! random ray's scattered reads stop missing the TLB as well as the cache. Measured on the
//! full dragon (`strahl bench`, 3 alternations): random rays 4.52 → 4.92 Mrays/CPU-s on one
//! thread, native / raw Embree 1.15–1.17 → 1.05–1.06 (docs/performance.md, "Huge pages").
//!
//! And the build's float-to-bin conversions ([`truncate`], [`truncate3`]): one SSE2
//! instruction where Rust's saturating `as` takes five, the three axes in one; the bin
//! positions are clamped before, so the bins are the same. The full dragon's build, 1
//! thread: 321–372 → 293–344 ms (docs/performance.md, "Native BVH build").

#[cfg(target_arch = "x86_64")]
use std::arch::x86_64::*;

use std::mem::MaybeUninit;

use super::Stack;
#[cfg(target_arch = "x86_64")]
use super::node::{ChildRef, Node, WIDTH};
#[cfg(target_arch = "x86_64")]
use super::{Block, BoxTest, Bvh, Found, TraversalRay};
#[cfg(target_arch = "x86_64")]
use crate::geometry::triangle::{self, RayFrame4, Triangle4, TriangleHit};
#[cfg(target_arch = "x86_64")]
use crate::math::Ray;
#[cfg(target_arch = "x86_64")]
use glam::Vec4;

/// Proof that the CPU runs AVX2: made only by [`Avx2::detect`].
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy, Debug)]
pub struct Avx2(());

#[cfg(target_arch = "x86_64")]
impl Avx2 {
    /// `Some` on a CPU with AVX2.
    pub fn detect() -> Option<Avx2> {
        is_x86_feature_detected!("avx2").then_some(Avx2(()))
    }

    /// [`Bvh::intersect_tree`] with the AVX2 kernel.
    #[inline]
    pub fn intersect(self, bvh: &Bvh, ray: &Ray, tfar: f32) -> Option<Found> {
        // SAFETY: `self` exists, so the CPU has AVX2 (see `detect`).
        unsafe { intersect(bvh, ray, tfar) }
    }

    /// [`Bvh::occluded_tree`] with the AVX2 kernel.
    #[inline]
    pub fn occluded(self, bvh: &Bvh, ray: &Ray) -> bool {
        // SAFETY: `self` exists, so the CPU has AVX2 (see `detect`).
        unsafe { occluded(bvh, ray) }
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn intersect(bvh: &Bvh, ray: &Ray, tfar: f32) -> Option<Found> {
    let r = TraversalRay::new(ray);
    bvh.intersect_by(ray, tfar, &r, &Boxes8::new(&r))
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn occluded(bvh: &Bvh, ray: &Ray) -> bool {
    let r = TraversalRay::new(ray);
    bvh.occluded_by(ray, &r, &Boxes8::new(&r))
}

/// A [`TraversalRay`] broadcast to eight lanes. Made and used only inside the
/// `#[target_feature(enable = "avx2")]` functions above.
#[cfg(target_arch = "x86_64")]
struct Boxes8 {
    org: [__m256; 3],
    inv: [__m256; 3],
    inv_far: [__m256; 3],
    near: [usize; 3],
    far: [usize; 3],
    tnear: __m256,
}

#[cfg(target_arch = "x86_64")]
impl Boxes8 {
    #[inline(always)]
    fn new(r: &TraversalRay) -> Self {
        // SAFETY: only called from the AVX2 functions above, on a CPU with AVX2.
        unsafe {
            Boxes8 {
                org: r.org.map(|v| _mm256_set1_ps(v.x)),
                inv: r.inv.map(|v| _mm256_set1_ps(v.x)),
                inv_far: r.inv_far.map(|v| _mm256_set1_ps(v.x)),
                near: r.near,
                far: r.far,
                tnear: _mm256_set1_ps(r.tnear.x),
            }
        }
    }
}

/// Cache lines of a leaf's first blocks that [`Boxes8::prefetch`] asks for.
#[cfg(target_arch = "x86_64")]
const LEAF_LINES: usize = 4;

#[cfg(target_arch = "x86_64")]
impl BoxTest for Boxes8 {
    #[inline(always)]
    fn prefetch(&self, bvh: &Bvh, child: ChildRef) {
        let (p, lines) = if child.is_leaf() {
            if child.is_spheres() {
                return;
            }
            let (first, count) = child.range();
            let bytes = count * size_of::<super::Block>();
            (bvh.blocks.as_ptr().wrapping_add(first).cast::<i8>(), bytes.div_ceil(64).min(LEAF_LINES))
        } else if child != ChildRef::EMPTY {
            (bvh.nodes.as_ptr().wrapping_add(child.index()).cast::<i8>(), size_of::<Node>() / 64)
        } else {
            return;
        };
        for line in 0..lines {
            // SAFETY: a prefetch is a hint that never faults and reads nothing the program
            // sees, whatever the address (computed with `wrapping_add`, so no out-of-bounds
            // pointer arithmetic either); SSE is part of x86-64.
            unsafe { _mm_prefetch::<_MM_HINT_T0>(p.wrapping_add(64 * line)) };
        }
    }

    #[inline(always)]
    fn hit_boxes<const AXIAL: bool>(&self, node: &Node, tfar: f32) -> ([f32; WIDTH], u32) {
        let b = &node.bounds;
        let [ox, oy, oz] = self.org;
        let [ix, iy, iz] = self.inv;
        let [fx, fy, fz] = self.inv_far;
        let mut entry = [0.0f32; WIDTH];
        // SAFETY: a `Boxes8` exists only inside the AVX2 functions above, on a CPU with AVX2.
        // Each `b[slab]` is two `Vec4`s, eight contiguous f32 (`Node` is `repr(C)`, 64-byte
        // aligned, and a slab row is 32 bytes), read unaligned anyway; `entry` has eight f32.
        unsafe {
            let load = |slab: usize| _mm256_loadu_ps(b[slab].as_ptr().cast::<f32>());
            let slab = |bound: __m256, o: __m256, inv: __m256| _mm256_mul_ps(_mm256_sub_ps(bound, o), inv);
            let n0 = slab(load(self.near[0]), ox, ix);
            let n1 = slab(load(self.near[1]), oy, iy);
            let n2 = slab(load(self.near[2]), oz, iz);
            let f0 = slab(load(self.far[0]), ox, fx);
            let f1 = slab(load(self.far[1]), oy, fy);
            let f2 = slab(load(self.far[2]), oz, fz);
            let tfar = _mm256_set1_ps(tfar * super::EXIT_SCALE);
            // MAXPS/MINPS return their second operand when either is NaN: `max(x, acc)` keeps
            // `acc` where the slab `x` is NaN (the portable `keep_max`).
            let (t0, t1) = if AXIAL {
                (
                    _mm256_max_ps(n2, _mm256_max_ps(n1, _mm256_max_ps(n0, self.tnear))),
                    _mm256_min_ps(f2, _mm256_min_ps(f1, _mm256_min_ps(f0, tfar))),
                )
            } else {
                (
                    _mm256_max_ps(_mm256_max_ps(n0, n1), _mm256_max_ps(n2, self.tnear)),
                    _mm256_min_ps(_mm256_min_ps(f0, f1), _mm256_min_ps(f2, tfar)),
                )
            };
            _mm256_storeu_ps(entry.as_mut_ptr(), t0);
            let mask = _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(t0, t1)) as u32;
            (entry, mask)
        }
    }

    #[inline(always)]
    fn intersect_blocks(
        &self,
        blocks: &[Block],
        frame: &RayFrame4,
        tnear: f32,
        tfar: f32,
    ) -> Option<(usize, usize, TriangleHit)> {
        let mut best = None;
        let mut tfar = tfar;
        let mut pairs = blocks.chunks_exact(2);
        for (i, pair) in pairs.by_ref().enumerate() {
            let (t, ok, w1, w2, det) = triangles8(frame, &pair[0].triangles, &pair[1].triangles, tnear, tfar);
            if ok == 0 {
                continue;
            }
            // Ties to the lowest lane (block `2i` first): what `intersect4` on the two blocks
            // in turn finds.
            let lane = triangle::nearest_lane(ok, &t);
            let hit = TriangleHit { t: t[lane], u: w1[lane] / det[lane], v: w2[lane] / det[lane] };
            tfar = hit.t;
            best = Some((2 * i + lane / 4, lane % 4, hit));
        }
        if let [last] = pairs.remainder() {
            if let Some((lane, hit)) = triangle::intersect4(frame, &last.triangles, tnear, tfar) {
                best = Some((blocks.len() - 1, lane, hit));
            }
        }
        best
    }

    #[inline(always)]
    fn occluded_blocks(&self, blocks: &[Block], frame: &RayFrame4, tnear: f32, tfar: f32) -> bool {
        let mut pairs = blocks.chunks_exact(2);
        for pair in pairs.by_ref() {
            if triangles8(frame, &pair[0].triangles, &pair[1].triangles, tnear, tfar).1 != 0 {
                return true;
            }
        }
        pairs.remainder().iter().any(|b| triangle::occluded4(frame, &b.triangles, tnear, tfar))
    }
}

/// Two `Vec4`s as one 8-lane vector, `lo` in lanes 0–3.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn pair(lo: Vec4, hi: Vec4) -> __m256 {
    // SAFETY: called only inside the AVX2 functions above, on a CPU with AVX2.
    unsafe { _mm256_set_m128(hi.into(), lo.into()) }
}

/// One corner of eight triangles (`p` in lanes 0–3, `q` in 4–7) in the ray's sheared frame:
/// `(x', y', depth)` per lane, as `triangle::shear4` computes them.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn shear8(
    [kx, ky, kz]: [usize; 3],
    [ox, oy, oz]: [__m256; 3],
    [sx, sy, sz]: [__m256; 3],
    p: &[Vec4; 3],
    q: &[Vec4; 3],
) -> (__m256, __m256, __m256) {
    // SAFETY: called only inside the AVX2 functions above, on a CPU with AVX2.
    unsafe {
        let dx = _mm256_sub_ps(pair(p[kx], q[kx]), ox);
        let dy = _mm256_sub_ps(pair(p[ky], q[ky]), oy);
        let dz = _mm256_sub_ps(pair(p[kz], q[kz]), oz);
        (_mm256_sub_ps(dx, _mm256_mul_ps(sx, dz)), _mm256_sub_ps(dy, _mm256_mul_ps(sy, dz)), _mm256_mul_ps(sz, dz))
    }
}

/// [`triangle::intersect4`]'s test on two blocks at once, `a` in lanes 0–3 and `b` in lanes
/// 4–7: the same operations in the same order, lane by lane (no fused multiply-add), so the
/// same bits. Returns `t`, the mask of lanes hit inside `(tnear, tfar)`, and the edge
/// functions `w1`, `w2` and `det` that give `u` and `v`.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn triangles8(
    frame: &RayFrame4,
    a: &Triangle4,
    b: &Triangle4,
    tnear: f32,
    tfar: f32,
) -> ([f32; 8], u32, [f32; 8], [f32; 8], [f32; 8]) {
    // SAFETY: called only from `Boxes8`'s methods, which run inside the AVX2 functions above
    // on a CPU with AVX2; the stores write eight f32 into arrays of eight.
    unsafe {
        let org = frame.org.map(|v| pair(v, v));
        let shear = frame.shear.map(|v| pair(v, v));
        let (ax, ay, az) = shear8(frame.axes, org, shear, &a.p[0], &b.p[0]);
        let (bx, by, bz) = shear8(frame.axes, org, shear, &a.p[1], &b.p[1]);
        let (cx, cy, cz) = shear8(frame.axes, org, shear, &a.p[2], &b.p[2]);
        let w0 = _mm256_sub_ps(_mm256_mul_ps(cx, by), _mm256_mul_ps(cy, bx));
        let w1 = _mm256_sub_ps(_mm256_mul_ps(ax, cy), _mm256_mul_ps(ay, cx));
        let w2 = _mm256_sub_ps(_mm256_mul_ps(bx, ay), _mm256_mul_ps(by, ax));
        let zero = _mm256_setzero_ps();
        // glam's cmpge/cmple/cmpgt/cmplt are ordered (false on NaN), its cmpne unordered.
        let ge = _mm256_and_ps(
            _mm256_and_ps(_mm256_cmp_ps::<_CMP_GE_OQ>(w0, zero), _mm256_cmp_ps::<_CMP_GE_OQ>(w1, zero)),
            _mm256_cmp_ps::<_CMP_GE_OQ>(w2, zero),
        );
        let le = _mm256_and_ps(
            _mm256_and_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(w0, zero), _mm256_cmp_ps::<_CMP_LE_OQ>(w1, zero)),
            _mm256_cmp_ps::<_CMP_LE_OQ>(w2, zero),
        );
        let det = _mm256_add_ps(_mm256_add_ps(w0, w1), w2);
        let t = _mm256_div_ps(
            _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(w0, az), _mm256_mul_ps(w1, bz)), _mm256_mul_ps(w2, cz)),
            det,
        );
        let ok = _mm256_and_ps(
            _mm256_and_ps(_mm256_or_ps(ge, le), _mm256_cmp_ps::<_CMP_NEQ_UQ>(det, zero)),
            _mm256_and_ps(
                _mm256_cmp_ps::<_CMP_GT_OQ>(t, _mm256_set1_ps(tnear)),
                _mm256_cmp_ps::<_CMP_LT_OQ>(t, _mm256_set1_ps(tfar)),
            ),
        );
        let mask = _mm256_movemask_ps(ok) as u32;
        let mut out = [[0.0f32; 8]; 4];
        if mask != 0 {
            _mm256_storeu_ps(out[0].as_mut_ptr(), t);
            _mm256_storeu_ps(out[1].as_mut_ptr(), w1);
            _mm256_storeu_ps(out[2].as_mut_ptr(), w2);
            _mm256_storeu_ps(out[3].as_mut_ptr(), det);
        }
        let [t, w1, w2, det] = out;
        (t, mask, w1, w2, det)
    }
}

/// Entries of the fixed traversal stack, enough for trees up to 9 levels deep (each level
/// leaves at most seven children on the stack; the dragon's tree has 8). Deeper trees
/// traverse with a growable stack instead.
pub(super) const STACK: usize = 64;

/// The entries of the fixed traversal stack ([`ArrayStack`]), left uninitialised: filling
/// its 64 entries for every ray (16 32-byte stores before the first node) cost about a tenth
/// of a primary ray on the full dragon (native / raw Embree 1.30 -> 1.18, `strahl bench`, see
/// docs/performance.md).
///
/// Aligned to 64 bytes, which makes the kernels realign their stack frame: their 32-byte
/// spills (the ray broadcast to eight lanes, ten vectors) then never straddle a cache line,
/// whatever the callers' frames. Without it the traversal's speed depended on the stack depth
/// it was called at: the same kernel code measured 13.9 or 12.8 Mrays/CPU-s on primary rays
/// depending on an unrelated change elsewhere in the binary.
#[repr(align(64))]
pub(super) struct StackItems<T, const N: usize>([MaybeUninit<T>; N]);

impl<T: Copy, const N: usize> StackItems<T, N> {
    #[inline(always)]
    pub(super) fn new() -> Self {
        StackItems([const { MaybeUninit::uninit() }; N])
    }
}

/// The fixed traversal stack: the entries (a [`StackItems`] the caller owns) and their count,
/// kept apart. In one struct, the array's index by a run-time count made LLVM keep the whole
/// struct in memory (its scalar replacement gives up on an aggregate indexed at an unknown
/// offset), so every push and pop loaded and stored the count, and each pop waited for the
/// previous store to forward; here the count lives in a register. Measured on the full dragon
/// (`strahl bench`, 4 alternations, medians of the runs' CPU-time ratios, 1 / 2 threads):
/// native / raw Embree primary 1.092 / 1.111 -> 1.075 / 1.082, random 1.066 / 1.023 -> 1.042 /
/// 1.014, secondary 1.011 / 1.006 -> 1.002 / 0.994, shadow 0.968 / 0.969 -> 0.958 / 0.960.
pub(super) struct ArrayStack<'a, T, const N: usize> {
    items: &'a mut StackItems<T, N>,
    /// Entries `0..len` are initialised (written by `push`).
    len: usize,
}

impl<'a, T: Copy, const N: usize> ArrayStack<'a, T, N> {
    #[inline(always)]
    pub(super) fn new(items: &'a mut StackItems<T, N>) -> Self {
        ArrayStack { items, len: 0 }
    }
}

impl<T: Copy, const N: usize> Stack<T> for ArrayStack<'_, T, N> {
    #[inline(always)]
    fn push(&mut self, x: T) {
        // Bounds-checked: a push beyond N panics (the tree's depth rules it out).
        self.items.0[self.len] = MaybeUninit::new(x);
        self.len += 1;
    }

    #[inline(always)]
    fn pop(&mut self) -> Option<T> {
        self.len = self.len.checked_sub(1)?;
        // SAFETY: `len` only grows by `push`, which writes entry `len` first, so every entry
        // below `len`, this one included, is initialised.
        Some(unsafe { self.items.0[self.len].assume_init() })
    }
}

/// A vector of at most `capacity` elements, filled by `fill`, whose memory Linux is asked to
/// back with transparent huge pages (2 MB instead of 4 KB), as Embree does for its BVH.
///
/// A random ray touches a few dozen nodes and blocks scattered over tens of megabytes; with
/// 4-KB pages nearly each of those reads also misses the TLB (the full dragon's 47 MB span
/// 11,500 pages, the second-level TLB holds about 1,500), with 2-MB pages the whole BVH fits
/// in it. `MADV_HUGEPAGE` before the first write makes the page faults to come take huge
/// pages; `MADV_COLLAPSE` after `fill` moves onto huge pages what was already mapped with
/// small ones before (malloc reuses freed memory below 32 MB: the nodes of the full dragon
/// came back on 4-KB pages without it). Both are hints: on other systems, or where the kernel
/// has transparent huge pages off, the vector is an ordinary one.
pub(super) fn huge_page_vec<T>(capacity: usize, fill: impl FnOnce(&mut Vec<T>)) -> Vec<T> {
    let mut v: Vec<T> = Vec::with_capacity(capacity);
    advise(&v, Advice::BeforeWrites);
    let at = v.as_ptr();
    fill(&mut v);
    debug_assert!(v.as_ptr() == at, "fill reallocated: the advice is lost");
    advise(&v, Advice::AfterWrites);
    v
}

#[derive(Clone, Copy)]
enum Advice {
    BeforeWrites,
    AfterWrites,
}

#[cfg(all(target_os = "linux", target_env = "gnu"))]
fn advise<T>(v: &Vec<T>, advice: Advice) {
    const PAGE: usize = 4096;
    const HUGE_PAGE: usize = 2 << 20;
    let start = v.as_ptr().cast::<u8>();
    let bytes = v.capacity() * size_of::<T>();
    // The whole pages inside the allocation: madvise takes page-aligned ranges.
    let skip = start.align_offset(PAGE);
    let len = bytes.saturating_sub(skip) / PAGE * PAGE;
    // Below two huge pages no aligned huge page need fit, and every advised range is a
    // mapping of its own: advising each small prototype of an instanced scene could exhaust
    // the process's mappings (vm.max_map_count).
    if len < 2 * HUGE_PAGE {
        return;
    }
    let advice = match advice {
        Advice::BeforeWrites => libc::MADV_HUGEPAGE,
        Advice::AfterWrites => libc::MADV_COLLAPSE,
    };
    // SAFETY: the range lies inside the vector's allocation (whole pages from its first
    // page boundary on), which the caller owns and nothing else is reading or writing
    // while it advises; MADV_HUGEPAGE only changes how the kernel backs the range's
    // future page faults, MADV_COLLAPSE copies what is mapped onto huge pages: neither
    // changes the contents or validity of the memory. A failure (an older kernel, no
    // transparent huge pages, no free huge page) leaves ordinary pages, so the result is
    // ignored.
    unsafe { libc::madvise(start.add(skip).cast_mut().cast(), len, advice) };
}

#[cfg(not(all(target_os = "linux", target_env = "gnu")))]
fn advise<T>(_: &Vec<T>, _: Advice) {}

/// `x as i32` for `x` in `i32`'s range (the build's bin positions, clamped to the bins
/// first) in one conversion instruction: Rust's `as` saturates, which costs two compares and
/// two conditional moves more per conversion, in the build's hottest loop. Outside that
/// range (and for NaN) the result on x86-64 is `i32::MIN`, not `as`'s.
#[inline(always)]
pub(super) fn truncate(x: f32) -> i32 {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: SSE and SSE2 are part of x86-64, so every x86-64 CPU runs these; they only
    // compute on their arguments.
    unsafe {
        _mm_cvttss_si32(_mm_set_ss(x))
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        x as i32
    }
}

/// [`truncate`] of the three lanes of `v` in one conversion instruction.
#[inline(always)]
pub(super) fn truncate3(v: glam::Vec3A) -> [i32; 3] {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: as in `truncate` (SSE2 only).
    unsafe {
        let i = _mm_cvttps_epi32(v.into());
        [
            _mm_cvtsi128_si32(i),
            _mm_cvtsi128_si32(_mm_shuffle_epi32::<0x55>(i)),
            _mm_cvtsi128_si32(_mm_shuffle_epi32::<0xaa>(i)),
        ]
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        [v.x as i32, v.y as i32, v.z as i32]
    }
}

#[cfg(test)]
mod stack_tests {
    use super::*;
    use crate::accel::bvh::node::ChildRef;

    #[test]
    fn pops_what_was_pushed_last_first() {
        let mut items = StackItems::<(ChildRef, f32), 4>::new();
        let mut s = ArrayStack::new(&mut items);
        assert_eq!(s.pop().map(|(c, _)| c), None);
        s.push((ChildRef(1), 0.5));
        s.push((ChildRef(2), 0.25));
        assert_eq!(s.pop(), Some((ChildRef(2), 0.25)));
        s.push((ChildRef(3), 1.0));
        assert_eq!(s.pop(), Some((ChildRef(3), 1.0)));
        assert_eq!(s.pop(), Some((ChildRef(1), 0.5)));
        assert_eq!(s.pop(), None);
    }

    #[test]
    #[should_panic]
    fn a_push_beyond_the_capacity_panics() {
        let mut items = StackItems::<ChildRef, 1>::new();
        let mut s = ArrayStack::new(&mut items);
        s.push(ChildRef(1));
        s.push(ChildRef(2));
    }
}

#[cfg(all(test, target_os = "linux", target_env = "gnu"))]
mod huge_page_tests {
    use super::huge_page_vec;

    /// The `THPeligible` line of the mapping that holds `addr`, from /proc/self/smaps: whether
    /// the kernel may back it with huge pages.
    fn thp_eligible(addr: usize) -> Option<bool> {
        let smaps = std::fs::read_to_string("/proc/self/smaps").ok()?;
        let mut inside = false;
        for line in smaps.lines() {
            let range = line.split_once(' ').and_then(|(r, _)| r.split_once('-'));
            if let Some((Ok(a), Ok(b))) =
                range.map(|(a, b)| (usize::from_str_radix(a, 16), usize::from_str_radix(b, 16)))
            {
                inside = (a..b).contains(&addr);
            } else if let Some(v) = line.strip_prefix("THPeligible:").filter(|_| inside) {
                return Some(v.trim() == "1");
            }
        }
        None
    }

    #[test]
    fn the_vector_is_advised_onto_huge_pages_and_a_plain_one_is_not() {
        let mode = std::fs::read_to_string("/sys/kernel/mm/transparent_hugepage/enabled").unwrap_or_default();
        // Larger than glibc's largest mmap threshold (32 MB), so each is a mapping of its own.
        let bytes = 64 << 20;
        let plain: Vec<u8> = Vec::with_capacity(bytes);
        let advised: Vec<u8> = huge_page_vec(bytes, |_| ());
        assert_eq!((advised.len(), advised.capacity()), (0, bytes));
        let middle = |v: &Vec<u8>| v.as_ptr() as usize + bytes / 2;
        let (plain, advised) = (thp_eligible(middle(&plain)), thp_eligible(middle(&advised)));
        let on = mode.contains("[madvise]") || mode.contains("[always]");
        if !on || advised.is_none() {
            eprintln!("skipped: transparent huge pages are off or unknown here ('{}')", mode.trim());
            return;
        }
        assert_eq!(advised, Some(true), "THP mode {}", mode.trim());
        if mode.contains("[madvise]") {
            assert_eq!(plain, Some(false), "without the advice");
        }
    }
}
