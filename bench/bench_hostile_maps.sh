#!/bin/bash
# Hostile map files through the commands that read maps (issue 16's first target): a wrapper of
# bench/hostile_maps.py (the maps, the commands and what is counted are described there). Run by
# hand, niced (one core):
#   bash bench/bench_hostile_maps.sh [MAPS=1000] [path/to/lcv] [JOBS=1]
# prints progress on stderr and, at the end, the counts of crashes, hangs, exit-0 outputs that do
# not read back and errors not naming the input; findings go to bench_hostile_maps.jsonl here.
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
maps=${1:-1000}
lcv=${2:-$here/build/lcv}
jobs=${3:-1}
exec nice -n 19 python3 "$here/bench/hostile_maps.py" --maps "$maps" --lcv "$lcv" --jobs "$jobs" \
  --results "${RESULTS:-bench_hostile_maps.jsonl}" --keep "${KEEP:-bench_hostile_maps_failures}"
