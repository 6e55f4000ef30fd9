#!/usr/bin/env bash
# A planned study's slurm.sbatch on a real one-node Slurm on localhost: Debian's slurm-wlm and
# munge, started here with private configuration, key, spool and socket under a temporary
# directory (nothing in /etc is touched), the array submitted and waited for, the study
# collected, and only the daemons this script started stopped. Run by .ci/run as root (or with
# sudo available); its one argument is the groundscope binary.
set -euo pipefail
gs="$(realpath "$1")"
if [ "$(id -u)" = 0 ]; then SUDO=""; else SUDO="sudo"; fi
if ! command -v sbatch >/dev/null 2>&1 || ! command -v munged >/dev/null 2>&1; then
  echo "   (installing slurm-wlm and munge)"
  $SUDO apt-get update -qq && $SUDO apt-get install -y -qq slurm-wlm munge >/dev/null
fi

work="$(mktemp -d)"
chmod 755 "$work"
pids=()
cleanup() {
  for p in "${pids[@]}"; do $SUDO kill "$p" 2>/dev/null || true; done
  sleep 1
  for p in "${pids[@]}"; do $SUDO kill -9 "$p" 2>/dev/null || true; done
  $SUDO rm -rf "$work"
}
trap cleanup EXIT

# munge: its own key (a private directory) and socket, pid, seed and log (a directory every
# user can reach, as munged requires of its socket's), run as the munge user.
mkdir -p "$work/munge-key" "$work/munge"
$SUDO mungekey -c -k "$work/munge-key/munge.key" >/dev/null
$SUDO chown -R munge:munge "$work/munge-key" "$work/munge"
$SUDO chmod 700 "$work/munge-key"
$SUDO chmod 400 "$work/munge-key/munge.key"
$SUDO chmod 755 "$work/munge"
sock="$work/munge/munge.socket"
if [ -z "$SUDO" ]; then as_munge=(runuser -u munge --); else as_munge=(sudo -u munge); fi
"${as_munge[@]}" /usr/sbin/munged --key-file="$work/munge-key/munge.key" --socket="$sock" \
  --pid-file="$work/munge/munged.pid" --log-file="$work/munge/munged.log" \
  --seed-file="$work/munge/munged.seed"
for _ in $(seq 50); do [ -S "$sock" ] && [ -s "$work/munge/munged.pid" ] && break; sleep 0.1; done
pids+=("$(cat "$work/munge/munged.pid")")

mkdir -p "$work/spool/ctld" "$work/spool/d" "$work/log"
cat > "$work/slurm.conf" <<CONF
ClusterName=gsci
SlurmctldHost=localhost
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
AuthInfo=socket=$sock
CredType=cred/munge
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
ReturnToService=2
StateSaveLocation=$work/spool/ctld
SlurmdSpoolDir=$work/spool/d
SlurmctldPidFile=$work/slurmctld.pid
SlurmdPidFile=$work/slurmd.pid
SlurmctldPort=16817
SlurmdPort=16818
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
MpiDefault=none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
NodeName=localhost CPUs=$(nproc) RealMemory=2000 State=UNKNOWN
PartitionName=debug Nodes=localhost Default=YES MaxTime=INFINITE State=UP
CONF
export SLURM_CONF="$work/slurm.conf"
$SUDO env SLURM_CONF="$SLURM_CONF" slurmctld -D -f "$SLURM_CONF" >"$work/log/ctld.txt" 2>&1 &
pids+=($!)
$SUDO env SLURM_CONF="$SLURM_CONF" slurmd -D -f "$SLURM_CONF" >"$work/log/d.txt" 2>&1 &
pids+=($!)
for _ in $(seq 100); do
  sinfo -h -o %t 2>/dev/null | grep -q idle && break
  sleep 0.2
done
sinfo -h -o "%P %t" | grep -q idle || { cat "$work/log/"*.txt; echo "slurm did not come up"; exit 1; }

cat > "$work/study.toml" <<'SPEC'
seeds = [1, 2, 3]
frames = 128
eval = ["--seeds", "1", "--episodes", "4"]

[recipes]
tiny = ["--procs", "4", "--frames-per-proc", "16", "--batch-size", "32", "--hidden", "16",
        "--eval-interval", "0", "--size", "5", "--objects", "1", "--tasks", "goto", "--no-done"]

[levels]
paper = { train = [], eval = ["--sizes", "5", "--objects", "1"] }
SPEC
"$gs" study plan "$work/study.toml" --out "$work/study" >/dev/null
grep -q -- "--array=0-2" "$work/study/slurm.sbatch"
# The plan makes slurm-logs/ (the script's --output directory): nothing is made by hand here.
[ -d "$work/study/slurm-logs" ] || { echo "study plan did not make slurm-logs/"; exit 1; }
$SUDO env SLURM_CONF="$SLURM_CONF" sbatch --wait "$work/study/slurm.sbatch" >/dev/null
for s in 1 2 3; do
  [ -f "$work/study/runs/tiny-paper-s$s/study-done.json" ] || {
    cat "$work/study/slurm-logs/"* "$work/study/runs/tiny-paper-s$s/study.log" 2>/dev/null || true
    echo "run tiny-paper-s$s did not finish under Slurm"; exit 1; }
done
[ "$(ls "$work/study/slurm-logs" | wc -l)" = 3 ] || { echo "expected one log per array task"; exit 1; }
"$gs" study collect "$work/study" | grep -q "collected 3 finished runs of 3"
echo "   slurm: a 3-task array ran the study's lines; collect read 3 finished runs"
