// The light field's lookups composed on the GPU (see lookups.rs), after surfaces.wgsl:
// each pixel's from the wall's first hit where the CPU found its point there on an
// element its material's table shades (the element's first cell and resolution from the
// triangle's table, the hit's barycentrics, the weight from the surface's albedo towards
// the pixel's ray), with the emitted light the CPU sent; the others copied whole from the
// lookups the CPU sent. Written as holocave_vlf::Lookup's sixteen words.

struct LookupParams {
    count: u32,
    row: u32,
    pad0: u32,
    pad1: u32,
}

// What the CPU sends of a pixel: the lookup's emitted light, and a tag: the side of the
// triangle seen (0 front, 1 back) where the lookup is composed here with the weight from
// the material data; WEIGHT_SENT | k << 1 | side where it is composed with the k-th of
// the weights sent; WHOLE | k where it is the k-th of the lookups sent whole.
struct Shade {
    emitted: vec3<f32>,
    tag: u32,
}

@group(0) @binding(0) var<uniform> lp: LookupParams;
// Per static triangle: its first element (front side; the back side follows) and its
// resolution.
@group(0) @binding(1) var<storage, read> cells: array<vec2<u32>>;
// The wall's first hits: t, triangle, u, v.
@group(0) @binding(2) var<storage, read> hits: array<vec4<u32>>;
@group(0) @binding(3) var<storage, read> shades: array<Shade>;
@group(0) @binding(4) var<storage, read> sent: array<u32>;
@group(0) @binding(5) var<storage, read_write> lookups: array<u32>;
// The wall's pixel rays (GpuRay: origin and tmax, direction and a pad).
@group(0) @binding(12) var<storage, read> pixel_rays: array<vec4<f32>>;
// The weights the CPU sent (w unused).
@group(0) @binding(13) var<storage, read> weights: array<vec4<f32>>;

const NONE: u32 = 0xffffffffu;
const WORDS: u32 = 16u;
const FRAC_1_PI: f32 = 0.31830988618379067;
const WEIGHT_SENT: u32 = 0x40000000u;
const WHOLE: u32 = 0x80000000u;

@compute @workgroup_size(64)
fn compose(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.y * lp.row + gid.x;
    if (i >= lp.count) {
        return;
    }
    let s = shades[i];
    let o = WORDS * i;
    if ((s.tag & WHOLE) != 0u) {
        let whole = WORDS * (s.tag & ~WHOLE);
        for (var k = 0u; k < WORDS; k += 1u) {
            lookups[o + k] = sent[whole + k];
        }
        return;
    }
    let h = hits[i];
    let c = cells[h.y];
    let res = c.y;
    var weight: vec3<f32>;
    if ((s.tag & WEIGHT_SENT) != 0u) {
        weight = weights[(s.tag & ~WEIGHT_SENT) >> 1u].xyz;
    } else {
        let at = surface_at(h.y, bitcast<f32>(h.z), bitcast<f32>(h.w));
        let m = material_surfaces[at.material];
        let cos_o = dot(at.shading_normal, pixel_rays[2u * i + 1u].xyz);
        weight = albedo_towards(m, base_color_at(m, at.uv), cos_o) * FRAC_1_PI;
    }
    lookups[o] = c.x + (s.tag & 1u) * (res * (res + 1u) / 2u);
    lookups[o + 1u] = res;
    lookups[o + 2u] = h.z;
    lookups[o + 3u] = h.w;
    lookups[o + 4u] = bitcast<u32>(weight.x);
    lookups[o + 5u] = bitcast<u32>(weight.y);
    lookups[o + 6u] = bitcast<u32>(weight.z);
    lookups[o + 7u] = bitcast<u32>(s.emitted.x);
    lookups[o + 8u] = bitcast<u32>(s.emitted.y);
    lookups[o + 9u] = bitcast<u32>(s.emitted.z);
    // No tile (its bins one a side, map coordinates zero), the samples counting fully (1.0),
    // the static scene.
    lookups[o + 10u] = NONE;
    lookups[o + 11u] = 1u;
    lookups[o + 12u] = 0u;
    lookups[o + 13u] = 0u;
    lookups[o + 14u] = 0x3f800000u;
    lookups[o + 15u] = 0u;
}
