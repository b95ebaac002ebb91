// Per eye: clear the per-pixel buffers, then z-buffered projection of every point in two
// linear passes over the points (WGSL has only 32-bit atomics, so depth and the rest of
// the key are resolved one after the other):
//   1. atomicMin of the depth (positive f32 bits order like u32),
//      (but for mixed points made from another eye position: common.wgsl),
//   2. among points within 1% of the pixel's nearest depth, atomicMin of the key
//      (quantised distance by which their ray missed this eye, then point index: the
//      holodeck paper's §2.4.2 convergence, deterministic on ties).

@group(0) @binding(0) var<uniform> P: EyeParams;
@group(0) @binding(1) var<storage, read> points: array<Point>;
@group(0) @binding(2) var<storage, read_write> depth_img: array<atomic<u32>>;
@group(0) @binding(3) var<storage, read_write> key_img: array<atomic<u32>>;
@group(0) @binding(4) var<storage, read_write> visible: array<u32>;
@group(0) @binding(5) var<storage, read_write> counters: array<atomic<u32>>;

const DEPTH_TOLERANCE: f32 = 1.01;

struct Projected {
    ok: bool,
    pixel: u32,
    depth: f32,
}

fn project(p: Point) -> Projected {
    var r = Projected(false, 0u, 0.0);
    if (!point_valid(p)) {
        return r;
    }
    let clip = P.view_proj * vec4<f32>(p.pos.xyz, 1.0);
    if (!(clip.w > P.eye.w)) {
        return r;
    }
    let ndc = clip.xy / clip.w;
    let fx = (ndc.x * 0.5 + 0.5) * f32(P.width);
    let fy = (0.5 - ndc.y * 0.5) * f32(P.height);
    if (!(fx >= 0.0 && fy >= 0.0 && fx < f32(P.width) && fy < f32(P.height))) {
        return r;
    }
    r.ok = true;
    r.pixel = min(u32(fy), P.height - 1u) * P.width + min(u32(fx), P.width - 1u);
    r.depth = clip.w;
    return r;
}

@compute @workgroup_size(256)
fn clear(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if (i < 4u) {
        atomicStore(&counters[i], 0u);
    }
    if (i >= P.width * P.height) {
        return;
    }
    atomicStore(&depth_img[i], EMPTY);
    atomicStore(&key_img[i], EMPTY);
}

@compute @workgroup_size(256)
fn project_depth(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if (i >= P.npoints) {
        return;
    }
    let p = points[i];
    let pr = project(p);
    if (!pr.ok) {
        return;
    }
    visible[i] = 1u;
    // A mixed point made from another eye position hides nothing: it stands for a pixel
    // of that view, not for a surface in front of this one's points.
    if (point_mixed(p) && distance(p.origin.xyz, P.eye.xyz) > SAME_ORIGIN) {
        return;
    }
    atomicMin(&depth_img[pr.pixel], bitcast<u32>(pr.depth));
}

@compute @workgroup_size(256)
fn project_key(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if (i >= P.npoints) {
        return;
    }
    let p = points[i];
    let pr = project(p);
    if (!pr.ok) {
        return;
    }
    // (No depth: only mixed points from elsewhere project here; they may show.)
    let nearest = atomicLoad(&depth_img[pr.pixel]);
    if (nearest == EMPTY || pr.depth <= bitcast<f32>(nearest) * DEPTH_TOLERANCE) {
        let key = make_key(miss_distance(p, P.eye.xyz), i, P.index_bits);
        atomicMin(&key_img[pr.pixel], key);
    }
}
