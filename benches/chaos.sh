#!/usr/bin/env bash
# Chaos campaigns against the cluster's supervision, and their figures:
#
#   benches/chaos.sh [KILLS]     (default 100)
#
# Runs the suite's two chaos tests with KILLS SIGKILLs each, in their fixed pseudo-random
# orders: `holocave sim`'s nodes and workers (tests/supervision.rs,
# `killed_nodes_and_workers_come_back_and_lose_nothing`: the Cornell box's CAVE at 20 Hz,
# two workers), and a cluster of separate processes under `holocave supervise`, the master
# hosting the holodeck among the killed (tests/cluster_chaos.rs). The tests check what
# must hold after every kill; this script prints how long each kind of process took to come
# back, p50 and worst: from the kill to the wall presenting again (a node), the new worker
# joined to the holodeck (a worker), or every wall presenting a frame after the last the
# killed master kept (the master: its supervisor's restart and the resume included); and
# the share of `sim`'s campaign frames each wall presented (a run without kills presents
# every frame on every wall: `sim`'s summary, "N with every wall").
set -euo pipefail
cd "$(dirname "$0")/.."
kills=${1:-100}
log=$(mktemp)
for test in "supervision killed_nodes_and_workers_come_back_and_lose_nothing" \
    "cluster_chaos a_supervised_cluster_heals_from_random_kills_of_every_process"; do
    set -- $test
    echo "== $1" | tee -a "$log"
    HOLOCAVE_CHAOS_KILLS=$kills cargo test --release --test "$1" "$2" -- --nocapture 2>&1 |
        tee -a "$log" | grep -E "presented .* of the campaign|stored samples|test result"
done
python3 - "$log" <<'PY'
import re, sys
times = {}
for line in open(sys.argv[1]):
    if line.startswith("== "):
        campaign = line[3:].strip()
    m = re.match(r"(node \w+|worker|master) killed; back after ([0-9.]+) s", line.strip())
    if m:
        kind = (campaign, m.group(1).split()[0])
        times.setdefault(kind, []).append(float(m.group(2)))
for (campaign, kind), t in sorted(times.items()):
    t.sort()
    print(f"{campaign}: {kind}: {len(t)} kills, back after p50 {t[len(t) // 2]:.2f} s, worst {t[-1]:.2f} s")
PY
rm -f "$log"
