#!/usr/bin/env bash
# Checks the C++ lines a change touches against .clang-format (git clang-format: only changed
# lines, so the tree is never reformatted wholesale). Usage:
#   scripts/check-format.sh [BASE]   # BASE: commit to compare with (default: the merge base
#                                    # with main, else HEAD~1); uncommitted changes count too
# Exit 0 when the changed lines are formatted, 1 with the diff that would fix them.
# To fix them: git clang-format BASE
set -euo pipefail
cd "$(dirname "$0")/.."
command -v git-clang-format >/dev/null || { echo "check-format: git-clang-format not installed (apt install clang-format)"; exit 2; }
base="${1:-}"
if [ -z "$base" ]; then
  base="$(git merge-base HEAD main 2>/dev/null || true)"
  if [ -z "$base" ] || [ "$base" = "$(git rev-parse HEAD)" ]; then base="$(git rev-parse HEAD~1 2>/dev/null || git rev-parse HEAD)"; fi
fi
out="$(git clang-format --quiet --diff --extensions h,cc "$base" -- 2>&1 || true)"
if [ -z "$out" ] || [[ "$out" == "no modified files to format" ]] || [[ "$out" == *"did not modify any files"* ]]; then
  echo "check-format: changed lines since $(git rev-parse --short "$base") are formatted"
  exit 0
fi
echo "$out"
echo "check-format: the lines above differ from .clang-format; fix with: git clang-format $(git rev-parse --short "$base")"
exit 1
