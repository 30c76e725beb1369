#!/usr/bin/env bash
# A single-node Slurm cluster on this machine, for trying examples/slurm/ and for the test that runs
# them for real (tests/merge.rs; CI calls this script from .ci/run). Debian/Ubuntu, as root, without
# systemd (containers): installs munge and Slurm, writes a minimal slurm.conf for one node,
# "localhost" on 127.0.0.1 with this machine's CPUs, starts munged, slurmctld and slurmd in the
# background and waits until `sinfo` shows the node idle. Running it again while the cluster is up
# does nothing (jobs keep running); after a change of this script's configuration it restarts the
# daemons. A slurm.conf that this script did not write (a real cluster's) makes it stop untouched.
#
#   scripts/slurm-local.sh          # start (or check) the cluster
#   scripts/slurm-local.sh stop     # stop the daemons this script started
#
# Everything it writes lives in /etc/slurm/slurm.conf, /var/spool/ftpd3d-slurm and
# /var/log/ftpd3d-slurm. Jobs run as root: Slurm allows that unless DisableRootJobs=YES.
set -euo pipefail

spool=/var/spool/ftpd3d-slurm
logs=/var/log/ftpd3d-slurm
conf=/etc/slurm/slurm.conf

die() {
    echo "slurm-local: $*" >&2
    exit 1
}

[ "$(id -u)" -eq 0 ] || die "run as root (it installs packages and starts daemons)"

# The daemons this script starts, by the pid files they write.
pid_of() {
    local f=$1 pid
    [ -f "$f" ] || return 1
    pid=$(cat "$f" 2>/dev/null) || return 1
    [ -n "$pid" ] && alive "$pid" && echo "$pid"
}

# Running, not just a zombie that its parent has not reaped yet.
alive() {
    kill -0 "$1" 2>/dev/null && ! grep -q '^[0-9]* ([^)]*) Z' "/proc/$1/stat" 2>/dev/null
}

stop() {
    local f pid
    for f in "$spool/slurmd.pid" "$spool/slurmctld.pid" /run/munge/munged.pid; do
        if pid=$(pid_of "$f"); then
            kill "$pid"
            for _ in $(seq 50); do alive "$pid" || break; sleep 0.1; done
        fi
    done
}

if [ "${1:-}" = stop ]; then
    stop
    echo "slurm-local: stopped"
    exit 0
fi

if ! command -v slurmctld >/dev/null || ! command -v slurmd >/dev/null \
    || ! command -v sbatch >/dev/null || ! command -v munged >/dev/null; then
    echo "slurm-local: installing slurmctld, slurmd, slurm-client and munge" >&2
    export DEBIAN_FRONTEND=noninteractive
    apt-get update -qq
    apt-get install -y -qq --no-install-recommends slurmctld slurmd slurm-client munge >/dev/null
fi

# The configuration: one node with this machine's CPUs and (a little less than) its memory, one
# partition, no cgroups (containers rarely allow them), no accounting.
cpus=$(nproc)
mem_mb=$(awk '/^MemTotal:/ { print int($2 / 1024 * 0.9) }' /proc/meminfo)
new_conf=$(
    cat <<EOF
# Written by ftpd3d's scripts/slurm-local.sh: a single-node cluster on this machine.
ClusterName=ftpd3d-local
SlurmctldHost=localhost(127.0.0.1)
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
MpiDefault=none
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
SchedulerType=sched/backfill
# Schedule as soon as jobs are queued or end (the default waits up to 3 s between passes).
SchedulerParameters=batch_sched_delay=0
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
ReturnToService=2
StateSaveLocation=$spool/ctld
SlurmdSpoolDir=$spool/d
SlurmctldPidFile=$spool/slurmctld.pid
SlurmdPidFile=$spool/slurmd.pid
SlurmctldLogFile=$logs/slurmctld.log
SlurmdLogFile=$logs/slurmd.log
SlurmctldPort=6817
SlurmdPort=6818
# Finished jobs stay visible to scontrol for 10 minutes (the test reads their states).
MinJobAge=600
NodeName=localhost NodeAddr=127.0.0.1 CPUs=$cpus RealMemory=$mem_mb State=UNKNOWN
PartitionName=debug Nodes=localhost Default=YES MaxTime=INFINITE State=UP
EOF
)

node_state() {
    timeout 5 sinfo -h -n localhost -o %T 2>/dev/null | head -n 1
}

marker=$(printf '%s\n' "$new_conf" | head -n 1)
if [ -f "$conf" ] && [ "$(head -n 1 "$conf")" != "$marker" ]; then
    die "$conf was not written by this script; it leaves a real cluster's configuration alone"
fi
# Up already (idle, or busy with jobs, which a restart would kill): nothing to do.
if [ -f "$conf" ] && [ "$(cat "$conf")" = "$new_conf" ] \
    && pid_of "$spool/slurmctld.pid" >/dev/null && pid_of "$spool/slurmd.pid" >/dev/null; then
    case "$(node_state)" in
        idle | mixed | allocated | completing)
            echo "slurm-local: already running; node localhost $(node_state)"
            exit 0
            ;;
    esac
fi

stop
mkdir -p /etc/slurm "$spool/ctld" "$spool/d" "$logs"
printf '%s\n' "$new_conf" >"$conf"

# munge: a key (the package's postinst makes one; make one if it is missing), then the daemon, as
# the munge user, which owns the key.
if [ ! -s /etc/munge/munge.key ]; then
    mungekey --create --keyfile=/etc/munge/munge.key
    chown munge:munge /etc/munge/munge.key
    chmod 600 /etc/munge/munge.key
fi
mkdir -p /run/munge
chown munge:munge /run/munge
chmod 755 /run/munge
if ! pid_of /run/munge/munged.pid >/dev/null; then
    rm -f /run/munge/munge.socket.2 /run/munge/munge.socket.2.lock
    runuser -u munge -- munged
fi
munge -n | unmunge >/dev/null || die "munge does not work (see /var/log/munge/munged.log)"

# slurmctld and slurmd daemonise themselves; slurmd is told its node name, as the machine's host
# name is not "localhost".
slurmctld
for _ in $(seq 100); do
    timeout 5 scontrol ping 2>/dev/null | grep -q 'is UP' && break
    sleep 0.2
done
timeout 5 scontrol ping | grep -q 'is UP' || die "slurmctld did not come up; see $logs/slurmctld.log"
slurmd -N localhost

state=""
for _ in $(seq 150); do
    state=$(node_state)
    [ "$state" = idle ] && break
    sleep 0.2
done
if [ "$state" != idle ]; then
    sinfo -N -l >&2 || true
    die "node localhost is '${state:-unknown}', not idle; see $logs/slurmd.log and $logs/slurmctld.log"
fi
echo "slurm-local: node localhost idle ($cpus CPUs)"
