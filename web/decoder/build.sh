#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Builds the WebAssembly decoder: the core layer (osteon_core, the same files the native library
# compiles) plus the C ABI in osteon_decoder.cpp, with Debian 12's emscripten (apt-get install
# emscripten), into a standalone module with an explicit export list and no Emscripten JavaScript.
# Output: build/wasm/{osteon_decoder.wasm, osteon_decoder.mjs, worker.mjs, pool.mjs}, the files a
# web page serves side by side. Prints the download size (gzip -9), budgeted at 25 KB.
#
#   bash web/decoder/build.sh          (or: cd web && npm run build:decoder)
#   JOBS=2 OUT=build/wasm ...          parallel compiles, output folder
set -euo pipefail
root="$(cd "$(dirname "$0")/../.." && pwd)"
cd "$root"
out="${OUT:-build/wasm}"
jobs="${JOBS:-2}"

if ! command -v em++ >/dev/null; then
  echo "osteon: em++ not found: install Debian's emscripten (apt-get install emscripten)" >&2
  exit 1
fi
# Debian's emscripten runs its JavaScript tools on the system Node, which finds their modules
# (acorn) here. The system libraries come prebuilt in Debian's read-only cache
# (/usr/share/emscripten/cache, FROZEN_CACHE): nothing is downloaded or built, nothing written.
export NODE_PATH="${NODE_PATH:-/usr/share/nodejs}"

# The decoder is a CMake target: CMakeLists.txt, configured with emcmake, builds osteon_core
# (the same core and codec sources the native library compiles) with the browser's flags and
# links web/decoder/osteon_decoder.cpp's C ABI with an explicit export list, so the sources are
# listed once, there; so is the export list, which CMake writes beside the build for the check
# below.
cmake_flags=(-G Ninja -DCMAKE_BUILD_TYPE=Release -DOSTEON_BUILD_TESTS=OFF)
[ "${OSTEON_WERROR:-0}" = 1 ] && cmake_flags+=(-DOSTEON_WERROR=ON)
mkdir -p "$out"
echo "osteon: em++ $(em++ --version 2>/dev/null | sed -n '1s/.*) //p') -> $out"
emcmake cmake -S . -B "$out/cmake" "${cmake_flags[@]}" >/dev/null
cmake --build "$out/cmake" --target osteon_decoder_wasm -j "$jobs" ||
  { echo "osteon: compiling the decoder failed" >&2; exit 1; }
cp "$out/cmake/osteon_decoder.wasm" "$out/osteon_decoder.wasm"
mapfile -t exports < "$out/cmake/osteon_decoder_exports.txt"
# The JavaScript modules, minified by esbuild (web/package.json; npm ci in web/) the way they ship:
# each stays its own ES module, imports untouched. Without esbuild they are copied as written.
esbuild="$root/web/node_modules/.bin/esbuild"
for js in osteon_decoder.mjs worker.mjs pool.mjs; do
  if [ -x "$esbuild" ]; then
    "$esbuild" "web/decoder/$js" --minify --format=esm --target=es2022 --log-level=warning \
      --outfile="$out/$js"
  else
    cp "web/decoder/$js" "$out/"
  fi
done
[ -x "$esbuild" ] || echo "osteon: esbuild not installed (cd web && npm ci): the wrapper is not minified"

# The wrapper supplies exactly this import; a new one (a libc call reaching for the console or
# the clock) would fail at instantiation, so fail here instead.
node --input-type=module - "$out/osteon_decoder.wasm" "${exports[@]}" <<'EOF'
import { readFileSync } from 'node:fs';
const [file, ...wanted] = process.argv.slice(2);
const module = new WebAssembly.Module(readFileSync(file));
const allowed = new Set(['wasi_snapshot_preview1.proc_exit']);
const bad = WebAssembly.Module.imports(module).map((i) => `${i.module}.${i.name}`)
  .filter((name) => !allowed.has(name));
const have = new Set(WebAssembly.Module.exports(module).map((e) => e.name));
const missing = [...wanted, 'memory', '_initialize'].filter((name) => !have.has(name));
if (bad.length || missing.length) {
  console.error(`osteon: ${file}: unexpected imports [${bad}], missing exports [${missing}]`);
  process.exit(1);
}
EOF

size() { stat -c %s "$1"; }
gz() { gzip -9c "$1" | wc -c; }
wasm="$out/osteon_decoder.wasm"
wrapper="$out/osteon_decoder.mjs"
echo "osteon: $wasm $(size "$wasm") bytes, gzip -9 $(gz "$wasm")"
echo "osteon: $wrapper $(size "$wrapper") bytes, gzip -9 $(gz "$wrapper")"
echo "osteon: decoder download (wasm + wrapper, gzip -9): $(( $(gz "$wasm") + $(gz "$wrapper") )) bytes" \
     "(target 25000; worker.mjs adds $(gz "$out/worker.mjs"), pool.mjs $(gz "$out/pool.mjs"))"
