// Once per frame, after every eye has projected: points age by one frame, points no eye
// saw age faster.

@group(0) @binding(0) var<uniform> P: EyeParams;
@group(0) @binding(1) var<storage, read_write> points: array<Point>;
@group(0) @binding(2) var<storage, read_write> visible: array<u32>;

const OFFSCREEN_AGING: f32 = 4.0;

@compute @workgroup_size(256)
fn age(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if (i >= P.npoints) {
        return;
    }
    let a = points[i].pos.w;
    if (a < MAX_AGE) {
        let step = select(OFFSCREEN_AGING, 1.0, visible[i] != 0u);
        points[i].pos.w = min(a + step, MAX_AGE - 1.0);
    }
    visible[i] = 0u;
}
