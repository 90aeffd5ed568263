#!/usr/bin/env bash
# The default job of `make run`: the IN-PROCESS DiNNO fleet on the default plan.
#
#   tools/run-fleet.sh [BIN_DIR]        (BIN_DIR defaults to build/bin)
#
# 1. drives each of the 7 robots along its tour (host_sim/plans/apartment/robot_<i>.csv) in
#    the ODE world and writes its lidar samples (host_sim scan),
# 2. builds the validation set (host_sim valset: 500 random free poses x 500 points),
# 3. trains 7 BNNs (preset of the build) with DiNNO, strategy `kl` (paper Algorithm 2), over a
#    Euclidean disk graph rebuilt every round, in one process (host_sim fleet --inproc),
# 4. leaves everything in results/: samples/, valset.samples, metrics.csv, map_mean.png,
#    map_std.png, summary.txt.
# Environment overrides: ROUNDS (default 600), SEED (default 1), RESULTS (default results),
# THREADS (default 2).
# This is the in-process fleet; the multi-process fleet (one host_sim per robot over LCM) is
# on the roadmap.
set -euo pipefail
bin=${1:-build/bin}
rounds=${ROUNDS:-600}
seed=${SEED:-1}
out=${RESULTS:-results}
threads=${THREADS:-2}
plan=host_sim/plans/apartment.svg
paths=host_sim/plans/apartment
robots=7
hs="$bin/host_sim"
[ -x "$hs" ] || { echo "run-fleet: $hs not found; build first (make)" >&2; exit 1; }
[ -f "$plan" ] || { echo "run-fleet: default plan $plan is missing" >&2; exit 1; }
for i in $(seq 0 $((robots - 1))); do
    [ -f "$paths/robot_$i.csv" ] || { echo "run-fleet: $paths/robot_$i.csv is missing" >&2; exit 1; }
done

echo "fleetsim: IN-PROCESS fleet (all $robots robots in one host_sim process)."
echo "fleetsim: the multi-process LCM fleet (one host_sim per robot) is on the roadmap, not run here."
mkdir -p "$out/samples"
echo "fleetsim: [1/3] scanning the $robots paths of $plan (seed $seed)"
for i in $(seq 0 $((robots - 1))); do
    "$hs" scan --plan "$plan" --path "$paths/robot_$i.csv" --robot "$i" --seed "$seed" \
        --out "$out/samples/robot_$i.samples" -q
done
echo "fleetsim: [2/3] validation set"
"$hs" valset --plan "$plan" --poses 500 --seed "$seed" --out "$out/valset.samples"
echo "fleetsim: [3/3] DiNNO (strategy kl, disk graph 4 m), $rounds rounds"
"$hs" fleet --inproc --plan "$plan" --paths "$paths" --robots "$robots" --rounds "$rounds" \
    --strategy kl --graph disk --radius 4 --seed "$seed" --threads "$threads" \
    --metrics-every $(( rounds >= 20 ? rounds / 20 : 1 )) \
    --samples "$out/samples" --valset "$out/valset.samples" --out "$out"
echo "fleetsim: results in $(cd "$out" && pwd):"
echo "  metrics.csv  map_mean.png  map_std.png  summary.txt  samples/  valset.samples"
echo "  plot: /usr/bin/python3 tools/plot_metrics.py --out $out/val_loss.png $out"
