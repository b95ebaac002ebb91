// Per eye, per pixel: the 3x3 depth cull, the 3x3 interpolation (weights 4, 2, 1) and the
// priority image.

@group(0) @binding(0) var<uniform> P: EyeParams;
@group(0) @binding(1) var<storage, read> points: array<Point>;
@group(0) @binding(2) var<storage, read> depth_img: array<u32>;
@group(0) @binding(3) var<storage, read> key_img: array<u32>;
// rgb + state: 1 a point is shown, 0 no point (after the cull).
@group(0) @binding(4) var<storage, read_write> culled: array<vec4<f32>>;
// rgb + state: 1 point, 0.5 interpolated, 0.25 filled from farther away, 0 empty.
@group(0) @binding(5) var<storage, read_write> color: array<vec4<f32>>;
@group(0) @binding(6) var<storage, read_write> priority: array<f32>;
@group(0) @binding(7) var<storage, read_write> counters: array<atomic<u32>>;

const CULL_FACTOR: f32 = 1.1;
// A point whose ray passed this close to the eye (m) was traced from it.
const SEEN_FROM_HERE: f32 = 1.0e-4;
// Priority of a point: its age relative to this many frames (capped at 1) ...
const AGE_SCALE: f32 = 32.0;
// ... plus up to 0.5 when its ray missed this eye by this many metres or more.
const MISS_SCALE: f32 = 0.02;
// A point whose ray escaped the scene shows the sky in its direction (or nothing), the
// same from every eye position and free of noise: resampling it only refines within the
// pixel, so it ages this much slower in the priority (samples go to the scene instead).
const BACKGROUND_WEIGHT: f32 = 1.0 / 32.0;
// Fixed-point scale of the priority sum.
const SUM_SCALE: f32 = 256.0;
// How far (in pixels) a hole with no point around it is filled from.
const FILL_RADIUS: i32 = 4;

@compute @workgroup_size(256)
fn cull(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if (i >= P.width * P.height) {
        return;
    }
    let key = key_img[i];
    if (key == EMPTY) {
        culled[i] = vec4<f32>(0.0);
        return;
    }
    let x = i32(i % P.width);
    let y = i32(i / P.width);
    var sum = 0.0;
    var n = 0.0;
    for (var dy = -1; dy <= 1; dy++) {
        for (var dx = -1; dx <= 1; dx++) {
            let xx = x + dx;
            let yy = y + dy;
            if (xx < 0 || yy < 0 || xx >= i32(P.width) || yy >= i32(P.height)) {
                continue;
            }
            let d = depth_img[u32(yy) * P.width + u32(xx)];
            if (d != EMPTY) {
                sum += bitcast<f32>(d);
                n += 1.0;
            }
        }
    }
    let depth = bitcast<f32>(depth_img[i]);
    // A point whose ray started at this eye was the first thing that ray hit: nothing in
    // front of it can have been missed, so only reprojected points are culled (this keeps
    // background and far points beside silhouettes).
    let seen_from_here = key_miss(key, P.index_bits) < SEEN_FROM_HERE;
    if (!seen_from_here && depth > CULL_FACTOR * sum / n) {
        culled[i] = vec4<f32>(0.0);
    } else {
        culled[i] = vec4<f32>(points[key_index(key, P.index_bits)].rad.xyz, 1.0);
    }
}

@compute @workgroup_size(256)
fn interpolate(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if (i >= P.width * P.height) {
        return;
    }
    let c = culled[i];
    var pr = 0.0;
    if (c.w > 0.0) {
        color[i] = c;
        let key = key_img[i];
        let p = points[key_index(key, P.index_bits)];
        let age = min(p.pos.w / AGE_SCALE, 1.0);
        if (bitcast<u32>(p.origin.w) == BACKGROUND) {
            pr = BACKGROUND_WEIGHT * age;
        } else {
            let miss = min(key_miss(key, P.index_bits) / MISS_SCALE, 1.0);
            pr = age + 0.5 * miss;
        }
    } else {
        let x = i32(i % P.width);
        let y = i32(i / P.width);
        var sum = vec3<f32>(0.0);
        var wsum = 0.0;
        var empty = 0.0;
        for (var dy = -1; dy <= 1; dy++) {
            for (var dx = -1; dx <= 1; dx++) {
                if (dx == 0 && dy == 0) {
                    continue;
                }
                let xx = x + dx;
                let yy = y + dy;
                if (xx < 0 || yy < 0 || xx >= i32(P.width) || yy >= i32(P.height)) {
                    empty += 1.0;
                    continue;
                }
                let n = culled[u32(yy) * P.width + u32(xx)];
                if (n.w > 0.0) {
                    // 4 at the centre (empty here), 2 on the edges, 1 at the corners.
                    let w = select(1.0, 2.0, dx == 0 || dy == 0);
                    sum += w * n.xyz;
                    wsum += w;
                } else {
                    empty += 1.0;
                }
            }
        }
        if (wsum > 0.0) {
            color[i] = vec4<f32>(sum / wsum, 0.5);
        } else {
            color[i] = fill(x, y);
        }
        // Empty pixels first, the emptier their neighbourhood the more.
        pr = 1.0 + empty / 8.0;
    }
    priority[i] = pr;
    atomicAdd(&counters[0], u32(pr * SUM_SCALE + 0.5));
}

// A hole the 3×3 interpolation leaves (where motion uncovered what no point has sampled
// yet): the mean of the points on the nearest square ring around it that has any, out to
// FILL_RADIUS, so that it shows its surroundings rather than black until it is sampled.
fn fill(x: i32, y: i32) -> vec4<f32> {
    for (var r = 2; r <= FILL_RADIUS; r++) {
        var sum = vec3<f32>(0.0);
        var n = 0.0;
        for (var dy = -r; dy <= r; dy++) {
            // The ring's rows at dy = ±r are whole; the others have their two ends only.
            let step = select(2 * r, 1, dy == -r || dy == r);
            for (var dx = -r; dx <= r; dx += step) {
                let xx = x + dx;
                let yy = y + dy;
                if (xx < 0 || yy < 0 || xx >= i32(P.width) || yy >= i32(P.height)) {
                    continue;
                }
                let c = culled[u32(yy) * P.width + u32(xx)];
                if (c.w > 0.0) {
                    sum += c.xyz;
                    n += 1.0;
                }
            }
        }
        if (n > 0.0) {
            return vec4<f32>(sum / n, 0.25);
        }
    }
    return vec4<f32>(0.0);
}
