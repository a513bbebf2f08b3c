#!/usr/bin/env bash
# Fuzzes every libFuzzer target of fuzz/ for SECONDS each (default 600), one after another.
#   bash scripts/fuzz.sh [SECONDS] [TARGET...]     e.g. bash scripts/fuzz.sh 60 protocol_fuzz
# Builds them with clang in build-fuzz/ (-DOWLCAL_FUZZ=ON; Debian's clang package), seeds each
# from tests/fuzz/corpus/NAME (the committed seeds are never written to: new inputs go to
# build-fuzz/corpus/NAME), runs at nice 10, and prints one line per target: executions, new
# corpus size and crashes. A crash leaves build-fuzz/artifacts/NAME/crash-*: turn it into a
# regression test, then fix. Exit status 1 if any target crashed.
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-600}
shift || true
build=build-fuzz
cmake -S . -B "$build" -DOWLCAL_FUZZ=ON -DCMAKE_CXX_COMPILER=clang++ -DCMAKE_BUILD_TYPE=RelWithDebInfo >/dev/null
targets=("$@")
if [ ${#targets[@]} -eq 0 ]; then
  for f in fuzz/*_fuzz.cc; do targets+=("$(basename "$f" .cc)"); done
fi
nice -n 10 cmake --build "$build" -j2 --target "${targets[@]}"
status=0
for t in "${targets[@]}"; do
  name=${t%_fuzz}
  mkdir -p "$build/corpus/$name" "$build/artifacts/$name"
  log="$build/$t.log"
  set +e
  nice -n 10 "$build/fuzz/$t" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 -max_len=262144 \
    -artifact_prefix="$build/artifacts/$name/" -print_final_stats=1 \
    "$build/corpus/$name" "tests/fuzz/corpus/$name" >"$log" 2>&1
  rc=$?
  set -e
  runs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | grep -o '[0-9]*$' || echo "?")
  crashes=$(find "$build/artifacts/$name" -name 'crash-*' -o -name 'leak-*' -o -name 'timeout-*' -o -name 'oom-*' | wc -l)
  echo "$t: ${seconds} s, ${runs} runs, corpus $(ls "$build/corpus/$name" | wc -l) new inputs, ${crashes} findings, exit ${rc} (log $log)"
  if [ "$rc" -ne 0 ] || [ "$crashes" -gt 0 ]; then status=1; fi
done
exit $status
