#!/usr/bin/env bash
# The main job: installs what is missing, builds osteon, its WebAssembly decoder and the viewer,
# packs the real BodyParts3D skeleton in ../shared/data with its anatomical names (or, when
# ../shared is absent, a generated phantom skeleton) and serves the package. Open the printed URL.
#
#   bash scripts/demo.sh                     (PORT=8080 HOST=127.0.0.1 by default)
#   PORT=9000 HOST=0.0.0.0 bash scripts/demo.sh
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/deps.sh
jobs=$(nproc)

echo "== building osteon"
cmake -S . -B build/demo -G Ninja -DCMAKE_BUILD_TYPE=Release -DOSTEON_BUILD_TESTS=OFF >/dev/null
cmake --build build/demo -j"$jobs" --target osteon_cli
osteon=build/demo/osteon

echo "== building the WebAssembly decoder and the viewer"
(cd web && npm ci --no-audit --no-fund && JOBS="$jobs" npm run build:decoder && npm run build:viewer)

site=build/demo-site
data=../shared/data/aHer-dev__3DAnatomy
ontology=../shared/data/BodyParts3D-FMA
rm -rf "$site"
if [ -d "$data/models/bones" ]; then
  echo "== packing the BodyParts3D skeleton (235 bones, names from meta.json, regions from its FMA ontology)"
  regions=()
  [ -f "$ontology/conventional_part_of.txt" ] && regions=(--regions "fma:$ontology")
  "$osteon" pack "$data/models/bones" --names "$data/meta.json" "${regions[@]}" --precision 0.0289 \
    --viewer build/viewer -o "$site"
else
  echo "osteon: ../shared/data is absent: packing a generated phantom skeleton instead"
  "$osteon" phantom -o build/phantom
  "$osteon" pack build/phantom --regions names --viewer build/viewer -o "$site"
fi

echo "== serving $site (Ctrl-C stops)"
exec "$osteon" serve "$site" --port "${PORT:-8080}" --host "${HOST:-127.0.0.1}"
