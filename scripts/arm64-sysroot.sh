#!/usr/bin/env bash
# Assembles the probe board's Debian 12 arm64 sysroot from Debian's own arm64 packages:
# `apt-get download` + `dpkg -x` into a folder. Installing the arm64 -dev packages beside the
# amd64 ones is not possible (they conflict); extracted into a folder they need no installing.
# The folder holds what the firmware (geometry, probe_fw, link, agent) and its tests build and
# run against: headers and libraries for the cross compiler, and the run-time closure that
# qemu-aarch64 loads (-L <sysroot>). libc's headers and crt files come with Debian's cross
# compiler (g++-aarch64-linux-gnu), not from here.
#
# Idempotent: the packages and their versions are recorded in <sysroot>/.packages; a second run
# with the same list does nothing. Needs the arm64 architecture in apt's lists
# (scripts/install-deps.sh adds it). Prints the sysroot's path last.
# Usage: bash scripts/arm64-sysroot.sh   (MLP_ARM64_SYSROOT overrides the folder)
set -euo pipefail
sysroot=${MLP_ARM64_SYSROOT:-/var/cache/mlprobe/arm64-sysroot}
triplet=aarch64-linux-gnu

# Run time: the libraries the firmware and its tests load, and what they load in turn
# (libopencv_core needs libGLX, BLAS/LAPACK and TBB). The list is checked by running: the
# tests and mlp-fw run under qemu-aarch64 with nothing but this folder (scripts/build-arm64.sh).
runtime=(libc6 libgcc-s1 libstdc++6 zlib1g libpng16-16 libssl3 libzstd1
  libopencv-core406 libopencv-imgproc406 libtbb12 libtbbmalloc2 liblapack3 libblas3 libgfortran5
  libglx0 libglvnd0 libx11-6 libxcb1 libxau6 libxdmcp6 libbsd0 libmd0)
# Build time: headers, link symlinks, static test libraries, CMake package files.
develop=(zlib1g-dev libpng-dev libssl-dev libzstd-dev libopencv-core-dev libopencv-imgproc-dev
  libgtest-dev libgmock-dev libboost1.74-dev)
# Architecture-independent headers.
common=(libeigen3-dev nlohmann-json3-dev)

if ! dpkg --print-foreign-architectures | grep -qx arm64; then
  echo "arm64-sysroot: apt has no arm64 architecture (run scripts/install-deps.sh as root)" >&2
  exit 1
fi
wanted=()
for p in "${runtime[@]}" "${develop[@]}"; do wanted+=("$p:arm64"); done
wanted+=("${common[@]}")
# The exact versions apt would fetch now: the sysroot is current when it holds these.
list=$(apt-cache policy "${wanted[@]}" | awk '/^[^ ]/{p=$1} /Candidate:/{print p, $2}')
if grep -q "(none)" <<<"$list"; then
  echo "arm64-sysroot: apt cannot find: $(grep "(none)" <<<"$list" | cut -d' ' -f1 | tr '\n' ' ')" >&2
  echo "arm64-sysroot: run apt-get update (scripts/install-deps.sh)" >&2
  exit 1
fi
if [ -f "$sysroot/.packages" ] && [ "$(cat "$sysroot/.packages")" = "$list" ]; then
  echo "arm64-sysroot: up to date ($(wc -l <<<"$list") packages)" >&2
  echo "$sysroot"
  exit 0
fi

echo "arm64-sysroot: downloading ${#wanted[@]} Debian packages into $sysroot" >&2
debs=$(mktemp -d)
chmod 755 "$debs"  # apt's download user (_apt) writes here
trap 'rm -rf "$debs"' EXIT
download() { (cd "$debs" && apt-get download -qq "${wanted[@]}" 2>/dev/null); }
# Lists older than the archive name versions it no longer has: refresh them once (as root).
if ! download && ! { [ "$(id -u)" -eq 0 ] && apt-get update -qq && download; }; then
  echo "arm64-sysroot: apt-get download failed; run apt-get update and try again" >&2
  exit 1
fi
rm -rf "$sysroot.new"
mkdir -p "$sysroot.new"
for deb in "$debs"/*.deb; do dpkg -x "$deb" "$sysroot.new"; done

# Absolute symlinks (libz.so -> /lib/...) would point at the build machine's amd64 files.
while IFS= read -r link; do
  target=$(readlink "$link")
  ln -sfn "$(realpath -m --relative-to="$(dirname "$link")" "$sysroot.new$target")" "$link"
done < <(find "$sysroot.new" -lname '/*')
# dpkg -x runs no maintainer scripts: make the links update-alternatives would have made.
libdir=$sysroot.new/usr/lib/$triplet
ln -sfn blas/libblas.so.3 "$libdir/libblas.so.3"
ln -sfn lapack/liblapack.so.3 "$libdir/liblapack.so.3"

echo "$list" >"$sysroot.new/.packages"
rm -rf "$sysroot"
mv "$sysroot.new" "$sysroot"
echo "arm64-sysroot: $(wc -l <<<"$list") packages extracted, $(du -sh "$sysroot" | cut -f1)" >&2
echo "$sysroot"
