// Shadow rays made on the GPU (see shadow.rs), after walk.wgsl: from each pixel's first
// hit as the wall's closest-hit pass left it, towards every punctual light, the sun's
// samples of the pixel's sequence and the aims the CPU sent (area lamps' points, the
// sky's directions), as holocave_vlf::pixel_direct makes them on the CPU; each traced by
// the any-hit walk, answered as one bit a ray.

// A punctual light: position and kind (w: 1 directional, 0 point or spot), the direction
// it points along.
struct MadeLight {
    position_kind: vec4<f32>,
    direction: vec4<f32>,
}

struct ShadowParams {
    // Pixels, invocations per row of the dispatch grid, punctual lights, whether there is
    // a sun.
    count: u32,
    row: u32,
    lights: u32,
    sun: u32,
    // The sun's frame (Frame::new of its direction, the direction in n; n.w: one minus
    // the cosine of the disc's radius).
    sun_t: vec4<f32>,
    sun_b: vec4<f32>,
    sun_n: vec4<f32>,
    // The R2 sequence's steps in 64-bit fixed point: high and low words of each.
    step: vec4<u32>,
    light: array<MadeLight, MAX_LIGHTS>,
}

// A static triangle by the scene's index: its vertices, its face normal in the w's.
struct Face {
    p0: vec4<f32>,
    p1: vec4<f32>,
    p2: vec4<f32>,
}

@group(0) @binding(0) var<uniform> sp: ShadowParams;
@group(0) @binding(3) var<storage, read> faces: array<Face>;
// One word a pixel: bit i for punctual light i blocked, bit lights + j for the sun's
// sample first + j blocked, bit lights + suns + a for the pixel's aim a blocked.
@group(0) @binding(4) var<storage, read_write> masks: array<u32>;
// The wall's first hits: t, triangle (NO_HIT on a miss), u, v.
@group(0) @binding(5) var<storage, read> firsts: array<vec4<u32>>;
// Five words a pixel: the first of its sun samples; their count (low byte), bit 8 set
// when its punctual lights' rays are made, bit 9 when they leave from the barycentrics
// of the last two words (the estimate moved within the pixel) instead of the hit's, its
// aims' count (third byte); its first aim; the moved point's u and v.
@group(0) @binding(6) var<storage, read> tasks: array<u32>;
// Per pixel: its sun sequence's shifts in 32-bit fixed point.
@group(0) @binding(7) var<storage, read> shifts: array<vec2<u32>>;
// The aims of rays chosen on the CPU: the direction from the point, and the distance to
// the light's point (infinite for the sky).
@group(0) @binding(8) var<storage, read> aims: array<vec4<f32>>;

const PI: f32 = 3.14159265358979;

// The high word of a · b (32 × 32 → 64 bits) in 16-bit halves.
fn mul_hi(a: u32, b: u32) -> u32 {
    let a0 = a & 0xffffu;
    let a1 = a >> 16u;
    let b0 = b & 0xffffu;
    let b1 = b >> 16u;
    let p01 = a0 * b1;
    let p10 = a1 * b0;
    let mid = ((a0 * b0) >> 16u) + (p01 & 0xffffu) + (p10 & 0xffffu);
    return a1 * b1 + (p01 >> 16u) + (p10 >> 16u) + (mid >> 16u);
}

// Component c of sample k: shift + ⌊k · step / 2³²⌋ mod 2³², as a float in [0, 1) of 24 bits.
fn sequence(k: u32, shift: u32, hi: u32, lo: u32) -> f32 {
    let x = shift + k * hi + mul_hi(k, lo);
    return f32(x >> 8u) * (1.0 / 16777216.0);
}

// holocave_scene::ray::surface_epsilon.
fn surface_epsilon(p: vec3<f32>) -> f32 {
    let m = max(max(abs(p.x), abs(p.y)), abs(p.z));
    return max(1.0e-4 * (1.0 + min(m, 100.0)), 4.0 * 1.1920929e-7 * m);
}

// holocave_scene::ray::leave_surface.
fn leave_surface(p: vec3<f32>, ng: vec3<f32>, towards: vec3<f32>) -> vec3<f32> {
    return p + ng * (surface_epsilon(p) * select(-1.0, 1.0, dot(ng, towards) >= 0.0));
}

// The tracer's shadow_ray from `p` (face normal `ng`) towards `aim`: along `aim.xyz` to
// infinity where `aim.w` is not finite, else the segment to `p + aim.xyz * aim.w`
// (segment_ray). A segment of no length has no ray (its query is never made): tmax < 0.
fn shadow_ray(p: vec3<f32>, ng: vec3<f32>, aim: vec4<f32>) -> GpuRay {
    if (!finite(aim.w)) {
        return GpuRay(leave_surface(p, ng, aim.xyz), bitcast<f32>(0x7f800000u), aim.xyz, 0.0);
    }
    let to = p + aim.xyz * aim.w;
    let origin = leave_surface(p, ng, to - p);
    let d = to - origin;
    let len = length(d);
    if (!(len > 0.0) || !finite(len)) {
        return GpuRay(origin, -1.0, aim.xyz, 0.0);
    }
    return GpuRay(origin, max(len - surface_epsilon(to), 0.0), d / len, 0.0);
}

// Each pixel's shadow rays, one after another: every kind of ray is made as an aim and
// walked by the one call of any_hit, so that the walk and its stack are compiled once
// (a call site each inlines a walk each).
@compute @workgroup_size(WORKGROUP)
fn made_shadow_rays(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.y * sp.row + gid.x;
    if (i >= sp.count) {
        return;
    }
    let first_sun = tasks[5u * i];
    let counts = tasks[5u * i + 1u];
    let first_aim = tasks[5u * i + 2u];
    let suns = counts & 0xffu;
    let punctual = (counts & 0x100u) != 0u;
    let aimed = (counts >> 16u) & 0xffu;
    let hit = firsts[i];
    var mask = 0u;
    if ((suns == 0u && !punctual && aimed == 0u) || hit.y == NO_HIT) {
        masks[i] = mask;
        return;
    }
    // The point as holocave_scene's surface_point makes it, from the vertices.
    let f = faces[hit.y];
    let moved = (counts & 0x200u) != 0u;
    let u = bitcast<f32>(select(hit.z, tasks[5u * i + 3u], moved));
    let v = bitcast<f32>(select(hit.w, tasks[5u * i + 4u], moved));
    let w = vec3<f32>(1.0 - u - v, u, v);
    let p = f.p0.xyz * w.x + f.p1.xyz * w.y + f.p2.xyz * w.z;
    let ng = vec3<f32>(f.p0.w, f.p1.w, f.p2.w);
    let shift = shifts[i];
    let inf = bitcast<f32>(0x7f800000u);
    // Bit r: punctual light r, the sun's sample first_sun + r − lights, the aim
    // first_aim + r − lights − suns.
    for (var r = select(sp.lights, 0u, punctual); r < sp.lights + suns + aimed; r += 1u) {
        var aim = vec4<f32>(0.0, 0.0, 0.0, -1.0);
        if (r < sp.lights) {
            let light = sp.light[r];
            if (light.position_kind.w > 0.5) {
                aim = vec4<f32>(-light.direction.xyz, inf);
            } else {
                let to = light.position_kind.xyz - p;
                let d2 = dot(to, to);
                if (d2 > 0.0 && finite(d2)) {
                    let dist = sqrt(d2);
                    aim = vec4<f32>(to / dist, dist);
                }
            }
        } else if (r < sp.lights + suns) {
            let k = first_sun + r - sp.lights;
            let u0 = sequence(k, shift.x, sp.step.x, sp.step.y);
            let u1 = sequence(k, shift.y, sp.step.z, sp.step.w);
            // The tracer's uniform_cone in the sun's frame.
            let omc = sp.sun_n.w;
            let x = u0 * omc;
            let sin_t = sqrt(max(x * (2.0 - x), 0.0));
            let phi = 2.0 * PI * u1;
            let wi = sp.sun_t.xyz * (sin_t * cos(phi)) + sp.sun_b.xyz * (sin_t * sin(phi))
                + sp.sun_n.xyz * (1.0 - x);
            aim = vec4<f32>(wi, inf);
        } else {
            aim = aims[first_aim + r - sp.lights - suns];
        }
        if (aim.w < 0.0) {
            continue;
        }
        let ray = shadow_ray(p, ng, aim);
        if (ray.tmax >= 0.0 && any_hit(ray) != NO_HIT) {
            mask |= 1u << r;
        }
    }
    masks[i] = mask;
}
