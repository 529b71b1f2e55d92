//! The scene's BVHs, built by obvhs (compressed wide BVHs) and traversed
//! with our own watertight triangle test: one over the top-level triangles,
//! spheres and instances, and one per shape group, which each instance
//! traverses in its own space (instanced, not copied).

use std::time::{Duration, Instant};

use glam::{Vec3A, Vec4};
use obvhs::bvh2::builder::build_bvh2;
use obvhs::cwbvh::builder::build_cwbvh;
use obvhs::{aabb::Aabb as OAabb, Boundable, BvhBuildParams};

#[cfg(target_arch = "x86_64")]
use super::lanes::{Avx2Lanes, Avx512VlLanes, Lanes, PacketIsa, F8};
use super::leaf_rows::LeafRows;
#[cfg(target_arch = "x86_64")]
use super::leaf_rows::TAG_ROW;
use super::triangle::{intersect_triangle, PackedTriangle, RayShear};
#[cfg(target_arch = "x86_64")]
use super::triangle::{watertight_lanes, AxisShear, WatertightLanes};
use super::wide_bvh::{LeafCost, WideBvh};
use super::{CurveSegment, Disk, Geometry, Instance, Rectangle, Sphere};
use crate::math::{Aabb, Ray, Vec3};
use crate::sampling::mix64;

/// A primitive with its data copied in BVH order, so traversal touches one
/// contiguous array of 48-byte records: a triangle's vertices by
/// coordinate in lanes 0-2 ([`PackedTriangle`]); lane 3 of `xs` holds, as
/// bits, 0 for a triangle, 1 + the index of a sphere in `Bvh::spheres`,
/// [`DISK_BIT`] | the index of a disk in `Bvh::disks`, [`RECTANGLE_BIT`] |
/// the index of a rectangle in `Bvh::rectangles`,
/// [`CURVE_BIT`] | the index of a curve segment in `Bvh::curves`, or
/// [`INSTANCE_BIT`] | the index of an instance in `Bvh::instances`.
#[derive(Clone, Copy, Debug)]
struct Prim {
    xs: Vec4,
    ys: Vec4,
    zs: Vec4,
}

impl Prim {
    fn triangle(v: [Vec3; 3]) -> Prim {
        Prim {
            xs: Vec4::new(v[0].x, v[1].x, v[2].x, f32::from_bits(TRIANGLE_TAG)),
            ys: Vec4::new(v[0].y, v[1].y, v[2].y, 0.0),
            zs: Vec4::new(v[0].z, v[1].z, v[2].z, 0.0),
        }
    }

    fn tagged(bits: u32) -> Prim {
        Prim {
            xs: Vec4::new(0.0, 0.0, 0.0, f32::from_bits(bits)),
            ys: Vec4::ZERO,
            zs: Vec4::ZERO,
        }
    }

    #[inline]
    fn kind(&self) -> PrimKind {
        match self.xs.w.to_bits() {
            TRIANGLE_TAG => PrimKind::Triangle,
            i if i & INSTANCE_BIT != 0 => PrimKind::Instance((i & !INSTANCE_BIT) as usize),
            i if i & CURVE_BIT != 0 => PrimKind::Curve((i & !CURVE_BIT) as usize),
            i if i & DISK_BIT != 0 => PrimKind::Disk((i & !DISK_BIT) as usize),
            i if i & RECTANGLE_BIT != 0 => PrimKind::Rectangle((i & !RECTANGLE_BIT) as usize),
            i => PrimKind::Sphere(i as usize - 1),
        }
    }

    #[inline]
    fn packed_triangle(&self) -> PackedTriangle {
        PackedTriangle::from_lanes(
            Vec3A::from_vec4(self.xs),
            Vec3A::from_vec4(self.ys),
            Vec3A::from_vec4(self.zs),
        )
    }
}

/// Lane 3 of a triangle's [`Prim::xs`]: no mark (a sphere's is its index
/// plus one, never 0).
const TRIANGLE_TAG: u32 = 0;

/// Marks an instance primitive in lane 3 of [`Prim::xs`].
const INSTANCE_BIT: u32 = 1 << 31;

/// Marks a curve segment in lane 3 of [`Prim::xs`].
const CURVE_BIT: u32 = 1 << 30;

/// Marks a disk in lane 3 of [`Prim::xs`].
const DISK_BIT: u32 = 1 << 29;

/// Marks a rectangle in lane 3 of [`Prim::xs`].
const RECTANGLE_BIT: u32 = 1 << 28;

enum PrimKind {
    Triangle,
    Sphere(usize),
    Disk(usize),
    Rectangle(usize),
    Curve(usize),
    Instance(usize),
}

#[derive(Clone, Copy, Debug)]
struct PrimRef {
    shape: u32,
    index: u32,
}

/// A box as obvhs's builders take it.
pub struct BoundsOnly(pub OAabb);

impl Boundable for BoundsOnly {
    fn aabb(&self) -> OAabb {
        self.0
    }
}

/// Closest-hit record from the BVH: enough to rebuild the full intersection.
#[derive(Clone, Copy, Debug)]
pub struct BvhHit {
    pub t: f32,
    pub shape: u32,
    /// Triangle index within its mesh, segment index within its curve
    /// file (0 for spheres, disks and rectangles).
    pub index: u32,
    /// Barycentrics of vertices 1 and 2 (triangles); the parameter along
    /// the segment in `b1` (curves); object x and y (disks, rectangles).
    pub b1: f32,
    pub b2: f32,
    /// The instance hit, or [`BvhHit::NO_INSTANCE`] for a top-level shape.
    pub instance: u32,
}

impl BvhHit {
    pub const NO_INSTANCE: u32 = u32::MAX;

    fn none(tmax: f32) -> BvhHit {
        BvhHit {
            t: tmax,
            shape: 0,
            index: 0,
            b1: 0.0,
            b2: 0.0,
            instance: BvhHit::NO_INSTANCE,
        }
    }
}

/// The scene's acceleration structure.
pub struct Bvh {
    bvh: Option<WideBvh>,
    prims: Vec<Prim>,
    /// The spheres, in the order of their primitives' indices.
    spheres: Vec<Sphere>,
    /// The disks, in the order of their primitives' indices.
    disks: Vec<Disk>,
    /// The rectangles, in the order of their primitives' indices.
    rectangles: Vec<Rectangle>,
    /// The curve segments, in the order of their primitives' indices.
    curves: Vec<CurveSegment>,
    refs: Vec<PrimRef>,
    /// Placed shape groups (top level only).
    instances: Vec<Instance>,
    /// One BVH per shape group, in the space its instances map from.
    groups: Vec<Bvh>,
    bounds: Aabb,
    /// Whether the one-ray walks test a leaf's triangles together in AVX2
    /// lanes ([`Bvh::leaf_triangles_lanes`]): trees built with leaves of up
    /// to eight (`WideBvh::from_bvh2`, those too big for packets), on CPUs
    /// with AVX2.
    #[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
    leaf_lanes: bool,
    /// The leaves' triangles as the lanes read them (empty unless
    /// `leaf_lanes`).
    #[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
    leaf_rows: LeafRows,
    /// Wall time spent building.
    pub build_time: Duration,
}

/// The boxes obvhs builds the tree from: each of `boxes` moved by its own
/// pseudo-random offset (at most 0.001% of its size along each axis). PLOC
/// merges clusters whose cheapest neighbour is each other; among identical
/// boxes (a mesh of one triangle repeated, an instance placed many times at
/// one spot) every merge costs the same, ties go one way, and one pair
/// merged per round made the build quadratic and the tree a chain (20,000
/// copies of one triangle: 28 s). Scattered a little,
/// such boxes build like a point cloud. The tree's node boxes are
/// recomputed from the exact boxes (`WideBvh::from_cwbvh`; the GPU's BVH2
/// is refitted), so only the tree's shape depends on the offsets.
pub fn build_boxes(boxes: &[Aabb]) -> Vec<BoundsOnly> {
    // Zero-sized boxes move by a share of the scene's size instead.
    let scene = boxes.iter().fold(Aabb::EMPTY, |acc, b| acc.union(*b));
    let floor = scene.diagonal().max_element() * 1e-7;
    boxes
        .iter()
        .enumerate()
        .map(|(i, b)| {
            let h = mix64(i as u64);
            let unit = |k: u32| ((h >> (k * 21)) & 0x1f_ffff) as f32 * (1.0 / (1 << 21) as f32);
            let offset = (Vec3::new(unit(0), unit(1), unit(2)) - 0.5)
                * ((b.diagonal().max_element() + floor) * 2e-5);
            BoundsOnly(OAabb::new(
                Vec3A::from(b.min + offset),
                Vec3A::from(b.max + offset),
            ))
        })
        .collect()
}

impl Bvh {
    /// One BVH over all `shapes` (shape indices are their positions).
    pub fn build(shapes: &[Geometry]) -> Bvh {
        Bvh::build_instanced(shapes, shapes.len(), &[], Vec::new())
    }

    /// The scene's BVH: over `shapes[..top]` and the `instances`, each of
    /// which traverses the BVH of its group, built over `shapes[group]`
    /// (hits report indices into `shapes` throughout).
    pub fn build_instanced(
        shapes: &[Geometry],
        top: usize,
        groups: &[std::ops::Range<usize>],
        instances: Vec<Instance>,
    ) -> Bvh {
        let start = Instant::now();
        let groups: Vec<Bvh> = groups
            .iter()
            .map(|r| Bvh::build_over(shapes, r.clone(), Vec::new(), Vec::new()))
            .collect();
        let mut bvh = Bvh::build_over(shapes, 0..top, instances, groups);
        bvh.build_time = start.elapsed();
        bvh
    }

    fn build_over(
        shapes: &[Geometry],
        range: std::ops::Range<usize>,
        instances: Vec<Instance>,
        groups: Vec<Bvh>,
    ) -> Bvh {
        let start = Instant::now();
        // Each primitive's record tag (`Prim::tagged`; `TRIANGLE_TAG`):
        // the records themselves are made once the tree has put the
        // primitives in leaf order, so that they are not held, 48 bytes a
        // primitive, through the build's peak of memory.
        let mut tags = Vec::new();
        let mut spheres = Vec::new();
        let mut disks = Vec::new();
        let mut rectangles = Vec::new();
        let mut curves = Vec::new();
        let mut refs = Vec::new();
        let mut boxes = Vec::new();
        let mut bounds = Aabb::EMPTY;
        // One primitive: its record's tag, the shape and index a hit
        // reports, its box.
        let mut add = |tag: u32, shape: usize, index: usize, b: Aabb| {
            tags.push(tag);
            refs.push(PrimRef {
                shape: shape as u32,
                index: index as u32,
            });
            boxes.push(b);
        };
        for (si, g) in shapes.iter().enumerate().take(range.end).skip(range.start) {
            match g {
                Geometry::Mesh(m) => {
                    for ti in 0..m.triangle_count() {
                        add(TRIANGLE_TAG, si, ti, m.triangle_bounds(ti));
                    }
                }
                Geometry::Sphere(s) => {
                    add(spheres.len() as u32 + 1, si, 0, s.bounds());
                    spheres.push(*s);
                }
                Geometry::Disk(k) => {
                    add(DISK_BIT | disks.len() as u32, si, 0, k.bounds());
                    disks.push(*k);
                }
                Geometry::Rectangle(r) => {
                    let tag = RECTANGLE_BIT | rectangles.len() as u32;
                    add(tag, si, 0, r.bounds());
                    rectangles.push(*r);
                }
                Geometry::Curve(c) => {
                    for seg in 0..c.segment_count() {
                        let tag = CURVE_BIT | curves.len() as u32;
                        add(tag, si, seg, c.segment_bounds(seg));
                        curves.push(c.segment(seg));
                    }
                }
            }
        }
        for (i, inst) in instances.iter().enumerate() {
            let b = inst.world_bounds(groups[inst.group as usize].bounds);
            // An empty group places nothing.
            if !b.is_empty() {
                add(INSTANCE_BIT | i as u32, 0, 0, b);
            }
        }
        for b in &boxes {
            bounds = bounds.union(*b);
        }
        // The record of primitive `i` (in the order added).
        let prim = |i: usize| match tags[i] {
            TRIANGLE_TAG => {
                let r = refs[i];
                let Geometry::Mesh(m) = &shapes[r.shape as usize] else {
                    unreachable!("only meshes add triangles")
                };
                Prim::triangle(m.vertices(r.index as usize))
            }
            tag => Prim::tagged(tag),
        };
        if tags.is_empty() || bounds.is_empty() {
            return Bvh {
                bvh: None,
                prims: (0..tags.len()).map(prim).collect(),
                spheres,
                disks,
                rectangles,
                curves,
                refs,
                instances,
                groups,
                bounds,
                leaf_lanes: false,
                leaf_rows: LeafRows::empty(),
                build_time: start.elapsed(),
            };
        }
        // Each box padded by a few ulps of its coordinates: a margin beyond
        // the slab test's own rounding bound for rays that meet a triangle
        // exactly at its box's face (obvhs's traversal, used until the wide
        // BVH, needed it; kept so the tree and the hits stay as they were).
        // Padded in place: the unpadded boxes are not needed again, and a
        // copy would add 24 bytes a primitive to the build's peak memory.
        let mut padded = boxes;
        for b in &mut padded {
            let pad = b.min.abs().max(b.max.abs()) * 1e-5 + Vec3::splat(1e-30);
            *b = Aabb {
                min: b.min - pad,
                max: b.max + pad,
            };
        }
        let oboxes = build_boxes(&padded);
        let mut core = Duration::default();
        // Trees too big for packets are walked one ray at a time, their
        // leaves' triangles tested together in lanes: those collapse
        // obvhs's binary tree into leaves of up to `LEAF_LANES`
        // primitives (`WideBvh::from_bvh2`); the others keep obvhs's wide
        // tree, whose leaves of up to three suit the packet walks.
        #[cfg(target_arch = "x86_64")]
        let leaves_in_lanes = PacketIsa::detect().is_some();
        #[cfg(not(target_arch = "x86_64"))]
        let leaves_in_lanes = false;
        let wide_leaves = (tags.len() > PACKET_MAX_PRIMITIVES)
            .then(|| {
                // A more thorough build where it pays for itself: obvhs's
                // most thorough preset (reinsertion over every node) on
                // the 102k-triangle mesh renders 6% faster (1 thread,
                // median of 5) for 0.2 s more build on two cores; on a
                // million triangles 3-4% faster for 3.4 s more, which a
                // render must be long to win back. (With the cost-optimal
                // collapse, the mesh still renders 3-4% faster: three
                // alternating pairs, build 277 ms against 65.)
                let preset = if tags.len() <= THOROUGH_BUILD_MAX_PRIMITIVES {
                    BvhBuildParams::very_slow_build()
                } else {
                    BvhBuildParams::medium_build()
                };
                let params = BvhBuildParams {
                    max_prims_per_leaf: 1,
                    ..preset
                };
                let bvh2 = build_bvh2(&oboxes, params, &mut core);
                // Measured on the 102k-triangle mesh (incoherent rays,
                // the blob's render): a leaf tested in lanes costs about
                // one and a half nodes' tests; one tested triangle by
                // triangle a fifth of a node per triangle (0.1 to 0.3 alike,
                // 1 was 15% slower).
                let leaf_cost = if leaves_in_lanes {
                    LeafCost::Lanes(1.5)
                } else {
                    LeafCost::PerPrimitive(0.2)
                };
                WideBvh::from_bvh2(&bvh2, &padded, LEAF_LANES as u32, leaf_cost)
            })
            .flatten();
        // Its leaves' triangles are tested in lanes where it was built so
        // and the CPU has AVX2, as the walks' choice of copy sees it.
        let leaf_lanes = wide_leaves.is_some() && leaves_in_lanes;
        let (wide, order) = wide_leaves.unwrap_or_else(|| {
            let bvh = build_cwbvh(&oboxes, BvhBuildParams::medium_build(), &mut core);
            let order = bvh.primitive_indices.clone();
            let leaf_boxes: Vec<Aabb> = order.iter().map(|&i| padded[i as usize]).collect();
            (WideBvh::from_cwbvh(&bvh, &leaf_boxes), order)
        });
        // Primitives in leaf order, so the traversal's ids index them.
        drop((padded, oboxes));
        let prims: Vec<Prim> = order.iter().map(|&i| prim(i as usize)).collect();
        drop(tags);
        let refs: Vec<PrimRef> = order.iter().map(|&i| refs[i as usize]).collect();
        let leaf_rows = if leaf_lanes {
            LeafRows::new(prims.len(), wide.leaves(), |i| {
                let p = &prims[i];
                // Its records hold the three vertices by axis already.
                matches!(p.kind(), PrimKind::Triangle)
                    .then(|| [p.xs, p.ys, p.zs].map(|c| c.truncate().to_array()))
            })
        } else {
            LeafRows::empty()
        };
        Bvh {
            bvh: Some(wide),
            prims,
            spheres,
            disks,
            rectangles,
            curves,
            refs,
            instances,
            groups,
            bounds,
            leaf_lanes,
            leaf_rows,
            build_time: start.elapsed(),
        }
    }

    pub fn bounds(&self) -> Aabb {
        self.bounds
    }

    /// The top-level tree's depth in nodes (0 when empty).
    pub fn depth(&self) -> usize {
        self.bvh.as_ref().map_or(0, WideBvh::depth)
    }

    pub fn primitive_count(&self) -> usize {
        self.prims.len()
    }

    /// The instance a hit's `instance` field names.
    pub fn instance(&self, index: u32) -> &Instance {
        &self.instances[index as usize]
    }

    /// Number of placed shape groups.
    pub fn instance_count(&self) -> usize {
        self.instances.len()
    }

    /// Closest hit along the ray within its range.
    pub fn intersect(&self, ray: &Ray) -> Option<BvhHit> {
        let bvh = self.bvh.as_ref()?;
        // The triangle test's shear, set up at the first triangle the ray
        // meets (rays that meet only analytic shapes never need it).
        let mut shear: Option<RayShear> = None;
        let mut best = BvhHit::none(ray.tmax);
        let (o, d, tmin) = (ray.o, ray.d, ray.tmin);
        // One primitive's hit, as the scalar loop tests it.
        let one = |id: usize, tmax: f32, shear: &mut Option<RayShear>| -> Option<BvhHit> {
            let prim = &self.prims[id];
            match prim.kind() {
                PrimKind::Triangle => {
                    let shear = shear.get_or_insert_with(|| RayShear::new(o, d));
                    intersect_triangle(shear, &prim.packed_triangle(), tmin, tmax).map(
                        |(t, b1, b2)| BvhHit {
                            t,
                            shape: self.refs[id].shape,
                            index: self.refs[id].index,
                            b1,
                            b2,
                            instance: BvhHit::NO_INSTANCE,
                        },
                    )
                }
                PrimKind::Sphere(si) => {
                    self.spheres[si]
                        .intersect(o, d, tmin, tmax)
                        .map(|t| BvhHit {
                            t,
                            shape: self.refs[id].shape,
                            ..BvhHit::none(t)
                        })
                }
                PrimKind::Disk(di) => self.disks[di]
                    .intersect(o, d, tmin, tmax)
                    .map(|(t, l)| planar_hit(t, l, self.refs[id].shape)),
                PrimKind::Rectangle(ri) => self.rectangles[ri]
                    .intersect(o, d, tmin, tmax)
                    .map(|(t, l)| planar_hit(t, l, self.refs[id].shape)),
                PrimKind::Curve(_) | PrimKind::Instance(_) => {
                    self.primitive_hit(id, &Ray::with_range(o, d, tmin, tmax))
                }
            }
        };
        let found = bvh.closest_leaves(
            ray,
            #[inline(always)]
            |first, count, mut tmax| {
                #[cfg(target_arch = "x86_64")]
                if self.leaf_lanes && (2..=LEAF_LANES as u32).contains(&count) {
                    let sh = shear.get_or_insert_with(|| RayShear::new(o, d));
                    // SAFETY: `leaf_lanes` is set only where the CPU has AVX2
                    // (`PacketIsa::detect`).
                    let lanes = unsafe { self.leaf_triangles_lanes(first, count, sh, tmin, tmax) };
                    if let Some(lanes) = lanes {
                        let w = lanes?;
                        if w.hits == 0 {
                            return None;
                        }
                        // SAFETY: as above.
                        let l = unsafe { Avx2Lanes::new_unchecked() };
                        let ts = l.store(w.t);
                        // The nearest, the first of equals: the one the
                        // primitive loop keeps (it needs t < tmax).
                        let mut each = w.hits;
                        let mut lane = each.trailing_zeros() as usize;
                        while each != 0 {
                            let l = each.trailing_zeros() as usize;
                            each &= each - 1;
                            if ts[l] < ts[lane] {
                                lane = l;
                            }
                        }
                        let id = first as usize + lane;
                        best = BvhHit {
                            t: ts[lane],
                            shape: self.refs[id].shape,
                            index: self.refs[id].index,
                            b1: l.store(w.b1)[lane],
                            b2: l.store(w.b2)[lane],
                            instance: BvhHit::NO_INSTANCE,
                        };
                        return Some(best.t);
                    }
                }
                let mut found = None;
                for id in first..first + count {
                    if let Some(h) = one(id as usize, tmax, &mut shear) {
                        best = h;
                        tmax = h.t;
                        found = Some(h.t);
                    }
                }
                found
            },
        );
        if found {
            Some(best)
        } else {
            None
        }
    }

    /// True if anything blocks the ray within its range.
    pub fn occluded(&self, ray: &Ray) -> bool {
        let Some(bvh) = self.bvh.as_ref() else {
            return false;
        };
        let mut shear: Option<RayShear> = None;
        let (o, d, tmin) = (ray.o, ray.d, ray.tmin);
        let one = |id: usize, tmax: f32, shear: &mut Option<RayShear>| -> bool {
            let prim = &self.prims[id];
            match prim.kind() {
                PrimKind::Triangle => {
                    let shear = shear.get_or_insert_with(|| RayShear::new(o, d));
                    intersect_triangle(shear, &prim.packed_triangle(), tmin, tmax).is_some()
                }
                PrimKind::Sphere(si) => self.spheres[si].intersect(o, d, tmin, tmax).is_some(),
                PrimKind::Disk(di) => self.disks[di].intersect(o, d, tmin, tmax).is_some(),
                PrimKind::Rectangle(ri) => {
                    self.rectangles[ri].intersect(o, d, tmin, tmax).is_some()
                }
                PrimKind::Curve(ci) => self.curves[ci].intersect(o, d, tmin, tmax).is_some(),
                PrimKind::Instance(ii) => {
                    let inst = &self.instances[ii];
                    let local = inst.to_local(&Ray::with_range(o, d, tmin, tmax));
                    self.groups[inst.group as usize].occluded(&local)
                }
            }
        };
        bvh.any_leaves(
            ray,
            #[inline(always)]
            |first, count, tmax| {
                #[cfg(target_arch = "x86_64")]
                if self.leaf_lanes && (2..=LEAF_LANES as u32).contains(&count) {
                    let sh = shear.get_or_insert_with(|| RayShear::new(o, d));
                    // SAFETY: `leaf_lanes` is set only where the CPU has AVX2
                    // (`PacketIsa::detect`).
                    let lanes = unsafe { self.leaf_triangles_lanes(first, count, sh, tmin, tmax) };
                    if let Some(lanes) = lanes {
                        return lanes.is_some_and(|w| w.hits != 0);
                    }
                }
                (first..first + count).any(|id| one(id as usize, tmax, &mut shear))
            },
        )
    }

    /// Primitives `first..first + count` (2 to 8 of them) against one ray
    /// (its shear, range `tmin`..`tmax`) in AVX2 lanes, a triangle a lane,
    /// by the scalar test's operations ([`watertight_lanes`]): the same
    /// hits bit for bit. `None` where the primitive loop must test them
    /// instead: a primitive that is not a triangle, or a lane whose edge
    /// function is exactly zero (the scalar test redoes it in double
    /// precision).
    ///
    /// # Safety
    /// Call only from functions compiled for AVX2 (the walks' AVX2 copies,
    /// into which it is inlined).
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    unsafe fn leaf_triangles_lanes(
        &self,
        first: u32,
        count: u32,
        shear: &RayShear,
        tmin: f32,
        tmax: f32,
    ) -> Option<Option<WatertightLanes<F8>>> {
        use std::arch::x86_64::*;
        let leaf = self.leaf_rows.leaf(first, count);
        let count = count as usize;
        // (No closures here: `array::from_fn`'s and `map`'s stayed out of
        // line, compiled without AVX2, with the loads as calls: +9%
        // instructions for the blob.)
        // SAFETY: the caller runs compiled for AVX2; every row is < ROWS.
        let tags = unsafe { LeafRows::load(leaf, count, TAG_ROW) };
        let lanes = (1u32 << count) - 1;
        // Triangles carry a zero tag; anything else goes to the loop.
        let tagged = _mm256_movemask_ps(_mm256_castsi256_ps(_mm256_cmpeq_epi32(
            _mm256_castps_si256(tags),
            _mm256_setzero_si256(),
        ))) as u32;
        if tagged & lanes != lanes {
            return None;
        }
        // SAFETY: the caller runs compiled for AVX2.
        let l = unsafe { Avx2Lanes::new_unchecked() };
        // The coordinates in the ray's axis order.
        let ([kx, ky, kz], [sx, sy, sz], [ox, oy, oz]) = shear.axes();
        // SAFETY: as above; every axis is < 3.
        let [x, y, z] = unsafe {
            [
                LeafRows::load_axis(leaf, count, kx),
                LeafRows::load_axis(leaf, count, ky),
                LeafRows::load_axis(leaf, count, kz),
            ]
        };
        let v = [
            [l.wrap(x[0]), l.wrap(y[0]), l.wrap(z[0])],
            [l.wrap(x[1]), l.wrap(y[1]), l.wrap(z[1])],
            [l.wrap(x[2]), l.wrap(y[2]), l.wrap(z[2])],
        ];
        let shear = AxisShear {
            o: [l.splat(ox), l.splat(oy), l.splat(oz)],
            s: [l.splat(sx), l.splat(sy), l.splat(sz)],
        };
        let found = watertight_lanes(l, &shear, v, l.splat(tmin), l.splat(tmax), lanes);
        match found {
            Some(w) if w.zero_edge & lanes != 0 => None,
            found => Some(found),
        }
    }
}

/// Trees of at most this many primitives are walked by packets of rays
/// ([`Bvh::intersect_packet`]): there, eight unrelated rays visit mostly
/// the same nodes and leaves, so testing them together costs less than
/// eight walks. Measured in instructions (callgrind, the speed suite): a
/// cube on a ground (13 primitives) -11% for the whole render, the
/// Cornell box (31) -5%, a mirror sphere on a stand (770) -2%; the
/// 102,401-triangle blob +37%.
pub const PACKET_MAX_PRIMITIVES: usize = 1024;

/// Trees of at most this many primitives, too big for packets, are built
/// with obvhs's most thorough preset ([`Bvh::build`]); bigger ones with
/// its medium one, whose build time grows more slowly.
pub const THOROUGH_BUILD_MAX_PRIMITIVES: usize = 1 << 18;

/// The most primitives in a leaf of a tree walked one ray at a time
/// (`WideBvh::from_bvh2`): AVX2's eight lanes, which test them together.
pub const LEAF_LANES: usize = 8;

/// Rays in a packet: at most sixteen, walked together in AVX-512's
/// sixteen lanes where [`PacketIsa::Avx512`] says so, in two halves of
/// eight elsewhere.
pub const PACKET_LANES: usize = 16;

#[cfg(target_arch = "x86_64")]
const _: () = assert!(PACKET_LANES == super::lanes::MAX_LANES);

/// The rays of a packet walked in eight lanes.
#[cfg(target_arch = "x86_64")]
const EIGHT: usize = <Avx2Lanes as Lanes>::WIDTH;

impl Bvh {
    /// Whether [`Bvh::intersect_packet`] walks rays together here: a small
    /// tree and a CPU with AVX2.
    pub fn walks_packets(&self) -> bool {
        #[cfg(target_arch = "x86_64")]
        {
            self.prims.len() <= PACKET_MAX_PRIMITIVES
                && self.bvh.as_ref().is_some_and(WideBvh::packet_walkable)
                && PacketIsa::detect().is_some()
        }
        #[cfg(not(target_arch = "x86_64"))]
        false
    }

    /// [`Bvh::intersect`] of each of `rays` (at most
    /// [`PACKET_LANES`]) into `hits`: the same hits, found by one
    /// walk of the packet where [`Bvh::walks_packets`] (on ties, two
    /// primitives at exactly the same distance, the packet may keep the
    /// other one), by one walk per ray elsewhere.
    pub fn intersect_packet(&self, rays: &[Ray], hits: &mut [Option<BvhHit>]) {
        #[cfg(target_arch = "x86_64")]
        if rays.len() > 1 && self.walks_packets() {
            // `walks_packets` saw that the CPU has one.
            if let Some(isa) = PacketIsa::detect() {
                return self.intersect_packet_in(isa, rays, hits);
            }
        }
        for (ray, hit) in rays.iter().zip(hits.iter_mut()) {
            *hit = self.intersect(ray);
        }
    }

    /// [`Bvh::intersect_packet`]'s walk in `isa`'s lanes, which the CPU
    /// must have ([`PacketIsa::detect`], [`PacketIsa::available`]).
    #[cfg(target_arch = "x86_64")]
    fn intersect_packet_in(&self, isa: PacketIsa, rays: &[Ray], hits: &mut [Option<BvhHit>]) {
        assert!(isa.available());
        if rays.len() > EIGHT {
            if isa == PacketIsa::Avx512 {
                // SAFETY: the CPU has AVX-512F, AVX-512VL and AVX2.
                return unsafe { self.intersect_packet_avx512x16(rays, hits) };
            }
            let (a, b) = rays.split_at(EIGHT);
            let (hits_a, hits_b) = hits.split_at_mut(EIGHT);
            self.intersect_packet_in(isa, a, hits_a);
            return self.intersect_packet_in(isa, b, hits_b);
        }
        match isa {
            // SAFETY: the CPU has AVX-512F, AVX-512VL and AVX2.
            PacketIsa::Avx512Vl | PacketIsa::Avx512 => unsafe {
                self.intersect_packet_avx512(rays, hits)
            },
            // SAFETY: the CPU has AVX2.
            PacketIsa::Avx2 => unsafe { self.intersect_packet_avx2(rays, hits) },
        }
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn intersect_packet_avx2(&self, rays: &[Ray], hits: &mut [Option<BvhHit>]) {
        // SAFETY: compiled for AVX2, called where the CPU has it.
        let l = unsafe { Avx2Lanes::new_unchecked() };
        self.intersect_packet_lanes(l, rays, hits);
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,avx512f,avx512vl")]
    fn intersect_packet_avx512x16(&self, rays: &[Ray], hits: &mut [Option<BvhHit>]) {
        // SAFETY: compiled for AVX-512, called where the CPU has it.
        let l = unsafe { super::lanes::Avx512Lanes::new_unchecked() };
        self.intersect_packet_lanes(l, rays, hits);
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,avx512f,avx512vl")]
    fn intersect_packet_avx512(&self, rays: &[Ray], hits: &mut [Option<BvhHit>]) {
        // SAFETY: compiled for AVX-512VL, called where the CPU has it.
        let l = unsafe { Avx512VlLanes::new_unchecked() };
        self.intersect_packet_lanes(l, rays, hits);
    }

    /// The closest-hit walk of the packet of `rays` in `L`'s lanes.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn intersect_packet_lanes<L: Lanes>(&self, l: L, rays: &[Ray], hits: &mut [Option<BvhHit>]) {
        use super::packet::RayPacket;
        use super::triangle::intersect_triangle_lanes;
        let Some(bvh) = self.bvh.as_ref() else {
            hits.iter_mut().for_each(|h| *h = None);
            return;
        };
        let p = RayPacket::new(l, rays);
        let mut tmax = p.tmax;
        let (mut b1, mut b2) = (l.zero(), l.zero());
        // The primitive each lane hit (-1: none), as bits in a float
        // register; curve and instance hits, tested one ray at a time,
        // keep their whole record in `special`.
        const NONE: u32 = u32::MAX;
        const SPECIAL: u32 = u32::MAX - 1;
        let mut found = l.splat_bits(NONE);
        let mut special = [None::<BvhHit>; PACKET_LANES];
        bvh.closest_packet(
            &p,
            &mut tmax,
            #[inline(always)]
            |id, lanes, tmax| {
                let prim = &self.prims[id];
                let (bits, t, u, v) = match prim.kind() {
                    PrimKind::Triangle => intersect_triangle_lanes::<L, false>(
                        &p,
                        &prim.packed_triangle(),
                        lanes,
                        *tmax,
                    ),
                    PrimKind::Sphere(si) => {
                        let (bits, t) = self.spheres[si].intersect_lanes::<L, false>(&p, *tmax);
                        (bits, t, l.zero(), l.zero())
                    }
                    PrimKind::Disk(di) => {
                        let (bits, [t, x, y]) =
                            self.disks[di].intersect_lanes::<L, false>(&p, *tmax);
                        (bits, t, x, y)
                    }
                    PrimKind::Rectangle(ri) => {
                        let (bits, [t, x, y]) =
                            self.rectangles[ri].intersect_lanes::<L, false>(&p, *tmax);
                        (bits, t, x, y)
                    }
                    PrimKind::Curve(_) | PrimKind::Instance(_) => {
                        // One ray at a time, through the one-ray walk's test.
                        let mut ts = l.store(*tmax);
                        let mut each = lanes;
                        let mut hit_lanes = 0;
                        while each != 0 {
                            let lane = each.trailing_zeros() as usize;
                            each &= each - 1;
                            let r = &p.rays[lane];
                            let ray = Ray::with_range(r.o, r.d, r.tmin, ts[lane]);
                            if let Some(h) = self.primitive_hit_apart(id, &ray) {
                                ts[lane] = h.t;
                                special[lane] = Some(h);
                                hit_lanes |= 1 << lane;
                            }
                        }
                        let m = l.mask(hit_lanes);
                        found = l.blend(found, l.splat_bits(SPECIAL), m);
                        *tmax = l.load(&ts);
                        return;
                    }
                };
                let bits = bits & lanes;
                if bits == 0 {
                    return;
                }
                let m = l.mask(bits);
                *tmax = l.blend(*tmax, t, m);
                b1 = l.blend(b1, u, m);
                b2 = l.blend(b2, v, m);
                found = l.blend(found, l.splat_bits(id as u32), m);
            },
        );
        let (ts, b1s, b2s, ids) = (l.store(tmax), l.store(b1), l.store(b2), l.store(found));
        for (lane, hit) in hits.iter_mut().enumerate().take(rays.len()) {
            *hit = match ids[lane].to_bits() {
                NONE => None,
                SPECIAL => special[lane],
                id => {
                    let id = id as usize;
                    let r = self.refs[id];
                    Some(match self.prims[id].kind() {
                        PrimKind::Triangle => BvhHit {
                            t: ts[lane],
                            shape: r.shape,
                            index: r.index,
                            b1: b1s[lane],
                            b2: b2s[lane],
                            instance: BvhHit::NO_INSTANCE,
                        },
                        PrimKind::Sphere(_) => BvhHit {
                            shape: r.shape,
                            ..BvhHit::none(ts[lane])
                        },
                        _ => planar_hit(ts[lane], glam::Vec2::new(b1s[lane], b2s[lane]), r.shape),
                    })
                }
            };
        }
    }

    /// [`Bvh::occluded`] of each of `rays` (at most [`PACKET_LANES`])
    /// into `blocked`: the same answers (which primitive blocks a ray does
    /// not matter), by one walk of the packet where [`Bvh::walks_packets`].
    pub fn occluded_packet(&self, rays: &[Ray], blocked: &mut [bool]) {
        #[cfg(target_arch = "x86_64")]
        if rays.len() > 1 && self.walks_packets() {
            // `walks_packets` saw that the CPU has one.
            if let Some(isa) = PacketIsa::detect() {
                let bits = self.occluded_packet_in(isa, rays);
                for (k, b) in blocked.iter_mut().enumerate().take(rays.len()) {
                    *b = bits & (1 << k) != 0;
                }
                return;
            }
        }
        for (ray, b) in rays.iter().zip(blocked.iter_mut()) {
            *b = self.occluded(ray);
        }
    }

    /// The lanes of `rays`' packet that something blocks, walked in
    /// `isa`'s lanes, which the CPU must have.
    #[cfg(target_arch = "x86_64")]
    fn occluded_packet_in(&self, isa: PacketIsa, rays: &[Ray]) -> u32 {
        assert!(isa.available());
        if rays.len() > EIGHT {
            if isa == PacketIsa::Avx512 {
                // SAFETY: the CPU has AVX-512F, AVX-512VL and AVX2.
                return unsafe { self.occluded_packet_avx512x16(rays) };
            }
            let (a, b) = rays.split_at(EIGHT);
            return self.occluded_packet_in(isa, a) | (self.occluded_packet_in(isa, b) << EIGHT);
        }
        match isa {
            // SAFETY: the CPU has AVX-512F, AVX-512VL and AVX2.
            PacketIsa::Avx512Vl | PacketIsa::Avx512 => unsafe { self.occluded_packet_avx512(rays) },
            // SAFETY: the CPU has AVX2.
            PacketIsa::Avx2 => unsafe { self.occluded_packet_avx2(rays) },
        }
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn occluded_packet_avx2(&self, rays: &[Ray]) -> u32 {
        // SAFETY: compiled for AVX2, called where the CPU has it.
        let l = unsafe { Avx2Lanes::new_unchecked() };
        self.occluded_packet_lanes(l, rays)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,avx512f,avx512vl")]
    fn occluded_packet_avx512x16(&self, rays: &[Ray]) -> u32 {
        // SAFETY: compiled for AVX-512, called where the CPU has it.
        let l = unsafe { super::lanes::Avx512Lanes::new_unchecked() };
        self.occluded_packet_lanes(l, rays)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,avx512f,avx512vl")]
    fn occluded_packet_avx512(&self, rays: &[Ray]) -> u32 {
        // SAFETY: compiled for AVX-512VL, called where the CPU has it.
        let l = unsafe { Avx512VlLanes::new_unchecked() };
        self.occluded_packet_lanes(l, rays)
    }

    /// The lanes of `rays`' packet that something blocks, as bits.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn occluded_packet_lanes<L: Lanes>(&self, l: L, rays: &[Ray]) -> u32 {
        use super::packet::RayPacket;
        use super::triangle::intersect_triangle_lanes;
        let Some(bvh) = self.bvh.as_ref() else {
            return 0;
        };
        let p = RayPacket::new(l, rays);
        let tmax = p.tmax;
        bvh.any_packet(
            &p,
            #[inline(always)]
            |id, lanes| {
                let prim = &self.prims[id];
                let bits = match prim.kind() {
                    PrimKind::Triangle => {
                        intersect_triangle_lanes::<L, true>(
                            &p,
                            &prim.packed_triangle(),
                            lanes,
                            tmax,
                        )
                        .0
                    }
                    PrimKind::Sphere(si) => self.spheres[si].intersect_lanes::<L, true>(&p, tmax).0,
                    PrimKind::Disk(di) => self.disks[di].intersect_lanes::<L, true>(&p, tmax).0,
                    PrimKind::Rectangle(ri) => {
                        self.rectangles[ri].intersect_lanes::<L, true>(&p, tmax).0
                    }
                    PrimKind::Curve(ci) => {
                        let mut bits = 0;
                        let mut each = lanes;
                        while each != 0 {
                            let lane = each.trailing_zeros() as usize;
                            each &= each - 1;
                            let r = &p.rays[lane];
                            let hit = self.curves[ci].intersect(r.o, r.d, r.tmin, r.tmax);
                            bits |= u32::from(hit.is_some()) << lane;
                        }
                        bits
                    }
                    PrimKind::Instance(ii) => {
                        let inst = &self.instances[ii];
                        let mut bits = 0;
                        let mut each = lanes;
                        while each != 0 {
                            let lane = each.trailing_zeros() as usize;
                            each &= each - 1;
                            let local = inst.to_local(&p.rays[lane]);
                            let hit = self.groups[inst.group as usize].occluded(&local);
                            bits |= u32::from(hit) << lane;
                        }
                        bits
                    }
                };
                bits & lanes
            },
        )
    }

    /// [`Bvh::primitive_hit`] out of line, for the packet walk (inlined,
    /// it cost that walk 2% more instructions on scenes without curves or
    /// instances).
    #[cfg(target_arch = "x86_64")]
    #[inline(never)]
    fn primitive_hit_apart(&self, id: usize, ray: &Ray) -> Option<BvhHit> {
        self.primitive_hit(id, ray)
    }

    /// A curve segment's or an instance's hit along `ray` (whose `tmax`
    /// is the closest hit so far), for both walks.
    #[inline(always)]
    fn primitive_hit(&self, id: usize, ray: &Ray) -> Option<BvhHit> {
        let (o, d, tmin, tmax) = (ray.o, ray.d, ray.tmin, ray.tmax);
        match self.prims[id].kind() {
            PrimKind::Curve(ci) => {
                self.curves[ci]
                    .intersect(o, d, tmin, tmax)
                    .map(|(t, v)| BvhHit {
                        t,
                        shape: self.refs[id].shape,
                        index: self.refs[id].index,
                        b1: v,
                        ..BvhHit::none(t)
                    })
            }
            PrimKind::Instance(ii) => {
                let inst = &self.instances[ii];
                let local = inst.to_local(&Ray::with_range(o, d, tmin, tmax));
                self.groups[inst.group as usize]
                    .intersect(&local)
                    .map(|h| BvhHit {
                        instance: ii as u32,
                        ..h
                    })
            }
            _ => unreachable!("only curves and instances are tested one ray at a time"),
        }
    }
}

/// The hit record of a flat analytic shape: its object coordinates `l`
/// ride in the barycentrics' place.
#[inline]
fn planar_hit(t: f32, l: glam::Vec2, shape: u32) -> BvhHit {
    BvhHit {
        t,
        shape,
        b1: l.x,
        b2: l.y,
        ..BvhHit::none(t)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::TriangleMesh;

    /// A hit as bits, for exact comparison.
    fn bits(h: Option<BvhHit>) -> Option<(u32, u32, u32, u32, u32, u32)> {
        h.map(|h| {
            (
                h.t.to_bits(),
                h.shape,
                h.index,
                h.b1.to_bits(),
                h.b2.to_bits(),
                h.instance,
            )
        })
    }

    /// Every ray of every packet size finds what it finds alone (with
    /// `ties`, where two primitives lie at exactly the hit's distance, the
    /// same distance, either primitive), and is blocked where it is alone.
    fn check_packets(bvh: &Bvh, rays: &[Ray], ties: bool) -> usize {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            assert!(bvh.walks_packets(), "a small tree is walked by packets");
        }
        // The dispatching entry points, then each instruction set the CPU
        // has, called directly (packets of one ray included).
        #[cfg(target_arch = "x86_64")]
        let walks: Vec<Option<PacketIsa>> = [
            None,
            Some(PacketIsa::Avx2),
            Some(PacketIsa::Avx512Vl),
            Some(PacketIsa::Avx512),
        ]
        .into_iter()
        .filter(|w| w.is_none_or(PacketIsa::available))
        .collect();
        #[cfg(not(target_arch = "x86_64"))]
        let walks = [None::<()>];
        let mut hit = 0;
        for walk in walks {
            hit = 0;
            let mut start = 0;
            let mut size = 1;
            while start < rays.len() {
                let chunk = &rays[start..(start + size).min(rays.len())];
                let mut hits = [None; PACKET_LANES];
                let mut blocked = [false; PACKET_LANES];
                match walk {
                    #[cfg(target_arch = "x86_64")]
                    Some(isa) => {
                        bvh.intersect_packet_in(isa, chunk, &mut hits);
                        let b = bvh.occluded_packet_in(isa, chunk);
                        for (k, blocked) in blocked.iter_mut().enumerate() {
                            *blocked = b & (1 << k) != 0;
                        }
                    }
                    _ => {
                        bvh.intersect_packet(chunk, &mut hits);
                        bvh.occluded_packet(chunk, &mut blocked[..chunk.len()]);
                    }
                }
                for (k, ray) in chunk.iter().enumerate() {
                    let alone = bvh.intersect(ray);
                    let (packed, alone_bits) = if ties {
                        (hits[k].map(|h| h.t.to_bits()), alone.map(|h| h.t.to_bits()))
                    } else {
                        (bits(hits[k]).map(|b| b.0), bits(alone).map(|b| b.0))
                    };
                    let at = format!("{walk:?}, ray {} {ray:?}", start + k);
                    assert_eq!(packed, alone_bits, "{at}");
                    if !ties {
                        assert_eq!(bits(hits[k]), bits(alone), "{at}");
                    }
                    assert_eq!(blocked[k], bvh.occluded(ray), "{at}");
                    hit += usize::from(alone.is_some());
                }
                start += chunk.len();
                size = size % PACKET_LANES + 1;
            }
        }
        hit
    }

    /// A tree too big for packets tests its leaves' triangles in lanes;
    /// it finds what the primitive loop finds, bit for bit (hit record
    /// and occlusion): on a grid of 3,200 triangles whose shared edges and
    /// vertices rays pass exactly through (the lanes hand those leaves to
    /// the loop), a random soup, and spheres, a disk, a rectangle and a
    /// curve among them (leaves of mixed kinds).
    #[test]
    fn leaf_lanes_find_what_the_primitive_loop_finds() {
        use crate::geometry::{Curve, CurveBasis, Disk, Rectangle, Sphere};
        use crate::math::{Mat4, Transform};
        use crate::sampling::Sampler;
        let mut s = Sampler::for_pixel_sample(21, 4, 5, 0);
        let mut v = |scale: f32| (Vec3::new(s.next_1d(), s.next_1d(), s.next_1d()) - 0.5) * scale;
        let (mut p, mut tris) = (Vec::new(), Vec::new());
        let n = 41u32;
        for j in 0..n {
            for i in 0..n {
                p.push(Vec3::new(i as f32 - 20.0, j as f32 - 20.0, 0.0));
            }
        }
        for j in 0..n - 1 {
            for i in 0..n - 1 {
                let a = j * n + i;
                tris.extend([[a, a + 1, a + n + 1], [a, a + n + 1, a + n]]);
            }
        }
        for _ in 0..1000 {
            let c = v(30.0) + Vec3::new(0.0, 0.0, 6.0);
            let k = p.len() as u32;
            p.extend([c, c + v(3.0), c + v(3.0)]);
            tris.push([k, k + 1, k + 2]);
        }
        let t = |m: Mat4| Transform::new(m).unwrap();
        let curve = Curve::parse(
            "-3 0 4 0.3\n0 2 4 0.3\n3 0 5 0.2\n",
            CurveBasis::Linear,
            &Transform::IDENTITY,
        )
        .unwrap();
        let shapes = vec![
            Geometry::Mesh(TriangleMesh::new(p, vec![], vec![], tris).unwrap()),
            Geometry::Sphere(Sphere::new(Vec3::new(1.5, 0.5, 2.0), 1.5).unwrap()),
            Geometry::Sphere(Sphere::new(Vec3::new(-4.0, -1.0, 1.0), 0.5).unwrap()),
            Geometry::Disk(
                Disk::new(&t(Mat4::from_translation(Vec3::new(5.0, 5.0, 3.0)))).unwrap(),
            ),
            Geometry::Rectangle(
                Rectangle::new(&t(Mat4::from_translation(Vec3::new(-5.0, 5.0, 2.0)))).unwrap(),
            ),
            Geometry::Curve(curve),
        ];
        let lanes = Bvh::build(&shapes);
        let mut plain = Bvh::build(&shapes);
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            assert!(
                lanes.leaf_lanes,
                "a tree of 4,205 primitives tests leaves in lanes"
            );
        }
        plain.leaf_lanes = false;
        let mut s = Sampler::for_pixel_sample(22, 0, 1, 0);
        let (mut hit, mut edges) = (0, 0);
        for i in 0..30_000 {
            let mut u = || s.next_1d();
            let ray = match i % 4 {
                // Straight down through a vertex or along an edge of the grid.
                0 | 1 => {
                    let (x, y) = ((u() * 40.0).floor() - 20.0, (u() * 40.0).floor() - 20.0);
                    let x = if i % 4 == 1 { x + 0.5 } else { x };
                    Ray::new(Vec3::new(x, y, 9.0), Vec3::new(0.0, 0.0, -1.0))
                }
                // Random, some with a short range.
                _ => {
                    let o = (Vec3::new(u(), u(), u()) - 0.5) * 40.0 + Vec3::new(0.0, 0.0, 8.0);
                    let d = (Vec3::new(u(), u(), u()) - 0.5).normalize();
                    let tmax = if i % 7 == 0 { 5.0 } else { f32::INFINITY };
                    Ray::with_range(o, d, 0.0, tmax)
                }
            };
            let found = lanes.intersect(&ray);
            assert_eq!(bits(found), bits(plain.intersect(&ray)), "ray {i} {ray:?}");
            assert_eq!(
                lanes.occluded(&ray),
                plain.occluded(&ray),
                "ray {i} {ray:?}"
            );
            hit += usize::from(found.is_some());
            edges += usize::from(i % 4 < 2 && found.is_some_and(|h| h.shape == 0 && h.t == 9.0));
        }
        assert!(hit > 15_000, "{hit} of 30,000 rays hit");
        assert!(
            edges > 5_000,
            "{edges} rays through the grid's edges and vertices"
        );
    }

    /// Triangles (a random soup and a quad's two halves), spheres, a
    /// disk, a rectangle, a linear curve and two instances of a group
    /// holding a sphere and a triangle, met by random rays (some along an
    /// axis, some from inside a sphere, some with a short range): the
    /// packet walk's hits are the one-ray walk's, bit for bit.
    #[test]
    fn packets_find_what_single_rays_find() {
        use crate::geometry::{Curve, CurveBasis, Disk, Instance, Rectangle, Sphere};
        use crate::math::{Mat4, Transform};
        use crate::sampling::Sampler;
        let mut s = Sampler::for_pixel_sample(11, 2, 3, 0);
        let mut v = |scale: f32| (Vec3::new(s.next_1d(), s.next_1d(), s.next_1d()) - 0.5) * scale;
        let mut p = Vec::new();
        let mut tris = Vec::new();
        for _ in 0..24 {
            let c = v(6.0);
            let n = p.len() as u32;
            p.extend([c, c + v(2.0), c + v(2.0)]);
            tris.push([n, n + 1, n + 2]);
        }
        let n = p.len() as u32;
        p.extend([
            Vec3::new(-1.0, -1.0, 2.0),
            Vec3::new(1.0, -1.0, 2.0),
            Vec3::new(1.0, 1.0, 2.0),
            Vec3::new(-1.0, 1.0, 2.0),
        ]);
        tris.extend([[n, n + 1, n + 2], [n, n + 2, n + 3]]);
        let mesh = TriangleMesh::new(p, vec![], vec![], tris).unwrap();
        let t = |m: Mat4| Transform::new(m).unwrap();
        let small = TriangleMesh::new(
            vec![Vec3::ZERO, Vec3::X, Vec3::Y],
            vec![],
            vec![],
            vec![[0, 1, 2]],
        )
        .unwrap();
        let curve = Curve::parse(
            "-2 0 0 0.1\n0 1 0 0.2\n2 0 1 0.1\n",
            CurveBasis::Linear,
            &Transform::IDENTITY,
        )
        .unwrap();
        let shapes = vec![
            Geometry::Mesh(mesh),
            Geometry::Sphere(Sphere::new(Vec3::new(1.0, 0.5, -1.0), 1.5).unwrap()),
            Geometry::Sphere(Sphere::new(Vec3::new(-2.0, -1.0, 1.0), 0.5).unwrap()),
            Geometry::Disk(
                Disk::new(&t(
                    Mat4::from_rotation_x(0.6) * Mat4::from_scale(Vec3::splat(1.5))
                ))
                .unwrap(),
            ),
            Geometry::Rectangle(
                Rectangle::new(&t(
                    Mat4::from_translation(Vec3::new(0.0, -2.0, 0.5)) * Mat4::from_rotation_y(-0.4)
                ))
                .unwrap(),
            ),
            Geometry::Curve(curve),
            // The group: a sphere and a triangle.
            Geometry::Sphere(Sphere::new(Vec3::ZERO, 0.4).unwrap()),
            Geometry::Mesh(small),
        ];
        let instances = vec![
            Instance {
                group: 0,
                to_world: t(Mat4::from_translation(Vec3::new(2.0, 2.0, 2.0))),
            },
            Instance {
                group: 0,
                to_world: t(Mat4::from_translation(Vec3::new(-2.0, 2.0, -1.0))
                    * Mat4::from_scale(Vec3::new(1.0, 2.0, 0.5))),
            },
        ];
        let group = 6..8;
        let bvh = Bvh::build_instanced(&shapes, 6, std::slice::from_ref(&group), instances);
        let mut s = Sampler::for_pixel_sample(12, 0, 1, 0);
        let rays: Vec<Ray> = (0..6000)
            .map(|i| {
                let mut o = (Vec3::new(s.next_1d(), s.next_1d(), s.next_1d()) - 0.5) * 10.0;
                let mut d = Vec3::new(s.next_1d(), s.next_1d(), s.next_1d()) - 0.5;
                match i % 5 {
                    0 => {
                        d.x = 0.0;
                        d.y = if i % 2 == 0 { 0.0 } else { -0.0 };
                    }
                    1 => o = Vec3::new(1.0, 0.5, -1.0) + d,
                    _ => {}
                }
                let tmax = if i % 7 == 0 { 2.0 } else { f32::INFINITY };
                Ray::with_range(o, d.normalize(), if i % 3 == 0 { 0.5 } else { 0.0 }, tmax)
            })
            .collect();
        let hit = check_packets(&bvh, &rays, false);
        assert!(hit > 1000 && hit < 5000, "{hit} of 6000 rays hit");
        // Each kind of primitive was hit by some ray.
        let mut met = [0; 7];
        for ray in &rays {
            if let Some(h) = bvh.intersect(ray) {
                let slot = if h.instance == BvhHit::NO_INSTANCE {
                    h.shape as usize
                } else {
                    6
                };
                met[slot] += 1;
            }
        }
        assert!(met.iter().all(|&m| m > 0), "hits per shape: {met:?}");
    }

    /// Rays along z through a quad's shared diagonal and vertices: their
    /// edge functions come out exactly zero, so the packet redoes them
    /// with the one-ray test (in double precision) and finds a hit at the
    /// same distance. On the diagonal both halves are hit at that distance
    /// and the walks, visiting them in different orders, may keep
    /// different ones.
    #[test]
    fn packets_through_edges_and_vertices_find_the_same() {
        let p = vec![
            Vec3::new(0.0, 0.0, 1.0),
            Vec3::new(1.0, 0.0, 1.0),
            Vec3::new(1.0, 1.0, 1.0),
            Vec3::new(0.0, 1.0, 1.0),
        ];
        let mesh = TriangleMesh::new(p, vec![], vec![], vec![[0, 1, 2], [0, 2, 3]]).unwrap();
        let bvh = Bvh::build(&[Geometry::Mesh(mesh)]);
        let mut rays = Vec::new();
        for i in 0..=8 {
            for j in 0..=8 {
                let o = Vec3::new(i as f32 / 8.0, j as f32 / 8.0, 0.0);
                rays.push(Ray::new(o, Vec3::Z));
            }
        }
        // Every ray lands on the closed quad: none slips through an edge.
        assert_eq!(check_packets(&bvh, &rays, true), rays.len());
    }

    /// One triangle repeated 20,000 times: PLOC's merge costs all tie, and
    /// before `build_boxes` broke the ties the tree came out a chain of
    /// thousands of levels (a quadratic build: 28 s).
    #[test]
    fn identical_primitives_build_a_shallow_tree() {
        let n = 20_000;
        let p = vec![Vec3::ZERO, Vec3::X, Vec3::Y];
        let mesh = TriangleMesh::new(p, vec![], vec![], vec![[0, 1, 2]; n]).unwrap();
        let bvh = Bvh::build(&[Geometry::Mesh(mesh)]);
        assert_eq!(bvh.primitive_count(), n);
        // A balanced 8-wide tree over 2,500 leaves of 8 is 4 deep.
        assert!(bvh.depth() <= 12, "depth {}", bvh.depth());
        let ray = Ray::new(Vec3::new(0.25, 0.25, 1.0), -Vec3::Z);
        let hit = bvh.intersect(&ray).expect("the triangle is hit");
        assert!((hit.t - 1.0).abs() < 1e-6);
    }
}
