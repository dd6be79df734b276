#!/usr/bin/env bash
# LC-VSLAM client targets (issue 11, "Targets"; issue 12 Table 1 for the p6L baseline).
#
#   bench/bench_lcvslam.sh [--lcv PATH] [--out DIR] [--frames N] [--seeds "1 2"] [--quick]
#                          [--models "perspective fisheye equirectangular"] [--no-kitti]
#                          [--p6l-frames A:B:S] [--reuse-maps] [--server-poses sim3|ground-truth]
#                          [--client-config FILE] [--timing-runs N] [--ape-runs N] [--width W]
#                          [--scenario overlap|tracking]
#   (defaults: build/lcv, /tmp/lcv-bench-lcvslam, 100 frames, seeds "1", all three models,
#    KITTI included, p6L on client frames 0::4 (a frame that fails costs ~1000 p6L samples);
#    --quick: 40 frames, seed 1, perspective only, no KITTI;
#    --width W: synthetic images W pixels wide, W x 9W/16 (equirectangular W x W/2; default
#    640); KITTI keeps its own size; the 15 ms bound is checked at 640 only (the issue's size);
#    --reuse-maps: keep the server maps (aligned.lcmap, lines.$LINES_EXT) a previous run left in
#    OUT instead of rebuilding them: for iterating on the client only, not after a change to
#    the server's SLAM, `map transform` or `map convert`; a map made with other
#    --server-poses is re-published from the kept SLAM map);
#    --server-poses: how the server map gets into the ground truth's frame: sim3 (default, the
#    issue's protocol: `lcv map transform --sim3-align-to`) or ground-truth (the paper's Sec. 4.1:
#    also --ground-truth-poses, keyframes on the ground truth and points refined by BA);
#    --client-config: `lcv slam --config FILE` for both clients (not the server map), e.g. for
#    an A/B of a LineCloud key on the same maps with --reuse-maps;
#    --timing-runs N (default 1): run both clients N times, alternating which goes first, and
#    report each one's tracking time as the smallest of its N per-run medians (all of them are
#    printed and kept in results.json). On this 2-vCPU VM a run's median moves by up to 35%
#    with the machine's state over tens of seconds (ORB extraction, the same work in both
#    clients, took 4.5 or 6.1 ms per frame in consecutive runs), more than the 1.2x target
#    leaves; interference only adds time, so the least disturbed run is the measurement
#    (Python's timeit reports the minimum for the same reason). A second estimator is printed
#    beside it: the median over k of run k's line median over run k's point median. The two runs
#    of a pair are adjacent in time, so a slow phase that covers both cancels in their ratio,
#    where the two smallest medians may come from different phases. The issue asks for the
#    time "measured in the same run": the pass column reads the paired median (results.json:
#    time_ratio_paired_median, pass.time_ratio_1_2_and_15ms; the smallest medians' verdict is
#    pass.time_ratio_smallest_medians_1_2). APE and everything else come
#    from run 1 (the runs are --deterministic, so their trajectories are the same));
#    --scenario (default overlap, the issue's pairs): `lcv synth --scenario` of the pairs. With
#    tracking the client stays inside the server map all along (Table 1's pair), so the two
#    clients are compared on what each makes of the map, without the monocular drift beyond
#    its end that dominates an overlap pair's APE; cases are then named tracking_MODEL_sSEED;
#    --ape-runs N (default 1): run both clients N times with the ORB feature count perturbed
#    (run k >= 2: the default count of run 1 times 1 -2%, +2%, -4%, +4%, ...; --num-features)
#    and report each one's APE as the median of its N runs (ORB-SLAM's papers report the
#    median of 5 runs). Why: most of each client trajectory is monocular mapping beyond the
#    server map, whose drift is chaotic; a 2% change of the feature count moves either
#    client's APE on one pair by up to 4x (docs/benchmarks-lcvslam.md, "Both clients vary"), so
#    one --deterministic run per pair cannot compare the two maps. The runs are deterministic:
#    the same command gives the same numbers.
#
# For each camera model (perspective, fisheye, equirectangular) and seed:
#  1. `lcv synth --scenario overlap` (or --scenario; 640x360; equirectangular 640x320; --width
#     changes both);
#  2. server map: `lcv slam --deterministic` on DIR/map, moved into the ground truth's frame
#     (`lcv map transform --sim3-align-to DIR/map/groundtruth.txt`), published as a line cloud
#     (`lcv map convert --to-lines`);
#  3. the client (`lcv slam --deterministic`) on DIR/client twice: `--map-in LINES` and
#     `--map-in ALIGNED` (the same map unconverted, 3D points);
#  4. each client trajectory evaluated with `lcv eval ape --align none` (server frame; plotted
#     over the ground truth in CASE/ape_lines.png and ape_points.png), and the line client's X'
#     against the hidden points (`lcv audit --client --reference`).
# KITTI (/work/shared/data/kitti00, or $KITTI_DIR): map from the odd frames, client on the even.
# The perspective pair also runs the p6L baseline (`lcv localize`, every client frame on its own).
# Prints a Markdown table, writes OUT/results.json; every intermediate file stays in OUT. A second
# table splits run 1's tracking time: ORB extraction against the rest, and the line client's
# frames inside the cloud against those leaving it (results.json: time_split_run1). A third
# splits run 1's APE the same way: both clients' position error over the line client's frames
# inside the cloud and over the frames after it (results.json: ape_split_run1).
# Times are wall-clock per frame on whatever machine runs this: note its load with the numbers.
set -euo pipefail
# Everything runs inside main(), which bash parses whole before running it, and the script
# exits on main's own line (the end of the file): editing this file while a run is under way
# then cannot change what that run executes (a line inserted above the loop once made a
# running bench execute the middle of a line and lose its report; with main() alone, another
# edit made a finished bench read on from the old offset and start its pairs again).
main() {
LCV=build/lcv
OUT=/tmp/lcv-bench-lcvslam
FRAMES=100
SEEDS="1"
QUICK=0
MODELS="perspective fisheye equirectangular"
RUN_KITTI=1
P6L_FRAMES=0::4
REUSE_MAPS=0
CLIENT_CONFIG=
TIMING_RUNS=1
APE_RUNS=1
SCENARIO=overlap
KITTI_DIR=${KITTI_DIR:-/work/shared/data/kitti00}
while [ $# -gt 0 ]; do
  case "$1" in
    --lcv) LCV=$2; shift 2 ;;
    --out) OUT=$2; shift 2 ;;
    --frames) FRAMES=$2; shift 2 ;;
    --seeds) SEEDS=$2; shift 2 ;;
    --quick) QUICK=1; shift ;;
    --models) MODELS=$2; shift 2 ;;
    --no-kitti) RUN_KITTI=0; shift ;;
    --p6l-frames) P6L_FRAMES=$2; shift 2 ;;
    --reuse-maps) REUSE_MAPS=1; shift ;;
    --server-poses) export LCV_SERVER_POSES=$2; shift 2 ;;
    --client-config) CLIENT_CONFIG=$2; shift 2 ;;
    --timing-runs) TIMING_RUNS=$2; shift 2 ;;
    --ape-runs) APE_RUNS=$2; shift 2 ;;
    --width) export LCV_SYNTH_WIDTH=$2; shift 2 ;;
    --scenario) SCENARIO=$2; shift 2 ;;
    -h|--help) sed -n '2,57p' "$0"; exit 0 ;;
    *) echo "bench_lcvslam.sh: unknown argument '$1' (see --help)" >&2; exit 2 ;;
  esac
done
[[ "$TIMING_RUNS" =~ ^[1-9][0-9]*$ ]] ||
  { echo "bench_lcvslam.sh: --timing-runs takes a positive integer, not '$TIMING_RUNS'" >&2; exit 2; }
[ -z "${LCV_SYNTH_WIDTH:-}" ] || [[ "$LCV_SYNTH_WIDTH" =~ ^[1-9][0-9]*$ ]] ||
  { echo "bench_lcvslam.sh: --width takes a positive integer, not '$LCV_SYNTH_WIDTH'" >&2; exit 2; }
[[ "$APE_RUNS" =~ ^[1-9][0-9]*$ ]] ||
  { echo "bench_lcvslam.sh: --ape-runs takes a positive integer, not '$APE_RUNS'" >&2; exit 2; }
[[ "$SCENARIO" =~ ^(overlap|tracking)$ ]] ||
  { echo "bench_lcvslam.sh: --scenario takes overlap or tracking, not '$SCENARIO'" >&2; exit 2; }
if [ "$QUICK" = 1 ]; then FRAMES=40; SEEDS="1"; MODELS="perspective"; RUN_KITTI=0; fi
[ -x "$LCV" ] || { echo "bench_lcvslam.sh: $LCV is not an executable (--lcv PATH)" >&2; exit 2; }
mkdir -p "$OUT"
LCV_BENCH_NAME=bench_lcvslam
# shellcheck source=bench/lib_lcvslam.sh
. "$(dirname "$0")/lib_lcvslam.sh"
log() { lcv_log "$@"; }

# run_case NAME MAP_DATASET_ARGS... -- CLIENT_DATASET_ARGS... ; needs MAP_GT, CLIENT_GT set.
# Produces OUT/NAME/{points,aligned,lines}.lcmap, client_{lines,points}.{txt,json}, ape_*.json
run_case() {
  local name=$1; shift
  local map_args=() client_args=()
  while [ "$1" != "--" ]; do map_args+=("$1"); shift; done; shift
  client_args=("$@")
  if [ -n "$CLIENT_CONFIG" ]; then client_args+=(--config "$CLIENT_CONFIG"); fi
  local d="$OUT/$name"; mkdir -p "$d"
  if [ "$REUSE_MAPS" = 1 ] && lcv_server_map_current "$d"; then
    log "$name: server maps reused (--reuse-maps)"
  elif [ "$REUSE_MAPS" = 1 ] && [ -s "$d/points.lcmap" ]; then
    log "$name: server SLAM map reused (--reuse-maps), published with --server-poses $LCV_SERVER_POSES"
    lcv_publish_server_map "$d" "$MAP_GT" || return 0
  else
    lcv_build_server_map "$d" "$MAP_GT" "${map_args[@]}" || return 0
  fi
  lcv_run_client "$d" lines "$d/lines.lcmap" "$CLIENT_GT" "${client_args[@]}" || true
  lcv_run_client "$d" points "$d/aligned.lcmap" "$CLIENT_GT" "${client_args[@]}" || true
  cp "$CLIENT_GT" "$d/client_gt.txt"
  # How many of the line client's X' lie on their line's hidden point (the audit's "client"
  # entry; exit 3 only means some other check of the cloud failed, the report is written).
  rm -f "$d/audit_client.json"
  if [ -s "$d/client_lines$CLIENT_MAP_SUFFIX" ]; then
    "$LCV" audit "$d/lines.lcmap" --client "$d/client_lines$CLIENT_MAP_SUFFIX" \
      --reference "$d/aligned.lcmap" --report "$d/audit_client.json" --fail-on none \
      >/dev/null 2>"$d/audit_client.log" || true
  fi
  rm -rf "$d/timing"
  local k kind map order
  for ((k = 2; k <= TIMING_RUNS; k++)); do
    mkdir -p "$d/timing"
    order="points lines"; [ $((k % 2)) = 1 ] && order="lines points"
    for kind in $order; do
      map="$d/lines.lcmap"; [ "$kind" = points ] && map="$d/aligned.lcmap"
      log "$name: timing run $k/$TIMING_RUNS, client $kind"
      "$LCV" slam "${client_args[@]}" --deterministic --map-in "$map" \
        --trajectory-out "$d/timing/${kind}_$k.txt" --stats-out "$d/timing/${kind}_$k.json" \
        >/dev/null 2>"$d/timing/${kind}_$k.log" || log "$name: timing run $k of $kind failed"
    done
  done
  lcv_ape_runs "$d" "$APE_RUNS" "$CLIENT_GT" "${client_args[@]}"
  if [ "${WITH_P6L:-0}" = 1 ]; then
    lcv_run_p6l "$d" "$d/lines.lcmap" "$CLIENT_GT" "$P6L_FRAMES" "${client_args[@]}"
  fi
}

CASES=()
for model in $MODELS; do
  for seed in $SEEDS; do
    name="${model}_s$seed"; [ "$SCENARIO" = overlap ] || name="${SCENARIO}_$name"
    scene="$OUT/$name/scene"
    lcv_synth_pair "$SCENARIO" "$model" "$FRAMES" "$seed" "$scene"
    MAP_GT="$scene/map/groundtruth.txt"; CLIENT_GT="$scene/client/groundtruth.txt"
    WITH_P6L=0; [ "$model" = perspective ] && WITH_P6L=1
    run_case "$name" --dataset "$scene/map" -- --dataset "$scene/client"
    CASES+=("$name")
  done
done
if [ "$RUN_KITTI" = 1 ]; then
  if [ -d "$KITTI_DIR" ]; then
    lcv_kitti_split "$KITTI_DIR" "$OUT/kitti00"
    MAP_GT="$OUT/kitti00/map_gt.txt"; CLIENT_GT="$OUT/kitti00/client_gt_sel.txt"; WITH_P6L=0
    run_case kitti00 --dataset "$KITTI_DIR" --frames 1::2 -- --dataset "$KITTI_DIR" --frames 0::2
    CASES+=(kitti00)
  else
    log "no KITTI at $KITTI_DIR: skipped"
  fi
fi

LCV_BENCH_DIR=$(dirname "$0") LCV_TIMING_RUNS=$TIMING_RUNS LCV_APE_RUNS=$APE_RUNS \
  python3 - "$OUT" "${CASES[@]}" <<'PYEOF'
import json, os, sys
out, cases = sys.argv[1], sys.argv[2:]
sys.path.insert(0, os.environ["LCV_BENCH_DIR"])
from paper_tables_report import read_tum

def load(path):
    try:
        with open(path) as f:
            return json.load(f)
    except (OSError, ValueError):
        return None

def first_time(path):
    """Timestamp of the first pose of a TUM trajectory (None when empty or missing)."""
    try:
        with open(path) as f:
            for line in f:
                if line.strip() and not line.startswith("#"):
                    return float(line.split()[0])
    except OSError:
        pass
    return None

def tracking_medians(d, kind, first_stats):
    """Median tracking time of each run, by run number: run 1 from first_stats, runs 2..N from
    OUT/CASE/timing/KIND_K.json (--timing-runs); runs without one are left out."""
    medians = {}
    first = (first_stats.get("tracking_ms") or {}).get("median")
    if first is not None:
        medians[1] = first
    timing = os.path.join(d, "timing")
    if os.path.isdir(timing):
        for name in os.listdir(timing):
            if name.startswith(kind + "_") and name.endswith(".json"):
                v = ((load(os.path.join(timing, name)) or {}).get("tracking_ms") or {}).get("median")
                if v is not None:
                    medians[int(name[len(kind) + 1:-len(".json")])] = v
    return medians

def least_disturbed(values):
    return min(values) if values else None

def paired_time_ratios(lines_by_run, points_by_run):
    """Run k's line median over run k's point median, for every k both clients finished. The two
    runs of a pair are adjacent in time (the bench alternates which goes first), so a slow phase
    of the machine that lasts tens of seconds mostly slows both and cancels in their ratio; the
    smallest medians taken apart can come from different phases (a quiet point run against line
    runs all in a slow phase). The median over the pairs is robust to the pairs that straddle a
    change."""
    return [lines_by_run[k] / points_by_run[k] for k in sorted(lines_by_run)
            if points_by_run.get(k)]

def plain_median(values):
    v = sorted(values)
    if not v:
        return None
    return v[len(v) // 2] if len(v) % 2 else 0.5 * (v[len(v) // 2 - 1] + v[len(v) // 2])

def time_split(stats):
    """Where run 1's tracking time goes, from --stats-out's per_frame records of tracked frames:
    ORB extraction (the same work in both clients) against the rest, and for a client in a line
    cloud, from its first line match on, its frames with at least CLOUD_MATCHES line and X'
    inliers (inside the cloud) against the others (leaving it; a 360-degree client keeps 10-20
    to the end). The target compares whole medians; these show which frames and which work set
    them."""
    frames = [f for f in (stats.get("per_frame") or [])
              if f.get("state") == "tracking" and f.get("tracking_ms") is not None]
    if not frames:
        return None
    extraction = [f.get("extraction_ms") or 0.0 for f in frames]
    line_matches = [f.get("line_matches") or 0 for f in frames]
    first = next((k for k, m in enumerate(line_matches) if m > 0), len(frames))
    in_cloud, beyond = [], []
    for f, m in zip(frames[first:], line_matches[first:]):
        (in_cloud if m >= CLOUD_MATCHES else beyond).append(f["tracking_ms"])
    return {"frames": len(frames),
            "extraction_ms_median": plain_median(extraction),
            "after_extraction_ms_median":
                plain_median([f["tracking_ms"] - e for f, e in zip(frames, extraction)]),
            "inside_cloud": {"frames": len(in_cloud), "ms_median": plain_median(in_cloud)},
            "leaving_cloud": {"frames": len(beyond), "ms_median": plain_median(beyond)}}

# Line and X' inliers of a frame "inside the cloud" (KeyframeInserter.line_cloud_fading_min).
CLOUD_MATCHES = 30

def positions(path):
    """read_tum with its timestamps rounded to the microsecond, to meet --stats-out's."""
    return {round(t, 6): p for t, p in read_tum(path).items()}

def ape_split(d):
    """Where run 1's APE comes from: position error RMSE of both clients (no alignment, as the
    table's APE) over the line client's frames inside the cloud (>= CLOUD_MATCHES line and X'
    inliers) and over the frames after its last such frame, on the same frames for both. Tells
    a client that is already behind inside the server map from one that loses it beyond."""
    stats = load(os.path.join(d, "client_lines.json")) or {}
    truth = positions(os.path.join(d, "client_gt.txt"))
    est = {k: positions(os.path.join(d, f"client_{k}.txt")) for k in ("lines", "points")}
    inside = [round(f["timestamp"], 6) for f in (stats.get("per_frame") or [])
              if (f.get("line_matches") or 0) >= CLOUD_MATCHES and f.get("timestamp") is not None]
    if not inside or not truth:
        return None
    last_inside = max(inside)
    after = [t for t in sorted(truth) if t > last_inside]
    def rmse(kind, stamps):
        sq = [sum((a - b) ** 2 for a, b in zip(est[kind][t], truth[t]))
              for t in stamps if t in est[kind] and t in truth]
        return {"frames": len(sq), "rmse": (sum(sq) / len(sq)) ** 0.5 if sq else None}
    return {k: {"inside_cloud": rmse(k, inside), "after_cloud": rmse(k, after)}
            for k in ("lines", "points")}

def ape_runs(d, kind, first_ape):
    """APE RMSE of run 1, then of OUT/CASE/ape_runs/ape_KIND_K.json (--ape-runs)."""
    values = [first_ape.get("rmse")]
    runs = os.path.join(d, "ape_runs")
    if os.path.isdir(runs):
        names = [n for n in os.listdir(runs) if n.startswith(f"ape_{kind}_") and n.endswith(".json")]
        for name in sorted(names, key=lambda n: int(n[len(kind) + 5:-len(".json")])):
            values.append((load(os.path.join(runs, name)) or {}).get("rmse"))
    return values

def median_or_none(values):
    if not values or any(v is None for v in values):
        return None  # a failed run counts against the client: no median hides it
    v = sorted(values)
    return v[len(v) // 2] if len(v) % 2 else 0.5 * (v[len(v) // 2 - 1] + v[len(v) // 2])

results = []
synth_width = int(os.environ.get("LCV_SYNTH_WIDTH") or 640)
for case in cases:
    d = os.path.join(out, case)
    t0 = first_time(os.path.join(d, "client_gt.txt"))  # first client frame
    row = {"case": case}
    medians_by_run = {}  # per client kind: run number -> median tracking ms
    for kind in ("lines", "points"):
        stats = load(os.path.join(d, f"client_{kind}.json")) or {}
        ape = load(os.path.join(d, f"ape_{kind}.json")) or {}
        first = first_time(os.path.join(d, f"client_{kind}.txt"))
        frames, tracked = stats.get("frames"), stats.get("tracked")
        if kind == "lines":
            relocalized = bool(stats.get("relocalized"))
            reloc_time = stats.get("relocalization_time_s")
        else:  # stats' "relocalized" describes line-cloud registration only: first tracked frame
            relocalized = first is not None
            reloc_time = first - t0 if first is not None and t0 is not None else None
        by_run = medians_by_run[kind] = tracking_medians(d, kind, stats)
        per_run = [by_run[k] for k in sorted(by_run)]
        apes = ape_runs(d, kind, ape)
        row[kind] = {
            "ran": bool(stats),
            "relocalized": relocalized,
            "relocalization_time_s": reloc_time,
            "frames": frames, "tracked": tracked,
            "tracked_pct": 100.0 * tracked / frames if frames and tracked is not None else None,
            "ape_rmse": median_or_none(apes), "ape_rmse_per_run": apes,
            "ape_matched": ape.get("matched"),
            "tracking_ms_median": least_disturbed(per_run),
            "tracking_ms_medians_per_run": per_run,
            "line_matches_per_frame": stats.get("line_matches_per_frame"),
            "time_split_run1": time_split(stats),
            "restored_points": stats.get("restored_points"),
        }
    row["ape_split_run1"] = ape_split(d)
    client_entry = next((a for a in (load(os.path.join(d, "audit_client.json")) or {}).get("attacks", [])
                         if a.get("name") == "client"), None)
    row["lines"]["restored_on_hidden_point"] = None if client_entry is None else {
        "restored": client_entry.get("estimated"),
        "within_1pct": (client_entry.get("precision") or {}).get("1%"),
        "within_0_1m": (client_entry.get("precision") or {}).get("0.1m"),
        "median_error_m": client_entry.get("median_estimate_error_m")}
    p6l = load(os.path.join(d, "p6l.json"))
    if p6l is not None:
        wall = (load(os.path.join(d, "p6l_wall.json")) or {}).get("wall_s")
        ape = load(os.path.join(d, "ape_p6l.json")) or {}
        n = sum(1 for line in open(os.path.join(d, "p6l_frames.txt"))) if os.path.exists(
            os.path.join(d, "p6l_frames.txt")) else None
        gt = p6l.get("ground_truth") or {}
        median_s = p6l.get("median_seconds_per_frame")
        row["p6l"] = {"wall_s": wall, "ms_per_frame_wall": 1000.0 * wall / n if wall and n else None,
                      "ms_per_frame_median": 1000.0 * median_s if median_s is not None else None,
                      "frames": p6l.get("frames"), "localized": p6l.get("localized"),
                      "success": gt.get("success"),
                      "median_position_error": gt.get("median_position_error"),
                      "ape_rmse": ape.get("rmse"), "ape_matched": ape.get("matched")}
    L, P = row["lines"], row["points"]
    ratio = lambda a, b: a / b if a is not None and b else None
    row["ape_ratio"] = ratio(L["ape_rmse"], P["ape_rmse"])
    row["time_ratio"] = ratio(L["tracking_ms_median"], P["tracking_ms_median"])
    row["time_ratio_paired_per_run"] = paired_time_ratios(medians_by_run["lines"],
                                                          medians_by_run["points"])
    row["time_ratio_paired_median"] = plain_median(row["time_ratio_paired_per_run"])
    row["pass"] = {
        "relocalized_2s": bool(L["relocalized"]) and L["relocalization_time_s"] is not None
                          and L["relocalization_time_s"] <= 2.0,
        "tracked_95": L["tracked_pct"] is not None and L["tracked_pct"] >= 95.0,
        "ape_ratio_1_05": row["ape_ratio"] is not None and row["ape_ratio"] <= 1.05,
        # The issue's time target: 1.2x "measured in the same run", read on the median of the
        # paired ratios (paired_time_ratios: each run's two clients back to back), and 15 ms
        # on the line client's least disturbed median. The 15 ms bound is the issue's at
        # 640x360 (and KITTI's own size): with --width it is not applied to the synthetic
        # cases, only the 1.2x ratio. With one timing run both ratios are run 1's.
        "time_ratio_1_2_and_15ms": row["time_ratio_paired_median"] is not None
                                   and row["time_ratio_paired_median"] <= 1.2
                                   and L["tracking_ms_median"] is not None
                                   and (L["tracking_ms_median"] <= 15.0
                                        or (synth_width != 640 and not row["case"].startswith("kitti"))),
        # The ratio of the two smallest medians, each client's least disturbed run, which can
        # lie a minute apart: shown beside it (before 0742b7b it was the only one).
        "time_ratio_smallest_medians_1_2": row["time_ratio"] is not None and row["time_ratio"] <= 1.2,
    }
    results.append(row)

# Per camera model: the geometric means over its cases (seeds) of the APE as in the table, the
# measure the docs' ratios use (one pair's ratio moves by up to 4x with a 2% change of the
# feature count; the mean over seeds is what the target can be read on).
import math
pairs_by_model = {}
for r in results:
    L, P = r["lines"]["ape_rmse"], r["points"]["ape_rmse"]
    if L and P:
        pairs_by_model.setdefault(r["case"].rsplit("_", 1)[0], []).append((L, P))
geomean = lambda xs: math.exp(sum(math.log(x) for x in xs) / len(xs))

def ratio_interval(pairs, level=0.90, resamples=2000):
    """Percentile bootstrap over the pairs of the geometric-mean APE ratio (lines / points).

    The pairs (scene seeds) are what varies between two sets of scenes: with one pair's ratio
    moving by up to 4x under a 2% change of the feature count, whether a model's ratio meets a
    target is read on this interval, not on the point value alone. Fixed seed: the same
    results give the same interval. None below 3 pairs."""
    if len(pairs) < 3:
        return None
    import random
    rng = random.Random(0)
    logs = [math.log(a) - math.log(b) for a, b in pairs]
    means = sorted(sum(rng.choice(logs) for _ in logs) / len(logs) for _ in range(resamples))
    tail = (1.0 - level) / 2.0
    return [math.exp(means[int(tail * (resamples - 1))]),
            math.exp(means[int((1.0 - tail) * (resamples - 1))])]

by_model = {m: {"cases": len(v), "ape_lines_geomean": geomean([a for a, _ in v]),
                "ape_points_geomean": geomean([b for _, b in v]),
                "ape_ratio_interval_90": ratio_interval(v)}
            for m, v in pairs_by_model.items()}
tmp = os.path.join(out, "results.json.tmp")
with open(tmp, "w") as f:
    json.dump({"cases": results,
               "server_poses": os.environ.get("LCV_SERVER_POSES", "sim3"),
               "timing_runs": int(os.environ.get("LCV_TIMING_RUNS", "1")),
               "synth_width": synth_width,
               "ape_runs": int(os.environ.get("LCV_APE_RUNS", "1")),
               "ape_rmse_is": "the median over ape_runs runs (run k >= 2 with the feature count "
                              "perturbed; every run in ape_rmse_per_run)",
               "tracking_ms_median_is": "the smallest per-run median over timing_runs runs",
               "time_ratio_paired_median_is": "the median over the runs k of run k's line "
                                              "median over run k's point median (the two "
                                              "runs adjacent in time)",
               "by_model": by_model},
              f, indent=2)
os.replace(tmp, os.path.join(out, "results.json"))

def fmt(v, spec=".3f"):
    return "-" if v is None else format(v, spec)
def yn(b):
    return "pass" if b else "FAIL"
print("| case | relocalized at s (lines; points: first tracked) | tracked % (lines / points) | APE m lines | APE m points "
      "| APE ratio | ms median lines | ms median points | time ratio (smallest medians) | time ratio (paired median) "
      "| reloc <= 2 s | >= 95% | APE <= 1.05x | time <= 1.2x (paired), <= 15 ms (at 640x360) |")
print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
for r in results:
    L, P = r["lines"], r["points"]
    rel = lambda k: ("yes " + fmt(k["relocalization_time_s"], ".2f")) if k["relocalized"] else "no"
    print(f"| {r['case']} | {rel(L)} / {rel(P)} | {fmt(L['tracked_pct'], '.0f')} / {fmt(P['tracked_pct'], '.0f')} "
          f"| {fmt(L['ape_rmse'])} | {fmt(P['ape_rmse'])} | {fmt(r['ape_ratio'], '.2f')} "
          f"| {fmt(L['tracking_ms_median'], '.1f')} | {fmt(P['tracking_ms_median'], '.1f')} "
          f"| {fmt(r['time_ratio'], '.2f')} | {fmt(r['time_ratio_paired_median'], '.2f')} "
          f"| {yn(r['pass']['relocalized_2s'])} | {yn(r['pass']['tracked_95'])} "
          f"| {yn(r['pass']['ape_ratio_1_05'])} | {yn(r['pass']['time_ratio_1_2_and_15ms'])} |")
if by_model:
    print("\nBy camera model (geometric mean over the cases of the APE above; 90% interval of the "
          "ratio by a bootstrap over the cases, from 3 cases):\n")
    print("| model | cases | APE m lines | APE m points | ratio | 90% interval |")
    print("|---|---|---|---|---|---|")
    for model, g in by_model.items():
        gl, gp = g["ape_lines_geomean"], g["ape_points_geomean"]
        ci = g["ape_ratio_interval_90"]
        ci_text = "-" if ci is None else f"{ci[0]:.2f}-{ci[1]:.2f}"
        print(f"| {model} | {g['cases']} | {gl:.3f} | {gp:.3f} | {gl / gp:.2f} | {ci_text} |")
if any(r["lines"]["restored_on_hidden_point"] for r in results):
    print("\nThe line client's X' against their lines' hidden points (`lcv audit --client "
          "--reference aligned.lcmap`, run 1):\n")
    print("| case | X' | within 0.1 m | within 1% of the scene | median error m |")
    print("|---|---|---|---|---|")
    for r in results:
        x = r["lines"]["restored_on_hidden_point"]
        if not x:
            continue
        pct = lambda v: "-" if v is None else format(100.0 * v, ".1f") + "%"
        print(f"| {r['case']} | {x['restored']} | {pct(x['within_0_1m'])} | {pct(x['within_1pct'])} "
              f"| {fmt(x['median_error_m'])} |")
if any(r["lines"]["time_split_run1"] and r["points"]["time_split_run1"] for r in results):
    print("\nWhere the tracking time goes (run 1, medians over tracked frames, ms): ORB extraction, "
          "the rest, and the line client's frames from its first line match on, inside the cloud "
          f"(>= {CLOUD_MATCHES} line and X' inliers) and leaving it:\n")
    print("| case | extraction lines / points | after extraction lines / points (ratio) "
          "| lines inside the cloud: frames, ms | lines leaving it: frames, ms |")
    print("|---|---|---|---|---|")
    for r in results:
        a, b = r["lines"]["time_split_run1"], r["points"]["time_split_run1"]
        if not (a and b):
            continue
        ae, be = a["after_extraction_ms_median"], b["after_extraction_ms_median"]
        w, wo = a["inside_cloud"], a["leaving_cloud"]
        print(f"| {r['case']} | {fmt(a['extraction_ms_median'], '.2f')} / {fmt(b['extraction_ms_median'], '.2f')} "
              f"| {fmt(ae, '.2f')} / {fmt(be, '.2f')} ({fmt(ae / be if ae is not None and be else None, '.2f')}) "
              f"| {w['frames']}, {fmt(w['ms_median'], '.2f')} | {wo['frames']}, {fmt(wo['ms_median'], '.2f')} |")
if any(r.get("ape_split_run1") for r in results):
    print("\nWhere the APE comes from (run 1, position error RMSE in m, no alignment): the line "
          f"client's frames inside the cloud (>= {CLOUD_MATCHES} line and X' inliers) and the frames "
          "after its last such frame, the same frames for both clients:\n")
    print("| case | inside the cloud: frames, lines / points | after it: frames, lines / points |")
    print("|---|---|---|")
    for r in results:
        x = r.get("ape_split_run1")
        if not x:
            continue
        cell = lambda part: (f"{x['lines'][part]['frames']}, {fmt(x['lines'][part]['rmse'])} / "
                             f"{fmt(x['points'][part]['rmse'])}")
        print(f"| {r['case']} | {cell('inside_cloud')} | {cell('after_cloud')} |")
if any(len(r["lines"]["tracking_ms_medians_per_run"]) > 1 for r in results):
    print("\nTracking time, median of each run (ms; the table takes the smallest), and the ratio "
          "of each run's two medians (the runs of a pair adjacent in time) with their median:\n")
    print("| case | lines | points | paired ratios | their median | <= 1.2x, <= 15 ms |")
    print("|---|---|---|---|---|---|")
    for r in results:
        runs = lambda k: " ".join(format(v, ".1f") for v in r[k]["tracking_ms_medians_per_run"])
        paired = " ".join(format(v, ".2f") for v in r["time_ratio_paired_per_run"])
        print(f"| {r['case']} | {runs('lines')} | {runs('points')} | {paired} "
              f"| {fmt(r['time_ratio_paired_median'], '.2f')} | {yn(r['pass']['time_ratio_1_2_and_15ms'])} |")
if any(len(r["lines"]["ape_rmse_per_run"]) > 1 for r in results):
    print("\nAPE RMSE of each run (m; run k >= 2 with the feature count perturbed; the table takes the median):\n")
    print("| case | lines | points | ratio of the runs' geometric means |")
    print("|---|---|---|---|")
    import math
    for r in results:
        runs = lambda k: " ".join(fmt(v) for v in r[k]["ape_rmse_per_run"])
        ok = all(v for k in ("lines", "points") for v in r[k]["ape_rmse_per_run"])
        gm = (lambda k: math.exp(sum(math.log(v) for v in r[k]["ape_rmse_per_run"])
                                 / len(r[k]["ape_rmse_per_run"]))) if ok else None
        print(f"| {r['case']} | {runs('lines')} | {runs('points')} "
              f"| {fmt(gm('lines') / gm('points') if ok else None, '.2f')} |")
p6 = [r for r in results if "p6l" in r]
if p6:
    print("\np6L baseline (`lcv localize`, every client frame on its own) vs LC-VSLAM (lines):\n")
    print("| case | p6L ms/frame median (wall incl. load) | p6L localized / frames | p6L success (0.5 m, 2 deg) "
          "| p6L median position error m | p6L APE m (poses) | LC-VSLAM ms median | LC-VSLAM APE m (poses) |")
    print("|---|---|---|---|---|---|---|---|")
    for r in p6:
        q, L = r["p6l"], r["lines"]
        print(f"| {r['case']} | {fmt(q['ms_per_frame_median'], '.0f')} ({fmt(q['ms_per_frame_wall'], '.0f')}) "
              f"| {q['localized']} / {q['frames']} | {q['success']} | {fmt(q['median_position_error'])} "
              f"| {fmt(q['ape_rmse'])} ({q['ape_matched']}) "
              f"| {fmt(L['tracking_ms_median'], '.1f')} | {fmt(L['ape_rmse'])} ({L['ape_matched']}) |")
PYEOF
}
# On one line: bash reads a whole line before running it, so after main returns it exits
# without reading on from an offset that an edit of this file during the run has moved.
main "$@"; exit $?
