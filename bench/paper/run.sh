#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Redoes the evaluation of Zhou, Jia & Su 2018 (Table 1, Fig. 9, 10, 11) on the real meshes and
# rewrites docs/PAPER.md and docs/paper/*.svg. See bench/README.md, section "paper".
#
#   bash bench/paper/run.sh [--quick] [--no-build] [--only table1,fig9,fig10,fig11]
#
#   --quick     fewer meshes and bit depths, no CGAL peer, fewer browser runs (about 3 minutes)
#   --no-build  use the builds as they are (build-bench/, build/wasm/, build/viewer/)
#   --only      measure these items only (the page is rendered from every results file there is)
#
# Needs: Debian 12 with cmake, ninja, g++, node/npm, emscripten (the WebAssembly decoder),
# draco (draco_encoder / draco_decoder, the Fig. 9 and Table 1 peer), chromium (Table 1's browser),
# libcgal-dev (optional: the CGAL peer of Fig. 10). Nothing is downloaded but npm packages pinned
# in bench/ and web/package-lock.json; Playwright's browser download is switched off.
set -euo pipefail
root="$(cd "$(dirname "$0")/../.." && pwd)"
cd "$root"

quick=""
build=1
only="table1,fig9,fig10,fig11"
while [ $# -gt 0 ]; do
  case "$1" in
    --quick) quick="--quick" ;;
    --no-build) build=0 ;;
    --only) only="$2"; shift ;;
    -h|--help) sed -n '3,15p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) echo "run.sh: unknown option $1 (see --help)" >&2; exit 2 ;;
  esac
  shift
done

# Playwright must never fetch a browser: Debian's Chromium is the one measured.
export PLAYWRIGHT_SKIP_BROWSER_DOWNLOAD=1
start=$SECONDS
say() { echo "run.sh: $*" >&2; }
need() {
  command -v "$1" >/dev/null || { say "$1 not found: $2"; exit 1; }
}
need node "apt-get install nodejs npm"
need draco_encoder "apt-get install draco (Draco's command-line tools)"
need draco_decoder "apt-get install draco"
need "${OSTEON_CHROMIUM:-chromium}" "apt-get install chromium"

data="${OSTEON_SHARED_DATA:-$root/../shared/data}"
if [ ! -d "$data" ]; then
  say "no shared data at $data: the items fall back to the phantom skeleton (osteon phantom)" \
      "and Fig. 10 cannot be measured; the page will say so"
fi

if [ "$build" = 1 ]; then
  need cmake "apt-get install cmake ninja-build g++"
  need em++ "apt-get install emscripten (the WebAssembly decoder)"
  say "building the Release bench build (build-bench: osteon CLI, segmentation_bench) ..."
  cmake -S . -B build-bench -G Ninja -DCMAKE_BUILD_TYPE=Release -DOSTEON_BUILD_BENCH=ON \
    -DOSTEON_BUILD_TESTS=OFF >/dev/null
  cmake --build build-bench -j2 --target osteon_cli segmentation_bench
  say "npm packages (bench/, web/: pinned by their package-lock.json) ..."
  (cd bench && npm ci --no-audit --no-fund >/dev/null)
  (cd web && npm ci --no-audit --no-fund >/dev/null)
  # The WebAssembly decoder must come from this very tree: a stream the CLI writes is decoded by
  # it in Table 1. Rebuild when any of its sources is newer than the module.
  wasm=build/wasm/osteon_decoder.wasm
  if [ ! -f "$wasm" ] || [ -n "$(find src include web/decoder -newer "$wasm" -type f -print -quit)" ]; then
    say "building the WebAssembly decoder (web/decoder/build.sh) ..."
    (cd web && npm run --silent build:decoder)
  fi
fi

for item in table1 fig9 fig10 fig11; do
  case ",$only," in
    *",$item,"*)
      say "$item ..."
      t=$SECONDS
      node "bench/paper/$item.mjs" $quick
      say "$item: $((SECONDS - t)) s"
      ;;
  esac
done
node bench/paper/render.mjs
say "done in $((SECONDS - start)) s: docs/PAPER.md, docs/paper/*.svg, docs/paper/results/*.json"
