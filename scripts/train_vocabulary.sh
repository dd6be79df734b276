#!/usr/bin/env bash
# Reproduces the shipped BoW vocabulary slam/bow/vocabulary/orb_synth.lcvoc: renders the
# project's own synthetic scenarios (`lcv synth`: every scenario, every camera model, three scene
# seeds that no test or demo uses), then trains a vocabulary tree on their ORB features
# (`lcv vocab train`). Everything it trains on is generated here, so the result may be
# redistributed with the repository. Deterministic: same lcv, same file.
#
# usage: scripts/train_vocabulary.sh OUT_FILE [LCV_BINARY]
#   OUT_FILE    the vocabulary to write, e.g. slam/bow/vocabulary/orb_synth.lcvoc
#   LCV_BINARY  the built lcv (default build/lcv)
# Environment (defaults are the shipped vocabulary's parameters):
#   BRANCHING=16 DEPTH=4  tree shape (K children per node, L levels: at most K^L words)
#   FEATURES=1000         ORB features per training image
#   FRAMES=20             frames per rendered sequence (each scenario has two sequences)
#   SEEDS="1001 1002 1003" scene seeds (tests and the demo use seeds below 100)
#   WORK_DIR              where the renders go (default: a fresh folder under /tmp, removed at
#                         the end; a given WORK_DIR is kept). Never inside the repository.
# Progress goes to stderr; the summary of `lcv vocab train` to stdout.
set -euo pipefail
repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
if [ $# -lt 1 ]; then
  echo "usage: scripts/train_vocabulary.sh OUT_FILE [LCV_BINARY]" >&2
  exit 2
fi
out="$1"
lcv="${2:-$repo/build/lcv}"
branching="${BRANCHING:-16}"
depth="${DEPTH:-4}"
features="${FEATURES:-1000}"
frames="${FRAMES:-20}"
seeds="${SEEDS:-1001 1002 1003}"
[ -x "$lcv" ] || { echo "train_vocabulary.sh: $lcv is not an executable lcv" >&2; exit 1; }

if [ -n "${WORK_DIR:-}" ]; then
  work="$WORK_DIR"
  case "$(realpath -m "$work")/" in
    "$repo"/*) echo "train_vocabulary.sh: WORK_DIR must be outside the repository" >&2; exit 2 ;;
  esac
  mkdir -p "$work"
else
  work="$(mktemp -d /tmp/lcv_vocabulary.XXXXXX)"
  trap 'rm -rf "$work"' EXIT
fi

folders=()
for seed in $seeds; do
  for scenario in tracking overlap loop desk; do
    for camera in perspective fisheye equirectangular; do
      dir="$work/${scenario}_${camera}_${seed}"
      if [ ! -f "$dir/scene.json" ]; then
        echo "train_vocabulary.sh: rendering $scenario $camera seed $seed" >&2
        "$lcv" synth --scenario "$scenario" --camera "$camera" --frames "$frames" --seed "$seed" \
          --out "$dir" >/dev/null 2>&1
      fi
      folders+=(--images "$dir/map/images" --images "$dir/client/images")
    done
  done
done

echo "train_vocabulary.sh: training K=$branching L=$depth on ${#folders[@]} folders" >&2
"$lcv" vocab train "${folders[@]}" --branching "$branching" --depth "$depth" \
  --features "$features" --seed 1 --out "$out"
