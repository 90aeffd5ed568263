#!/usr/bin/env bash
# test-slurm.sh: tools/slurm/fleet.sbatch on a one-node SLURM cluster brought up on this machine.
#
#   tools/slurm/test-slurm.sh HOST_SIM [--keep]      (`make test-slurm` calls it)
#
#   1. installs Debian's slurm-wlm and munge when missing (tools/install-deps.sh --slurm);
#   2. in a scratch folder: a new munge key and munged on its own socket, a slurm.conf for one node
#      (this machine, its real CPU count) with slurmctld and slurmd as local daemons (no systemd, no
#      cgroups: proctrack/linuxproc, task/none), ports of their own;
#   3. submits a 4-robot fleet (10 rounds, seed 3) with `sbatch --wait -N 1 -n 4 --overcommit
#      tools/slurm/fleet.sbatch`, waiting at most SLURM_TEST_DEADLINE_S (default 600 s; a hang
#      is a failure: the job is cancelled). SLURM_TEST_NODES=K (1 .. 4, default 1) makes the
#      one machine K nodes (K slurmd, each its own node name and port) and the job -N K, so the
#      peers list spans nodes (tasks in blocks, 2(x2) for K = 2). SLURM_TEST_ROBOTS=N (2 .. 16,
#      default 4) sets the fleet's size; beyond the default plan's 7 tours the job makes its own
#      (host_sim paths gen into RESULTS/tours). SLURM_TEST_PROXY=on sends the robots through one
#      `host_sim zmq-proxy` (the job's ZMQ_PROXY; default auto: the full mesh at these sizes);
#   4. checks it: the job succeeded, every robot_<i>/final.bnn exists, every summary.txt says it
#      was robot i of a keyed fleet of N with the job's run id, and the N final models equal
#      `host_sim fleet --inproc`'s of the same settings (and tours) bit for bit;
#   5. always stops the daemons it started (by their pids) and removes the scratch folder (kept
#      with --keep); on a failure it prints the tails of the daemons' logs and the robots' logs.
# Prints one line per check and "test-slurm: N passed, N failed"; exits 1 on a failure, 2 on bad
# arguments. Not root: prints "skipped: ..." and exits 0 (daemons and packages need root).
set -uo pipefail

ROOT=$(cd "$(dirname "$0")/../.." && pwd)
HOST_SIM=${1:-}
KEEP=0
[ "${2:-}" = "--keep" ] && KEEP=1
N=${SLURM_TEST_ROBOTS:-4} ROUNDS=10 SEED=3
PROXY=${SLURM_TEST_PROXY:-auto}
DEADLINE=${SLURM_TEST_DEADLINE_S:-600}
NODES=${SLURM_TEST_NODES:-1}
case "$NODES" in 1|2|3|4) ;; *) echo "test-slurm: SLURM_TEST_NODES must be 1 .. 4" >&2; exit 2 ;; esac
case "$N" in [2-9]|1[0-6]) ;; *) echo "test-slurm: SLURM_TEST_ROBOTS must be 2 .. 16" >&2; exit 2 ;; esac
[ "$N" -ge "$NODES" ] || { echo "test-slurm: SLURM_TEST_ROBOTS must be at least SLURM_TEST_NODES" >&2; exit 2; }

say() { echo "test-slurm: $*"; }
case "$HOST_SIM" in
    -h|--help) sed -n '2,23p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    ""|-*) echo "usage: tools/slurm/test-slurm.sh HOST_SIM [--keep]  (--help)" >&2; exit 2 ;;
esac
case "$HOST_SIM" in /*) ;; *) HOST_SIM=$PWD/$HOST_SIM ;; esac
if [ "$(id -u)" -ne 0 ]; then
    say "skipped: needs root (installs slurm-wlm and munge, runs munged, slurmctld and slurmd)"
    exit 0
fi
[ -x "$HOST_SIM" ] || { say "$HOST_SIM is not an executable (build first: make)"; exit 2; }
"$ROOT/tools/install-deps.sh" --slurm || { say "cannot install slurm-wlm and munge"; exit 1; }

S=$(mktemp -d /tmp/fleetsim-slurm.XXXXXX) || exit 1
chmod 0755 "$S"
pids=() job=
passed=0 failed=0

show_tail() { # FILE [LINES]
    [ -f "$1" ] || return 0
    echo "----- the end of $1"
    tail -n "${2:-25}" "$1" | sed 's/^/    /'
}

# What a cancelled job may leave behind once the daemons are gone: slurmstepd (it detaches from
# slurmd) and the job's processes (srun, its tasks). Only those with this cluster's SLURM_CONF in
# their environment (set by this script for its daemons and sbatch, nobody else has it) and
# either named slurmstepd or inside a job (SLURM_JOB_ID); never this script or its subshells.
cluster_pids() {
    local d pid env
    for d in /proc/[0-9]*; do
        pid=${d#/proc/}
        [ "$pid" = "$$" ] || [ "$pid" = "$BASHPID" ] && continue
        env=$( { tr '\0' '\n' <"$d/environ"; } 2>/dev/null) || continue
        grep -qxF "SLURM_CONF=$S/slurm.conf" <<<"$env" || continue
        if [ "$(cat "$d/comm" 2>/dev/null)" = slurmstepd ] || grep -q '^SLURM_JOB_ID=' <<<"$env"; then
            echo "$pid"
        fi
    done
}

cleanup() {
    local rc=$? p
    trap - EXIT INT TERM HUP
    if [ -n "$job" ] && [ -n "${SLURM_CONF:-}" ]; then
        # Cancel and let slurmd end the job's steps before the daemons go (bounded).
        scancel "$job" >/dev/null 2>&1
        wait_for 30 job_gone || say "job $job still listed 30 s after scancel"
    fi
    # The daemons this script started, newest first, by pid: TERM, then KILL when still there.
    for ((k = ${#pids[@]} - 1; k >= 0; k--)); do kill -TERM "${pids[$k]}" 2>/dev/null; done
    for _ in $(seq 1 50); do
        alive=0
        for p in "${pids[@]}"; do kill -0 "$p" 2>/dev/null && alive=1; done
        [ "$alive" -eq 0 ] && break
        sleep 0.2
    done
    for p in "${pids[@]}"; do kill -KILL "$p" 2>/dev/null; done
    left=$(cluster_pids | tr '\n' ' ')
    if [ -n "$left" ]; then
        say "killing what the job left behind: pids $left"
        for p in $left; do kill -KILL "$p" 2>/dev/null; done
    fi
    wait 2>/dev/null
    if [ "$KEEP" -eq 1 ]; then
        say "kept $S"
    else
        rm -rf "$S"
    fi
    exit "$rc"
}
job_gone() { [ -z "$(squeue -h -j "$job" 2>/dev/null)" ]; }
trap cleanup EXIT
trap 'say "interrupted"; exit 130' INT TERM HUP

show_logs() {
    show_tail "$S/log/munged.log" 10
    show_tail "$S/log/slurmctld.log" 40
    for f in "$S"/log/slurmd.*.log; do show_tail "$f" 40; done
    show_tail "$S/job.out" 40
    for i in $(seq 0 $((N - 1))); do show_tail "$S/results/log_$i.txt" 15; done
}

ok() { passed=$((passed + 1)); echo "[       OK ] $1"; }
bad() { failed=$((failed + 1)); echo "[  FAILED  ] $1"; }
finish() {
    [ "$failed" -gt 0 ] && show_logs
    say "$passed passed, $failed failed"
    [ "$failed" -eq 0 ]
    exit $?
}
die() { bad "$1"; finish; }

# Stops while waiting for COND (a command) to hold, up to SECONDS; 0 when it holds.
wait_for() { # SECONDS COND...
    local t=$(( $1 * 5 )); shift
    for _ in $(seq 1 "$t"); do "$@" && return 0; sleep 0.2; done
    return 1
}

# ---- munge: a key of our own, munged on its own socket --------------------------------------
mkdir -p "$S/munge" "$S/log" "$S/state" "$S/spool" "$S/results" "$S/run"
chmod 0755 "$S/munge" # munged wants its socket's folder open to every client
dd if=/dev/urandom of="$S/munge/munge.key" bs=1024 count=1 status=none
chmod 0600 "$S/munge/munge.key"
SOCK=$S/munge/munge.socket
munged --force --key-file="$S/munge/munge.key" --socket="$SOCK" --pid-file="$S/munge/munged.pid" \
    --log-file="$S/log/munged.log" --seed-file="$S/munge/munged.seed" --foreground 2>>"$S/log/munged.log" &
pids+=($!)
wait_for 10 test -S "$SOCK" || die "munged started (no socket $SOCK after 10 s)"
if echo fleetsim | munge --socket="$SOCK" | unmunge --socket="$SOCK" >/dev/null 2>&1; then
    ok "munged: a credential made and read back"
else
    die "munged: a credential made and read back"
fi

# ---- slurm.conf: one node, this machine ------------------------------------------------------
NODE=$(hostname -s)
CPUS=$(nproc)
BASE=$((17000 + ($$ % 200) * 16)) # slurmctld, slurmd, srun ports: not 6817/6818 of a real install
cat >"$S/slurm.conf" <<EOF
# Written by tools/slurm/test-slurm.sh: a one-node cluster for one test, then removed.
ClusterName=fleetsimtest
SlurmctldHost=$NODE(127.0.0.1)
SlurmctldPort=$BASE
SlurmdPort=$((BASE + 1))
SrunPortRange=$((BASE + 6))-$((BASE + 15))
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$SOCK
StateSaveLocation=$S/state
SlurmdSpoolDir=$S/spool/%n
SlurmctldPidFile=$S/run/slurmctld.pid
SlurmdPidFile=$S/run/slurmd.%n.pid
SlurmctldLogFile=$S/log/slurmctld.log
SlurmdLogFile=$S/log/slurmd.%n.log
SlurmctldDebug=info
SlurmdDebug=info
PlugStackConfig=$S/plugstack.conf
MailProg=/bin/true
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
MpiDefault=none
SwitchType=switch/none
SchedulerType=sched/builtin
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
SlurmdParameters=config_overrides
ReturnToService=2
MaxTasksPerNode=64
InactiveLimit=0
KillWait=5
MinJobAge=300
SlurmctldTimeout=30
SlurmdTimeout=60
$(if [ "$NODES" -eq 1 ]; then
    echo "NodeName=$NODE NodeAddr=127.0.0.1 CPUs=$CPUS State=UNKNOWN"
else
    for k in $(seq 1 "$NODES"); do
        echo "NodeName=${NODE}-$k NodeHostname=$NODE NodeAddr=127.0.0.1 Port=$((BASE + 1 + k)) CPUs=$CPUS State=UNKNOWN"
    done
fi)
PartitionName=test Nodes=ALL Default=YES MaxTime=30 State=UP OverSubscribe=YES
EOF
: >"$S/plugstack.conf"
export SLURM_CONF=$S/slurm.conf

slurmctld -D -i -f "$SLURM_CONF" >"$S/log/slurmctld.out" 2>&1 &
pids+=($!)
names=("$NODE")
[ "$NODES" -gt 1 ] && names=($(for k in $(seq 1 "$NODES"); do echo "${NODE}-$k"; done))
for n in "${names[@]}"; do
    mkdir -p "$S/spool/$n"
    slurmd -D -N "$n" -f "$SLURM_CONF" >"$S/log/slurmd-$n.out" 2>&1 &
    pids+=($!)
done
node_idle() { [ "$(sinfo -h -N -o %T 2>/dev/null | grep -cx idle)" -eq "$NODES" ]; }
if wait_for 60 node_idle; then
    ok "slurmctld and $NODES slurmd up, node(s) ${names[*]} idle ($CPUS CPUs each)"
else
    show_tail "$S/log/slurmctld.out" 10
    for n in "${names[@]}"; do show_tail "$S/log/slurmd-$n.out" 10; done
    sinfo -N -l 2>&1 | sed 's/^/    /'
    die "slurmctld and $NODES slurmd up, node(s) ${names[*]} idle within 60 s"
fi

# ---- the fleet as a SLURM job -----------------------------------------------------------------
PORT_BASE=$((BASE + 3300)) # the robots: 20300 .. 23499, clear of the daemons' 17000 .. 20199
say "sbatch --wait -N $NODES -n $N --overcommit tools/slurm/fleet.sbatch ROUNDS=$ROUNDS SEED=$SEED (bound: $DEADLINE s)"
t0=$(date +%s)
# sbatch --wait returns with the job's exit status; it runs in the background so that the wait
# is bounded (the job id, printed at submission, lets the cleanup cancel a hung job).
(cd "$ROOT" && exec sbatch --wait --parsable -N "$NODES" -n "$N" --overcommit --time=$(( (DEADLINE + 59) / 60 )) \
    --output="$S/job.out" tools/slurm/fleet.sbatch \
    ROOT="$ROOT" HOST_SIM="$HOST_SIM" RESULTS="$S/results" ROUNDS=$ROUNDS SEED=$SEED PORT_BASE=$PORT_BASE \
    ZMQ_PROXY="$PROXY") \
    >"$S/sbatch.out" 2>"$S/sbatch.err" &
sbatch_pid=$!
wait_for 30 grep -qE '^[0-9]+' "$S/sbatch.out" && job=$(grep -oE '^[0-9]+' "$S/sbatch.out" | head -1)
if [ -z "$job" ]; then
    kill "$sbatch_pid" 2>/dev/null
    show_tail "$S/sbatch.err" 10
    die "sbatch accepted the job within 30 s"
fi
sbatch_done() { ! kill -0 "$sbatch_pid" 2>/dev/null; }
if ! wait_for "$DEADLINE" sbatch_done; then
    kill "$sbatch_pid" 2>/dev/null
    wait "$sbatch_pid" 2>/dev/null
    die "job $job done within $DEADLINE s (a hang is a failure: cancelled)"
fi
wait "$sbatch_pid"
sbatch_rc=$?
wall=$(( $(date +%s) - t0 ))
info=$(scontrol -o show job "$job" 2>/dev/null | grep -oE '(JobState|ExitCode)=[^ ]*' | tr '\n' ' ')
if [ "$sbatch_rc" -eq 0 ]; then
    layout=$(sed -n 's/.* robots on \(.*\), tasks per node \(.*\)/\1, tasks per node \2/p' "$S/job.out" | head -1)
    via=$(grep -q "through one proxy" "$S/job.out" && echo "through one proxy" || echo "full mesh")
    ok "job $job: $N robots over ZeroMQ ($via) on $layout, sbatch --wait exit 0 in $wall s ($info)"
else
    show_tail "$S/sbatch.err" 10
    bad "job $job: sbatch --wait exit $sbatch_rc after $wall s ($info)"
fi
job= # done: nothing to cancel any more

# ---- its results --------------------------------------------------------------------------
RUN_ID=$(cat "$S/results/run_id" 2>/dev/null)
miss=()
for i in $(seq 0 $((N - 1))); do [ -s "$S/results/robot_$i/final.bnn" ] || miss+=("$i"); done
if [ ${#miss[@]} -eq 0 ]; then ok "every robot_<i>/final.bnn written"; else bad "final.bnn missing for robot(s) ${miss[*]}"; fi
wrong=()
for i in $(seq 0 $((N - 1))); do
    f=$S/results/robot_$i/summary.txt
    grep -q "^rounds: $ROUNDS\$" "$f" 2>/dev/null &&
        grep -q "^fleet: $N robots (this is robot $i," "$f" &&
        [ -n "$RUN_ID" ] && grep -q "^keyed fleet (run id 0*$RUN_ID)" "$f" || wrong+=("$i")
done
if [ ${#wrong[@]} -eq 0 ]; then
    ok "every summary.txt: $ROUNDS rounds, robot i of a keyed fleet of $N, run id $RUN_ID"
else
    bad "summary.txt of robot(s) ${wrong[*]} lacks the rounds, the member or the keyed fleet's run id"
fi

# ---- the in-process reference: the same models bit for bit --------------------------------
ref_log=$S/inproc.txt
tours=$ROOT/host_sim/plans/apartment
if [ "$N" -gt 7 ]; then # the job made its own tours
    tours=$S/results/tours
    if [ -f "$tours/robot_$((N - 1)).csv" ]; then ok "the job made $N tours in RESULTS/tours"; else bad "the job made no tours for robots 7 .. $((N - 1)) in $tours"; fi
fi
if timeout "$DEADLINE" "$HOST_SIM" fleet --inproc --plan "$ROOT/host_sim/plans/apartment.svg" \
        --paths "$tours" --robots $N --rounds $ROUNDS --strategy kl --graph disk \
        --radius 6 --seed $SEED --out "$S/inproc" --val-poses 5 --mc 1 --map-res 0.5 >"$ref_log" 2>&1; then
    diff=()
    for i in $(seq 0 $((N - 1))); do
        # the model: the header's network and seed, then theta (n_params at byte 28); the
        # epistemic posterior after it is the robot's own here, the fleet's in the reference
        f="$S/results/robot_$i/final.bnn"
        nparams=$(od -An -tu4 -j28 -N4 "$f" | tr -d ' ')
        { cmp -s -i 12 -n 28 "$f" "$S/inproc/models/robot_$i.bnn" &&
          cmp -s -i 60 -n $((4 * nparams)) "$f" "$S/inproc/models/robot_$i.bnn"; } || diff+=("$i")
    done
    if [ ${#diff[@]} -eq 0 ]; then
        ok "the $N final.bnn equal host_sim fleet --inproc's bit for bit"
    else
        bad "final.bnn of robot(s) ${diff[*]} differ from host_sim fleet --inproc's"
    fi
else
    show_tail "$ref_log" 15
    bad "host_sim fleet --inproc (the reference) ran within $DEADLINE s"
fi
finish
