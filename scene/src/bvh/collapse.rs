//! The binary tree collapsed into eight-wide nodes, by the surface area heuristic with
//! the costs of the walks that traverse it.
//!
//! A ray enters a box with a chance in proportion to its surface, so a tree's expected
//! cost per ray is the sum, over its nodes and leaves, of their surface times what a visit
//! costs. Which binary nodes become an eight-wide node, which become leaves and how the
//! eight slots are shared out is chosen by dynamic programming over the binary tree
//! (Ylitie, Karras and Laine, "Efficient Incoherent Ray Traversal on GPUs Through
//! Compressed Wide BVHs", HPG 2017, §3.1). obvhs has that collapse too, but for its
//! compressed format: leaves of three triangles at most, each costing in proportion to
//! its triangles. Our walks test a leaf's four triangles in one four-wide test, so a leaf
//! here holds up to [`LEAF_SIZE`] triangles and costs the same whatever it holds.

use glam::Vec3A;
use obvhs::bvh2::Bvh2;

use super::triangle::IsectTriangle;
use super::wide_node::{Child, WideNode};

/// The most triangles a leaf holds: one four-wide block.
const LEAF_SIZE: usize = 4;
/// What a visit to an eight-wide node costs (its eight box tests and the ordering of the
/// children entered).
const NODE_COST: f32 = 1.0;
/// What a leaf's four-wide triangle test costs, against a node visit's 1: counted per
/// instruction in the closest-hit walk (README, "Where a ray's instructions went after
/// item 8"), a leaf tested is about 95 instructions and a node visited 29, or 56 where
/// several children are entered, so about two to one. Checked by counting the walks'
/// instructions per ray on Sponza's primary and diffuse rays (callgrind): 867 and 904 at 1.0, 822 and 883 at 1.5, 819 and 878 at 2.0 (and at
/// 2.5), 849 and 867 at 4.0; shadow rays 514 at 2.0, 507 at 4.0. obvhs' collapse, with
/// leaves of three merged into fours where that lowered the heuristic, gave 854, 919
/// and 516.
const LEAF_COST: f32 = 2.0;

/// How a binary node is best shared out over `i` slots of its wide parent (`i` ≥ 2).
#[derive(Clone, Copy)]
enum Share {
    /// As over `i − 1` slots.
    Fewer,
    /// `k` slots to the left child's subtree, the rest to the right's.
    Split(u8),
}

/// A binary node's costs: `cost[i − 1]` its subtree's least cost in `i` slots.
struct Plan {
    cost: [f32; 8],
    share: [Share; 8],
    /// In one slot, whether it is a leaf (rather than a wide node of its own).
    leaf: bool,
    /// As a wide node, the left child's share of its eight slots.
    split8: u8,
}

/// The collapsed tree: its nodes, root first and breadth first (siblings side by side),
/// each leaf's triangles as one block made by `block(triangles, ids)` (numbered in the
/// order they are made), and the depth of the tree.
pub(super) fn collapse(
    bvh2: &Bvh2,
    triangles: &[IsectTriangle],
    mut block: impl FnMut(&[IsectTriangle], &[u32]) -> u32,
) -> (Vec<WideNode>, usize) {
    if bvh2.nodes.is_empty() {
        return (Vec::new(), 0);
    }
    let order = children_first(bvh2);
    let boxes = tight_boxes(bvh2, triangles, &order);
    let plans = plan(bvh2, &boxes, &order);
    let mut nodes = vec![WideNode::EMPTY];
    // Binary nodes waiting to become wide nodes, with their wide index and depth.
    let mut queue = std::collections::VecDeque::from([(0usize, 0usize, 1usize)]);
    let mut depth = 1;
    let mut slots = Vec::with_capacity(8);
    while let Some((binary, wide, level)) = queue.pop_front() {
        depth = depth.max(level);
        slots.clear();
        let node = &bvh2.nodes[binary];
        if node.is_leaf() {
            slots.push(binary);
        } else {
            let k = usize::from(plans[binary].split8);
            let first = node.first_index as usize;
            gather(bvh2, &plans, first, k, &mut slots);
            gather(bvh2, &plans, first + 1, 8 - k, &mut slots);
        }
        let mut wide_node = WideNode::EMPTY;
        for (slot, child) in by_direction(&slots, &boxes, boxes[binary]) {
            let (min, max) = boxes[child];
            wide_node.set_box(slot, min, max);
            wide_node.children[slot] = if plans[child].leaf {
                let (tris, ids) = leaf_triangles(bvh2, triangles, child);
                Child::leaf(block(&tris, &ids), ids.len() as u32)
            } else {
                nodes.push(WideNode::EMPTY);
                queue.push_back((child, nodes.len() - 1, level + 1));
                Child::node((nodes.len() - 1) as u32)
            };
        }
        wide_node.set_order();
        nodes[wide] = wide_node;
    }
    (nodes, depth)
}

/// The children's slots: slot `s` for the child lying farthest towards the corner of
/// the parent's box whose signs are bit 2 (x), 1 and 0 of `s` (set: positive), chosen
/// greedily (Ylitie et al., §3.2). The any-hit walk, which takes a node's children
/// from the highest slot down without sorting them, then meets them in a spatially
/// coherent order.
fn by_direction(
    children: &[usize],
    boxes: &[(Vec3A, Vec3A)],
    parent: (Vec3A, Vec3A),
) -> Vec<(usize, usize)> {
    let centre = |(min, max): (Vec3A, Vec3A)| (min + max) * 0.5;
    let corner = |slot: usize| {
        let sign = |bit: usize| if slot & (1 << bit) != 0 { 1.0 } else { -1.0 };
        Vec3A::new(sign(2), sign(1), sign(0))
    };
    let mut pairs: Vec<(f32, usize, usize)> = children
        .iter()
        .flat_map(|&child| {
            let offset = centre(boxes[child]) - centre(parent);
            (0..8).map(move |slot| (-corner(slot).dot(offset), slot, child))
        })
        .collect();
    pairs.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)).then(a.2.cmp(&b.2)));
    let (mut slot_taken, mut placed) = ([false; 8], Vec::with_capacity(children.len()));
    for (_, slot, child) in pairs {
        if !slot_taken[slot] && placed.iter().all(|&(_, c)| c != child) {
            slot_taken[slot] = true;
            placed.push((slot, child));
        }
    }
    placed
}

/// Each binary node's box as tight as the triangles allow: a leaf's triangle bounds
/// (grown by what the widened triangle test accepts beyond them) cut to the builder's box
/// for the leaf (with spatial splits a leaf holds only the part of a triangle inside it),
/// and an inner node's the union of its children's.
fn tight_boxes(bvh2: &Bvh2, triangles: &[IsectTriangle], order: &[usize]) -> Vec<(Vec3A, Vec3A)> {
    let mut boxes = vec![(Vec3A::INFINITY, Vec3A::NEG_INFINITY); bvh2.nodes.len()];
    for &index in order {
        let node = &bvh2.nodes[index];
        let first = node.first_index as usize;
        boxes[index] = if node.is_leaf() {
            let parts = &bvh2.primitive_indices[first..first + node.prim_count as usize];
            parts.iter().fold(boxes[index], |(min, max), &t| {
                let (lo, hi, pad) = triangles[t as usize].bounds();
                let split = (node.aabb.min, node.aabb.max);
                (
                    min.min(lo.max(split.0 - pad)),
                    max.max(hi.min(split.1 + pad)),
                )
            })
        } else {
            let (l, r) = (boxes[first], boxes[first + 1]);
            (l.0.min(r.0), l.1.max(r.1))
        };
    }
    boxes
}

/// The binary nodes in an order that puts every child before its parent.
fn children_first(bvh2: &Bvh2) -> Vec<usize> {
    let mut order = Vec::with_capacity(bvh2.nodes.len());
    let mut stack = vec![0usize];
    while let Some(index) = stack.pop() {
        order.push(index);
        let node = &bvh2.nodes[index];
        if !node.is_leaf() {
            stack.extend([node.first_index as usize, node.first_index as usize + 1]);
        }
    }
    order.reverse();
    order
}

/// Half the surface of a box (what the heuristic weighs by); 0 for an empty one.
fn half_area((min, max): (Vec3A, Vec3A)) -> f32 {
    let e = (max - min).max(Vec3A::ZERO);
    e.x * e.y + e.y * e.z + e.z * e.x
}

/// Each binary node's least costs in one to eight slots (Ylitie et al.'s table), visiting
/// them in `order` (children first). A binary leaf is a leaf in every plan.
fn plan(bvh2: &Bvh2, boxes: &[(Vec3A, Vec3A)], order: &[usize]) -> Vec<Plan> {
    let mut plans: Vec<Plan> = (0..bvh2.nodes.len())
        .map(|_| Plan {
            cost: [f32::INFINITY; 8],
            share: [Share::Fewer; 8],
            leaf: true,
            split8: 1,
        })
        .collect();
    let mut parts = vec![0usize; bvh2.nodes.len()];
    for &index in order {
        let node = &bvh2.nodes[index];
        let area = half_area(boxes[index]);
        if node.is_leaf() {
            parts[index] = node.prim_count as usize;
            plans[index].cost = [area * LEAF_COST; 8];
            continue;
        }
        let (l, r) = (node.first_index as usize, node.first_index as usize + 1);
        parts[index] = parts[l] + parts[r];
        // Shared out over i slots: k to the left, i − k to the right.
        let mut spread = [(f32::INFINITY, 1u8); 8];
        for (i, best) in spread.iter_mut().enumerate().skip(1) {
            for k in 1..=i {
                let cost = plans[l].cost[k - 1] + plans[r].cost[i - k];
                if cost < best.0 {
                    *best = (cost, k as u8);
                }
            }
        }
        let as_node = area * NODE_COST + spread[7].0;
        let as_leaf = if parts[index] <= LEAF_SIZE {
            area * LEAF_COST
        } else {
            f32::INFINITY
        };
        let plan = &mut plans[index];
        plan.split8 = spread[7].1;
        plan.leaf = as_leaf <= as_node;
        plan.cost[0] = as_leaf.min(as_node);
        for (i, &(cost, k)) in spread.iter().enumerate().skip(1) {
            (plan.cost[i], plan.share[i]) = if cost < plan.cost[i - 1] {
                (cost, Share::Split(k))
            } else {
                (plan.cost[i - 1], Share::Fewer)
            };
        }
    }
    plans
}

/// The binary nodes that fill `slots` slots for `index`'s subtree, as planned.
fn gather(bvh2: &Bvh2, plans: &[Plan], index: usize, slots: usize, out: &mut Vec<usize>) {
    match plans[index].share[slots - 1] {
        _ if slots == 1 || bvh2.nodes[index].is_leaf() => out.push(index),
        Share::Fewer => gather(bvh2, plans, index, slots - 1, out),
        Share::Split(k) => {
            let first = bvh2.nodes[index].first_index as usize;
            gather(bvh2, plans, first, usize::from(k), out);
            gather(bvh2, plans, first + 1, slots - usize::from(k), out);
        }
    }
}

/// The triangles under a binary node that is to be one leaf, each once (spatial splits
/// may have put parts of one triangle in several of its leaves), and their ids.
fn leaf_triangles(
    bvh2: &Bvh2,
    triangles: &[IsectTriangle],
    index: usize,
) -> (Vec<IsectTriangle>, Vec<u32>) {
    let mut ids: Vec<u32> = Vec::with_capacity(LEAF_SIZE);
    let mut stack = vec![index];
    while let Some(i) = stack.pop() {
        let node = &bvh2.nodes[i];
        let first = node.first_index as usize;
        if node.is_leaf() {
            for &t in &bvh2.primitive_indices[first..first + node.prim_count as usize] {
                if !ids.contains(&t) {
                    ids.push(t);
                }
            }
        } else {
            stack.extend([first + 1, first]);
        }
    }
    debug_assert!(ids.len() <= LEAF_SIZE, "a leaf planned with too many parts");
    let tris = ids.iter().map(|&t| triangles[t as usize]).collect();
    (tris, ids)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bvh::spatial_split::{self, tests::strips_over_a_grid};
    use obvhs::triangle::Triangle;

    fn isect(tris: &[Triangle]) -> Vec<IsectTriangle> {
        tris.iter().map(IsectTriangle::from).collect()
    }

    /// Every leaf of the collapsed tree: its box and its triangles' ids.
    fn leaves(nodes: &[WideNode], blocks: &[Vec<u32>]) -> Vec<((Vec3A, Vec3A), Vec<u32>)> {
        let mut out = Vec::new();
        for node in nodes {
            for slot in 0..8 {
                let child = node.children[slot];
                if child != Child::EMPTY && child.as_node().is_none() {
                    let (block, lanes) = child.leaf_block();
                    assert_eq!(blocks[block].len(), lanes);
                    out.push((node.child_box(slot), blocks[block].clone()));
                }
            }
        }
        out
    }

    #[test]
    fn every_point_of_every_triangle_lies_in_a_leaf_holding_it() {
        let tris = strips_over_a_grid();
        let bvh2 = spatial_split::build(&tris);
        assert!(
            bvh2.primitive_indices.len() > tris.len(),
            "no spatial split made"
        );
        let mut blocks = Vec::new();
        let (nodes, _) = collapse(&bvh2, &isect(&tris), |_, ids| {
            blocks.push(ids.to_vec());
            (blocks.len() - 1) as u32
        });
        let leaves = leaves(&nodes, &blocks);
        for (_, ids) in &leaves {
            let mut unique = ids.clone();
            unique.sort();
            unique.dedup();
            assert!(
                ids.len() <= LEAF_SIZE && unique.len() == ids.len(),
                "leaf {ids:?}"
            );
        }
        // A barycentric grid over each triangle, corners and edges included.
        let n = 16;
        for (id, t) in tris.iter().enumerate() {
            for i in 0..=n {
                for j in 0..=n - i {
                    let (u, v) = (i as f32 / n as f32, j as f32 / n as f32);
                    let p = t.v0 + (t.v1 - t.v0) * u + (t.v2 - t.v0) * v;
                    let held = leaves.iter().any(|((min, max), ids)| {
                        ids.contains(&(id as u32)) && p.cmpge(*min).all() && p.cmple(*max).all()
                    });
                    assert!(held, "triangle {id} at {p}: in no leaf of it");
                }
            }
        }
    }

    #[test]
    fn the_tree_costs_what_the_plan_says() {
        // The heuristic's cost summed over the nodes and leaves made equals the table's
        // cost for the root: the tree is the one planned.
        let tris = strips_over_a_grid();
        let bvh2 = spatial_split::build(&tris);
        let (nodes, _) = collapse(&bvh2, &isect(&tris), |_, _| 0);
        let order = children_first(&bvh2);
        let plans = plan(&bvh2, &tight_boxes(&bvh2, &isect(&tris), &order), &order);
        let made: f32 = nodes
            .iter()
            .map(|node| {
                let leaves: f32 = (0..8)
                    .filter(|&s| node.children[s] != Child::EMPTY)
                    .filter(|&s| node.children[s].as_node().is_none())
                    .map(|s| half_area(node.child_box(s)) * LEAF_COST)
                    .sum();
                half_area(node.bounds()) * NODE_COST + leaves
            })
            .sum();
        let planned = plans[0].cost[0];
        assert!(
            (made - planned).abs() <= 1e-4 * planned,
            "made {made}, planned {planned}"
        );
        assert!(nodes.len() > 1 && nodes.len() < bvh2.nodes.len() / 4);
    }
}
