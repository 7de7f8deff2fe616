#!/usr/bin/env bash
# Builds what runs on the probe's board (geometry, probe_fw, link, agent: mlp-fw) for aarch64
# with Debian's cross compiler against the Debian 12 arm64 sysroot (scripts/arm64-sysroot.sh),
# runs the firmware's tests under qemu-aarch64, then the firmware pipeline on the same rendered
# frames on x86-64 and on aarch64: the two clouds must be the same file, byte for byte
# (floating point is not contracted into FMAs: CMakeLists.txt).
# Usage: bash scripts/build-arm64.sh [X86_BIN_DIR]   (default build/bin: mlp-sim and mlp-fw)
set -euo pipefail
cd "$(dirname "$0")/.."
x86_bin=${1:-build/bin}
for tool in aarch64-linux-gnu-g++ qemu-aarch64; do
  command -v "$tool" >/dev/null || {
    echo "build-arm64: $tool missing (scripts/install-deps.sh installs it)" >&2
    exit 1
  }
done
sysroot=$(bash scripts/arm64-sysroot.sh)
source scripts/build-env.sh
echo "build-arm64: configuring build-arm64 (sysroot $sysroot)"
cmake -S . -B build-arm64 -G Ninja -DCMAKE_TOOLCHAIN_FILE=cmake/aarch64-linux-gnu.cmake \
  -DMLP_ARM64_SYSROOT="$sysroot" -DMLP_FIRMWARE_ONLY=ON -DMLP_BUILD_TESTS=ON \
  -DCMAKE_BUILD_TYPE=Release "${mlp_launcher[@]}" >/dev/null
cmake --build build-arm64 -j "${MLP_JOBS:-2}"
# Two tests take 6 to 7 minutes each under qemu, most of this script's time: the pipeline on
# three bores' captures and three probes streaming 20 rounds each. Both run natively in the main
# suite, and the pipeline's aarch64 output is compared below with x86-64's byte for byte; under
# qemu they run with MLP_ARM64_ALL=1 (before a release, after a change to the link's agent or
# the firmware's pipeline). CI runs the rest (docs/PROBE.md).
qemu_slow='Pipeline\.BoreDiametersFromFourWallCaptures|ProbeAgent\.SeveralVirtualProbesStreamToOneHost'
if [ "${MLP_ARM64_ALL:-0}" = 1 ]; then
  echo "build-arm64: every firmware test under qemu-aarch64"
  ctest --test-dir build-arm64 --output-on-failure -j 2 --timeout 900
else
  echo "build-arm64: the firmware's tests under qemu-aarch64 but two slow ones (MLP_ARM64_ALL=1: all)"
  ctest --test-dir build-arm64 --output-on-failure -j 2 --timeout 900 -E "$qemu_slow"
fi

echo "build-arm64: the pipeline on x86-64 and on aarch64, same frames"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
probe=samples/probes/reference_probe.json
"$x86_bin/mlp-sim" render --probe "$probe" --scene samples/scenes/bore_block.json \
  --out "$work/frames" --seed 7 >/dev/null
"$x86_bin/mlp-fw" run --probe "$probe" --frames "$work/frames" --roi full --out "$work/x86.ply" \
  >/dev/null
qemu-aarch64 -L "$sysroot" build-arm64/bin/mlp-fw run --probe "$probe" --frames "$work/frames" \
  --roi full --out "$work/arm64.ply" >/dev/null
points=$(grep -a -m1 "^element vertex" "$work/x86.ply" | cut -d' ' -f3)
if ! cmp -s "$work/x86.ply" "$work/arm64.ply"; then
  echo "build-arm64: the aarch64 cloud differs from the x86-64 one ($(cmp "$work/x86.ply" "$work/arm64.ply" || true))" >&2
  exit 1
fi
if ! [ "${points:-0}" -gt 1000 ]; then
  echo "build-arm64: the pipeline gave ${points:-no} points; a bore block sweep gives tens of thousands" >&2
  exit 1
fi
echo "build-arm64: the aarch64 firmware's cloud equals the x86-64 one byte for byte ($points points)"

# The firmware's Debian package for the board (docs/PACKAGES.md). dpkg-shlibdeps cannot ask an
# arm64 system here, so each library mlp-fw needs (its NEEDED entries) is mapped to the sysroot's
# package and version; a library the map lacks stops the build rather than ship a package that
# would not run.
echo "build-arm64: the mlprobe-fw package for arm64"
declare -A package_of=([libc.so.6]=libc6 [libm.so.6]=libc6 [libstdc++.so.6]=libstdc++6
  [libgcc_s.so.1]=libgcc-s1 [libpng16.so.16]=libpng16-16 [libcrypto.so.3]=libssl3
  [libzstd.so.1]=libzstd1 [libz.so.1]=zlib1g [libopencv_core.so.406]=libopencv-core406
  [libopencv_imgproc.so.406]=libopencv-imgproc406)
depends=()
for so in $(aarch64-linux-gnu-readelf -d build-arm64/bin/mlp-fw | sed -n 's/.*Shared library: \[\(.*\)\]/\1/p'); do
  pkg=${package_of[$so]:-}
  [ -n "$pkg" ] || { echo "build-arm64: mlp-fw needs $so: add its package to the map" >&2; exit 1; }
  version=$(awk -v p="$pkg:arm64:" '$1 == p { print $2 }' "$sysroot/.packages")
  [ -n "$version" ] || { echo "build-arm64: $pkg is not in the sysroot" >&2; exit 1; }
  depends+=("$pkg (>= $version)")
done
depends_line=$(printf '%s\n' "${depends[@]}" | sort -u | paste -sd, - | sed 's/,/, /g')
rm -rf build-arm64/packages
(cd build-arm64 && cpack -G DEB -B packages -D "CPACK_DEBIAN_FW_PACKAGE_DEPENDS=$depends_line" \
  >packages.log 2>&1) || { cat build-arm64/packages.log >&2; exit 1; }
deb=$(ls build-arm64/packages/mlprobe-fw_*_arm64.deb)
[ "$(dpkg-deb -f "$deb" Architecture)" = arm64 ] || { echo "build-arm64: $deb is not arm64" >&2; exit 1; }
contents=$(dpkg-deb -c "$deb")  # whole, not piped into grep -q (pipefail: a broken pipe)
grep -q '\./usr/bin/mlp-fw$' <<<"$contents" || { echo "build-arm64: no mlp-fw in $deb" >&2; exit 1; }
dpkg-deb -x "$deb" "$work/deb"
qemu-aarch64 -L "$sysroot" "$work/deb/usr/bin/mlp-fw" --help >/dev/null ||
  { echo "build-arm64: the packaged mlp-fw does not run" >&2; exit 1; }
echo "build-arm64: $(basename "$deb"), Depends: $depends_line"
