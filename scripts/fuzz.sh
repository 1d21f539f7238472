#!/bin/sh
# Runs every libFuzzer harness of a fuzzing build for SECONDS each, starting
# from the committed seeds (test/fuzz/corpus/NAME) and keeping what it finds
# in BUILD/corpus/NAME. Fails at the first crash, leak, timeout or sanitizer
# report (libFuzzer writes the input as BUILD/crash-* and so on: it becomes a
# regression test), printing each harness's executions.
#   scripts/fuzz.sh BUILD_DIR [SECONDS]        (default 60; FUZZ_FLAGS adds libFuzzer flags,
#                                               e.g. -seed=1 for CI's repeatable runs)
set -eu
BUILD=$1
SECONDS_EACH=${2:-60}
# The runtimes are shared libraries (so that plugin modules link): their
# loading order is then the dynamic loader's, which ASan would refuse.
export ASAN_OPTIONS="${ASAN_OPTIONS:-}:verify_asan_link_order=0"
status=0
for fuzzer in fuzz_graph fuzz_channel fuzz_can fuzz_pattern fuzz_cli fuzz_mcap fuzz_view; do
  name=${fuzzer#fuzz_}
  mkdir -p "$BUILD/corpus/$name"
  log="$BUILD/$fuzzer.log"
  if "$BUILD/bin/$fuzzer" -max_total_time="$SECONDS_EACH" -timeout=10 -rss_limit_mb=2048 -max_len=65536 \
       -print_final_stats=1 -artifact_prefix="$BUILD/$fuzzer-" ${FUZZ_FLAGS:-} \
       "$BUILD/corpus/$name" "test/fuzz/corpus/$name" \
       > "$log" 2>&1; then
    runs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log")
    rss=$(sed -n 's/^stat::peak_rss_mb: *//p' "$log")
    echo "$fuzzer: ${runs:-?} executions in $SECONDS_EACH s, peak ${rss:-?} MB, no failure"
  else
    echo "$fuzzer: FAILED (the input is $BUILD/$fuzzer-*; the log $log):"
    grep -E "ERROR|SUMMARY|Test unit written|error while loading" "$log" | head -20
    status=1
  fi
done
exit $status
