#!/usr/bin/env bash
# The whole test suite under AddressSanitizer + UndefinedBehaviorSanitizer.
#   bash scripts/sanitize.sh [CTEST ARGS...]     e.g. bash scripts/sanitize.sh -R robot_
#   OWLCAL_SANITIZE_TARGETS="io_tests robot_tests" bash scripts/sanitize.sh -E NOT_BUILT
# Builds in build-asan/ (GCC by default; CXX=clang++ to use clang) with
# -fsanitize=address,undefined -fno-sanitize-recover=undefined -fno-omit-frame-pointer and line
# tables only (-g1: stack traces keep file:line, compiling and linking are much faster), -O1 and
# -DNDEBUG as in the release build (build type "Sanitize": no other flags), without the
# benchmarks, then runs ctest there. Any sanitizer report fails the test that triggered it.
# A full build from cold takes about twice as long as the normal one; it runs at nice 10.
set -euo pipefail
cd "$(dirname "$0")/.."
build=build-asan
# EIGEN_MALLOC_ALREADY_ALIGNED=1: Eigen turns its own over-aligned malloc on under ASan
# (__SANITIZE_ADDRESS__), while Debian's libceres.a was built without ASan and uses plain malloc;
# the linker keeps one copy of each Eigen template, so a matrix allocated by one was freed by the
# other ("attempting free on address which was not malloc()-ed" in Ceres' covariance SVD). Both
# sides then agree: glibc's and ASan's malloc return 16-byte aligned blocks on x86-64.
flags="-fsanitize=address,undefined -fno-sanitize-recover=undefined -fno-omit-frame-pointer -g1 -O1 -DNDEBUG"
flags+=" -DEIGEN_MALLOC_ALREADY_ALIGNED=1"
cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=Sanitize -DOWLCAL_BENCH=OFF \
  -DCMAKE_CXX_FLAGS="$flags" -DCMAKE_EXE_LINKER_FLAGS="-fsanitize=address,undefined" >/dev/null
# OWLCAL_SANITIZE_TARGETS="io_tests robot_tests": build only those (then pass -E NOT_BUILT to ctest).
# shellcheck disable=SC2086
nice -n 10 cmake --build "$build" -j2 ${OWLCAL_SANITIZE_TARGETS:+--target $OWLCAL_SANITIZE_TARGETS}
export ASAN_OPTIONS=detect_leaks=1:abort_on_error=1:strict_string_checks=1
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
nice -n 10 ctest --test-dir "$build" --output-on-failure -j2 "$@"
