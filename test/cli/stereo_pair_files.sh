#!/bin/bash
# A pair given as files scores as the same pair built in: the stereo benchmark
# exports Aloe at a third in Middlebury's 2014 layout (--export), reads it back
# with --middlebury and with --stereo-pair, and every matcher's figures but its
# time are the same as the built-in pair's, in both tables. And a pair smaller
# than the retina is refused.
# Usage: stereo_pair_files.sh BENCH DATA OUT
set -euo pipefail
bench=$1 data=$2 out=$3
rm -rf "$out"
mkdir -p "$out"
"$bench" --data "$data" --pair aloe_third --export "$out/pairs"
pair=$out/pairs/aloe_third
# The matchers' rows without the time (the eighth column).
rows() { grep '^| saccade\|^| OpenCV' | awk -F'|' '{ $9 = ""; print }'; }
"$bench" --data "$data" --pair aloe_third --reps 1 --cv-reps 1 | rows > "$out/builtin.txt"
"$bench" --data "$data" --no-builtin --middlebury "$pair" --reps 1 --cv-reps 1 | rows > "$out/middlebury.txt"
"$bench" --data "$data" --no-builtin --stereo-pair "$pair/im0.png,$pair/im1.png,$pair/disp0.pfm" --reps 1 \
  --cv-reps 1 | rows > "$out/files.txt"
rows_read=$(wc -l < "$out/builtin.txt")
if [ "$rows_read" -lt 6 ]; then
  echo "expected the defaults', BM's and SGBM's rows in both tables, read $rows_read rows"
  exit 1
fi
diff "$out/builtin.txt" "$out/middlebury.txt"
diff "$out/builtin.txt" "$out/files.txt"
# A pair smaller than the retina's levels is refused, naming its file, as the retina node refuses it.
tiny=$out/tiny
mkdir -p "$tiny"
for side in left right; do
  { printf 'P5\n16 12\n255\n'; head -c 192 /dev/zero | tr '\0' '\200'; } > "$tiny/$side.pgm"
done
{ printf 'Pf\n16 12\n-1\n'; head -c 768 /dev/zero; } > "$tiny/truth.pfm"
if "$bench" --no-builtin --stereo-pair "$tiny/left.pgm,$tiny/right.pgm,$tiny/truth.pfm" > "$out/tiny.txt" 2>&1; then
  echo "a 16x12 pair was scored"
  exit 1
fi
grep -q "$tiny/left.pgm: frame 16x12 is smaller than a level (32x24)" "$out/tiny.txt" || {
  cat "$out/tiny.txt"
  exit 1
}
echo "the same figures from the files as from the built-in pair ($rows_read rows)"
