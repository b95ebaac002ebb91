#!/usr/bin/env bash
# The GPU ray engine's figure on this machine's GPU, in one call:
#
#   benches/gpu_rays.sh [SCALE]                 build with cargo here and measure
#   benches/gpu_rays.sh --pack DIR              build the benches and put them in DIR
#   benches/gpu_rays.sh --binaries DIR [SCALE]  measure with the benches packed in DIR
#
# A GPU machine without a Rust toolchain takes the last two: pack on a machine with cargo
# (same architecture), carry DIR, and run there from a checkout at the same path as the one
# packed from (the benches read the project's scenes by the path they were built at, and
# Sponza from ../shared/scenes/sponza beside it; Sponza.gltf and Sponza.bin are enough).
#
# 1. The machine: CPU, and the GPU as the driver sees it (nvidia-smi, vulkaninfo --summary,
#    where installed).
# 2. The `gpu_rays` bench of holocave-render-node: the adapter wgpu opens (name, type,
#    backend, driver), every feature it offers and its limits, then Mrays/s (criterion's
#    Melem/s) for the room's and Sponza's primary, shadow and diffuse sets: the GPU walk
#    alone (`*_gpu`), with upload and read-back (`*_gpu_readback`) and its two halves
#    (`*_gpu_send`, `*_gpu_receive`), the wall's rays made on the GPU and traced
#    (`primary_gpu_wall`), and the CPU BVH on one thread and on every core (`*_cpu_1t`,
#    `*_cpu_all`), on the same rays.
# 3. A table of those rates, rays per second, from criterion's estimates.
# 4. A wall's whole frame (per-pixel work, render cache) at 1920 × 1200 per eye, stereo
#    (HOLOCAVE_BENCH_WALL, default 1920x1200), with rays on the CPU and on the GPU.
# 5. Gather samples over the Cornell box's light field, their rays on the CPU and on the GPU
#    (`pixel_tracer`'s `cornell_gather`), samples per second.
#
# SCALE (default 2) multiplies Sponza's 1024 × 576 primary rays in each axis (2: 2048 × 1152,
# 2.4 M rays, enough to fill a large GPU; 1: the same rays as `scene`'s ray_sets bench).
# WGPU_BACKEND (vulkan, gl) chooses the backend as everywhere in holocave. Without Sponza
# only the room is measured. On a machine without a GPU, wgpu opens lavapipe and the "GPU"
# figures are the CPU's cores running the compiled shader (DESIGN.md, "GPUs and software
# adapters").
set -euo pipefail

root=$(cd "$(dirname "$0")/.." && pwd)
benches=(gpu_rays wall_frame display pixel_tracer)
cd "$root"

# The bench executables cargo builds, one path per line, in the order of `benches`.
built() {
    cargo bench --no-run -p holocave-render-node --message-format=json 2>/dev/null |
        python3 -c '
import json, sys
want = sys.argv[1:]
found = {}
for line in sys.stdin:
    m = json.loads(line)
    if m.get("reason") == "compiler-artifact" and m.get("executable") \
            and "bench" in m["target"]["kind"] and m["target"]["name"] in want:
        found[m["target"]["name"]] = m["executable"]
missing = [w for w in want if w not in found]
if missing:
    sys.exit("benches not built: " + ", ".join(missing))
print("\n".join(found[w] for w in want))
' "${benches[@]}"
}

bin_dir=""
case "${1:-}" in
--pack)
    dir=${2:?"--pack needs a folder"}
    mkdir -p "$dir"
    paths=$(built)
    i=0
    for path in $paths; do
        cp "$path" "$dir/${benches[$i]}"
        strip "$dir/${benches[$i]}" 2>/dev/null || true
        i=$((i + 1))
    done
    echo "packed ${benches[*]} into $dir (built from $root)"
    exit 0
    ;;
--binaries)
    bin_dir=$(cd "${2:?"--binaries needs a folder"}" && pwd)
    shift 2
    ;;
esac
scale=${1:-2}

# Runs bench $1 with criterion's arguments $2…: the packed binary, or through cargo.
bench() {
    local name=$1
    shift
    if [ -n "$bin_dir" ]; then
        (cd "$root" && "$bin_dir/$name" --bench "$@")
    else
        cargo bench -p holocave-render-node --bench "$name" -- "$@"
    fi
}

echo "== machine"
uname -srm
grep -m1 'model name' /proc/cpuinfo || true
echo "cores: $(nproc)"
if command -v nvidia-smi >/dev/null 2>&1; then
    nvidia-smi --query-gpu=name,driver_version,memory.total,clocks.max.sm,clocks.max.mem \
        --format=csv || true
else
    echo "nvidia-smi: not installed"
fi
if command -v vulkaninfo >/dev/null 2>&1; then
    vulkaninfo --summary 2>/dev/null | sed -n '/Devices:/,$p' || true
else
    echo "vulkaninfo: not installed"
fi

echo "== bench (Sponza scale $scale)"
log=$(mktemp)
HOLOCAVE_GPU_RAYS_SCALE=$scale bench gpu_rays 2>&1 | tee "$log"

echo "== Mrays/s (criterion's mid estimate)"
# criterion prints "gpu_rays_<scene>/<set>_<walk>" then "thrpt: [lo mid hi]" lines.
awk '
    /^gpu_rays_[a-z]+\/[a-z_0-9]+/ { name = $1 }
    /thrpt:/ && !/%/ {
        v = $(NF - 3); u = $(NF - 2)
        if (u ~ /^Gelem/) v *= 1000; else if (u ~ /^Kelem/) v /= 1000; else if (u ~ /^elem/) v /= 1e6
        printf "%-40s %10.2f Mrays/s\n", name, v
    }
' "$log"
rm -f "$log"

# A wall's frame at a projector's size, both eyes: the per-pixel work (first hits, mirrors
# and glass, the direct light's shadow rays, lookups; `--rays cpu` against `--rays gpu`)
# and the render cache's passes with the light field under them.
echo "== a wall's frame, both eyes, at 128x96, 1024x768 and ${HOLOCAVE_BENCH_WALL:=1920x1200} per eye"
export HOLOCAVE_BENCH_WALL
bench wall_frame 2>&1 | grep -E '^wall_frame|time:|adapter'
bench display 2>&1 | grep -E '^display|time:|adapter|steps|per eye|clear'

echo "== gather samples, rays on the CPU and on the GPU"
bench pixel_tracer cornell_gather 2>&1 | grep -E '^pixel_tracer|time:|thrpt:|adapter'
