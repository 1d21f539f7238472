#!/bin/sh
# Capture -> CAN joint command latency of the active vision loop, in one
# process (graphs/head_loop.xml) and split across two processes
# (graphs/two_pc.xml, both on this host), from the driver's timing
# gaze_capture_to_command (a request's camera frame -> the set-points that
# answer it are on the bus for every running drive) and the head's
# gaze_capture_to_taken. The fovea's margin is widened so that it asks often.
# Percentiles are the stats' (see core/src/stats.cpp for how they are taken).
#   scripts/bench-latency.sh [SECONDS] [OUT_DIR]      (default 30 s, out/bench-latency)
set -eu
SECONDS_RUN=${1:-30}
OUT=${2:-out/bench-latency}
B=${SACCADE_BIN:-build/release/bin}
mkdir -p "$OUT"
ASK="--set cameras.target_speed=1 --set fovea.margin=125 --set fovea.gaze_repeat=5"
RUN="--set driver.duration=$SECONDS_RUN --set drives.duration=$SECONDS_RUN"

echo "one process: graphs/head_loop.xml, $SECONDS_RUN s"
# shellcheck disable=SC2086
"$B/saccade" run graphs/head_loop.xml $ASK $RUN --stats-json "$OUT/one_process.json" > "$OUT/one_process.log" 2>&1

echo "two processes: graphs/two_pc.xml, $SECONDS_RUN s"
# shellcheck disable=SC2086
"$B/saccade" run graphs/two_pc.xml --process robot_pc $RUN --stats-json "$OUT/robot_pc.json" \
  > "$OUT/robot_pc.log" 2>&1 &
ROBOT=$!
# shellcheck disable=SC2086
"$B/saccade" run graphs/two_pc.xml --process head_pc $ASK --stats-json "$OUT/head_pc.json" \
  > "$OUT/head_pc.log" 2>&1 || true
wait "$ROBOT"

python3 scripts/latency-figures.py "$OUT/one_process.json" "$OUT/robot_pc.json" | tee "$OUT/figures.md"
