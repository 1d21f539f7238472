#!/usr/bin/env bash
# Installs the npm packages some tests use as real clients (test time only:
# nothing at build or run time needs them): for every folder under test/ with
# a package.json and package-lock.json, `npm ci` into BUILD_DIR/npm/<folder>.
# Idempotent: a folder whose lock file is unchanged since its last install is
# skipped. Without node and npm it says so and installs nothing (the tests that
# need them then fail, naming what is missing; scripts/install-deps.sh
# installs node and npm).
#   scripts/install-test-npm.sh [BUILD_DIR]   (default build/release)
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build/release}

if ! command -v node >/dev/null || ! command -v npm >/dev/null; then
  echo "install-test-npm: node or npm missing: the npm test clients are not installed"
  exit 0
fi

for lock in test/*/package-lock.json; do
  [ -e "$lock" ] || continue
  src=$(dirname "$lock")
  name=$(basename "$src")
  dest="$build/npm/$name"
  if [ -d "$dest/node_modules" ] && cmp -s "$lock" "$dest/package-lock.json" && cmp -s "$src/package.json" "$dest/package.json"; then
    continue
  fi
  echo "install-test-npm: $name (npm ci in $dest)"
  mkdir -p "$dest"
  cp "$src/package.json" "$lock" "$dest/"
  (cd "$dest" && npm ci --no-audit --no-fund --loglevel=error)
done
