// Per eye: choose the pixels to sample next by error-diffusion dithering (Floyd–Steinberg,
// serpentine) of the priority image scaled so that it sums to the sample budget. The image
// is cut into TILE x TILE tiles, one invocation each, so the work is linear in pixels and
// runs in parallel; error does not cross tiles. Chosen pixels are appended to `chosen`.

@group(0) @binding(0) var<uniform> P: EyeParams;
@group(0) @binding(1) var<storage, read> priority: array<f32>;
@group(0) @binding(2) var<storage, read_write> counters: array<atomic<u32>>;
@group(0) @binding(3) var<storage, read_write> chosen: array<u32>;

const TILE: u32 = 8u;
const SUM_SCALE: f32 = 256.0;

@compute @workgroup_size(64)
fn dither(@builtin(global_invocation_id) gid: vec3<u32>) {
    // The tile grid moves by a random offset every frame, so that what happens at tile
    // edges (less error arriving, error lost) does not stay on the same pixels.
    let shift = hash_u32(P.frame * 0x9e3779b9u + P.eye_index * 0x85ebca6bu + 17u);
    let ox = shift % TILE;
    let oy = (shift / TILE) % TILE;
    let tiles_x = (P.width + ox + TILE - 1u) / TILE;
    let tiles_y = (P.height + oy + TILE - 1u) / TILE;
    let t = gid.x;
    if (t >= tiles_x * tiles_y) {
        return;
    }
    let total = f32(atomicLoad(&counters[0])) / SUM_SCALE;
    let scale = select(0.0, f32(P.target_samples) / total, total > 0.0);
    // Tile origin in image pixels (may be negative: i32).
    let x0 = i32((t % tiles_x) * TILE) - i32(ox);
    let y0 = i32((t / tiles_x) * TILE) - i32(oy);
    // Error carried to this row and the next; index k+1 is column k of the tile.
    var cur: array<f32, 10>;
    var nxt: array<f32, 10>;
    for (var k = 0u; k < 10u; k++) {
        cur[k] = 0.0;
        nxt[k] = 0.0;
    }
    // A random start so that tiles and frames do not repeat one pattern.
    cur[1] = f32(hash_u32(t * 9781u + P.frame * 6271u + P.eye_index * 7919u) >> 8u) / 16777216.0 - 0.5;
    for (var r = 0u; r < TILE; r++) {
        let yi = y0 + i32(r);
        let forward = (r & 1u) == 0u;
        for (var s = 0u; s < TILE; s++) {
            let c = select(TILE - 1u - s, s, forward);
            let xi = x0 + i32(c);
            if (xi < 0 || yi < 0 || xi >= i32(P.width) || yi >= i32(P.height)) {
                continue;
            }
            let x = u32(xi);
            let y = u32(yi);
            let i = y * P.width + x;
            let v = priority[i] * scale + cur[c + 1u];
            var e = v;
            if (v >= 0.5) {
                e = v - 1.0;
                let slot = atomicAdd(&counters[1], 1u);
                if (slot < P.max_chosen) {
                    chosen[slot] = i;
                }
            }
            // Floyd–Steinberg weights, mirrored on backward rows; the tile's last row
            // passes all its error along the row, so at most half a sample is lost per tile.
            let last_row = r + 1u == TILE || yi + 1 >= i32(P.height);
            if (last_row) {
                if (forward) {
                    cur[c + 2u] += e;
                } else {
                    cur[c] += e;
                }
            } else if (forward) {
                cur[c + 2u] += e * 7.0 / 16.0;
                nxt[c] += e * 3.0 / 16.0;
                nxt[c + 1u] += e * 5.0 / 16.0;
                nxt[c + 2u] += e * 1.0 / 16.0;
            } else {
                cur[c] += e * 7.0 / 16.0;
                nxt[c + 2u] += e * 3.0 / 16.0;
                nxt[c + 1u] += e * 5.0 / 16.0;
                nxt[c] += e * 1.0 / 16.0;
            }
        }
        // Error pushed past the tile's sides goes to where the next (serpentine) row
        // starts, so that little is lost at tile edges.
        if (forward) {
            nxt[TILE] += cur[TILE + 1u] + nxt[TILE + 1u];
        } else {
            nxt[1] += cur[0] + nxt[0];
        }
        for (var k = 0u; k < 10u; k++) {
            cur[k] = nxt[k];
            nxt[k] = 0.0;
        }
    }
}
