#!/usr/bin/env bash
# Installs the Debian 12 packages the build needs (only the missing ones), then configures and
# builds the project into build/. Idempotent: quiet when everything is already there.
#
#   bash scripts/setup.sh            # packages + build
#   BUILD_DIR=out bash scripts/setup.sh
set -euo pipefail

repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build_dir="${BUILD_DIR:-$repo/build}"
jobs="${JOBS:-$(nproc)}"

packages=(
  build-essential cmake pkg-config git
  libeigen3-dev libopencv-dev libceres-dev libpcl-dev libflann-dev
  libvtk9-dev libosmesa6-dev nlohmann-json3-dev libgtest-dev libopengv-dev
)

missing=()
for p in "${packages[@]}"; do
  status="$(dpkg-query -W -f='${Status}' "$p" 2>/dev/null || true)"
  [[ "$status" == "install ok installed" ]] || missing+=("$p")
done
if (( ${#missing[@]} )); then
  echo "setup: installing ${missing[*]}" >&2
  if [[ $(id -u) -ne 0 ]]; then
    echo "setup: missing packages and not root: run as root or install them: ${missing[*]}" >&2
    exit 1
  fi
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq >&2
  apt-get install -y -qq --no-install-recommends "${missing[@]}" >&2
fi

if [[ ! -f "$build_dir/CMakeCache.txt" ]]; then
  cmake -S "$repo" -B "$build_dir" -DCMAKE_BUILD_TYPE=Release >/dev/null
fi
# Only errors and warnings reach the terminal; the full log stays in the build folder.
if ! cmake --build "$build_dir" -j "$jobs" >"$build_dir/build.log" 2>&1; then
  grep -E "error|Error" -A3 "$build_dir/build.log" | head -60 >&2
  echo "setup: build failed, full log in $build_dir/build.log" >&2
  exit 1
fi
