// The histogram of an eye image's log10 world luminance, on the GPU, for the tone mapping
// (`tonemap::LogHistogram`, as `LogHistogram::of_image` makes it on the CPU): `reduce` finds
// the range (atomic min / max of order-preserving keys), counts the pixels above black and
// sums their logs per workgroup; `histogram` bins them over that range.

struct LumParams {
    n: u32,
    bins: u32,
    // lm/W: scene radiance to cd/m² (`ToneMapper::efficacy`).
    efficacy: f32,
    _pad: u32,
};

@group(0) @binding(0) var<uniform> lp: LumParams;
@group(0) @binding(1) var<storage, read> pixels: array<vec4<f32>>;
// [min key, max key, count, unused]
@group(0) @binding(2) var<storage, read_write> stats: array<atomic<u32>, 4>;
@group(0) @binding(3) var<storage, read_write> partial: array<f32>;
@group(0) @binding(4) var<storage, read_write> hist: array<atomic<u32>>;

const L_FLOOR: f32 = 1e-4;
const LOG10_2: f32 = 0.30102999566;

// log10 of the pixel's luminance (cd/m²), or a value below -1e30 for black or non-finite.
fn log_lum(i: u32) -> f32 {
    let c = pixels[i].xyz;
    let l = lp.efficacy * luminance(c);
    if (l > L_FLOOR && l < 3.0e38) {
        return log2(l) * LOG10_2;
    }
    return -3.0e38;
}

// f32 → u32 keys that order as the floats do.
fn order_key(f: f32) -> u32 {
    let b = bitcast<u32>(f);
    if ((b & 0x80000000u) != 0u) {
        return ~b;
    }
    return b | 0x80000000u;
}

fn order_unkey(k: u32) -> f32 {
    if ((k & 0x80000000u) != 0u) {
        return bitcast<f32>(k & 0x7fffffffu);
    }
    return bitcast<f32>(~k);
}

// Each invocation takes CHUNK neighbouring pixels and keeps its statistics in registers
// (a private histogram for `histogram`), then does one atomic per statistic (per non-empty
// bin): no workgroup barriers (slow on software rasterisers) and few atomics on one
// address.
const CHUNK: u32 = 256u;
const MAX_BINS: u32 = 128u;

@compute @workgroup_size(64)
fn reduce(@builtin(global_invocation_id) g: vec3<u32>) {
    let start = g.x * CHUNK;
    if (start >= lp.n) {
        return;
    }
    let end = min(start + CHUNK, lp.n);
    var s = 0.0;
    var lo = 3.0e38;
    var hi = -3.0e38;
    var c = 0u;
    for (var i = start; i < end; i = i + 1u) {
        let lg = log_lum(i);
        if (lg > -1.0e30) {
            s = s + lg;
            lo = min(lo, lg);
            hi = max(hi, lg);
            c = c + 1u;
        }
    }
    partial[g.x] = s;
    if (c > 0u) {
        atomicMin(&stats[0], order_key(lo));
        atomicMax(&stats[1], order_key(hi));
        atomicAdd(&stats[2], c);
    }
}

@compute @workgroup_size(64)
fn histogram(@builtin(global_invocation_id) g: vec3<u32>) {
    let start = g.x * CHUNK;
    if (start >= lp.n || atomicLoad(&stats[2]) == 0u) {
        return;
    }
    let end = min(start + CHUNK, lp.n);
    let lo = order_unkey(atomicLoad(&stats[0]));
    let hi = max(order_unkey(atomicLoad(&stats[1])), lo + 1e-3);
    let bins = min(lp.bins, MAX_BINS);
    let db = (hi - lo) / f32(bins);
    var local: array<u32, 128>;
    for (var i = start; i < end; i = i + 1u) {
        let lg = log_lum(i);
        if (lg > -1.0e30) {
            let b = min(u32(max((lg - lo) / db, 0.0)), bins - 1u);
            local[b] = local[b] + 1u;
        }
    }
    for (var b = 0u; b < bins; b = b + 1u) {
        if (local[b] > 0u) {
            atomicAdd(&hist[b], local[b]);
        }
    }
}
