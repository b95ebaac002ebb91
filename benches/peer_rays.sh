#!/usr/bin/env bash
# Ray rates on Sponza, holocave's BVH beside a peer kernel (tinybvh) on the very same rays.
#
#   benches/peer_rays.sh [RUNS]
#
# 1. `cargo bench -p holocave-scene --bench ray_sets` measures holocave (criterion) and, with
#    HOLOCAVE_RAY_DUMP, writes the triangles, the primary / shadow / diffuse ray sets and
#    holocave's answers to target/peer/rays/.
# 2. tinybvh (its single header, fetched at a pinned commit into target/peer/tinybvh-<commit>;
#    never part of the project) and benches/peer/tinybvh_rays.cpp are compiled with
#    g++ -std=c++17 -O3 -march=native (so BVH8_CPU where the CPU has AVX2); the harness
#    builds its BVH over the same triangles (BuildHQ, and the plain Build for reference),
#    traces each set one ray at a time on one thread and on two (alternate chunks of 4096
#    rays), best of RUNS (default 10), and checks its answers against holocave's.
# 3. Two tables, Mrays/s per ray set: by wall clock, and per CPU-second (the process's CPU
#    time, which other processes' load on a shared machine does not lower by taking turns on
#    the cores). holocave's figure is criterion's best sample (as tinybvh's is its best
#    run); its median is printed beside it. A third, one thread per CPU-second: tinybvh
#    with each Ray made inside its timed loop from the origin and direction, as holocave's
#    queries take them (tinybvh's rates above are on Rays made before the clock starts).
#
# TINYBVH_GIT overrides where tinybvh's header is fetched from (a github.com URL or a local
# clone / mirror).
# With HOLOCAVE_NATIVE_TARGET=DIR, holocave's one-core figures are measured a second time from
# a build with RUSTFLAGS="-C target-cpu=native" in that cargo target directory (an extra
# column: how much of the gap is the instruction set). Not part of `cargo test`. Run it on an otherwise idle machine: both sides are timed.
set -euo pipefail

root=$(cd "$(dirname "$0")/.." && pwd)
runs=${1:-10}
TINYBVH_COMMIT=4735685f64d8b2bb0ad2c6c4643f291bf58774ad # main, 2026-02-13, version 1.6.7
TINYBVH_GIT=${TINYBVH_GIT:-https://github.com/jbikker/tinybvh.git}
target=${CARGO_TARGET_DIR:-$root/target}
work=$root/target/peer
mkdir -p "$work"

# --- tinybvh at the pinned commit (only its header is needed) --------------------------------
src=$work/tinybvh-$TINYBVH_COMMIT
if [ ! -s "$src/tiny_bvh.h" ]; then
    mkdir -p "$src"
    if [ -d "$TINYBVH_GIT" ]; then
        git -C "$TINYBVH_GIT" show "$TINYBVH_COMMIT:tiny_bvh.h" >"$src/tiny_bvh.h.part"
    elif [[ "$TINYBVH_GIT" == https://github.com/* ]]; then
        repo=${TINYBVH_GIT#https://github.com/}
        curl -fsSL "https://raw.githubusercontent.com/${repo%.git}/$TINYBVH_COMMIT/tiny_bvh.h" \
            -o "$src/tiny_bvh.h.part"
    else
        echo "TINYBVH_GIT must be a local clone or a github.com URL" >&2
        exit 1
    fi
    mv "$src/tiny_bvh.h.part" "$src/tiny_bvh.h"
fi
echo "tinybvh ${TINYBVH_COMMIT:0:7} from $TINYBVH_GIT"

harness=$work/tinybvh_rays
cpp=$root/benches/peer/tinybvh_rays.cpp
if [ ! -x "$harness" ] || [ "$cpp" -nt "$harness" ] || [ "$src/tiny_bvh.h" -nt "$harness" ]; then
    echo "compiling the harness: g++ -std=c++17 -O3 -march=native"
    g++ -std=c++17 -O3 -march=native -w -I"$src" -o "$harness" "$cpp" -lpthread
fi

# --- holocave: criterion, and the ray sets for the peer -------------------------------------
rays=$work/rays
(cd "$root" && HOLOCAVE_RAY_DUMP=$rays cargo bench -p holocave-scene --bench ray_sets -- sponza_rays) 2>&1 |
    grep -E "ray_sets bench|^sponza_rays|thrpt:" || true
if [ -n "${HOLOCAVE_NATIVE_TARGET:-}" ]; then
    (cd "$root" && CARGO_TARGET_DIR=$HOLOCAVE_NATIVE_TARGET RUSTFLAGS="-C target-cpu=native" \
        cargo bench -p holocave-scene --bench ray_sets -- 'sponza_rays.*/.*_1t') 2>&1 |
        grep -E "^sponza_rays|thrpt:" | sed 's/^/target-cpu=native: /' || true
fi
if [ ! -f "$rays/primary.rays" ]; then
    echo "no ray sets written (Sponza absent?); nothing to compare" >&2
    exit 1
fi

# --- tinybvh on the same rays ------------------------------------------------------------
peer_hq=$("$harness" "$rays" "$runs" hq)
echo "$peer_hq"
peer_plain=$("$harness" "$rays" "$runs" plain)
echo "$peer_plain" | grep -v -e '^agree' -e '^made'

# --- the tables ------------------------------------------------------------------------
PEER_HQ=$peer_hq PEER_PLAIN=$peer_plain CRITERION=$target/criterion \
    NATIVE=${HOLOCAVE_NATIVE_TARGET:+$HOLOCAVE_NATIVE_TARGET/criterion} python3 - <<'EOF'
import json, os, statistics

def peer(text, kind):
    rates = {}
    for line in text.splitlines():
        f = line.split()
        if f and f[0] == kind:
            rates[(f[1], int(f[2]))] = float(f[3])
    return rates

crit, native = os.environ["CRITERION"], os.environ.get("NATIVE")

def ours(root, group, name):
    d = os.path.join(root, group, name, "new")
    try:
        s = json.load(open(os.path.join(d, "sample.json")))
        b = json.load(open(os.path.join(d, "benchmark.json")))
    except (FileNotFoundError, TypeError):
        return None
    n = b["throughput"]["Elements"]
    per = [t / i for t, i in zip(s["times"], s["iters"])]  # ns per iteration
    return n / min(per) * 1e3, n / statistics.median(per) * 1e3  # Mrays/s: best, median

def cell(v):
    return "—" if v is None else f"{v:.2f}"

def fmt(o):
    return "—" if o is None else f"{o[0]:.2f} ({o[1]:.2f})"

for kind, group, title, cols in [
    ("rate", "sponza_rays", "Mrays/s, wall clock", ("1 core", "2 cores")),
    ("cpurate", "sponza_rays_cpu", "Mrays per CPU-second (process CPU time, both threads summed)",
     ("1 thread", "2 threads")),
]:
    hq = peer(os.environ["PEER_HQ"], kind)
    plain = peer(os.environ["PEER_PLAIN"], kind)
    print()
    print(f"{title}, Sponza; holocave: criterion's best sample (median); tinybvh: best run")
    print()
    extra = f" holocave {cols[0]}, target-cpu=native |" if native else ""
    print(f"| ray set | holocave {cols[0]} | holocave {cols[1]} | tinybvh {cols[0]} "
          f"| tinybvh {cols[1]} | holocave / tinybvh, {cols[0]} "
          f"| tinybvh {cols[0]}, plain Build |" + extra)
    print("|---|---|---|---|---|---|---|" + ("---|" if native else ""))
    for name in ["primary", "shadow", "diffuse", "primary_packets"]:
        o1, o2 = ours(crit, group, f"{name}_1t"), ours(crit, group, f"{name}_2t")
        p1, p2 = hq.get((name, 1)), hq.get((name, 2))
        ratio = f"{o1[0] / p1:.2f}" if o1 and p1 else "—"
        label = "primary, 4×4 packets (holocave only)" if name == "primary_packets" else name
        row = (f"| {label} | {fmt(o1)} | {fmt(o2)} | {cell(p1)} | {cell(p2)} | {ratio} "
               f"| {cell(plain.get((name, 1)))} |")
        if native:
            row += f" {fmt(ours(native, group, f'{name}_1t'))} |"
        print(row)

# tinybvh timed as holocave is: each ray made in the timed loop from its origin and direction.
made = peer(os.environ["PEER_HQ"], "made")
print()
print("One thread, tinybvh with each Ray made inside the timed loop (its constructor: "
      "normalised direction, inverse), Mrays per CPU-second, best run; holocave as above:")
print()
print("| ray set | holocave, 1 thread | tinybvh, Ray made in the loop | holocave / tinybvh |")
print("|---|---|---|---|")
for name in ["primary", "shadow", "diffuse"]:
    o1, p1 = ours(crit, "sponza_rays_cpu", f"{name}_1t"), made.get((name, 1))
    ratio = f"{o1[0] / p1:.2f}" if o1 and p1 else "—"
    print(f"| {name} | {fmt(o1)} | {cell(p1)} | {ratio} |")
EOF
