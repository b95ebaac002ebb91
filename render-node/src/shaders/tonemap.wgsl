// The picture of a wall in a window: the eyes' linear images (the render cache's colour
// buffers) laid out (one eye, side by side, top-bottom, anaglyph; flips; swapped eyes),
// tone-mapped with the curve the CPU computed from the histogram (the same numbers as
// `ToneMapper::apply`), and written straight into the surface. One full-screen triangle.

struct Screen {
    window: vec2<u32>,
    eye_size: vec2<u32>,
    // 0: one eye (`first`), 1: side by side, 2: top-bottom, 3: anaglyph.
    arrangement: u32,
    first: u32,
    second: u32,
    // 1: flip x, 2: flip y, 4: encode sRGB here (the surface is not sRGB), 8: a mapping exists.
    flags: u32,
    // 1: linear curve (log_scale), 0: histogram (cdf).
    linear: u32,
    log_min: f32,
    log_max: f32,
    log_scale: f32,
    cdf: array<vec4<f32>, 26>,
};

@group(0) @binding(0) var<uniform> s: Screen;
@group(0) @binding(1) var<storage, read> eye0: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> eye1: array<vec4<f32>>;

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

// `ToneMapper::apply` before encoding: linear display values in 0..1.
fn tone(c: vec3<f32>) -> vec3<f32> {
    if ((s.flags & 8u) == 0u) {
        return vec3<f32>(0.0);
    }
    let lw = LUMINOUS_EFFICACY * luminance(c);
    let ld = display_luminance(lw);
    var scale = 0.0;
    if (lw > 0.0) {
        scale = ld / lw / LD_MAX;
    }
    return clamp(c * LUMINOUS_EFFICACY * scale, vec3<f32>(0.0), vec3<f32>(1.0));
}

fn srgb(v: f32) -> f32 {
    if (v <= 0.0031308) {
        return 12.92 * v;
    }
    return 1.055 * pow(v, 1.0 / 2.4) - 0.055;
}

// The eye pixel under window point `p` of a region at `origin` of `size` (nearest).
fn eye_pixel(p: vec2<f32>, origin: vec2<f32>, size: vec2<f32>) -> u32 {
    let q = (p - origin) / size * vec2<f32>(s.eye_size);
    let xy = min(vec2<u32>(max(floor(q), vec2<f32>(0.0))), s.eye_size - vec2<u32>(1u));
    return xy.y * s.eye_size.x + xy.x;
}

fn fetch(eye: u32, i: u32) -> vec3<f32> {
    if (eye == 0u) {
        return eye0[i].xyz;
    }
    return eye1[i].xyz;
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
                d = tone(fetch(s.first, eye_pixel(p, vec2<f32>(0.0), vec2<f32>(half, w.y))));
            } else {
                d = tone(fetch(s.second, eye_pixel(p, vec2<f32>(half, 0.0), vec2<f32>(w.x - half, w.y))));
            }
        }
        case 2u: {
            let half = w.y * 0.5;
            if (p.y < half) {
                d = tone(fetch(s.first, eye_pixel(p, vec2<f32>(0.0), vec2<f32>(w.x, half))));
            } else {
                d = tone(fetch(s.second, eye_pixel(p, vec2<f32>(0.0, half), vec2<f32>(w.x, w.y - half))));
            }
        }
        case 3u: {
            let i = eye_pixel(p, vec2<f32>(0.0), w);
            let l = tone(fetch(s.first, i));
            let r = tone(fetch(s.second, i));
            d = vec3<f32>(l.x, r.y, r.z);
        }
        default: {
            d = tone(fetch(s.first, eye_pixel(p, vec2<f32>(0.0), w)));
        }
    }
    if ((s.flags & 4u) != 0u) {
        d = vec3<f32>(srgb(d.x), srgb(d.y), srgb(d.z));
    }
    return vec4<f32>(d, 1.0);
}
