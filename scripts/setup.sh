#!/usr/bin/env bash
# Installs every system package Locard needs to build, test and benchmark, from Debian 12.
# Idempotent: packages already present are skipped, so it is cheap to run before every build.
set -euo pipefail

packages=(
  # toolchain
  build-essential cmake ninja-build pkg-config git ca-certificates
  # core libraries
  libeigen3-dev libtbb-dev libnanoflann-dev libcli11-dev libspdlog-dev libfmt-dev
  nlohmann-json3-dev libpng-dev libjpeg-dev libdeflate-dev libembree-dev libceres-dev libassimp-dev libcgal-dev
  # E57 point clouds: their XML section
  libpugixml-dev
  # case integrity (SHA-256), local viewer server, physics scenarios
  libssl-dev libcpp-httplib-dev libbullet-dev
  # tests of signed and time-stamped cases play the key holder and the authority
  openssl
  # browser tests of the report and viewer (headless Chromium driven by Playwright)
  chromium fonts-dejavu-core
  # fuzzing (make fuzz, and the short pass of make test): clang and its libFuzzer runtime
  clang libclang-rt-14-dev
  # tests and benchmarks
  libgtest-dev libgmock-dev libbenchmark-dev
  # reference peer for benchmarks and cross-checks (never a runtime dependency)
  python3 python3-numpy python3-open3d
  # re-import tests of the mesh exports (tests/reimport): the tools investigators open them in;
  # meshlabserver needs an X display for its GL context (xvfb-run)
  blender assimp-utils cloudcompare meshlab xvfb xauth
)

# Node.js and npm bundle the viewer (three.js) and drive the browser tests. A machine may
# already carry another build of Node (with its own npm); Debian's are installed only when
# there is no npm at all.
if ! command -v npm >/dev/null 2>&1; then packages+=(nodejs npm); fi

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]} == 0)); then
  exit 0
fi

sudo_cmd=()
if [[ $(id -u) -ne 0 ]]; then sudo_cmd=(sudo); fi
echo "setup: installing ${missing[*]}" >&2
export DEBIAN_FRONTEND=noninteractive
"${sudo_cmd[@]}" apt-get update -qq
"${sudo_cmd[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}"
