#!/usr/bin/env bash
# The workflow on a real Slurm (CTest label `cluster`): starts a one-node cluster of its own on this
# machine (munged, slurmctld, slurmd on localhost as root; keys, configuration, state and logs in a
# temp folder), runs a tiny record (Table 5 on SO-13, seeds 1-2, Handa noise, quick size) once with
# `snakemake --cores 2` and once through workflow/profiles/slurm, and checks that the merged tables
# are byte-identical and that every job went through sbatch. Every daemon it started is stopped and
# the temp folder removed on any exit (trap), also on failure or interruption.
# Usage: run_cluster_test.sh SOURCE_DIR PANOSCAN_BINARY     (exit 77 = skipped: not root / no Slurm)
set -euo pipefail
source_dir="$(cd "$1" && pwd)"
panoscan="$(cd "$(dirname "$2")" && pwd)/$(basename "$2")"

for tool in munged slurmctld slurmd sbatch sinfo snakemake; do
  if ! command -v "$tool" >/dev/null; then
    echo "cluster test skipped: $tool is not installed (bash scripts/setup.sh installs slurm-wlm, munge, snakemake)"
    exit 77
  fi
done
if [ "$(id -u)" -ne 0 ]; then
  echo "cluster test skipped: starting slurmctld and slurmd as their own SlurmUser needs root"
  exit 77
fi

tmp="$(mktemp -d /tmp/panoscan-cluster-XXXXXX)"
chmod 755 "$tmp"  # munged requires every directory above its socket to be searchable by all
started=()
stop_all() {
  local status=$?
  # Stop in reverse order of starting; each daemon wrote its pid file.
  for ((i = ${#started[@]} - 1; i >= 0; i--)); do
    local pidfile="${started[i]}"
    if [ -s "$pidfile" ]; then
      local pid
      pid="$(cat "$pidfile")"
      kill "$pid" 2>/dev/null || true
      for _ in $(seq 50); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
      kill -9 "$pid" 2>/dev/null || true
    fi
  done
  if [ $status -ne 0 ]; then
    for log in "$tmp"/*.log; do [ -f "$log" ] && { echo "--- $log (last lines)"; tail -n 20 "$log"; }; done
  fi
  rm -rf "$tmp"
  exit $status
}
trap stop_all EXIT
trap 'exit 130' INT TERM

# munge: a fresh key and a private socket, so that no system munged or key is touched.
mkdir -p "$tmp/run" "$tmp/state" "$tmp/spool"
chmod 755 "$tmp/run"
dd if=/dev/urandom of="$tmp/munge.key" bs=1024 count=1 status=none
chmod 0400 "$tmp/munge.key"
socket="$tmp/run/munge.socket"
started+=("$tmp/run/munged.pid")
munged --socket="$socket" --key-file="$tmp/munge.key" --log-file="$tmp/munged.log" \
  --pid-file="$tmp/run/munged.pid" --seed-file="$tmp/munged.seed"
munge -n --socket="$socket" | unmunge --socket="$socket" >/dev/null

# Two free TCP ports for slurmctld and slurmd.
read -r ctld_port slurmd_port < <(python3 - <<'PY'
import socket
ports = []
sockets = []
for _ in range(2):
    s = socket.socket()
    s.bind(("127.0.0.1", 0))
    sockets.append(s)
    ports.append(s.getsockname()[1])
print(*ports)
PY
)
host="$(hostname -s)"
# The node as slurmd sees it (CPUs, sockets, memory); config_overrides keeps a VM's odd topology
# from draining it.
node_line="$(slurmd -C | head -n 1)"
export SLURM_CONF="$tmp/slurm.conf"
cat > "$SLURM_CONF" <<CONF
ClusterName=panoscantest
SlurmctldHost=${host}(127.0.0.1)
SlurmUser=root
SlurmdUser=root
SlurmctldPort=${ctld_port}
SlurmdPort=${slurmd_port}
AuthType=auth/munge
AuthInfo=socket=${socket}
CredType=cred/munge
StateSaveLocation=${tmp}/state
SlurmdSpoolDir=${tmp}/spool
SlurmctldPidFile=${tmp}/run/slurmctld.pid
SlurmdPidFile=${tmp}/run/slurmd.pid
SlurmctldLogFile=${tmp}/slurmctld.log
SlurmdLogFile=${tmp}/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core_Memory
SchedulerType=sched/builtin
ReturnToService=2
MpiDefault=none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
SlurmdParameters=config_overrides
${node_line} NodeAddr=127.0.0.1 State=UNKNOWN
PartitionName=test Nodes=ALL Default=YES MaxTime=INFINITE State=UP
CONF
started+=("$tmp/run/slurmctld.pid")
slurmctld -i
started+=("$tmp/run/slurmd.pid")
slurmd
for i in $(seq 60); do
  state="$(sinfo -h -o %T 2>/dev/null || true)"
  [ "$state" = "idle" ] && break
  [ "$i" -eq 60 ] && { echo "cluster test: the node did not become idle in 60 s (state '$state')"; exit 1; }
  sleep 1
done
echo "cluster test: one-node Slurm up ($host, slurmctld port $ctld_port)"

# The same tiny record, locally and through the Slurm profile, each in its own folder.
config=(seeds=1-2 "tables=[table5]" "only=[SO-13]" "noises=[handa]" "scenes=[builtin]" "panoscan=$panoscan")
run_workflow() {  # NAME SNAKEMAKE-OPTIONS...
  local name="$1"
  shift
  mkdir -p "$tmp/$name"
  timeout 900 snakemake -s "$source_dir/workflow/Snakefile" -d "$tmp/$name" "$@" \
    --config "${config[@]}" "out=$tmp/$name/out" > "$tmp/$name.log" 2>&1 ||
    { echo "cluster test: the $name workflow failed:"; tail -n 30 "$tmp/$name.log"; exit 1; }
}
run_workflow local --cores 2
run_workflow slurm --profile "$source_dir/workflow/profiles/slurm"

# Every job of the Slurm run was an sbatch job that ended with status 0 (9: 4 scans, 2 parts, 2 merges... ).
jobs_expected="$(grep -c '^rule \|^localrule ' "$tmp/local.log" || true)"
jobs_completed="$(grep -c 'WEXITSTATUS 0' "$tmp/slurmctld.log" || true)"
echo "cluster test: $jobs_completed Slurm jobs completed with status 0 (the local run had $jobs_expected jobs, 'all' local)"
if [ "$jobs_completed" -ne $((jobs_expected - 1)) ]; then
  echo "cluster test: expected $((jobs_expected - 1)) Slurm jobs"
  exit 1
fi
# The merged tables, byte for byte.
diff -r "$tmp/local/out/record" "$tmp/slurm/out/record"
diff -r "$tmp/local/out/tables" "$tmp/slurm/out/tables"
grep -q ' ± .* (2) |' "$tmp/slurm/out/record/handa/table5/table5.md" ||
  { echo "cluster test: the merged table has no confidence intervals"; exit 1; }
echo "cluster test: the Slurm run's merged tables equal the local run's byte for byte"
