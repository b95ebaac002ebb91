// The GPU ray engine's walk (see mod.rs): closest hit and any hit over the scene's
// eight-wide BVH (holocave_scene::bvh::FlatBvh), one ray per invocation, for the kernels of
// rays.wgsl and shadow.wgsl, which follow this file. The Rust side prepends
// `const RAY_STACK: u32 = …;` (the tree's stack size).

// One node: child `slot`'s box in plane rows min x, y, z, max x, y, z of eight lanes each,
// read four lanes at a time (planes[2 * row + half] holds slots 4 · half to 4 · half + 3),
// the children's words, and per octant the slots from the one met last to the one met first.
struct RayNode {
    planes: array<vec4<f32>, 12>,
    children: array<vec4<u32>, 2>,
    order: array<vec4<u32>, 2>,
}

// One triangle slot: first vertex and the caller's triangle index, the two edges.
struct RayTriangle {
    v0_id: vec4<f32>,
    e1: vec4<f32>,
    e2: vec4<f32>,
}

// A ray: origin and `tmax`, unit direction.
struct GpuRay {
    origin: vec3<f32>,
    tmax: f32,
    dir: vec3<f32>,
    pad: f32,
}

@group(0) @binding(1) var<storage, read> ray_nodes: array<RayNode>;
@group(0) @binding(2) var<storage, read> ray_tris: array<RayTriangle>;

const NO_HIT: u32 = 0xffffffffu;
const CHILD_EMPTY: u32 = 0xffffffffu;
const CHILD_LEAF: u32 = 0x80000000u;
const COUNT_SHIFT: u32 = 27u;
const FIRST_MASK: u32 = 0x07ffffffu;
// EDGE_TOLERANCE of holocave_scene::bvh::triangle.
const EDGE_TOL: f32 = 1.0e-5;
// The slab test's growth of the far distance: Ize's 1 + 2γ₃ covers three correctly
// rounded operations; Vulkan allows 2.5 ulp for the division that makes the inverse
// direction, so grow by 1 + 16 ε (ε = 2⁻²³): a box is never missed for rounding.
const FAR_GROW: f32 = 1.0000019073486328;
const WORKGROUP: u32 = 64u;

// A ray that can hit something: finite origin and direction, non-zero direction, tmax not
// NaN (as `usable` in holocave_scene::bvh).
fn usable(r: GpuRay) -> bool {
    let ok = finite(r.origin.x) && finite(r.origin.y) && finite(r.origin.z)
        && finite(r.dir.x) && finite(r.dir.y) && finite(r.dir.z);
    let nonzero = r.dir.x != 0.0 || r.dir.y != 0.0 || r.dir.z != 0.0;
    return ok && nonzero && r.tmax == r.tmax;
}

// The inverse direction with a zero component made a tiny one (as `safe_inverse`): no
// 0 · ∞ on a box plane. Its sign does not matter: the near plane is picked by it.
fn safe_inverse(d: vec3<f32>) -> vec3<f32> {
    let m = max(abs(d), vec3<f32>(1.0e-30));
    return vec3<f32>(1.0) / select(m, -m, d < vec3<f32>(0.0));
}

// The entry distances of a node's eight children (slots 0-3, 4-7), -1 for a child the
// ray does not enter before `bound`: the CPU's slab test four lanes at a time. `o` origin,
// `inv` inverse direction, `neg` which axes run negative.
struct Entries {
    lo: vec4<f32>,
    hi: vec4<f32>,
}

fn enter_half(node: u32, half: u32, o: vec3<f32>, inv: vec3<f32>, neg: vec3<bool>, bound: f32) -> vec4<f32> {
    let min_x = ray_nodes[node].planes[half];
    let min_y = ray_nodes[node].planes[2u + half];
    let min_z = ray_nodes[node].planes[4u + half];
    let max_x = ray_nodes[node].planes[6u + half];
    let max_y = ray_nodes[node].planes[8u + half];
    let max_z = ray_nodes[node].planes[10u + half];
    let ax = (select(min_x, max_x, neg.x) - o.x) * inv.x;
    let ay = (select(min_y, max_y, neg.y) - o.y) * inv.y;
    let az = (select(min_z, max_z, neg.z) - o.z) * inv.z;
    let bx = (select(max_x, min_x, neg.x) - o.x) * inv.x;
    let by = (select(max_y, min_y, neg.y) - o.y) * inv.y;
    let bz = (select(max_z, min_z, neg.z) - o.z) * inv.z;
    let t_near = max(max(ax, ay), max(az, vec4<f32>(0.0)));
    let t_far = min(min(bx, by), bz) * FAR_GROW;
    return select(vec4<f32>(-1.0), t_near, t_near <= min(t_far, vec4<f32>(bound)));
}

fn enter(node: u32, o: vec3<f32>, inv: vec3<f32>, neg: vec3<bool>, bound: f32) -> Entries {
    return Entries(enter_half(node, 0u, o, inv, neg, bound), enter_half(node, 1u, o, inv, neg, bound));
}

struct TriHit {
    t: f32,
    u: f32,
    v: f32,
    hit: bool,
}

// Möller–Trumbore with the CPU's widened bounds, in the CPU's order of operations.
fn intersect(slot: u32, o: vec3<f32>, d: vec3<f32>, tmax: f32) -> TriHit {
    let tri = ray_tris[slot];
    let v0 = tri.v0_id.xyz;
    let e1 = tri.e1.xyz;
    let e2 = tri.e2.xyz;
    let px = d.y * e2.z - d.z * e2.y;
    let py = d.z * e2.x - d.x * e2.z;
    let pz = d.x * e2.y - d.y * e2.x;
    let det = e1.x * px + e1.y * py + e1.z * pz;
    let inv = 1.0 / det;
    let sx = o.x - v0.x;
    let sy = o.y - v0.y;
    let sz = o.z - v0.z;
    let u = (sx * px + sy * py + sz * pz) * inv;
    let qx = sy * e1.z - sz * e1.y;
    let qy = sz * e1.x - sx * e1.z;
    let qz = sx * e1.y - sy * e1.x;
    let v = (d.x * qx + d.y * qy + d.z * qz) * inv;
    let t = (e2.x * qx + e2.y * qy + e2.z * qz) * inv;
    // An unused lane (det 0) gives ±∞ or NaN here, which every comparison below fails.
    let hit = u >= -EDGE_TOL && u <= 1.0 + EDGE_TOL && v >= -EDGE_TOL
        && u + v <= 1.0 + EDGE_TOL && t >= 0.0 && t < tmax;
    return TriHit(t, u, v, hit);
}

fn octant(d: vec3<f32>) -> u32 {
    return select(0u, 4u, d.x < 0.0) | select(0u, 2u, d.y < 0.0) | select(0u, 1u, d.z < 0.0);
}

// The walk both queries share: pops the nearest pending child, pushes the children a
// node's ray enters from the one met last to the one met first (the node's stored order for
// the ray's octant), skips whatever lies beyond the nearest hit so far. With `any`, the
// first hit before `r.tmax` ends it. Answers as `closest` does.
fn walk(r: GpuRay, any: bool) -> vec4<u32> {
    let miss = vec4<u32>(bitcast<u32>(r.tmax), NO_HIT, 0u, 0u);
    if (!usable(r)) {
        return miss;
    }
    let o = r.origin;
    let d = r.dir;
    let inv = safe_inverse(d);
    let neg = inv < vec3<f32>(0.0);
    let shift = 3u * octant(d);
    var stack_child: array<u32, RAY_STACK>;
    var stack_t: array<f32, RAY_STACK>;
    var top = 1u;
    stack_child[0] = 0u;
    stack_t[0] = 0.0;
    var best = r.tmax;
    var best_slot = NO_HIT;
    var bu = 0.0;
    var bv = 0.0;
    while (top > 0u) {
        top -= 1u;
        let child = stack_child[top];
        if (stack_t[top] > best) {
            continue;
        }
        if ((child & CHILD_LEAF) == 0u) {
            let e = enter(child, o, inv, neg, best);
            var order = ray_nodes[child].order;
            var children = ray_nodes[child].children;
            for (var k = 0u; k < 8u; k += 1u) {
                let slot = (order[k / 4u][k % 4u] >> shift) & 7u;
                let t = select(e.lo[slot % 4u], e.hi[slot % 4u], slot >= 4u);
                let c = children[slot / 4u][slot % 4u];
                // An empty slot's box is inverted (never entered); its word is checked too.
                if (t >= 0.0 && c != CHILD_EMPTY && top < RAY_STACK) {
                    stack_child[top] = c;
                    stack_t[top] = t;
                    top += 1u;
                }
            }
        } else {
            let first = 4u * (child & FIRST_MASK);
            let count = (child & ~CHILD_LEAF) >> COUNT_SHIFT;
            for (var i = 0u; i < count; i += 1u) {
                let h = intersect(first + i, o, d, best);
                if (h.hit) {
                    best = h.t;
                    best_slot = first + i;
                    bu = h.u;
                    bv = h.v;
                    if (any) {
                        break;
                    }
                }
            }
            if (any && best_slot != NO_HIT) {
                break;
            }
        }
    }
    if (best_slot == NO_HIT) {
        return miss;
    }
    // Barycentrics clamped back into the triangle, as `Bvh::hit` does.
    bu = max(bu, 0.0);
    bv = max(bv, 0.0);
    let over = max(bu + bv - 1.0, 0.0) * 0.5;
    let id = bitcast<u32>(ray_tris[best_slot].v0_id.w);
    return vec4<u32>(
        bitcast<u32>(best),
        id,
        bitcast<u32>(max(bu - over, 0.0)),
        bitcast<u32>(max(bv - over, 0.0)),
    );
}

// The closest hit before `r.tmax`: t, triangle (NO_HIT on a miss), u, v.
fn closest(r: GpuRay) -> vec4<u32> {
    return walk(r, false);
}

// Something before `r.tmax`? The triangle found, or NO_HIT.
fn any_hit(r: GpuRay) -> u32 {
    return walk(r, true).y;
}

