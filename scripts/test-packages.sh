#!/usr/bin/env bash
# The Debian packages installed, upgraded and removed on this machine (issue 22; docs/PACKAGES.md),
# as root: builds them with cpack from BUILD_DIR (default build/), then
#   mlprobe-host: installed (user, folders, a key made, the unit), its mlp-hostd started as the
#     unit starts it and asked by `mlp status`; the site's edits (configuration, a calibration,
#     the history) survive an upgrade to a newer version, removal and reinstallation; purge
#     drops only the configuration file;
#   mlprobe-fw: installed, mlp-fw runs, its unit verifies, removed.
# No systemd runs here (a container): the service is started by hand with the unit's user and
# command line. Refuses to run where a real mlprobe package is installed: it would replace it.
set -euo pipefail
build=$(realpath "${1:-build}")
work=$(mktemp -d /tmp/mlp_packages.XXXXXX)
port=17469  # the probe link's port in the test's configuration
fail() { echo "test-packages: FAILED: $*" >&2; exit 1; }
step() { echo "test-packages: $*"; }

[ "$(id -u)" -eq 0 ] || fail "run as root (dpkg)"
for p in mlprobe-host mlprobe-fw; do
  if dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "ok installed" &&
     [ ! -e /var/lib/mlprobe/.installed-by-test-packages ]; then
    fail "$p is installed here and not by this test: it would be replaced"
  fi
done
hostd_pid=
cleanup() {
  [ -n "$hostd_pid" ] && kill "$hostd_pid" 2>/dev/null || true
  dpkg --purge mlprobe-host mlprobe-fw >/dev/null 2>&1 || true
  rm -rf /var/lib/mlprobe /etc/mlprobe /run/mlprobe "$work"
  userdel mlprobe 2>/dev/null || true
  getent group mlprobe >/dev/null && groupdel mlprobe 2>/dev/null || true
}
trap cleanup EXIT
cleanup_before() { dpkg --purge mlprobe-host mlprobe-fw >/dev/null 2>&1 || true; rm -rf /var/lib/mlprobe /etc/mlprobe; }
cleanup_before

step "cpack in $build"
(cd "$build" && cpack -G DEB -B "$work/debs" >"$work/cpack.log" 2>&1) || { cat "$work/cpack.log"; fail "cpack"; }
host_deb=$(ls "$work"/debs/mlprobe-host_*.deb)
fw_deb=$(ls "$work"/debs/mlprobe-fw_*.deb)
dpkg-deb -I "$host_deb" | grep -E "Package|Version|Depends" | sed 's/^/  /'

start_hostd() {  # as mlp-hostd.service starts it: its user, RuntimeDirectory, ExecStart
  install -d -m 0750 -o mlprobe -g mlprobe /run/mlprobe
  grep -q '^ExecStart=/usr/bin/mlp-hostd --config /etc/mlprobe/hostd.json$' \
    /lib/systemd/system/mlp-hostd.service || fail "the unit's ExecStart"
  runuser -u mlprobe -- /usr/bin/mlp-hostd --config /etc/mlprobe/hostd.json >"$work/hostd.log" 2>&1 &
  hostd_pid=$!
  for _ in $(seq 1 300); do
    mlp status --socket /run/mlprobe/jobs.sock >"$work/status.txt" 2>&1 && return 0
    kill -0 "$hostd_pid" 2>/dev/null || { cat "$work/hostd.log"; fail "mlp-hostd exited"; }
    sleep 0.1
  done
  cat "$work/hostd.log"; fail "mlp status never answered"
}
stop_hostd() { kill "$hostd_pid"; wait "$hostd_pid" || true; hostd_pid=; }
sums() { sha256sum /etc/mlprobe/hostd.json /etc/mlprobe/keys/MLP-REF-0001.key \
           /var/lib/mlprobe/calibrations/site.json /var/lib/mlprobe/history.sqlite; }

step "install $(basename "$host_deb")"
dpkg -i "$host_deb" >"$work/dpkg.log" 2>&1 || { cat "$work/dpkg.log"; fail "dpkg -i"; }
touch /var/lib/mlprobe/.installed-by-test-packages
getent passwd mlprobe >/dev/null || fail "no system user mlprobe"
[ "$(stat -c '%U %a' /etc/mlprobe/keys/MLP-REF-0001.key)" = "mlprobe 600" ] || fail "the key's owner or mode"
[ "$(wc -c < /etc/mlprobe/keys/MLP-REF-0001.key)" -eq 65 ] || fail "the key is not 32 bytes of hex"
[ "$(stat -c '%U:%G %a' /etc/mlprobe/hostd.json)" = "root:mlprobe 640" ] || fail "hostd.json's owner or mode"
for p in mlp mlp-hostd mlp-history mlp-calibrate mlp-tool mlp-setter mlp-grind mlp-kinematics; do
  [ -x "/usr/bin/$p" ] || fail "/usr/bin/$p missing"
done
[ -f /usr/lib/libmlp_pcl_reader.so ] || fail "the PCL reader plug-in"
# The site's edit: its own probe link port (as an operator would for a machine's network).
sed -i "s/\"port\": 7420/\"port\": $port/" /etc/mlprobe/hostd.json
start_hostd
grep -q "mlp-hostd up" "$work/status.txt" || fail "mlp status: $(cat "$work/status.txt")"
grep -q "machine vmc-1" "$work/status.txt" || fail "mlp status names no machine"
step "installed and running: $(head -1 "$work/status.txt")"
mlp history --db /var/lib/mlprobe/history.sqlite >/dev/null || fail "mlp history on the installed history"
install -d -o mlprobe -g mlprobe /var/lib/mlprobe/calibrations
echo '{"site": "calibration"}' > /var/lib/mlprobe/calibrations/site.json
stop_hostd
before=$(sums)

step "upgrade to a newer version"
dpkg-deb -R "$host_deb" "$work/newer"
sed -i 's/^Version: \(.*\)$/Version: \1+test1/' "$work/newer/DEBIAN/control"
dpkg-deb -b "$work/newer" "$work/newer.deb" >/dev/null
dpkg -i "$work/newer.deb" >"$work/dpkg.log" 2>&1 || { cat "$work/dpkg.log"; fail "upgrade"; }
dpkg-query -W -f='${Version}' mlprobe-host | grep -q '+test1$' || fail "not upgraded"
[ "$(sums)" = "$before" ] || fail "the upgrade changed the site's files"
start_hostd
stop_hostd
before=$(sums)  # the history as the upgraded service left it

step "remove, then install again"
dpkg -r mlprobe-host >"$work/dpkg.log" 2>&1 || { cat "$work/dpkg.log"; fail "dpkg -r"; }
[ ! -e /usr/bin/mlp-hostd ] || fail "mlp-hostd left after removal"
[ "$(sums)" = "$before" ] || fail "removal changed the site's files"
dpkg -i "$host_deb" >"$work/dpkg.log" 2>&1 || { cat "$work/dpkg.log"; fail "reinstall (a downgrade)"; }
[ "$(sums)" = "$before" ] || fail "reinstalling changed the site's files"
start_hostd
stop_hostd

step "purge"
dpkg --purge mlprobe-host >"$work/dpkg.log" 2>&1 || { cat "$work/dpkg.log"; fail "purge"; }
[ ! -e /etc/mlprobe/hostd.json ] || fail "purge left the configuration file"
[ -f /var/lib/mlprobe/history.sqlite ] && [ -f /etc/mlprobe/keys/MLP-REF-0001.key ] ||
  fail "purge removed the history or the key"

step "install $(basename "$fw_deb")"
dpkg -i "$fw_deb" >"$work/dpkg.log" 2>&1 || { cat "$work/dpkg.log"; fail "dpkg -i fw"; }
/usr/bin/mlp-fw --help >/dev/null || fail "mlp-fw does not run"
[ "$(stat -c '%G %a' /etc/mlprobe/probe.env)" = "mlprobe 640" ] || fail "probe.env's group or mode"
systemd-analyze verify /lib/systemd/system/mlp-fw.service >"$work/verify.log" 2>&1 ||
  { cat "$work/verify.log"; fail "the firmware's unit does not verify"; }
dpkg --purge mlprobe-fw >"$work/dpkg.log" 2>&1 || { cat "$work/dpkg.log"; fail "purge fw"; }
step "passed"
