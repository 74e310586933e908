#!/usr/bin/env python3
"""SIGKILL campaign against the cache (issue 17).

Runs the quickstart study (synthesis, noise, a simulated impact test,
AutoEMA twice, scores, report, export) over and over on one cache, each
iteration with a new pipeline seed so that the random stages recompute, and
kills the whole process group with SIGKILL after a random delay. After each
kill it counts what the dead run left: temp files in cache/tmp, its lock
file there, hidden staging folders and half-copied files in the results.
The next run must clean those and complete the cache.

At the end, for a few of the seeds, a complete run on the campaign cache is
compared byte for byte with a clean run on an empty cache (every result
file; manifests by their outputs, since they record wall times).

    cargo build --release
    python3 benchmarks/kill_campaign.py [--iterations 120] [--seed 1]

Prints one summary line per figure; exits 1 if any comparison differs or
leftovers survive a complete run.
"""

import argparse
import json
import os
import random
import shutil
import signal
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BIN = os.path.join(ROOT, "target", "release", "modalflow")


def workspace(base):
    os.makedirs(base)
    shutil.copytree(os.path.join(ROOT, "pipelines", "models"), os.path.join(base, "models"))
    with open(os.path.join(ROOT, "pipelines", "quickstart.yaml")) as f:
        return f.read()


def write_pipeline(base, text, seed):
    lines = [l for l in text.splitlines() if not l.startswith("seed:")]
    lines.insert(1, f"seed: {seed}")
    with open(os.path.join(base, "p.yaml"), "w") as f:
        f.write("\n".join(lines) + "\n")


def run(base, check=True):
    r = subprocess.run([BIN, "run", "p.yaml", "--progress", "none"], cwd=base,
                       capture_output=True, text=True)
    if check and r.returncode != 0:
        sys.exit(f"run failed in {base}: {r.stderr}")
    return r


def leftovers(base):
    """(temp files, lock files, staging folders and half-copied files)."""
    tmp = os.path.join(base, "cache", "tmp")
    names = os.listdir(tmp) if os.path.isdir(tmp) else []
    locks = sum(1 for n in names if n.startswith("live-") or n.startswith(".live-"))
    temps = len(names) - locks
    staging = 0
    for d, dirs, files in os.walk(os.path.join(base, "results")):
        staging += sum(1 for x in dirs if ".staging-" in x)
        staging += sum(1 for x in files if ".modalflow-tmp-" in x)
    for n in os.listdir(base):
        staging += ".modalflow-tmp-" in n
    return temps, locks, staging


def snapshot(base):
    """Every result file's bytes; manifests reduced to their outputs."""
    out = {}
    root = os.path.join(base, "results")
    for d, _, files in os.walk(root):
        for f in files:
            p = os.path.join(d, f)
            rel = os.path.relpath(p, root)
            with open(p, "rb") as fh:
                data = fh.read()
            if f == "manifest.json":
                m = json.loads(data)
                data = json.dumps({"key": m["key"], "outputs": m["outputs"]}, sort_keys=True).encode()
            out[rel] = data
    return out


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--iterations", type=int, default=120)
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args()
    rng = random.Random(args.seed)
    top = tempfile.mkdtemp(prefix="modalflow-kill-")
    base = os.path.join(top, "campaign")
    text = workspace(base)

    # The duration of one full run, to spread the kills over it.
    write_pipeline(base, text, 10_000)
    t0 = time.perf_counter()
    run(base)
    full = time.perf_counter() - t0

    live_kills = 0
    max_left = (0, 0, 0)
    left_after_run = 0
    for i in range(args.iterations):
        write_pipeline(base, text, 1 + i)
        p = subprocess.Popen([BIN, "run", "p.yaml", "--progress", "none"], cwd=base,
                             stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                             start_new_session=True)
        time.sleep(rng.uniform(0.0, 1.6 * full))
        if p.poll() is None:
            live_kills += 1
            os.killpg(p.pid, signal.SIGKILL)
        else:
            # The run finished: it must have cleaned what the last kill left.
            after = leftovers(base)
            left_after_run += after[0] + after[2]
        p.wait()
        left = leftovers(base)
        max_left = tuple(max(a, b) for a, b in zip(max_left, left))

    seeds = [1, 1 + args.iterations // 2, args.iterations]
    differ = 0
    for s in seeds:
        write_pipeline(base, text, s)
        run(base)
        clean = os.path.join(top, f"clean-{s}")
        workspace(clean)
        write_pipeline(clean, text, s)
        run(clean)
        a, b = snapshot(base), snapshot(clean)
        bad = sorted(k for k in set(a) | set(b) if a.get(k) != b.get(k))
        if bad:
            differ += 1
            print(f"seed {s}: {len(bad)} files differ, e.g. {bad[:3]}")
    final = leftovers(base)
    print(f"full run: {full:.2f} s; iterations: {args.iterations}; kills on a live run: {live_kills}")
    print(f"most left by one kill: {max_left[0]} temp files, {max_left[1]} lock files, "
          f"{max_left[2]} staging folders/half files")
    print(f"left after a complete run: {final[0]} temp files, {final[1]} lock files, "
          f"{final[2]} staging (runs that finished without cleaning: {left_after_run})")
    print(f"byte-for-byte comparisons with clean runs: {len(seeds) - differ}/{len(seeds)} identical")
    shutil.rmtree(top, ignore_errors=True)
    if differ or sum(final):
        sys.exit(1)


if __name__ == "__main__":
    main()
