// When moving objects moved (the render cache paper's §4, "moving objects"), one pass over
// the points:
//   - a point on a moved object moves with it (its rigid transform since the last frame,
//     applied to the point and to the origin of its ray) and is marked for resampling:
//     it keeps at most one sample's weight and the age that gives it the highest priority,
//     since its light changed as it moved;
//   - a point that showed an object beyond a mirror or glass is dropped;
//   - any other point in the shadow of a moved object, where it was or where it is now,
//     towards any light, is dropped: its light changed, and the pixel shows the light
//     field (with the exact direct light) until a new sample comes, asked for first as an
//     empty pixel is.

struct Move {
    // The object's rigid transform since the last pass.
    delta: mat4x4<f32>,
    // Its bounding sphere (xyz centre, w radius) before and after.
    before: vec4<f32>,
    after: vec4<f32>,
    // The object's index + 1 (as in a surface id).
    object: u32,
    pad0: u32,
    pad1: u32,
    pad2: u32,
}

struct ShadowLight {
    // xyz: a point light's position (w 1), or the direction towards a distant one (w 0).
    at: vec4<f32>,
    // x: a point light's radius, or the tangent of a distant light's angular radius.
    spread: vec4<f32>,
}

struct MoveParams {
    npoints: u32,
    nmoves: u32,
    nlights: u32,
    pad: u32,
}

@group(0) @binding(0) var<uniform> M: MoveParams;
@group(0) @binding(1) var<storage, read_write> points: array<Point>;
@group(0) @binding(2) var<storage, read> moves: array<Move>;
@group(0) @binding(3) var<storage, read> lights: array<ShadowLight>;

// filter.wgsl's AGE_SCALE: the age of the highest priority.
const RESAMPLE_AGE: f32 = 32.0;

// Whether the way from `p` to light `l` passes through the sphere `s`, widened by the
// light's size as the penumbra widens towards it.
fn shadowed(p: vec3<f32>, s: vec4<f32>, l: ShadowLight) -> bool {
    let c = s.xyz - p;
    if (dot(c, c) <= s.w * s.w) {
        return true;
    }
    if (l.at.w == 0.0) {
        let t = dot(c, l.at.xyz);
        if (t <= 0.0) {
            return false;
        }
        let miss = length(c - t * l.at.xyz);
        return miss <= s.w + t * l.spread.x;
    }
    let to = l.at.xyz - p;
    let d = length(to);
    if (d <= 0.0) {
        return false;
    }
    let u = to / d;
    let t = clamp(dot(c, u), 0.0, d);
    let miss = length(c - t * u);
    return miss <= s.w + l.spread.x * t / d;
}

@compute @workgroup_size(256)
fn move_points(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if (i >= M.npoints) {
        return;
    }
    var p = points[i];
    if (!point_valid(p) || bitcast<u32>(p.origin.w) == BACKGROUND) {
        return;
    }
    let k = point_object(p);
    if (k == OBJECT_BEYOND) {
        points[i].pos.w = MAX_AGE;
        return;
    }
    for (var m = 0u; m < M.nmoves; m++) {
        if (k != 0u && moves[m].object == k) {
            let d = moves[m].delta;
            p.pos = vec4<f32>((d * vec4<f32>(p.pos.xyz, 1.0)).xyz, max(p.pos.w, RESAMPLE_AGE));
            p.origin = vec4<f32>((d * vec4<f32>(p.origin.xyz, 1.0)).xyz, p.origin.w);
            p.rad.w = min(p.rad.w, 1.0);
            points[i] = p;
            return;
        }
    }
    for (var m = 0u; m < M.nmoves; m++) {
        for (var j = 0u; j < M.nlights; j++) {
            let l = lights[j];
            if (shadowed(p.pos.xyz, moves[m].before, l) || shadowed(p.pos.xyz, moves[m].after, l)) {
                points[i].pos.w = MAX_AGE;
                return;
            }
        }
    }
}
