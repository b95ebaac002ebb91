// Inserting a batch of new samples for one eye, in two passes:
//   match: a sample whose pixel already shows a point made from the same eye position
//          is averaged into that point (progressive refinement of a still view); one
//          from an eye position at most NEAR_ORIGIN away that hit the same surface at the
//          same place joins a running mean capped at MOVING_MAX_COUNT samples (so a slowly
//          moving head is not shown 1-sample noise, and view-dependent change still shows)
//          and moves the point's ray origin to the new eye; a sample of a Lambertian
//          surface (marked view-independent) joins it from any eye position, without
//          the cap, since what such a surface sends does not depend on where it is seen
//          from;
//          a sample of another surface than the point's from the same eye position
//          makes it a mixed point (common.wgsl), which no other eye position joins;
//          a sample from another eye position whose colour differs a lot from the
//          pixel's well-sampled point asks for the points around it to be aged
//          (premature aging), counted per pixel;
//   age:   the points shown in pixels so asked are aged (one invocation per pixel);
//   place: every other sample becomes a new point, replacing the oldest point of a
//          group of GROUP points chosen round robin (the render cache's replacement).
// Each pass writes every point from at most one invocation (a batch's pixels are distinct
// and a point is shown in at most one pixel; a batch has at most one sample per group),
// so the result does not depend on the order the GPU runs invocations in: a run is
// repeatable on any adapter and any number of GPU threads.

struct NewSample {
    pos: vec4<f32>,    // xyz hit position, w pixel index (bitcast u32)
    rad: vec4<f32>,    // rgb radiance, w surface id (bitcast u32)
    origin: vec4<f32>, // xyz ray origin, w distance along the ray
    weight: vec4<f32>, // x: samples this one's radiance is the mean of (1 when traced),
                       // y: 1 when its radiance is the same from every eye position
}

struct InsertParams {
    count: u32,
    cursor: u32,
    ngroups: u32,
    group_size: u32,
    npoints: u32,
    index_bits: u32,
    width: u32,
    height: u32,
}

@group(0) @binding(0) var<uniform> Q: InsertParams;
@group(0) @binding(1) var<storage, read_write> points: array<Point>;
@group(0) @binding(2) var<storage, read> samples: array<NewSample>;
@group(0) @binding(3) var<storage, read> key_img: array<u32>;
@group(0) @binding(4) var<storage, read_write> matched: array<u32>;
// Per pixel of the eye: how many samples asked for its point to be aged (zero between
// batches: `age_changed` clears what it applies).
@group(0) @binding(5) var<storage, read_write> aging: array<atomic<u32>>;

// Ray origins closer than this (m) may share a point if the hits agree.
const NEAR_ORIGIN: f32 = 0.02;
// Hits closer than this fraction of their distance are the same place.
const SAME_PLACE: f32 = 0.05;
const MOVING_MAX_COUNT: f32 = 16.0;
// Premature aging: a sample from another eye position whose luminance differs from the
// pixel's point (of at least MIN_COUNT samples) by more than this factor either way ...
const CHANGE_FACTOR: f32 = 4.0;
const MIN_COUNT: f32 = 2.0;
// ... ages the points shown in the pixel's 3x3 neighbourhood by this many frames (per
// sample asking), so they are resampled sooner (the render cache's premature aging of
// stale points).
const CHANGE_AGING: f32 = 16.0;

// Asks for the points shown around `pixel` to be aged (applied by `age_changed`).
fn age_neighbourhood(pixel: u32) {
    let x = i32(pixel % Q.width);
    let y = i32(pixel / Q.width);
    for (var dy = -1; dy <= 1; dy++) {
        for (var dx = -1; dx <= 1; dx++) {
            let xx = x + dx;
            let yy = y + dy;
            if (xx < 0 || yy < 0 || xx >= i32(Q.width) || yy >= i32(Q.height)) {
                continue;
            }
            atomicAdd(&aging[u32(yy) * Q.width + u32(xx)], 1u);
        }
    }
}

@compute @workgroup_size(64)
fn match_samples(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if (i >= Q.count) {
        return;
    }
    let s = samples[i];
    matched[i] = 0u;
    let key = key_img[bitcast<u32>(s.pos.w)];
    if (key == EMPTY) {
        return;
    }
    let idx = key_index(key, Q.index_bits);
    var p = points[idx];
    if (!point_valid(p)) {
        return;
    }
    let moved = distance(p.origin.xyz, s.origin.xyz);
    if (moved > SAME_ORIGIN && p.rad.w >= MIN_COUNT) {
        let a = luminance(p.rad.xyz) + 1.0e-3;
        let b = luminance(s.rad.xyz) + 1.0e-3;
        if (a > CHANGE_FACTOR * b || b > CHANGE_FACTOR * a) {
            age_neighbourhood(bitcast<u32>(s.pos.w));
        }
    }
    // A sample of another object than the point's (or of an object where the point is the
    // room's) never joins it, even from the same eye: an object moved in front of it. (The
    // room's surfaces and the background are all static: a sample escaping at a silhouette
    // still joins the pixel's point, as before.)
    if (point_object(p) != surface_object(bitcast<u32>(s.rad.w))) {
        return;
    }
    let w = max(s.weight.x, 1.0);
    var n = p.rad.w + w;
    let same_surface = bitcast<u32>(p.origin.w) == bitcast<u32>(s.rad.w);
    if (moved > SAME_ORIGIN) {
        let same_place = distance(p.pos.xyz, s.pos.xyz) <= SAME_PLACE * s.origin.w;
        let view_independent = s.weight.y > 0.5;
        if (point_mixed(p) || !same_surface || !same_place
            || (moved > NEAR_ORIGIN && !view_independent)) {
            return;
        }
        if (!view_independent) {
            n = min(n, MOVING_MAX_COUNT);
        }
        p.origin = vec4<f32>(s.origin.xyz, p.origin.w);
    } else if (!same_surface) {
        p.square.y = 1.0;
    }
    let share = min(w / n, 1.0);
    p.rad = vec4<f32>(p.rad.xyz + (s.rad.xyz - p.rad.xyz) * share, n);
    let l = luminance(s.rad.xyz);
    p.square.x = p.square.x + (l * l - p.square.x) * share;
    // The point stands for the pixel: keep the nearest hit so the depth cull sees the
    // front surface at silhouettes.
    if (s.origin.w < distance(p.pos.xyz, p.origin.xyz)) {
        p.pos = vec4<f32>(s.pos.xyz, p.pos.w);
        p.origin = vec4<f32>(p.origin.xyz, s.rad.w);
    }
    p.pos.w = 0.0;
    points[idx] = p;
    matched[i] = 1u;
}

// One invocation per pixel of the eye: the point shown there is aged as many times as
// samples asked (after `match_samples` has written every matched point).
@compute @workgroup_size(64)
fn age_changed(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if (i >= Q.width * Q.height) {
        return;
    }
    let asked = atomicLoad(&aging[i]);
    if (asked == 0u) {
        return;
    }
    atomicStore(&aging[i], 0u);
    let k = key_img[i];
    if (k != EMPTY) {
        let j = key_index(k, Q.index_bits);
        points[j].pos.w = min(points[j].pos.w + CHANGE_AGING * f32(asked), MAX_AGE - 1.0);
    }
}

@compute @workgroup_size(64)
fn place_samples(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if (i >= Q.count || matched[i] != 0u) {
        return;
    }
    let s = samples[i];
    let g = (Q.cursor + i) % Q.ngroups;
    let base = g * Q.group_size;
    var oldest = base;
    var oldest_age = -1.0;
    for (var k = 0u; k < Q.group_size; k++) {
        let j = base + k;
        if (j >= Q.npoints) {
            break;
        }
        let a = points[j].pos.w;
        if (a > oldest_age) {
            oldest_age = a;
            oldest = j;
        }
    }
    points[oldest] = Point(
        vec4<f32>(s.pos.xyz, 0.0),
        vec4<f32>(s.rad.xyz, max(s.weight.x, 1.0)),
        vec4<f32>(s.origin.xyz, s.rad.w),
        vec4<f32>(luminance(s.rad.xyz) * luminance(s.rad.xyz), 0.0, 0.0, 0.0),
    );
}
