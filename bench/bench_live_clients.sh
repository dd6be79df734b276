#!/bin/bash
# Live LC-VSLAM clients: `lcv slam --realtime` (frames at the sequence's own rate, dropped when
# tracking is behind, keyframes refused when mapping is) on the cases bench/bench_lcvslam.sh
# built, for what the deterministic benchmark cannot show: refused keyframes, interrupted local
# BAs, keyframes re-anchored after the map moved, dropped frames (docs/slam.md "Threads").
#
#   bench/bench_live_clients.sh [--lcv PATH] [--runs N] [--kitti DIR] [--clients "lines points"]
#                               [--config FILE] [--gap A:B [--retime]] CASE_DIR...
#   (defaults: build/lcv, 3 runs, /work/shared/data/kitti00 or $KITTI_DIR, both clients)
#
# --gap A:B: the client sequence without its frames [A, B) (bench/gap_dataset.py; --retime: the
# timestamps renumbered, so the camera jumps), an interrupted camera for the line-cloud check
# (docs/slam.md "The line-cloud check on a live camera"); results in D/live_gap_A_B[_retime]/.
# On kitti00, A:B counts the client's (even) frames and becomes the frame selection
# 0:2A:2,2B::2 of the dataset (true timestamps; --retime is for rendered cases only).
# --config FILE is passed to every client (lcv slam --config).
#
# A case directory D is one of bench_lcvslam.sh's --out DIR/CASE (D/lines.lcmap, D/aligned.lcmap,
# D/client_gt.txt and the rendered D/scene/client); a case named kitti00 runs the KITTI
# dataset's even frames against D/client_gt_sel.txt. Each client (lines, points) runs N times, one
# run at a time: live timing needs the machine to itself. The runs differ (thread timing), so
# the table gives each one and their median. APE in the server frame (no alignment); "(c)" marks
# a run whose trajectory ended in a new map's own frame (the map registered in the line cloud was
# lost), where that APE means nothing. Results: D/live/KIND_RUN.{txt,json,log}; the table on
# stdout, progress on stderr.
#
# Example: bash bench/bench_lcvslam.sh --out /tmp/b --seeds "1 2"
#          bash bench/bench_live_clients.sh --runs 3 /tmp/b/*_s* /tmp/b/kitti00
set -euo pipefail

LCV=build/lcv
RUNS=3
KITTI_DIR=${KITTI_DIR:-/work/shared/data/kitti00}
CLIENTS="lines points"
CONFIG=
GAP=
RETIME=
CASES=()
while [ $# -gt 0 ]; do
  case "$1" in
    --lcv) LCV=$2; shift 2 ;;
    --runs) RUNS=$2; shift 2 ;;
    --kitti) KITTI_DIR=$2; shift 2 ;;
    --clients) CLIENTS=$2; shift 2 ;;
    --config) CONFIG=$(realpath "$2"); shift 2 ;;
    --gap) GAP=$2; shift 2 ;;
    --retime) RETIME=--retime; shift ;;
    -h|--help) sed -n '2,28p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    -*) echo "bench_live_clients: unknown option $1 (see --help)" >&2; exit 2 ;;
    *) CASES+=("$1"); shift ;;
  esac
done
[ ${#CASES[@]} -gt 0 ] || { echo "bench_live_clients: no case directory (see --help)" >&2; exit 2; }
[ -x "$LCV" ] || { echo "bench_live_clients: $LCV is not an executable lcv" >&2; exit 1; }
LCV=$(realpath "$LCV")
for kind in $CLIENTS; do
  case "$kind" in lines|points) ;; *) echo "bench_live_clients: --clients: unknown client $kind" >&2; exit 2 ;; esac
done
[ -z "$RETIME" ] || [ -n "$GAP" ] || { echo "bench_live_clients: --retime needs --gap" >&2; exit 2; }
if [ -n "$GAP" ]; then
  [[ "$GAP" =~ ^[0-9]+:[0-9]+$ ]] || { echo "bench_live_clients: --gap A:B, got $GAP" >&2; exit 2; }
  LIVE_DIR=live_gap_${GAP/:/_}${RETIME:+_retime}
else
  LIVE_DIR=live
fi
HERE=$(cd "$(dirname "$0")" && pwd)

# The client's ground truth of a case (KITTI: its even frames).
case_gt() { if [ "$(basename "$1")" = kitti00 ]; then echo "$1/client_gt_sel.txt"; else echo "$1/client_gt.txt"; fi; }
# Every case is checked before any run: a typo should not surface after an hour of runs.
for d in "${CASES[@]}"; do
  for f in "$d/lines.lcmap" "$d/aligned.lcmap" "$(case_gt "$d")"; do
    [ -s "$f" ] || { echo "bench_live_clients: $f is missing (run bench/bench_lcvslam.sh first)" >&2; exit 1; }
  done
  if [ -n "$RETIME" ] && [ "$(basename "$d")" = kitti00 ]; then
    echo "bench_live_clients: --retime works on rendered cases only, not $d" >&2; exit 2
  fi
done

for d in "${CASES[@]}"; do
  case=$(basename "$d")
  gt=$(case_gt "$d")
  mkdir -p "$d/$LIVE_DIR"
  if [ "$case" = kitti00 ] && [ -n "$GAP" ]; then
    dataset=(--dataset "$KITTI_DIR" --frames "0:$((2 * ${GAP%:*})):2,$((2 * ${GAP#*:}))::2")
  elif [ "$case" = kitti00 ]; then
    dataset=(--dataset "$KITTI_DIR" --frames 0::2)
  elif [ -n "$GAP" ]; then
    rm -rf "$d/$LIVE_DIR/client"
    python3 "$HERE/gap_dataset.py" "$d/scene/client" "$d/$LIVE_DIR/client" --drop "$GAP" $RETIME >/dev/null
    dataset=(--dataset "$d/$LIVE_DIR/client")
    gt=$d/$LIVE_DIR/client/groundtruth.txt
  else
    dataset=(--dataset "$d/scene/client")
  fi
  for run in $(seq 1 "$RUNS"); do
    for kind in $CLIENTS; do
      map=$d/lines.lcmap; [ "$kind" = points ] && map=$d/aligned.lcmap
      out=$d/$LIVE_DIR/${kind}_$run
      echo "[bench_live_clients] $case: $kind client, live run $run/$RUNS" >&2
      rm -f "$out.txt" "$out.json" "$out.ape.json"  # a failed run must not show an older one's
      "$LCV" slam "${dataset[@]}" --realtime --map-in "$map" ${CONFIG:+--config "$CONFIG"} \
        --trajectory-out "$out.txt" --stats-out "$out.json" >"$out.log" 2>&1 ||
        echo "[bench_live_clients] $case: $kind run $run failed (see $out.log)" >&2
      "$LCV" eval ape --gt "$gt" --est "$out.txt" --align none --json >"$out.ape.json" 2>/dev/null ||
        echo '{}' >"$out.ape.json"
    done
  done
done

python3 - "$RUNS" "$LIVE_DIR" "$CLIENTS" "${CASES[@]}" <<'PY'
import json, os, statistics, sys
runs, live_dir, clients = int(sys.argv[1]), sys.argv[2], sys.argv[3].split()
def load(path):
    try:
        with open(path) as f:
            return json.load(f)
    except (OSError, ValueError):
        return {}
print("| case | client | APE m per run (median) | tracked / dropped | keyframes / refused / re-anchored | local BAs stopped early / run | p6L checks / cut short / re-tracked | tracking ms median / max |")
print("|---|---|---|---|---|---|---|---|")
for d in sys.argv[4:]:
    for kind in clients:
        apes, texts = [], []
        cells = {"tracked": [], "dropped": [], "kf": [], "refused": [], "reanchored": [],
                 "stopped": [], "local": [], "checks": [], "cut": [], "adopted": [], "ms": [],
                 "max_ms": []}
        for run in range(1, runs + 1):
            base = os.path.join(d, live_dir, f"{kind}_{run}")
            stats, ape = load(base + ".json"), load(base + ".ape.json")
            own_frame = stats.get("relocalized") and not stats.get("trajectory_in_line_cloud_frame", True)
            if "rmse" in ape:
                texts.append(f"{ape['rmse']:.3f}" + (" (c)" if own_frame else ""))
                if not own_frame:
                    apes.append(ape["rmse"])
            if not stats:
                continue
            ba = stats.get("bundle_adjustment", {})
            cells["tracked"].append(stats.get("tracked", 0))
            cells["dropped"].append(stats.get("frames_dropped", 0))
            cells["kf"].append(stats.get("keyframes", 0))
            cells["refused"].append(stats.get("keyframes_refused", 0))
            cells["reanchored"].append(stats.get("keyframes_reanchored", 0))
            cells["stopped"].append(ba.get("local_stopped_early", 0))
            cells["local"].append(ba.get("local_runs", 0))
            cells["checks"].append(stats.get("line_cloud_checks", 0))
            cells["cut"].append(stats.get("line_cloud_checks_cut_short", 0))
            cells["adopted"].append(stats.get("line_cloud_check_adoptions", 0))
            cells["ms"].append(stats.get("tracking_ms", {}).get("median", 0.0))
            frames = stats.get("per_frame", [])
            cells["max_ms"].append(max((f.get("tracking_ms", 0.0) for f in frames), default=0.0))
        j = lambda key: ",".join(str(v) for v in cells[key])
        ape_text = (" ".join(texts) or "-") + (f" ({statistics.median(apes):.3f})" if apes else "")
        print(f"| {os.path.basename(d)} | {kind} | {ape_text} | {j('tracked')} / {j('dropped')} | "
              f"{j('kf')} / {j('refused')} / {j('reanchored')} | {j('stopped')} / {j('local')} | "
              f"{j('checks')} / {j('cut')} / {j('adopted')} | "
              + ",".join(f"{v:.1f}" for v in cells["ms"]) + " / "
              + ",".join(f"{v:.0f}" for v in cells["max_ms"]) + " |")
PY
