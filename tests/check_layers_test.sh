#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# scripts/check_layers.sh catches each kind of crossing: a copy of the tree with one crossing of
# each kind planted must fail with exactly those, and the tree itself must pass.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
tree=$(mktemp -d)
trap 'rm -rf "$tree"' EXIT
cp -r "$root/src" "$root/include" "$tree/"
echo '#include <tbb/parallel_for.h>' >> "$tree/src/codec/quantize.cpp"
echo '#include "osteon/io.hpp"' >> "$tree/src/core/mesh.cpp"
echo '#include "osteon/package.hpp"' >> "$tree/src/io_stl.cpp"
echo '#include <httplib.h>' >> "$tree/src/repeats.cpp"
echo '// see issue 12' >> "$tree/include/osteon/vec.hpp"
if out=$(bash "$root/scripts/check_layers.sh" "$tree" 2>&1); then
  echo "FAIL: planted crossings passed the check"; exit 1
fi
for want in "src/codec/quantize.cpp:.*<tbb/parallel_for.h>" "src/core/mesh.cpp:.*osteon/io.hpp" \
            "src/io_stl.cpp:.*osteon/package.hpp" "src/repeats.cpp:.*httplib" \
            "include/osteon/vec.hpp:.*tracker issue" "5 crossing"; do
  grep -q "$want" <<<"$out" || { echo "FAIL: not reported: $want"; echo "$out"; exit 1; }
done
bash "$root/scripts/check_layers.sh" "$root"
echo "1 passed, 0 failed"
