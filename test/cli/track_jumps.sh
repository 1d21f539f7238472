#!/bin/bash
# --jumps: a line per jump, with whether it was right and how much of the
# first box's tones the box it jumped to has. fresh2_out_of_view in gray,
# the tones not asked (--set box_min_shared_tones=0): while the target is
# away (frames 75-123 of the script) the fovea tracker takes background at
# frame 98; that find is wrong, and its tones are not the target's.
# Usage: track_jumps.sh BENCH DATA OUT
set -euo pipefail
bench=$1 data=$2 out=$3
rm -rf "$out"
mkdir -p "$out"
"$bench" --data "$data" --no-generated --fresh 2 --gray --sequences fresh2_out_of_view --frames 110 \
  --trackers fovea --set box_min_shared_tones=0 --jumps "$out/jumps.csv" > "$out/table.md"
head -1 "$out/jumps.csv" | grep -q '^sequence,run,tracker,frame,.*,right,tones_shared,colours_shared$' ||
  { echo "no header in $out/jumps.csv"; exit 1; }
counted=$(tail -n +2 "$out/jumps.csv" | wc -l)
line=$(grep '^fresh2_out_of_view@gray,0,fovea,98,' "$out/jumps.csv") ||
  { echo "no jump at frame 98 in:"; cat "$out/jumps.csv"; exit 1; }
right=$(echo "$line" | cut -d, -f15) tones=$(echo "$line" | cut -d, -f16) colours=$(echo "$line" | cut -d, -f17)
[ "$right" = 0 ] || { echo "the jump at frame 98 is not wrong: $line"; exit 1; }
awk -v t="$tones" 'BEGIN { exit !(t < 0.3) }' || { echo "the background's tones shared $tones"; exit 1; }
[ -z "$colours" ] || { echo "a gray target's colours were scored: $line"; exit 1; }
echo "a wrong jump at frame 98 sharing $tones of the target's tones ($counted jumps)"
