//! The binary BVH build: binned surface-area heuristic over primitive bounding boxes, in
//! parallel with rayon, deterministic whatever the thread count.
//!
//! Every node bins its primitives' centroids into slabs per axis ([`BINS`], fewer for small
//! nodes: `node_bins`) and picks the plane between two slabs that minimises the SAH cost
//! `A_L·N_L + A_R·N_R` (with `N` counted in blocks of four, the width of the leaf test), or
//! makes a leaf when that is cheaper. Bin counts and box unions are exact and
//! order-independent (integer sums, min/max), the partition is sequential, and subtrees are
//! built with `rayon::join`: the tree is the same for one thread or many.

use rayon::prelude::*;

use glam::{Vec3A, Vec4};

use super::simd;
use crate::math::Aabb;

/// Centroid bins per axis (of nodes of more than 64 primitives).
pub const BINS: usize = 32;
/// The most triangles a leaf may ever hold (the leaf encoding's limit: eight blocks of four).
pub const MAX_LEAF: usize = 32;
/// The most spheres a leaf may hold (the same encoding counts spheres one by one).
pub const MAX_SPHERE_LEAF: usize = 8;
/// Below this depth the SAH decides; deeper nodes split at the median, which bounds the
/// depth by `MAX_SAH_DEPTH + log2(n)` even for pathological input (and so the traversal
/// stack).
pub const MAX_SAH_DEPTH: usize = 40;

/// Tuning of the build.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Options {
    /// The most primitives a leaf holds (1 to [`MAX_LEAF`]).
    pub max_leaf: usize,
    /// SAH cost of visiting a node, relative to one 4-wide primitive test.
    pub traversal_cost: f32,
}

impl Default for Options {
    fn default() -> Self {
        // Measured on the Stanford bunny and dragon (1M primary and random rays): with 4-wide
        // nodes, leaves of up to four blocks and a node costing two block tests beat one-block
        // leaves by 5-10 % on primary and 10-25 % on random rays. With 8-wide nodes leaf sizes
        // 4 to 24 and node costs 1 to 3 all measure within the noise (±5 %); this one also
        // keeps the tree small (the dragon: 27k nodes, 47 MB).
        Options { max_leaf: 16, traversal_cost: 2.0 }
    }
}
/// Nodes with more primitives than this bin and build their children in parallel.
const PARALLEL: usize = 4096;
/// Chunk of primitives per rayon task when binning.
const CHUNK: usize = 16 * 1024;

/// A primitive as the build sees it (32 bytes, two aligned SIMD loads): its box's corners in
/// `lo.xyz` and `hi.xyz`, its index in the caller's list in `lo.w` and whether it is a sphere
/// (leaves hold one kind only) in `hi.w`, 1 or 0. The index is kept as the bits of a normal
/// float (`ID_TAG | id`), so that arithmetic on the whole vector never meets a denormal
/// (which costs a microcode assist per operation on many CPUs).
#[derive(Clone, Copy, Debug)]
pub struct PrimRef {
    lo: Vec4,
    hi: Vec4,
}

/// Exponent bits that make an index below [`MAX_ID`] a normal float (exponent 2¹ to 2¹⁶).
const ID_TAG: u32 = 0x4000_0000;
/// The largest primitive index a [`PrimRef`] holds.
pub const MAX_ID: usize = (1 << 27) - 1;

impl PrimRef {
    pub fn new(bounds: Aabb, id: u32, is_sphere: bool) -> Self {
        debug_assert!(id as usize <= MAX_ID);
        PrimRef {
            lo: bounds.min.extend(f32::from_bits(ID_TAG | id)),
            hi: bounds.max.extend(if is_sphere { 1.0 } else { 0.0 }),
        }
    }

    /// The index in the caller's list.
    #[inline]
    pub fn id(&self) -> u32 {
        self.lo.w.to_bits() & MAX_ID as u32
    }

    #[inline]
    pub fn is_sphere(&self) -> bool {
        self.hi.w != 0.0
    }

    #[inline]
    fn min(&self) -> Vec3A {
        Vec3A::from_vec4(self.lo)
    }

    #[inline]
    fn max(&self) -> Vec3A {
        Vec3A::from_vec4(self.hi)
    }

    /// The centre of the box (computed where needed: a smaller ref streams faster).
    #[inline]
    fn centroid(&self) -> Vec3A {
        Vec3A::from_vec4(0.5 * (self.lo + self.hi))
    }
}

/// A node of the binary tree: a leaf holds `refs[start .. start + count]` (after the build
/// has reordered `refs`), all of one kind.
#[derive(Debug)]
pub enum Node2 {
    Leaf { bounds: Aabb, start: u32, count: u32 },
    Inner { bounds: Aabb, children: Box<[Node2; 2]> },
}

impl Node2 {
    pub fn bounds(&self) -> Aabb {
        match self {
            Node2::Leaf { bounds, .. } | Node2::Inner { bounds, .. } => *bounds,
        }
    }
}

/// Builds the binary tree over `refs`, reordering them so that every leaf is a contiguous
/// range. Runs on the current rayon pool. `None` for no primitives.
pub fn build(refs: &mut [PrimRef], options: &Options) -> Option<Node2> {
    if refs.is_empty() {
        return None;
    }
    let options = Options { max_leaf: options.max_leaf.clamp(1, MAX_LEAF), ..*options };
    Some(build_node(refs, 0, 0, &options, None))
}

/// Rounds a primitive count up to whole 4-wide blocks.
#[inline]
fn blocks(n: usize) -> f32 {
    n.div_ceil(4) as f32
}

/// A bin's box in glam's 16-byte `Vec3A` (one SIMD min and one max per union, where `Vec3`
/// takes three scalar ones each; binning is the build's hottest loop), and its count.
#[derive(Clone, Copy)]
struct Bin {
    min: Vec3A,
    max: Vec3A,
    count: u32,
}

const EMPTY_BIN: Bin = Bin { min: Vec3A::splat(f32::INFINITY), max: Vec3A::splat(f32::NEG_INFINITY), count: 0 };

/// Node bounds, centroid bounds and the number of spheres of a range of primitives, the
/// boxes as `Vec3A` corners (one SIMD min or max per union).
#[derive(Clone, Copy)]
struct Summary {
    min: Vec3A,
    max: Vec3A,
    cmin: Vec3A,
    cmax: Vec3A,
    spheres: usize,
}

impl Summary {
    const EMPTY: Summary =
        Summary { min: EMPTY_BIN.min, max: EMPTY_BIN.max, cmin: EMPTY_BIN.min, cmax: EMPTY_BIN.max, spheres: 0 };

    fn of(refs: &[PrimRef]) -> Summary {
        let mut s = Summary::EMPTY;
        for r in refs {
            s.add(r);
        }
        s
    }

    #[inline]
    fn add(&mut self, r: &PrimRef) {
        let c = r.centroid();
        self.min = self.min.min(r.min());
        self.max = self.max.max(r.max());
        self.cmin = self.cmin.min(c);
        self.cmax = self.cmax.max(c);
        self.spheres += r.is_sphere() as usize;
    }

    fn merge(a: Summary, b: Summary) -> Summary {
        Summary {
            min: a.min.min(b.min),
            max: a.max.max(b.max),
            cmin: a.cmin.min(b.cmin),
            cmax: a.cmax.max(b.cmax),
            spheres: a.spheres + b.spheres,
        }
    }

    fn bounds(&self) -> Aabb {
        Aabb::new(self.min.into(), self.max.into())
    }
}

/// Maps centroids to bins along each axis.
#[derive(Clone, Copy)]
struct Binning {
    origin: Vec3A,
    scale: Vec3A,
    /// Bins in use per axis (at most [`BINS`]).
    bins: usize,
}

impl Binning {
    fn new(s: &Summary, n: usize) -> Self {
        let bins = node_bins(n);
        let extent = (s.cmax - s.cmin).max(Vec3A::ZERO);
        // Slightly under bins/extent so that the far edge falls into the last bin.
        let scale =
            Vec3A::select(extent.cmpgt(Vec3A::ZERO), Vec3A::splat(bins as f32 * (1.0 - 1e-6)) / extent, Vec3A::ZERO);
        Binning { origin: s.cmin, scale, bins }
    }

    /// The centroid's position in bin units along each axis (a bin index before truncation).
    #[inline]
    fn position(&self, c: Vec3A) -> Vec3A {
        (c - self.origin) * self.scale
    }
}

/// The bin of a position in bin units: `(p as usize).min(bins - 1)` (NaN and negative
/// positions in bin 0). The position is clamped to `0 ..= bins − 1` as a float first (NaN
/// to 0: `max` returns its other operand), so that the truncation needs no saturation: one
/// conversion instruction ([`simd::truncate`]) where Rust's saturating `as` takes two
/// compares and two conditional moves more, and a clamp as integers two more. The same
/// index for every float; the mask, a no-op, spares the bins' bounds check.
#[inline(always)]
fn bin_index(p: f32, bins: usize) -> usize {
    simd::truncate(p.max(0.0).min((bins - 1) as f32)) as usize & (BINS - 1)
}

/// [`bin_index`] of the three lanes of `p` at once: one clamp and one conversion for all
/// three.
#[inline(always)]
fn bin_indices(p: Vec3A, bins: usize) -> [usize; 3] {
    simd::truncate3(p.max(Vec3A::ZERO).min(Vec3A::splat((bins - 1) as f32))).map(|i| i as usize & (BINS - 1))
}

/// Centroid bins per axis for a node of `n` refs: [`BINS`] above 64 refs, 16 up to 64, 8 up
/// to 16. Every bin is swept whatever the node holds, and small nodes are most of the tree:
/// fewer bins there took 8–12 % off the full dragon's build (1 thread) for trees of the same
/// SAH cost within 0.05 % (full dragon, dragon res2, bunny) and the same tracing speed.
fn node_bins(n: usize) -> usize {
    if n <= 16 {
        8
    } else if n <= 64 {
        16
    } else {
        BINS
    }
}

type Bins = [[Bin; BINS]; 3];

const EMPTY_BINS: Bins = [[EMPTY_BIN; BINS]; 3];

/// Adds `refs` to `bins`. From [`PAIRED`] refs on, every other ref goes to a second set of
/// bins, merged at the end (min, max and integer counts: the same bins in any order): a
/// ref whose bin the previous ref has just updated waits for that store (neighbouring refs
/// often share a bin, the deeper in the tree the more), two sets halve those waits.
fn bin_refs(refs: &[PrimRef], binning: &Binning, bins: &mut Bins) {
    if refs.len() < PAIRED {
        for r in refs {
            bin_ref(r, binning, bins);
        }
        return;
    }
    let mut other = EMPTY_BINS;
    let mut pairs = refs.chunks_exact(2);
    for pair in pairs.by_ref() {
        bin_ref(&pair[0], binning, bins);
        bin_ref(&pair[1], binning, &mut other);
    }
    for r in pairs.remainder() {
        bin_ref(r, binning, bins);
    }
    *bins = merge_bins(*bins, other);
}

/// Nodes of at least this many refs bin into two sets of bins (below it, merging the second
/// set costs more than it saves). Full dragon build, 8 alternations (`strahl bench … --kind
/// primary --rays 1000 --threads 1,2 --runs 9`): 1 thread, median 300 → 289 ms, 2 threads
/// 158 → 153 ms.
const PAIRED: usize = 64;

/// Adds one ref to its bin on each axis.
#[inline(always)]
fn bin_ref(r: &PrimRef, binning: &Binning, bins: &mut Bins) {
    let index = bin_indices(binning.position(r.centroid()), binning.bins);
    let (min, max) = (r.min(), r.max());
    for (axis, axis_bins) in bins.iter_mut().enumerate() {
        let b = &mut axis_bins[index[axis]];
        b.min = b.min.min(min);
        b.max = b.max.max(max);
        b.count += 1;
    }
}

fn merge_bins(mut a: Bins, b: Bins) -> Bins {
    for (axis_a, axis_b) in a.iter_mut().zip(b.iter()) {
        for (x, y) in axis_a.iter_mut().zip(axis_b.iter()) {
            x.min = x.min.min(y.min);
            x.max = x.max.max(y.max);
            x.count += y.count;
        }
    }
    a
}

/// The cheapest split of `refs` (see [`best_split`]); nodes of more than [`PARALLEL`] refs bin
/// them in parallel chunks.
fn find_split(refs: &[PrimRef], binning: &Binning) -> Option<(f32, usize, usize)> {
    if refs.len() > PARALLEL {
        let bins = refs
            .par_chunks(CHUNK)
            .fold(
                || EMPTY_BINS,
                |mut bins, c| {
                    bin_refs(c, binning, &mut bins);
                    bins
                },
            )
            .reduce(|| EMPTY_BINS, merge_bins);
        best_split(&bins, binning.bins)
    } else {
        let mut bins = EMPTY_BINS;
        bin_refs(refs, binning, &mut bins);
        best_split(&bins, binning.bins)
    }
}

/// Surface area of the box `min..max` held as `Vec3A`; 0 when empty (as [`Aabb::area`]).
#[inline]
fn area(min: Vec3A, max: Vec3A) -> f32 {
    let e = (max - min).max(Vec3A::ZERO);
    2.0 * (e.x * e.y + e.y * e.z + e.z * e.x)
}

/// The cheapest split among the first `used` bins of each axis (the node's
/// [`Binning::bins`]): `(cost, axis, bins left of the plane)`, relative to the node's area;
/// the first of equal costs wins. Every plane between those bins is evaluated and the best one
/// selected without branches (the bins' occupancy, and so which planes split anything, is
/// unpredictable).
fn best_split(bins: &Bins, used: usize) -> Option<(f32, usize, usize)> {
    let (mut found, mut best) = (false, (0.0, 0, 0));
    for (axis, bins) in bins.iter().enumerate() {
        // Right-to-left sweep: area and count of everything right of each plane.
        let mut right_area = [0.0f32; BINS];
        let mut right_count = [0u32; BINS];
        let (mut min, mut max, mut n) = (EMPTY_BIN.min, EMPTY_BIN.max, 0);
        for i in (1..used).rev() {
            (min, max) = (min.min(bins[i].min), max.max(bins[i].max));
            n += bins[i].count;
            right_area[i] = area(min, max);
            right_count[i] = n;
        }
        let (mut min, mut max, mut n) = (EMPTY_BIN.min, EMPTY_BIN.max, 0);
        for i in 1..used {
            (min, max) = (min.min(bins[i - 1].min), max.max(bins[i - 1].max));
            n += bins[i - 1].count;
            let cost = area(min, max) * blocks(n as usize) + right_area[i] * blocks(right_count[i] as usize);
            // A plane with nothing on one side is no split.
            let better = (n != 0) & (right_count[i] != 0) & (!found | (cost < best.0));
            found |= better;
            best = if better { (cost, axis, i) } else { best };
        }
    }
    found.then_some(best)
}

/// Moves the refs for which `left` holds to the front; returns how many there are and, when
/// `SUMMARISE`, the summaries of both sides, made as it goes (one pass over the refs instead
/// of two: the children need no [`Summary::of`] of their own). Without it both are empty.
#[inline(always)]
fn partition<const SUMMARISE: bool>(
    refs: &mut [PrimRef],
    left: impl Fn(&PrimRef) -> bool,
) -> (usize, Summary, Summary) {
    let (mut ls, mut rs) = (Summary::EMPTY, Summary::EMPTY);
    let mut i = 0;
    let mut j = refs.len();
    while i < j {
        if left(&refs[i]) {
            if SUMMARISE {
                ls.add(&refs[i]);
            }
            i += 1;
        } else {
            j -= 1;
            refs.swap(i, j);
            if SUMMARISE {
                rs.add(&refs[j]);
            }
        }
    }
    (i, ls, rs)
}

/// A node's partition: nodes of more than [`PARALLEL`] refs partition alone and let each child
/// summarise itself in parallel; smaller ones summarise the children while partitioning.
#[inline(always)]
fn partition_node(refs: &mut [PrimRef], left: impl Fn(&PrimRef) -> bool) -> (usize, Option<(Summary, Summary)>) {
    if refs.len() > PARALLEL {
        (partition::<false>(refs, left).0, None)
    } else {
        let (mid, l, r) = partition::<true>(refs, left);
        (mid, Some((l, r)))
    }
}

/// Builds the node over `refs` (at `offset` in the whole list), given their summary when the
/// parent computed it while partitioning.
fn build_node(refs: &mut [PrimRef], offset: usize, depth: usize, options: &Options, known: Option<Summary>) -> Node2 {
    let n = refs.len();
    let summary = match known {
        Some(s) => s,
        None if n > PARALLEL => refs.par_chunks(CHUNK).map(Summary::of).reduce(|| Summary::EMPTY, Summary::merge),
        None => Summary::of(refs),
    };
    let bounds = summary.bounds();
    let mixed = summary.spheres != 0 && summary.spheres != n;
    let max_leaf = if summary.spheres == n { options.max_leaf.min(MAX_SPHERE_LEAF) } else { options.max_leaf };
    let leaf = || Node2::Leaf { bounds, start: offset as u32, count: n as u32 };
    if n == 1 {
        return leaf();
    }
    // A split costs at least `traversal_cost` times the node's area, a leaf of that many
    // blocks at most that: no need to look for a split.
    if !mixed && n <= max_leaf && blocks(n) <= options.traversal_cost {
        return leaf();
    }
    let split = if depth < MAX_SAH_DEPTH {
        let binning = Binning::new(&summary, n);
        find_split(refs, &binning)
            .map(|(cost, axis, plane)| (options.traversal_cost * bounds.area() + cost, axis, plane, binning))
    } else {
        None
    };
    let leaf_cost = bounds.area() * blocks(n);
    if !mixed && n <= max_leaf && split.as_ref().is_none_or(|s| leaf_cost <= s.0) {
        return leaf();
    }
    let (mid, sides) = match split {
        // A leaf of mixed kinds must be split by kind first.
        _ if mixed && n <= max_leaf => partition_node(refs, |r| !r.is_sphere()),
        // One loop per axis, each reading its one lane.
        Some((_, axis, plane, binning)) => {
            let (o, s, nb) = (binning.origin[axis], binning.scale[axis], binning.bins);
            match axis {
                0 => partition_node(refs, |r| bin_index((r.centroid().x - o) * s, nb) < plane),
                1 => partition_node(refs, |r| bin_index((r.centroid().y - o) * s, nb) < plane),
                _ => partition_node(refs, |r| bin_index((r.centroid().z - o) * s, nb) < plane),
            }
        }
        // All centroids coincide, or the tree is deep: split by kind, else in the middle.
        None if mixed => partition_node(refs, |r| !r.is_sphere()),
        None => (n / 2, None),
    };
    let (ls, rs) = (sides.map(|s| s.0), sides.map(|s| s.1));
    let (left, right) = refs.split_at_mut(mid);
    let (l, r) = if n > PARALLEL {
        rayon::join(
            || build_node(left, offset, depth + 1, options, ls),
            || build_node(right, offset + mid, depth + 1, options, rs),
        )
    } else {
        (build_node(left, offset, depth + 1, options, ls), build_node(right, offset + mid, depth + 1, options, rs))
    };
    Node2::Inner { bounds, children: Box::new([l, r]) }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Vec3;

    fn point_refs(points: &[Vec3]) -> Vec<PrimRef> {
        points
            .iter()
            .enumerate()
            .map(|(i, &p)| PrimRef::new(Aabb::new(p, p + Vec3::splat(0.1)), i as u32, false))
            .collect()
    }

    fn leaves(node: &Node2, out: &mut Vec<(u32, u32)>, depth: usize, max_depth: &mut usize) {
        *max_depth = (*max_depth).max(depth);
        match node {
            Node2::Leaf { start, count, .. } => out.push((*start, *count)),
            Node2::Inner { children, .. } => {
                for c in children.iter() {
                    leaves(c, out, depth + 1, max_depth);
                }
            }
        }
    }

    #[test]
    fn bin_indices_are_the_saturating_conversions_clamped() {
        // What the bins were before the conversion without saturation, for every kind of
        // float: NaN, infinities, negatives, huge values, both sides of every bin edge.
        let expected = |p: f32, bins: usize| (p as i32).clamp(0, bins as i32 - 1) as usize;
        let mut ps = vec![f32::NAN, -f32::NAN, f32::INFINITY, f32::NEG_INFINITY, -0.0, 0.0, f32::MAX, f32::MIN];
        ps.extend([2.0f32.powi(31), 2.0f32.powi(31) - 128.0, -(2.0f32.powi(31)), 1e-30, -1e-30]);
        for i in -2..=34 {
            let edge = i as f32;
            ps.extend([edge, edge.next_up(), edge.next_down(), edge + 0.5]);
        }
        for bins in [8, 16, BINS] {
            for &p in &ps {
                assert_eq!(bin_index(p, bins), expected(p, bins), "{p} in {bins} bins");
                for lane in 0..3 {
                    let mut v = Vec3A::splat(1.5);
                    v[lane] = p;
                    let want = [0, 1, 2].map(|l| expected(v[l], bins));
                    assert_eq!(bin_indices(v, bins), want, "{v} in {bins} bins");
                }
            }
        }
    }

    #[test]
    fn two_sets_of_bins_bin_as_one() {
        // Boxes scattered at random, some sharing bins in runs, as refs deep in a tree.
        use rand::{Rng, SeedableRng};
        let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(7);
        let points: Vec<Vec3> =
            (0..PAIRED * 3 + 1).map(|i| Vec3::new(rng.random(), (i / 7) as f32, rng.random())).collect();
        let refs = point_refs(&points);
        let binning = Binning::new(&Summary::of(&refs), refs.len());
        let mut paired = EMPTY_BINS;
        bin_refs(&refs, &binning, &mut paired);
        let mut one = EMPTY_BINS;
        for r in &refs {
            bin_ref(r, &binning, &mut one);
        }
        for (a, b) in paired.iter().flatten().zip(one.iter().flatten()) {
            assert_eq!((a.min, a.max, a.count), (b.min, b.max, b.count));
        }
        assert_eq!(paired[0].iter().map(|b| b.count as usize).sum::<usize>(), refs.len());
    }

    #[test]
    fn two_clusters_split_between_them() {
        let mut pts: Vec<Vec3> = (0..4).map(|i| Vec3::new(i as f32 * 0.01, 0.0, 0.0)).collect();
        pts.extend((0..4).map(|i| Vec3::new(10.0 + i as f32 * 0.01, 0.0, 0.0)));
        let mut refs = point_refs(&pts);
        let options = Options { max_leaf: 4, traversal_cost: 1.0 };
        let Node2::Inner { children, .. } = build(&mut refs, &options).unwrap() else {
            panic!("one leaf for two clusters")
        };
        for (child, range) in children.iter().zip([0..4u32, 4..8]) {
            let Node2::Leaf { start, count, .. } = child else { panic!("cluster not a leaf") };
            assert_eq!((*start, *count), (range.start, 4));
            let mut ids: Vec<u32> = refs[range.start as usize..range.end as usize].iter().map(|r| r.id()).collect();
            ids.sort();
            assert_eq!(ids, range.collect::<Vec<_>>());
        }
    }

    #[test]
    fn coincident_primitives_still_make_small_leaves() {
        // 1000 identical boxes: no plane separates them; median splits keep leaves small.
        let mut refs = point_refs(&vec![Vec3::ONE; 1000]);
        let root = build(&mut refs, &Options::default()).unwrap();
        let (mut out, mut depth) = (Vec::new(), 0);
        leaves(&root, &mut out, 0, &mut depth);
        assert!(out.iter().all(|&(_, c)| c as usize <= Options::default().max_leaf));
        assert_eq!(out.iter().map(|&(_, c)| c).sum::<u32>(), 1000);
        assert!(depth <= MAX_SAH_DEPTH + 12, "depth {depth}");
    }

    #[test]
    fn leaves_hold_one_kind() {
        let mut refs: Vec<PrimRef> =
            (0..6).map(|i| PrimRef::new(Aabb::new(Vec3::ZERO, Vec3::ONE), i, i % 2 == 0)).collect();
        let root = build(&mut refs, &Options::default()).unwrap();
        let (mut out, mut depth) = (Vec::new(), 0);
        leaves(&root, &mut out, 0, &mut depth);
        for (start, count) in out {
            let kinds: Vec<bool> =
                refs[start as usize..(start + count) as usize].iter().map(|r| r.is_sphere()).collect();
            assert!(kinds.iter().all(|&k| k == kinds[0]), "mixed leaf {kinds:?}");
        }
    }
}
