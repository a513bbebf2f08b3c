#!/usr/bin/env bash
# Checks every tracked C++ file (*.h, *.cc) against .clang-format; the tree was formatted once, so
# any difference is a change that was not formatted. Usage:
#   scripts/check-format.sh [--fix]   # --fix: rewrite the differing files in place
# Exit 0 when every file is formatted, 1 naming the files that are not (and how to fix them),
# 2 when clang-format is missing. Runs as the ctest test `format` (label unit).
set -euo pipefail
cd "$(dirname "$0")/.."
command -v clang-format >/dev/null || { echo "check-format: clang-format not installed (apt install clang-format)"; exit 2; }
fix=0
[ "${1:-}" = "--fix" ] && fix=1
mapfile -t files < <(git ls-files '*.h' '*.cc' 2>/dev/null || find . -path ./build -prune -o \( -name '*.h' -o -name '*.cc' \) -print)
existing=()
for f in "${files[@]}"; do [ -f "$f" ] && existing+=("$f"); done
# One clang-format process for the whole tree: --dry-run -Werror names each file:line that differs.
bad=()
if [ ${#existing[@]} -gt 0 ]; then
  mapfile -t bad < <(clang-format --style=file --dry-run -Werror "${existing[@]}" 2>&1 >/dev/null |
                     sed -n 's/^\([^:]*\):[0-9]*:[0-9]*: error: .*/\1/p' | sort -u)
fi
[ "$fix" = 1 ] && [ ${#bad[@]} -gt 0 ] && clang-format --style=file -i "${bad[@]}"
if [ ${#bad[@]} -eq 0 ]; then
  echo "check-format: every C++ file matches .clang-format"
  exit 0
fi
if [ "$fix" = 1 ]; then echo "check-format: reformatted ${#bad[@]} file(s): ${bad[*]}"; exit 0; fi
printf 'check-format: not formatted: %s\n' "${bad[@]}"
echo "check-format: ${#bad[@]} file(s) differ from .clang-format; fix with: scripts/check-format.sh --fix"
exit 1
