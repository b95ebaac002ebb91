#!/usr/bin/env bash
# holocave's path tracer against Mitsuba 3 (llvm_ad_rgb, `path`), side by side, on the same
# machine and cores, at equal samples per pixel, on scenes whose materials map exactly
# (../shared/tools/mitsuba/README.md): the Cornell box without its glass sphere (Lambert
# walls, a perfect-mirror box, an area light) and Khronos' EmissiveStrengthTest (a
# textured backdrop before five emissive cubes) with its materials made Lambertian
# (`KHR_materials_specular` factor 0: as shipped they are rough dielectrics, which Mitsuba
# maps to its Disney `principled`, a different BSDF).
#
#   benches/vs_mitsuba.sh                 # SPP=512 REF_SPP=2048 OUT=target/vs_mitsuba
#
# For each scene: one converged reference (the mean of a holocave and a Mitsuba render at
# REF_SPP, different seeds; cached in OUT/refs), then each renderer at SPP, timed as a
# whole process (scene import, BVH build and Mitsuba's JIT included) and scored by relative
# MSE of luminance against the reference. Efficiency = 1 / (relMSE · seconds); the ratio is
# holocave's over Mitsuba's. Not part of `cargo test`.
set -euo pipefail

ROOT=$(cd "$(dirname "$0")/.." && pwd)
SHARED=${SHARED:-$ROOT/../shared}
MITSUBA=$SHARED/tools/mitsuba
OUT=${OUT:-$ROOT/target/vs_mitsuba}
SPP=${SPP:-512}
REF_SPP=${REF_SPP:-2048}
mkdir -p "$OUT/refs" "$OUT/runs"

cd "$ROOT"
cargo build --release --quiet --bin holocave
HOLOCAVE=$ROOT/target/release/holocave

# Mitsuba 3 and an LLVM it can JIT with (drjit 1.5 needs libLLVM >= 17; without one
# reference.py falls back to the much slower scalar variant, and this says so).
python3 -c 'import mitsuba' 2>/dev/null || pip install --quiet mitsuba numpy
if ! ls /usr/lib/*/libLLVM*.so.1[7-9]* /usr/lib/*/libLLVM*.so.2[0-9]* >/dev/null 2>&1; then
    if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null; then
        apt-get install -y -qq libllvm19 >/dev/null 2>&1 ||
            { apt-get update -qq >/dev/null && apt-get install -y -qq libllvm19 >/dev/null; }
    else
        echo "warning: no libLLVM >= 17: Mitsuba runs its scalar variant (not the one to beat)" >&2
    fi
fi

# The scenes, written to OUT/scenes: the generated Cornell box without its glass sphere,
# and the Khronos scene with Lambertian materials (its buffers and images read in place).
"$HOLOCAVE" scene generate --out "$OUT/scenes" >/dev/null
python3 - "$OUT/scenes" "$SHARED/scenes/khronos/EmissiveStrengthTest/EmissiveStrengthTest.gltf" <<'EOF'
import json, os, sys
d, khronos = sys.argv[1], sys.argv[2]
g = json.load(open(f"{d}/cornell.gltf"))
glass = [i for i, n in enumerate(g["nodes"]) if n.get("name") == "glass sphere"]
for s in g["scenes"]:
    s["nodes"] = [i for i in s["nodes"] if i not in glass]
json.dump(g, open(f"{d}/cornell_noglass.gltf", "w"))
json.dump({"eye": [0.0, 1.0, 3.4],
           "screen": {"pa": [-1, 0, 1], "pb": [1, 0, 1], "pc": [-1, 2, 1]},
           "width": 256, "height": 256}, open(f"{d}/cornell_noglass.json", "w"))
g = json.load(open(khronos))
for m in g["materials"]:
    m.setdefault("extensions", {})["KHR_materials_specular"] = {"specularFactor": 0.0}
g["extensionsUsed"] = sorted(set(g.get("extensionsUsed", [])) | {"KHR_materials_specular"})
for item in g.get("buffers", []) + g.get("images", []):
    if "uri" in item and not item["uri"].startswith("data:"):
        item["uri"] = os.path.join(os.path.dirname(khronos), item["uri"])
json.dump(g, open(f"{d}/emissive_lambert.gltf", "w"))
EOF

# name | glTF | camera JSON
SCENES=(
    "cornell-noglass|$OUT/scenes/cornell_noglass.gltf|$OUT/scenes/cornell_noglass.json"
    "emissive-lambert|$OUT/scenes/emissive_lambert.gltf|$MITSUBA/emissive_strength.json"
)

# The camera JSON as holocave's flags: --eye X,Y,Z --screen "PA;PB;PC" --size WxH.
camera_flags() {
    python3 - "$1" <<'EOF'
import json, sys
c = json.load(open(sys.argv[1]))
s = c.get("screen", c)
v = lambda p: ",".join(repr(float(x)) for x in p)
print(f'--eye={v(c["eye"])}')
print(f'--screen={v(s["pa"])};{v(s["pb"])};{v(s["pc"])}')
print(f'--size={c["width"]}x{c["height"]}')
EOF
}

# Wall-clock seconds of a whole command.
timed() {
    local t0 t1
    t0=$(date +%s.%N)
    "$@" >/dev/null 2>&1
    t1=$(date +%s.%N)
    python3 -c "print(f'{$t1 - $t0:.2f}')"
}

holocave_render() { # gltf camera spp seed out.exr
    mapfile -t flags < <(camera_flags "$2")
    "$HOLOCAVE" render --scene "$1" "${flags[@]}" --spp "$3" --seed "$4" --out "$5"
}
mitsuba_render() { # gltf camera spp seed out.exr
    python3 "$MITSUBA/reference.py" "$1" "$2" "$5" --spp "$3" --seed "$4"
}

RESULTS=$OUT/results.tsv
: >"$RESULTS"
for entry in "${SCENES[@]}"; do
    IFS='|' read -r name gltf camera <<<"$entry"
    ref=$OUT/refs/$name-$REF_SPP.exr
    if [ ! -f "$ref" ]; then
        echo "$name: reference, $REF_SPP spp with each renderer (cached in $OUT/refs)" >&2
        holocave_render "$gltf" "$camera" "$REF_SPP" 1001 "$OUT/refs/$name-holocave.exr" >/dev/null 2>&1
        mitsuba_render "$gltf" "$camera" "$REF_SPP" 1002 "$OUT/refs/$name-mitsuba.exr" >/dev/null 2>&1
        python3 "$MITSUBA/compare.py" "$OUT/refs/$name-holocave.exr" "$OUT/refs/$name-mitsuba.exr" \
            --avg "$ref" --json "$OUT/refs/$name-$REF_SPP.json" >/dev/null
    fi
    for renderer in holocave mitsuba; do
        exr=$OUT/runs/$name-$renderer-$SPP.exr
        echo "$name: $renderer, $SPP spp" >&2
        secs=$(timed "${renderer}_render" "$gltf" "$camera" "$SPP" 1 "$exr")
        python3 "$MITSUBA/compare.py" "$exr" "$ref" --json "$exr.json" >/dev/null
        printf '%s\t%s\t%s\t%s\t%s\t%s\n' "$name" "$renderer" "$SPP" "$secs" "$exr.json" "$camera" >>"$RESULTS"
    done
done

python3 - "$RESULTS" "$OUT/refs" "$REF_SPP" <<'EOF'
import json, sys
rows = [l.rstrip("\n").split("\t") for l in open(sys.argv[1]) if l.strip()]
print(f"\n{'scene':18} {'renderer':9} {'spp':>5} {'time s':>7} {'M paths/s':>9} "
      f"{'relMSE':>9} {'efficiency':>10} {'ratio':>6}")
eff = {}
for name, renderer, spp, secs, stats, camera in rows:
    c = json.load(open(camera))
    paths = c["width"] * c["height"] * int(spp)
    rel = json.load(open(stats))["relmse_luminance"]
    e = 1.0 / (rel * float(secs))
    eff[(name, renderer)] = e
    ratio = f"{eff[(name, 'holocave')] / e:.2f}" if renderer == "mitsuba" else ""
    print(f"{name:18} {renderer:9} {spp:>5} {float(secs):7.2f} {paths / float(secs) / 1e6:9.2f} "
          f"{rel:9.5f} {e:10.1f} {ratio:>6}")
for name in dict.fromkeys(r[0] for r in rows):
    floor = json.load(open(f"{sys.argv[2]}/{name}-{sys.argv[3]}.json"))["relmse_luminance"]
    print(f"{name}: the two {sys.argv[3]}-spp references differ by relMSE {floor:.5f} "
          f"(their mean, the reference, has about a quarter of that as noise)")
print("ratio = holocave efficiency / Mitsuba efficiency (>= 1: holocave is ahead)")
EOF
