#!/usr/bin/env bash
# Installs the Debian 12 packages osteon builds with, if any is missing. Run as root (or with sudo).
set -euo pipefail
packages=(
  cmake ninja-build g++ clang libclang-rt-14-dev pkg-config
  libgtest-dev libgmock-dev
  libcli11-dev nlohmann-json3-dev libtinygltf-dev libtbb-dev libeigen3-dev libcpp-httplib-dev libssl-dev
  libmicrohttpd-dev
  libnifti2-dev libmeshoptimizer-dev libdraco-dev
  libassimp-dev
  emscripten
)
# The test command also needs Debian's Chromium (the viewer's tests drive it headless through npm's
# playwright-core, which never downloads a browser): `bash scripts/deps.sh test`.
[ "${1:-}" = test ] && packages+=(chromium)
missing=()
# Node.js and npm for the web decoder's tests: use the machine's own when it has one (e.g.
# NodeSource's Node 20, which bundles npm); otherwise Debian's packages.
command -v node >/dev/null 2>&1 || packages+=(nodejs)
command -v npm >/dev/null 2>&1 || packages+=(npm)
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "osteon: installing ${missing[*]}"
  sudo_cmd=""
  [ "$(id -u)" -ne 0 ] && sudo_cmd="sudo"
  $sudo_cmd apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo_cmd apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi
