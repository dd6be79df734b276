#!/usr/bin/env bash
# Builds a real COLMAP sparse model of the KITTI 00 excerpt (../shared/data/kitti00) on the CPU
# from its odd frames (the map half of the paper's KITTI protocol: 80 images), then runs the map
# commands on it: import, convert, info, export.
#
# usage: scripts/kitti00_colmap.sh [WORK_DIR] [LCV_BINARY]
#   WORK_DIR    where COLMAP's database, models and the lcv outputs go (default /tmp/kitti00_colmap).
#               Never inside the repository: KITTI is CC BY-NC-SA, derived models stay out of it.
#   LCV_BINARY  the built lcv (default build/lcv)
# Needs: apt-get install -y --no-install-recommends colmap (Debian 12: COLMAP 3.8, no CUDA).
#
# The camera is fixed to KITTI's calibration (rectified, no distortion). COLMAP puts the centre
# of the top-left pixel at (0.5, 0.5) and KITTI at (0, 0), so cx and cy get +0.5 here; the import
# shifts them back. SIFT is capped at 1500 features per image and matching to 5 neighbours: CPU
# matching is brute force and took ~35 s per image with COLMAP's defaults on 2 busy cores.
# Takes about 15 minutes on 2 cores.
set -euo pipefail
repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
data="${KITTI00_DIR:-$repo/../shared/data/kitti00}"
work="${1:-/tmp/kitti00_colmap}"
lcv="${2:-$repo/build/lcv}"
case "$(realpath -m "$work")/" in
  "$repo"/*) echo "kitti00_colmap.sh: WORK_DIR must be outside the repository" >&2; exit 2 ;;
esac
[ -d "$data/image_0" ] || { echo "kitti00_colmap.sh: $data/image_0 not found" >&2; exit 1; }
command -v colmap >/dev/null || { echo "kitti00_colmap.sh: colmap not installed" >&2; exit 1; }
export QT_QPA_PLATFORM=offscreen  # COLMAP links Qt; no display here

mkdir -p "$work"
rm -rf "$work/database.db" "$work/sparse" "$work/sparse_txt" "$work/images"
mkdir -p "$work/sparse" "$work/sparse_txt" "$work/images"
for image in "$data"/image_0/*[13579].png; do ln -s "$(realpath "$image")" "$work/images/"; done

colmap feature_extractor \
  --database_path "$work/database.db" --image_path "$work/images" \
  --ImageReader.camera_model PINHOLE --ImageReader.single_camera 1 \
  --ImageReader.camera_params "718.856,718.856,607.6928,185.7157" \
  --SiftExtraction.use_gpu 0 --SiftExtraction.num_threads 2 \
  --SiftExtraction.max_num_features 1500
colmap sequential_matcher \
  --database_path "$work/database.db" \
  --SiftMatching.use_gpu 0 --SiftMatching.num_threads 2 --SequentialMatching.overlap 5 \
  --SequentialMatching.quadratic_overlap 0
colmap mapper \
  --database_path "$work/database.db" --image_path "$work/images" --output_path "$work/sparse" \
  --Mapper.num_threads 2 --Mapper.ba_refine_focal_length 0 \
  --Mapper.ba_refine_principal_point 0 --Mapper.ba_refine_extra_params 0
# The largest model is sparse/0.
colmap model_converter --input_path "$work/sparse/0" --output_path "$work/sparse_txt" \
  --output_type TXT

"$lcv" map import --colmap "$work/sparse_txt" "$work/kitti00_points.lcmap"
"$lcv" map info "$work/kitti00_points.lcmap"
"$lcv" map convert --to-lines "$work/kitti00_points.lcmap" "$work/kitti00_lines.lcmap" --seed 1
"$lcv" map info "$work/kitti00_lines.lcmap"
"$lcv" map export "$work/kitti00_points.lcmap" "$work/kitti00_points.ply" --cameras
"$lcv" map export "$work/kitti00_lines.lcmap" "$work/kitti00_lines.ply" --cameras
"$lcv" map export "$work/kitti00_lines.lcmap" "$work/kitti00_lines.pcd"
