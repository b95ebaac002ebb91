//! The binary tree the wide BVH is collapsed from: a top-down surface-area-heuristic build
//! with spatial splits (Stich, Friedrich and Dietrich, "Spatial Splits in Bounding Volume
//! Hierarchies", HPG 2009), the build tinybvh's `BuildHQ` also makes.
//!
//! Each node is cut either by an *object split* (its triangle parts sorted into two groups
//! by their centres, binned) or by a *spatial split*: a plane through the node, with the
//! triangles it crosses clipped into a part on each side. A long triangle then no longer
//! stretches the boxes of everything beside it, which is what makes architecture (long
//! walls and floors beside small detail) slow to trace. Spatial splits are tried only where
//! the best object split leaves boxes that overlap, and the copies they make are bounded
//! (each node's share of [`GROWTH`] times the triangles).
//!
//! The result is obvhs' `Bvh2` with one triangle part per leaf, which
//! [`super::collapse`] makes the eight-wide tree.

use glam::{BVec3A, Vec3A};
use obvhs::{
    aabb::Aabb,
    bvh2::{Bvh2, node::Bvh2Node},
    triangle::Triangle,
};

/// Bins per axis, for object and for spatial splits: twice the node's parts, between 8
/// and 128. On Sponza 128 bins let primary rays visit 11% fewer nodes than 32 did (11.6
/// against 13.0 per ray); a small node
/// needs fewer to find its cut, and filling and sweeping bins it does not need was most of
/// a small scene's build.
fn bin_count(parts: usize) -> usize {
    (2 * parts).clamp(8, 128)
}

/// Spatial splits are tried where the best object split's two boxes overlap by more than
/// this fraction of the root's surface (the paper's α).
const OVERLAP: f32 = 1e-5;
/// The most triangle parts the tree may hold, per triangle.
const GROWTH: f32 = 1.5;
/// A spatial split replaces an object split only when it lowers the cost by this factor at
/// least (a tiny gain is not worth the copies).
const SPATIAL_GAIN: f32 = 0.985;

/// Part of one triangle, and the box around that part.
#[derive(Clone, Copy)]
struct Part {
    bounds: Aabb,
    triangle: u32,
}

/// How a node's parts are divided.
enum Cut {
    /// Into two halves of the list (parts whose centres all coincide).
    Halve,
    /// By part centre: bin `bin` and below go left.
    Object { axis: usize, bins: Bins, bin: usize },
    /// By the plane at the top of bin `bin`; parts that cross it are clipped in two.
    Spatial {
        axis: usize,
        bins: Bins,
        bin: usize,
        left: Aabb,
        right: Aabb,
        counts: (usize, usize),
    },
}

/// `count` equal slabs over `[min, min + count / scale]` on one axis.
#[derive(Clone, Copy)]
struct Bins {
    min: f32,
    scale: f32,
    count: usize,
}

impl Bins {
    /// `count` slabs over `[min, max]`; `None` where the range is empty.
    fn over(min: f32, max: f32, count: usize) -> Option<Bins> {
        let extent = max - min;
        (extent > 0.0 && extent.is_finite()).then(|| Bins {
            min,
            scale: count as f32 / extent,
            count,
        })
    }

    fn index(&self, x: f32) -> usize {
        // `as usize` saturates, so a value below the range lands in bin 0.
        (((x - self.min) * self.scale) as usize).min(self.count - 1)
    }

    /// The plane between bin `bin` and the next.
    fn plane(&self, bin: usize) -> f32 {
        self.min + (bin + 1) as f32 / self.scale
    }
}

/// Builds the binary tree over `triangles`. Triangles with a non-finite corner are left
/// out: no ray can hit them.
pub(super) fn build(triangles: &[Triangle]) -> Bvh2 {
    let parts: Vec<Part> = triangles
        .iter()
        .enumerate()
        .filter(|(_, t)| t.v0.is_finite() && t.v1.is_finite() && t.v2.is_finite())
        .map(|(i, t)| Part {
            bounds: Aabb::from_points(&[t.v0, t.v1, t.v2]),
            triangle: i as u32,
        })
        .collect();
    let mut bvh = Bvh2 {
        uses_spatial_splits: true,
        ..Bvh2::default()
    };
    if parts.is_empty() {
        return bvh;
    }
    let budget = ((parts.len() as f32 * GROWTH) as usize).max(parts.len());
    let root = Side::new(parts, budget);
    let builder = Builder {
        triangles,
        root_area: root.bounds.half_area(),
    };
    let tree = builder.subtree(root);
    bvh.nodes = tree.nodes;
    bvh.primitive_indices = tree.parts;
    bvh
}

/// A subtree: its nodes (the root first, then each node's two children side by side, as
/// obvhs' `Bvh2` stores them) and the triangle of each part, in leaf order.
struct Subtree {
    nodes: Vec<Bvh2Node>,
    parts: Vec<u32>,
}

/// Subtrees with at least this many parts build their two halves on two threads.
const PARALLEL_PARTS: usize = 16_384;

/// What every node's cut needs to know of the whole build.
struct Builder<'a> {
    triangles: &'a [Triangle],
    root_area: f32,
}

impl Builder<'_> {
    /// Cuts a node's parts in two: each side's parts, box, and share of `budget` (the
    /// most parts the subtree may end with), in proportion to its parts.
    fn cut(&self, node: Side) -> [Side; 2] {
        let cut = choose_cut(
            self.triangles,
            &node.parts,
            &node.bounds,
            node.budget,
            self.root_area,
        );
        let (left, right) = divide(self.triangles, node.parts, cut);
        let total = left.len() + right.len();
        let spare = node.budget.saturating_sub(total);
        let left_budget = left.len() + spare * left.len() / total;
        let right_budget = node.budget.max(total) - left_budget;
        [Side::new(left, left_budget), Side::new(right, right_budget)]
    }

    /// The subtree over `parts`: large ones as two subtrees built in parallel and joined
    /// (the result does not depend on which thread finishes first), small ones in one
    /// depth-first pass.
    fn subtree(&self, node: Side) -> Subtree {
        if node.parts.len() < PARALLEL_PARTS {
            return self.serial(node);
        }
        let bounds = node.bounds;
        let [left, right] = self.cut(node);
        let (left, right) = rayon::join(|| self.subtree(left), || self.subtree(right));
        // Root, the two children's roots, then the rest of the left subtree and of the
        // right: a left node k ≥ 1 moves to k + 2, a right node k ≥ 1 to k + left − 1 + 2.
        let mut nodes = Vec::with_capacity(1 + left.nodes.len() + right.nodes.len());
        nodes.push(Bvh2Node::new(bounds, 0, 1));
        let shifts = [(2, 0), (left.nodes.len() + 1, left.parts.len() as u32)];
        let moved = |n: &Bvh2Node, (node_shift, part_shift): (usize, u32)| {
            let shift = if n.prim_count > 0 {
                part_shift
            } else {
                node_shift as u32
            };
            Bvh2Node::new(*n.aabb(), n.prim_count, n.first_index + shift)
        };
        for (side, shift) in [&left, &right].into_iter().zip(shifts) {
            nodes.push(moved(&side.nodes[0], shift));
        }
        for (side, shift) in [&left, &right].into_iter().zip(shifts) {
            nodes.extend(side.nodes[1..].iter().map(|n| moved(n, shift)));
        }
        let mut all_parts = left.parts;
        all_parts.extend(right.parts);
        Subtree {
            nodes,
            parts: all_parts,
        }
    }

    /// The subtree over `parts`, depth first on this thread; the left child is built
    /// first, so the nodes of a subtree lie together.
    fn serial(&self, root: Side) -> Subtree {
        let mut tree = Subtree {
            nodes: vec![Bvh2Node::new(root.bounds, 0, 0)],
            parts: Vec::new(),
        };
        let mut pending = vec![(0, root)];
        while let Some((index, node)) = pending.pop() {
            if let [part] = node.parts[..] {
                let first = tree.parts.len() as u32;
                tree.nodes[index] = Bvh2Node::new(part.bounds, 1, first);
                tree.parts.push(part.triangle);
                continue;
            }
            let bounds = node.bounds;
            let [left, right] = self.cut(node);
            let first = tree.nodes.len();
            tree.nodes.push(Bvh2Node::new(left.bounds, 0, 0));
            tree.nodes.push(Bvh2Node::new(right.bounds, 0, 0));
            tree.nodes[index] = Bvh2Node::new(bounds, 0, first as u32);
            pending.push((first + 1, right));
            pending.push((first, left));
        }
        tree
    }
}

/// A node still to be cut: its parts, their box, and the most parts its subtree may end
/// with.
struct Side {
    parts: Vec<Part>,
    bounds: Aabb,
    budget: usize,
}

impl Side {
    fn new(parts: Vec<Part>, budget: usize) -> Self {
        let bounds = parts
            .iter()
            .fold(Aabb::empty(), |acc, p| acc.union(&p.bounds));
        Side {
            parts,
            bounds,
            budget,
        }
    }
}

/// The surface-area cost of two groups, up to the constant factors every candidate shares.
fn sah(left: &Aabb, n_left: usize, right: &Aabb, n_right: usize) -> f32 {
    left.half_area() * n_left as f32 + right.half_area() * n_right as f32
}

/// Sweeps bins of boxes and counts from both ends (a part is counted on the left from the
/// bin it enters, on the right up to the bin it leaves); returns the cheapest plane (`bin`
/// and below go left), its cost and the two sides' boxes and counts.
fn sweep(
    boxes: &[Aabb],
    enter: &[usize],
    leave: &[usize],
) -> Option<(usize, f32, Aabb, Aabb, usize, usize)> {
    let bins = boxes.len();
    let mut right_box = vec![Aabb::empty(); bins];
    let mut right_count = vec![0usize; bins];
    let (mut acc, mut n) = (Aabb::empty(), 0);
    for bin in (1..bins).rev() {
        acc = acc.union(&boxes[bin]);
        n += leave[bin];
        right_box[bin - 1] = acc;
        right_count[bin - 1] = n;
    }
    let (mut acc, mut n) = (Aabb::empty(), 0);
    let mut best: Option<(usize, f32, Aabb, Aabb, usize, usize)> = None;
    for bin in 0..bins - 1 {
        acc = acc.union(&boxes[bin]);
        n += enter[bin];
        let m = right_count[bin];
        if n == 0 || m == 0 {
            continue;
        }
        let cost = sah(&acc, n, &right_box[bin], m);
        if best.is_none_or(|b| cost < b.1) {
            best = Some((bin, cost, acc, right_box[bin], n, m));
        }
    }
    best
}

/// The cheapest cut of a node with two parts or more.
fn choose_cut(
    triangles: &[Triangle],
    parts: &[Part],
    bounds: &Aabb,
    budget: usize,
    root_area: f32,
) -> Cut {
    let count = bin_count(parts.len());
    // Object splits: parts binned by their centres.
    let centres = parts.iter().fold(Aabb::empty(), |mut acc, p| {
        acc.extend(p.bounds.center());
        acc
    });
    let mut best_object: Option<(Cut, f32, Aabb, Aabb)> = None;
    for axis in 0..3 {
        let Some(bins) = Bins::over(centres.min[axis], centres.max[axis], count) else {
            continue;
        };
        let mut boxes = vec![Aabb::empty(); count];
        let mut counts = vec![0usize; count];
        for p in parts {
            let bin = bins.index(p.bounds.center_axis(axis));
            boxes[bin] = boxes[bin].union(&p.bounds);
            counts[bin] += 1;
        }
        if let Some((bin, cost, left, right, _, _)) = sweep(&boxes, &counts, &counts)
            && best_object.as_ref().is_none_or(|b| cost < b.1)
        {
            best_object = Some((Cut::Object { axis, bins, bin }, cost, left, right));
        }
    }
    let Some((object, object_cost, left, right)) = best_object else {
        // Every centre in one point: any division is as good as another.
        return Cut::Halve;
    };
    let overlap = left.intersection(&right);
    if !nonempty(&overlap) || overlap.half_area() <= OVERLAP * root_area || budget <= parts.len() {
        return object;
    }
    // Spatial splits: parts clipped into the slabs they cross.
    let mut best = (object, object_cost * SPATIAL_GAIN);
    for axis in 0..3 {
        let Some(bins) = Bins::over(bounds.min[axis], bounds.max[axis], count) else {
            continue;
        };
        let mut boxes = vec![Aabb::empty(); count];
        let mut enter = vec![0usize; count];
        let mut leave = vec![0usize; count];
        for p in parts {
            let (first, last) = (
                bins.index(p.bounds.min[axis]),
                bins.index(p.bounds.max[axis]),
            );
            enter[first] += 1;
            leave[last] += 1;
            if first == last {
                boxes[first] = boxes[first].union(&p.bounds);
                continue;
            }
            // Each plane's section bounds the pieces on both its sides.
            let section = Sections::new(&triangles[p.triangle as usize], axis);
            let mut below = (f32::NEG_INFINITY, Aabb::empty());
            for (bin, into) in boxes.iter_mut().enumerate().take(last + 1).skip(first) {
                let above = if bin == last {
                    (f32::INFINITY, Aabb::empty())
                } else {
                    let plane = bins.plane(bin);
                    (plane, section.at(plane))
                };
                *into = into.union(&section.between(below, above, &p.bounds));
                below = above;
            }
        }
        if let Some((bin, cost, left, right, n_left, n_right)) = sweep(&boxes, &enter, &leave)
            && cost < best.1
            && n_left + n_right <= budget
        {
            best = (
                Cut::Spatial {
                    axis,
                    bins,
                    bin,
                    left,
                    right,
                    counts: (n_left, n_right),
                },
                cost,
            );
        }
    }
    best.0
}

/// A triangle's cross-sections by planes across one axis.
struct Sections {
    /// The corners, by their coordinate on the axis, and those coordinates.
    sorted: [Vec3A; 3],
    along: [f32; 3],
    /// True in the axis' lane (points are put on a plane by selecting, not by writing one
    /// lane: a one-lane store read back as a vector stalls the load).
    on_axis: BVec3A,
}

impl Sections {
    fn new(t: &Triangle, axis: usize) -> Self {
        let mut sorted = [t.v0, t.v1, t.v2];
        sorted.sort_by(|a, b| a[axis].total_cmp(&b[axis]));
        Self {
            sorted,
            along: sorted.map(|c| c[axis]),
            on_axis: BVec3A::new(axis == 0, axis == 1, axis == 2),
        }
    }

    /// The box of the triangle's section by the plane at `x` (empty where the plane
    /// misses the triangle): a segment from the long edge (first to last corner) to one
    /// of the two short ones.
    fn at(&self, x: f32) -> Aabb {
        let [a, b, c] = self.sorted;
        let [pa, pb, pc] = self.along;
        if !(pa < x && x < pc) {
            return Aabb::empty();
        }
        let plane = Vec3A::splat(x);
        let point = |p: Vec3A, q: Vec3A, pp: f32, pq: f32| {
            let at = p.lerp(q, ((x - pp) / (pq - pp)).clamp(0.0, 1.0));
            Vec3A::select(self.on_axis, plane, at)
        };
        let long = point(a, c, pa, pc);
        let short = if x < pb {
            point(a, b, pa, pb)
        } else {
            point(b, c, pb, pc)
        };
        Aabb::new(long.min(short), long.max(short))
    }

    /// The box of the triangle's piece between two planes, each given with the box of
    /// its section ([`Sections::at`]; an infinite plane, with an empty box, bounds
    /// nothing), within `bounds` (the box of the part the piece is cut from): its corners
    /// between the planes and its sections on them. Empty where the piece is.
    fn between(&self, (lo, at_lo): (f32, Aabb), (hi, at_hi): (f32, Aabb), bounds: &Aabb) -> Aabb {
        let mut piece = at_lo.union(&at_hi);
        for (corner, along) in self.sorted.iter().zip(self.along) {
            if (lo..=hi).contains(&along) {
                piece.extend(*corner);
            }
        }
        let piece = piece.intersection(bounds);
        if nonempty(&piece) {
            piece
        } else {
            Aabb::empty()
        }
    }
}

/// Divides a node's parts by `cut`; neither side is left empty.
fn divide(triangles: &[Triangle], parts: Vec<Part>, cut: Cut) -> (Vec<Part>, Vec<Part>) {
    let (mut left, mut right) = (Vec::new(), Vec::new());
    match cut {
        Cut::Halve => left = parts,
        Cut::Object { axis, bins, bin } => {
            for p in parts {
                if bins.index(p.bounds.center_axis(axis)) <= bin {
                    left.push(p);
                } else {
                    right.push(p);
                }
            }
        }
        Cut::Spatial {
            axis,
            bins,
            bin,
            left: mut left_box,
            right: mut right_box,
            counts: (mut n_left, mut n_right),
        } => {
            let plane = bins.plane(bin);
            let (mut into_left, mut into_right) = (Vec::new(), Vec::new());
            for p in parts {
                let (first, last) = (
                    bins.index(p.bounds.min[axis]),
                    bins.index(p.bounds.max[axis]),
                );
                if last <= bin {
                    into_left.push(p);
                    continue;
                }
                if first > bin {
                    into_right.push(p);
                    continue;
                }
                // A part the plane crosses goes whole to one side where that costs less
                // than two clipped copies (the paper's "unsplitting").
                let split = sah(&left_box, n_left, &right_box, n_right);
                let whole_left = sah(&left_box.union(&p.bounds), n_left, &right_box, n_right - 1);
                let whole_right = sah(&left_box, n_left - 1, &right_box.union(&p.bounds), n_right);
                if whole_left <= split.min(whole_right) && n_right > 1 {
                    left_box = left_box.union(&p.bounds);
                    n_right -= 1;
                    into_left.push(p);
                    continue;
                }
                if whole_right <= split && n_left > 1 {
                    right_box = right_box.union(&p.bounds);
                    n_left -= 1;
                    into_right.push(p);
                    continue;
                }
                let section = Sections::new(&triangles[p.triangle as usize], axis);
                let on_plane = (plane, section.at(plane));
                let below =
                    section.between((f32::NEG_INFINITY, Aabb::empty()), on_plane, &p.bounds);
                let above = section.between(on_plane, (f32::INFINITY, Aabb::empty()), &p.bounds);
                match (nonempty(&below), nonempty(&above)) {
                    (true, true) => {
                        into_left.push(Part { bounds: below, ..p });
                        into_right.push(Part { bounds: above, ..p });
                    }
                    (false, true) => into_right.push(p),
                    _ => into_left.push(p),
                }
            }
            (left, right) = (into_left, into_right);
        }
    }
    if left.is_empty() || right.is_empty() {
        // Rounding put everything on one side, or the cut asked for halves.
        let mut all = left;
        all.append(&mut right);
        let right = all.split_off(all.len() / 2);
        return (all, right);
    }
    (left, right)
}

/// Whether a box holds any point (obvhs' `Aabb::valid`, which is not inlined).
#[inline(always)]
fn nonempty(b: &Aabb) -> bool {
    b.min.cmple(b.max).all()
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;

    fn triangle(a: [f32; 3], b: [f32; 3], c: [f32; 3]) -> Triangle {
        Triangle {
            v0: a.into(),
            v1: b.into(),
            v2: c.into(),
        }
    }

    /// Long thin strips across a grid of small triangles: the strips' boxes cover the
    /// grid's, which is where spatial splits pay.
    pub(in crate::bvh) fn strips_over_a_grid() -> Vec<Triangle> {
        let mut tris = Vec::new();
        for k in 0..8 {
            let z = k as f32 * 0.5;
            tris.push(triangle(
                [0.0, 0.0, z],
                [16.0, 0.1, z + 0.05],
                [0.0, 0.2, z + 0.3],
            ));
        }
        for i in 0..32 {
            for j in 0..8 {
                let (x, z) = (i as f32 * 0.5, j as f32 * 0.5);
                tris.push(triangle(
                    [x, 0.0, z + 0.1],
                    [x + 0.3, 0.1, z + 0.1],
                    [x, 0.2, z + 0.4],
                ));
            }
        }
        tris
    }

    /// Points on a triangle: a barycentric grid including its corners and edges.
    fn points_on(t: &Triangle) -> Vec<Vec3A> {
        let n = 12;
        let mut points = Vec::new();
        for i in 0..=n {
            for j in 0..=n - i {
                let (u, v) = (i as f32 / n as f32, j as f32 / n as f32);
                points.push(t.v0 + (t.v1 - t.v0) * u + (t.v2 - t.v0) * v);
            }
        }
        points
    }

    #[test]
    fn sections_bound_the_triangle_between_two_planes() {
        // The box of the triangle between two planes (or beyond one), from the sections
        // and the corners between, equals the box of many points of the triangle between
        // the planes (to within the sampling).
        let t = triangle([0.0, 0.0, 0.0], [4.0, 1.0, -1.0], [1.5, 3.0, 2.0]);
        let dense: Vec<Vec3A> = (0..=400)
            .flat_map(|i| (0..=400 - i).map(move |j| (i as f32 / 400.0, j as f32 / 400.0)))
            .map(|(u, v)| t.v0 + (t.v1 - t.v0) * u + (t.v2 - t.v0) * v)
            .collect();
        for axis in 0..3 {
            let sections = Sections::new(&t, axis);
            let whole = Aabb::from_points(&dense);
            let ranges = [
                (f32::NEG_INFINITY, 0.5),
                (0.5, 1.2),
                (1.2, 2.9),
                (2.0, f32::INFINITY),
            ];
            for (lo, hi) in ranges {
                let b = sections.between((lo, sections.at(lo)), (hi, sections.at(hi)), &whole);
                let sampled = dense.iter().filter(|p| (lo..=hi).contains(&p[axis])).fold(
                    Aabb::empty(),
                    |mut b, p| {
                        b.extend(*p);
                        b
                    },
                );
                // A sample lies within 1/400 of the triangle's extent of the true edge.
                let step = 5.0 / 400.0;
                assert!(
                    (b.min - sampled.min).abs().max_element() <= step
                        && (b.max - sampled.max).abs().max_element() <= step,
                    "axis {axis}, [{lo}, {hi}]: {b:?} vs sampled {sampled:?}"
                );
                // And it holds every sample (up to rounding).
                let ulps = Vec3A::splat(8.0 * 5.0 * f32::EPSILON);
                assert!(
                    (b.min - ulps).cmple(sampled.min).all()
                        && (b.max + ulps).cmpge(sampled.max).all()
                );
            }
        }
    }

    #[test]
    fn every_point_of_every_triangle_lies_in_a_leaf_of_that_triangle() {
        let tris = strips_over_a_grid();
        let bvh = build(&tris);
        let leaves: Vec<(u32, Aabb)> = bvh
            .nodes
            .iter()
            .filter(|n| n.prim_count > 0)
            .map(|n| {
                assert_eq!(n.prim_count, 1, "one part per leaf");
                (bvh.primitive_indices[n.first_index as usize], *n.aabb())
            })
            .collect();
        // The strips were cut: there are more parts than triangles.
        assert!(
            leaves.len() > tris.len(),
            "{} parts for {} triangles: no spatial split",
            leaves.len(),
            tris.len()
        );
        assert!(leaves.len() as f32 <= tris.len() as f32 * GROWTH);
        // Clipping rounds: a point may lie outside its part's box by a few ulps.
        let slack = Vec3A::splat(16.0 * 4.0 * f32::EPSILON);
        for (index, t) in tris.iter().enumerate() {
            let parts: Vec<&Aabb> = leaves
                .iter()
                .filter(|(i, _)| *i == index as u32)
                .map(|(_, b)| b)
                .collect();
            assert!(!parts.is_empty(), "triangle {index} is in no leaf");
            for p in points_on(t) {
                assert!(
                    parts
                        .iter()
                        .any(|b| (b.min - slack).cmple(p).all() && p.cmple(b.max + slack).all()),
                    "triangle {index}: {p} lies in none of its {} parts",
                    parts.len()
                );
            }
        }
        // Each inner node's box holds its children's.
        for n in bvh.nodes.iter().filter(|n| n.prim_count == 0) {
            for child in [n.first_index, n.first_index + 1] {
                let c = bvh.nodes[child as usize].aabb();
                assert!(n.aabb().min.cmple(c.min).all() && c.max.cmple(n.aabb().max).all());
            }
        }
    }

    #[test]
    fn the_parallel_build_makes_the_serial_builds_tree() {
        // Enough triangles for the top cuts to run on two threads, with long strips among
        // them so that parts are copied: joining the halves must give the very tree one
        // depth-first pass gives.
        let mut tris = strips_over_a_grid();
        for i in 0..20_000 {
            let (x, y, z) = (
                (i % 40) as f32 * 0.4,
                (i / 40 % 25) as f32 * 0.3,
                (i / 1000) as f32 * 0.2,
            );
            tris.push(triangle(
                [x, y, z],
                [x + 0.2, y + 0.05, z],
                [x, y + 0.1, z + 0.15],
            ));
        }
        let parts: Vec<Part> = tris
            .iter()
            .enumerate()
            .map(|(i, t)| Part {
                bounds: Aabb::from_points(&[t.v0, t.v1, t.v2]),
                triangle: i as u32,
            })
            .collect();
        let budget = (parts.len() as f32 * GROWTH) as usize;
        let root = || Side::new(parts.clone(), budget);
        let builder = Builder {
            triangles: &tris,
            root_area: root().bounds.half_area(),
        };
        let parallel = builder.subtree(root());
        let serial = builder.serial(root());
        assert!(serial.parts.len() > tris.len(), "no part was copied");
        assert_eq!(parallel.parts, serial.parts);
        let fields = |n: &Bvh2Node| (n.aabb().min, n.aabb().max, n.prim_count, n.first_index);
        assert_eq!(parallel.nodes.len(), serial.nodes.len());
        for (k, (a, b)) in parallel.nodes.iter().zip(&serial.nodes).enumerate() {
            assert_eq!(fields(a), fields(b), "node {k}");
        }
    }

    #[test]
    fn coincident_and_non_finite_triangles_build() {
        // Forty copies of one triangle (no plane separates their centres) and two with a
        // non-finite corner, which are left out.
        let t = triangle([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]);
        let mut tris = vec![t; 40];
        tris.push(triangle(
            [f32::NAN, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
        ));
        tris.push(triangle(
            [0.0, f32::INFINITY, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
        ));
        let bvh = build(&tris);
        let mut indices: Vec<u32> = bvh
            .nodes
            .iter()
            .filter(|n| n.prim_count > 0)
            .map(|n| bvh.primitive_indices[n.first_index as usize])
            .collect();
        indices.sort();
        assert_eq!(indices, (0..40).collect::<Vec<u32>>());
        assert!(build(&[]).nodes.is_empty());
    }
}
