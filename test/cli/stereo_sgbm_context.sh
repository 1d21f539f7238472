#!/bin/bash
# --sgbm-context: StereoSGBM run on each fovea's neighbourhood alone. With a
# neighbourhood larger than the image it is the whole-image SGBM, and its
# fovea figures must be the same to the last digit; with the fovea alone
# (margin 0) SGBM loses the context it owes its accuracy to (Aloe at a third:
# fovea bad-2 0.204 against 0.064, docs/accuracy.md).
# Usage: stereo_sgbm_context.sh BENCH DATA
set -euo pipefail
bench=$1 data=$2
table=$("$bench" --data "$data" --pair aloe_third --reps 1 --cv-reps 1 --sgbm-context 0,1000)
# A row's fovea density, bad-1 and bad-2 (columns 3-5 between the bars).
fovea() { grep -F "| $1 |" <<< "$table" | head -1 | awk -F'|' '{ print $3 $4 $5 }'; }
whole=$(fovea "OpenCV StereoSGBM (5x5)")
wide=$(fovea "OpenCV StereoSGBM, the fovea +-1000 px, the pair's range")
alone=$(fovea "OpenCV StereoSGBM, the fovea +-0 px, the pair's range")
echo "fovea density, bad-1, bad-2: whole image [$whole], a neighbourhood wider than it [$wide], the fovea alone [$alone]"
[ -n "$whole" ] && [ "$whole" = "$wide" ] || { echo "the neighbourhood wider than the image must score as the whole image"; exit 1; }
bad2() { awk '{ print $3 }' <<< "$1"; }
awk -v a="$(bad2 "$alone")" -v w="$(bad2 "$whole")" 'BEGIN { exit !(a > 2 * w) }' ||
  { echo "SGBM on the fovea alone should be far worse than on the whole image"; exit 1; }
echo "a neighbourhood wider than the image scores as the whole image; the fovea alone far worse"
