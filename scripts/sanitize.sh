#!/usr/bin/env bash
# The whole test suite under AddressSanitizer + UndefinedBehaviorSanitizer (issue 15, item 6).
#   bash scripts/sanitize.sh [CTEST ARGS...]     e.g. bash scripts/sanitize.sh -R robot_
# Builds in build-asan/ (GCC by default; CXX=clang++ to use clang) with
# -fsanitize=address,undefined -fno-sanitize-recover=undefined -fno-omit-frame-pointer, then runs
# ctest there. Any sanitizer report fails the test that triggered it. A full build from cold
# takes about twice as long as the normal one; run it at nice 10 on a shared machine.
set -euo pipefail
cd "$(dirname "$0")/.."
build=build-asan
flags="-fsanitize=address,undefined -fno-sanitize-recover=undefined -fno-omit-frame-pointer -g -O1"
cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCMAKE_CXX_FLAGS="$flags" -DCMAKE_EXE_LINKER_FLAGS="-fsanitize=address,undefined" >/dev/null
nice -n 10 cmake --build "$build" -j2
export ASAN_OPTIONS=detect_leaks=1:abort_on_error=1:strict_string_checks=1
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
nice -n 10 ctest --test-dir "$build" --output-on-failure -j2 "$@"
