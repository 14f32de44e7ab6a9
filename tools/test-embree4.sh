#!/usr/bin/env bash
# Runs strahl's tests against Embree 4 (Debian trixie's libembree-dev, 4.3.x built with
# instance arrays: RTCRayHit is 96 bytes there) from this Debian bookworm machine, in a minimal
# trixie root made with debootstrap. Needs root. Not part of CI: a developer's check that the
# cfg(embree4) paths of src/embree/ build and pass.
#
#   sudo tools/test-embree4.sh [ROOT]     (ROOT defaults to /var/tmp/strahl-trixie)
#
# The host's toolchain (~/.rustup, ~/.cargo) is bind-mounted; crates.io is not reachable from
# inside, so dependencies are fetched on the host first and the build runs --offline, into a
# separate target directory (build scripts linked inside need trixie's glibc).
set -euo pipefail
ROOT=${1:-/var/tmp/strahl-trixie}
REPO=$(cd "$(dirname "$0")/.." && pwd)
MIRROR=${MIRROR:-http://deb.debian.org/debian}
[ "$(id -u)" -eq 0 ] || { echo "error: needs root (debootstrap, mount, chroot)" >&2; exit 1; }

if [ ! -x "$ROOT/usr/bin/apt-get" ]; then
  command -v debootstrap >/dev/null || apt-get install -y -qq debootstrap
  debootstrap --variant=minbase trixie "$ROOT" "$MIRROR"
fi
(cd "$REPO" && cargo fetch --locked)

mounts=()
mnt() { mkdir -p "$ROOT$2"; mount $1 "$ROOT$2"; mounts+=("$ROOT$2"); }
cleanup() { for ((i = ${#mounts[@]} - 1; i >= 0; i--)); do umount -l "${mounts[$i]}" || true; done; }
trap cleanup EXIT
mnt "-t proc proc" /proc
mnt "--rbind /sys" /sys
mnt "--rbind /dev" /dev
mnt "--bind $HOME/.rustup" /root/.rustup
mnt "--bind $HOME/.cargo" /root/.cargo
mnt "--bind $REPO" /src
cp /etc/resolv.conf "$ROOT/etc/resolv.conf"

chroot "$ROOT" /usr/bin/env -i HOME=/root PATH=/root/.cargo/bin:/usr/bin:/bin TERM=dumb bash -euc '
  if ! dpkg-query -W libembree-dev >/dev/null 2>&1; then
    apt-get update -qq
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends \
      libembree-dev libclang1-19 libclang-common-19-dev gcc libc6-dev >/dev/null
  fi
  echo "Embree in the root: $(dpkg-query -W -f="\${Version}" libembree-dev)"
  cd /src
  export CARGO_TARGET_DIR=/root/target-embree4
  cargo test --offline --locked --test embree
  cargo test --offline --locked --lib -- embree::
'
