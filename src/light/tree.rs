//! A light tree: many lights chosen by their importance at the shading point, in the manner
//! of pbrt-v4's `BVHLightSampler` (Cycles' light tree is the same idea).
//!
//! ```text
//! sample(p, n, u) → (light, pmf)        pmf(p, n, light) = what sample would have given it
//!
//! infinite lights (directional, environment): P_inf = n_inf / (n_inf + 1)  (n_inf / n_inf
//!     without bounded lights), each of them P_inf / n_inf
//! bounded lights (everything else): a binary tree, one light per leaf; from the root, child
//!     c of a node is taken with probability I_c / (I_0 + I_1), and the light's pmf is
//!     (1 − P_inf) · Π over its ancestors of that ratio
//!
//! importance of bounds (box B, centre c, normal cone (w, θo), emission spread θe, power Φ)
//! at p with normal n (pbrt-v4's LightBounds::Importance):
//!     d²   = max(|p − c|², |diag B| / 2)
//!     θw   = ∠(w, p − c)       (|cos| for two-sided lights)
//!     θb   = half-angle of the cone from p around B's bounding sphere (π from inside it)
//!     θ'   = max(0, θw − θo − θb)
//!     I    = 0                                        if cos θ' ≤ cos θe
//!            Φ · cos θ' / d² · cos(max(0, θi − θb))   otherwise
//!     θi   = ∠(n, p − c) taken two-sided (|cos|); the last factor is 1 when n = 0
//! ```
//!
//! A node whose children both have importance 0 at `p` (as far as their bounds tell, nothing
//! below it reaches `p`) chooses between them by power instead, so the pmf is a distribution
//! over the lights at every point (pbrt-v4 returns no light there; the light then chosen
//! contributes nothing, which is unbiased either way). A node whose children's bounds differ
//! in power alone (a quad light's two triangles) chooses by power everywhere without computing
//! the importances: their ratio is the powers' ratio, `Φ0·g / (Φ0·g + Φ1·g)` with one factor
//! `g` for both, up to rounding.
//!
//! A node's bounds are the union of its lights': boxes united, cones united (the smallest cone
//! holding both, pbrt-v4's `Union(DirectionCone, DirectionCone)`), θe the largest, Φ summed,
//! two-sided if either is.
//!
//! **Build.** Top-down and single-threaded over the lights in their given order, so the tree is
//! the same whatever the thread count. A node of one light is a leaf. Otherwise each axis with
//! an extent of light centroids is cut into 12 buckets and the split between buckets that
//! minimises pbrt-v4's cost is taken:
//!
//! ```text
//! cost(side) = Φ · M_Ω · K_r · area(B)
//!     M_Ω = 2π(1 − cos θo) + π/2 · (2 θw sin θo − cos(θo − 2θw) − 2 θo sin θo + cos θo),
//!           θw = min(θo + θe, π)          (the solid angle the side's emission spreads into)
//!     K_r = largest extent of the node's box / its extent along the axis
//! ```
//!
//! When no split separates the lights (all centroids equal, or every cost 0), or below depth
//! [`SAH_DEPTH`], the lights are split in two halves by count along the axis of widest centroid
//! extent (ties by their order), so no path is deeper than 63 edges and every light's way down
//! fits in the 64 bits of its trail (bit `k`: the right child at depth `k`). Lights of power 0
//! are left out and never chosen (their pmf is 0).
//!
//! Everything is f32 and computed the same way by [`LightTree::sample`] and [`LightTree::pmf`]
//! (the same importances, the same ratio `I_c / (I_0 + I_1)`, multiplied in the same order), so
//! `pmf` returns bit for bit the probability `sample` reported. Importances are clamped below
//! `f32::MAX / 4` so their sum stays finite. A tree of one bounded light (and no infinite
//! light) returns that light with pmf exactly 1 without looking at the point, as a choice by
//! power among one light does.

use std::f32::consts::PI;

use crate::math::{Aabb, Vec3};

/// Buckets per axis of the build's split search.
const BUCKETS: usize = 12;

/// Depth from which the build splits by count (module docs): 31 levels of cost-driven splits
/// and at most 32 of halving keep every path within 63 edges.
pub const SAH_DEPTH: u32 = 31;

/// Largest importance of a node, so that two add up to a finite number.
const MAX_IMPORTANCE: f32 = f32::MAX / 4.0;

/// The bounds of a light, or of a set of lights: where it is, which way it emits, how much.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightBounds {
    /// The box holding every emitting point.
    pub bounds: Aabb,
    /// The axis of the cone of surface normals (unit).
    pub w: Vec3,
    /// Power (luminance, W), the sum for a set.
    pub phi: f32,
    /// Cosine of the half-angle of the normal cone (1: a single normal; −1: every direction).
    pub cos_theta_o: f32,
    /// Cosine of the angle beyond the normal cone up to which light leaves the surface
    /// (`cos(π/2)` for a diffuse emitter).
    pub cos_theta_e: f32,
    /// Whether the back of the surfaces emits too (the cone holds `−w` as well).
    pub two_sided: bool,
}

/// `cos(π/2)` in f32 (−4.4e-8, not 0): a diffuse emitter's spread, as pbrt-v4 writes it.
pub fn cos_half_pi() -> f32 {
    (PI / 2.0).cos()
}

impl LightBounds {
    /// The bounds of nothing: the identity of [`LightBounds::union`].
    pub const EMPTY: LightBounds =
        LightBounds { bounds: Aabb::EMPTY, w: Vec3::Z, phi: 0.0, cos_theta_o: 1.0, cos_theta_e: 1.0, two_sided: false };

    /// A diffuse emitter of power `phi` within `bounds` whose normals lie within the cone
    /// `(w, cos_theta_o)`.
    pub fn diffuse(bounds: Aabb, w: Vec3, phi: f32, cos_theta_o: f32, two_sided: bool) -> LightBounds {
        LightBounds { bounds, w: w.normalize_or(Vec3::Z), phi, cos_theta_o, cos_theta_e: cos_half_pi(), two_sided }
    }

    /// A point emitting `phi` in every direction.
    pub fn point(p: Vec3, phi: f32) -> LightBounds {
        LightBounds::diffuse(Aabb::new(p, p), Vec3::Z, phi, -1.0, false)
    }

    fn centroid(&self) -> Vec3 {
        self.bounds.centroid()
    }

    /// The bounds of both (module docs).
    pub fn union(&self, o: &LightBounds) -> LightBounds {
        if self.phi == 0.0 {
            return *o;
        }
        if o.phi == 0.0 {
            return *self;
        }
        let (w, cos_theta_o) = cone_union((self.w, self.cos_theta_o), (o.w, o.cos_theta_o));
        LightBounds {
            bounds: self.bounds.union(o.bounds),
            w,
            phi: self.phi + o.phi,
            cos_theta_o,
            cos_theta_e: self.cos_theta_e.min(o.cos_theta_e),
            two_sided: self.two_sided || o.two_sided,
        }
    }

    /// The importance of these bounds at `p` with surface normal `n` (`Vec3::ZERO`: no
    /// surface), module docs.
    pub fn importance(&self, p: Vec3, n: Vec3) -> f32 {
        let pc = self.centroid();
        let d2 = (p - pc).length_squared().max(0.5 * (self.bounds.max - self.bounds.min).length());
        let wi = (p - pc).normalize_or_zero();
        let mut cos_w = self.w.dot(wi);
        if self.two_sided {
            cos_w = cos_w.abs();
        }
        let sin_w = safe_sqrt(1.0 - cos_w * cos_w);
        let cos_b = cos_subtended(&self.bounds, p);
        let sin_b = safe_sqrt(1.0 - cos_b * cos_b);
        let sin_o = safe_sqrt(1.0 - self.cos_theta_o * self.cos_theta_o);
        let cos_x = cos_sub_clamped(sin_w, cos_w, sin_o, self.cos_theta_o);
        let sin_x = sin_sub_clamped(sin_w, cos_w, sin_o, self.cos_theta_o);
        let cos_p = cos_sub_clamped(sin_x, cos_x, sin_b, cos_b);
        if cos_p <= self.cos_theta_e {
            return 0.0;
        }
        let mut importance = self.phi * cos_p / d2;
        if n != Vec3::ZERO {
            let cos_i = wi.dot(n).abs();
            let sin_i = safe_sqrt(1.0 - cos_i * cos_i);
            importance *= cos_sub_clamped(sin_i, cos_i, sin_b, cos_b);
        }
        if importance.is_nan() { 0.0 } else { importance.clamp(0.0, MAX_IMPORTANCE) }
    }

    /// Whether `o` differs from these bounds in its power alone (the two triangles of a quad
    /// light have the same box, cone and spread): then their importances are in the ratio of
    /// their powers at every point.
    fn same_but_power(&self, o: &LightBounds) -> bool {
        LightBounds { phi: o.phi, ..*self } == *o
    }

    /// pbrt-v4's cost of these bounds as one side of a split along `axis` of a node whose box is
    /// `node` (module docs).
    fn cost(&self, node: &Aabb, axis: usize) -> f32 {
        if self.phi == 0.0 {
            return 0.0;
        }
        let theta_o = self.cos_theta_o.clamp(-1.0, 1.0).acos();
        let theta_e = self.cos_theta_e.clamp(-1.0, 1.0).acos();
        let theta_w = (theta_o + theta_e).min(PI);
        let sin_o = safe_sqrt(1.0 - self.cos_theta_o * self.cos_theta_o);
        let m_omega = 2.0 * PI * (1.0 - self.cos_theta_o)
            + PI / 2.0
                * (2.0 * theta_w * sin_o - (theta_o - 2.0 * theta_w).cos() - 2.0 * theta_o * sin_o + self.cos_theta_o);
        let extent = node.extent();
        let kr = extent.max_element() / extent[axis];
        self.phi * m_omega * kr * self.bounds.area()
    }
}

fn safe_sqrt(x: f32) -> f32 {
    x.max(0.0).sqrt()
}

/// `cos(max(0, a − b))` from the sines and cosines of `a` and `b`.
fn cos_sub_clamped(sin_a: f32, cos_a: f32, sin_b: f32, cos_b: f32) -> f32 {
    if cos_a > cos_b { 1.0 } else { cos_a * cos_b + sin_a * sin_b }
}

/// `sin(max(0, a − b))` from the sines and cosines of `a` and `b`.
fn sin_sub_clamped(sin_a: f32, cos_a: f32, sin_b: f32, cos_b: f32) -> f32 {
    if cos_a > cos_b { 0.0 } else { sin_a * cos_b - cos_a * sin_b }
}

/// The cosine of the half-angle of the cone of directions from `p` that holds the bounding
/// sphere of `b` (−1 from inside it).
fn cos_subtended(b: &Aabb, p: Vec3) -> f32 {
    let c = b.centroid();
    let r2 = (b.max - c).length_squared();
    let d2 = (p - c).length_squared();
    if d2 <= r2 {
        return -1.0;
    }
    safe_sqrt(1.0 - r2 / d2)
}

/// The angle between unit vectors, accurate for small and large angles.
fn angle_between(a: Vec3, b: Vec3) -> f32 {
    if a.dot(b) < 0.0 {
        PI - 2.0 * ((a + b).length() / 2.0).min(1.0).asin()
    } else {
        2.0 * ((b - a).length() / 2.0).min(1.0).asin()
    }
}

/// The smallest cone holding the cones `a` and `b` (axis, cosine of the half-angle).
fn cone_union(a: (Vec3, f32), b: (Vec3, f32)) -> (Vec3, f32) {
    let theta_a = a.1.clamp(-1.0, 1.0).acos();
    let theta_b = b.1.clamp(-1.0, 1.0).acos();
    let theta_d = angle_between(a.0, b.0);
    if (theta_d + theta_b).min(PI) <= theta_a {
        return a;
    }
    if (theta_d + theta_a).min(PI) <= theta_b {
        return b;
    }
    let theta_o = (theta_a + theta_d + theta_b) / 2.0;
    if theta_o >= PI {
        return (Vec3::Z, -1.0);
    }
    let theta_r = theta_o - theta_a;
    let k = a.0.cross(b.0);
    if k.length_squared() == 0.0 {
        return (Vec3::Z, -1.0);
    }
    // a.w rotated by θr about k (Rodrigues).
    let k = k.normalize();
    let (s, c) = theta_r.sin_cos();
    let w = a.0 * c + k.cross(a.0) * s + k * k.dot(a.0) * (1.0 - c);
    (w.normalize(), theta_o.cos())
}

/// What the tree is given per light.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum LightExtent {
    /// A light with bounds, in the tree.
    Bounded(LightBounds),
    /// A light infinitely far away, of this power (directional, environment), chosen apart.
    Infinite(f32),
}

/// How the tree reaches a light.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Place {
    /// Power 0: never chosen.
    Never,
    /// The `k`-th infinite light.
    Infinite(u32),
    /// In the tree: bit `k` of the trail is 1 where the way goes to the right child at depth `k`.
    Tree(u64),
}

#[derive(Clone, Copy, Debug)]
struct Node {
    bounds: LightBounds,
    /// A leaf's light, or an inner node's right child (its left child follows it).
    child_or_light: u32,
    leaf: bool,
    /// An inner node whose children's bounds differ in power alone: it chooses between
    /// them by power (module docs).
    twins: bool,
}

/// The light tree over a scene's lights (module docs).
#[derive(Clone, Debug)]
pub struct LightTree {
    nodes: Vec<Node>,
    /// Per light given to [`LightTree::new`].
    places: Vec<Place>,
    /// The infinite lights' indices, in their order.
    infinite: Vec<u32>,
    /// Edges from the root to the deepest leaf.
    depth: u32,
}

impl LightTree {
    /// The tree over `lights` (indices are their positions here).
    pub fn new(lights: &[LightExtent]) -> LightTree {
        let mut places = vec![Place::Never; lights.len()];
        let mut infinite = Vec::new();
        let mut items = Vec::new();
        for (i, l) in lights.iter().enumerate() {
            match *l {
                LightExtent::Infinite(phi) if phi > 0.0 && phi.is_finite() => {
                    places[i] = Place::Infinite(infinite.len() as u32);
                    infinite.push(i as u32);
                }
                LightExtent::Bounded(b) if b.phi > 0.0 && b.phi.is_finite() && !b.bounds.is_empty() => {
                    items.push(Item { bounds: b, centroid: b.centroid(), light: i as u32 })
                }
                _ => {}
            }
        }
        let mut nodes = Vec::with_capacity(2 * items.len());
        let mut depth = 0;
        if !items.is_empty() {
            build(&mut items, 0, 0, &mut Build { nodes: &mut nodes, places: &mut places, depth: &mut depth });
        }
        LightTree { nodes, places, infinite, depth }
    }

    /// The probability of choosing the infinite lights as a whole.
    fn p_infinite(&self) -> f32 {
        let n = self.infinite.len();
        let total = n + usize::from(!self.nodes.is_empty());
        if total == 0 { 0.0 } else { n as f32 / total as f32 }
    }

    /// A light chosen for the point `p` with shading normal `n` by `u ∈ [0, 1)`, the
    /// probability of that choice, and what is left of `u`: its place within the chosen
    /// light's share of `[0, 1)`, again uniform in `[0, 1)` (`None` without lights).
    pub fn sample(&self, p: Vec3, n: Vec3, u: f32) -> Option<(usize, f32, f32)> {
        let p_inf = self.p_infinite();
        if u < p_inf {
            let x = u / p_inf * self.infinite.len() as f32;
            let k = (x as usize).min(self.infinite.len() - 1);
            let rest = (x - k as f32).clamp(0.0, ONE_MINUS_EPSILON);
            return Some((self.infinite[k] as usize, p_inf / self.infinite.len() as f32, rest));
        }
        if self.nodes.is_empty() {
            return None;
        }
        let mut u = ((u - p_inf) / (1.0 - p_inf)).min(ONE_MINUS_EPSILON);
        let mut pmf = 1.0 - p_inf;
        let mut i = 0usize;
        loop {
            let node = &self.nodes[i];
            if node.leaf {
                return Some((node.child_or_light as usize, pmf, u));
            }
            let right = node.child_or_light as usize;
            let (c0, c1) = self.child_weights(i, p, n);
            let p0 = c0 / (c0 + c1);
            if u < p0 {
                u = (u / p0).min(ONE_MINUS_EPSILON);
                pmf *= c0 / (c0 + c1);
                i += 1;
            } else {
                u = ((u - p0) / (1.0 - p0)).min(ONE_MINUS_EPSILON);
                pmf *= c1 / (c0 + c1);
                i = right;
            }
        }
    }

    /// The probability that [`LightTree::sample`] at `p` (normal `n`) chooses `light`.
    pub fn pmf(&self, p: Vec3, n: Vec3, light: usize) -> f32 {
        let p_inf = self.p_infinite();
        match self.places.get(light) {
            None | Some(Place::Never) => 0.0,
            Some(Place::Infinite(_)) => p_inf / self.infinite.len() as f32,
            Some(&Place::Tree(mut trail)) => {
                let mut pmf = 1.0 - p_inf;
                let mut i = 0usize;
                loop {
                    let node = &self.nodes[i];
                    if node.leaf {
                        return pmf;
                    }
                    let right = node.child_or_light as usize;
                    let (c0, c1) = self.child_weights(i, p, n);
                    let c = if trail & 1 == 0 { c0 } else { c1 };
                    if c == 0.0 {
                        return 0.0;
                    }
                    pmf *= c / (c0 + c1);
                    i = if trail & 1 == 0 { i + 1 } else { right };
                    trail >>= 1;
                }
            }
        }
    }

    /// The weights of inner node `i`'s children at `p` (normal `n`): their importances, or
    /// their powers when both importances are 0 or the children differ in power alone (module
    /// docs).
    #[inline]
    fn child_weights(&self, i: usize, p: Vec3, n: Vec3) -> (f32, f32) {
        let node = &self.nodes[i];
        let (left, right) = (&self.nodes[i + 1].bounds, &self.nodes[node.child_or_light as usize].bounds);
        if node.twins {
            // Φ0·g / (Φ0·g + Φ1·g) with one falloff g for both: the ratio of the powers, the
            // point aside (and so also where g is 0).
            return (left.phi, right.phi);
        }
        let (c0, c1) = (left.importance(p, n), right.importance(p, n));
        if c0 == 0.0 && c1 == 0.0 { (left.phi, right.phi) } else { (c0, c1) }
    }

    /// Nodes in the tree (2·bounded lights − 1, or 0).
    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }

    /// Bytes the tree holds (nodes, per-light places, infinite lights).
    pub fn memory_bytes(&self) -> usize {
        self.nodes.capacity() * std::mem::size_of::<Node>()
            + self.places.capacity() * std::mem::size_of::<Place>()
            + self.infinite.capacity() * std::mem::size_of::<u32>()
    }

    /// The depth of the deepest leaf (0 for a lone leaf).
    pub fn depth(&self) -> u32 {
        self.depth
    }
}

/// The largest f32 below 1.
const ONE_MINUS_EPSILON: f32 = 1.0 - f32::EPSILON / 2.0;

#[derive(Clone, Copy)]
struct Item {
    bounds: LightBounds,
    centroid: Vec3,
    light: u32,
}

/// What the build writes.
struct Build<'a> {
    nodes: &'a mut Vec<Node>,
    places: &'a mut [Place],
    depth: &'a mut u32,
}

/// Builds the subtree of `items` at `depth`, reached by `trail`; returns its root's index.
fn build(items: &mut [Item], depth: u32, trail: u64, out: &mut Build) -> usize {
    let at = out.nodes.len();
    if let [item] = items {
        out.nodes.push(Node { bounds: item.bounds, child_or_light: item.light, leaf: true, twins: false });
        out.places[item.light as usize] = Place::Tree(trail);
        *out.depth = (*out.depth).max(depth);
        return at;
    }
    let bounds = items.iter().fold(LightBounds::EMPTY, |b, it| b.union(&it.bounds));
    let centroids = Aabb::from_points(items.iter().map(|it| it.centroid));
    let mid = (if depth < SAH_DEPTH { sah_split(items, &bounds.bounds, &centroids) } else { None })
        .unwrap_or_else(|| halve(items, &centroids));
    out.nodes.push(Node { bounds, child_or_light: 0, leaf: false, twins: false });
    let (left, right) = items.split_at_mut(mid);
    let l = build(left, depth + 1, trail, out);
    let r = build(right, depth + 1, trail | (1u64 << depth), out);
    out.nodes[at].child_or_light = r as u32;
    out.nodes[at].twins = out.nodes[l].bounds.same_but_power(&out.nodes[r].bounds);
    at
}

/// The bucket of a centroid coordinate `c` along an axis spanning `[lo, lo + extent]`.
fn bucket(c: f32, lo: f32, extent: f32) -> usize {
    ((BUCKETS as f32 * ((c - lo) / extent)) as usize).min(BUCKETS - 1)
}

/// The cheapest split of `items` by buckets (module docs), applied as a stable partition:
/// the number of items on the left, or `None` when no split separates them.
fn sah_split(items: &mut [Item], node: &Aabb, centroids: &Aabb) -> Option<usize> {
    let extent = centroids.extent();
    let mut best: Option<(f32, usize, usize)> = None;
    for axis in 0..3 {
        if !(extent[axis] > 0.0) {
            continue;
        }
        let mut buckets = [LightBounds::EMPTY; BUCKETS];
        for it in items.iter() {
            let b = bucket(it.centroid[axis], centroids.min[axis], extent[axis]);
            buckets[b] = buckets[b].union(&it.bounds);
        }
        for split in 0..BUCKETS - 1 {
            let below = buckets[..=split].iter().fold(LightBounds::EMPTY, |a, b| a.union(b));
            let above = buckets[split + 1..].iter().fold(LightBounds::EMPTY, |a, b| a.union(b));
            let cost = below.cost(node, axis) + above.cost(node, axis);
            if cost > 0.0 && cost.is_finite() && best.is_none_or(|(c, _, _)| cost < c) {
                best = Some((cost, axis, split));
            }
        }
    }
    let (_, axis, split) = best?;
    let (lo, ext) = (centroids.min[axis], extent[axis]);
    let (mut left, right): (Vec<Item>, Vec<Item>) =
        items.iter().partition(|it| bucket(it.centroid[axis], lo, ext) <= split);
    let mid = left.len();
    if mid == 0 || mid == items.len() {
        return None;
    }
    left.extend(right);
    items.copy_from_slice(&left);
    Some(mid)
}

/// Splits `items` in two halves by count along the axis of widest centroid extent (stable:
/// equal coordinates keep their order); the number on the left.
fn halve(items: &mut [Item], centroids: &Aabb) -> usize {
    let e = centroids.extent();
    let axis = if e.x >= e.y && e.x >= e.z {
        0
    } else if e.y >= e.z {
        1
    } else {
        2
    };
    items.sort_by(|a, b| a.centroid[axis].total_cmp(&b.centroid[axis]));
    items.len() / 2
}

#[cfg(test)]
mod tests {
    use rand::{Rng, SeedableRng};
    use rand_pcg::Pcg64Mcg;

    use super::*;
    use crate::sampling::chi2::{gamma_q, sidak};

    /// 64 small one-sided triangles scattered over a box (normals in every direction, powers
    /// over two decades), a point light, a two-sided one, and `infinite` infinite lights.
    fn lights(infinite: usize) -> Vec<LightExtent> {
        let mut rng = Pcg64Mcg::seed_from_u64(3);
        let mut v = Vec::new();
        for k in 0..64 {
            let c = Vec3::new(rng.random_range(-4.0..4.0), rng.random_range(0.0..3.0), rng.random_range(-4.0..4.0));
            let a =
                c + Vec3::new(rng.random_range(-0.2..0.2), rng.random_range(-0.2..0.2), rng.random_range(-0.2..0.2));
            let b =
                c + Vec3::new(rng.random_range(-0.2..0.2), rng.random_range(-0.2..0.2), rng.random_range(-0.2..0.2));
            let n = (a - c).cross(b - c).normalize();
            let phi = 10f32.powf(rng.random_range(0.0..2.0));
            v.push(LightExtent::Bounded(LightBounds::diffuse(Aabb::from_points([a, b, c]), n, phi, 1.0, k % 5 == 0)));
        }
        v.push(LightExtent::Bounded(LightBounds::point(Vec3::new(1.0, 2.0, 0.5), 30.0)));
        v.push(LightExtent::Bounded(LightBounds { phi: 0.0, ..LightBounds::point(Vec3::ONE, 1.0) }));
        for _ in 0..infinite {
            v.push(LightExtent::Infinite(5.0));
        }
        v
    }

    fn points() -> Vec<(Vec3, Vec3)> {
        vec![
            (Vec3::new(0.0, -1.0, 0.0), Vec3::Y),
            (Vec3::new(3.5, 1.0, -2.0), Vec3::new(-1.0, 0.2, 0.3).normalize()),
            (Vec3::new(0.1, 1.5, 0.2), Vec3::ZERO),
            (Vec3::new(-8.0, 4.0, 8.0), Vec3::new(1.0, -1.0, -1.0).normalize()),
        ]
    }

    #[test]
    fn pmfs_sum_to_one() {
        for infinite in [0, 1, 2] {
            let lights = lights(infinite);
            let tree = LightTree::new(&lights);
            assert_eq!(tree.node_count(), 2 * 65 - 1);
            let mut rng = Pcg64Mcg::seed_from_u64(9);
            for _ in 0..200 {
                let p =
                    Vec3::new(rng.random_range(-6.0..6.0), rng.random_range(-2.0..5.0), rng.random_range(-6.0..6.0));
                let n =
                    Vec3::new(rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0))
                        .normalize();
                let sum: f64 = (0..lights.len()).map(|k| tree.pmf(p, n, k) as f64).sum();
                assert!((sum - 1.0).abs() < 1e-5, "{infinite} infinite lights, at {p} {n}: Σ pmf = {sum}");
                assert_eq!(tree.pmf(p, n, 65), 0.0, "the light of power 0");
            }
        }
    }

    /// The frequency with which `sample` picks each light is `pmf` (Pearson's χ² over the
    /// lights, pooling those expected fewer than 5 times), and `sample` reports that `pmf`.
    #[test]
    fn sample_picks_lights_with_their_pmf() {
        let lights = lights(1);
        let tree = LightTree::new(&lights);
        let pts = points();
        let alpha = sidak(0.01, pts.len());
        let n = 200_000;
        let mut rng = Pcg64Mcg::seed_from_u64(17);
        for (p, nrm) in pts {
            let mut counts = vec![0f64; lights.len()];
            for _ in 0..n {
                let u: f32 = rng.random();
                let (k, pmf, _) = tree.sample(p, nrm, u).expect("a light");
                assert_eq!(pmf, tree.pmf(p, nrm, k), "light {k} at {p}");
                counts[k] += 1.0;
            }
            let (p_value, dof) = chi2_discrete(&counts, |k| n as f64 * tree.pmf(p, nrm, k) as f64);
            assert!(p_value >= alpha, "at {p}: p = {p_value} (dof {dof})");
        }
    }

    /// Pearson's χ² of observed `counts` against `expected(k)`: its p-value and dof.
    fn chi2_discrete(counts: &[f64], expected: impl Fn(usize) -> f64) -> (f64, usize) {
        let mut cells: Vec<(f64, f64)> = (0..counts.len()).map(|k| (expected(k), counts[k])).collect();
        for &(e, o) in &cells {
            assert!(e > 0.0 || o == 0.0, "{o} samples of a light of pmf 0");
        }
        cells.sort_by(|a, b| a.0.total_cmp(&b.0));
        let (mut chi2, mut dof, mut pool) = (0.0, 0usize, (0.0, 0.0));
        for (e, o) in cells {
            if e == 0.0 {
                continue;
            }
            if e < 5.0 {
                pool = (pool.0 + e, pool.1 + o);
                if pool.0 < 5.0 {
                    continue;
                }
                let (pe, po) = std::mem::take(&mut pool);
                chi2 += (po - pe) * (po - pe) / pe;
            } else {
                chi2 += (o - e) * (o - e) / e;
            }
            dof += 1;
        }
        let dof = dof - 1;
        (gamma_q(dof as f64 / 2.0, chi2 / 2.0), dof)
    }

    #[test]
    fn a_wrong_pmf_is_rejected() {
        // The test above can fail: counts from the tree against the choice by power alone.
        let lights = lights(0);
        let tree = LightTree::new(&lights);
        let total: f32 = lights.iter().map(|l| if let LightExtent::Bounded(b) = l { b.phi } else { 0.0 }).sum();
        let (p, nrm) = points()[1];
        let mut rng = Pcg64Mcg::seed_from_u64(5);
        let n = 200_000;
        let mut counts = vec![0f64; lights.len()];
        for _ in 0..n {
            counts[tree.sample(p, nrm, rng.random()).unwrap().0] += 1.0;
        }
        let by_power = |k: usize| match lights[k] {
            LightExtent::Bounded(b) => n as f64 * (b.phi / total) as f64,
            LightExtent::Infinite(_) => 0.0,
        };
        assert!(chi2_discrete(&counts, by_power).0 < 1e-6);
    }

    #[test]
    fn one_light_is_chosen_whole_and_infinite_lights_apart() {
        let one = [LightExtent::Bounded(LightBounds::point(Vec3::ZERO, 2.0))];
        let tree = LightTree::new(&one);
        for u in [0.0, 0.5, ONE_MINUS_EPSILON] {
            assert_eq!(tree.sample(Vec3::X, Vec3::Y, u), Some((0, 1.0, u)));
        }
        assert_eq!(tree.pmf(Vec3::X, Vec3::Y, 0), 1.0);
        // Two infinite lights and the tree: a third each.
        let tree = LightTree::new(&[one[0], LightExtent::Infinite(1.0), LightExtent::Infinite(9.0)]);
        assert_eq!(tree.sample(Vec3::X, Vec3::Y, 0.1).map(|(k, p, _)| (k, p)), Some((1, 1.0 / 3.0)));
        assert_eq!(tree.sample(Vec3::X, Vec3::Y, 0.5).map(|(k, p, _)| (k, p)), Some((2, 1.0 / 3.0)));
        assert_eq!(tree.sample(Vec3::X, Vec3::Y, 0.9).map(|(k, p, _)| (k, p)), Some((0, 1.0 - 2.0 / 3.0)));
        assert_eq!(LightTree::new(&[]).sample(Vec3::X, Vec3::Y, 0.5), None);
    }

    #[test]
    fn children_alike_but_in_power_are_chosen_by_power() {
        // A quad light's two triangles: the same box and cone, different powers.
        let quad = Aabb::new(Vec3::new(-0.5, 2.0, -0.5), Vec3::new(0.5, 2.0, 0.5));
        let tri = |phi| LightExtent::Bounded(LightBounds::diffuse(quad, Vec3::NEG_Y, phi, 1.0, false));
        let other = LightExtent::Bounded(LightBounds::diffuse(quad, Vec3::NEG_Y, 2.0, 0.5, false));
        let twins = LightTree::new(&[tri(1.0), tri(3.0)]);
        assert!(twins.nodes[0].twins && !twins.nodes[1].twins && !twins.nodes[2].twins);
        assert!(!LightTree::new(&[tri(1.0), other]).nodes[0].twins, "another cone");
        let mut rng = Pcg64Mcg::seed_from_u64(7);
        for _ in 0..1000 {
            let p = Vec3::new(rng.random_range(-3.0..3.0), rng.random_range(-1.0..3.0), rng.random_range(-3.0..3.0));
            let n =
                if rng.random_bool(0.2) { Vec3::ZERO } else { Vec3::new(rng.random(), 1.0, rng.random()).normalize() };
            assert_eq!((twins.pmf(p, n, 0), twins.pmf(p, n, 1)), (0.25, 0.75), "at {p} {n}");
            // What the importances give, where they are not 0, up to rounding.
            let (l, r) = (&twins.nodes[1].bounds, &twins.nodes[2].bounds);
            let (c0, c1) = (l.importance(p, n), r.importance(p, n));
            if c0 > 0.0 {
                assert!((c0 / (c0 + c1) - 0.25).abs() < 1e-6, "at {p} {n}: {c0} {c1}");
            }
        }
    }

    #[test]
    fn importance_is_zero_behind_a_one_sided_light_only() {
        // A unit square at y = 1 facing down.
        let b = LightBounds::diffuse(
            Aabb::new(Vec3::new(-0.5, 1.0, -0.5), Vec3::new(0.5, 1.0, 0.5)),
            Vec3::NEG_Y,
            1.0,
            1.0,
            false,
        );
        assert!(b.importance(Vec3::ZERO, Vec3::Y) > 0.0);
        assert!(b.importance(Vec3::new(3.0, 0.99, 0.0), Vec3::Y) > 0.0, "below its plane, far to the side");
        assert_eq!(b.importance(Vec3::new(0.0, 2.0, 0.0), Vec3::Y), 0.0, "above it");
        assert!(LightBounds { two_sided: true, ..b }.importance(Vec3::new(0.0, 2.0, 0.0), Vec3::Y) > 0.0);
        // Closer is more important; a cone union holds both cones.
        assert!(
            b.importance(Vec3::new(0.0, 0.5, 0.0), Vec3::ZERO) > b.importance(Vec3::new(0.0, -3.0, 0.0), Vec3::ZERO)
        );
        let (w, cos) = cone_union((Vec3::X, 1.0), (Vec3::Y, 1.0));
        assert!((w - Vec3::new(1.0, 1.0, 0.0).normalize()).length() < 1e-6 && (cos - 0.5f32.sqrt()).abs() < 1e-6);
    }

    #[test]
    fn the_build_is_deterministic_and_shallow() {
        let lights = lights(1);
        let (a, b) = (LightTree::new(&lights), LightTree::new(&lights));
        assert_eq!(a.places, b.places);
        assert!(a.depth() <= 20, "depth {}", a.depth());
        // 1000 lights at one point: no split separates them, halving keeps the depth at 10.
        let same = vec![LightExtent::Bounded(LightBounds::point(Vec3::ONE, 1.0)); 1000];
        let t = LightTree::new(&same);
        assert_eq!(t.depth(), 10);
        let sum: f32 = (0..1000).map(|k| t.pmf(Vec3::ZERO, Vec3::Y, k)).sum();
        assert!((sum - 1.0).abs() < 1e-5);
    }
}
