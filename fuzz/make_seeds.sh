#!/bin/bash
# Writes the seed inputs of fuzz/seeds/<reader>/ with the project's own commands (lcv synth,
# dataset info, map import, map convert), plus the small hand-written index files of the fixed
# scratch scenes of fuzz/fuzz_readers.h. Then run fuzz/make_corpus.py.
# Usage: bash fuzz/make_seeds.sh [path/to/lcv]   (default build/lcv)
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
lcv=${1:-$here/../build/lcv}
seeds=$here/seeds
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
rm -rf "$seeds"
mkdir -p "$seeds"/{map,camera,trajectory,times,tum_index,kitti_calib,colmap,audit_rules}

# A rendered sequence: camera file, ground truth trajectory, times.
for model in perspective fisheye equirectangular; do
  "$lcv" synth --scenario tracking --camera "$model" --frames 4 --size 64x32 \
    --out "$work/synth_$model" > /dev/null 2>&1
  cp "$work/synth_$model/map/camera.yaml" "$seeds/camera/$model.yaml"
done
cp "$work/synth_perspective/map/groundtruth.txt" "$seeds/trajectory/groundtruth_tum.txt"
cp "$work/synth_perspective/map/times.txt" "$seeds/times/times.txt"
"$lcv" dataset info "$work/synth_perspective/map" --frames 0::2 \
  --write-gt "$seeds/trajectory/even_frames_tum.txt" --write-camera "$work/cam.yaml" > /dev/null
# KITTI poses: 12 numbers per line (the world_from_cam matrix rows of the same trajectory).
awk '!/^#/ && NF == 8 {
  w=$8; x=$5; y=$6; z=$7;
  printf "%.9g %.9g %.9g %s %.9g %.9g %.9g %s %.9g %.9g %.9g %s\n",
    1-2*(y*y+z*z), 2*(x*y-z*w), 2*(x*z+y*w), $2,
    2*(x*y+z*w), 1-2*(x*x+z*z), 2*(y*z-x*w), $3,
    2*(x*z-y*w), 2*(y*z+x*w), 1-2*(x*x+y*y), $4 }' \
  "$seeds/trajectory/groundtruth_tum.txt" > "$seeds/trajectory/poses_kitti.txt"

# A tiny COLMAP text model (one pinhole camera, two images, four points), imported as a point map
# and published as a line cloud, in both encodings.
model=$work/colmap
mkdir -p "$model"
cat > "$model/cameras.txt" <<'TXT'
# Camera list with one line of data per camera:
1 PINHOLE 64 48 60 60 32 24
TXT
cat > "$model/images.txt" <<'TXT'
# Image list with two lines of data per image:
1 1 0 0 0 0 0 0 1 000000.png
24.8 18 1 36 34 2 41.6 18 3 32 32 4
2 0.99875026 0 0.04997917 0 -0.5 0 0.02 1 000001.png
24.904 18.065 1 37.012 34.084 2 41.707 17.896 3 32.992 32.013 4
TXT
cat > "$model/points3D.txt" <<'TXT'
# 3D point list with one line of data per point:
1 -0.6 -0.5 5 128 64 32 0.5 1 0 2 0
2 0.4 1.0 6 128 64 32 0.5 1 1 2 1
3 0.8 -0.5 5 128 64 32 0.5 1 2 2 2
4 0 0.8 6 128 64 32 0.5 1 3 2 3
TXT
"$lcv" map import --colmap "$model" "$seeds/map/points.json" > /dev/null
"$lcv" map import --colmap "$model" "$seeds/map/points.lcmap" > /dev/null
"$lcv" map convert --to-lines "$seeds/map/points.json" "$seeds/map/lines.json" > /dev/null
"$lcv" map convert --to-lines "$seeds/map/points.lcmap" "$seeds/map/lines.lcmap" > /dev/null
for f in cameras.txt images.txt points3D.txt; do
  echo "=== $f"
  cat "$model/$f"
done > "$seeds/colmap/model.txt"

# Index files of the fixed scratch scenes (two 32x24 images each).
printf '# timestamp filename\n1305031102.175304 rgb/0.png\n1305031102.211214 rgb/1.png\n' \
  > "$seeds/tum_index/rgb.txt"
printf 'P0: 30 0 15.5 0 0 30 11.5 0 0 0 1 0\nP1: 30 0 15.5 -10 0 30 11.5 0 0 0 1 0\n' \
  > "$seeds/kitti_calib/calib.txt"
printf 'density@0.1m=0.05' > "$seeds/audit_rules/density.txt"
printf 'density@0.1m=0.05,visibility@1%%=0.2,duplicate@0.05m=0' > "$seeds/audit_rules/three.txt"
ls -R "$seeds" | head -40
