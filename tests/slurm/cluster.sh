#!/usr/bin/env bash
# A single-node Slurm cluster on this machine, and modalflow on it.
#
# Installs Debian's slurm-wlm and munge (if missing), starts munged, slurmctld
# and slurmd on localhost with a configuration under $WORK (nothing in
# /etc/slurm is touched), then:
#   1. runs tests/slurm/gsa_study.yaml (a CI-sized PUB2 screening) locally
#      and with `--executor slurm`, its GSA sharded into 4 array tasks, in
#      two separate caches, and checks that every result file is identical;
#   2. measures what a job costs: a no-op stage run locally, through the
#      stand-in scheduler of tests/slurm/fake (modalflow's own overhead) and
#      through Slurm (submission to completion), and a batch of 8 such stages;
#   3. a retry: a stage that needs 110 s under `time: "1 * attempt"` times
#      out at attempt 1 and succeeds at attempt 2 (about 4 minutes);
#   4. a submitter killed with -9 while its job runs: the next run adopts
#      the job instead of submitting it again;
#   5. counts every scheduler call (sbatch, sacct, squeue, scancel) of each
#      step through logging wrappers, and prints the traces.
# With --accounting it also installs MariaDB and slurmdbd, so job states come
# from sacct (as on production clusters); without, from squeue.
# Stops the daemons it started at the end (keep them with --keep).
# Takes about two minutes once modalflow is built.
#
# Needs root (apt-get, daemons) on Debian 12 or later. Not part of CI.
# Usage: tests/slurm/cluster.sh [--accounting] [--keep]   (WORK defaults to /tmp/modalflow-slurm)
set -euo pipefail

repo=$(cd "$(dirname "$0")/../.." && pwd)
work=${WORK:-/tmp/modalflow-slurm}
keep=""
accounting=""
for arg in "$@"; do
    case "$arg" in
        --keep) keep=--keep ;;
        --accounting) accounting=1 ;;
        *) echo "usage: $0 [--accounting] [--keep]" >&2; exit 2 ;;
    esac
done
host=$(hostname -s)
say() { printf '\n== %s\n' "$*"; }

[ "$(id -u)" -eq 0 ] || { echo "run as root (installs packages, starts daemons)" >&2; exit 2; }

say "packages"
if ! command -v slurmctld > /dev/null || ! command -v munged > /dev/null; then
    apt-get update -qq
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq slurm-wlm munge > /dev/null
fi
if [ -n "$accounting" ] && ! command -v slurmdbd > /dev/null; then
    apt-get update -qq
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq mariadb-server slurmdbd > /dev/null
fi
slurmctld -V

say "munge"
if [ ! -s /etc/munge/munge.key ]; then
    mungekey --create --keyfile=/etc/munge/munge.key
    chown munge:munge /etc/munge/munge.key
    chmod 600 /etc/munge/munge.key
fi
mkdir -p /run/munge /var/log/munge /var/lib/munge
chown munge:munge /run/munge /var/log/munge /var/lib/munge
started_munge=""
if ! munge -n > /dev/null 2>&1; then
    runuser -u munge -- /usr/sbin/munged
    started_munge=1
    sleep 1
fi
munge -n | unmunge | grep -q 'STATUS: *Success' && echo "munge works"

say "slurm configuration in $work"
rm -rf "$work"
mkdir -p "$work/etc" "$work/state/ctld" "$work/state/d" "$work/log" "$work/run"
cpus=$(nproc)
memory=$(slurmd -C | sed -n 's/.*RealMemory=\([0-9]*\).*/\1/p')
export SLURM_CONF="$work/etc/slurm.conf"
storage=none
gather=jobacct_gather/none
if [ -n "$accounting" ]; then
    storage=slurmdbd
    gather=jobacct_gather/linux # MaxRSS and CPU time per job step
fi
cat > "$SLURM_CONF" <<EOF
ClusterName=modalflow
SlurmctldHost=$host(127.0.0.1)
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
StateSaveLocation=$work/state/ctld
SlurmdSpoolDir=$work/state/d
SlurmctldPidFile=$work/run/slurmctld.pid
SlurmdPidFile=$work/run/slurmd.pid
SlurmctldLogFile=$work/log/slurmctld.log
SlurmdLogFile=$work/log/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
SchedulerType=sched/backfill
MpiDefault=none
ReturnToService=2
AccountingStorageType=accounting_storage/$storage
AccountingStorageHost=localhost
JobAcctGatherType=$gather
JobCompType=jobcomp/none
NodeName=$host NodeAddr=127.0.0.1 CPUs=$cpus RealMemory=$memory State=UNKNOWN
PartitionName=debug Nodes=ALL Default=YES MaxTime=INFINITE State=UP
EOF

stop() {
    for d in slurmd slurmctld slurmdbd; do
        if [ -s "$work/run/$d.pid" ]; then
            kill "$(cat "$work/run/$d.pid")" 2> /dev/null || true
        fi
    done
    if [ -n "$started_munge" ] && [ -s /run/munge/munged.pid ]; then
        kill "$(cat /run/munge/munged.pid)" 2> /dev/null || true
    fi
    if [ -n "$started_mariadb" ]; then
        service mariadb stop > /dev/null 2>&1 || true
    fi
}
started_mariadb=""
if [ "$keep" != "--keep" ]; then
    trap stop EXIT
fi

if [ -n "$accounting" ]; then
    say "accounting: MariaDB and slurmdbd"
    if ! mysqladmin ping > /dev/null 2>&1; then
        service mariadb start > /dev/null
        started_mariadb=1
    fi
    # A throwaway database on localhost, new for every run (job ids restart at 1).
    mysql -e "DROP DATABASE IF EXISTS modalflow_acct; CREATE DATABASE modalflow_acct;
        CREATE USER IF NOT EXISTS 'modalflow'@'localhost' IDENTIFIED BY 'modalflow';
        GRANT ALL ON modalflow_acct.* TO 'modalflow'@'localhost';"
    cat > "$work/etc/slurmdbd.conf" <<EOF
AuthType=auth/munge
DbdHost=localhost
SlurmUser=root
StorageType=accounting_storage/mysql
StorageHost=localhost
StorageUser=modalflow
StoragePass=modalflow
StorageLoc=modalflow_acct
PidFile=$work/run/slurmdbd.pid
LogFile=$work/log/slurmdbd.log
EOF
    chmod 600 "$work/etc/slurmdbd.conf"
    slurmdbd
    for _ in $(seq 30); do
        sacctmgr -n list cluster > /dev/null 2>&1 && break
        sleep 1
    done
    sacctmgr -i add cluster modalflow > /dev/null
fi

say "start slurmctld and slurmd"
slurmctld -f "$SLURM_CONF"
slurmd -f "$SLURM_CONF"
for _ in $(seq 60); do
    state=$(sinfo -h -N -o %T 2> /dev/null | head -n 1)
    [ "$state" = idle ] && break
    case "$state" in down* | drain*) scontrol update nodename="$host" state=resume || true ;; esac
    sleep 1
done
sinfo
[ "$state" = idle ] || { echo "the node did not come up; see $work/log" >&2; exit 1; }

say "build modalflow"
(cd "$repo" && cargo build --release -q)
mf="$repo/target/release/modalflow"

# Logging wrappers in front of the scheduler's commands: calls.log gets one
# line per call, so each step's calls are counted.
mkdir -p "$work/bin"
for c in sbatch sacct squeue scancel; do
    real=$(command -v "$c")
    printf '#!/bin/sh\necho "%s $*" >> "%s/calls.log"\nexec "%s" "$@"\n' "$c" "$work" "$real" > "$work/bin/$c"
    chmod +x "$work/bin/$c"
done
export PATH="$work/bin:$PATH"
calls() { # label: count and reset the calls since the last count
    local f="$work/calls.log"
    touch "$f"
    printf 'scheduler calls, %s: sbatch %s, sacct %s, squeue %s, scancel %s\n' "$1" \
        "$(grep -c '^sbatch ' "$f")" "$(grep -c '^sacct ' "$f")" "$(grep -c '^squeue ' "$f")" "$(grep -c '^scancel ' "$f")"
    : > "$f"
}

ms() { # command... -> wall milliseconds
    local t0
    t0=$(date +%s%N)
    "$@" > /dev/null
    echo $((($(date +%s%N) - t0) / 1000000))
}

say "CI-sized GSA study, local"
study="$repo/tests/slurm/gsa_study.yaml"
local_ms=$(ms "$mf" run "$study" --executor local --cache "$work/local/cache" --results "$work/local/results" --progress lines)

say "CI-sized GSA study, --executor slurm (GSA in 4 array tasks)"
: > "$work/calls.log"
slurm_ms=$(ms "$mf" run "$study" --executor slurm --cache "$work/slurm/cache" --results "$work/slurm/results" --progress lines)
calls "GSA study"
cat "$work/slurm/results/slurm_gsa/trace.csv"
if [ -n "$accounting" ]; then
    sleep 2
    sacct -X -o JobID,JobName%28,State,Elapsed,ExitCode
else
    squeue -h -t all -o '%.12i %.28j %.10T %.8M' | sort -n
fi

say "compare results (every file but the manifests, which hold run times)"
diff -r -x manifest.json -x 'trace*' -x run.log "$work/local/results" "$work/slurm/results"
for stage in truth gsa report; do
    a=$(grep -o '"hash": "[0-9a-f]*"' "$work/local/results/slurm_gsa/$stage/manifest.json" | sort)
    b=$(grep -o '"hash": "[0-9a-f]*"' "$work/slurm/results/slurm_gsa/$stage/manifest.json" | sort)
    [ "$a" = "$b" ] || { echo "output hashes of $stage differ" >&2; exit 1; }
done
echo "identical: every result file and output hash of truth, gsa, report"

say "what a job costs (wall milliseconds, 5 runs each)"
noop="$work/noop"
mkdir -p "$noop/bin"
{
    echo "name: noop"
    echo "stages:"
    for i in 1 2 3 4 5 6 7 8; do
        echo "  s$i: {kind: command, params: {cmd: \"echo $i > o$i.txt\", outs: [o$i.txt]}}"
    done
} > "$noop/batch.yaml"
printf 'name: one\nstages:\n  s: {kind: command, params: {cmd: "echo 1 > one.txt", outs: [one.txt]}}\n' > "$noop/one.yaml"
fake="$repo/tests/slurm/fake"
# The stand-in sbatch, keeping a copy of the job description it is handed.
printf '#!/bin/sh\nfor a in "$@"; do script="$a"; done\ncp "$(dirname "$script")/job.json" "%s/job.json"\nexec "%s/sbatch" "$@"\n' \
    "$noop" "$fake" > "$noop/bin/sbatch"
chmod +x "$noop/bin/sbatch"
for executor in local stand-in slurm; do
    times=""
    for _ in 1 2 3 4 5; do
        case $executor in
            local) t=$(ms "$mf" run "$noop/one.yaml" --executor local --force s --cache "$noop/c-local" --progress none) ;;
            stand-in) t=$(FAKE_SLURM_DIR="$noop/fake" PATH="$noop/bin:$fake:$PATH" ms "$mf" run "$noop/one.yaml" --executor slurm --force s --cache "$noop/c-fake" --progress none) ;;
            slurm) t=$(ms "$mf" run "$noop/one.yaml" --executor slurm --force s --cache "$noop/c-slurm" --progress none) ;;
        esac
        times="$times $t"
    done
    echo "run of one no-op stage, executor $executor:$times"
done
key=$(sed -n 's/^  "key": "\([0-9a-f]*\)".*/\1/p' "$noop/job.json")
times=""
for _ in 1 2 3 4 5; do
    rm -f "$noop/c-fake/runs/$key.json"
    times="$times $(ms "$mf" exec --cache "$noop/c-fake" "$noop/job.json")"
done
echo "modalflow exec of that stage (run and commit):$times"
times=""
for _ in 1 2 3 4 5; do
    times="$times $(ms "$mf" exec --cache "$noop/c-fake" "$noop/job.json")"
done
echo "modalflow exec of that stage, already cached:$times"
for executor in local slurm; do
    t=$(ms "$mf" run "$noop/batch.yaml" --executor "$executor" --cache "$noop/c-batch-$executor" --progress none)
    echo "run of 8 independent no-op stages, executor $executor: $t"
done

say "16 independent stages of 5 s (poll: 30): scheduler calls"
many="$work/many"
mkdir -p "$many"
{
    echo "name: many"
    echo "executor: {kind: slurm, poll: 30}"
    echo "stages:"
    for i in $(seq 16); do
        echo "  s$i: {kind: command, params: {cmd: \"sleep 5; echo $i > o$i.txt\", outs: [o$i.txt]}}"
    done
} > "$many/p.yaml"
: > "$work/calls.log"
many_ms=$(ms "$mf" run "$many/p.yaml" --cache "$many/cache" --results "$many/results" --progress none)
calls "16 stages in $many_ms ms"

say "retry: attempt 1 times out (1 min), attempt 2 (2 min) succeeds"
retry="$work/retry"
mkdir -p "$retry"
printf 'name: retry\nexecutor: {kind: slurm, poll: 10, retries: 1, time: "1 * attempt"}\nstages:\n  slow: {kind: command, params: {cmd: "sleep 110; echo ok > r.txt", outs: [r.txt]}}\n' > "$retry/p.yaml"
: > "$work/calls.log"
retry_ms=$(ms "$mf" run "$retry/p.yaml" --cache "$retry/cache" --results "$retry/results" --progress lines)
calls "retry in $retry_ms ms"
cat "$retry/results/retry/trace.csv"
grep -q '^ok$' "$retry/r.txt" && echo "retry: attempt 2 committed the result"

say "submitter killed with -9 while its job runs; the next run adopts it"
kill9="$work/kill9"
mkdir -p "$kill9"
printf 'name: adopt\nexecutor: {kind: slurm, poll: 5}\nstages:\n  long: {kind: command, params: {cmd: "sleep 20; echo done > a.txt", outs: [a.txt]}}\n' > "$kill9/p.yaml"
: > "$work/calls.log"
"$mf" run "$kill9/p.yaml" --cache "$kill9/cache" --results "$kill9/results" --progress none &
submitter=$!
for _ in $(seq 60); do
    squeue -h -t running -o %j | grep -q 'modalflow:long' && break
    sleep 1
done
kill -9 "$submitter"
wait "$submitter" 2> /dev/null || true
squeue -h -o '%.10i %.20j %.8T'
"$mf" status "$kill9/p.yaml" --cache "$kill9/cache" --results "$kill9/results"
"$mf" run "$kill9/p.yaml" --cache "$kill9/cache" --results "$kill9/results" --progress lines
calls "kill -9 and adoption (both runs)"
cat "$kill9/results/adopt/trace.csv"

say "summary"
echo "GSA study wall time: local $local_ms ms, slurm $slurm_ms ms"
echo "logs: $work/log; cluster left running: ${keep:-no}"
