#!/usr/bin/env bash
# The default job of `make run`. The fleet (N host_sim processes over LCM) is on the
# roadmap; until it exists this says so instead of pretending.
set -euo pipefail
bin=${1:-build/bin}
echo "fleetsim: built into $bin."
echo "fleetsim: the multi-robot fleet run does not exist yet; nothing was launched." >&2
exit 0
