#!/usr/bin/env bash
# Installs every build and test dependency of mlprobe from Debian 12's archive.
# Non-interactive and idempotent: safe to run on a fresh machine and again on a prepared one.
set -euo pipefail
if [ "$(id -u)" -ne 0 ]; then
  echo "install-deps: run as root (apt-get needs it)" >&2
  exit 1
fi
export DEBIAN_FRONTEND=noninteractive
packages=(
  build-essential cmake ninja-build pkg-config git clang-format
  libeigen3-dev libceres-dev libpcl-dev libflann-dev liblz4-dev libopencv-dev
  libboost-dev libboost-system-dev nlohmann-json3-dev
  libssl-dev libsqlite3-dev libsqlitecpp-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  g++-aarch64-linux-gnu  # the firmware portability check (scripts/check-arm64.sh)
  linuxcnc-uspace  # the real controller for the LinuxCNC adapter tests and demo
  clang libclang-rt-14-dev  # the libFuzzer targets (scripts/fuzz-link.sh)
)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#packages[@]} packages already installed"
  exit 0
fi
echo "install-deps: installing ${missing[*]}"
apt-get update -qq
apt-get install -y -qq --no-install-recommends "${missing[@]}"
