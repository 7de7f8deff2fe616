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
  build-essential cmake ninja-build pkg-config git clang-format clang-tidy
  ccache  # scripts/build.sh: a rebuild of unchanged files is a cache hit (CI's 30 minutes)
  libeigen3-dev libceres-dev libpcl-dev libflann-dev liblz4-dev libopencv-dev libpng-dev
  libboost-dev libboost-system-dev nlohmann-json3-dev
  libssl-dev libsqlite3-dev libsqlitecpp-dev
  libmosquitto-dev mosquitto openssl  # the plant feed (MQTT); its tests start a real broker with TLS
  libpqxx-dev libpq-dev postgresql  # the plant database; its tests start a real server (initdb, pg_ctl)
  libgtest-dev libgmock-dev libbenchmark-dev
  g++-aarch64-linux-gnu qemu-user  # the firmware for the probe's board (scripts/build-arm64.sh)
  systemd valgrind  # systemd-analyze checks the board's unit; scripts/count-fw-instructions.sh
  linuxcnc-uspace  # the real controller for the LinuxCNC adapter tests and demo
  linuxcnc-uspace-dev  # hal.h and liblinuxcnchal: the setter as a HAL component (mlp-setter-hal)
  clang libclang-rt-14-dev llvm  # the sanitized build, its symbolizer, the libFuzzer targets
  python3 python3-numpy  # the outside renderer (../shared/conformance) the firmware is judged on
)
# The probe board's arm64 packages are downloaded and extracted into a sysroot, never installed
# (scripts/arm64-sysroot.sh): apt only needs their lists.
if ! dpkg --print-foreign-architectures | grep -qx arm64; then
  echo "install-deps: adding the arm64 architecture to apt's lists (for the probe's sysroot)"
  dpkg --add-architecture arm64
  apt-get update -qq
fi
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
