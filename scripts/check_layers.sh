#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Checks the layer boundaries (docs/DESIGN.md "Layers") on a source tree and prints every crossing:
#   1. the core (src/core, src/codec and its public headers: include/osteon/{status,mesh,vec,codec}.hpp)
#      includes only itself and the C++ standard library: it builds the WebAssembly decoder;
#   2. the library (src/, include/osteon) includes nothing from the tools (tools/, cpp-httplib,
#      libmicrohttpd);
#   3. the mesh readers (src/io*) do not include the package module, which reads through them;
#   4. no product file (code, docs, scripts, benchmarks, tests) names a tracker issue: a user has
#      no tracker.
# Exit status 1 when anything crosses, 0 otherwise.
#
#   bash scripts/check_layers.sh [ROOT]      (ROOT: the checkout, default this one)
set -euo pipefail
root="${1:-$(cd "$(dirname "$0")/.." && pwd)}"
cd "$root"
failures=0
report() {
  echo "osteon: layers: $1" >&2
  failures=$((failures + 1))
}

# "file:line:include" for every #include in the given files.
includes() {
  [ "$#" -gt 0 ] || return 0
  grep -HnE '^[[:space:]]*#[[:space:]]*include' "$@" |
    sed -E 's/^([^:]*):([0-9]*):[[:space:]]*#[[:space:]]*include[[:space:]]*/\1:\2:/'
}

core_public="include/osteon/status.hpp include/osteon/mesh.hpp include/osteon/vec.hpp include/osteon/codec.hpp"
mapfile -t core_files < <(ls src/core/* src/codec/* $core_public 2>/dev/null)
mapfile -t library_files < <(find src include -type f \( -name '*.cpp' -o -name '*.hpp' \) | sort)
mapfile -t io_files < <(ls src/io*.cpp src/io*.hpp 2>/dev/null)

# 1. The core.
while IFS=: read -r file line what; do
  case "$what" in
    \<*\>)
      # The C++ standard library's headers have no '.' and no '/' in their names.
      header="${what#<}"; header="${header%>}"
      # One operating-system header, for a hint behind #if __linux__ that the WebAssembly build
      # never compiles: huge pages under the codec's large buffers.
      [ "$file:$header" = "src/core/huge_pages.cpp:sys/mman.h" ] && continue
      [[ "$header" =~ ^[a-z_0-9]+$ ]] ||
        report "$file:$line: the core includes $what, which is not the C++ standard library"
      ;;
    \"*\")
      header="${what#\"}"; header="${header%\"}"
      case "$header" in
        core/*|codec/*) [ -f "src/$header" ] || report "$file:$line: $what does not exist" ;;
        osteon/status.hpp|osteon/mesh.hpp|osteon/vec.hpp|osteon/codec.hpp) ;;
        *) report "$file:$line: the core includes $what, which is outside src/core, src/codec and their public headers" ;;
      esac
      ;;
    *) report "$file:$line: unexpected include $what" ;;
  esac
done < <(includes "${core_files[@]}")

# 2. The library includes nothing of the tools.
while IFS=: read -r file line what; do
  case "$what" in
    *httplib*|*microhttpd*|\"support/*|\"serve.hpp\"|\"progress.hpp\"|\"cli.hpp\"|*tools/*)
      report "$file:$line: the library includes $what, which belongs to the tools" ;;
  esac
done < <(includes "${library_files[@]}")

# 3. The mesh readers do not include the package module.
while IFS=: read -r file line what; do
  case "$what" in
    \"osteon/package.hpp\"|\"osteon/pack.hpp\"|\"package/*)
      report "$file:$line: a mesh reader includes $what (the package module sits above the readers)" ;;
  esac
done < <(includes "${io_files[@]}")

# 4. Tracker issue numbers in product files. Lock files and installed packages are not ours.
while IFS= read -r hit; do
  report "$hit: names a tracker issue; name the feature instead"
done < <(grep -rniE '\bissues?[ -]?#?[0-9]+\b' README.md CMakeLists.txt include src tools web docs \
           bench scripts fuzz tests \
           --exclude-dir=node_modules --exclude=package-lock.json --exclude='*.svg' \
           --exclude-dir=corpus --exclude=check_layers.sh --exclude=check_layers_test.sh 2>/dev/null || true)

if [ "$failures" -gt 0 ]; then
  echo "osteon: layers: $failures crossing(s)" >&2
  exit 1
fi
echo "osteon: layers: core ${#core_files[@]} files, library ${#library_files[@]} files: no crossing"
