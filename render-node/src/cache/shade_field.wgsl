// Per eye, per pixel: the Virtual Light Field under the render cache's exact samples
// (papers/vlf-in-the-cave.md §4, pass 5). Each pixel's lookup (what the eye sees there,
// found by the node's own ray cast: render_node::vlf) is shaded from the baked
// irradiance — or, for a glossy surface, from its directional radiance tile in the
// direction towards the eye — exactly as holocave_vlf::view::shade_one does on the CPU,
// then blended
// with what the cache shows: the light field is a prior worth `k` samples,
//   shown = (k · V + n · C) / (k + n),
// with n the samples behind the cache's value (its point's count, discounted by age;
// half a sample for an interpolated pixel, none for an empty one), times the lookup's
// `samples` (none where a moving object makes the static samples wrong), and none from a
// point on another object than the pixel sees (or on one where it sees the room; an
// interpolated pixel's points are not known, so it counts only where the pixel sees the
// room). Where the two
// disagree most, the priority image asks for samples first.
//
// `k` is the display's `prior` where a pixel's samples spread as the display's do
// (render_node::prior: k = σ²/b², the samples' variance over the field's squared error,
// both over μ² + 0.01). Per pixel the maths asks for the pixel's own σ²: with `spread` the
// display's σ²/(μ² + 0.01), a point's squared luminance gives its samples' variance v from
// its n samples, and the pixel's σ² is taken as the two pooled, the display's worth
// PRIOR_DOF degrees of freedom and the pixel's n − 1,
//   σ² = (PRIOR_DOF · spread · (μ² + 0.01) + (n − 1) · v) / (PRIOR_DOF + n − 1),
// with the field's error as the display's, b² = (μ² + 0.01) · spread / prior:
//   k = prior · σ² / (spread · (μ² + 0.01)).
// Where the samples agree (a smooth wall's gathers) they take over sooner; where they
// scatter (a penumbra, a lamp found by chance) the field holds longer. With `spread` 0
// (the node's choice under gathers: render_node::prior), `prior` everywhere.

struct Lookup {
    base: u32,
    res: u32,
    u: f32,
    v: f32,
    wr: f32, wg: f32, wb: f32,
    er: f32, eg: f32, eb: f32,
    // A glossy tile's first bin (NONE: none), its bins per side, the eye's map coordinates.
    tile: u32,
    bins: u32,
    x: f32,
    y: f32,
    // What the cache's samples count for here (0 where a moving object makes them stale).
    samples: f32,
    // The moving object seen (index + 1; 0: the static scene): only a point on the same
    // one counts.
    object: u32,
}

struct VlfParams {
    width: u32,
    height: u32,
    index_bits: u32,
    // The light field's worth in samples (0: the cache alone).
    prior: f32,
    // Values per buffer: the values are split over irradiance, irradiance1..3, each
    // within the adapter's binding limit.
    chunk: u32,
    // A sample's variance over μ² + 0.01 on the display (0: `prior` in every pixel).
    spread: f32,
    pad1: u32,
    pad2: u32,
}

@group(0) @binding(0) var<uniform> V: VlfParams;
@group(0) @binding(1) var<storage, read> lookups: array<Lookup>;
// The elements' irradiance, then the glossy tiles' radiance (holocave_vlf::State::values).
@group(0) @binding(2) var<storage, read> irradiance: array<f32>;
@group(0) @binding(3) var<storage, read> points: array<Point>;
@group(0) @binding(4) var<storage, read> key_img: array<u32>;
@group(0) @binding(5) var<storage, read_write> color: array<vec4<f32>>;
@group(0) @binding(6) var<storage, read_write> priority: array<f32>;
@group(0) @binding(7) var<storage, read_write> counters: array<atomic<u32>>;
@group(0) @binding(8) var<storage, read> irradiance1: array<f32>;
@group(0) @binding(9) var<storage, read> irradiance2: array<f32>;
@group(0) @binding(10) var<storage, read> irradiance3: array<f32>;

const NONE: u32 = 0xffffffffu;
// A point's samples count half after this many frames without a new one.
const STALE_FRAMES: f32 = 64.0;
// The degrees of freedom the display's spread counts for in a pixel's variance: the
// chi-square estimate from d samples has the relative standard deviation √(2/d), one half
// at 8, where the two are worth the same.
const PRIOR_DOF: f32 = 8.0;
// Priority added where the light field and the samples differ by this relative amount.
const DISAGREE_SCALE: f32 = 0.5;
// Fixed-point scale of the priority sum (as filter.wgsl).
const SUM_SCALE: f32 = 256.0;

fn cell_index(i0: u32, j0: u32, r: u32) -> u32 {
    let i = min(i0, r - 1u);
    let j = min(j0, r - 1u - i);
    return j * r - j * (max(j, 1u) - 1u) / 2u + i;
}

// Value i of the light field, from the buffer that holds it.
fn value(i: u32) -> f32 {
    let c = V.chunk;
    if (i < c) {
        return irradiance[i];
    }
    if (i < 2u * c) {
        return irradiance1[i - c];
    }
    if (i < 3u * c) {
        return irradiance2[i - 2u * c];
    }
    return irradiance3[i - 3u * c];
}

fn irr(e: u32) -> vec3<f32> {
    return vec3<f32>(value(3u * e), value(3u * e + 1u), value(3u * e + 2u));
}

// holocave_vlf::elements::interpolate
fn interpolate(base: u32, r: u32, u: f32, v: f32) -> vec3<f32> {
    let rf = f32(r);
    let x = max(u * rf - 0.5, 0.0);
    let y = max(v * rf - 0.5, 0.0);
    let i0 = min(u32(x), r - 1u);
    let j0 = min(u32(y), r - 1u);
    let i1 = min(i0 + 1u, r - 1u);
    let j1 = min(j0 + 1u, r - 1u);
    let fx = clamp(x - f32(i0), 0.0, 1.0);
    let fy = clamp(y - f32(j0), 0.0, 1.0);
    let bottom = irr(base + cell_index(i0, j0, r)) * (1.0 - fx) + irr(base + cell_index(i1, j0, r)) * fx;
    let top = irr(base + cell_index(i0, j1, r)) * (1.0 - fx) + irr(base + cell_index(i1, j1, r)) * fx;
    return bottom * (1.0 - fy) + top * fy;
}

// holocave_vlf::octahedral::interpolate: bilinear between the bin centres of a tile.
fn interpolate_tile(base: u32, k: u32, x0: f32, y0: f32) -> vec3<f32> {
    let x = max(x0 - 0.5, 0.0);
    let y = max(y0 - 0.5, 0.0);
    let i0 = min(u32(x), k - 1u);
    let j0 = min(u32(y), k - 1u);
    let i1 = min(i0 + 1u, k - 1u);
    let j1 = min(j0 + 1u, k - 1u);
    let fx = clamp(x - f32(i0), 0.0, 1.0);
    let fy = clamp(y - f32(j0), 0.0, 1.0);
    let bottom = irr(base + j0 * k + i0) * (1.0 - fx) + irr(base + j0 * k + i1) * fx;
    let top = irr(base + j1 * k + i0) * (1.0 - fx) + irr(base + j1 * k + i1) * fx;
    return bottom * (1.0 - fy) + top * fy;
}

fn shade(l: Lookup) -> vec3<f32> {
    var c = vec3<f32>(l.er, l.eg, l.eb);
    if (l.base != NONE) {
        c += vec3<f32>(l.wr, l.wg, l.wb) * interpolate(l.base, l.res, l.u, l.v);
    }
    if (l.tile != NONE) {
        c += vec3<f32>(l.wr, l.wg, l.wb) * interpolate_tile(l.tile, l.bins, l.x, l.y);
    }
    return c;
}

// The light field alone (for tests and `vlf` output): writes V into `color`.
@compute @workgroup_size(256)
fn lookup(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if (i >= V.width * V.height) {
        return;
    }
    color[i] = vec4<f32>(shade(lookups[i]), 1.0);
}

// The light field's worth in samples at a pixel showing point `p`, the field's luminance
// there `field` (see the top of this file).
fn pixel_prior(p: Point, field: f32) -> f32 {
    if (V.spread <= 0.0) {
        return V.prior;
    }
    let m = luminance(p.rad.xyz);
    let scale = max(field, m) * max(field, m) + 0.01;
    let dof = max(p.rad.w - 1.0, 0.0);
    let v = max(p.square.x - m * m, 0.0) * p.rad.w / max(dof, 1.0);
    let variance = (PRIOR_DOF * V.spread * scale + dof * v) / (PRIOR_DOF + dof);
    return V.prior * variance / (V.spread * scale);
}

@compute @workgroup_size(256)
fn blend(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if (i >= V.width * V.height) {
        return;
    }
    let vlf = shade(lookups[i]);
    let c = color[i];
    var n = 0.0;
    var k = V.prior;
    if (c.w >= 1.0) {
        let p = points[key_index(key_img[i], V.index_bits)];
        let seen = point_object(p);
        if (seen == lookups[i].object && seen != OBJECT_BEYOND) {
            n = p.rad.w * STALE_FRAMES / (STALE_FRAMES + p.pos.w);
            k = pixel_prior(p, luminance(vlf));
        }
    } else if (c.w > 0.0 && lookups[i].object == 0u) {
        // Interpolated (0.5) or filled from farther away (0.25): worth that much.
        n = c.w;
    }
    n *= lookups[i].samples;
    let shown = (k * vlf + n * c.xyz) / max(k + n, 1.0e-6);
    color[i] = vec4<f32>(shown, c.w);
    if (c.w > 0.0 && lookups[i].samples > 0.0) {
        let d = abs(luminance(c.xyz - vlf)) / (luminance(vlf) + 0.05);
        let extra = DISAGREE_SCALE * min(d, 1.0);
        priority[i] += extra;
        atomicAdd(&counters[0], u32(extra * SUM_SCALE + 0.5));
    }
}
