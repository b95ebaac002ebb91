// Shared by every render-cache shader (prepended by the Rust side).

// One cached point: world position and age, mean radiance and sample count, the origin
// of the ray(s) that made it and the id of the surface it lies on.
struct Point {
    pos: vec4<f32>,    // xyz world position, w age in frames (>= MAX_AGE: empty slot)
    rad: vec4<f32>,    // rgb mean radiance, w number of samples averaged
    origin: vec4<f32>, // xyz ray origin, w surface id (bitcast u32)
}

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
    pad1: u32,
}

const EMPTY: u32 = 0xffffffffu;
const MAX_AGE: f32 = 1.0e6;

fn point_valid(p: Point) -> bool {
    return p.pos.w < MAX_AGE;
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
