#!/bin/sh
# saccade run --frames N --stats --stats-json FILE: the stats table, the JSON
# file with each node's count, and the snapshots it wrote.
# Usage: run_frames_json.sh SACCADE GRAPH OUT
set -eu
saccade=$1 graph=$2 out=$3
rm -rf "$out"
mkdir -p "$out"
"$saccade" run "$graph" --frames 20 --set snapshot.dir="$out/snapshots" --stats --stats-json "$out/stats.json"
grep -q '"name": "filters", "plugin": "filters.bank", "processed": 20,' "$out/stats.json" ||
  { echo "$out/stats.json: no filters node that processed 20 frames"; exit 1; }
[ -s "$out/snapshots/snapshot_000000_levels.png" ] || { echo "no snapshot of frame 0 in $out/snapshots"; exit 1; }
echo "the stats table, its JSON file and the snapshots"
