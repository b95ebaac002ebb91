// The GPU ray engine's kernels over batches of rays (see mod.rs), after walk.wgsl: a
// wall's pixel rays, closest hit and any hit, one ray per invocation.

struct RayParams {
    // Rays in the batch, and invocations per row of the dispatch grid.
    count: u32,
    row: u32,
    width: u32,
    height: u32,
    // The wall's view (eye, pa, pb, pc; w unused) and the generated rays' tmax.
    eye: vec4<f32>,
    pa: vec4<f32>,
    pb: vec4<f32>,
    pc: vec4<f32>,
    tmax: f32,
    pad0: f32,
    pad1: f32,
    pad2: f32,
}

@group(0) @binding(0) var<uniform> rp: RayParams;
@group(0) @binding(3) var<storage, read_write> rays: array<GpuRay>;
// Closest hit: four words a ray (t, triangle, u, v; triangle NO_HIT on a miss). Any hit:
// one word a ray (the occluding triangle found, or NO_HIT).
@group(0) @binding(4) var<storage, read_write> ray_out: array<u32>;

fn ray_index(gid: vec3<u32>) -> u32 {
    return gid.y * rp.row + gid.x;
}

// A wall's pixel rays, row by row from the top-left: through pixel centre (x + ½, y + ½),
// as `holocave_cave::WallView::ray` makes them.
@compute @workgroup_size(WORKGROUP)
fn generate(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = ray_index(gid);
    if (i >= rp.count) {
        return;
    }
    let x = i % rp.width;
    let y = i / rp.width;
    let s = (f32(x) + 0.5) / f32(rp.width);
    let t = 1.0 - (f32(y) + 0.5) / f32(rp.height);
    let pa = rp.pa.xyz;
    let p = pa + (rp.pb.xyz - pa) * s + (rp.pc.xyz - pa) * t;
    let v = p - rp.eye.xyz;
    // glam's normalize_or_zero: times the reciprocal length, zero where that is not finite.
    let rcp = 1.0 / sqrt(dot(v, v));
    var dir = vec3<f32>(0.0);
    if (finite(rcp) && rcp > 0.0) {
        dir = v * rcp;
    }
    rays[i] = GpuRay(rp.eye.xyz, rp.tmax, dir, 0.0);
}

@compute @workgroup_size(WORKGROUP)
fn closest_hit(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = ray_index(gid);
    if (i >= rp.count) {
        return;
    }
    let h = closest(rays[i]);
    ray_out[4u * i] = h.x;
    ray_out[4u * i + 1u] = h.y;
    ray_out[4u * i + 2u] = h.z;
    ray_out[4u * i + 3u] = h.w;
}

@compute @workgroup_size(WORKGROUP)
fn occluded(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = ray_index(gid);
    if (i >= rp.count) {
        return;
    }
    ray_out[i] = any_hit(rays[i]);
}
