#!/usr/bin/env bash
# `make run-inproc`: the IN-PROCESS DiNNO fleet on the default plan, the reference of the
# multi-process fleet (`make run`, tools/fleet): the same seed gives the same models.
#
#   tools/run-fleet.sh [BIN_DIR]        (BIN_DIR defaults to build/bin)
#
# 1. drives each of the 7 robots along its tour (host_sim/plans/apartment/robot_<i>.csv) in
#    the ODE world and writes its lidar samples (host_sim scan),
# 2. builds the validation set (host_sim valset: val_poses random free poses x 500 points),
# 3. trains 7 BNNs (preset of the build) with DiNNO, the default strategy (`kl`, paper
#    Algorithm 2), over a Euclidean disk graph (radius_m) rebuilt every round, in one process
#    (host_sim fleet --inproc),
# 4. leaves everything in results/: samples/, valset.samples, metrics.csv, map_mean.png,
#    map_std.png (fleet_map_res_m grid), val_loss.png (when Debian's python3 has matplotlib),
#    summary.txt.
# The defaults are the binary's (`host_sim defaults`: fleet_robots, fleet_rounds, seed,
# radius_m, val_poses, strategy, metrics_rows, fleet_map_res_m), as tools/fleet's.
# Environment overrides: ROUNDS (default fleet_rounds), SEED (default seed), RESULTS (default
# results), THREADS (default 2), RADIUS (default radius_m).
# Why 6 m: each robot sweeps its own room, so at 4 m the graph is split in ~80 % of the rounds
# and the models drift apart between meetings (seed 1, 2000 rounds: validation loss 0.123 at
# round 300, 0.168 at the end, wall IoU 0.04); at 6 m it stays connected (10-17 of 21 edges)
# and 1500 rounds reach validation loss 0.072 and wall IoU 0.86 in ~2.5 min on 2 cores.
set -euo pipefail
bin=${1:-build/bin}
hs="$bin/host_sim"
die() { echo "run-fleet: $*" >&2; exit 1; }
# def KEY: KEY's value in `host_sim defaults` (read once into $defaults).
def() {
    local v
    v=$(sed -n "s/^$1=//p" <<<"$defaults")
    [ -n "$v" ] || die "$hs defaults has no $1 (an older build?): rebuild it (make)"
    printf '%s\n' "$v"
}
if [[ "${1:-}" == -h || "${1:-}" == --help ]]; then
    sed -n '2,/^set -euo/{/^set -euo/d;s/^# \{0,1\}//;p}' "$0"
    hs=build/bin/host_sim
    if [ -x "$hs" ] && defaults=$("$hs" defaults 2>/dev/null); then
        echo "This build's ($hs defaults): robots $(def fleet_robots), ROUNDS $(def fleet_rounds), SEED $(def seed)," \
            "RADIUS $(def radius_m) m, strategy $(def strategy), map grid $(def fleet_map_res_m) m."
    fi
    exit 0
fi
[ -x "$hs" ] || die "$hs not found; build first (make)"
defaults=$("$hs" defaults) || die "$hs has no \`defaults\` command (an older build?): rebuild it (make)"
rounds=${ROUNDS:-$(def fleet_rounds)}
seed=${SEED:-$(def seed)}
out=${RESULTS:-results}
threads=${THREADS:-2}
radius=${RADIUS:-$(def radius_m)}
robots=$(def fleet_robots)
strategy=$(def strategy)
val_poses=$(def val_poses)
metrics_rows=$(def metrics_rows)
map_res=$(def fleet_map_res_m)
plan=host_sim/plans/apartment.svg
paths=host_sim/plans/apartment
[[ "$rounds" =~ ^[1-9][0-9]{0,6}$ ]] || die "ROUNDS must be a whole number from 1, got '$rounds'"
[[ "$seed" =~ ^[0-9]{1,18}$ ]] || die "SEED must be a whole number, got '$seed'"
[[ "$threads" =~ ^[1-9][0-9]?$ ]] || die "THREADS must be a whole number from 1, got '$threads'"
[[ "$radius" =~ ^[0-9]+(\.[0-9]+)?$ ]] || die "RADIUS must be a distance in metres, got '$radius'"
[ -f "$plan" ] || { echo "run-fleet: default plan $plan is missing" >&2; exit 1; }
for i in $(seq 0 $((robots - 1))); do
    [ -f "$paths/robot_$i.csv" ] || { echo "run-fleet: $paths/robot_$i.csv is missing" >&2; exit 1; }
done

echo "fleetsim: IN-PROCESS fleet (all $robots robots in one host_sim process; make run runs one process per robot)."
mkdir -p "$out/samples"
echo "fleetsim: [1/3] scanning the $robots paths of $plan (seed $seed)"
for i in $(seq 0 $((robots - 1))); do
    "$hs" scan --plan "$plan" --path "$paths/robot_$i.csv" --robot "$i" --seed "$seed" \
        --out "$out/samples/robot_$i.samples" -q
done
echo "fleetsim: [2/3] validation set"
"$hs" valset --plan "$plan" --poses "$val_poses" --seed "$seed" --out "$out/valset.samples"
echo "fleetsim: [3/3] DiNNO (strategy $strategy, disk graph $radius m), $rounds rounds"
"$hs" fleet --inproc --plan "$plan" --paths "$paths" --robots "$robots" --rounds "$rounds" \
    --strategy "$strategy" --graph disk --radius "$radius" --seed "$seed" --threads "$threads" \
    --metrics-every $(( rounds >= metrics_rows ? rounds / metrics_rows : 1 )) --map-res "$map_res" \
    --samples "$out/samples" --valset "$out/valset.samples" --out "$out"
plot=""
if /usr/bin/python3 -c 'import matplotlib, numpy' 2>/dev/null; then
    /usr/bin/python3 tools/plot_metrics.py --skip-first --log --title "DiNNO $strategy, $robots robots" \
        --out "$out/val_loss.png" "$out" >/dev/null && plot="val_loss.png"
else
    echo "fleetsim: no loss plot (Debian python3-matplotlib is missing; tools/install-deps.sh installs it)"
fi
echo "fleetsim: results in $(cd "$out" && pwd):"
echo "  metrics.csv  map_mean.png  map_std.png  $plot  summary.txt  samples/  valset.samples"
