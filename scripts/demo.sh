#!/usr/bin/env bash
# The main job: installs what is missing, builds osteon, and diagnoses the real BodyParts3D skeleton
# in ../shared/data (or, when ../shared is absent, a generated phantom skeleton).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/deps.sh
cmake -S . -B build/demo -G Ninja -DCMAKE_BUILD_TYPE=Release -DOSTEON_BUILD_TESTS=OFF >/dev/null
cmake --build build/demo -j"$(nproc)" --target osteon_cli
osteon=build/demo/osteon
skeleton=../shared/data/aHer-dev__3DAnatomy/models/bones
if [ ! -d "$skeleton" ]; then
  echo "osteon: ../shared/data is absent: using a generated phantom skeleton instead"
  skeleton=build/phantom
  "$osteon" phantom -o "$skeleton"
fi
"$osteon" info "$skeleton"
