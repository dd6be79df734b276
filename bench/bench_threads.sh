#!/usr/bin/env bash
# Engine threads (issue 14, "Targets"): the threaded engine against the deterministic one.
#
#   bench/bench_threads.sh [--lcv PATH] [--out DIR] [--frames N] [--seed N]
#                          [--models "perspective fisheye equirectangular"] [--no-kitti]
#                          [--kitti-frames A:B:S] [--no-realtime] [--repeat N]
#                          [--realtime-repeat N] [--slam-args "ARGS"]
#   (defaults: build/lcv, /tmp/lcv-bench-threads, 400 frames, seed 1, all three models, KITTI
#    00 (all frames, --kitti-frames A:B:S to select) when /work/shared/data/kitti00 (or $KITTI_DIR) exists, realtime runs on,
#    1 threaded run per input, 1 realtime run per input; --slam-args: added to every threaded
#    lcv slam run, e.g. "--background-nice 0")
#
# Per input (`lcv synth --scenario loop --camera MODEL`, generated into OUT when missing; KITTI):
#  - `lcv slam --deterministic` (the reference; reproducible);
#  - `lcv slam` threaded, fed as fast as tracking returns (REPEAT runs: not reproducible);
#  - `lcv slam --realtime` threaded, fed at the camera's rate (live: frames dropped when
#    tracking falls behind, keyframes refused when mapping does).
# Prints one Markdown row per run: frames tracked (of frames fed, dropped ones counted as not
# tracked), initializations, loops closed, APE (Sim3) RMSE and its ratio to the deterministic
# run, tracking latency median / p90 / p99 / max (ms), the longest map-lock hold per thread
# (tracking / mapping / loop closing, ms), frames dropped, keyframes refused; then p99 / median
# of tracking latency, the tracking thread's own CPU time per frame (median / p99: the work,
# without the time spent waiting for a core; "-" from binaries without it) and the 1-minute
# load average when the run started.
# Every run's stats JSON and trajectory stay in OUT. Times are wall-clock on whatever machine
# runs this: note its load with the numbers.
set -euo pipefail
LCV=build/lcv
OUT=/tmp/lcv-bench-threads
FRAMES=400
SEED=1
MODELS="perspective fisheye equirectangular"
RUN_KITTI=1
KITTI_FRAMES=:
RUN_REALTIME=1
REPEAT=1
REALTIME_REPEAT=1
SLAM_ARGS=""
KITTI_DIR=${KITTI_DIR:-/work/shared/data/kitti00}
while [ $# -gt 0 ]; do
  case "$1" in
    --lcv) LCV=$2; shift 2 ;;
    --out) OUT=$2; shift 2 ;;
    --frames) FRAMES=$2; shift 2 ;;
    --seed) SEED=$2; shift 2 ;;
    --models) MODELS=$2; shift 2 ;;
    --no-kitti) RUN_KITTI=0; shift ;;
    --kitti-frames) KITTI_FRAMES=$2; shift 2 ;;
    --no-realtime) RUN_REALTIME=0; shift ;;
    --repeat) REPEAT=$2; shift 2 ;;
    --realtime-repeat) REALTIME_REPEAT=$2; shift 2 ;;
    --slam-args) SLAM_ARGS=$2; shift 2 ;;
    -h|--help) sed -n '2,26p' "$0"; exit 0 ;;
    *) echo "bench_threads.sh: unknown option '$1' (see --help)" >&2; exit 2 ;;
  esac
done
[ -x "$LCV" ] || { echo "bench_threads.sh: $LCV: not an executable (build the lcv target)" >&2; exit 2; }
mkdir -p "$OUT"

# name dataset extra_args...
declare -a INPUTS=()
for model in $MODELS; do
  dir="$OUT/loop${FRAMES}_${model}_seed${SEED}"
  if [ ! -f "$dir/scene.json" ]; then
    "$LCV" synth --scenario loop --camera "$model" --frames "$FRAMES" --seed "$SEED" --out "$dir" \
      > "$dir.synth.log" 2>&1 || { echo "bench_threads.sh: lcv synth failed, see $dir.synth.log" >&2; exit 1; }
  fi
  INPUTS+=("loop_${model}|$dir|")
done
if [ "$RUN_KITTI" = 1 ] && [ -d "$KITTI_DIR" ]; then
  INPUTS+=("kitti00|$KITTI_DIR|--frames $KITTI_FRAMES")
fi

# run NAME DATASET MODE_ARGS EXTRA -> OUT/NAME.json
run() {
  local name=$1 dataset=$2 mode=$3 extra=$4
  [ "$mode" = "--deterministic" ] || extra="$extra $SLAM_ARGS"
  cut -d' ' -f1 /proc/loadavg > "$OUT/$name.load" 2>/dev/null || echo "-" > "$OUT/$name.load"
  # shellcheck disable=SC2086
  if ! "$LCV" slam --dataset "$dataset" $extra $mode --trajectory-out "$OUT/$name.txt" \
      --stats-out "$OUT/$name.json" > "$OUT/$name.log" 2>&1; then
    echo "bench_threads.sh: lcv slam failed for $name, see $OUT/$name.log" >&2
    return 1
  fi
}

row() {
  python3 - "$@" <<'EOF'
import json, sys
name, path, ref_path = sys.argv[1], sys.argv[2], sys.argv[3]
s = json.load(open(path))
try:
    load = open(path[:-len(".json")] + ".load").read().strip()
except OSError:
    load = "-"
cpu = s.get("tracking_cpu_ms")
ref = json.load(open(ref_path))
fed = s["frames"] + s.get("frames_dropped", 0)
ape = s.get("ape_sim3", {}).get("rmse")
ref_ape = ref.get("ape_sim3", {}).get("rmse")
ratio = f"{ape / ref_ape:.2f}" if ape and ref_ape else "-"
t = s["tracking_ms"]
lock = s.get("map_lock_ms", {})
def lk(k):
    v = lock.get(k, {})
    return f"{v.get('max', 0):.3f}" if v.get("count", 0) else "-"
print(f"| {name} | {s['tracked']}/{fed} ({100.0 * s['tracked'] / fed:.1f}%) | "
      f"{s['initializations']} | {s.get('loops_closed', 0)} | "
      f"{ape:.3f} m | {ratio} | "
      f"{t['median']:.1f} / {t['p90']:.1f} / {t['p99']:.1f} / {t['max']:.1f} | "
      f"{lk('tracking')} / {lk('mapping')} / {lk('loop_closing')} | "
      f"{s.get('frames_dropped', 0)} | {s.get('keyframes_refused', 0)} | "
      f"{t['p99'] / t['median']:.2f} | "
      + (f"{cpu['median']:.1f} / {cpu['p99']:.1f}" if cpu else "-") +
      f" | {load} |" if ape else
      f"| {name} | {s['tracked']}/{fed} | {s['initializations']} | {s.get('loops_closed', 0)} | - | - | - | - | - | - | - | - | {load} |")
EOF
}

echo "| run | tracked | inits | loops closed | APE Sim3 | APE / det. | tracking ms median / p90 / p99 / max | map lock max ms (tracking / mapping / loop) | frames dropped | keyframes refused | p99 / median | tracking CPU ms median / p99 | load |"
echo "|---|---|---|---|---|---|---|---|---|---|---|---|---|"
for input in "${INPUTS[@]}"; do
  IFS='|' read -r name dataset extra <<< "$input"
  run "${name}_det" "$dataset" "--deterministic" "$extra"
  row "${name} deterministic" "$OUT/${name}_det.json" "$OUT/${name}_det.json"
  for r in $(seq 1 "$REPEAT"); do
    run "${name}_threads_$r" "$dataset" "" "$extra"
    row "${name} threads, as fast as possible (run $r)" "$OUT/${name}_threads_$r.json" "$OUT/${name}_det.json"
  done
  if [ "$RUN_REALTIME" = 1 ]; then
    for r in $(seq 1 "$REALTIME_REPEAT"); do
      run "${name}_realtime_$r" "$dataset" "--realtime" "$extra"
      row "${name} threads, --realtime (run $r)" "$OUT/${name}_realtime_$r.json" "$OUT/${name}_det.json"
    done
  fi
done
