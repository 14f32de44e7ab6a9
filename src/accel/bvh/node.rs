//! The flat 8-wide node layout the traversal reads, and the collapse of the binary build tree
//! into it.
//!
//! A [`Node`] holds the boxes of its eight children in structure-of-arrays form (for each of
//! the six slabs, two `Vec4`s of four children: 192 bytes) and their references (32 bytes),
//! in four cache lines: one node visit tests eight boxes with two 4-wide SIMD passes. Eight
//! children instead of four make the tree a third shallower (the dragon: depth 8 instead of
//! 12), so a ray waits for fewer dependent memory fetches. A child
//! reference ([`ChildRef`]) is either another node's index or a leaf: a run of
//! [`Triangle4`](crate::geometry::triangle::Triangle4) blocks or of spheres.

use glam::Vec4;

use super::build::{MAX_LEAF, Node2};
use crate::math::Aabb;

/// Groups of four children per node (the SIMD width of the slab test).
pub const CHUNKS: usize = 2;
/// Children per node.
pub const WIDTH: usize = 4 * CHUNKS;

/// A node's reference to a child, packed into 32 bits:
/// - bit 31 clear: an inner node, the rest is its index in the node array;
/// - bit 31 set: a leaf; bit 30 says spheres (else triangle blocks), bits 27–29 hold the
///   number of blocks or spheres minus one, bits 0–26 the index of the first.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ChildRef(pub u32);

const LEAF: u32 = 1 << 31;
const SPHERES: u32 = 1 << 30;
const COUNT_SHIFT: u32 = 27;
/// Largest first-block or first-sphere index a leaf can encode.
pub const MAX_LEAF_INDEX: usize = (1 << COUNT_SHIFT) - 1;
/// Largest inner-node index.
pub const MAX_NODE_INDEX: usize = (LEAF - 2) as usize;

impl ChildRef {
    /// The empty slot of a node with fewer than eight children (its box is empty too).
    pub const EMPTY: ChildRef = ChildRef(LEAF - 1);

    #[inline]
    pub fn node(index: usize) -> Self {
        debug_assert!(index <= MAX_NODE_INDEX);
        ChildRef(index as u32)
    }

    #[inline]
    pub fn leaf(first: usize, count: usize, spheres: bool) -> Self {
        debug_assert!(first <= MAX_LEAF_INDEX && (1..=8).contains(&count));
        ChildRef(LEAF | if spheres { SPHERES } else { 0 } | ((count as u32 - 1) << COUNT_SHIFT) | first as u32)
    }

    #[inline]
    pub fn is_leaf(self) -> bool {
        self.0 & LEAF != 0
    }

    #[inline]
    pub fn is_spheres(self) -> bool {
        self.0 & SPHERES != 0
    }

    /// The index of the inner node.
    #[inline]
    pub fn index(self) -> usize {
        self.0 as usize
    }

    /// A leaf's first block or sphere, and how many.
    #[inline]
    pub fn range(self) -> (usize, usize) {
        ((self.0 & ((1 << COUNT_SHIFT) - 1)) as usize, ((self.0 >> COUNT_SHIFT) & 7) as usize + 1)
    }
}

/// Eight children: their boxes as `bounds[slab][group][lane]` (child `4·group + lane`) with
/// slabs `min x, min y, min z, max x, max y, max z`, and their references. Empty lanes have empty boxes (`min = +∞`,
/// `max = −∞`), which no ray enters.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
pub struct Node {
    pub bounds: [[Vec4; CHUNKS]; 6],
    pub children: [ChildRef; WIDTH],
}

impl Node {
    const EMPTY: Node = Node {
        bounds: [
            [Vec4::INFINITY; CHUNKS],
            [Vec4::INFINITY; CHUNKS],
            [Vec4::INFINITY; CHUNKS],
            [Vec4::NEG_INFINITY; CHUNKS],
            [Vec4::NEG_INFINITY; CHUNKS],
            [Vec4::NEG_INFINITY; CHUNKS],
        ],
        children: [ChildRef::EMPTY; WIDTH],
    };

    fn set(&mut self, lane: usize, b: Aabb, child: ChildRef) {
        for axis in 0..3 {
            self.bounds[axis][lane / 4][lane % 4] = b.min[axis];
            self.bounds[axis + 3][lane / 4][lane % 4] = b.max[axis];
        }
        self.children[lane] = child;
    }

    /// The box of child `lane`.
    pub fn child_bounds(&self, lane: usize) -> Aabb {
        let b = |slab: usize| self.bounds[slab][lane / 4][lane % 4];
        Aabb::new([b(0), b(1), b(2)].into(), [b(3), b(4), b(5)].into())
    }
}

/// What a leaf needs from the caller: the leaf's range of (reordered) primitives, all of one
/// kind, turned into blocks or spheres; returns the leaf reference.
pub trait LeafSink {
    fn leaf(&mut self, start: usize, count: usize) -> ChildRef;
}

/// Collapses the binary tree into 8-wide nodes. Each node takes its two children and keeps
/// opening the inner child with the largest surface area until it has eight (fewer only where
/// the children are leaves).
/// Returns the nodes, the root reference and the depth (the inner nodes on the longest path
/// from the root, as [`crate::accel::bvh::Stats::depth`] counts them).
pub fn collapse(root: &Node2, sink: &mut impl LeafSink) -> (Vec<Node>, ChildRef, usize) {
    let mut nodes = Vec::new();
    match root {
        Node2::Leaf { start, count, .. } => {
            debug_assert!(*count as usize <= MAX_LEAF);
            (nodes, sink.leaf(*start as usize, *count as usize), 0)
        }
        Node2::Inner { .. } => {
            nodes.push(Node::EMPTY);
            let depth = fill(0, root, sink, &mut nodes);
            (nodes, ChildRef::node(0), depth)
        }
    }
}

/// The (up to eight) children of a wide node, and how many: the binary node's two children,
/// with the inner child of largest surface area opened while there is room (the last of
/// equal areas). A fixed array: no allocation per node.
fn open_children(node: &Node2) -> ([&Node2; WIDTH], usize) {
    let mut open = [node; WIDTH];
    let Node2::Inner { children, .. } = node else { return (open, 1) };
    (open[0], open[1]) = (&children[0], &children[1]);
    let mut len = 2;
    while len < WIDTH {
        let mut widest: Option<(usize, f32)> = None;
        for (i, n) in open[..len].iter().enumerate() {
            if let Node2::Inner { bounds, .. } = n {
                let a = bounds.area();
                if widest.is_none_or(|(_, w)| a.total_cmp(&w).is_ge()) {
                    widest = Some((i, a));
                }
            }
        }
        let Some((i, _)) = widest else { break };
        let Node2::Inner { children, .. } = open[i] else { unreachable!() };
        open.copy_within(i + 1..len, i + 2);
        (open[i], open[i + 1]) = (&children[0], &children[1]);
        len += 1;
    }
    (open, len)
}

/// Fills `nodes[index]` from the binary node `node`. The node's inner children are allocated
/// next to each other before any of their subtrees, so that siblings share pages and
/// neighbouring cache lines. Returns the depth of the subtree (1 for a node of leaves).
fn fill(index: usize, node: &Node2, sink: &mut impl LeafSink, nodes: &mut Vec<Node>) -> usize {
    let (children, len) = open_children(node);
    let mut inner = [(0, node); WIDTH];
    let mut n_inner = 0;
    for (lane, child) in children[..len].iter().enumerate() {
        let r = match child {
            Node2::Leaf { start, count, .. } => {
                debug_assert!(*count as usize <= MAX_LEAF);
                sink.leaf(*start as usize, *count as usize)
            }
            Node2::Inner { .. } => {
                nodes.push(Node::EMPTY);
                inner[n_inner] = (nodes.len() - 1, *child);
                n_inner += 1;
                ChildRef::node(nodes.len() - 1)
            }
        };
        nodes[index].set(lane, child.bounds(), r);
    }
    inner[..n_inner].iter().map(|&(i, child)| fill(i, child, sink, nodes)).max().unwrap_or(0) + 1
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn child_refs_round_trip() {
        let r = ChildRef::leaf(12345, 8, true);
        assert!(r.is_leaf() && r.is_spheres());
        assert_eq!(r.range(), (12345, 8));
        let r = ChildRef::leaf(MAX_LEAF_INDEX, 1, false);
        assert!(r.is_leaf() && !r.is_spheres());
        assert_eq!(r.range(), (MAX_LEAF_INDEX, 1));
        let r = ChildRef::node(77);
        assert!(!r.is_leaf());
        assert_eq!(r.index(), 77);
        assert!(!ChildRef::EMPTY.is_leaf());
        assert_eq!(std::mem::size_of::<Node>(), 256);
    }
}
