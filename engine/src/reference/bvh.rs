//! A bounding volume hierarchy over **moving** triangles (camera space, linear vertex motion) for one
//! interval `[t_a, t_b]` of the shutter in which every triangle moves linearly (the whole shutter for
//! two-key motion; between two consecutive motion keys of the scene otherwise, one tree per interval).
//!
//! Every node stores its bounding box at the interval's start and end; at ray time `t` the node is
//! tested against `lerp(box0, box1, u)`, `u` the time's fraction of the interval. Because each vertex
//! moves linearly, a vertex at time `t` lies inside the interpolated box of any box pair that contains
//! it at both ends, so the test is conservative (boxes are padded by a few ulps to absorb rounding of
//! the interpolation). The triangles themselves are evaluated exactly as every renderer does: each
//! keeps its key segment ([`SegmentTriangle`]), so a hit is bit-identical to the GPU's.
//!
//! Built top-down with binned SAH on the mid-shutter centroids (cost = open + close surface area),
//! flattened depth-first (left child follows its parent), traversed iteratively, nearest child first.
//! Triangles are [`MovingTriangle`]s tested with the shared [`intersect_triangle`] (the GPU's inside
//! test), so the nearest hit is the nearest by the GPU's barycentric view depth.

use glam::Vec3;

use crate::geometry::{intersect_triangle, MovingTriangle, TriangleHit};

/// A triangle over one key segment of its object's motion: its vertices at the segment's keys, and the
/// segment's start time and inverse length ([`crate::geometry::KeyTimes`]), so that at shutter time
/// `t` it is `tri.at(min((t − t0)·inv_len, 1))`, exactly as the GPU evaluates it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SegmentTriangle {
    pub tri: MovingTriangle,
    pub t0: f32,
    pub inv_len: f32,
}

impl SegmentTriangle {
    /// The triangle moving over the whole shutter (two keys, 0 and 1).
    pub fn whole_shutter(tri: MovingTriangle) -> Self {
        SegmentTriangle { tri, t0: 0.0, inv_len: 1.0 }
    }
    /// The vertices at shutter time `t`.
    #[inline(always)]
    pub fn at(&self, t: f32) -> [Vec3; 3] {
        self.tri.at(((t - self.t0) * self.inv_len).min(1.0))
    }
    /// The vertices at shutter time `t`, exact at the segment's keys.
    fn at_exact(&self, t: f32) -> [Vec3; 3] {
        let s = ((t - self.t0) * self.inv_len).min(1.0);
        if s <= 0.0 {
            self.tri.v0
        } else if s >= 1.0 {
            self.tri.v1
        } else {
            self.tri.at(s)
        }
    }
}

/// Axis-aligned box.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    pub min: Vec3,
    pub max: Vec3,
}

impl Aabb {
    pub const EMPTY: Aabb = Aabb { min: Vec3::splat(f32::INFINITY), max: Vec3::splat(f32::NEG_INFINITY) };

    fn of(points: &[Vec3; 3]) -> Aabb {
        Aabb { min: points[0].min(points[1]).min(points[2]), max: points[0].max(points[1]).max(points[2]) }
    }
    fn union(self, o: Aabb) -> Aabb {
        Aabb { min: self.min.min(o.min), max: self.max.max(o.max) }
    }
    fn grow(self, p: Vec3) -> Aabb {
        Aabb { min: self.min.min(p), max: self.max.max(p) }
    }
    fn centre(self) -> Vec3 {
        0.5 * (self.min + self.max)
    }
    /// Surface area (0 for an empty box).
    fn area(self) -> f32 {
        let e = (self.max - self.min).max(Vec3::ZERO);
        2.0 * (e.x * e.y + e.y * e.z + e.z * e.x)
    }
}

/// One node of the flattened tree: boxes at both shutter ends. `count == 0`: interior node whose left
/// child is the next node and whose right child is `first`; otherwise a leaf over triangles
/// `first..first + count` (BVH order).
#[derive(Clone, Copy, Debug)]
struct Node {
    bounds: [Aabb; 2],
    first: u32,
    count: u32,
}

/// The nearest accepted hit along a ray.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Index of the triangle in the list given to [`Bvh::build`].
    pub id: u32,
    /// View depth and barycentrics, from the shared [`intersect_triangle`].
    pub hit: TriangleHit,
}

/// Relative slack of the depth → ray-parameter bounds the traversal prunes with. A hit's depth is the
/// barycentric interpolation of the vertices' `z` (the GPU's), not the depth of the ray's exact point on the
/// triangle; the two differ by rounding, amplified for grazing rays (below 1e-5 of the depth for millions of
/// rays grazing a plane, measured against `f64`). A node is skipped only when the ray enters its box more
/// than this fraction beyond the best hit's (or the far plane's) depth, so the rounding cannot hide a nearer
/// hit; it costs a few extra node visits next to the hit.
const DEPTH_SLACK: f32 = 1e-3;

/// Does view depth grow along direction `d` (`d.z < 0`), and is `[near, far]` a range? False for NaN.
fn depth_grows_within(d: Vec3, near: f32, far: f32) -> bool {
    d.z < 0.0 && near <= far
}

/// BVH over moving triangles.
#[derive(Clone, Debug)]
pub struct Bvh {
    nodes: Vec<Node>,
    /// Triangles in BVH (leaf) order.
    tris: Vec<SegmentTriangle>,
    /// The shutter interval the node boxes span: start and inverse length.
    t0: f32,
    inv_len: f32,
    /// For each triangle in BVH order, its index in the input list.
    ids: Vec<u32>,
}

const BINS: usize = 16;
const MAX_LEAF: usize = 8;
/// Past this depth the builder splits at the object median, which bounds the depth by
/// `FORCE_MEDIAN_DEPTH + log2(n)`.
const FORCE_MEDIAN_DEPTH: usize = 64;
/// Traversal stack size: depth can reach `FORCE_MEDIAN_DEPTH + 32`.
const STACK: usize = 128;
/// Relative cost of visiting a node vs. testing a triangle.
const TRAVERSAL_COST: f32 = 1.0;

struct Builder<'a> {
    boxes: &'a [[Aabb; 2]],
    centres: &'a [Vec3],
    nodes: Vec<Node>,
}

fn cost_area(b: &[Aabb; 2]) -> f32 {
    b[0].area() + b[1].area()
}

impl Builder<'_> {
    fn bounds_of(&self, prims: &[u32]) -> ([Aabb; 2], Aabb) {
        let mut b = [Aabb::EMPTY; 2];
        let mut c = Aabb::EMPTY;
        for &i in prims {
            let pb = &self.boxes[i as usize];
            b[0] = b[0].union(pb[0]);
            b[1] = b[1].union(pb[1]);
            c = c.grow(self.centres[i as usize]);
        }
        (b, c)
    }

    /// Builds the subtree over `prims` (which start at `offset` in the final triangle order), returns
    /// its node index.
    fn build(&mut self, prims: &mut [u32], offset: usize, depth: usize) -> u32 {
        let (bounds, cbox) = self.bounds_of(prims);
        let index = self.nodes.len() as u32;
        self.nodes.push(Node { bounds, first: offset as u32, count: prims.len() as u32 });
        let n = prims.len();
        if n <= 2 {
            return index;
        }
        let mid = match self.choose_split(prims, &bounds, cbox, depth) {
            Some(mid) => mid,
            None => return index,
        };
        let (left, right) = prims.split_at_mut(mid);
        self.build(left, offset, depth + 1);
        let r = self.build(right, offset + mid, depth + 1);
        let node = &mut self.nodes[index as usize];
        node.first = r;
        node.count = 0;
        index
    }

    /// Partitions `prims` and returns the split point, or None to make a leaf.
    fn choose_split(&self, prims: &mut [u32], bounds: &[Aabb; 2], cbox: Aabb, depth: usize) -> Option<usize> {
        let n = prims.len();
        let extent = cbox.max - cbox.min;
        let axis = if extent.x >= extent.y && extent.x >= extent.z {
            0
        } else if extent.y >= extent.z {
            1
        } else {
            2
        };
        if depth >= FORCE_MEDIAN_DEPTH
            || extent.max_element().partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater)
        {
            if n <= MAX_LEAF {
                return None;
            }
            return self.median(prims, axis);
        }
        // Binned SAH over all three axes.
        let mut best: Option<(f32, usize, usize)> = None; // (cost, axis, first bin of the right side)
        for ax in 0..3 {
            let (lo, ext) = (cbox.min[ax], extent[ax]);
            if ext.is_nan() || ext <= 0.0 {
                continue;
            }
            let k = BINS as f32 / ext;
            let bin_of = |i: u32| (((self.centres[i as usize][ax] - lo) * k) as usize).min(BINS - 1);
            let mut counts = [0usize; BINS];
            let mut boxes = [[Aabb::EMPTY; 2]; BINS];
            for &i in prims.iter() {
                let b = bin_of(i);
                counts[b] += 1;
                let pb = &self.boxes[i as usize];
                boxes[b] = [boxes[b][0].union(pb[0]), boxes[b][1].union(pb[1])];
            }
            // Suffix sweep.
            let mut right_cost = [0.0f32; BINS];
            let mut acc = [Aabb::EMPTY; 2];
            let mut cnt = 0;
            for b in (1..BINS).rev() {
                acc = [acc[0].union(boxes[b][0]), acc[1].union(boxes[b][1])];
                cnt += counts[b];
                right_cost[b] = cnt as f32 * cost_area(&acc);
            }
            let mut acc = [Aabb::EMPTY; 2];
            let mut cnt = 0;
            for b in 0..BINS - 1 {
                acc = [acc[0].union(boxes[b][0]), acc[1].union(boxes[b][1])];
                cnt += counts[b];
                if cnt == 0 || cnt == n {
                    continue;
                }
                let cost = cnt as f32 * cost_area(&acc) + right_cost[b + 1];
                if !matches!(best, Some((c, _, _)) if c <= cost) {
                    best = Some((cost, ax, b + 1));
                }
            }
        }
        let parent_area = cost_area(bounds).max(f32::MIN_POSITIVE);
        let Some((cost, ax, best_bin)) = best else {
            return if n <= MAX_LEAF { None } else { self.median(prims, axis) };
        };
        let split_cost = TRAVERSAL_COST + cost / parent_area;
        if split_cost >= n as f32 && n <= MAX_LEAF {
            return None;
        }
        // Partition by the same bin function used for costing (so the split matches the estimate).
        let lo = cbox.min[ax];
        let k = BINS as f32 / extent[ax];
        let in_left =
            |i: u32| ((((self.centres[i as usize][ax] - lo) * k) as usize).min(BINS - 1)) < best_bin;
        let mut l = 0;
        for j in 0..n {
            if in_left(prims[j]) {
                prims.swap(l, j);
                l += 1;
            }
        }
        if l == 0 || l == n {
            return self.median(prims, axis);
        }
        Some(l)
    }

    /// Object median along `axis` (index order breaks ties, so the result is deterministic).
    fn median(&self, prims: &mut [u32], axis: usize) -> Option<usize> {
        let mid = prims.len() / 2;
        let c = self.centres;
        prims.select_nth_unstable_by(mid, |&a, &b| {
            c[a as usize][axis].total_cmp(&c[b as usize][axis]).then(a.cmp(&b))
        });
        Some(mid)
    }
}

/// Pads a box outward by a few ulps of the largest coordinate magnitude on each axis (over both ends),
/// so rounding in `lerp` can never put an interpolated vertex outside its interpolated node box.
fn pad(bounds: [Aabb; 2]) -> [Aabb; 2] {
    let mag = bounds[0].min.abs().max(bounds[0].max.abs()).max(bounds[1].min.abs()).max(bounds[1].max.abs());
    let eps = mag * 4.0e-6 + Vec3::splat(1.0e-30);
    bounds.map(|b| Aabb { min: b.min - eps, max: b.max + eps })
}

impl Bvh {
    /// Builds the tree over triangles moving linearly over the whole shutter. Triangles with
    /// non-finite vertices are left out (they can never be hit).
    pub fn build(triangles: &[MovingTriangle]) -> Bvh {
        let tris: Vec<SegmentTriangle> =
            triangles.iter().map(|&t| SegmentTriangle::whole_shutter(t)).collect();
        Bvh::build_interval(&tris, 0.0, 1.0)
    }

    /// Builds the tree for shutter times `[t_a, t_b]`, in which each triangle stays in its one key
    /// segment (`t_a`, `t_b` consecutive keys of the union of all objects' keys). Triangles with
    /// non-finite vertices are left out.
    pub fn build_interval(triangles: &[SegmentTriangle], t_a: f32, t_b: f32) -> Bvh {
        let boxes: Vec<[Aabb; 2]> =
            triangles.iter().map(|t| [Aabb::of(&t.at_exact(t_a)), Aabb::of(&t.at_exact(t_b))]).collect();
        let centres: Vec<Vec3> = boxes.iter().map(|b| 0.5 * (b[0].centre() + b[1].centre())).collect();
        let mut prims: Vec<u32> =
            (0..triangles.len() as u32).filter(|&i| triangles[i as usize].tri.is_finite()).collect();
        let mut builder = Builder { boxes: &boxes, centres: &centres, nodes: Vec::new() };
        if !prims.is_empty() {
            builder.nodes.reserve(2 * prims.len());
            builder.build(&mut prims, 0, 0);
        }
        let mut nodes = builder.nodes;
        for n in &mut nodes {
            n.bounds = pad(n.bounds);
        }
        let tris = prims.iter().map(|&i| triangles[i as usize]).collect();
        Bvh { nodes, tris, ids: prims, t0: t_a, inv_len: 1.0 / (t_b - t_a) }
    }

    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }

    pub fn triangle_count(&self) -> usize {
        self.tris.len()
    }

    /// Depth of the tree (a single leaf has depth 1; empty tree 0).
    pub fn depth(&self) -> usize {
        fn rec(nodes: &[Node], i: usize) -> usize {
            let n = &nodes[i];
            if n.count > 0 {
                1
            } else {
                1 + rec(nodes, i + 1).max(rec(nodes, n.first as usize))
            }
        }
        if self.nodes.is_empty() {
            0
        } else {
            rec(&self.nodes, 0)
        }
    }

    /// Entry ray parameter of the ray into `node`'s box at `time`, or +∞ when it misses within
    /// `[t_min, t_max]`.
    #[inline(always)]
    fn enter(node: &Node, time: f32, o: Vec3, inv_d: Vec3, t_min: f32, t_max: f32) -> f32 {
        let lo = node.bounds[0].min.lerp(node.bounds[1].min, time);
        let hi = node.bounds[0].max.lerp(node.bounds[1].max, time);
        let a = (lo - o) * inv_d;
        let b = (hi - o) * inv_d;
        // A NaN slab (origin on a flat box's plane, ray parallel to it) is ignored by min/max, i.e. the
        // axis is treated as unbounded: conservative.
        let near = a.min(b).max_element().max(t_min);
        // 1 + 2γ₃ widening of the far distance (robust slab test).
        let far = a.max(b).min_element().min(t_max) * (1.0 + 4.0 * f32::EPSILON);
        if near <= far {
            near
        } else {
            f32::INFINITY
        }
    }

    /// The ordered traversal of [`Bvh::intersect_filtered`] and [`Bvh::nearest`]: the leaves whose
    /// boxes the ray `o + s·d` enters at shutter time `time` within `[s_min, limit]`, nearest entry
    /// first, `leaf(k, &mut limit)` called for each of their triangles (index into `tris`). `leaf`
    /// lowers `limit` as it finds nearer hits; a node whose entry lies beyond the current limit is
    /// skipped.
    #[inline]
    fn front_to_back(
        &self,
        o: Vec3,
        d: Vec3,
        time: f32,
        s_min: f32,
        mut limit: f32,
        mut leaf: impl FnMut(usize, &mut f32),
    ) {
        let inv_d = d.recip();
        // The nodes' time: the fraction of the tree's interval (exactly `time` for the whole shutter).
        let box_time = ((time - self.t0) * self.inv_len).clamp(0.0, 1.0);
        let mut stack = [(0u32, 0.0f32); STACK];
        let root = Self::enter(&self.nodes[0], box_time, o, inv_d, s_min, limit);
        if root == f32::INFINITY {
            return;
        }
        stack[0] = (0, root);
        let mut sp = 1;
        while sp > 0 {
            sp -= 1;
            let (mut ni, entry) = stack[sp];
            if entry > limit {
                continue;
            }
            loop {
                let node = &self.nodes[ni as usize];
                if node.count > 0 {
                    let first = node.first as usize;
                    for k in first..first + node.count as usize {
                        leaf(k, &mut limit);
                    }
                    break;
                }
                let (l, r) = (ni + 1, node.first);
                let tl = Self::enter(&self.nodes[l as usize], box_time, o, inv_d, s_min, limit);
                let tr = Self::enter(&self.nodes[r as usize], box_time, o, inv_d, s_min, limit);
                let (near_child, far_child, tn, tf) = if tl <= tr { (l, r, tl, tr) } else { (r, l, tr, tl) };
                if tn == f32::INFINITY {
                    break;
                }
                if tf != f32::INFINITY {
                    stack[sp] = (far_child, tf);
                    sp += 1;
                }
                ni = near_child;
            }
        }
    }

    /// The nearest hit at shutter time `time` whose view depth lies in `[near, far]`, among triangles
    /// for which `accept(id)` says yes (`id` = index in the build list). Hits are found by the shared
    /// [`intersect_triangle`] and ordered by its (barycentric) depth; on an exact tie the first found
    /// wins. `accept` is asked only for triangles the ray hits in range and nearer than the best hit so
    /// far (stochastic alpha).
    ///
    /// Depth along the ray `o + s·d` is `−(o.z + s·d.z)`, increasing in `s` when `d.z < 0` (primary rays
    /// start on the lens plane and go forward): the node boxes are pruned in ray-parameter units, with
    /// `s = (depth + o.z) / −d.z` widened by `DEPTH_SLACK`. Rays with `d.z ≥ 0` (or NaN) and an empty
    /// or NaN depth range find nothing. As on the GPU, no separate test excludes points behind the
    /// origin: for a primary ray (`o.z = 0`) they have depth < 0, below any `near > 0`.
    #[inline]
    pub fn intersect(
        &self,
        o: Vec3,
        d: Vec3,
        time: f32,
        near: f32,
        far: f32,
        mut accept: impl FnMut(u32) -> bool,
    ) -> Option<Hit> {
        self.intersect_filtered(o, d, time, near, far, |id, _| accept(id))
    }

    /// [`Bvh::intersect`] whose filter also sees the candidate hit (its barycentrics, for coverage
    /// from a texture's alpha; its depth, to tell which rejected surfaces lie in front of the hit).
    #[inline]
    pub fn intersect_filtered(
        &self,
        o: Vec3,
        d: Vec3,
        time: f32,
        near: f32,
        far: f32,
        mut accept: impl FnMut(u32, &TriangleHit) -> bool,
    ) -> Option<Hit> {
        if self.nodes.is_empty() || !depth_grows_within(d, near, far) {
            return None;
        }
        let ray_parameter = |depth: f32| (depth + o.z) / -d.z;
        let s_min = ray_parameter(near - DEPTH_SLACK * near.abs());
        let s_bound = |depth: f32| ray_parameter(depth + DEPTH_SLACK * depth.abs());
        let mut best = f32::INFINITY;
        let mut hit: Option<Hit> = None;
        self.front_to_back(o, d, time, s_min, s_bound(far), |k, s_max| {
            let Some(h) = intersect_triangle(&self.tris[k].at(time), o, d) else { return };
            if h.depth_z >= near && h.depth_z <= far && h.depth_z < best {
                let id = self.ids[k];
                if accept(id, &h) {
                    best = h.depth_z;
                    *s_max = s_bound(best);
                    hit = Some(Hit { id, hit: h });
                }
            }
        });
        hit
    }

    /// Every hit at shutter time `time` along the segment `o + s·d`, `s_min < s < s_max`, in any
    /// direction (shadow rays; not only the camera's forward rays [`Bvh::intersect`] handles), in no
    /// particular order: `visit(id, hit, s)` for each, stopping when it returns false. `s` is the ray
    /// parameter of the hit's barycentric point. A ray through an edge shared by two triangles hits
    /// both (the intersector is edges-inclusive); the caller decides whether that is one crossing.
    pub fn for_each_hit(
        &self,
        o: Vec3,
        d: Vec3,
        time: f32,
        s_min: f32,
        s_max: f32,
        mut visit: impl FnMut(u32, &TriangleHit, f32) -> bool,
    ) {
        let d2 = d.length_squared();
        let range = s_min < s_max; // false for NaN
        if self.nodes.is_empty() || !(d2 > 0.0 && d2.is_finite()) || !range {
            return;
        }
        let inv_d = d.recip();
        let box_time = ((time - self.t0) * self.inv_len).clamp(0.0, 1.0);
        let mut stack = [0u32; STACK];
        let mut sp = 0;
        if Self::enter(&self.nodes[0], box_time, o, inv_d, s_min, s_max) != f32::INFINITY {
            stack[0] = 0;
            sp = 1;
        }
        while sp > 0 {
            sp -= 1;
            let ni = stack[sp];
            let node = &self.nodes[ni as usize];
            if node.count > 0 {
                let first = node.first as usize;
                for k in first..first + node.count as usize {
                    let p = self.tris[k].at(time);
                    let Some(h) = intersect_triangle(&p, o, d) else { continue };
                    let s = (h.point(&p) - o).dot(d) / d2;
                    if s > s_min && s < s_max && !visit(self.ids[k], &h, s) {
                        return;
                    }
                }
                continue;
            }
            for child in [ni + 1, node.first] {
                if Self::enter(&self.nodes[child as usize], box_time, o, inv_d, s_min, s_max) != f32::INFINITY
                {
                    stack[sp] = child;
                    sp += 1;
                }
            }
        }
    }

    /// The nearest hit `accept` admits at shutter time `time` along the segment `o + s·d`,
    /// `s_min < s < s_max`, in any direction (one-bounce indirect light's rays), with its ray parameter
    /// `s` (of the hit's barycentric point, as [`Bvh::for_each_hit`]): nodes beyond the best hit so
    /// far are skipped.
    pub fn nearest(
        &self,
        o: Vec3,
        d: Vec3,
        time: f32,
        s_min: f32,
        s_max: f32,
        mut accept: impl FnMut(u32, &TriangleHit) -> bool,
    ) -> Option<(Hit, f32)> {
        let d2 = d.length_squared();
        let range = s_min < s_max; // false for NaN
        if self.nodes.is_empty() || !(d2 > 0.0 && d2.is_finite()) || !range {
            return None;
        }
        let mut best: Option<(Hit, f32)> = None;
        self.front_to_back(o, d, time, s_min, s_max, |k, limit| {
            let p = self.tris[k].at(time);
            let Some(h) = intersect_triangle(&p, o, d) else { return };
            let s = (h.point(&p) - o).dot(d) / d2;
            if s > s_min && s < *limit && accept(self.ids[k], &h) {
                *limit = s;
                best = Some((Hit { id: self.ids[k], hit: h }, s));
            }
        });
        best
    }

    /// Reference for tests: the hit [`Bvh::intersect`] should find (same rules), by testing every
    /// triangle in list order.
    pub fn brute_force(
        triangles: &[MovingTriangle],
        o: Vec3,
        d: Vec3,
        time: f32,
        near: f32,
        far: f32,
    ) -> Option<Hit> {
        if !depth_grows_within(d, near, far) {
            return None;
        }
        let mut best = f32::INFINITY;
        let mut hit = None;
        for (i, tri) in triangles.iter().enumerate() {
            let Some(h) = intersect_triangle(&tri.at(time), o, d) else { continue };
            if h.depth_z >= near && h.depth_z <= far && h.depth_z < best {
                best = h.depth_z;
                hit = Some(Hit { id: i as u32, hit: h });
            }
        }
        hit
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Pcg32;

    fn rnd3(r: &mut Pcg32, scale: f32) -> Vec3 {
        Vec3::new(r.next_f32() - 0.5, r.next_f32() - 0.5, r.next_f32() - 0.5) * scale
    }

    /// Moving and deforming triangles in front of the lens plane (depths about 5 to 45).
    fn random_scene(r: &mut Pcg32, n: usize) -> Vec<MovingTriangle> {
        (0..n)
            .map(|i| {
                let c = rnd3(r, 20.0) - 25.0 * Vec3::Z;
                let size = if i % 17 == 0 { 8.0 } else { 1.5 };
                let v0 = [c + rnd3(r, size), c + rnd3(r, size), c + rnd3(r, size)];
                let motion = if i % 3 == 0 { Vec3::ZERO } else { rnd3(r, 6.0) };
                // Some triangles also deform (vertices move independently).
                let v1 = if i % 5 == 0 {
                    [v0[0] + motion, v0[1] + rnd3(r, 4.0), v0[2] + motion]
                } else {
                    v0.map(|p| p + motion)
                };
                MovingTriangle { v0, v1 }
            })
            .collect()
    }

    /// A primary ray: origin on the lens plane z = 0, going forward.
    fn lens_ray(r: &mut Pcg32, target: Vec3) -> (Vec3, Vec3) {
        let o = Vec3::new(r.next_f32() - 0.5, r.next_f32() - 0.5, 0.0) * 4.0;
        (o, (target - o).normalize())
    }

    /// Asserts that the BVH finds the brute force's hit: the same depth (and, but for an exact depth
    /// tie, the same triangle and barycentrics). Returns whether there was a hit.
    fn check_ray(
        bvh: &Bvh,
        tris: &[MovingTriangle],
        o: Vec3,
        d: Vec3,
        time: f32,
        near: f32,
        far: f32,
    ) -> bool {
        let a = bvh.intersect(o, d, time, near, far, |_| true);
        let b = Bvh::brute_force(tris, o, d, time, near, far);
        match (a, b) {
            (None, None) => false,
            (Some(a), Some(b)) => {
                assert_eq!(a.hit.depth_z, b.hit.depth_z, "{a:?} vs {b:?}");
                if a.id == b.id {
                    assert_eq!(a, b);
                }
                assert!(a.hit.depth_z >= near && a.hit.depth_z <= far);
                true
            }
            _ => panic!("o={o} d={d} time={time}: bvh {a:?} vs brute force {b:?}"),
        }
    }

    #[test]
    fn bvh_matches_brute_force_on_moving_triangles() {
        let mut r = Pcg32::new(42, 9);
        for n in [1usize, 2, 7, 40, 1500] {
            let tris = random_scene(&mut r, n);
            let bvh = Bvh::build(&tris);
            assert_eq!(bvh.triangle_count(), n);
            assert!(bvh.depth() < STACK);
            let mut hits = 0;
            for _ in 0..4000 {
                let time = r.next_f32();
                // Half the rays aim near a random triangle at the ray's time, half anywhere.
                let target = if r.next_u32() & 1 == 0 {
                    let p = tris[r.below(n as u32) as usize].at(time);
                    (p[0] + p[1] + p[2]) / 3.0 + rnd3(&mut r, 0.3)
                } else {
                    rnd3(&mut r, 20.0) - 25.0 * Vec3::Z
                };
                let (o, d) = lens_ray(&mut r, target);
                let (near, far) = if r.next_u32() & 3 == 0 { (20.0, 30.0) } else { (0.1, f32::INFINITY) };
                hits += check_ray(&bvh, &tris, o, d, time, near, far) as usize;
            }
            if n >= 40 {
                assert!(hits > 800, "test rays should hit something (n={n}, hits={hits})");
            }
        }
    }

    /// Where the barycentric depth and the ray's own depth disagree most: a finely tessellated,
    /// slightly bumpy floor seen at grazing angles, every ray crossing many nearly coplanar triangles
    /// at nearly equal depths.
    #[test]
    fn bvh_matches_brute_force_on_a_grazing_floor() {
        let mut r = Pcg32::new(5, 1);
        let (nx, nz) = (24usize, 400usize);
        let vertex = |i: usize, j: usize, r: &mut Pcg32| {
            Vec3::new(
                i as f32 - 0.5 * nx as f32,
                -1.0 + 1e-3 * r.next_f32(),
                -0.5 - 0.25 * (j * j) as f32 / nz as f32,
            )
        };
        let grid: Vec<Vec<Vec3>> =
            (0..=nz).map(|j| (0..=nx).map(|i| vertex(i, j, &mut r)).collect()).collect();
        let mut tris = vec![];
        for j in 0..nz {
            for i in 0..nx {
                let (a, b, c, e) = (grid[j][i], grid[j][i + 1], grid[j + 1][i + 1], grid[j + 1][i]);
                let lift = Vec3::new(0.0, 0.02, 0.0);
                tris.push(MovingTriangle { v0: [a, b, c], v1: [a + lift, b, c] });
                tris.push(MovingTriangle { v0: [a, c, e], v1: [a + lift, c, e] });
            }
        }
        let bvh = Bvh::build(&tris);
        let mut hits = 0;
        for k in 0..20_000 {
            let depth = 2.0f32.powf(1.0 + 6.0 * r.next_f32());
            let target = Vec3::new(8.0 * (r.next_f32() - 0.5), -1.0 + 1e-3 * r.next_f32(), -depth);
            let (o, d) = lens_ray(&mut r, target);
            let (near, far) = if k % 4 == 0 { (3.0, 20.0) } else { (0.1, 1000.0) };
            hits += check_ray(&bvh, &tris, o, d, r.next_f32(), near, far) as usize;
        }
        assert!(hits > 10_000, "{hits}");
    }

    /// Any-hit traversal along segments in every direction finds exactly the triangles a brute-force
    /// test finds in the segment's range, and stops when asked to.
    #[test]
    fn for_each_hit_finds_every_hit_in_the_segment() {
        let mut r = Pcg32::new(17, 3);
        let tris = random_scene(&mut r, 600);
        let bvh = Bvh::build(&tris);
        let mut total = 0;
        for _ in 0..3000 {
            let time = r.next_f32();
            let o = rnd3(&mut r, 30.0) - 25.0 * Vec3::Z;
            // Half the segments through a random triangle's centre (and on), half anywhere.
            let d = if r.next_u32() & 1 == 0 {
                let p = tris[r.below(tris.len() as u32) as usize].at(time);
                ((p[0] + p[1] + p[2]) / 3.0 - o) * 1.5
            } else {
                rnd3(&mut r, 40.0)
            };
            let (s_min, s_max) = if r.next_u32() & 1 == 0 { (0.0, 1.0) } else { (0.3, f32::INFINITY) };
            let mut got = vec![];
            bvh.for_each_hit(o, d, time, s_min, s_max, |id, _, s| {
                got.push((id, s));
                true
            });
            let mut want = vec![];
            for (i, t) in tris.iter().enumerate() {
                let p = t.at(time);
                if let Some(h) = intersect_triangle(&p, o, d) {
                    let s = (h.point(&p) - o).dot(d) / d.length_squared();
                    if s > s_min && s < s_max {
                        want.push((i as u32, s));
                    }
                }
            }
            got.sort_by_key(|g| g.0);
            assert_eq!(got, want, "o={o} d={d} t={time}");
            total += got.len();
            if want.len() >= 2 {
                let mut calls = 0;
                bvh.for_each_hit(o, d, time, s_min, s_max, |_, _, _| {
                    calls += 1;
                    false
                });
                assert_eq!(calls, 1);
            }
        }
        assert!(total > 2000, "the test should exercise hits ({total})");
    }

    #[test]
    fn accept_filter_skips_rejected_triangles() {
        // Two parallel triangles; rejecting the near one yields the far one.
        let near = MovingTriangle::fixed([
            Vec3::new(-1.0, -1.0, -2.0),
            Vec3::new(1.0, -1.0, -2.0),
            Vec3::new(0.0, 1.0, -2.0),
        ]);
        let far = MovingTriangle::fixed([
            Vec3::new(-1.0, -1.0, -4.0),
            Vec3::new(1.0, -1.0, -4.0),
            Vec3::new(0.0, 1.0, -4.0),
        ]);
        let bvh = Bvh::build(&[near, far]);
        let h = bvh.intersect(Vec3::ZERO, -Vec3::Z, 0.5, 0.1, f32::INFINITY, |_| true).unwrap();
        assert_eq!((h.id, h.hit.depth_z), (0, 2.0));
        let h = bvh.intersect(Vec3::ZERO, -Vec3::Z, 0.5, 0.1, f32::INFINITY, |id| id != 0).unwrap();
        assert_eq!((h.id, h.hit.depth_z), (1, 4.0));
        // The depth range acts like clip planes, both ends inclusive as on the GPU.
        assert_eq!(bvh.intersect(Vec3::ZERO, -Vec3::Z, 0.5, 3.0, f32::INFINITY, |_| true).unwrap().id, 1);
        assert!(bvh.intersect(Vec3::ZERO, -Vec3::Z, 0.5, 0.1, 1.5, |_| true).is_none());
        assert_eq!(bvh.intersect(Vec3::ZERO, -Vec3::Z, 0.5, 4.0, 4.0, |_| true).unwrap().id, 1);
        // Rays that do not go forward find nothing.
        assert!(bvh
            .intersect(Vec3::new(0.0, 0.0, -3.0), Vec3::Z, 0.5, 0.1, f32::INFINITY, |_| true)
            .is_none());
    }

    #[test]
    fn degenerate_inputs_do_not_produce_nan() {
        let needle = MovingTriangle::fixed([
            Vec3::new(0.0, 0.0, -3.0),
            Vec3::new(1e-9, 5.0, -3.0),
            Vec3::new(0.0, 5.0, -3.0),
        ]);
        let huge = MovingTriangle::fixed([
            Vec3::new(-1e9, -1e9, -5.0),
            Vec3::new(1e9, -1e9, -5.0),
            Vec3::new(0.0, 1e9, -5.0),
        ]);
        // |e₁ × e₂|² overflows f32: the GPU's inside test (and so the shared intersector) finds no
        // hit on it rather than a NaN.
        let too_huge = MovingTriangle::fixed([
            Vec3::new(-1e18, -1e18, -6.0),
            Vec3::new(1e18, -1e18, -6.0),
            Vec3::new(0.0, 1e18, -6.0),
        ]);
        let line = MovingTriangle::fixed([
            Vec3::new(0.0, 0.0, -2.0),
            Vec3::new(1.0, 1.0, -2.0),
            Vec3::new(2.0, 2.0, -2.0),
        ]);
        let infinite = MovingTriangle::fixed([
            Vec3::new(0.0, 0.0, -1.0),
            Vec3::new(f32::INFINITY, 0.0, -1.0),
            Vec3::new(0.0, 1.0, -1.0),
        ]);
        let tris = [needle, huge, line, infinite, too_huge];
        let bvh = Bvh::build(&tris);
        assert_eq!(bvh.triangle_count(), 4, "non-finite triangles are left out");
        let mut r = Pcg32::new(1, 2);
        for _ in 0..2000 {
            let d = (rnd3(&mut r, 2.0) - Vec3::Z).normalize();
            let time = r.next_f32();
            for h in [
                bvh.intersect(Vec3::ZERO, d, time, 0.1, f32::INFINITY, |_| true),
                Bvh::brute_force(&tris, Vec3::ZERO, d, time, 0.1, f32::INFINITY),
            ]
            .into_iter()
            .flatten()
            {
                assert!(h.hit.depth_z.is_finite() && h.hit.barycentrics.is_finite(), "{h:?}");
            }
        }
        // Straight down the axis hits the huge triangle at depth 5 (the needle and the line are
        // degenerate for the relative area test), and nothing behind it but the too-huge one.
        let o = Vec3::new(0.3, 0.2, 0.0);
        let h = bvh.intersect(o, -Vec3::Z, 0.0, 0.1, f32::INFINITY, |_| true).unwrap();
        assert_eq!(h.id, 1);
        assert!((h.hit.depth_z - 5.0).abs() < 1e-4);
        assert!(bvh.intersect(o, -Vec3::Z, 0.0, 5.5, f32::INFINITY, |_| true).is_none());
    }
}
