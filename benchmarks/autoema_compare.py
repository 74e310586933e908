#!/usr/bin/env python3
"""modalflow `autoema` side by side with the published PUB5 code (PyPI `autoema`)
on the same FRFs: the synthetic families of issue 14 and one PUB5-size case.

Each case is exported by the Rust bench (`cargo bench --bench polymax -- export`,
exact modal truth from `modalflow::ema::families`): `frf.uff` (58b) for
modalflow's `import` → `autoema` pipeline (only `band` and `seed` set), and
`frf.bin` for the PUB5 code's `OptModel` (all FRFs as rows, 40 BO evaluations
each, its own bounds and regularization). Each tool runs in its own process;
CPU seconds (user + system) and peak memory (max RSS) come from `os.wait4` of
that process, so both include start-up and file reading.

Both results are scored here in the same way: estimates paired with true modes
by the Hungarian method on NFD/0.005 + (1 − MAC_S) within 2 % in frequency
(MAC_S: MAC with the projection on the span of the true shapes at a root, so a
repeated root is scored by its subspace); a true mode is *visible* when its
peak stands ≥ 10× above the noise at its best channel (from the exporter); it
is *found* when paired with NFD < 0.5 %, NDD < 20 %, MAC_S ≥ 0.9; unpaired
estimates within 2 % of a true mode are *duplicates*, others *spurious*. A case
succeeds when every visible mode is found with nothing duplicate or spurious
and mean FRAC ≥ 1/(1 + r²) − 0.001. PUB5's shapes are the dominant left
singular vector of its residues reshaped to outputs × references. Medians of
NFD/NDD/MAC are over found modes.

Set-up (PyPI AutoEMA 0.0 predates scikit-learn 1.4, which renamed
AgglomerativeClustering's `affinity=` to `metric=`):

    python3 -m venv /tmp/aeenv
    /tmp/aeenv/bin/pip install numpy scipy scikit-learn "bayesian-optimization<2" sdypy-ema pyuff
    /tmp/aeenv/bin/pip install --no-deps autoema
    sed -i "s/affinity='l1'/metric='l1'/" /tmp/aeenv/lib/python3.11/site-packages/AutoEMA/AutoEMA.py
    cargo build --release && cargo bench --bench polymax --no-run
    /tmp/aeenv/bin/python benchmarks/autoema_compare.py --seeds 5            # families
    /tmp/aeenv/bin/python benchmarks/autoema_compare.py --pub5-size          # 600 FRFs x 2001 lines x 4 positions
    /tmp/aeenv/bin/python benchmarks/autoema_compare.py --test-bench         # pipelines/autoema_study.yaml

`--test-bench` runs `pipelines/autoema_study.yaml` (test bench, 4 positions,
2 % noise) with an added CSV export, runs the PUB5 code per position on the
same FRFs, and scores both against the noise-free model's modes (visibility
from the modal model: |φ_o φ_i|/(2ζω²) over 2 % of each channel's RMS).
"""
import argparse
import csv
import glob
import json
import os
import subprocess
import sys
import tempfile

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def bench_binary():
    out = subprocess.run(["cargo", "bench", "--bench", "polymax", "--no-run", "--message-format=json"],
                         cwd=ROOT, capture_output=True, text=True, check=True).stdout
    for line in out.splitlines():
        msg = json.loads(line)
        if msg.get("reason") == "compiler-artifact" and msg.get("target", {}).get("name") == "polymax" \
                and msg.get("executable"):
            return msg["executable"]
    sys.exit("cannot find the polymax bench binary; run cargo bench --bench polymax --no-run")


def run_measured(cmd, cwd):
    """Run cmd; return (CPU seconds of the child, peak RSS in MiB)."""
    p = subprocess.Popen(cmd, cwd=cwd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    _, status, ru = os.wait4(p.pid, 0)
    err = p.stderr.read().decode(errors="replace")
    if os.waitstatus_to_exitcode(status) != 0:
        raise RuntimeError(f"{cmd[0]} failed: {err[-2000:]}")
    return ru.ru_utime + ru.ru_stime, ru.ru_maxrss / 1024.0


PIPELINE = """name: cmp
seed: {seed}
stages:
  measured:
    kind: import
    params: {{path: frf.uff}}
  ema:
    kind: autoema
    inputs: {{frf: measured.frf}}
    params: {{band: [{lo}, {hi}]}}
"""

PUB5_RUNNER = r"""
import json, sys, numpy as np
from AutoEMA import AutoEMA as ae
d = json.load(open('case.json'))
f = np.array(d['frequencies_hz'])
raw = np.fromfile('frf.bin', dtype='<f8')
frf = (raw[0::2] + 1j * raw[1::2]).reshape(-1, len(f))
model = ae.OptModel(frf=frf, f_axis=f, show_progress=False)
model.optimize(n_init=int(sys.argv[1]), n_iter=int(sys.argv[2]))
_, _, nat, damp, ms = model.get_results()
json.dump({'frequency_hz': [float(x) for x in np.atleast_1d(nat)],
           'damping_ratio': [float(x) for x in np.atleast_1d(damp)],
           'residues_re': np.real(np.atleast_2d(ms)).tolist(), 'residues_im': np.imag(np.atleast_2d(ms)).tolist(),
           'mean_frac': float(model.get_frac())}, open('pub5.json', 'w'))
"""


def subspace_mac(v, basis):
    q, _ = np.linalg.qr(np.array(basis, dtype=complex).T)
    vv = np.vdot(v, v).real
    return float(np.sum(np.abs(q.conj().T @ v) ** 2) / vv) if vv > 0 else 0.0


def score(case, est, mean_frac):
    from scipy.optimize import linear_sum_assignment
    modes, vis, noise = case["modes"], case["visibility"], case["noise"]
    span = [[np.array(m["shape"], dtype=complex) for m in modes if m["frequency_hz"] == t["frequency_hz"]] for t in modes]
    big = 1e6
    nfd = lambda a, b: abs(a - b) / min(a, b)
    cost = np.full((len(est), len(modes)), big)
    for i, e in enumerate(est):
        for k, t in enumerate(modes):
            d = nfd(e["frequency_hz"], t["frequency_hz"])
            if d <= 0.02:
                cost[i, k] = d / 0.005 + (1 - subspace_mac(e["shape"], span[k]))
    s = {"visible": sum(v >= 10 for v in vis), "found": 0, "spurious": 0, "duplicate": 0, "nfd": [], "ndd": [], "mac": []}
    paired = set()
    if len(est):
        rows, cols = linear_sum_assignment(cost)
        for i, k in zip(rows, cols):
            if cost[i, k] >= big:
                continue
            paired.add(i)
            e, t = est[i], modes[k]
            d = nfd(e["frequency_hz"], t["frequency_hz"])
            z = abs(e["damping_ratio"] - t["damping_ratio"]) / t["damping_ratio"]
            mac = subspace_mac(e["shape"], span[k])
            if vis[k] >= 10 and d < 0.005 and z < 0.2 and mac >= 0.9:
                s["found"] += 1
                s["nfd"].append(d), s["ndd"].append(z), s["mac"].append(mac)
    for i, e in enumerate(est):
        if i not in paired:
            near = any(nfd(e["frequency_hz"], t["frequency_hz"]) <= 0.02 for t in modes)
            s["duplicate" if near else "spurious"] += 1
    s["frac"] = mean_frac
    s["success"] = s["found"] == s["visible"] and s["spurious"] == 0 and s["duplicate"] == 0 \
        and mean_frac >= 1 / (1 + noise ** 2) - 0.001
    return s


def modalflow_estimates(d, n_out, position=0):
    res = os.path.join(d, "results/cmp/ema")
    modes = [r for r in csv.DictReader(open(os.path.join(res, "modes/modes.csv"))) if r.get("position", "0") == str(position)]
    shapes = {}
    for r in csv.DictReader(open(os.path.join(res, "modes/mode_shapes.csv"))):
        if r.get("position", "0") == str(position):
            shapes.setdefault(int(r["mode"]), {})[int(r["node"])] = complex(float(r["real"]), float(r["imag"]))
    est = []
    for r in modes:
        sh = shapes[int(r["mode"])]
        est.append({"frequency_hz": float(r["frequency_hz"]), "damping_ratio": float(r["damping_ratio"]),
                    "shape": np.array([sh.get(j + 1, 0) for j in range(n_out)])})
    metrics = json.load(open(os.path.join(res, "metrics.json")))
    return est, metrics["positions"][position]["mean_frac"], metrics


def pub5_estimates(d, n_out, n_ref):
    r = json.load(open(os.path.join(d, "pub5.json")))
    res = np.array(r["residues_re"]) + 1j * np.array(r["residues_im"])  # channels x modes
    est = []
    for k, (f, z) in enumerate(zip(r["frequency_hz"], r["damping_ratio"])):
        if res.size == 0:
            break
        m = res[:, k].reshape(n_out, n_ref)
        u, _, _ = np.linalg.svd(m, full_matrices=False)
        est.append({"frequency_hz": f, "damping_ratio": z, "shape": u[:, 0]})
    return est, r["mean_frac"]


def run_case(binary, family, seed, noise, pub5_evals, positions=1):
    with tempfile.TemporaryDirectory() as d:
        subprocess.run([binary, "export", d, family, str(seed), str(noise), str(positions)], check=True)
        case = json.load(open(os.path.join(d, "case.json")))
        f = case["frequencies_hz"]
        n_out, n_ref = case["n_out"], len(case["references"])
        with open(os.path.join(d, "p.yaml"), "w") as fh:
            fh.write(PIPELINE.format(seed=seed, lo=f[0], hi=f[-1]))
        mf_cpu, mf_mem = run_measured([os.path.join(ROOT, "target/release/modalflow"), "run", "p.yaml", "--progress", "none"], d)
        est, frac, metrics = modalflow_estimates(d, n_out)
        mf = score(case, est, frac)
        mf.update(cpu=mf_cpu, mem=mf_mem, goal=metrics["goal_reached"])
        with open(os.path.join(d, "pub5_run.py"), "w") as fh:
            fh.write(PUB5_RUNNER)
        n_init = pub5_evals // 2
        # The PUB5 code analyses one FRF matrix per call: one call per position.
        ae_cpu, ae_mem = 0.0, 0.0
        for _ in range(positions):
            c, m = run_measured([sys.executable, "pub5_run.py", str(n_init), str(pub5_evals - n_init)], d)
            ae_cpu, ae_mem = ae_cpu + c, max(ae_mem, m)
        est, frac = pub5_estimates(d, n_out, n_ref)
        ae = score(case, est, frac)
        ae.update(cpu=ae_cpu, mem=ae_mem)
        return mf, ae


def read_csv_frf(path):
    with open(path) as f:
        rows = list(csv.reader(line for line in f if not line.startswith("#")))
    head, data = rows[0], rows[1:]
    pos = head.index("position") if "position" in head else None
    chans = [h[3:] for h in head if h.startswith("re:")]
    out = {}
    for r in data:
        p = int(r[pos]) if pos is not None else 0
        out.setdefault(p, []).append(r)
    sets = {}
    for p, rs in out.items():
        skip = {head.index(k) for k in ("position_label",) if k in head}
        a = np.array([[np.nan if (j in skip or not x) else float(x) for j, x in enumerate(r)] for r in rs])
        f = a[:, head.index("frequency_hz")]
        h = np.array([a[:, head.index("re:" + c)] + 1j * a[:, head.index("im:" + c)] for c in chans])
        sets[p] = (f, h)
    return chans, sets


def bench_modes(res, stage, position):
    modes = [r for r in csv.DictReader(open(os.path.join(res, stage, "modes/modes.csv"))) if r.get("position", "0") == str(position)]
    shapes = {}
    for r in csv.DictReader(open(os.path.join(res, stage, "modes/mode_shapes.csv"))):
        if r.get("position", "0") == str(position):
            shapes.setdefault(int(r["mode"]), {})[r["node"] + r["direction"]] = complex(float(r["real"]), float(r["imag"]))
    return [(float(r["frequency_hz"]), float(r["damping_ratio"]), shapes[int(r["mode"])]) for r in modes]


def test_bench(pub5_evals):
    import shutil
    with tempfile.TemporaryDirectory() as d:
        shutil.copytree(os.path.join(ROOT, "pipelines"), os.path.join(d, "pipelines"))
        path = os.path.join(d, "pipelines/autoema_study.yaml")
        with open(path, "a") as fh:
            fh.write("  csv:\n    kind: export\n    inputs: {frf: measured.frf}\n    params: {format: csv}\n")
        mf_cpu, mf_mem = run_measured([os.path.join(ROOT, "target/release/modalflow"), "run", path, "--progress", "none"], d)
        res = os.path.join(d, "results/autoema_study")
        csv_path = glob.glob(os.path.join(res, "csv/**/*.csv"), recursive=True)[0]
        chans, sets = read_csv_frf(csv_path)
        dofs = sorted({c.split("/")[0] for c in chans})
        refs = sorted({c.split("/")[1] for c in chans})
        rows = []
        for p in sorted(sets):
            f, h = sets[p]
            keep = ~np.isnan(h).any(axis=0)
            f, h = f[keep], h[:, keep]
            truth = bench_modes(res, "truth", p)
            rms = np.sqrt(np.mean(np.abs(h) ** 2, axis=1))
            modes, vis = [], []
            for fr, z, sh in truth:
                modes.append({"frequency_hz": fr, "damping_ratio": z, "shape": [sh.get(o, 0).real for o in dofs]})
                w = 2 * np.pi * fr
                vis.append(max(abs(sh.get(c.split("/")[0], 0) * sh.get(c.split("/")[1], 0)) / (2 * z * w * w) / (0.02 * rms[k])
                               for k, c in enumerate(chans)))
            case = {"modes": modes, "visibility": vis, "noise": 0.02}
            est = [{"frequency_hz": fr, "damping_ratio": z, "shape": np.array([sh.get(o, 0) for o in dofs])}
                   for fr, z, sh in bench_modes(res, "ema", p)]
            frac = json.load(open(os.path.join(res, "ema/metrics.json")))["positions"][p]["mean_frac"]
            mf = score(case, est, frac)
            mf.update(cpu=mf_cpu / len(sets), mem=mf_mem)
            np.asarray(np.column_stack([h.real, h.imag]).reshape(len(chans), 2, -1).transpose(0, 2, 1), "<f8").tofile(os.path.join(d, "frf.bin"))
            json.dump({"frequencies_hz": list(f)}, open(os.path.join(d, "case.json"), "w"))
            with open(os.path.join(d, "pub5_run.py"), "w") as fh:
                fh.write(PUB5_RUNNER)
            ae_cpu, ae_mem = run_measured([sys.executable, "pub5_run.py", str(pub5_evals // 2), str(pub5_evals - pub5_evals // 2)], d)
            r = json.load(open(os.path.join(d, "pub5.json")))
            resid = np.array(r["residues_re"]) + 1j * np.array(r["residues_im"])
            est = []
            for k, (fr, z) in enumerate(zip(r["frequency_hz"], r["damping_ratio"])):
                m = np.zeros((len(dofs), len(refs)), complex)
                for c, name in enumerate(chans):
                    o, i = name.split("/")
                    m[dofs.index(o), refs.index(i)] = resid[c, k]
                est.append({"frequency_hz": fr, "damping_ratio": z, "shape": np.linalg.svd(m)[0][:, 0]})
            ae = score(case, est, r["mean_frac"])
            ae.update(cpu=ae_cpu, mem=ae_mem)
            rows += [(f"test bench position {p}", "modalflow", mf), (f"test bench position {p}", "PUB5", ae)]
            print(f"position {p}: modalflow {mf['found']}/{mf['visible']} spur {mf['spurious']} dup {mf['duplicate']} | "
                  f"PUB5 {ae['found']}/{ae['visible']} spur {ae['spurious']} dup {ae['duplicate']}", flush=True)
        report(rows, "test bench (autoema_study.yaml), 2 % noise; modalflow CPU is the whole pipeline / 4")


def med(v):
    return float(np.median(v)) if v else float("nan")


def report(rows, title):
    print(f"\n{title}")
    head = f"{'case':<26}{'tool':<11}{'success':>8}{'found':>9}{'spur':>6}{'dup':>5}{'med NFD':>10}{'med NDD':>9}{'med MAC':>9}{'FRAC':>9}{'CPU s':>8}{'MiB':>7}"
    print(head)
    for name, tool, s in rows:
        print(f"{name:<26}{tool:<11}{str(s['success']):>8}{s['found']:>5}/{s['visible']:<3}{s['spurious']:>6}{s['duplicate']:>5}"
              f"{med(s['nfd']):>10.2e}{med(s['ndd']):>9.3f}{med(s['mac']):>9.4f}{s['frac']:>9.5f}{s['cpu']:>8.2f}{s['mem']:>7.0f}")


def summary(rows):
    print(f"\n{'family/noise':<26}{'tool':<11}{'success':>9}{'missed':>8}{'spur':>6}{'dup':>5}{'med NFD':>10}{'med NDD':>9}{'med MAC':>9}{'CPU s':>9}")
    groups = {}
    for name, tool, s in rows:
        groups.setdefault((name.rsplit(" seed", 1)[0], tool), []).append(s)
    for (name, tool), ss in groups.items():
        print(f"{name:<26}{tool:<11}{sum(s['success'] for s in ss):>5}/{len(ss):<3}{sum(s['visible'] - s['found'] for s in ss):>8}"
              f"{sum(s['spurious'] for s in ss):>6}{sum(s['duplicate'] for s in ss):>5}"
              f"{med([x for s in ss for x in s['nfd']]):>10.2e}{med([x for s in ss for x in s['ndd']]):>9.3f}"
              f"{med([x for s in ss for x in s['mac']]):>9.4f}{np.mean([s['cpu'] for s in ss]):>9.2f}")
    for name in sorted({n for n, _ in groups}):
        mf, ae = groups.get((name, "modalflow")), groups.get((name, "PUB5"))
        if mf and ae:
            print(f"{name}: CPU ratio PUB5/modalflow {np.mean([s['cpu'] for s in ae]) / np.mean([s['cpu'] for s in mf]):.1f}x")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--noise", type=float, nargs="+", default=[0.02, 0.05])
    ap.add_argument("--families", nargs="+", default=["close_pair", "repeated_root", "high_damping"])
    ap.add_argument("--pub5-evaluations", type=int, default=40)
    ap.add_argument("--pub5-size", action="store_true", help="one PUB5-size case: 600 FRFs x 2001 lines x 4 positions")
    ap.add_argument("--test-bench", action="store_true", help="pipelines/autoema_study.yaml beside the PUB5 code")
    a = ap.parse_args()
    if a.test_bench:
        test_bench(a.pub5_evaluations)
        return
    binary = bench_binary()
    rows = []
    if a.pub5_size:
        mf, ae = run_case(binary, "large", 1, 0.02, a.pub5_evaluations, positions=4)
        rows = [("large (4 positions) seed 1", "modalflow", mf), ("large (4 positions) seed 1", "PUB5", ae)]
        report(rows, "PUB5 size: 300 outputs x 2 references x 2001 lines, 4 positions, 2 % noise "
                     "(scores of position 0; CPU and memory of all four)")
        summary(rows)
        return
    for noise in a.noise:
        for fam in a.families:
            for seed in range(1, a.seeds + 1):
                mf, ae = run_case(binary, fam, seed, noise, a.pub5_evaluations)
                name = f"{fam} {noise:.2f} seed {seed}"
                rows += [(name, "modalflow", mf), (name, "PUB5", ae)]
                print(f"{name}: modalflow {mf['found']}/{mf['visible']} spur {mf['spurious']} dup {mf['duplicate']} "
                      f"{mf['cpu']:.2f}s | PUB5 {ae['found']}/{ae['visible']} spur {ae['spurious']} dup {ae['duplicate']} {ae['cpu']:.2f}s",
                      flush=True)
    report(rows, "per case")
    summary(rows)


if __name__ == "__main__":
    main()
