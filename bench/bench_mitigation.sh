#!/usr/bin/env bash
# Mitigation cost benchmark (issue 6, check 5): privacy gained vs localization lost.
#
#   bench/bench_mitigation.sh [LCV_BINARY] [OUT_DIR] [SCENARIO] [FRAMES]
#   (defaults: build/lcv, /tmp/lcv-bench-mitigation, tracking, 100)
#
# On a synthetic scene (`lcv synth`, perspective 640x360, seed 1):
#  1. SLAM map of the map sequence (`lcv slam --deterministic`), moved into the ground truth's
#     world frame (`lcv map transform --sim3-align-to`: Sim(3) of the keyframes), so that the
#     localization errors below need no alignment;
#  2. the point map published as a line cloud (seed 7) and audited against its hidden points
#     (`lcv audit --reference`): the per-line risk of the attacks;
#  3. for each mitigation (none; drop 10/30/50/80% riskiest; re-randomize 30% riskiest around
#     the true points), the same conversion with `--mitigate ... --risk audit_none.json`, audited
#     again (density-attack recovery over ALL hidden points: dropped lines count as not
#     recovered), and every 2nd client frame localized in it on its own (`lcv localize`, p6L):
#     success = camera centre within 0.5 m and rotation within 2 degrees of the ground truth
#     (and, stricter, 0.25 m and 1 degree: the SLAM map itself is only as good as its keyframe
#     alignment RMSE, printed by `lcv map transform`).
# Prints one Markdown table; every intermediate file stays in OUT_DIR. LCV_SLAM (default: the
# same binary) runs the SLAM step, e.g. a build whose `lcv slam` needs no vocabulary file.
set -euo pipefail
LCV=${1:-build/lcv}
OUT=${2:-/tmp/lcv-bench-mitigation}
SCENARIO=${3:-tracking}
FRAMES=${4:-100}
MAX_POSITION_M=0.5
MAX_ROTATION_DEG=2
mkdir -p "$OUT"
log() { echo "[bench_mitigation] $*" >&2; }

log "scene: lcv synth --scenario $SCENARIO --frames $FRAMES"
[ -f "$OUT/scene/scene.json" ] ||
  "$LCV" synth --scenario "$SCENARIO" --frames "$FRAMES" --seed 1 --out "$OUT/scene" >/dev/null
log "SLAM on the map sequence"
"${LCV_SLAM:-$LCV}" slam --dataset "$OUT/scene" --sequence map --deterministic \
  --trajectory-out "$OUT/slam_trajectory.txt" --map-out "$OUT/points.lcmap" >/dev/null
"$LCV" map transform "$OUT/points.lcmap" "$OUT/points_gt.lcmap" \
  --sim3-align-to "$OUT/scene/map/groundtruth.txt" >&2
"$LCV" map convert --to-lines "$OUT/points_gt.lcmap" "$OUT/lines_none.lcmap" --seed 7 >/dev/null
audit() {  # audit NAME: exit 3 (a check failed) is a result here, not an error
  "$LCV" audit "$OUT/lines_$1.lcmap" --reference "$OUT/points_gt.lcmap" \
    --report "$OUT/audit_$1.json" >/dev/null 2>&1 || [ $? -eq 3 ]
}
audit none

run() {  # run NAME [MODE FRACTION]
  local name=$1
  if [ $# -gt 1 ]; then
    "$LCV" map convert --to-lines "$OUT/points_gt.lcmap" "$OUT/lines_$name.lcmap" --seed 7 \
      --mitigate "$2" --fraction "$3" --risk "$OUT/audit_none.json" >/dev/null
    audit "$name"
  fi
  log "localizing the client frames in lines_$name"
  "$LCV" localize --map "$OUT/lines_$name.lcmap" --dataset "$OUT/scene" --sequence client \
    --frames 0::2 --max-position-error $MAX_POSITION_M --max-rotation-error $MAX_ROTATION_DEG \
    --trajectory-out "$OUT/localized_$name.txt" --stats-out "$OUT/localize_$name.json" >/dev/null
}
run none
run drop10 drop 0.1
run drop30 drop 0.3
run drop50 drop 0.5
run drop80 drop 0.8
run rerandomize30 rerandomize 0.3

python3 - "$OUT" <<'EOF'
import json, sys
out = sys.argv[1]
rows = [("none", "none"), ("drop10", "drop 10%"), ("drop30", "drop 30%"), ("drop50", "drop 50%"),
        ("drop80", "drop 80%"), ("rerandomize30", "re-randomize 30%")]
scale = json.load(open(f"{out}/audit_none.json"))["inputs"]["scene_scale_m"]
print(f"scene scale (1%-99% diagonal of the hidden points): {scale:.1f} m; 5% = {0.05*scale:.2f} m\n")
print("| mitigation | lines | density attack: recovered within 0.1 m / 0.25 m / 5% "
      "| visibility attack: within 5% | localized | success (0.5 m, 2 deg) | success (0.25 m, 1 deg) "
      "| median error | median inliers |")
print("|---|---|---|---|---|---|---|---|---|")
for key, label in rows:
    audit = json.load(open(f"{out}/audit_{key}.json"))
    loc = json.load(open(f"{out}/localize_{key}.json"))
    attacks = {a["name"]: a for a in audit["attacks"]}
    d, v = attacks["density"]["recovered"], attacks["visibility"]["recovered"]
    gt = loc["ground_truth"]
    inliers = sorted(f["inliers"] for f in loc["per_frame"])
    med = lambda x: x[len(x) // 2] if x else float("nan")
    strict = sum(1 for f in loc["per_frame"] if f.get("position_error", 1e9) <= 0.25
                 and f.get("rotation_error_deg", 1e9) <= 1.0) / gt["frames"]
    print(f"| {label} | {audit['inputs'].get('lines', '?')} "
          f"| {100*d['0.1m']:.1f}% / {100*d['0.25m']:.1f}% / {100*d['5%']:.1f}% "
          f"| {100*v['5%']:.1f}% | {loc['localized']}/{loc['frames']} "
          f"| {100*gt['success_rate']:.1f}% | {100*strict:.1f}% "
          f"| {gt['median_position_error'] or float('nan'):.3f} m, "
          f"{gt['median_rotation_error_deg'] or float('nan'):.2f} deg | {med(inliers)} |")
EOF
