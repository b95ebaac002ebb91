// The picture of a wall in a window: the eyes' linear images (the render cache's colour
// buffers) laid out (one eye, side by side, top-bottom, anaglyph; flips; swapped eyes),
// tone-mapped with the curve the CPU computed from the histogram (the same numbers as
// `ToneMapper::apply`) or shown in false colour with the CPU's legend over it, and written
// straight into the surface. One full-screen triangle.

struct ScreenParams {
    window: vec2<u32>,
    eye_size: vec2<u32>,
    // 0: one eye (`first`), 1: side by side, 2: top-bottom, 3: anaglyph.
    arrangement: u32,
    first: u32,
    second: u32,
    // 1: flip x, 2: flip y, 4: encode sRGB here (the surface is not sRGB), 8: a mapping exists,
    // 16: false colour.
    flags: u32,
    // 1: linear curve (log_scale), 0: histogram (cdf).
    linear: u32,
    log_min: f32,
    log_max: f32,
    log_scale: f32,
    cdf: array<vec4<f32>, 26>,
    // lm/W: scene radiance to cd/m².
    efficacy: f32,
    // False colour: log10 of the scale's bottom (cd/m²) and its decades.
    fc_log_min: f32,
    fc_decades: f32,
    // The legend's size in eye pixels (0: none), at the eye image's top-left.
    legend_w: u32,
    legend_h: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
};

@group(0) @binding(0) var<uniform> s: ScreenParams;
@group(0) @binding(1) var<storage, read> eye0: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> eye1: array<vec4<f32>>;
// The legend's sRGB codes, 0x00BBGGRR per pixel, row by row (`falsecolor::Legend`).
@group(0) @binding(3) var<storage, read> legend: array<u32>;

const LD_MAX: f32 = 100.0;
const L_FLOOR: f32 = 1e-4;
const BINS: u32 = 100u;
const LOG10_2: f32 = 0.30102999566;

@vertex
fn vs(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    let x = f32((i << 1u) & 2u);
    let y = f32(i & 2u);
    return vec4<f32>(x * 2.0 - 1.0, y * 2.0 - 1.0, 0.0, 1.0);
}

fn cdf_at(b: u32) -> f32 {
    return s.cdf[b / 4u][b % 4u];
}

fn log10_(x: f32) -> f32 {
    return log2(x) * LOG10_2;
}

fn pow10(x: f32) -> f32 {
    return exp2(x / LOG10_2);
}

// `Mapping::display_luminance`: the display range is 1..100 cd/m² (log 0..2).
fn display_luminance(lw: f32) -> f32 {
    if (lw <= L_FLOOR) {
        return 0.0;
    }
    if (s.linear == 1u) {
        return pow10(clamp(log10_(lw) + s.log_scale, 0.0, 2.0));
    }
    let x = clamp((log10_(lw) - s.log_min) / (s.log_max - s.log_min), 0.0, 1.0) * f32(BINS);
    let b = min(u32(x), BINS - 1u);
    let f = x - f32(b);
    let p = cdf_at(b) + (cdf_at(b + 1u) - cdf_at(b)) * f;
    return pow10(2.0 * p);
}

// `falsecolor::palette`: Radiance's `spec` palette.
fn palette(v: f32) -> vec3<f32> {
    var g = 1.6 - 1.6 * v;
    if (v < 0.375) {
        g = 8.0 / 3.0 * v;
    }
    return clamp(vec3<f32>(1.6 * v - 0.6, g, 1.0 - 8.0 / 3.0 * v), vec3<f32>(0.0), vec3<f32>(1.0));
}

// `ToneMapper::apply` before encoding: linear display values in 0..1.
fn tone(c: vec3<f32>) -> vec3<f32> {
    if ((s.flags & 8u) == 0u) {
        return vec3<f32>(0.0);
    }
    let lw = s.efficacy * luminance(c);
    if ((s.flags & 16u) != 0u) {
        var v = 0.0;
        if (lw > 0.0) {
            v = clamp((log10_(lw) - s.fc_log_min) / s.fc_decades, 0.0, 1.0);
        }
        return palette(clamp(v, 0.0, 1.0));
    }
    let ld = display_luminance(lw);
    var scale = 0.0;
    if (lw > 0.0) {
        scale = ld / lw / LD_MAX;
    }
    return clamp(c * s.efficacy * scale, vec3<f32>(0.0), vec3<f32>(1.0));
}

fn srgb(v: f32) -> f32 {
    if (v <= 0.0031308) {
        return 12.92 * v;
    }
    return 1.055 * pow(v, 1.0 / 2.4) - 0.055;
}

fn srgb_decode(v: f32) -> f32 {
    if (v <= 0.04045) {
        return v / 12.92;
    }
    return pow((v + 0.055) / 1.055, 2.4);
}

// The eye pixel under window point `p` of a region at `origin` of `size` (nearest).
fn eye_pixel(p: vec2<f32>, origin: vec2<f32>, size: vec2<f32>) -> vec2<u32> {
    let q = (p - origin) / size * vec2<f32>(s.eye_size);
    return min(vec2<u32>(max(floor(q), vec2<f32>(0.0))), s.eye_size - vec2<u32>(1u));
}

// Eye pixel `xy` of `eye` tone-mapped (linear display values), or the legend's pixel
// there (decoded to linear: encoded again below, or by the sRGB surface).
fn shade(eye: u32, xy: vec2<u32>) -> vec3<f32> {
    if ((s.flags & 24u) == 24u && xy.x < s.legend_w && xy.y < s.legend_h) {
        let code = legend[xy.y * s.legend_w + xy.x];
        let rgb = vec3<u32>(code & 255u, (code >> 8u) & 255u, (code >> 16u) & 255u);
        let c = vec3<f32>(rgb) / 255.0;
        return vec3<f32>(srgb_decode(c.x), srgb_decode(c.y), srgb_decode(c.z));
    }
    let i = xy.y * s.eye_size.x + xy.x;
    if (eye == 0u) {
        return tone(eye0[i].xyz);
    }
    return tone(eye1[i].xyz);
}

@fragment
fn fs(@builtin(position) pos: vec4<f32>) -> @location(0) vec4<f32> {
    let w = vec2<f32>(s.window);
    var p = pos.xy;
    if ((s.flags & 1u) != 0u) {
        p.x = w.x - p.x;
    }
    if ((s.flags & 2u) != 0u) {
        p.y = w.y - p.y;
    }
    var d: vec3<f32>;
    switch s.arrangement {
        case 1u: {
            let half = w.x * 0.5;
            if (p.x < half) {
                d = shade(s.first, eye_pixel(p, vec2<f32>(0.0), vec2<f32>(half, w.y)));
            } else {
                d = shade(s.second, eye_pixel(p, vec2<f32>(half, 0.0), vec2<f32>(w.x - half, w.y)));
            }
        }
        case 2u: {
            let half = w.y * 0.5;
            if (p.y < half) {
                d = shade(s.first, eye_pixel(p, vec2<f32>(0.0), vec2<f32>(w.x, half)));
            } else {
                d = shade(s.second, eye_pixel(p, vec2<f32>(0.0, half), vec2<f32>(w.x, w.y - half)));
            }
        }
        case 3u: {
            let i = eye_pixel(p, vec2<f32>(0.0), w);
            let l = shade(s.first, i);
            let r = shade(s.second, i);
            d = vec3<f32>(l.x, r.y, r.z);
        }
        default: {
            d = shade(s.first, eye_pixel(p, vec2<f32>(0.0), w));
        }
    }
    if ((s.flags & 4u) != 0u) {
        d = vec3<f32>(srgb(d.x), srgb(d.y), srgb(d.z));
    }
    return vec4<f32>(d, 1.0);
}
