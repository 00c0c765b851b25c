#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# bench/web in one command: installs bench/web's npm packages (npm ci, pinned by package-lock.json;
# no browser is downloaded: Debian's /usr/bin/chromium is used), makes sure the osteon CLI and the
# viewer are built, then runs load_bench.mjs, which prepares the five ways (and, once, the dense
# skeleton) into build/bench-web/, measures them in headless Chromium under three profiles and,
# after a complete run, writes the "Browser load time (bench/web)" section of docs/BENCHMARKS.md
# and docs/load_time.svg. Arguments go to load_bench.mjs (--help lists them; --runs 1 for a quick
# check, --no-write to print only, --prepare-only to build the cache).
set -euo pipefail

here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
repo=$(cd "$here/../.." && pwd)
export PLAYWRIGHT_SKIP_BROWSER_DOWNLOAD=1

fail() { echo "bench/web: error: $*" >&2; exit 1; }

command -v node >/dev/null || fail "node is not installed (Debian: apt-get install nodejs npm)"
command -v npm >/dev/null || fail "npm is not installed (Debian: apt-get install npm)"
# @gltf-transform/cli (the Draco way's encoder) needs Node 20; Debian 12's own nodejs is 18.
node -e 'process.exit(Number(process.versions.node.split(".")[0]) >= 20 ? 0 : 1)' ||
  fail "node $(node --version) is too old: bench/web needs Node 20 or later (@gltf-transform/cli)"

# npm ci only when package-lock.json changed since the last install (it deletes node_modules).
lock_hash=$(sha256sum "$here/package-lock.json" | cut -d' ' -f1)
if [[ ! -f "$here/node_modules/.bench-web-lock" || "$(cat "$here/node_modules/.bench-web-lock")" != "$lock_hash" ]]; then
  echo "bench/web: npm ci" >&2
  (cd "$here" && npm ci --no-audit --no-fund >&2)
  echo "$lock_hash" > "$here/node_modules/.bench-web-lock"
fi

osteon=${OSTEON_CLI:-$repo/build/release/osteon}
if [[ ! -x "$osteon" ]]; then
  [[ -d "$repo/build/release" ]] || fail "$osteon is missing: configure and build osteon first (bash scripts/demo.sh)"
  echo "bench/web: building the osteon CLI" >&2
  cmake --build "$repo/build/release" -j2 --target osteon_cli >&2
fi

# The osteon way needs the built viewer; without it load_bench.mjs runs the other ways and says why.
if [[ ! -f "$repo/build/viewer/index.html" && -f "$repo/web/viewer/build.mjs" ]]; then
  echo "bench/web: building the viewer (web: npm ci, npm run build:viewer)" >&2
  (cd "$repo/web" && npm ci --no-audit --no-fund >&2 && npm run build:viewer >&2) ||
    echo "bench/web: the viewer did not build; the osteon way will be skipped" >&2
fi

exec env OSTEON_CLI="$osteon" node "$here/load_bench.mjs" "$@"
