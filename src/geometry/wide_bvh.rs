//! An 8-wide BVH with uncompressed child boxes, traversed front to back
//! with one SIMD slab test per node (AVX2 where the CPU has it, chosen at
//! run time; plain code elsewhere).
//!
//! The tree is obvhs's compressed wide BVH (SAH-collapsed from a PLOC
//! build): [`WideBvh::from_cwbvh`] keeps its topology and leaf order but
//! stores each child's exact box in floats, so a node test is six loads and
//! a dozen vector operations rather than obvhs's byte-to-float conversions,
//! and children are visited nearest first and skipped once a closer hit is
//! known. Measured on this project's speed suite (`lente bench`).
//!
//! Trees walked one ray at a time (too big for packets) are collapsed by
//! [`WideBvh::from_bvh2`] from obvhs's binary tree instead, into leaves of
//! up to eight primitives that the walk hands over whole
//! ([`WideBvh::closest_leaves`]) to be tested in SIMD lanes: on the
//! 102k-triangle mesh, incoherent closest hits +14% and any hits +10%
//! (leaves of at most three, tested one by one, made a tree a level
//! deeper; the collapse alone, without the lanes, was slower). Which
//! binary subtrees become leaves, nodes or slots is the least
//! surface-area cost's choice ([`CollapsePlan`]), not the widest child's
//! opening first that it replaced: incoherent rays another 15%.
//!
//! The slab test is conservatively rounded (pbrt's `1 + 2 gamma(3)` on the
//! far distance) and has no distance epsilon, so a primitive hit at any
//! distance, however small the scene, is never culled by its box.

use std::mem::MaybeUninit;

use obvhs::cwbvh::CwBvh;

use crate::math::{gamma, Aabb, Ray};

/// Eight children's boxes (`bounds[2 a]` the lower, `bounds[2 a + 1]` the
/// upper planes along axis `a`), their node or primitive indices, and their
/// primitive counts (0: an inner node; empty slots have an empty box).
#[derive(Clone, Copy, Debug)]
#[repr(C, align(32))]
struct WideNode {
    bounds: [[f32; 8]; 6],
    child: [u32; 8],
    count: [u8; 8],
}

impl WideNode {
    const EMPTY: WideNode = WideNode {
        bounds: [
            [f32::INFINITY; 8],
            [f32::NEG_INFINITY; 8],
            [f32::INFINITY; 8],
            [f32::NEG_INFINITY; 8],
            [f32::INFINITY; 8],
            [f32::NEG_INFINITY; 8],
        ],
        child: [0; 8],
        count: [0; 8],
    };

    /// The box around all the node's children.
    fn bounds_all(&self) -> Aabb {
        (0..8).fold(Aabb::EMPTY, |acc, slot| {
            let b = &self.bounds;
            acc.union(Aabb {
                min: crate::math::Vec3::new(b[0][slot], b[2][slot], b[4][slot]),
                max: crate::math::Vec3::new(b[1][slot], b[3][slot], b[5][slot]),
            })
        })
    }

    fn set_box(&mut self, slot: usize, b: Aabb) {
        for a in 0..3 {
            self.bounds[2 * a][slot] = b.min[a];
            self.bounds[2 * a + 1][slot] = b.max[a];
        }
    }
}

/// A subtree to visit: a node (`count == 0`) or `count` primitives from
/// `index`, with the distance at which the ray enters its box.
#[derive(Clone, Copy, Debug)]
struct Entry {
    t: f32,
    index: u32,
    count: u32,
}

impl Entry {
    /// A placeholder, overwritten before it is read.
    const UNSET: Entry = Entry {
        t: 0.0,
        index: 0,
        count: 0,
    };
}

/// The ray as the slab test wants it: origin, reciprocal direction, which
/// plane of each pair is met first, and the range.
struct SlabRay {
    o: [f32; 3],
    inv: [f32; 3],
    /// Index into `WideNode::bounds` of the near plane along each axis.
    near: [usize; 3],
    /// Byte offsets in `WideNode::bounds` of the near and far planes'
    /// rows along each axis (the AVX2 test's loads; an index scaled at
    /// every node cost two instructions a plane).
    #[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
    near_at: [usize; 3],
    #[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
    far_at: [usize; 3],
    tmin: f32,
}

impl SlabRay {
    fn new(ray: &Ray) -> SlabRay {
        let inv = ray.d.recip();
        // The far plane comes first where the direction is negative, -0
        // included (its reciprocal is -inf): the sign bit, read without a
        // branch (random directions made those branches mispredict). A NaN
        // component makes both planes' distances NaN, which the test
        // ignores, whichever plane is "near".
        let near = |a: usize| 2 * a + (ray.d[a].to_bits() >> 31) as usize;
        let near = [near(0), near(1), near(2)];
        const ROW: usize = std::mem::size_of::<[f32; 8]>();
        SlabRay {
            o: ray.o.to_array(),
            inv: inv.to_array(),
            near,
            near_at: near.map(|n| n * ROW),
            far_at: near.map(|n| (n ^ 1) * ROW),
            tmin: ray.tmin,
        }
    }
}

/// Widens the far distance of a slab test by its rounding error (pbrt-v4,
/// `Bounds3::IntersectP`).
const FAR_SCALE: f32 = 1.0 + 2.0 * gamma(3);

/// Which of a node's children the ray meets within `[tmin, tmax]`, as a
/// bit mask, and the distance at which it enters each.
trait NodeTest {
    fn test(node: &WideNode, ray: &SlabRay, tmax: f32) -> (u32, [f32; 8]);
}

/// The slab test one lane at a time (any CPU; compilers vectorise it).
struct Portable;

impl NodeTest for Portable {
    #[inline(always)]
    fn test(node: &WideNode, r: &SlabRay, tmax: f32) -> (u32, [f32; 8]) {
        let mut tnear = [0.0f32; 8];
        let mut mask = 0u32;
        for (i, tn) in tnear.iter_mut().enumerate() {
            let mut lo = r.tmin;
            let mut hi = tmax;
            for a in 0..3 {
                let n = r.near[a];
                let t0 = (node.bounds[n][i] - r.o[a]) * r.inv[a];
                let t1 = (node.bounds[n ^ 1][i] - r.o[a]) * r.inv[a] * FAR_SCALE;
                // NaN (0 x inf: the origin on a plane of a flat box, moving
                // along it) leaves the range as it is: conservative.
                if t0 > lo {
                    lo = t0;
                }
                if t1 < hi {
                    hi = t1;
                }
            }
            *tn = lo;
            mask |= u32::from(lo <= hi) << i;
        }
        (mask, tnear)
    }
}

/// The slab test for eight children at once with AVX2.
#[cfg(target_arch = "x86_64")]
struct Avx2;

#[cfg(target_arch = "x86_64")]
impl NodeTest for Avx2 {
    #[inline(always)]
    fn test(node: &WideNode, r: &SlabRay, tmax: f32) -> (u32, [f32; 8]) {
        // SAFETY: only instantiated inside functions compiled for AVX2,
        // which run only after the CPU was seen to support it.
        unsafe { slab_test_avx2(node, r, tmax) }
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
unsafe fn slab_test_avx2(node: &WideNode, r: &SlabRay, tmax: f32) -> (u32, [f32; 8]) {
    use std::arch::x86_64::*;
    let mut lo = _mm256_set1_ps(r.tmin);
    let mut hi = _mm256_set1_ps(tmax);
    let scale = _mm256_set1_ps(FAR_SCALE);
    let rows = node.bounds.as_ptr().cast::<u8>();
    for a in 0..3 {
        let o = _mm256_set1_ps(r.o[a]);
        let inv = _mm256_set1_ps(r.inv[a]);
        // SAFETY: the offsets are those of rows of `bounds` (`SlabRay::new`),
        // 32-byte aligned arrays of eight floats.
        let near = _mm256_load_ps(rows.add(r.near_at[a]).cast());
        let far = _mm256_load_ps(rows.add(r.far_at[a]).cast());
        let t0 = _mm256_mul_ps(_mm256_sub_ps(near, o), inv);
        let t1 = _mm256_mul_ps(_mm256_mul_ps(_mm256_sub_ps(far, o), inv), scale);
        // max/min return their second operand when either is NaN: a NaN
        // distance leaves the range as it is (see `Portable`).
        lo = _mm256_max_ps(t0, lo);
        hi = _mm256_min_ps(t1, hi);
    }
    let hit = _mm256_cmp_ps::<_CMP_LE_OQ>(lo, hi);
    let mut tnear = [0.0f32; 8];
    _mm256_storeu_ps(tnear.as_mut_ptr(), lo);
    (_mm256_movemask_ps(hit) as u32, tnear)
}

/// The traversal stack: a fixed array, left uninitialised (it is written
/// before it is read). A node visit pops one entry and pushes at most 7,
/// so a tree of depth `d` never holds more than `7 d` entries: trees that
/// fit (`WideBvh::fixed_stack`, set by [`WideBvh::from_nodes`]) are walked
/// with this stack and no bounds check; deeper ones, which no sane scene
/// builds, with [`VecStack`].
/// The packet walks keep their entries (`PacketEntry`) in one too: they
/// push every child met, up to eight after a pop, so they hold at most
/// `7 d + 1` entries, which fits as well.
struct FixedStack<E = Entry> {
    fixed: [MaybeUninit<E>; FIXED_ENTRIES],
    len: usize,
}

/// Where a traversal keeps the subtrees it has still to visit.
trait TraversalStack<E = Entry> {
    fn new() -> Self;
    fn push(&mut self, e: E);
    fn pop(&mut self) -> Option<E>;
}

/// The entries a [`FixedStack`] holds.
const FIXED_ENTRIES: usize = 256;

/// The deepest tree whose traversal fits in [`FIXED_ENTRIES`].
const FIXED_DEPTH: usize = FIXED_ENTRIES / 7;

impl<E: Copy> TraversalStack<E> for FixedStack<E> {
    #[inline(always)]
    fn new() -> FixedStack<E> {
        FixedStack {
            fixed: [const { MaybeUninit::uninit() }; FIXED_ENTRIES],
            len: 0,
        }
    }

    #[inline(always)]
    fn push(&mut self, e: E) {
        self.push_if(e, true);
    }

    #[inline(always)]
    fn pop(&mut self) -> Option<E> {
        if self.len == 0 {
            return None;
        }
        self.len -= 1;
        // SAFETY: entries below `len` were written by `push`.
        Some(unsafe { self.fixed.get_unchecked(self.len).assume_init() })
    }
}

impl<E: Copy> FixedStack<E> {
    /// Writes `e` on top and keeps it only if `keep`: a push without a
    /// branch, for entries kept at random (the packet walks' children,
    /// whose per-slot branch mispredicted); `push` is it with `true`.
    #[inline(always)]
    fn push_if(&mut self, e: E, keep: bool) {
        debug_assert!(self.len < FIXED_ENTRIES);
        // SAFETY: the write is at `len`. Only trees of depth <= FIXED_DEPTH
        // are walked with this stack, and their walks hold at most
        // 7 * FIXED_DEPTH + 1 < FIXED_ENTRIES entries (see the type).
        unsafe { self.fixed.get_unchecked_mut(self.len).write(e) };
        self.len += usize::from(keep);
    }
}

/// The stack of walks through trees too deep for [`FixedStack`].
struct VecStack(Vec<Entry>);

impl TraversalStack for VecStack {
    fn new() -> VecStack {
        VecStack(Vec::new())
    }

    fn push(&mut self, e: Entry) {
        self.0.push(e);
    }

    fn pop(&mut self) -> Option<Entry> {
        self.0.pop()
    }
}

/// The children of `node` in `mask`: none, one (returned, to visit next),
/// or several (all but the nearest pushed, farthest first, so they pop
/// nearest first; the nearest returned).
#[inline(always)]
fn push_nearest_last<S: TraversalStack>(
    stack: &mut S,
    node: &WideNode,
    mut mask: u32,
    tnear: &[f32; 8],
) -> Option<Entry> {
    let entry = |slot: usize| Entry {
        t: tnear[slot],
        index: node.child[slot],
        count: node.count[slot] as u32,
    };
    if mask == 0 {
        return None;
    }
    let first = mask.trailing_zeros() as usize;
    mask &= mask - 1;
    if mask == 0 {
        return Some(entry(first));
    }
    if mask & (mask - 1) == 0 {
        // Two children, the most common case after one: the insertion
        // below in one comparison (on a tie the later slot goes first, as
        // there).
        let (a, b) = (entry(first), entry(mask.trailing_zeros() as usize));
        return Some(if a.t < b.t {
            stack.push(b);
            a
        } else {
            stack.push(a);
            b
        });
    }
    // Filled from a constant (a few vector stores) rather than with the
    // first entry eight times (24 scalar stores a visit).
    let mut hits = [Entry::UNSET; 8];
    hits[0] = entry(first);
    let mut n = 1;
    while mask != 0 {
        let slot = mask.trailing_zeros() as usize;
        mask &= mask - 1;
        let e = entry(slot);
        // Insertion into `hits`, kept sorted farthest first.
        let mut j = n;
        while j > 0 && hits[j - 1].t < e.t {
            hits[j] = hits[j - 1];
            j -= 1;
        }
        hits[j] = e;
        n += 1;
    }
    for h in &hits[..n - 1] {
        stack.push(*h);
    }
    Some(hits[n - 1])
}

/// What a leaf's test costs, against a node's eight box tests at 1 (both
/// times the box's surface area, the chance a ray meets it).
#[derive(Clone, Copy, Debug)]
pub enum LeafCost {
    /// The same for any number of primitives: tested together in lanes.
    Lanes(f32),
    /// So much a primitive: tested one by one.
    PerPrimitive(f32),
}

/// Which binary subtrees become the eight-wide tree's slots: the least
/// surface-area cost over every way to cut the binary tree into nodes of
/// up to eight slots and leaves of up to `leaf_max` primitives (Ylitie,
/// Karras and Laine 2017's dynamic program, with leaves tested in lanes
/// priced as one test). On the 102k-triangle mesh, against opening the
/// widest child first: incoherent closest hits about 15% faster (1.34x-
/// 1.41x Embree's time against 1.53x-1.65x), the blob's render 1-6.5%
/// (four alternating pairs, 4% on average).
struct CollapsePlan {
    /// Per binary node: whether it is a leaf where it takes one slot (else
    /// a wide node of its own).
    leaf: Vec<bool>,
    /// Per binary node and number of slots k (index k - 1): the slots its
    /// left child gets where it is split among k, 0 where it takes one.
    split: Vec<[u8; 8]>,
}

impl CollapsePlan {
    fn new(bvh: &obvhs::bvh2::Bvh2, leaf_max: u32, leaf_cost: LeafCost) -> CollapsePlan {
        let n = bvh.nodes.len();
        // Each node once, parents first (the right child's subtree before
        // the left's), with what the costs need: backwards, that is an
        // order in which a node's two children are the last two results
        // not yet taken, so they live on a stack as deep as the tree, and
        // the nodes are read once (a second pass over them in this order,
        // with tables by node, made a million-triangle build 17% slower
        // than the widest-first collapse; this way 4%).
        let mut pre = Vec::with_capacity(n);
        let mut stack = vec![0u32];
        while let Some(id) = stack.pop() {
            let node = &bvh.nodes[id as usize];
            let prims = if node.is_leaf() {
                node.prim_count
            } else {
                stack.extend([node.first_index, node.first_index + 1]);
                0
            };
            pre.push((id, prims, node.aabb.half_area()));
        }
        // Each node also costs a hair more than its area, so that of
        // trees of equal cost the one with fewest nodes wins: where boxes
        // have no area (primitives on a line, or all at one point) every
        // cost would be zero, and a chain of a binary tree would stay a
        // chain of two-slot nodes.
        let root_area = pre.first().map_or(0.0, |&(_, _, a)| a);
        let per_node = (root_area * f32::EPSILON).max(f32::MIN_POSITIVE);
        let mut leaf = vec![false; n];
        let mut split = vec![[0u8; 8]; n];
        // Per subtree done: its primitives and its least cost in at most k
        // slots (index k - 1).
        let mut done: Vec<(u32, [f32; 8])> = Vec::new();
        for &(id, prims, area) in pre.iter().rev() {
            let id = id as usize;
            let children = (prims == 0).then(|| {
                let right = done.pop().expect("a node's right child is done");
                let left = done.pop().expect("a node's left child is done");
                (left, right)
            });
            let under = children.map_or(prims, |(l, r)| l.0 + r.0);
            let as_leaf = match leaf_cost {
                _ if under > leaf_max => f32::INFINITY,
                LeafCost::Lanes(c) => c * area,
                LeafCost::PerPrimitive(c) => c * area * under as f32,
            };
            let Some(((_, l), (_, r))) = children else {
                leaf[id] = true;
                done.push((under, [as_leaf; 8]));
                continue;
            };
            // The two children in at most k slots together, and the left
            // one's share (1 where no cost compares, as with NaN boxes).
            let mut apart = [f32::INFINITY; 8];
            let mut share = [1u8; 8];
            for k in 2..=8 {
                for kl in 1..k {
                    let c = l[kl - 1] + r[k - kl - 1];
                    if c < apart[k - 1] {
                        apart[k - 1] = c;
                        share[k - 1] = kl as u8;
                    }
                }
            }
            let as_node = area + per_node + apart[7];
            leaf[id] = as_leaf <= as_node;
            let one = as_leaf.min(as_node);
            let mut best = [one; 8];
            for k in 2..=8 {
                // A wide node of its own (eight slots) always splits.
                if apart[k - 1] < one || (k == 8 && !leaf[id]) {
                    best[k - 1] = apart[k - 1];
                    split[id][k - 1] = share[k - 1];
                }
            }
            done.push((under, best));
        }
        CollapsePlan { leaf, split }
    }

    /// The slots of `id`'s subtree in at most `k` slots, appended to
    /// `kids` from `n` on.
    fn expand(
        &self,
        bvh: &obvhs::bvh2::Bvh2,
        id: u32,
        k: usize,
        kids: &mut [u32; 8],
        n: &mut usize,
    ) {
        let kl = self.split[id as usize][k - 1] as usize;
        if kl == 0 {
            kids[*n] = id;
            *n += 1;
            return;
        }
        let first = bvh.nodes[id as usize].first_index;
        self.expand(bvh, first, kl, kids, n);
        self.expand(bvh, first + 1, k - kl, kids, n);
    }
}

/// The 8-wide BVH over primitives `0..n` (in the order of the `CwBvh`'s
/// `primitive_indices`, which the caller lays its primitives out in).
pub struct WideBvh {
    nodes: Vec<WideNode>,
    /// Whether the tree is shallow enough for [`FixedStack`].
    fixed_stack: bool,
}

/// The root node (stored first), where every traversal starts.
const ROOT: Entry = Entry {
    t: 0.0,
    index: 0,
    count: 0,
};

impl WideBvh {
    /// Converts obvhs's tree. `boxes[i]` bounds primitive `i` in leaf order;
    /// child boxes are recomputed from them exactly (obvhs's are quantised).
    pub fn from_cwbvh(cw: &CwBvh, boxes: &[Aabb]) -> WideBvh {
        let mut nodes = vec![WideNode::EMPTY; cw.nodes.len()];
        // Parents before children (depth-first from the root), then filled
        // in reverse so every child's box is known before its parent's.
        let mut order = Vec::with_capacity(cw.nodes.len());
        let mut todo = if cw.nodes.is_empty() {
            vec![]
        } else {
            vec![0u32]
        };
        while let Some(ni) = todo.pop() {
            order.push(ni);
            let n = &cw.nodes[ni as usize];
            for below in 0..n.imask.count_ones() {
                todo.push(n.child_base_idx + below);
            }
        }
        let mut node_box = vec![Aabb::EMPTY; cw.nodes.len()];
        for &ni in order.iter().rev() {
            let n = &cw.nodes[ni as usize];
            let out = &mut nodes[ni as usize];
            let mut total = Aabb::EMPTY;
            for slot in 0..8 {
                let meta = n.child_meta[slot];
                if meta == 0 {
                    continue;
                }
                let b = if n.imask & (1 << slot) != 0 {
                    let below = (n.imask as u32 & ((1u32 << slot) - 1)).count_ones();
                    let child = n.child_base_idx + below;
                    out.child[slot] = child;
                    node_box[child as usize]
                } else {
                    let first = n.primitive_base_idx + (meta & 0b1_1111) as u32;
                    let count = (meta >> 5).count_ones();
                    out.child[slot] = first;
                    out.count[slot] = count as u8;
                    boxes[first as usize..(first + count) as usize]
                        .iter()
                        .fold(Aabb::EMPTY, |acc, b| acc.union(*b))
                };
                out.set_box(slot, b);
                total = total.union(b);
            }
            node_box[ni as usize] = total;
        }
        WideBvh::from_nodes(nodes)
    }

    /// Collapses obvhs's binary tree into eight-wide nodes whose leaves
    /// hold up to `leaf_max` primitives, each binary subtree made a leaf,
    /// a node or split among its parent's slots as the least
    /// surface-area cost says ([`CollapsePlan`]; `leaf_cost` prices a
    /// leaf's test against a node's). `boxes[i]` bounds input primitive
    /// `i`; returns the tree and its leaf order (the input index of each
    /// of its primitives `0..n`), or `None` if a leaf of the binary tree
    /// holds more than `leaf_max` (at most 255) primitives.
    pub fn from_bvh2(
        bvh: &obvhs::bvh2::Bvh2,
        boxes: &[Aabb],
        leaf_max: u32,
        leaf_cost: LeafCost,
    ) -> Option<(WideBvh, Vec<u32>)> {
        let leaf_max = leaf_max.min(u8::MAX as u32);
        let too_big = |n: &obvhs::bvh2::node::Bvh2Node| n.is_leaf() && n.prim_count > leaf_max;
        if bvh.nodes.is_empty() || bvh.nodes.iter().any(too_big) {
            return None;
        }
        let mut order = Vec::with_capacity(bvh.primitive_indices.len());
        let plan = CollapsePlan::new(bvh, leaf_max, leaf_cost);
        let mut nodes = vec![WideNode::EMPTY];
        // The binary subtree each wide node stands for, parents first.
        let mut todo = vec![(0usize, 0u32)];
        let mut filled = Vec::new();
        let mut prims = Vec::new();
        let mut stack = Vec::new();
        while let Some((wi, root)) = todo.pop() {
            filled.push(wi);
            let mut kids = [root; 8];
            let mut n = 0;
            if plan.leaf[root as usize] {
                // The whole tree in one leaf (a wide node's own subtree is
                // never one).
                n = 1;
            } else {
                plan.expand(bvh, root, 8, &mut kids, &mut n);
            }
            for (slot, &kid) in kids[..n].iter().enumerate() {
                if plan.leaf[kid as usize] {
                    // The subtree's primitives, left to right.
                    prims.clear();
                    stack.push(kid);
                    while let Some(id) = stack.pop() {
                        let b = &bvh.nodes[id as usize];
                        if b.is_leaf() {
                            let first = b.first_index as usize;
                            prims.extend_from_slice(
                                &bvh.primitive_indices[first..first + b.prim_count as usize],
                            );
                        } else {
                            stack.extend([b.first_index + 1, b.first_index]);
                        }
                    }
                    nodes[wi].child[slot] = order.len() as u32;
                    nodes[wi].count[slot] = prims.len() as u8;
                    order.extend_from_slice(&prims);
                } else {
                    nodes[wi].child[slot] = nodes.len() as u32;
                    todo.push((nodes.len(), kid));
                    nodes.push(WideNode::EMPTY);
                }
            }
        }
        // Boxes bottom up: every child was filled after its parent.
        for &wi in filled.iter().rev() {
            for slot in 0..8 {
                let (child, count) = (nodes[wi].child[slot] as usize, nodes[wi].count[slot]);
                let b = if count > 0 {
                    order[child..child + count as usize]
                        .iter()
                        .fold(Aabb::EMPTY, |acc, &i| acc.union(boxes[i as usize]))
                } else if child > 0 {
                    nodes[child].bounds_all()
                } else {
                    continue;
                };
                nodes[wi].set_box(slot, b);
            }
        }
        Some((WideBvh::from_nodes(nodes), order))
    }

    /// The tree of `nodes` (the root first), with the stack its walks
    /// take chosen by its depth.
    fn from_nodes(nodes: Vec<WideNode>) -> WideBvh {
        let mut bvh = WideBvh {
            nodes,
            fixed_stack: false,
        };
        bvh.fixed_stack = bvh.depth() <= FIXED_DEPTH;
        bvh
    }

    /// Every leaf, as `(first, count)`: its primitives' range.
    pub fn leaves(&self) -> impl Iterator<Item = (u32, u32)> + '_ {
        self.nodes.iter().flat_map(|n| {
            (0..8)
                .filter(|&slot| n.count[slot] > 0)
                .map(|slot| (n.child[slot], u32::from(n.count[slot])))
        })
    }

    /// The number of nodes on the longest path from the root to a leaf
    /// (0 for an empty tree): what a traversal's stack must hold.
    pub fn depth(&self) -> usize {
        let mut deepest = 0;
        let mut todo = if self.nodes.is_empty() {
            vec![]
        } else {
            vec![(0u32, 1usize)]
        };
        while let Some((ni, d)) = todo.pop() {
            deepest = deepest.max(d);
            let n = &self.nodes[ni as usize];
            for slot in 0..8 {
                let inner = n.count[slot] == 0 && n.bounds[0][slot] <= n.bounds[1][slot];
                if inner {
                    todo.push((n.child[slot], d + 1));
                }
            }
        }
        deepest
    }

    /// Visits, nearest first, every primitive whose leaf box the ray meets
    /// before the closest hit so far: `hit(prim, tmax)` returns the
    /// distance of a hit closer than `tmax`. True if anything was hit.
    /// (The tests' form: the renderer walks leaf by leaf,
    /// [`WideBvh::closest_leaves`].)
    #[cfg(test)]
    pub fn closest<F: FnMut(usize, f32) -> Option<f32>>(&self, ray: &Ray, mut hit: F) -> bool {
        self.closest_leaves(
            ray,
            #[inline(always)]
            |first, count, mut tmax| {
                let mut found = None;
                for p in first..first + count {
                    if let Some(t) = hit(p as usize, tmax) {
                        tmax = t;
                        found = Some(t);
                    }
                }
                found
            },
        )
    }

    /// [`WideBvh::closest`] a leaf at a time: `leaf(first, count, tmax)`
    /// tests primitives `first..first + count` as the primitive loop
    /// would, in order, and returns the closest hit's distance below
    /// `tmax`.
    #[inline]
    pub fn closest_leaves<F: FnMut(u32, u32, f32) -> Option<f32>>(
        &self,
        ray: &Ray,
        leaf: F,
    ) -> bool {
        if !self.fixed_stack {
            return self.closest_with::<Portable, VecStack, F>(ray, leaf);
        }
        #[cfg(target_arch = "x86_64")]
        use super::lanes::PacketIsa;
        #[cfg(target_arch = "x86_64")]
        match PacketIsa::detect() {
            // SAFETY: the CPU supports AVX-512VL.
            Some(PacketIsa::Avx512Vl | PacketIsa::Avx512) => {
                return unsafe { self.closest_avx512(ray, leaf) }
            }
            // SAFETY: the CPU supports AVX2.
            Some(PacketIsa::Avx2) => return unsafe { self.closest_avx2(ray, leaf) },
            None => {}
        }
        self.closest_with::<Portable, FixedStack, F>(ray, leaf)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,avx512f,avx512vl")]
    unsafe fn closest_avx512<F: FnMut(u32, u32, f32) -> Option<f32>>(
        &self,
        ray: &Ray,
        leaf: F,
    ) -> bool {
        self.closest_with::<Avx2, FixedStack, F>(ray, leaf)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn closest_avx2<F: FnMut(u32, u32, f32) -> Option<f32>>(
        &self,
        ray: &Ray,
        leaf: F,
    ) -> bool {
        self.closest_with::<Avx2, FixedStack, F>(ray, leaf)
    }

    /// The closest-hit walk with node test `T` and stack `S` (a
    /// [`FixedStack`] only for trees that fit it).
    #[inline(always)]
    fn closest_with<T: NodeTest, S: TraversalStack, F: FnMut(u32, u32, f32) -> Option<f32>>(
        &self,
        ray: &Ray,
        mut leaf: F,
    ) -> bool {
        if self.nodes.is_empty() {
            return false;
        }
        let r = SlabRay::new(ray);
        let mut tmax = ray.tmax;
        let mut found = false;
        let mut stack = S::new();
        let mut next = Some(ROOT);
        while let Some(e) = next.take().or_else(|| stack.pop()) {
            // The box distances and the primitives' are rounded apart: a
            // box entered a rounding error beyond the closest hit may still
            // hold a hit as close.
            let reach = tmax * FAR_SCALE;
            if e.t > reach {
                continue;
            }
            if e.count > 0 {
                if let Some(t) = leaf(e.index, e.count, tmax) {
                    tmax = t;
                    found = true;
                }
                continue;
            }
            let node = &self.nodes[e.index as usize];
            let (mask, tnear) = T::test(node, &r, reach);
            next = push_nearest_last(&mut stack, node, mask, &tnear);
        }
        found
    }

    /// True as soon as `hit(prim, tmax)` reports a hit for a primitive
    /// whose leaf box the ray meets (occlusion queries; nearest child
    /// first, but any hit ends the search).
    /// (The tests' form: the renderer walks leaf by leaf,
    /// [`WideBvh::any_leaves`].)
    #[cfg(test)]
    pub fn any<F: FnMut(usize, f32) -> bool>(&self, ray: &Ray, mut hit: F) -> bool {
        self.any_leaves(
            ray,
            #[inline(always)]
            |first, count, tmax| (first..first + count).any(|p| hit(p as usize, tmax)),
        )
    }

    /// [`WideBvh::any`] a leaf at a time: `leaf(first, count, tmax)` is
    /// true if one of primitives `first..first + count` is hit.
    #[inline]
    pub fn any_leaves<F: FnMut(u32, u32, f32) -> bool>(&self, ray: &Ray, leaf: F) -> bool {
        if !self.fixed_stack {
            return self.any_with::<Portable, VecStack, F>(ray, leaf);
        }
        #[cfg(target_arch = "x86_64")]
        use super::lanes::PacketIsa;
        #[cfg(target_arch = "x86_64")]
        match PacketIsa::detect() {
            // SAFETY: the CPU supports AVX-512VL.
            Some(PacketIsa::Avx512Vl | PacketIsa::Avx512) => {
                return unsafe { self.any_avx512(ray, leaf) }
            }
            // SAFETY: the CPU supports AVX2.
            Some(PacketIsa::Avx2) => return unsafe { self.any_avx2(ray, leaf) },
            None => {}
        }
        self.any_with::<Portable, FixedStack, F>(ray, leaf)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,avx512f,avx512vl")]
    unsafe fn any_avx512<F: FnMut(u32, u32, f32) -> bool>(&self, ray: &Ray, leaf: F) -> bool {
        self.any_with::<Avx2, FixedStack, F>(ray, leaf)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn any_avx2<F: FnMut(u32, u32, f32) -> bool>(&self, ray: &Ray, leaf: F) -> bool {
        self.any_with::<Avx2, FixedStack, F>(ray, leaf)
    }

    /// The any-hit walk with node test `T` and stack `S`.
    #[inline(always)]
    fn any_with<T: NodeTest, S: TraversalStack, F: FnMut(u32, u32, f32) -> bool>(
        &self,
        ray: &Ray,
        mut leaf: F,
    ) -> bool {
        if self.nodes.is_empty() {
            return false;
        }
        let r = SlabRay::new(ray);
        let mut stack = S::new();
        let mut next = Some(ROOT);
        // Nearest child first, as for the closest hit: near occluders end
        // the search sooner.
        while let Some(e) = next.take().or_else(|| stack.pop()) {
            if e.count > 0 {
                if leaf(e.index, e.count, ray.tmax) {
                    return true;
                }
                continue;
            }
            let node = &self.nodes[e.index as usize];
            let (mask, tnear) = T::test(node, &r, ray.tmax);
            next = push_nearest_last(&mut stack, node, mask, &tnear);
        }
        false
    }
}

/// A subtree a packet is still to visit, with the lanes whose rays meet
/// its box and where each enters it. The walks push every child met and
/// pop each entry field by field (no entry is copied whole: a 32-byte
/// load over the three 4-byte fields just stored could not be forwarded
/// from them, which the entry held back for the next visit did).
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy)]
struct PacketEntry<F> {
    tnear: F,
    index: u32,
    count: u32,
    lanes: u32,
}

/// The slab test of `node`'s child `slot` for every lane of packet `p`
/// within `[tmin, hi]`: which lanes meet its box, as bits, and where each
/// enters it. The one-ray test's operations (its far planes widened by
/// `FAR_SCALE`; a NaN distance leaves the range as it is), the near plane
/// of each lane chosen by its direction's sign.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn packet_slab_test<L: super::lanes::Lanes>(
    p: &super::packet::RayPacket<L>,
    node: &WideNode,
    slot: usize,
    hi: L::F,
) -> (u32, L::F) {
    let l = p.l;
    let scale = l.splat(FAR_SCALE);
    let (mut lo, mut hi) = (p.tmin, hi);
    for a in 0..3 {
        let lower = l.splat(node.bounds[2 * a][slot]);
        let upper = l.splat(node.bounds[2 * a + 1][slot]);
        let t_lower = (lower - p.o[a]) * p.inv[a];
        let t_upper = (upper - p.o[a]) * p.inv[a];
        let t0 = l.blend(t_lower, t_upper, p.neg[a]);
        let t1 = l.blend(t_upper, t_lower, p.neg[a]) * scale;
        lo = l.max(t0, lo);
        hi = l.min(t1, hi);
    }
    (l.bits(l.le(lo, hi)), lo)
}

#[cfg(target_arch = "x86_64")]
impl WideBvh {
    /// Whether the packet walks can take this tree (their stack is
    /// [`FixedStack`]'s size).
    pub fn packet_walkable(&self) -> bool {
        self.fixed_stack
    }

    /// The any-hit walk of a packet of rays: every subtree whose box the
    /// ray of a lane not yet blocked meets within its range is visited,
    /// children in slot order, and `hit(prim, lanes)` tells which of the
    /// rays in `lanes` the leaf's primitive blocks. Returns the blocked
    /// lanes. Only for trees that are [`WideBvh::packet_walkable`].
    #[inline(always)]
    pub fn any_packet<L: super::lanes::Lanes, F: FnMut(usize, u32) -> u32>(
        &self,
        p: &super::packet::RayPacket<L>,
        mut hit: F,
    ) -> u32 {
        assert!(self.fixed_stack);
        if self.nodes.is_empty() {
            return 0;
        }
        let mut stack = FixedStack::<PacketEntry<L::F>>::new();
        let mut open = p.live;
        stack.push(PacketEntry {
            tnear: p.l.zero(),
            index: ROOT.index,
            count: 0,
            lanes: p.live,
        });
        while let Some(e) = stack.pop() {
            let lanes = e.lanes & open;
            if lanes == 0 {
                continue;
            }
            if e.count > 0 {
                for prim in e.index..e.index + e.count {
                    open &= !hit(prim as usize, lanes & open);
                    if lanes & open == 0 {
                        break;
                    }
                }
                if open == 0 {
                    break;
                }
                continue;
            }
            let node = &self.nodes[e.index as usize];
            for slot in (0..8).rev() {
                let (meets, _) = packet_slab_test(p, node, slot, p.tmax);
                let meets = meets & lanes;
                // Pushed last to first, popped in slot order.
                stack.push_if(
                    PacketEntry {
                        tnear: p.l.zero(),
                        index: node.child[slot],
                        count: node.count[slot] as u32,
                        lanes: meets,
                    },
                    meets != 0,
                );
            }
        }
        p.live & !open
    }

    /// The closest-hit walk of a packet of rays: every subtree whose box
    /// one of the packet's rays meets before that ray's closest hit so far
    /// (`tmax`, one lane per ray) is visited, and `hit(prim, lanes, tmax)`
    /// tests a leaf's primitive against the rays in `lanes`, lowering
    /// their lanes of `tmax` where it hits closer. A node's children are
    /// visited in slot order (nearest first along one lane's ray cost the
    /// Cornell box 1% more instructions). Only for trees that are
    /// [`WideBvh::packet_walkable`].
    #[inline(always)]
    pub fn closest_packet<L: super::lanes::Lanes, F: FnMut(usize, u32, &mut L::F)>(
        &self,
        p: &super::packet::RayPacket<L>,
        tmax: &mut L::F,
        mut hit: F,
    ) {
        assert!(self.fixed_stack);
        if self.nodes.is_empty() {
            return;
        }
        let l = p.l;
        let scale = l.splat(FAR_SCALE);
        let mut stack = FixedStack::<PacketEntry<L::F>>::new();
        stack.push(PacketEntry {
            tnear: l.splat(f32::NEG_INFINITY),
            index: ROOT.index,
            count: 0,
            lanes: p.live,
        });
        while let Some(e) = stack.pop() {
            // As the one-ray walk: a box entered a rounding error beyond
            // the closest hit may still hold a hit as close.
            let reach = *tmax * scale;
            let lanes = e.lanes & l.bits(l.le(e.tnear, reach));
            if lanes == 0 {
                continue;
            }
            if e.count > 0 {
                for prim in e.index..e.index + e.count {
                    hit(prim as usize, lanes, tmax);
                }
                continue;
            }
            let node = &self.nodes[e.index as usize];
            for slot in (0..8).rev() {
                let (meets, lo) = packet_slab_test(p, node, slot, reach);
                let meets = meets & lanes;
                // Pushed last to first, popped in slot order.
                stack.push_if(
                    PacketEntry {
                        tnear: lo,
                        index: node.child[slot],
                        count: node.count[slot] as u32,
                        lanes: meets,
                    },
                    meets != 0,
                );
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{intersect_triangle, PackedTriangle, RayShear};
    use crate::math::Vec3;
    use crate::sampling::Sampler;
    use glam::Vec3A;
    use obvhs::{aabb::Aabb as OAabb, cwbvh::builder::build_cwbvh, BvhBuildParams};

    struct Boxed(OAabb);
    impl obvhs::Boundable for Boxed {
        fn aabb(&self) -> OAabb {
            self.0
        }
    }

    /// Triangles of every awkward kind: random, axis-aligned (flat boxes),
    /// repeated, tiny, and on a grid shared with the rays' origins.
    fn soup(n: usize) -> Vec<[Vec3; 3]> {
        let mut s = Sampler::for_pixel_sample(3, 1, 2, 0);
        let mut v = |scale: f32| (Vec3::new(s.next_1d(), s.next_1d(), s.next_1d()) - 0.5) * scale;
        let mut tris = Vec::new();
        for i in 0..n {
            let c = v(8.0);
            let tri = match i % 4 {
                0 => [c, c + v(1.0), c + v(1.0)],
                // In the plane z = round(c.z): a flat box.
                1 => {
                    let z = c.z.round();
                    let (a, b) = (v(1.0), v(1.0));
                    [
                        Vec3::new(c.x, c.y, z),
                        Vec3::new(c.x + a.x, c.y + a.y, z),
                        Vec3::new(c.x + b.x, c.y + b.y, z),
                    ]
                }
                2 => [c, c + v(1e-4), c + v(1e-4)],
                _ => tris[i - 3],
            };
            tris.push(tri);
        }
        tris
    }

    /// The triangles' boxes, and the same as obvhs's builders take them.
    fn boxes_of(tris: &[[Vec3; 3]]) -> (Vec<Aabb>, Vec<Boxed>) {
        let boxes: Vec<Aabb> = tris
            .iter()
            .map(|t| Aabb {
                min: t[0].min(t[1]).min(t[2]),
                max: t[0].max(t[1]).max(t[2]),
            })
            .collect();
        let o: Vec<Boxed> = boxes
            .iter()
            .map(|b| Boxed(OAabb::new(Vec3A::from(b.min), Vec3A::from(b.max))))
            .collect();
        (boxes, o)
    }

    fn build(tris: &[[Vec3; 3]]) -> (WideBvh, Vec<[Vec3; 3]>) {
        let (boxes, o) = boxes_of(tris);
        let cw = build_cwbvh(&o, BvhBuildParams::medium_build(), &mut Default::default());
        let order: Vec<usize> = cw.primitive_indices.iter().map(|&i| i as usize).collect();
        let leaf_boxes: Vec<Aabb> = order.iter().map(|&i| boxes[i]).collect();
        let leaf_tris = order.iter().map(|&i| tris[i]).collect();
        (WideBvh::from_cwbvh(&cw, &leaf_boxes), leaf_tris)
    }

    /// obvhs's binary tree over `o`, a primitive a leaf, as
    /// [`WideBvh::from_bvh2`] takes it.
    fn binary_tree(o: &[Boxed]) -> obvhs::bvh2::Bvh2 {
        let params = BvhBuildParams {
            max_prims_per_leaf: 1,
            ..BvhBuildParams::medium_build()
        };
        obvhs::bvh2::builder::build_bvh2(o, params, &mut Default::default())
    }

    /// As `build`, by [`WideBvh::from_bvh2`]: leaves of up to eight.
    fn build_collapsed(tris: &[[Vec3; 3]]) -> (WideBvh, Vec<[Vec3; 3]>) {
        let (boxes, o) = boxes_of(tris);
        let b2 = binary_tree(&o);
        let (bvh, order) =
            WideBvh::from_bvh2(&b2, &boxes, 8, LeafCost::Lanes(1.5)).expect("leaves of one");
        let mut seen = vec![false; tris.len()];
        for &i in &order {
            assert!(!std::mem::replace(&mut seen[i as usize], true), "{i} twice");
        }
        assert!(seen.iter().all(|&s| s), "every primitive in a leaf");
        let leaf_tris = order.iter().map(|&i| tris[i as usize]).collect();
        (bvh, leaf_tris)
    }

    fn rays(n: usize) -> Vec<Ray> {
        let mut s = Sampler::for_pixel_sample(5, 0, 0, 0);
        (0..n)
            .map(|i| {
                let mut o = Vec3::new(s.next_1d(), s.next_1d(), s.next_1d()) * 12.0 - 6.0;
                let mut d = Vec3::new(s.next_1d(), s.next_1d(), s.next_1d()) - 0.5;
                // Axis-parallel rays, some starting on a flat box's plane.
                if i % 3 == 0 {
                    d.x = 0.0;
                    d.y = if i % 2 == 0 { 0.0 } else { -0.0 };
                    o.z = o.z.round();
                }
                Ray::with_range(o, d.normalize(), 0.0, f32::INFINITY)
            })
            .collect()
    }

    fn brute(tris: &[[Vec3; 3]], ray: &Ray) -> Option<f32> {
        let sh = RayShear::new(ray.o, ray.d);
        tris.iter()
            .filter_map(|t| {
                intersect_triangle(
                    &sh,
                    &PackedTriangle::new(t[0], t[1], t[2]),
                    ray.tmin,
                    ray.tmax,
                )
                .map(|h| h.0)
            })
            .min_by(f32::total_cmp)
    }

    /// A tree and its triangles in leaf order.
    type Built = (WideBvh, Vec<[Vec3; 3]>);

    /// Which walk a check runs: the node test called as is, or one of
    /// the entry points compiled for an instruction set.
    #[derive(Clone, Copy, Debug)]
    enum Walk {
        Portable,
        #[cfg(target_arch = "x86_64")]
        Avx2,
        #[cfg(target_arch = "x86_64")]
        Avx2Entry,
        #[cfg(target_arch = "x86_64")]
        Avx512Entry,
    }

    impl Walk {
        fn closest<F: FnMut(u32, u32, f32) -> Option<f32>>(
            self,
            bvh: &WideBvh,
            ray: &Ray,
            leaf: F,
        ) -> bool {
            match self {
                Walk::Portable => bvh.closest_with::<Portable, FixedStack, F>(ray, leaf),
                #[cfg(target_arch = "x86_64")]
                Walk::Avx2 => bvh.closest_with::<Avx2, FixedStack, F>(ray, leaf),
                // SAFETY: only run where the CPU has the instructions.
                #[cfg(target_arch = "x86_64")]
                Walk::Avx2Entry => unsafe { bvh.closest_avx2(ray, leaf) },
                #[cfg(target_arch = "x86_64")]
                Walk::Avx512Entry => unsafe { bvh.closest_avx512(ray, leaf) },
            }
        }

        fn any<F: FnMut(u32, u32, f32) -> bool>(self, bvh: &WideBvh, ray: &Ray, leaf: F) -> bool {
            match self {
                Walk::Portable => bvh.any_with::<Portable, FixedStack, F>(ray, leaf),
                #[cfg(target_arch = "x86_64")]
                Walk::Avx2 => bvh.any_with::<Avx2, FixedStack, F>(ray, leaf),
                // SAFETY: only run where the CPU has the instructions.
                #[cfg(target_arch = "x86_64")]
                Walk::Avx2Entry => unsafe { bvh.any_avx2(ray, leaf) },
                #[cfg(target_arch = "x86_64")]
                Walk::Avx512Entry => unsafe { bvh.any_avx512(ray, leaf) },
            }
        }
    }

    fn check(walk: Walk, build: fn(&[[Vec3; 3]]) -> Built) {
        let tris = soup(4000);
        let (bvh, leaf) = build(&tris);
        let mut hits = 0;
        for ray in rays(20_000) {
            let sh = RayShear::new(ray.o, ray.d);
            let tri = |p: usize| PackedTriangle::new(leaf[p][0], leaf[p][1], leaf[p][2]);
            let mut best = None;
            let found = walk.closest(&bvh, &ray, |first, count, mut tmax| {
                let mut found = None;
                for p in first as usize..(first + count) as usize {
                    let t = intersect_triangle(&sh, &tri(p), ray.tmin, tmax).map(|h| h.0);
                    if let Some(t) = t {
                        (best, found, tmax) = (Some(t), Some(t), t);
                    }
                }
                found
            });
            let expect = brute(&tris, &ray);
            assert_eq!(found, expect.is_some());
            assert_eq!(best, expect, "{walk:?}: closest hit of {ray:?}");
            let any = walk.any(&bvh, &ray, |first, count, tmax| {
                (first as usize..(first + count) as usize)
                    .any(|p| intersect_triangle(&sh, &tri(p), ray.tmin, tmax).is_some())
            });
            assert_eq!(any, expect.is_some(), "{walk:?}: any hit of {ray:?}");
            hits += usize::from(found);
        }
        assert!(hits > 2000, "only {hits} hits: the test would prove little");
    }

    #[test]
    fn portable_traversal_finds_what_brute_force_finds() {
        check(Walk::Portable, build);
        check(Walk::Portable, build_collapsed);
    }

    /// The AVX2 node test, and the walks compiled for AVX2 and for
    /// AVX-512VL, where the CPU has them.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn avx2_traversal_finds_what_brute_force_finds() {
        if std::arch::is_x86_feature_detected!("avx2") {
            for walk in [Walk::Avx2, Walk::Avx2Entry] {
                check(walk, build);
                check(walk, build_collapsed);
            }
        }
        if super::super::lanes::PacketIsa::Avx512Vl.available() {
            check(Walk::Avx512Entry, build);
            check(Walk::Avx512Entry, build_collapsed);
        }
    }

    /// The surface-area cost of `bvh` under `cost`, as the collapse
    /// prices it: each node 1, each leaf its cost, times its box's half
    /// area.
    fn tree_cost(bvh: &WideBvh, cost: LeafCost) -> f64 {
        let half_area = |b: Aabb| {
            let d = b.diagonal();
            (d.x * d.y + d.y * d.z + d.z * d.x) as f64
        };
        let mut total = 0.0;
        for node in &bvh.nodes {
            total += half_area(node.bounds_all());
            for slot in 0..8 {
                let count = node.count[slot] as f64;
                if count == 0.0 {
                    continue;
                }
                let b = &node.bounds;
                let min = Vec3::new(b[0][slot], b[2][slot], b[4][slot]);
                let max = Vec3::new(b[1][slot], b[3][slot], b[5][slot]);
                let price = match cost {
                    LeafCost::Lanes(c) => c as f64,
                    LeafCost::PerPrimitive(c) => c as f64 * count,
                };
                total += price * half_area(Aabb { min, max });
            }
        }
        total
    }

    /// Each cost model's collapse is the cheapest tree under that model
    /// of the trees every model's collapse makes from the same binary
    /// tree (the dynamic program finds the least cost of all), and the
    /// models steer it: cheap leaves in lanes fill them, dear primitives
    /// keep them small. Control: the trees differ.
    #[test]
    fn the_collapse_is_the_cheapest_under_its_costs() {
        let tris = soup(3000);
        let (boxes, o) = boxes_of(&tris);
        let b2 = binary_tree(&o);
        let models = [
            LeafCost::Lanes(0.1),
            LeafCost::Lanes(1.5),
            LeafCost::Lanes(10.0),
            LeafCost::PerPrimitive(0.2),
            LeafCost::PerPrimitive(3.0),
        ];
        let trees: Vec<WideBvh> = models
            .iter()
            .map(|&m| WideBvh::from_bvh2(&b2, &boxes, 8, m).unwrap().0)
            .collect();
        for (a, &model) in models.iter().enumerate() {
            let own = tree_cost(&trees[a], model);
            for (b, other) in trees.iter().enumerate() {
                let cost = tree_cost(other, model);
                assert!(
                    own <= cost * (1.0 + 1e-5),
                    "{model:?}: {own} against tree {b}'s {cost}"
                );
            }
        }
        let mean_leaf = |t: &WideBvh| {
            let (leaves, prims) = t.leaves().fold((0, 0), |(l, p), (_, c)| (l + 1, p + c));
            prims as f64 / leaves as f64
        };
        assert!(mean_leaf(&trees[0]) > 3.0, "{}", mean_leaf(&trees[0]));
        assert!(mean_leaf(&trees[4]) < 1.5, "{}", mean_leaf(&trees[4]));
        assert!(trees[0].nodes.len() < trees[4].nodes.len());
    }

    /// Primitives on a line (every box without area, every cost zero)
    /// are still collapsed into full eight-wide nodes: obvhs's binary
    /// tree of them (unjittered boxes) is a chain, and each wide node
    /// takes seven of its levels, not one. Control: the binary depth.
    #[test]
    fn flat_costs_still_fill_the_slots() {
        let p = Vec3::new(0.5, -0.25, 2.0);
        let tris: Vec<[Vec3; 3]> = (0..4096)
            .map(|i| {
                let q = p + Vec3::X * (i as f32 * 1e-3);
                [q, q, q]
            })
            .collect();
        let (boxes, o) = boxes_of(&tris);
        let b2 = binary_tree(&o);
        let mut binary_depth = 0;
        let mut todo = vec![(0u32, 1usize)];
        while let Some((id, d)) = todo.pop() {
            binary_depth = binary_depth.max(d);
            let n = &b2.nodes[id as usize];
            if !n.is_leaf() {
                todo.extend([(n.first_index, d + 1), (n.first_index + 1, d + 1)]);
            }
        }
        assert!(binary_depth > 100, "binary depth {binary_depth}");
        let (bvh, _) = WideBvh::from_bvh2(&b2, &boxes, 8, LeafCost::Lanes(1.5)).unwrap();
        assert!(
            bvh.depth() <= binary_depth / 7 + 2,
            "depth {} of a binary {binary_depth}",
            bvh.depth()
        );
    }

    fn lifo<S: TraversalStack>(n: u32) {
        let mut s = S::new();
        for i in 0..n {
            s.push(Entry {
                t: i as f32,
                index: i,
                count: 0,
            });
        }
        for i in (0..n).rev() {
            assert_eq!(s.pop().map(|e| e.index), Some(i));
        }
        assert!(s.pop().is_none());
    }

    #[test]
    fn the_stacks_stay_last_in_first_out() {
        lifo::<FixedStack>(FIXED_ENTRIES as u32);
        lifo::<VecStack>(600);
    }

    /// `push_if` keeps exactly the entries it is told to, in order, the
    /// others overwritten by the next push.
    #[test]
    fn push_if_keeps_what_it_is_told_to() {
        let mut s = FixedStack::<Entry>::new();
        let entry = |i: u32| Entry {
            t: 0.0,
            index: i,
            count: 0,
        };
        for i in 0..FIXED_ENTRIES as u32 - 1 {
            s.push_if(entry(i), i % 3 != 1);
        }
        let kept: Vec<u32> = std::iter::from_fn(|| s.pop().map(|e| e.index)).collect();
        let expected: Vec<u32> = (0..FIXED_ENTRIES as u32 - 1)
            .rev()
            .filter(|i| i % 3 != 1)
            .collect();
        assert_eq!(kept, expected);
    }

    /// A chain of `levels` nodes, each with seven one-primitive leaves and
    /// the next node as children, all boxes the unit cube.
    fn chain(levels: u32) -> WideBvh {
        let unit = Aabb {
            min: Vec3::ZERO,
            max: Vec3::ONE,
        };
        let mut nodes = Vec::new();
        for level in 0..levels {
            let mut n = WideNode::EMPTY;
            for slot in 0..7 {
                n.set_box(slot, unit);
                n.child[slot] = level * 7 + slot as u32;
                n.count[slot] = 1;
            }
            if level + 1 < levels {
                n.set_box(7, unit);
                n.child[7] = level + 1;
            }
            nodes.push(n);
        }
        WideBvh::from_nodes(nodes)
    }

    /// A tree too deep for the fixed stack is walked with the growing one,
    /// and every leaf is still visited (the fixed stack would overflow:
    /// 7 entries a level over 60 levels); a tree at the fixed stack's depth
    /// limit fills it without overflowing.
    #[test]
    fn deep_trees_take_the_growing_stack() {
        let ray = Ray::with_range(Vec3::splat(0.5) - Vec3::Z, Vec3::Z, 0.0, f32::INFINITY);
        for (levels, fixed) in [(60, false), (FIXED_DEPTH as u32, true)] {
            let bvh = chain(levels);
            assert_eq!(bvh.depth(), levels as usize);
            assert_eq!(bvh.fixed_stack, fixed);
            let mut seen = vec![false; levels as usize * 7];
            assert!(!bvh.closest(&ray, |p, _| {
                seen[p] = true;
                None
            }));
            assert!(
                seen.iter().all(|&s| s),
                "{levels} levels: a leaf was skipped"
            );
            let mut visits = 0;
            assert!(!bvh.any(&ray, |_, _| {
                visits += 1;
                false
            }));
            assert_eq!(visits, levels as usize * 7);
        }
    }

    #[test]
    fn hits_a_hundred_thousandth_away_are_found() {
        // obvhs's own traversal skips boxes nearer than 1e-4.
        let s = 1e-6;
        let tri = [
            Vec3::new(-s, -s, 5.0 * s),
            Vec3::new(s, -s, 5.0 * s),
            Vec3::new(0.0, s, 5.0 * s),
        ];
        let (bvh, _) = build(&[tri, tri]);
        let ray = Ray::with_range(Vec3::ZERO, Vec3::Z, 0.0, f32::INFINITY);
        let sh = RayShear::new(ray.o, ray.d);
        let packed = PackedTriangle::new(tri[0], tri[1], tri[2]);
        let hit = |_: usize, tmax: f32| intersect_triangle(&sh, &packed, 0.0, tmax).map(|h| h.0);
        assert!(bvh.closest(&ray, hit));
        assert!(bvh.any(&ray, |p, tmax| hit(p, tmax).is_some()));
    }

    #[test]
    fn one_primitive_and_no_primitive() {
        let (bvh, _) = build(&soup(1));
        let ray = Ray::with_range(Vec3::new(0.0, 0.0, -9.0), Vec3::Z, 0.0, f32::INFINITY);
        let mut visited = 0;
        bvh.closest(&ray, |_, _| {
            visited += 1;
            None
        });
        assert!(visited <= 1);
        let empty = WideBvh::from_nodes(Vec::new());
        assert!(!empty.closest(&ray, |_, _| Some(1.0)));
        assert!(!empty.any(&ray, |_, _| true));
    }
}
