#!/usr/bin/env python3
"""An lcv sequence with a block of frames removed: an interruption of the camera.

    bench/gap_dataset.py SRC DST --drop A:B [--retime]

SRC is an `lcv synth` sequence folder (images/, camera.yaml, times.txt, groundtruth.txt). DST gets
the same layout with frames [A, B) left out: the images as symbolic links, times.txt and
groundtruth.txt of the kept frames. The timestamps stay the true ones (frames not delivered for
(B - A) frame periods) unless --retime, which renumbers them at the original period as if no
time had passed: the camera then jumps between two consecutive frames (a "kidnapped" camera,
which a constant-velocity prediction cannot follow). Used in docs/slam.md, "Interruptions in a
line cloud".
"""
import argparse
import os
import shutil
import sys


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("src")
    parser.add_argument("dst")
    parser.add_argument("--drop", required=True, help="A:B, the frames [A, B) left out")
    parser.add_argument("--retime", action="store_true",
                        help="renumber the timestamps at the original period (a kidnapped camera)")
    args = parser.parse_args()
    try:
        first, end = (int(v) for v in args.drop.split(":"))
    except ValueError:
        sys.exit(f"gap_dataset.py: --drop {args.drop}: expected A:B (two frame indices)")
    for name in ("images", "camera.yaml", "times.txt", "groundtruth.txt"):
        if not os.path.exists(os.path.join(args.src, name)):
            sys.exit(f"gap_dataset.py: {args.src}: no {name} (not an lcv synth sequence)")
    times = open(os.path.join(args.src, "times.txt")).read().split()
    truth = [line for line in open(os.path.join(args.src, "groundtruth.txt")).read().splitlines()
             if line.strip() and not line.startswith("#")]
    images = sorted(os.listdir(os.path.join(args.src, "images")))
    if not (len(images) == len(times) == len(truth)):
        sys.exit(f"gap_dataset.py: {args.src}: {len(images)} images, {len(times)} timestamps, "
                 f"{len(truth)} ground-truth poses")
    if not 0 <= first < end <= len(images):
        sys.exit(f"gap_dataset.py: --drop {args.drop} is outside the {len(images)} frames")
    keep = [i for i in range(len(images)) if not first <= i < end]
    period = float(times[1]) - float(times[0]) if len(times) > 1 else 0.1
    os.makedirs(os.path.join(args.dst, "images"), exist_ok=True)
    shutil.copy(os.path.join(args.src, "camera.yaml"), args.dst)
    out_times, out_truth = [], []
    for j, i in enumerate(keep):
        link = os.path.join(args.dst, "images", "%06d%s" % (j, os.path.splitext(images[i])[1]))
        if os.path.lexists(link):
            os.remove(link)
        os.symlink(os.path.abspath(os.path.join(args.src, "images", images[i])), link)
        stamp = "%.6f" % (float(times[0]) + j * period) if args.retime else times[i]
        out_times.append(stamp)
        out_truth.append(" ".join([stamp] + truth[i].split()[1:]))
    with open(os.path.join(args.dst, "times.txt"), "w") as f:
        f.write("\n".join(out_times) + "\n")
    with open(os.path.join(args.dst, "groundtruth.txt"), "w") as f:
        f.write("\n".join(out_truth) + "\n")
    print(f"{args.dst}: {len(keep)} of {len(images)} frames, [{first}, {end}) left out"
          + (", retimed" if args.retime else ""))


if __name__ == "__main__":
    main()
