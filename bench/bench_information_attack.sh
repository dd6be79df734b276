#!/usr/bin/env bash
# The information attack (privacy/information_attack.h) on real SLAM point maps, published with
# the paper's eq. 1 of each point's covariance and with the default rule (mapping/line_cloud.h).
#
#   bench/bench_information_attack.sh [--lcv PATH] --out DIR MAP.lcmap...
#
# Each MAP is a point map with keyframes (e.g. the aligned.lcmap server maps that
# bench/bench_lcvslam.sh leaves in OUT/CASE/): converted twice (`lcv map convert --to-lines
# --information covariance|proxy`, seed 0), each cloud audited against MAP's points
# (`lcv audit --reference MAP`). Prints one Markdown row per map and rule: the information and
# density attacks' recovered fractions within 5 cm, 10 cm and 1% of the scene. Files stay in DIR.
set -euo pipefail
LCV=build/lcv
OUT=
MAPS=()
while [ $# -gt 0 ]; do
  case "$1" in
    --lcv) LCV=$2; shift 2 ;;
    --out) OUT=$2; shift 2 ;;
    -h|--help) sed -n '2,12p' "$0"; exit 0 ;;
    -*) echo "unknown option $1 (see --help)" >&2; exit 2 ;;
    *) MAPS+=("$1"); shift ;;
  esac
done
[ -n "$OUT" ] && [ ${#MAPS[@]} -gt 0 ] || { echo "usage: $0 [--lcv PATH] --out DIR MAP.lcmap..." >&2; exit 2; }
mkdir -p "$OUT"
echo "| map | Omega_L | lines | information attack: 5 cm / 10 cm / 1% | density attack: 5 cm / 10 cm / 1% |"
echo "|---|---|---|---|---|"
for map in "${MAPS[@]}"; do
  [ -s "$map" ] || { echo "[bench_information_attack] $map: no such map" >&2; exit 1; }
  name=$(basename "$(dirname "$map")")_$(basename "$map" .lcmap)
  for rule in covariance proxy; do
    cloud="$OUT/${name}_$rule.lcmap"
    echo "[bench_information_attack] $name: $rule" >&2
    "$LCV" map convert --to-lines "$map" "$cloud" --information "$rule" >"$OUT/${name}_$rule.convert.log" 2>&1
    # exit 3 = some check failed: the numbers are what this bench wants.
    "$LCV" audit "$cloud" --reference "$map" --report "$OUT/${name}_$rule.audit.json" \
      --fail-on none >"$OUT/${name}_$rule.audit.log" 2>&1 || [ $? -eq 3 ]
    python3 - "$OUT/${name}_$rule.audit.json" "$name" "$rule" <<'PY'
import json, sys
report = json.load(open(sys.argv[1]))
cells = {}
for attack in report["attacks"]:
    rec = attack.get("recovered") or {}
    cells[attack["name"]] = " / ".join("%.1f%%" % (100 * rec[k]) if rec.get(k) is not None else "-"
                                       for k in ("0.05m", "0.1m", "1%"))
lines = report["inputs"].get("lines", "?") if isinstance(report.get("inputs"), dict) else "?"
print("| %s | %s | %s | %s | %s |" % (sys.argv[2], sys.argv[3], lines, cells.get("information", "-"),
                                      cells.get("density", "-")))
PY
  done
done
