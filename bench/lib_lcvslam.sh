# Shell functions shared by the LC-VSLAM benchmarks (bench/bench_lcvslam.sh, bench/paper_tables).
# Source it; it defines functions only. Every function uses the caller's $LCV (the `lcv`
# binary) and logs to stderr with the prefix $LCV_BENCH_NAME. Failures of a step are logged and
# returned as a non-zero status (never `exit`), so that one failing case does not stop a whole
# benchmark; callers running under `set -e` call them in an `if` or with `||`.
#
# Output layout of one case directory D (paths fixed, so the report scripts can find them):
#   D/server.{txt,json,log}, D/points.lcmap     the server's SLAM run on the map sequence
#   D/aligned.lcmap                             that map moved into the ground truth's frame
#   D/lines.$LINES_EXT                          the aligned map published as a line cloud
#   D/client_KIND.{txt,json,log,rc}, D/client_KIND$CLIENT_MAP_SUFFIX, D/ape_KIND.json
#   D/p6l.{txt,json,log}, D/p6l_wall.json, D/p6l_frames.txt, D/ape_p6l.json

LCV_BENCH_NAME=${LCV_BENCH_NAME:-lcvslam}
LINES_EXT=${LINES_EXT:-lcmap}          # json makes the line cloud readable without msgpack
# the client's --map-out is D/client_KIND$CLIENT_MAP_SUFFIX (not .json: that is the stats file)
CLIENT_MAP_SUFFIX=${CLIENT_MAP_SUFFIX:-.lcmap}

lcv_log() { echo "[$LCV_BENCH_NAME] $*" >&2; }
lcv_now() { date +%s.%N; }

# lcv_ape GT EST [PLOT.png] -> APE JSON (`lcv eval ape --align none`, the server's frame) on
# stdout, or {} when nothing could be evaluated (no trajectory, no common timestamps); with
# PLOT.png also the estimate over the ground truth coloured by its error (`--plot`).
lcv_ape() {
  "$LCV" eval ape --gt "$1" --est "$2" --align none --json ${3:+--plot "$3"} 2>/dev/null ||
    echo '{}'
}

# lcv_synth_pair SCENARIO MODEL FRAMES SEED DIR: renders the pair into DIR unless a completed
# render is there. scene.json is written before the images, so a marker of our own says the
# render completed (an interrupted one is redone). LCV_SYNTH_WIDTH (optional): the image width,
# the height 9/16 of it (equirectangular: 1/2, its 2:1 panorama); unset: lcv synth's defaults
# (640x360, equirectangular 640x320).
lcv_synth_pair() {
  local scenario=$1 model=$2 frames=$3 seed=$4 dir=$5 size_args=()
  [ -f "$dir/.synth_complete" ] && return 0
  rm -rf "$dir"
  if [ -n "${LCV_SYNTH_WIDTH:-}" ]; then
    local height=$((LCV_SYNTH_WIDTH * 9 / 16))
    [ "$model" = equirectangular ] && height=$((LCV_SYNTH_WIDTH / 2))
    size_args=(--size "${LCV_SYNTH_WIDTH}x$height")
  fi
  lcv_log "lcv synth --scenario $scenario --camera $model --frames $frames --seed $seed ${size_args[*]}"
  "$LCV" synth --scenario "$scenario" --camera "$model" --frames "$frames" --seed "$seed" \
    "${size_args[@]}" --out "$dir" >/dev/null || { lcv_log "synth $scenario/$model failed"; return 1; }
  touch "$dir/.synth_complete"
}

# lcv_build_server_map DIR MAP_GT SLAM_ARGS...: the prebuilt map of DIR. `lcv slam
# --deterministic` on the map sequence, then lcv_publish_server_map.
lcv_build_server_map() {
  local d=$1 map_gt=$2; shift 2
  mkdir -p "$d"
  lcv_log "$(basename "$d"): server SLAM"
  "$LCV" slam "$@" --deterministic --trajectory-out "$d/server.txt" \
    --map-out "$d/points.lcmap" --stats-out "$d/server.json" >/dev/null 2>"$d/server.log" ||
    { lcv_log "$(basename "$d"): server SLAM failed (see $d/server.log)"; return 1; }
  lcv_publish_server_map "$d" "$map_gt"
}

# lcv_publish_server_map DIR MAP_GT: DIR/points.lcmap moved into the ground truth's frame
# (`lcv map transform`: Sim(3) of the keyframes; with LCV_SERVER_POSES=ground-truth also
# --ground-truth-poses, the paper's construction: keyframes on their ground-truth poses, points
# refined by BA) -> DIR/aligned.lcmap, published as a line cloud (`lcv map convert --to-lines`)
# -> DIR/lines.$LINES_EXT. DIR/server_poses says which.
LCV_SERVER_POSES=${LCV_SERVER_POSES:-sim3}
lcv_publish_server_map() {
  local d=$1 map_gt=$2
  local extra=()
  case "$LCV_SERVER_POSES" in
    sim3) ;;
    ground-truth) extra=(--ground-truth-poses) ;;
    *) lcv_log "unknown server map poses '$LCV_SERVER_POSES' (sim3 or ground-truth)"; return 1 ;;
  esac
  "$LCV" map transform "$d/points.lcmap" "$d/aligned.lcmap" --sim3-align-to "$map_gt" \
    "${extra[@]}" >"$d/transform.log" 2>&1 ||
    { lcv_log "$(basename "$d"): map transform failed (see $d/transform.log)"; return 1; }
  "$LCV" map convert --to-lines "$d/aligned.lcmap" "$d/lines.$LINES_EXT" >"$d/convert.log" 2>&1 ||
    { lcv_log "$(basename "$d"): map convert failed (see $d/convert.log)"; return 1; }
  echo "$LCV_SERVER_POSES" >"$d/server_poses"
}

# lcv_server_map_current DIR: true when DIR holds a published server map made with the current
# LCV_SERVER_POSES (maps from before DIR/server_poses existed count as sim3).
lcv_server_map_current() {
  local d=$1 made=sim3
  [ -s "$d/aligned.lcmap" ] && [ -s "$d/lines.$LINES_EXT" ] || return 1
  [ -f "$d/server_poses" ] && made=$(cat "$d/server_poses")
  [ "$made" = "$LCV_SERVER_POSES" ]
}

# How the clients run (LCV_CLIENT_MODE): deterministic (default: mapping, loop closing and
# global BA inline, `--deterministic`, reproducible to the digit), threaded (the threads, frames
# as fast as tracking returns: how a dataset is run by default) or live (`--realtime`: frames at
# the dataset's rate, dropped when tracking is behind). Server maps are always deterministic.
LCV_CLIENT_MODE=${LCV_CLIENT_MODE:-deterministic}
lcv_client_mode_args() {
  case "$LCV_CLIENT_MODE" in
    deterministic) echo --deterministic ;;
    threaded) ;;
    live) echo --realtime ;;
    *) lcv_log "unknown client mode '$LCV_CLIENT_MODE' (deterministic, threaded or live)"; return 1 ;;
  esac
}

# lcv_run_client DIR KIND MAP CLIENT_GT CLIENT_ARGS...: LC-VSLAM client (`lcv slam
# --deterministic --map-in MAP`, or LCV_CLIENT_MODE's flag) -> DIR/client_KIND.*, and its APE
# against CLIENT_GT. The exit status of lcv is kept in DIR/client_KIND.rc (a rejected --config is
# told apart from a crash by the log). Returns that status.
lcv_run_client() {
  local d=$1 kind=$2 map=$3 client_gt=$4; shift 4
  local rc=0
  lcv_log "$(basename "$d"): client $kind (--map-in $(basename "$map"))"
  # Everything a report reads from this client: a failed run must not leave an earlier run's
  # numbers (its stats hold tracking_ms) to be reported as this one's.
  rm -f "$d/client_$kind.txt" "$d/ape_$kind.json" "$d/client_$kind.json" \
    "$d/client_$kind$CLIENT_MAP_SUFFIX"
  local mode
  mode=$(lcv_client_mode_args) || return 2
  # shellcheck disable=SC2086  # mode: one flag or none
  "$LCV" slam "$@" $mode --map-in "$map" \
    --trajectory-out "$d/client_$kind.txt" --map-out "$d/client_$kind$CLIENT_MAP_SUFFIX" \
    --stats-out "$d/client_$kind.json" >/dev/null 2>"$d/client_$kind.log" || rc=$?
  echo "$rc" >"$d/client_$kind.rc"
  if [ "$rc" != 0 ]; then
    lcv_log "$(basename "$d"): client $kind failed with exit $rc (see $d/client_$kind.log)"
    return "$rc"
  fi
  lcv_ape "$client_gt" "$d/client_$kind.txt" "$d/ape_$kind.png" >"$d/ape_$kind.json"
}

# lcv_ape_runs DIR N CLIENT_GT CLIENT_ARGS...: runs 2..N of both clients (after lcv_run_client
# made run 1) with the ORB feature count of run 1 (read from DIR/client_lines.log) changed by
# -2%, +2%, -4%, +4%, ... -> DIR/ape_runs/{lines,points}_K.{txt,json,log} and ape_KIND_K.json.
# Most of a client trajectory is monocular mapping beyond the server map, whose drift is chaotic:
# such a change moves either client's APE on one pair by up to 4x (docs/benchmarks-lcvslam.md,
# "Both clients vary"), so a comparison needs several runs (ORB-SLAM's papers: median of 5).
lcv_ape_runs() {
  local d=$1 n=$2 client_gt=$3; shift 3
  rm -rf "$d/ape_runs"
  [ "$n" -gt 1 ] || return 0
  local features k offset count kind map
  features=$(sed -n 's/.*, \([0-9][0-9]*\) features.*/\1/p' "$d/client_lines.log" 2>/dev/null | head -1)
  [ -n "$features" ] || { lcv_log "$(basename "$d"): no feature count in client_lines.log: no APE runs"; return 0; }
  mkdir -p "$d/ape_runs"
  for ((k = 2; k <= n; k++)); do
    offset=$(( (k / 2) * 2 )); [ $((k % 2)) = 0 ] && offset=$((-offset))
    count=$((features * (100 + offset) / 100))
    for kind in lines points; do
      map="$d/lines.$LINES_EXT"; [ "$kind" = points ] && map="$d/aligned.lcmap"
      lcv_log "$(basename "$d"): APE run $k/$n, client $kind, $count features"
      # shellcheck disable=SC2046  # one flag or none
      "$LCV" slam "$@" $(lcv_client_mode_args) --map-in "$map" --num-features "$count" \
        --trajectory-out "$d/ape_runs/${kind}_$k.txt" --stats-out "$d/ape_runs/${kind}_$k.json" \
        >/dev/null 2>"$d/ape_runs/${kind}_$k.log" ||
        lcv_log "$(basename "$d"): APE run $k of $kind failed (see $d/ape_runs/${kind}_$k.log)"
      lcv_ape "$client_gt" "$d/ape_runs/${kind}_$k.txt" >"$d/ape_runs/ape_${kind}_$k.json"
    done
  done
}

# lcv_run_p6l DIR LINES CLIENT_GT FRAMES CLIENT_ARGS...: the p6L baseline (`lcv localize`, every
# selected client frame on its own) in the same line cloud -> DIR/p6l.*, its wall time, the list
# of frames it was given (ground-truth lines) and its APE.
lcv_run_p6l() {
  local d=$1 lines=$2 client_gt=$3 frames=$4; shift 4
  lcv_log "$(basename "$d"): p6L baseline (lcv localize --frames $frames)"
  local t0 t1
  t0=$(lcv_now)
  "$LCV" localize --map "$lines" "$@" --frames "$frames" --trajectory-out "$d/p6l.txt" \
    --stats-out "$d/p6l.json" >/dev/null 2>"$d/p6l.log" || lcv_log "$(basename "$d"): lcv localize exit $?"
  t1=$(lcv_now)
  echo "{\"wall_s\": $(echo "$t1 - $t0" | bc -l)}" >"$d/p6l_wall.json"
  awk '!/^#/ && NF' "$client_gt" | python3 -c "import sys; l=sys.stdin.readlines(); \
a,b,c=(sys.argv[1].split(':')+['',''])[:3]; print(''.join(l[slice(int(a) if a else None, int(b) if b else None, int(c) if c else None)]), end='')" "$frames" >"$d/p6l_frames.txt"
  lcv_ape "$client_gt" "$d/p6l.txt" >"$d/ape_p6l.json"
}

# lcv_kitti_split KITTI_DIR OUT_DIR [MAP_FRAMES CLIENT_FRAMES]: the paper's KITTI protocol (odd
# frames build the map, even frames are the client; defaults 1::2 and 0::2): writes the two
# ground truths OUT_DIR/map_gt.txt and OUT_DIR/client_gt_sel.txt.
lcv_kitti_split() {
  local kitti=$1 d=$2 map_frames=${3:-1::2} client_frames=${4:-0::2}
  mkdir -p "$d"
  "$LCV" dataset info "$kitti" --frames "$map_frames" --write-gt "$d/map_gt.txt" >/dev/null &&
    "$LCV" dataset info "$kitti" --frames "$client_frames" --write-gt "$d/client_gt_sel.txt" >/dev/null
}
