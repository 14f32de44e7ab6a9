#!/usr/bin/env bash
# Runs strahl's WHOLE test suite against Embree 4 (Debian trixie's libembree-dev, 4.3.x built
# with instance arrays: RTCRayHit is 96 bytes there) from this Debian bookworm machine, inside a
# minimal trixie root made with debootstrap. `make test-embree4` calls it; `.ci/run` calls that.
#
#   tools/test-embree4.sh             run the suite (needs root: debootstrap, mount, chroot)
#   tools/test-embree4.sh --check     exit 0 if this machine can run it, else print why, exit 1
#
# Exit status: 0 passed, 1 the suite failed (or cannot run here), 3 the root could not be made
# (no network, mirror down) — 0 instead with STRAHL_EMBREE4_OPTIONAL=1, as CI sets it.
#
# Cache (kept between runs, documented in docs/building.md):
#   $STRAHL_EMBREE4_CACHE (default /var/cache/strahl): trixie-root/ (the prepared root, reused
#   while its stamp file says it is complete) and target/ (the Embree-4 build's target dir).
#   First run: debootstrap + packages, about a minute; later runs reuse both.
#
# Safety: every mount is undone on every exit path (a trap on EXIT, INT, TERM, HUP); mounts left
# inside the root by a killed run are found in /proc/mounts and undone first; the root is only
# ever deleted with `rm --one-file-system`, after checking nothing is mounted inside it.
#
# The host's toolchain (~/.rustup read-only, ~/.cargo) is bind-mounted at the same paths; the
# package registry is not reachable from inside, so dependencies are fetched on the host first
# and the build runs --offline. Build scripts linked inside need trixie's glibc, hence the
# separate target directory.
set -euo pipefail

CACHE=${STRAHL_EMBREE4_CACHE:-/var/cache/strahl}
ROOT=$CACHE/trixie-root
TARGET=$CACHE/target
REPO=$(cd "$(dirname "$0")/.." && pwd)
SHARED=$(cd "$REPO/.." && pwd)/shared
MIRROR=${MIRROR:-http://deb.debian.org/debian}
# Packages of the root; the stamp names them so that a change rebuilds the root.
PACKAGES="libembree-dev libclang1-19 libclang-common-19-dev gcc libc6-dev ca-certificates python3"
# The readers the tests check strahl's files with (exrheader, oiiotool, Python's OpenEXR, mmh3,
# numpy, pygltflib, trimesh) and /usr/bin/time (peak memory), as `make test-deps` installs them
# on the host: installed when the root is made, each step allowed to fail (a test whose reader
# is missing skips, and the summary line below counts and names every skip).
READERS="openexr openimageio-tools python3-numpy python3-pip time"
PIP_READERS="OpenEXR mmh3 pygltflib trimesh"
STAMP="strahl-root-v3: $PACKAGES; $READERS; $PIP_READERS"

say() { echo "test-embree4: $*" >&2; }

# Why this machine cannot run the suite (empty if it can).
cannot() {
  [ "$(id -u)" -eq 0 ] || { echo "needs root (debootstrap, mount, chroot)"; return; }
  [ "$(uname -m)" = x86_64 ] || { echo "needs an x86_64 machine (Debian trixie amd64 root)"; return; }
  command -v chroot >/dev/null || { echo "chroot is missing"; return; }
  if ! command -v debootstrap >/dev/null && ! [ -f "$ROOT/.strahl-ready" ]; then
    command -v apt-get >/dev/null || { echo "debootstrap is missing and apt-get cannot install it"; return; }
  fi
  command -v cargo >/dev/null || { echo "cargo is missing"; return; }
  [ -d "$HOME/.rustup" ] && [ -d "$HOME/.cargo" ] || { echo "the Rust toolchain is not under \$HOME/.rustup and \$HOME/.cargo"; return; }
}

if [ "${1:-}" = --check ]; then
  why=$(cannot)
  [ -z "$why" ] || { echo "$why"; exit 1; }
  exit 0
fi
why=$(cannot)
[ -z "$why" ] || { say "error: $why"; exit 1; }

# Mount points inside $1, deepest first (from the kernel's table, so stale ones are found too).
mounts_under() {
  awk -v root="$1" '{ gsub(/\\040/, " ", $2); if ($2 == root || index($2, root "/") == 1) print $2 }' /proc/mounts |
    awk '{ print length($0) " " $0 }' | sort -rn | cut -d' ' -f2-
}
unmount_all() {
  local m
  for m in $(mounts_under "$1"); do
    umount "$m" 2>/dev/null || umount -l "$m" 2>/dev/null || say "warning: cannot unmount $m"
  done
}
# Deletes a root directory, never crossing into another file system and never while anything is
# mounted inside it.
remove_root() {
  unmount_all "$1"
  if [ -n "$(mounts_under "$1")" ]; then
    say "error: $1 still has mounts inside; not deleting it"
    exit 1
  fi
  rm -rf --one-file-system -- "$1"
}

mkdir -p "$CACHE" "$TARGET"
# One run at a time: two would mount over each other in the same root.
exec 9>"$CACHE/lock"
flock -n 9 || { say "waiting for another run to release $CACHE/lock"; flock 9; }
stale=$(mounts_under "$ROOT")
if [ -n "$stale" ]; then
  say "unmounting what a previous run left mounted in $ROOT"
  unmount_all "$ROOT"
fi

mounts=()
mnt() { # mnt DEST mount-args...: mount inside the root and remember it
  local dest=$ROOT$1
  shift
  mkdir -p "$dest"
  mount "$@" "$dest"
  mounts+=("$dest")
}
unmount_tracked() {
  local i
  for ((i = ${#mounts[@]} - 1; i >= 0; i--)); do
    umount "${mounts[$i]}" 2>/dev/null || umount -l "${mounts[$i]}" 2>/dev/null || true
  done
  mounts=()
}
# Stops every process whose root directory is $1 (the suite's cargo and tests): their mounts
# cannot go while they run.
kill_inside() {
  local p pids=()
  for p in /proc/[0-9]*; do
    [ "$(readlink "$p/root" 2>/dev/null)" = "$1" ] && pids+=("${p#/proc/}")
  done
  [ ${#pids[@]} -eq 0 ] && return
  kill -TERM "${pids[@]}" 2>/dev/null || true
  sleep 1
  kill -KILL "${pids[@]}" 2>/dev/null || true
}
cleanup() {
  kill_inside "$ROOT"
  unmount_tracked
  [ -d "$ROOT.partial" ] && [ -z "$(mounts_under "$ROOT.partial")" ] && rm -rf --one-file-system -- "$ROOT.partial"
  true
}
trap cleanup EXIT
trap 'cleanup; exit 130' INT
trap 'cleanup; exit 143' TERM
trap 'cleanup; exit 129' HUP

# 1. The root: reuse it when its stamp matches, else build it in ROOT.partial and rename.
#    A failure here (no network, a mirror down) is "could not test", exit 3, not a test failure.
create_root() {
  local real_root=$ROOT
  [ -e "$ROOT" ] && remove_root "$ROOT"
  [ -e "$ROOT.partial" ] && remove_root "$ROOT.partial"
  command -v debootstrap >/dev/null || DEBIAN_FRONTEND=noninteractive apt-get install -y -qq debootstrap >/dev/null || return 1
  say "creating a Debian trixie root in $ROOT (debootstrap, about a minute)"
  debootstrap --variant=minbase trixie "$ROOT.partial" "$MIRROR" >/dev/null || return 1
  ROOT=$ROOT.partial
  mnt /proc -t proc proc || return 1
  mnt /dev --bind /dev || return 1
  cp /etc/resolv.conf "$ROOT/etc/resolv.conf"
  chroot "$ROOT" /usr/bin/env -i PATH=/usr/sbin:/usr/bin:/sbin:/bin DEBIAN_FRONTEND=noninteractive bash -ec "
    apt-get update -qq
    apt-get install -y -qq --no-install-recommends $PACKAGES >/dev/null
  " || { ROOT=$real_root; return 1; }
  chroot "$ROOT" /usr/bin/env -i PATH=/usr/sbin:/usr/bin:/sbin:/bin DEBIAN_FRONTEND=noninteractive bash -c "
    apt-get install -y -qq --no-install-recommends $READERS >/dev/null || echo 'test-embree4: could not install $READERS'
  " >&2
  # The Python readers' wheels are fetched by the host's pip, for the root's Python, as the
  # crates are (a machine whose HTTPS goes through a proxy trusts the proxy's certificate on
  # the host, not in a fresh root); pip inside the root installs them without the network.
  local py wheels=$ROOT/tmp/strahl-wheels
  local pip=(chroot "$ROOT" /usr/bin/env -i PATH=/usr/sbin:/usr/bin:/sbin:/bin python3 -m pip install -q
    --disable-pip-version-check --root-user-action=ignore --no-warn-script-location --break-system-packages)
  py=$(chroot "$ROOT" python3 -c 'import sys; print("%d%d" % sys.version_info[:2])')
  if python3 -m pip download -q --disable-pip-version-check --dest "$wheels" --only-binary=:all: \
    --python-version "$py" --implementation cp --abi "cp$py" --platform manylinux_2_28_x86_64 \
    --platform manylinux_2_17_x86_64 --platform manylinux2014_x86_64 --platform any \
    $PIP_READERS >/dev/null; then
    "${pip[@]}" --no-index --find-links /tmp/strahl-wheels $PIP_READERS >/dev/null ||
      say "could not pip-install $PIP_READERS from the host's wheels"
  else
    say "the host's pip could not fetch $PIP_READERS for the root's Python $py; trying pip in the root"
    "${pip[@]}" $PIP_READERS >/dev/null || say "could not pip-install $PIP_READERS"
  fi
  rm -rf -- "$wheels"
  local partial=$ROOT
  ROOT=$real_root
  unmount_tracked
  [ -z "$(mounts_under "$partial")" ] || return 1
  echo "$STAMP" >"$partial/.strahl-ready"
  mv "$partial" "$ROOT"
}
if [ "$(cat "$ROOT/.strahl-ready" 2>/dev/null)" != "$STAMP" ]; then
  start=$SECONDS
  if ! create_root; then
    cleanup
    echo "Embree 4 was not tested: could not create the Debian trixie root (debootstrap or apt-get failed; see above)"
    # CI sets STRAHL_EMBREE4_OPTIONAL=1: there an unreachable mirror is reported, not failed.
    [ "${STRAHL_EMBREE4_OPTIONAL:-0}" = 1 ] && exit 0
    exit 3
  fi
  say "root ready in $((SECONDS - start)) s"
fi

# 2. Dependencies, on the host (the registry is not reachable from inside).
(cd "$REPO" && cargo fetch --locked -q)

# 3. The suite, inside.
mnt /proc -t proc proc
mnt /sys -t sysfs sysfs
mnt /dev --bind /dev
mnt "$HOME/.rustup" --bind -o ro "$HOME/.rustup"
mnt "$HOME/.cargo" --bind "$HOME/.cargo"
mnt /src --bind "$REPO"
mnt /target --bind "$TARGET"
[ -d "$SHARED" ] && mnt /shared --bind -o ro "$SHARED"
# A read-only bind needs a remount to take effect on older kernels.
mount -o remount,bind,ro "$ROOT$HOME/.rustup" 2>/dev/null || true

embree=$(chroot "$ROOT" dpkg-query -W -f='${Version}' libembree-dev)
say "Embree in the root: libembree-dev $embree"
start=$SECONDS
# In the background, waited for: bash runs a trap only after the foreground command ends, but
# `wait` returns at once on a signal, so Ctrl-C or a kill cleans up now, not after the suite.
rm -f "$TARGET/skipped-tests.txt"
set +e
chroot "$ROOT" /usr/bin/env -i HOME="$HOME" PATH="$HOME/.cargo/bin:/usr/bin:/bin" TERM=dumb \
  RUSTUP_HOME="$HOME/.rustup" CARGO_HOME="$HOME/.cargo" CARGO_TARGET_DIR=/target \
  STRAHL_TEST_DATA=/shared/data/meshes STRAHL_EXPECT_EMBREE_MAJOR=4 STRAHL_SKIP_LOG=/target/skipped-tests.txt \
  bash -c 'cd /src && cargo test --offline --locked 2>&1' > >(tee "$TARGET/last-run.log") &
wait $!
status=$?
wait 2>/dev/null || true  # let tee finish the log
set -e
passed=$(grep -Eo '[0-9]+ passed' "$TARGET/last-run.log" | awk '{ s += $1 } END { print s + 0 }')
failed=$(grep -Eo '[0-9]+ failed' "$TARGET/last-run.log" | awk '{ s += $1 } END { print s + 0 }')
# Each check a test skipped for want of a tool (tests/common/mod.rs, `skip`), named.
skipped=0
if [ -s "$TARGET/skipped-tests.txt" ]; then
  skipped=$(sort -u "$TARGET/skipped-tests.txt" | wc -l)
  say "$skipped checks skipped inside the root:"
  sort -u "$TARGET/skipped-tests.txt" | sed 's/^/  /' >&2
fi
if [ "$status" -ne 0 ]; then
  say "FAILED against Embree $embree (exit $status, $passed passed, $failed failed, $skipped checks skipped, $((SECONDS - start)) s)"
  exit "$status"
fi
say "the whole suite passed against Embree $embree in $((SECONDS - start)) s"
echo "embree4: $passed passed, $failed failed, $skipped checks skipped (listed above)"
