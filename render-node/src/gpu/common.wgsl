// Shared by every shader of the render node (prepended by the Rust side: `gpu::with_common`).

// Rec. 709 luminance of linear RGB (`holocave_scene::color::luminance` on the CPU).
fn luminance(c: vec3<f32>) -> f32 {
    return dot(c, vec3<f32>(0.2126, 0.7152, 0.0722));
}

// Whether x is neither infinite nor NaN (by its exponent bits: WGSL lets a compiler assume
// no infinities or NaNs, so comparisons cannot tell).
fn finite(x: f32) -> bool {
    return (bitcast<u32>(x) & 0x7f800000u) != 0x7f800000u;
}

// One cached point: world position and age, mean radiance and sample count, the origin
// of the ray(s) that made it and the id of the surface it lies on, and the mean of its
// samples' squared luminance (their spread, for the light field's prior per pixel:
// vlf.wgsl).
struct Point {
    pos: vec4<f32>,    // xyz world position, w age in frames (>= MAX_AGE: empty slot)
    rad: vec4<f32>,    // rgb mean radiance, w number of samples averaged
    origin: vec4<f32>, // xyz ray origin, w surface id (bitcast u32)
    square: vec4<f32>, // x mean squared luminance (as rad's mean), y 1 when mixed, zw unused
}

// Ray origins closer than this (m) count as the same eye position.
const SAME_ORIGIN: f32 = 1.0e-4;

// Whether a point's samples, all from one eye position, hit more than one surface: the
// mean of a pixel across a silhouette or an emitter's edge, which stands for that pixel
// seen from there and for no surface. From elsewhere it never takes samples, and it shows
// only where nothing else lies within the depth tolerance (`project.wgsl`).
fn point_mixed(p: Point) -> bool {
    return p.square.y > 0.5;
}

// A surface id holds the material in its low 24 bits and the moving object the point lies
// on (index + 1; 0: the static scene) in its high 8 (`cache::surface_id`).
const OBJECT_SHIFT: u32 = 24u;

// Per eye and frame.
struct EyeParams {
    view_proj: mat4x4<f32>,
    eye: vec4<f32>,    // xyz eye position, w near plane distance
    width: u32,
    height: u32,
    npoints: u32,
    target_samples: u32,
    max_chosen: u32,
    frame: u32,
    eye_index: u32,
    // Bits of a pixel key that hold the point index (the rest: the quantised miss).
    index_bits: u32,
}

const EMPTY: u32 = 0xffffffffu;
// The surface id of rays that escaped the scene (`cache::BACKGROUND`).
const BACKGROUND: u32 = 0xfffffffeu;
const MAX_AGE: f32 = 1.0e6;

fn point_valid(p: Point) -> bool {
    return p.pos.w < MAX_AGE;
}

// A point that shows a moving object beyond a mirror or glass (`cache::Seen::ObjectBeyond`).
const OBJECT_BEYOND: u32 = 0xfeu;

// The moving object a point lies on (index + 1), 0 for the static scene, OBJECT_BEYOND; a
// high byte of 255 is the reserved ids' (the background, the holodeck's hits): static too.
fn point_object(p: Point) -> u32 {
    return surface_object(bitcast<u32>(p.origin.w));
}

// The same of a surface id.
fn surface_object(surface: u32) -> u32 {
    let k = surface >> OBJECT_SHIFT;
    return select(k, 0u, k == 0xffu);
}

// Distance from `eye` to the line of the ray that made the point (the holodeck paper's
// convergence criterion: the ray passing nearest the eye wins).
fn miss_distance(p: Point, eye: vec3<f32>) -> f32 {
    let d = p.pos.xyz - p.origin.xyz;
    let len = length(d);
    let v = eye - p.origin.xyz;
    if (len <= 0.0) {
        return length(v);
    }
    let u = d / len;
    return length(v - u * dot(v, u));
}

fn hash_u32(x: u32) -> u32 {
    var h = x;
    h = h ^ (h >> 16u);
    h = h * 0x7feb352du;
    h = h ^ (h >> 15u);
    h = h * 0x846ca68bu;
    h = h ^ (h >> 16u);
    return h;
}

// A pixel's key: the quantised distance by which the point's ray missed the eye in the
// high bits, the point index in the low `index_bits` (atomicMin picks the smallest miss,
// then the smallest index). The miss is quantised as sqrt(miss / MISS_RANGE) so that small
// misses keep fine steps.
const MISS_RANGE: f32 = 1.0;

fn miss_levels(index_bits: u32) -> u32 {
    return (1u << (32u - index_bits)) - 1u;
}

fn make_key(miss: f32, index: u32, index_bits: u32) -> u32 {
    let levels = miss_levels(index_bits);
    let q = min(u32(sqrt(clamp(miss / MISS_RANGE, 0.0, 1.0)) * f32(levels) + 0.5), levels);
    return (q << index_bits) | index;
}

fn key_index(key: u32, index_bits: u32) -> u32 {
    return key & ((1u << index_bits) - 1u);
}

fn key_miss(key: u32, index_bits: u32) -> f32 {
    let q = f32(key >> index_bits) / f32(miss_levels(index_bits));
    return q * q * MISS_RANGE;
}
