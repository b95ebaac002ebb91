// What a person would see (`vision::perceive` on the CPU, step for step): the foveal
// image's means and acuity levels (`means`), the veil on each foveal sample from this
// view's samples and the imported sources of other walls (`veil`), the box pyramid
// (`pyramid`, levels 1.. from the image's pixels), and each pixel seen (`perceive`):
// acuity from the pyramid, the veil added and the scattered fraction taken away, colour
// faded toward the scotopic grey.

struct VisionParams {
    width: u32,
    height: u32,
    cols: u32,
    rows: u32,
    imported: u32,
    levels: u32,
    efficacy: f32,
    veil_uniform: f32,
};

struct Cell {
    // xyz: unit direction of the cell's centre; w: its solid angle (sr).
    dir: vec4<f32>,
    // x: pixels per degree at its centre.
    ppd: vec4<f32>,
};

struct Source {
    dir: vec4<f32>,
    flux: vec4<f32>,
};

struct Foveal {
    // xyz: mean radiance; w: acuity level.
    mean: vec4<f32>,
    // xyz: veil.
    veil: vec4<f32>,
};

@group(0) @binding(0) var<uniform> vp: VisionParams;
@group(0) @binding(1) var<storage, read> pixels: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> cells: array<Cell>;
@group(0) @binding(3) var<storage, read> sources: array<Source>;
@group(0) @binding(4) var<storage, read_write> foveal: array<Foveal>;
@group(0) @binding(5) var<storage, read_write> pyramid: array<vec4<f32>>;
@group(0) @binding(6) var<storage, read_write> seen: array<vec4<f32>>;

const PI: f32 = 3.14159265358979;
// Holladay's 10 cd/m² per lux per degree², θ in radians (`veil::HOLLADAY_K`).
const HOLLADAY_K: f32 = 0.0030461742;
// Half the fovea, radians (`fovea::FOVEA_DEG` / 2).
const HALF_FOVEA: f32 = 0.0087266462;
const TOP_MESOPIC: f32 = 5.62;
const BOT_MESOPIC: f32 = 0.00562;

// `acuity::SHALER_LOG_LA` and `acuity::SHALER_CPD`.
const SHALER_LOG_LA = array<f32, 20>(
    -3.10503, -2.66403, -2.37703, -2.09303, -1.64403, -1.35803, -1.07403, -0.67203, -0.38503,
    -0.10103, 0.29397, 0.58097, 0.86497, 1.25697, 1.54397, 1.82797, 2.27597, 2.56297, 2.84697,
    3.24897);
const SHALER_CPD = array<f32, 20>(
    2.09, 3.28, 3.79, 4.39, 6.11, 8.83, 10.94, 18.66, 23.88, 31.05, 37.42, 37.68, 41.60, 43.16,
    45.30, 47.00, 48.43, 48.32, 51.06, 51.09);

fn resolvable_cpd(la: f32) -> f32 {
    let l = clamp(log2(max(la, 1e-30)) * 0.30102999566, SHALER_LOG_LA[0], SHALER_LOG_LA[19]);
    var i = 0u;
    while (i < 18u && SHALER_LOG_LA[i + 1u] <= l) {
        i = i + 1u;
    }
    let t = (l - SHALER_LOG_LA[i]) / (SHALER_LOG_LA[i + 1u] - SHALER_LOG_LA[i]);
    return SHALER_CPD[i] + (SHALER_CPD[i + 1u] - SHALER_CPD[i]) * t;
}

fn acuity_level(ppd: f32, la: f32) -> f32 {
    return min(log2(max(ppd / resolvable_cpd(la), 1.0)), f32(vp.levels - 1u));
}

// `Fovea::span` along one axis: the first pixel of cell `i` of `cells` over `size` (at
// most 180 cells of 16384 pixels: the product fits in 32 bits).
fn cell_start(i: u32, size: u32, cells: u32) -> u32 {
    return (i * size) / cells;
}

@compute @workgroup_size(64)
fn means(@builtin(global_invocation_id) g: vec3<u32>) {
    let n = vp.cols * vp.rows;
    if (g.x >= n) {
        return;
    }
    let i = g.x % vp.cols;
    let j = g.x / vp.cols;
    let x0 = cell_start(i, vp.width, vp.cols);
    let x1 = cell_start(i + 1u, vp.width, vp.cols);
    let y0 = cell_start(j, vp.height, vp.rows);
    let y1 = cell_start(j + 1u, vp.height, vp.rows);
    var s = vec3<f32>(0.0);
    for (var y = y0; y < y1; y = y + 1u) {
        for (var x = x0; x < x1; x = x + 1u) {
            s = s + pixels[y * vp.width + x].xyz;
        }
    }
    let m = s / f32(max((x1 - x0) * (y1 - y0), 1u));
    let level = acuity_level(cells[g.x].ppd.x, vp.efficacy * luminance(m));
    foveal[g.x].mean = vec4<f32>(m, level);
}

// `veil::veil_of`.
fn veil_of(d: vec3<f32>, src: vec3<f32>, flux: vec3<f32>) -> vec3<f32> {
    let c = dot(d, src);
    let theta = 2.0 * asin(min(0.5 * length(d - src), 1.0));
    if (c <= 0.0 || theta < HALF_FOVEA) {
        return vec3<f32>(0.0);
    }
    return flux * (HOLLADAY_K * c / (theta * theta));
}

@compute @workgroup_size(64)
fn veil(@builtin(global_invocation_id) g: vec3<u32>) {
    let n = vp.cols * vp.rows;
    if (g.x >= n) {
        return;
    }
    let d = cells[g.x].dir.xyz;
    var v = vec3<f32>(0.0);
    for (var k = 0u; k < n; k = k + 1u) {
        v = v + veil_of(d, cells[k].dir.xyz, foveal[k].mean.xyz * cells[k].dir.w);
    }
    for (var k = 0u; k < vp.imported; k = k + 1u) {
        v = v + veil_of(d, sources[k].dir.xyz, sources[k].flux.xyz);
    }
    foveal[g.x].veil = vec4<f32>(v, 0.0);
}

fn level_size(n: u32, k: u32) -> u32 {
    return max((n + (1u << k) - 1u) >> k, 1u);
}

// Where level `k` (1..) starts in `pyramid`.
fn level_offset(k: u32) -> u32 {
    var o = 0u;
    for (var j = 1u; j < k; j = j + 1u) {
        o = o + level_size(vp.width, j) * level_size(vp.height, j);
    }
    return o;
}

// One texel of levels 1.. per invocation: the mean of its block of the image's pixels,
// summed row by row as `acuity::Pyramid::new` does.
@compute @workgroup_size(64)
fn build_pyramid(@builtin(global_invocation_id) g: vec3<u32>) {
    var t = g.x;
    for (var k = 1u; k < vp.levels; k = k + 1u) {
        let w = level_size(vp.width, k);
        let h = level_size(vp.height, k);
        if (t < w * h) {
            let tx = t % w;
            let ty = t / w;
            let x0 = tx << k;
            let y0 = ty << k;
            let x1 = min(x0 + (1u << k), vp.width);
            let y1 = min(y0 + (1u << k), vp.height);
            var s = vec3<f32>(0.0);
            for (var y = y0; y < y1; y = y + 1u) {
                for (var x = x0; x < x1; x = x + 1u) {
                    s = s + pixels[y * vp.width + x].xyz;
                }
            }
            pyramid[level_offset(k) + t] = vec4<f32>(s / f32((x1 - x0) * (y1 - y0)), 1.0);
            return;
        }
        t = t - w * h;
    }
}

fn texel(k: u32, x: u32, y: u32) -> vec3<f32> {
    if (k == 0u) {
        return pixels[y * vp.width + x].xyz;
    }
    return pyramid[level_offset(k) + y * level_size(vp.width, k) + x].xyz;
}

// `Pyramid::at_level`: level k bilinear at the centre of pixel (x, y), edges clamped.
fn at_level(k: u32, x: u32, y: u32) -> vec3<f32> {
    let w = level_size(vp.width, k);
    let h = level_size(vp.height, k);
    let s = f32(1u << k);
    let gx = (f32(x) + 0.5) / s - 0.5;
    let gy = (f32(y) + 0.5) / s - 0.5;
    let fx = floor(gx);
    let fy = floor(gy);
    let x0 = u32(clamp(i32(fx), 0, i32(w) - 1));
    let x1 = u32(clamp(i32(fx) + 1, 0, i32(w) - 1));
    let y0 = u32(clamp(i32(fy), 0, i32(h) - 1));
    let y1 = u32(clamp(i32(fy) + 1, 0, i32(h) - 1));
    let tx = gx - fx;
    let ty = gy - fy;
    let top = texel(k, x0, y0) * (1.0 - tx) + texel(k, x1, y0) * tx;
    let bottom = texel(k, x0, y1) * (1.0 - tx) + texel(k, x1, y1) * tx;
    return top * (1.0 - ty) + bottom * ty;
}

// `vision::scotopic::scotopic`: Y·(1.33·(1 + (Y + Z)/X) − 1.68) of Rec. 709 RGB.
fn scotopic(c: vec3<f32>) -> f32 {
    let x = 0.4124 * c.x + 0.3576 * c.y + 0.1805 * c.z;
    let y = luminance(c);
    let z = 0.0193 * c.x + 0.1192 * c.y + 0.9505 * c.z;
    if (x <= 0.0) {
        return 0.0;
    }
    return y * (1.33 * (1.0 + (y + z) / x) - 1.68);
}

@compute @workgroup_size(8, 8)
fn perceive(@builtin(global_invocation_id) g: vec3<u32>) {
    if (g.x >= vp.width || g.y >= vp.height) {
        return;
    }
    // `Fovea::bilinear`.
    let gx = (f32(g.x) + 0.5) * f32(vp.cols) / f32(vp.width) - 0.5;
    let gy = (f32(g.y) + 0.5) * f32(vp.rows) / f32(vp.height) - 0.5;
    let fx = floor(gx);
    let fy = floor(gy);
    let cx0 = u32(clamp(i32(fx), 0, i32(vp.cols) - 1));
    let cx1 = u32(clamp(i32(fx) + 1, 0, i32(vp.cols) - 1));
    let cy0 = u32(clamp(i32(fy), 0, i32(vp.rows) - 1));
    let cy1 = u32(clamp(i32(fy) + 1, 0, i32(vp.rows) - 1));
    let tx = gx - fx;
    let ty = gy - fy;
    let i00 = cy0 * vp.cols + cx0;
    let i10 = cy0 * vp.cols + cx1;
    let i01 = cy1 * vp.cols + cx0;
    let i11 = cy1 * vp.cols + cx1;
    let w00 = (1.0 - tx) * (1.0 - ty);
    let w10 = tx * (1.0 - ty);
    let w01 = (1.0 - tx) * ty;
    let w11 = tx * ty;
    let level = w00 * foveal[i00].mean.w + w10 * foveal[i10].mean.w + w01 * foveal[i01].mean.w
        + w11 * foveal[i11].mean.w;
    let v = w00 * foveal[i00].veil.xyz + w10 * foveal[i10].veil.xyz + w01 * foveal[i01].veil.xyz
        + w11 * foveal[i11].veil.xyz;
    // `Pyramid::sample`.
    let k0 = u32(max(floor(level), 0.0));
    let k1 = min(k0 + 1u, vp.levels - 1u);
    let t = level - f32(k0);
    var c = at_level(k0, g.x, g.y);
    if (t > 0.0) {
        c = c * (1.0 - t) + at_level(k1, g.x, g.y) * t;
    }
    let s = c * (1.0 - vp.veil_uniform) + v;
    // `scotopic::mesopic`.
    let l = vp.efficacy * luminance(s);
    let f = clamp((l - BOT_MESOPIC) / (TOP_MESOPIC - BOT_MESOPIC), 0.0, 1.0);
    var out = s;
    if (f < 1.0) {
        let grey = scotopic(s) / scotopic(vec3<f32>(1.0));
        out = s * f + vec3<f32>(grey * (1.0 - f));
    }
    seen[g.y * vp.width + g.x] = vec4<f32>(out, 1.0);
}
