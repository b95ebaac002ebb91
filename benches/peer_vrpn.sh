#!/usr/bin/env bash
# Navigation against a real VRPN server (a peer built from its public source, never part of
# the project): does `holocave master` move the world only while the grab button is held?
#
#   benches/peer_vrpn.sh VRPN_SOURCE_DIR [SECONDS]
#
# 1. VRPN (github.com/vrpn/vrpn) is built from VRPN_SOURCE_DIR into target/peer/vrpn
#    (`cmake`, then `make vrpn_server`) unless that build has it already.
# 2. vrpn_server runs on loopback with a spinning tracker as the wand (0.1 turns/s about +Y,
#    sensor 1 of Wand0) and the example button box (Buttons0: its buttons toggle every 2 s).
# 3. `holocave master --wand … --buttons …` runs SECONDS (default 10) with the room's CAVE and
#    writes navigation.csv; benches/peer/navigation_runs.py cuts it into runs where the world
#    turns and where it stands still, for comparison with the master's log of the button 0
#    (grab) presses and releases.
# Needs cmake, a C++ compiler, python3 and a release build of holocave.
set -euo pipefail

root=$(cd "$(dirname "$0")/.." && pwd)
src=${1:?VRPN source folder}
seconds=${2:-10}
build="$root/target/peer/vrpn"
server="$build/server_src/vrpn_server"
if [ ! -x "$server" ]; then
    cmake -S "$src" -B "$build" -DCMAKE_BUILD_TYPE=Release -DVRPN_BUILD_JAVA=OFF -DVRPN_BUILD_PYTHON=OFF >/dev/null
    make -C "$build" -j"$(nproc)" vrpn_server >/dev/null
fi
out="$root/target/peer/vrpn-run"
rm -rf "$out" && mkdir -p "$out"
printf 'vrpn_Tracker_Spin\tWand0\t2\t60.0\t0.0 1.0 0.0\t0.1\nvrpn_Button_Example\tButtons0\t2\t0.5\n' > "$out/vrpn.cfg"
"$server" -f "$out/vrpn.cfg" -millisleep 1 >"$out/server.log" 2>&1 &
server_pid=$!
trap 'kill $server_pid 2>/dev/null' EXIT
sleep 1
cd "$root"
HOLOCAVE_SECRET=peer-vrpn RUST_LOG=info target/release/holocave master --config configs/cave4-room.toml \
    --listen 127.0.0.1:0 --wand 'vrpn://Wand0@127.0.0.1:3883#1' --buttons vrpn://Buttons0@127.0.0.1:3883 \
    --seconds "$seconds" --out "$out" 2>&1 | grep -E "button 0 (held|released)" | sed 's/.*navigation at/navigation at/'
python3 benches/peer/navigation_runs.py "$out/navigation.csv"
