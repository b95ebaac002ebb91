#!/usr/bin/env bash
# A chaos campaign against `holocave sim`'s supervision, and its figures:
#
#   benches/chaos.sh [KILLS]     (default 100)
#
# Runs the suite's chaos test (tests/supervision.rs,
# `killed_nodes_and_workers_come_back_and_lose_nothing`) with KILLS SIGKILLs of sim's nodes
# and workers in its fixed pseudo-random order, on the Cornell box's CAVE at 20 Hz with two
# workers. The test checks what must hold after every kill (the process back, the walls in
# frame lock at the end, the holodeck's samples never backwards, its file clean); this
# script prints how long each kind of process took to come back: p50 and worst, from the
# kill to the wall presenting again (a node) or the new worker joined to the holodeck, and
# the share of the campaign's frames each wall presented (a run without kills presents
# every frame on every wall: `sim`'s summary, "N with every wall").
set -euo pipefail
cd "$(dirname "$0")/.."
kills=${1:-100}
log=$(mktemp)
HOLOCAVE_CHAOS_KILLS=$kills cargo test --release --test supervision \
    killed_nodes_and_workers_come_back_and_lose_nothing -- --nocapture 2>&1 | tee "$log" |
    grep -E "killed; back after|presented .* of the campaign|test result"
python3 - "$log" <<'PY'
import re, sys
times = {}
for line in open(sys.argv[1]):
    m = re.match(r"(node \w+|worker) killed; back after ([0-9.]+) s", line.strip())
    if m:
        kind = "node" if m.group(1).startswith("node") else "worker"
        times.setdefault(kind, []).append(float(m.group(2)))
for kind, t in sorted(times.items()):
    t.sort()
    print(f"{kind}: {len(t)} kills, back after p50 {t[len(t) // 2]:.2f} s, worst {t[-1]:.2f} s")
PY
rm -f "$log"
