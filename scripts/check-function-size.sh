#!/usr/bin/env bash
# No function over 80 lines in the project's own code (core/, plugins/, apps/):
# clang-tidy's readability-function-size with LineThreshold 80 (lines from a
# body's opening brace to its closing one) over every source file of a build's
# compile_commands.json and the headers they include.
#   scripts/check-function-size.sh [BUILD_DIR]      (default build/release)
# JOBS (default 2) clang-tidy processes run at once. Exit status 0 when nothing
# is over, 1 with each function over listed, 2 when it cannot run.
#
# Not checked: generated code (under the build folder: the DDS types, the
# view's page), test/ (the rule is for the shipped code first;
# FUNCTION_SIZE_DIRS="core plugins apps test" checks it too), and these SIMD
# kernels, whose loops are kept whole so the compiler keeps their vectors in
# registers across them:
exempt=(
  plugins/stereo/ncc.cpp   # AVX2 / AVX-512 NCC sweeps and picks (intrinsics, vector extensions)
)
# Functions over 80 lines allowed for now, file:function (none: every
# function of core/, plugins/ and apps/ is within the rule). An entry is
# reported once it no longer needs to be here.
pending=()
set -euo pipefail

root=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-$root/build/release}
[[ $build = /* ]] || build=$root/$build
dirs=${FUNCTION_SIZE_DIRS:-core plugins apps}
jobs=${JOBS:-2}

tidy=$(command -v clang-tidy || command -v clang-tidy-14 || true)
if [ -z "$tidy" ]; then
  echo "check-function-size: clang-tidy not found (Debian package clang-tidy; scripts/install-deps.sh installs it)" >&2
  exit 2
fi
if [ ! -f "$build/compile_commands.json" ]; then
  echo "check-function-size: no $build/compile_commands.json (configure first: cmake --preset release)" >&2
  exit 2
fi

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
# GCC's flags clang does not know would stop clang-tidy at the command line.
sed -e 's/ -fno-gnu-unique//g' "$build/compile_commands.json" > "$work/compile_commands.json"

dir_pattern=$(echo "$dirs" | tr ' ' '|')
exempt_pattern=$(printf '%s|' "${exempt[@]}")
exempt_pattern=${exempt_pattern%|}
python3 - "$work/compile_commands.json" "$root" > "$work/sources" <<'EOF'
import json, os, sys
root = sys.argv[2]
for entry in json.load(open(sys.argv[1])):
    path = os.path.normpath(os.path.join(entry["directory"], entry["file"]))
    if path.startswith(root + "/") and not path.startswith(root + "/build/"):
        print(os.path.relpath(path, root))
EOF
{ grep -E "^($dir_pattern)/" "$work/sources" || true; } | { grep -vxE "$exempt_pattern" || true; } | sort -u > "$work/files"
if [ ! -s "$work/files" ]; then
  echo "check-function-size: no source files of $dirs in $build/compile_commands.json" >&2
  exit 2
fi

# __SANITIZE_THREAD__: SACCADE_AVX2_CLONE (saccade/simd.hpp) without GCC's
# target_clones, which clang refuses beside `aligned`; it changes no length.
# -Wno-error, -Wno-unknown-warning-option: the database holds GCC's flags; a
# warnings-as-errors build (the ci and sanitizer presets) would make every
# GCC-only -Wno-... and every clang-only warning an error that stops the parse.
config='{Checks: "-*,readability-function-size", CheckOptions: [{key: readability-function-size.LineThreshold, value: 80}]}'
cd "$root"
set +e
xargs -P "$jobs" -n 4 "$tidy" -p "$work" --quiet --config="$config" --extra-arg=-D__SANITIZE_THREAD__ \
  --extra-arg=-Wno-error --extra-arg=-Wno-unknown-warning-option \
  --header-filter="^$root/($dir_pattern)/" < "$work/files" > "$work/out" 2> "$work/err"
status=$?
set -e
if grep -q "Error while processing" "$work/err"; then
  grep -E "error:|Error while processing" "$work/out" "$work/err" >&2 || true
  echo "check-function-size: clang-tidy could not parse every file" >&2
  exit 2
fi
if [ "$status" -ne 0 ] && [ "$status" -ne 123 ]; then
  cat "$work/err" >&2
  exit 2
fi

# "file:line:col: warning: function 'name' exceeds ..." then "...: note: N lines ..."
awk -v root="$root/" '
  / warning: function .* \[readability-function-size\]/ {
    split($1, at, ":"); file = at[1]; sub("^" root, "", file)
    name = $0; sub(/^[^\x27]*\x27/, "", name); sub(/\x27.*/, "", name)
    where = file ":" at[2]; next
  }
  where != "" && / note: [0-9]+ lines / {
    n = $0; sub(/.* note: /, "", n); sub(/ .*/, "", n)
    print where "\t" name "\t" n; where = ""
  }' "$work/out" | sort -u > "$work/long"

over=0
while IFS=$'\t' read -r where name lines; do
  file=${where%%:*}
  if printf '%s\n' "${pending[@]}" | grep -qxF "$file:$name"; then
    echo "pending: $where $name: $lines lines"
  else
    echo "over 80 lines: $where $name: $lines lines"
    over=1
  fi
done < "$work/long"
for p in "${pending[@]}"; do
  if ! awk -F'\t' '{ split($1, a, ":"); print a[1] ":" $2 }' "$work/long" | grep -qxF "$p"; then
    echo "check-function-size: $p is no longer over 80 lines: remove it from the pending list"
  fi
done
count=$(wc -l < "$work/files")
if [ "$over" -ne 0 ]; then
  echo "check-function-size: functions over 80 lines (split them into named steps; docs/architecture.md, conventions)"
  exit 1
fi
echo "check-function-size: $count files of $dirs, nothing over 80 lines outside the pending list"
