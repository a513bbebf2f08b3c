#!/usr/bin/env bash
# Checks that the library dependency graph CMakeLists.txt states (the DEPS of each
# owlcal_library, and apps/CMakeLists.txt's owlcal link line) matches the #include lines:
#  - every `#include "DIR/..."` in a library folder names itself or a library it depends on
#    (directly or through others): nothing reaches past the graph;
#  - every stated edge is used by at least one include of that folder: no edge is stale.
# Run by ctest (dependency_graph); usage: scripts/check-dependency-graph.sh [SOURCE_DIR]
set -euo pipefail
root="${1:-$(cd "$(dirname "$0")/.." && pwd)}"
cd "$root"
declare -A deps
libs=()
while read -r name rest; do
  libs+=("$name")
  deps[$name]="$( (grep -o 'owlcal_[a-z_]*' <<<"$rest" || true) | sed 's/^owlcal_//' | tr '\n' ' ')"
done < <(sed -n 's/^owlcal_library(\([a-z_]*\) *DEPS\(.*\))$/\1 \2/p' CMakeLists.txt)
apps_line="$(grep -E '^target_link_libraries\(owlcal ' apps/CMakeLists.txt)"
libs+=(apps)
deps[apps]="$(grep -o 'owlcal_[a-z_]*' <<<"$apps_line" | sed 's/^owlcal_//' | tr '\n' ' ')"
[ "${#libs[@]}" -gt 2 ] || { echo "no owlcal_library lines found in $root/CMakeLists.txt"; exit 1; }

closure() {  # every library reachable from $1 (itself included)
  local -A seen=()
  local todo=("$1") x d
  while [ "${#todo[@]}" -gt 0 ]; do
    x="${todo[0]}"; todo=("${todo[@]:1}")
    [ -n "${seen[$x]:-}" ] && continue
    seen[$x]=1
    for d in ${deps[$x]:-}; do todo+=("$d"); done
  done
  echo "${!seen[@]}"
}

errors=0
for lib in "${libs[@]}"; do
  [ -d "$lib" ] || continue
  reach=" $(closure "$lib") "
  used=" "
  while IFS=: read -r file _ inc; do
    dir="${inc%%/*}"
    [ -d "$dir" ] || continue                 # not one of ours (e.g. "owlcal_version.h")
    case " ${libs[*]} " in *" $dir "*) ;; *) continue ;; esac
    used+="$dir "
    if [[ "$reach" != *" $dir "* ]]; then
      echo "$file: includes $inc, but $lib does not depend on $dir (CMakeLists.txt)"
      errors=$((errors + 1))
    fi
  done < <(grep -rnoE '^#include "[a-z_]+/[^"]+"' --include='*.h' --include='*.cc' "$lib" | sed 's/#include "\(.*\)"/\1/')
  for d in ${deps[$lib]}; do
    if [[ "$used" != *" $d "* ]]; then
      # An edge no include needs directly: fine only if another stated dependency needs it.
      echo "CMakeLists.txt: $lib depends on $d, but no file in $lib/ includes $d/"
      errors=$((errors + 1))
    fi
  done
done
if [ "$errors" -gt 0 ]; then
  echo "dependency graph: $errors mismatch(es)"
  exit 1
fi
echo "dependency graph: ${#libs[@]} libraries, every include within the stated graph, every edge used"
