#!/bin/bash
# Hostile map files through the commands that read maps (issue 16's targets): mutates the map
# seeds of fuzz/seeds/map (fuzz/make_corpus.py), runs `map info`, `map convert` (and `map info`
# on its output), `render`, `audit` and `slam --map-in --map-out` (on a 3-frame rendered
# sequence with the seeds' camera size; `map info` on its output) on each with a 10 s limit, and prints the counts of
# crashes (killed by a signal), hangs (10 s), exit-0 outputs that do not read back, and failures
# whose message does not name the input file. Run by hand:
#   bash bench/bench_hostile_maps.sh [MUTATIONS_PER_SEED=250] [path/to/lcv]
set -uo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
per_seed=${1:-250}
lcv=${2:-$here/build/lcv}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
python3 "$here/fuzz/make_corpus.py" --only map --map-per-seed "$per_seed" --out "$work/corpus" > /dev/null
files=("$work"/corpus/map/*)
crashes=0 hangs=0 unreadable=0 unnamed=0 runs=0 accepted=0
check() {  # check FILE ARGS...: one run; updates the counters
  local file=$1; shift
  timeout 10 "$lcv" "$@" > /dev/null 2> "$work/err"
  local rc=$?
  runs=$((runs + 1))
  if [ $rc -eq 124 ]; then hangs=$((hangs + 1)); echo "hang: lcv $*";
  elif [ $rc -ge 128 ]; then crashes=$((crashes + 1)); echo "crash ($rc): lcv $*";
  elif [ $rc -ne 0 ] && ! grep -qF -- "$file" "$work/err"; then
    unnamed=$((unnamed + 1)); echo "unnamed: lcv $*: $(head -c 200 "$work/err")"
  fi
  return $rc
}
"$lcv" synth --scenario tracking --frames 3 --size 64x48 --out "$work/synth" > /dev/null 2>&1
start=$(date +%s)
for f in "${files[@]}"; do
  check "$f" map info "$f" && accepted=$((accepted + 1))
  rm -f "$work/out.lcmap"
  if check "$f" map convert --to-lines "$f" "$work/out.lcmap"; then
    if ! "$lcv" map info "$work/out.lcmap" > /dev/null 2>&1; then
      unreadable=$((unreadable + 1)); echo "unreadable output: map convert $f"
    fi
  fi
  check "$f" render "$f" --out "$work/out.png" --size 160x90
  check "$f" audit "$f" --report "$work/report.json"
  rm -f "$work/slam.lcmap"
  if check "$f" slam --dataset "$work/synth/map" --map-in "$f" --map-out "$work/slam.lcmap" \
       --trajectory-out "$work/t.txt" --deterministic; then
    if ! "$lcv" map info "$work/slam.lcmap" > /dev/null 2>&1; then
      unreadable=$((unreadable + 1)); echo "unreadable output: slam --map-in $f"
    fi
  fi
done
echo "inputs ${#files[@]} (accepted by map info: $accepted), runs $runs in $(( $(date +%s) - start )) s"
echo "crashes $crashes, hangs $hangs, unreadable outputs $unreadable, errors not naming the file $unnamed"
