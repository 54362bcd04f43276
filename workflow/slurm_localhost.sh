#!/usr/bin/env bash
# A one-node SLURM cluster on this machine (Debian's slurm-wlm and munge; needs root), the quick build
# run through it with profiles/slurm, and a check that its report matches a local quick build apart
# from timings. Prints both wall times.
#
#     bash workflow/slurm_localhost.sh [OUT_DIR]      (default /tmp/ik-slurm)
#
# OUT_DIR/slurm and OUT_DIR/local receive the two builds (LOCAL_RESULTS=DIR reuses an existing local
# quick build instead of running one). Run from the repository root with the project's venv active
# (`pip install -e '.[cluster]'` adds snakemake-executor-plugin-slurm). Idempotent: a running cluster
# is reused.
set -euo pipefail
cd "$(dirname "$0")/.."
OUT="${1:-/tmp/ik-slurm}"
mkdir -p "$OUT"
[ "$(id -u)" = 0 ] || { echo "error: needs root (installs packages, starts munged, slurmctld, slurmd)"; exit 2; }
export DEBIAN_FRONTEND=noninteractive

# --- 1. packages -------------------------------------------------------------------------------------
if ! command -v slurmctld >/dev/null || ! command -v munged >/dev/null; then
    apt-get update
    apt-get install -y --no-install-recommends slurm-wlm munge
fi
python -c "import snakemake_executor_plugin_slurm" 2>/dev/null || pip install -q 'snakemake-executor-plugin-slurm>=2.8,<3'

# --- 2. munge ----------------------------------------------------------------------------------------
if [ ! -s /etc/munge/munge.key ]; then
    dd if=/dev/urandom bs=1 count=1024 of=/etc/munge/munge.key status=none
fi
chown munge:munge /etc/munge/munge.key && chmod 400 /etc/munge/munge.key
mkdir -p /run/munge && chown munge:munge /run/munge
if ! munge -n </dev/null | unmunge >/dev/null 2>&1; then
    runuser -u munge -- /usr/sbin/munged --force
    sleep 1
fi
munge -n </dev/null | unmunge >/dev/null

# --- 3. slurm.conf (one node: this machine's CPUs and memory) and the daemons ------------------------
CPUS=$(nproc)
MEM=$(( $(awk '/MemTotal/ {print $2}' /proc/meminfo) / 1024 - 512 ))
mkdir -p /etc/slurm /var/lib/slurm/slurmctld /var/lib/slurm/slurmd /var/log/slurm
cat > /etc/slurm/slurm.conf <<EOF
# written by workflow/slurm_localhost.sh: a one-node cluster on localhost
ClusterName=ik-localhost
SlurmctldHost=localhost
SlurmUser=root
AuthType=auth/munge
MpiDefault=none
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
ReturnToService=2
SlurmctldPidFile=/run/slurmctld.pid
SlurmdPidFile=/run/slurmd.pid
SlurmdSpoolDir=/var/lib/slurm/slurmd
StateSaveLocation=/var/lib/slurm/slurmctld
SlurmctldLogFile=/var/log/slurm/slurmctld.log
SlurmdLogFile=/var/log/slurm/slurmd.log
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_Core_Memory
AccountingStorageType=accounting_storage/none
JobAcctGatherType=jobacct_gather/none
JobCompType=jobcomp/none
MinJobAge=600
SlurmctldTimeout=30
SlurmdTimeout=30
NodeName=localhost NodeHostname=$(hostname) CPUs=$CPUS RealMemory=$MEM State=UNKNOWN
PartitionName=debug Nodes=localhost Default=YES MaxTime=INFINITE State=UP
EOF
if ! scontrol ping 2>/dev/null | grep -q "is UP"; then
    slurmctld
    sleep 2
fi
pgrep -x slurmd >/dev/null || slurmd -N localhost
for _ in $(seq 60); do
    sinfo -h -o %T 2>/dev/null | grep -q -E "idle|mix|alloc" && break
    scontrol update NodeName=localhost State=RESUME >/dev/null 2>&1 || true
    sleep 2
done
sinfo
srun -N1 -n1 hostname >/dev/null  # the cluster runs a job

# --- 4. the quick build through SLURM, and a local one -------------------------------------------------
# no accounting database on this one-node cluster: job states come from squeue
rm -rf "$OUT/slurm"
t0=$(date +%s)
snakemake --profile profiles/slurm --slurm-status-command squeue --slurm-init-seconds-before-status-checks 5 \
    --config scale=quick "results_dir=$OUT/slurm" > "$OUT/slurm.log" 2>&1 \
    || { tail -n 40 "$OUT/slurm.log"; exit 1; }
slurm_s=$(( $(date +%s) - t0 ))
LOCAL="${LOCAL_RESULTS:-$OUT/local}"
local_s="-"
if [ -z "${LOCAL_RESULTS:-}" ]; then
    rm -rf "$LOCAL"
    t0=$(date +%s)
    snakemake --config scale=quick "results_dir=$LOCAL" > "$OUT/local.log" 2>&1 || { tail -n 40 "$OUT/local.log"; exit 1; }
    local_s=$(( $(date +%s) - t0 ))
fi
jobs=$(grep -c "submitted with SLURM jobid" "$OUT/slurm.log" || true)
echo "SLURM quick build: ${slurm_s} s (${jobs} SLURM jobs); local quick build: ${local_s} s"

# --- 5. same report apart from timings ---------------------------------------------------------------
python -m pipeline verify "$OUT/slurm"
PYTHONPATH="$PWD${PYTHONPATH:+:$PYTHONPATH}" python workflow/scripts/compare_builds.py "$LOCAL" "$OUT/slurm"
