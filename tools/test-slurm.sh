#!/usr/bin/env bash
# make test-slurm: strahl's Slurm job arrays on a real (one-node, localhost) Slurm cluster.
#
# Installs Debian's slurmctld slurmd slurm-client munge when missing, starts munged,
# slurmctld and slurmd without systemd (loopback only, state under a private directory),
# submits `strahl farm slurm` for an 8-tile render into a folder whose name holds quotes, a
# space, '#', '%A' and '$( )', waits by polling squeue/sacct, compares the merged EXR with a
# single-process render byte for byte, and checks the logs are named as meant and nothing
# ran; with --denoise (when this strahl has OIDN), the merged and denoised frame against
# `render --denoise` byte for byte; then makes a task fail, and finishes the frame as docs/farm.md says (task and merge again). Every daemon it started is stopped by PID on every exit path. Needs root (it writes
# /etc/munge and starts daemons).
#
# Exit status: 0 passed or skipped (said loudly: not root, or no apt-get to install Slurm), 1 failed.
# Prints "N passed, N failed" at the end. STRAHL=path/to/strahl (default: target/release/strahl,
# built when missing).

set -uo pipefail
export PATH="$PATH:/usr/sbin:/sbin"
cd "$(dirname "$0")/.."
ROOT=$PWD
start_ms=$(date +%s%3N)
seconds() { local ms=$(( $(date +%s%3N) - start_ms )); printf '%d.%d' $((ms / 1000)) $((ms % 1000 / 100)); }
log() { printf 'test-slurm: %s\n' "$*" >&2; }
skip() { log "SKIPPED: $*"; echo "0 passed, 0 failed, 1 skipped"; exit 0; }
fail() { log "FAILED: $*"; echo "0 passed, 1 failed"; exit 1; }

[ "$(id -u)" -eq 0 ] || skip "needs root to install Slurm and start its daemons"

WORK=$(mktemp -d /tmp/strahl-slurm.XXXXXX)
PIDS=()   # pid files of the daemons this script started
cleanup() {
  local status=$?
  for pidfile in "${PIDS[@]}"; do
    [ -f "$pidfile" ] || continue
    local pid; pid=$(cat "$pidfile" 2>/dev/null)
    [ -n "$pid" ] || continue
    kill -TERM "$pid" 2>/dev/null
    for _ in $(seq 50); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
    kill -KILL "$pid" 2>/dev/null
  done
  rm -rf "$WORK"
  exit "$status"
}
trap cleanup EXIT
trap 'exit 130' INT
trap 'exit 143' TERM

# 1. Install.
need=0
for c in slurmctld slurmd sbatch squeue sinfo munge; do command -v "$c" >/dev/null || need=1; done
[ -x /usr/sbin/munged ] || need=1
if [ "$need" -eq 1 ]; then
  command -v apt-get >/dev/null || skip "Slurm is not installed and there is no apt-get"
  log "installing slurmctld slurmd slurm-client munge"
  export DEBIAN_FRONTEND=noninteractive
  apt-get install -y -qq --no-install-recommends slurmctld slurmd slurm-client munge >/dev/null 2>&1 \
    || { apt-get update -qq >/dev/null 2>&1 && apt-get install -y -qq --no-install-recommends slurmctld slurmd slurm-client munge >/dev/null; } \
    || fail "cannot install Slurm"
fi

# 2. strahl.
STRAHL=${STRAHL:-$ROOT/target/release/strahl}
if [ ! -x "$STRAHL" ]; then
  # Build only the default binary: a STRAHL given (`make test-slurm STRAHL=...`) is not rebuilt.
  [ "$STRAHL" = "$ROOT/target/release/strahl" ] || fail "no executable strahl at $STRAHL"
  log "building strahl"
  cargo build --release --locked -q || fail "cannot build strahl"
fi

# 3. munge: a key, its directories owned by munge, the daemon as that user.
if ! munge -n 2>/dev/null | unmunge >/dev/null 2>&1; then
  mkdir -p /etc/munge /var/lib/munge /var/log/munge /run/munge
  [ -s /etc/munge/munge.key ] || mungekey --create >/dev/null 2>&1 || dd if=/dev/urandom of=/etc/munge/munge.key bs=1024 count=1 2>/dev/null
  chown -R munge:munge /etc/munge /var/lib/munge /var/log/munge /run/munge
  chmod 0400 /etc/munge/munge.key
  chmod 0700 /etc/munge
  rm -f /run/munge/munged.pid
  runuser -u munge -- /usr/sbin/munged || fail "munged did not start"
  PIDS+=(/run/munge/munged.pid)
  for _ in $(seq 50); do munge -n 2>/dev/null | unmunge >/dev/null 2>&1 && break; sleep 0.1; done
  munge -n | unmunge >/dev/null 2>&1 || fail "munge does not work"
fi

# 4. Slurm, loopback only, everything under $WORK.
CPUS=8
mkdir -p "$WORK/state" "$WORK/spool" "$WORK/log" "$WORK/out"
CONF=$WORK/slurm.conf
cat >"$CONF" <<EOF
ClusterName=strahltest
SlurmctldHost=localhost
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CommunicationParameters=NoCtldInAddrAny,NoInAddrAny
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
SchedulerParameters=batch_sched_delay=0
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
SlurmdParameters=config_overrides
ReturnToService=2
SlurmctldPort=16817
SlurmdPort=16818
StateSaveLocation=$WORK/state
SlurmdSpoolDir=$WORK/spool
SlurmctldPidFile=$WORK/slurmctld.pid
SlurmdPidFile=$WORK/slurmd.pid
SlurmctldLogFile=$WORK/log/slurmctld.log
SlurmdLogFile=$WORK/log/slurmd.log
NodeName=localhost NodeAddr=127.0.0.1 CPUs=$CPUS RealMemory=1000
PartitionName=debug Nodes=localhost Default=YES MaxTime=INFINITE State=UP
EOF
export SLURM_CONF=$CONF
PIDS+=("$WORK/slurmd.pid" "$WORK/slurmctld.pid")
slurmctld -f "$CONF" || fail "slurmctld did not start (see its log)"
slurmd -f "$CONF" -N localhost || fail "slurmd did not start"
state=""
for _ in $(seq 200); do
  state=$(sinfo -h -n localhost -o %T 2>/dev/null | head -1)
  case "$state" in
    idle) break ;;
    drain*|down*) scontrol update nodename=localhost state=resume >/dev/null 2>&1 ;;
  esac
  sleep 0.1
done
[ "$state" = idle ] || { tail -5 "$WORK/log/slurmctld.log" >&2; fail "the node is '$state', not idle"; }
log "cluster up after $(seconds) s"

# 5. The render: 8 tiles on Slurm, and one process here, with fixed dates. The farm's folder
# has a space, quotes, a '#', Slurm's '%A' and a '$( )' in its name: sbatch must read the
# quoted #SBATCH --output lines as meant, and nothing may run.
export SOURCE_DATE_EPOCH=1700000000
SCENE=$ROOT/scenes/cornell.toml
RENDER=(--width 96 --height 72 --spp 2 --passes all)
OUT="$WORK/out/it's a \"farm\" #1 50%A \$(touch PWNED)"
mkdir -p "$OUT"
cd "$WORK" || fail "no $WORK"
"$STRAHL" render "$SCENE" -o "$WORK/out/single.exr" "${RENDER[@]}" --threads 2 >/dev/null 2>&1 || fail "the single render failed"
ids=$("$STRAHL" farm slurm "$SCENE" -o "$OUT/farm.exr" --tiles 8 --cpus 1 --submit -- "${RENDER[@]}" | tail -1) \
  || fail "strahl farm slurm --submit failed"
read -r array merge <<<"$ids"
log "submitted array $array and merge $merge"

# 6. Wait: poll squeue until neither job is queued or running, then ask sacct (when
# accounting is off it knows nothing, so the merged file decides).
wait_for() {
  for _ in $(seq 1200); do
    [ -z "$(squeue -h -j "$1" 2>/dev/null)" ] && return 0
    sleep 0.1
  done
  fail "the jobs $1 did not finish in 120 s"
}
wait_for "$array,$merge"
sacct -n -j "$array,$merge" -o JobID,State 2>/dev/null | grep -E 'FAILED|CANCELLED|TIMEOUT' && fail "a job failed"
[ -f "$OUT/farm.exr" ] || { cat "$OUT/farm.exr.farm/"*.log >&2 2>/dev/null; fail "no merged image"; }

# 7. Compare; the logs are where the #SBATCH lines name them, and nothing ran.
cmp "$WORK/out/single.exr" "$OUT/farm.exr" || fail "the merged EXR differs from the single-process render"
for f in "render-${array}_1.log" "render-${array}_8.log" "merge-$merge.log"; do
  [ -f "$OUT/farm.exr.farm/$f" ] || { ls -la "$OUT/farm.exr.farm" >&2; fail "no log $f in the farm's folder"; }
done
pwned=$(find "$WORK" "$ROOT" -name PWNED 2>/dev/null | head -1)
[ -z "$pwned" ] || fail "a path ran as a command: $pwned"
log "the 8-tile Slurm render merged equals the single-process render byte for byte ($(seconds) s)"

# 7b. With --denoise: the merge job denoises the merged frame once, which must be the bytes of
# the single-process `render --denoise` (tiles with the passes `--denoise` adds).
if "$STRAHL" denoise --help >/dev/null 2>&1 && "$STRAHL" render "$SCENE" -o "$WORK/out/dn-probe.exr" --width 8 --height 8 --spp 1 --denoise >/dev/null 2>&1; then
  DN=(--width 96 --height 72 --spp 2 --passes default,denoising_albedo,denoising_normal)
  D=$WORK/out/denoised
  mkdir -p "$D"
  "$STRAHL" render "$SCENE" -o "$WORK/out/single-denoised.exr" "${DN[@]}" --denoise --threads 2 >/dev/null 2>&1 \
    || fail "the single render --denoise failed"
  ids=$("$STRAHL" farm slurm "$SCENE" -o "$D/frame.exr" --tiles 8 --cpus 1 --denoise --submit -- "${DN[@]}" | tail -1) \
    || fail "strahl farm slurm --denoise --submit failed"
  read -r array merge <<<"$ids"
  wait_for "$array,$merge"
  [ -f "$D/frame.exr" ] || { cat "$D/frame.exr.farm/"*.log >&2 2>/dev/null; fail "no merged, denoised image"; }
  cmp "$WORK/out/single-denoised.exr" "$D/frame.exr" || fail "the merged, denoised EXR differs from render --denoise"
  log "the 8-tile Slurm render merged and denoised equals render --denoise byte for byte ($(seconds) s)"
  denoised=1
else
  log "this strahl has no OIDN (make oidn): the --denoise run is skipped"
  denoised=0
fi

# 8. After a failed task (tile 3's path is a folder), the merge still runs (afterany) and
# refuses, naming the tile; the two commands of docs/farm.md then finish the same frame.
R=$WORK/out/recover
mkdir -p "$R/frame.exr.farm/tile-3.exr"
ids=$("$STRAHL" farm slurm "$SCENE" -o "$R/frame.exr" --tiles 4 --cpus 1 --submit -- "${RENDER[@]}" | tail -1) \
  || fail "strahl farm slurm --submit failed"
read -r array merge <<<"$ids"
wait_for "$array,$merge"
[ ! -e "$R/frame.exr" ] || fail "merged although task 3 failed"
grep -q "tile-3.exr" "$R/frame.exr.farm/merge-$merge.log" || { cat "$R/frame.exr.farm/merge-$merge.log" >&2; fail "the merge's log does not name tile 3"; }
rmdir "$R/frame.exr.farm/tile-3.exr"
id=$(sbatch --parsable --array=3 "$R/frame.exr.farm/render.sbatch") || fail "cannot resubmit task 3"
merge=$(sbatch --parsable --dependency=afterany:"$id" "$R/frame.exr.farm/merge.sbatch") || fail "cannot resubmit the merge"
wait_for "$id,$merge"
cmp "$WORK/out/single.exr" "$R/frame.exr" || fail "the frame finished after a failed task differs from the single-process render"
log "after a failed task, resubmitting it and the merge gave the same frame ($(seconds) s in all)"
if [ "$denoised" -eq 1 ]; then echo "3 passed, 0 failed"; else echo "2 passed, 0 failed, 1 skipped"; fi
