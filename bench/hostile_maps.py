#!/usr/bin/env python3
"""Hostile map files through every command that reads a map (issue 16's first target).

Map i (i = --start .. --start + --maps - 1) is made on the fly from the map seeds of
fuzz/seeds/map with 1-3 mutations of fuzz/make_corpus.py, drawn from random.Random(f"hostile/{i}"):
the same i always gives the same bytes, so any finding replays with --start i --maps 1 (and
--keep saves the failing inputs). Each map goes through `map info`, `map convert --to-lines`
(`map info` on its output), `render`, `audit` and `slam --map-in --map-out` (on a 2-frame
64x48 rendered sequence, `map info` on its output), each with a time limit (10 s). Counted:

  crash       the process was killed by a signal (or exited >= 128)
  hang        the time limit was hit twice: --timeout s of wall time, then --timeout s of CPU
              time (a second try tells a hang from a busy machine; see Runner.run)
  slow        (not a failure) the first try ran out of wall time and the second finished
  unreadable  exit 0, but the map it wrote is refused by `map info`
  unnamed     a non-zero exit whose stderr does not contain the input's path

Cost: the process start of lcv (~10 ms since the image, video and GL libraries are opened at run
time), the renders (OSMesa, ~0.3 s each) and the slam runs. --jobs runs that many maps at once;
on a shared machine run it as `nice -n 19 python3 bench/hostile_maps.py --jobs 1 ...` (one core).
Progress goes to stderr; every finding and a final summary (JSON, one object a line) are appended
to --results. Usage:

  nice -n 19 python3 bench/hostile_maps.py --maps 100000 --results /tmp/hostile.jsonl [--jobs 1]
"""
import argparse
import concurrent.futures
import json
import math
import os
import random
import resource
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path.insert(0, os.path.join(ROOT, "fuzz"))
import make_corpus  # noqa: E402  (the mutations of the committed corpus)


def make_map(index, seeds):
    """The bytes and the seed's name of hostile map `index` (deterministic)."""
    rng = random.Random(f"hostile/{index}")
    name, data = rng.choice(seeds)
    for _ in range(rng.randint(1, 3)):
        data = make_corpus.mutate(data, [s for _, s in seeds], rng) if data else b"\x00"
    return name, data


class Runner:
    def __init__(self, lcv, timeout, dataset):
        self.lcv = lcv
        self.timeout = timeout
        self.dataset = dataset

    def run(self, args, cwd):
        """(exit code or 'hang', slow, stderr, seconds of the last try). A negative code is a
        signal. The first try has --timeout seconds of wall time. A process that runs out of it is
        tried again with --timeout seconds of CPU time (RLIMIT_CPU, all its threads) and 10x the
        wall time: on a busy machine a niced run can wait most of its wall time for a core, while
        a process that loops spends its CPU time and one that deadlocks its wall time. 'hang'
        when the second try also runs out; slow (True) when it finishes (its exit code is then
        checked like any other; the caller records both)."""
        def limit_cpu():
            cpu = max(1, math.ceil(self.timeout))
            resource.setrlimit(resource.RLIMIT_CPU, (cpu, cpu + 1))

        for attempt in range(2):
            began = time.time()
            try:
                done = subprocess.run([self.lcv] + args, cwd=cwd, stdin=subprocess.DEVNULL,
                                      stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                                      timeout=self.timeout * (1 if attempt == 0 else 10),
                                      preexec_fn=None if attempt == 0 else limit_cpu)
            except subprocess.TimeoutExpired:
                continue  # subprocess.run killed it
            code = done.returncode
            if attempt == 1 and code == -signal.SIGXCPU:
                break  # out of CPU time: a loop
            return code, attempt == 1, done.stderr.decode("utf-8", "replace"), time.time() - began
        return "hang", False, "", time.time() - began

    def reads_back(self, path, cwd):
        code, _, _, _ = self.run(["map", "info", path], cwd)
        return code == 0

    def check_map(self, index, seeds, scratch):
        """Runs map `index` through every command; returns (runs, findings)."""
        seed_name, data = make_map(index, seeds)
        ext = os.path.splitext(seed_name)[1]
        path = os.path.join(scratch, f"hostile-{index}{ext}")
        with open(path, "wb") as f:
            f.write(data)
        out_map = os.path.join(scratch, "out.lcmap")
        slam_map = os.path.join(scratch, "slam.lcmap")
        commands = [
            ("map info", ["map", "info", path], None),
            ("map convert", ["map", "convert", "--to-lines", path, out_map], out_map),
            ("render", ["render", path, "--out", os.path.join(scratch, "out.png"), "--size", "160x90"], None),
            ("audit", ["audit", path, "--report", os.path.join(scratch, "report.json")], None),
            ("slam --map-in", ["slam", "--dataset", self.dataset, "--map-in", path, "--map-out", slam_map,
                               "--trajectory-out", os.path.join(scratch, "t.txt"), "--deterministic"], slam_map),
        ]
        runs, findings, accepted = 0, [], False
        for name, args, output in commands:
            if output and os.path.exists(output):
                os.remove(output)
            code, slow, err, seconds = self.run(args, scratch)
            runs += 1
            kind = None
            if slow:  # not a failure: recorded so that the summary can say how many
                findings.append({"map": index, "seed": seed_name, "kind": "slow", "command": name,
                                 "exit": code, "seconds_second_try": round(seconds, 2), "stderr": ""})
            if code == "hang":
                kind = "hang"
            elif code < 0 or code >= 128:
                kind = "crash"
            elif code != 0 and path not in err:
                kind = "unnamed"
            elif code == 0 and output:
                runs += 1
                if not self.reads_back(output, scratch):
                    kind = "unreadable"
            if name == "map info" and code == 0:
                accepted = True
            if kind:
                findings.append({"map": index, "seed": seed_name, "kind": kind, "command": name,
                                 "exit": code, "stderr": err[-400:]})
        if findings:
            findings[0]["bytes_hex"] = data.hex() if len(data) <= 8192 else None
        os.remove(path)
        return runs, findings, accepted


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--maps", type=int, default=1000)
    parser.add_argument("--start", type=int, default=0, help="index of the first map")
    parser.add_argument("--jobs", type=int, default=1, help="maps run at once (one process each)")
    parser.add_argument("--timeout", type=float, default=10.0, help="seconds per run")
    parser.add_argument("--lcv", default=os.path.join(ROOT, "build", "lcv"))
    parser.add_argument("--results", required=True, help="JSON lines: findings and the summary")
    parser.add_argument("--keep", help="folder where failing inputs are saved")
    parser.add_argument("--progress-every", type=int, default=100)
    args = parser.parse_args()
    args.lcv = os.path.abspath(args.lcv)  # the runs start in a scratch folder

    seed_dir = os.path.join(ROOT, "fuzz", "seeds", "map")
    seeds = [(n, open(os.path.join(seed_dir, n), "rb").read()) for n in sorted(os.listdir(seed_dir))]
    work = tempfile.mkdtemp(prefix="lcv_hostile_")
    stop = threading.Event()
    signal.signal(signal.SIGTERM, lambda *_: stop.set())
    try:
        # The slam sequence: 2 rendered frames of the seeds' camera size (64x48).
        dataset = os.path.join(work, "synth")
        subprocess.run([args.lcv, "synth", "--scenario", "tracking", "--frames", "2", "--size", "64x48",
                        "--out", dataset], check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        runner = Runner(args.lcv, args.timeout, os.path.join(dataset, "map"))
        counts = {"crash": 0, "hang": 0, "unreadable": 0, "unnamed": 0, "slow": 0}
        maps = runs = accepted = 0
        start = time.time()
        results = open(args.results, "a")
        lock = threading.Lock()

        def one(index):
            if stop.is_set():
                return None
            scratch = os.path.join(work, f"job-{threading.get_ident()}")
            os.makedirs(scratch, exist_ok=True)
            return runner.check_map(index, seeds, scratch)

        indices = iter(range(args.start, args.start + args.maps))
        with concurrent.futures.ThreadPoolExecutor(max_workers=args.jobs) as pool:
            pending = set()
            while True:
                while len(pending) < 2 * args.jobs and not stop.is_set():
                    index = next(indices, None)
                    if index is None:
                        break
                    pending.add(pool.submit(one, index))
                if not pending:
                    break
                done, pending = concurrent.futures.wait(pending, return_when=concurrent.futures.FIRST_COMPLETED)
                for future in done:
                    result = future.result()
                    if result is None:
                        continue
                    map_runs, findings, map_accepted = result
                    with lock:
                        maps += 1
                        runs += map_runs
                        accepted += map_accepted
                        for finding in findings:
                            counts[finding["kind"]] += 1
                            results.write(json.dumps(finding) + "\n")
                            results.flush()
                            print(f"FOUND {finding['kind']}: map {finding['map']} ({finding['seed']}) "
                                  f"{finding['command']}: exit {finding['exit']}: {finding['stderr'][-200:]}",
                                  file=sys.stderr, flush=True)
                            if args.keep and finding.get("bytes_hex") is not None:
                                os.makedirs(args.keep, exist_ok=True)
                                name = f"hostile-{finding['map']}{os.path.splitext(finding['seed'])[1]}"
                                with open(os.path.join(args.keep, name), "wb") as f:
                                    f.write(bytes.fromhex(finding["bytes_hex"]))
                        if maps % args.progress_every == 0:
                            elapsed = time.time() - start
                            print(f"hostile maps: {maps}/{args.maps} maps, {runs} runs, {elapsed:.0f} s "
                                  f"({maps / elapsed:.2f} maps/s), crashes {counts['crash']}, hangs "
                                  f"{counts['hang']}, unreadable {counts['unreadable']}, unnamed "
                                  f"{counts['unnamed']}, slow {counts['slow']}", file=sys.stderr, flush=True)
        elapsed = time.time() - start
        summary = {"summary": True, "first_map": args.start, "maps": maps, "maps_requested": args.maps,
                   "runs": runs, "accepted_by_map_info": accepted, "seconds": round(elapsed, 1),
                   "jobs": args.jobs, "timeout_s": args.timeout, "lcv": args.lcv, **counts,
                   "date": time.strftime("%Y-%m-%d %H:%M:%S UTC", time.gmtime())}
        results.write(json.dumps(summary) + "\n")
        results.close()
        print(f"maps {maps} (from {args.start}; accepted by map info: {accepted}), runs {runs} in "
              f"{elapsed:.0f} s ({maps / max(elapsed, 1e-9):.2f} maps/s)")
        print(f"crashes {counts['crash']}, hangs {counts['hang']}, unreadable outputs {counts['unreadable']}, "
              f"errors not naming the file {counts['unnamed']} (slow but finished on the CPU-bounded "
              f"second try: {counts['slow']})")
    finally:
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
