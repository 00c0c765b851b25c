#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Builds the WebAssembly decoder: the C++ decoder's own sources (the same files the native library
# compiles) plus the C ABI in osteon_decoder.cpp, with Debian 12's emscripten (apt-get install
# emscripten), into a standalone module with an explicit export list and no Emscripten JavaScript.
# Output: build/wasm/{osteon_decoder.wasm, osteon_decoder.mjs, worker.mjs, pool.mjs}, the files a
# web page serves side by side. Prints the download size (gzip -9) the issue budgets at 25 KB.
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

# The decoder's sources; keep in step with src/codec_decode.cpp's callees. corner_table.cpp is
# linked for the corner-table types the Edgebreaker decoder shares (unused code is dropped).
sources=(
  src/status.cpp
  src/entropy.cpp
  src/corner_table.cpp
  src/edgebreaker_decode.cpp
  src/quantize.cpp
  src/parallelogram.cpp
  src/codec_decode.cpp
  src/normals.cpp
  web/decoder/osteon_decoder.cpp
)
# Every export; osteon_decoder.mjs calls exactly these (and _initialize, the reactor's start-up).
exports=(
  osteon_alloc osteon_free_bytes osteon_decode osteon_free osteon_error
  osteon_vertex_count osteon_triangle_count osteon_positions osteon_indices osteon_normals
)

# Measured on the ct-like meshes (web/README.md): -O3 decodes 5x faster than -Os for 2 KB more;
# LTO, emmalloc (instead of dlmalloc), bulk memory and non-trapping float-to-int together save
# 3 KB gzipped at the same speed. The two WebAssembly features are in every browser since 2021
# (Chrome 75, Firefox 79, Safari 15) and in Node >= 14. Memory grows on demand up to 2 GiB
# (a 1.5M-triangle mesh peaks at 80 MiB).
features=(-mbulk-memory -mnontrapping-fptoint)
cxxflags=(-std=c++20 -O3 -flto -DNDEBUG -fno-exceptions -fno-rtti "${features[@]}"
          -Wall -Wextra -Wshadow -Wno-missing-field-initializers
          -Iinclude -Isrc)
[ "${OSTEON_WERROR:-0}" = 1 ] && cxxflags+=(-Werror)
export_list=$(printf '"_%s",' "${exports[@]}")
ldflags=(-O3 -flto "${features[@]}" --no-entry -sSTANDALONE_WASM -sMALLOC=emmalloc
         -sALLOW_MEMORY_GROWTH=1 -sMAXIMUM_MEMORY=2GB -sFILESYSTEM=0
         -sEXPORTED_FUNCTIONS="[${export_list%,}]")

rm -rf "$out/obj"
mkdir -p "$out/obj"
echo "osteon: em++ $(em++ --version 2>/dev/null | sed -n '1s/.*) //p') -> $out"
# One object per source, $jobs at a time (the machine is shared: default 2).
printf '%s\n' "${sources[@]}" | xargs -P "$jobs" -I{} sh -c \
  'out="$1" src="$2"; shift 2; em++ "$@" -c "$src" -o "$out/obj/$(basename "$src" .cpp).o"' \
  _ "$out" {} "${cxxflags[@]}" || { echo "osteon: compiling the decoder failed" >&2; exit 1; }
objects=()
for s in "${sources[@]}"; do objects+=("$out/obj/$(basename "$s" .cpp).o"); done
em++ "${objects[@]}" "${ldflags[@]}" -o "$out/osteon_decoder.wasm"
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

# The wrapper supplies exactly these imports; a new one (a libc call reaching for the console or
# the clock) would fail at instantiation, so fail here instead.
node --input-type=module - "$out/osteon_decoder.wasm" "${exports[@]}" <<'EOF'
import { readFileSync } from 'node:fs';
const [file, ...wanted] = process.argv.slice(2);
const module = new WebAssembly.Module(readFileSync(file));
const allowed = new Set(['env.emscripten_notify_memory_growth', 'wasi_snapshot_preview1.proc_exit']);
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
