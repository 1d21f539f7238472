#!/usr/bin/env bash
# Every C++ file git tracks is laid out as .clang-format says (Debian 12's
# clang-format 14, which scripts/install-deps.sh installs).
#   scripts/check-format.sh          check: lists each file off and exits 1
#   scripts/check-format.sh --fix    rewrite the files in place
# Exit status 2 when it cannot run (no clang-format, not a git checkout).
set -euo pipefail

root=$(cd "$(dirname "$0")/.." && pwd)
format=$(command -v clang-format || command -v clang-format-14 || true)
if [[ -z $format ]]; then
  echo "check-format: clang-format not found (scripts/install-deps.sh installs it)" >&2
  exit 2
fi
cd "$root"
if ! files=$(git ls-files -- '*.cpp' '*.hpp' '*.h' '*.cc' 2>/dev/null) || [[ -z $files ]]; then
  echo "check-format: no C++ files listed by git in $root (not a git checkout?)" >&2
  exit 2
fi
if [[ ${1:-} == --fix ]]; then
  xargs "$format" -i --style=file <<<"$files"
  exit 0
fi
off=()
while IFS= read -r file; do
  "$format" --style=file --dry-run --Werror "$file" >/dev/null 2>&1 || off+=("$file")
done <<<"$files"
if ((${#off[@]})); then
  echo "check-format: ${#off[@]} file(s) not laid out as .clang-format says:" >&2
  printf '  %s\n' "${off[@]}" >&2
  echo "fix with: scripts/check-format.sh --fix (or clang-format -i FILE)" >&2
  exit 1
fi
echo "check-format: $(wc -l <<<"$files") files as .clang-format says"
