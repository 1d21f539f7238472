#!/bin/bash
# A sequence written as an OTB folder scores as the generated one: the tracking
# benchmark exports out_of_view's first 160 frames (--export; the camera looks
# away at frames 75-123), reads them back with --otb, and every tracker's
# figures but its time are the same, hidden frames and re-acquisition too.
# Usage: track_sequence_files.sh BENCH DATA OUT
set -euo pipefail
bench=$1 data=$2 out=$3
rm -rf "$out"
mkdir -p "$out"
"$bench" --data "$data" --sequences out_of_view --frames 160 --export "$out/sequences"
# The trackers' rows without the time (the last column).
rows() { grep '^| fovea\|^| kcf' | awk -F'|' '{ $(NF - 1) = ""; print }'; }
"$bench" --data "$data" --sequences out_of_view --frames 160 --trackers fovea,kcf | rows > "$out/generated.txt"
"$bench" --data "$data" --no-generated --otb "$out/sequences/out_of_view" --trackers fovea,kcf | rows > "$out/read.txt"
rows_read=$(wc -l < "$out/generated.txt")
if [ "$rows_read" -lt 4 ]; then
  echo "expected the fovea's and KCF's rows in the sequence's table and the average, read $rows_read rows"
  exit 1
fi
diff "$out/generated.txt" "$out/read.txt"
echo "the same figures from the OTB folder as from the generated sequence ($rows_read rows)"
