// The material data a hit needs (see surfaces.rs): a static triangle's shading normal and
// texture coordinates at a hit's barycentrics, its material's base colour there (factor
// times texture, sampled as holocave_scene::Texture::sample samples), and the material's
// directional albedo towards a viewer (holocave_vlf::surface::albedo_towards's table), in
// the CPU's operations and order. Bindings 6 to 11, after those of the pass that reads it.

// A static triangle: its vertex normals (the face normal three times where it has none),
// its face normal, its texture coordinates in the w's and uv2, and its material (the high
// bit set where it has vertex normals).
struct TriangleSurface {
    n0: vec4<f32>,
    n1: vec4<f32>,
    n2: vec4<f32>,
    ng: vec4<f32>,
    uv2: vec2<f32>,
    material: u32,
    pad: u32,
}

// A material: its base colour factor (rgb; a unused), its base colour texture and the
// first step of its albedo table in `towards` (NO_SURFACE: none; a material without a
// table is never shaded here).
struct MaterialSurface {
    base_color: vec4<f32>,
    texture: u32,
    table: u32,
    pad0: u32,
    pad1: u32,
}

@group(0) @binding(6) var<storage, read> triangle_surfaces: array<TriangleSurface>;
@group(0) @binding(7) var<storage, read> material_surfaces: array<MaterialSurface>;
// The albedo tables: step k of a table at `table` is a (xyz) at table + 2k and b at
// table + 2k + 1; the albedo towards a view is a + b · base between two steps.
@group(0) @binding(8) var<storage, read> towards: array<vec4<f32>>;
// Per texture: its first texel in `texels`, width, height, 1 where sRGB-encoded.
@group(0) @binding(9) var<storage, read> textures: array<vec4<u32>>;
// RGBA8 texels, r in the low byte.
@group(0) @binding(10) var<storage, read> texels: array<u32>;
// Each 8-bit code's value as the CPU reads it: sRGB-encoded at 0 to 255, linear at 256 to
// 511.
@group(0) @binding(11) var<storage, read> codes: array<f32, 512>;

const NO_SURFACE: u32 = 0xffffffffu;
const HAS_NORMALS: u32 = 0x80000000u;
const TOWARDS_STEPS: u32 = 32u;

// Texel (x, y) of texture t, wrapped, as linear values.
fn texel(t: vec4<u32>, x: i32, y: i32) -> vec4<f32> {
    let w = i32(t.y);
    let h = i32(t.z);
    let xi = ((x % w) + w) % w;
    let yi = ((y % h) + h) % h;
    let p = texels[t.x + u32(yi * w + xi)];
    let c = vec4<u32>(p & 0xffu, (p >> 8u) & 0xffu, (p >> 16u) & 0xffu, p >> 24u);
    var rgb = c.xyz;
    if (t.w != 1u) {
        rgb += vec3<u32>(256u);
    }
    return vec4<f32>(codes[rgb.x], codes[rgb.y], codes[rgb.z], codes[256u + c.w]);
}

// glam's lerp: a (1 − s) + b s.
fn lerp4(a: vec4<f32>, b: vec4<f32>, s: f32) -> vec4<f32> {
    return a * (1.0 - s) + b * s;
}

// Bilinear lookup with repeat wrapping; non-finite coordinates read at (0, 0).
fn sample_texture(t: vec4<u32>, at: vec2<f32>) -> vec4<f32> {
    var uv = at;
    if (!(finite(uv.x) && finite(uv.y))) {
        uv = vec2<f32>(0.0);
    }
    uv = uv - floor(uv);
    let x = uv.x * f32(t.y) - 0.5;
    let y = uv.y * f32(t.z) - 0.5;
    let x0 = floor(x);
    let y0 = floor(y);
    let fx = x - x0;
    let fy = y - y0;
    let xi = i32(x0);
    let yi = i32(y0);
    let a = lerp4(texel(t, xi, yi), texel(t, xi + 1, yi), fx);
    let b = lerp4(texel(t, xi, yi + 1), texel(t, xi + 1, yi + 1), fx);
    return lerp4(a, b, fy);
}

// What a hit on static triangle `tri` at barycentrics (u, v) sees of its surface.
struct SurfaceAt {
    shading_normal: vec3<f32>,
    uv: vec2<f32>,
    material: u32,
}

fn surface_at(tri: u32, u: f32, v: f32) -> SurfaceAt {
    let s = triangle_surfaces[tri];
    let w = vec3<f32>(1.0 - u - v, u, v);
    let ng = s.ng.xyz;
    var ns = ng;
    if ((s.material & HAS_NORMALS) != 0u) {
        let n = s.n0.xyz * w.x + s.n1.xyz * w.y + s.n2.xyz * w.z;
        // glam's normalize_or_zero (zero unless 1/|n| is finite and positive: for an f32
        // square length, unless it is positive and finite); the face normal where that is
        // zero, turned to its side.
        let d = dot(n, n);
        if (d > 0.0 && finite(d)) {
            ns = n * (1.0 / sqrt(d));
            if (dot(ns, ng) < 0.0) {
                ns = -ns;
            }
        }
    }
    let uv0 = vec2<f32>(s.n0.w, s.n1.w);
    let uv1 = vec2<f32>(s.n2.w, s.ng.w);
    let uv = uv0 * w.x + uv1 * w.y + s.uv2 * w.z;
    return SurfaceAt(ns, uv, s.material & ~HAS_NORMALS);
}

// The material's base colour at uv: factor times texture, clamped to [0, 1].
fn base_color_at(m: MaterialSurface, uv: vec2<f32>) -> vec3<f32> {
    var base = m.base_color.xyz;
    if (m.texture != NO_SURFACE) {
        base = base * sample_texture(textures[m.texture], uv).xyz;
    }
    return clamp(base, vec3<f32>(0.0), vec3<f32>(1.0));
}

// albedo_towards: the table's a + b · base between its two steps around |cos_o|, clamped.
fn albedo_towards(m: MaterialSurface, base: vec3<f32>, cos_o: f32) -> vec3<f32> {
    let at = clamp(abs(cos_o), 0.0, 1.0) * f32(TOWARDS_STEPS - 1u);
    let i = min(u32(at), TOWARDS_STEPS - 2u);
    let f = at - f32(i);
    let k = m.table + 2u * i;
    let lo = towards[k].xyz + towards[k + 1u].xyz * base;
    let hi = towards[k + 2u].xyz + towards[k + 3u].xyz * base;
    return clamp(lo * (1.0 - f) + hi * f, vec3<f32>(0.0), vec3<f32>(1.0));
}
