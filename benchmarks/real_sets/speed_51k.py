#!/usr/bin/env python3
"""AutoEMA at a real size: 9 FRFs x 51,201 lines (the size of the roving-hammer beam of
issue 31, 0.0156 Hz lines), modalflow against sdypy-EMA's LSCF, CPU and peak RSS
measured in the same run, interleaved, best of n.

The set is built from a real one: the modal model modalflow (autoema 7, frozen in
`beam51k_model/`; `--refit` to identify it anew) identifies on the UFSC beam's
hammer test (`../shared/data/real/beam_ufsc_ss`, 30 references x 1 response, 5-800 Hz),
resynthesized (H_j3 = sum_r phi_jr phi_3r / (i w - l_r) + conj., as accelerance) at 9 of
its hammer points on 51,201 lines over 0-800 Hz, with complex Gaussian noise of 1 % of
each channel's RMS (seeded). It is written twice as UFF 58b: as measured (9 references x
1 response) and in the reciprocal layout (1 x 9).

    /tmp/aeenv/bin/python benchmarks/real_sets/speed_51k.py --modalflow target/release/modalflow [--n 3]

Each run is its own process (modalflow: `run` of an import + autoema pipeline with a fresh
cache; sdypy-EMA: the procedure of peer_compare.py — LSCF to order 120, its stabilization,
the automatic pick and `select_closest_poles`); CPU = user + system of that process
(os.wait4), RSS its peak. The three are run in turn n times; best of n is reported, with
the ratios of the best CPU times.
"""
import argparse
import csv
import json
import os
import shutil
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import peer_compare as pc  # noqa: E402

N_LINES = 51201
F_MAX = 800.0
BAND = (5.0, 800.0)
NODES = [2, 5, 8, 11, 14, 20, 24, 28, 32]   # 9 of the 30 hammer points
RESPONSE = 3                                # the accelerometer (node 3, -Z)
NOISE = 0.01


# The modal model the case is built from, frozen so that the case does not change with the
# binary under test: autoema 7 (main ad3352c) on the hammer set, 15 modes (modes.csv and
# mode_shapes.csv as that run wrote them). `--refit` identifies it anew with `--modalflow`.
FROZEN = os.path.join(HERE, "beam51k_model")


def modal_model(binary, workdir, refit=False):
    """Modes and shapes modalflow identifies on the real hammer set (frozen unless `refit`)."""
    base = FROZEN
    if refit or not os.path.exists(os.path.join(FROZEN, "modes.csv")):
        pc.run_modalflow(binary, "beam_ufsc_hammer", workdir)
        base = os.path.join(workdir, "beam_ufsc_hammer", "results", "beam_ufsc_hammer", "ema", "modes")
    modes = {int(r["mode"]): (float(r["frequency_hz"]), float(r["damping_ratio"]))
             for r in csv.DictReader(open(os.path.join(base, "modes.csv")))}
    shapes = {}
    for r in csv.DictReader(open(os.path.join(base, "mode_shapes.csv"))):
        shapes[(int(r["mode"]), int(r["node"]))] = complex(float(r["real"]), float(r["imag"]))
    return modes, shapes


def synthesize(modes, shapes):
    f = np.linspace(0.0, F_MAX, N_LINES)
    w = 2 * np.pi * f
    rng = np.random.default_rng(31)
    frf = []
    for j in NODES:
        h = np.zeros(N_LINES, dtype=complex)
        for k, (fr, z) in modes.items():
            lam = -z * 2 * np.pi * fr + 1j * 2 * np.pi * fr * np.sqrt(1 - z * z)
            # The shapes are at the fitted outputs (the hammer points); the
            # accelerometer's participation is not a shape entry, so each
            # mode's residue is phi_j * phi_j0 with j0 the strongest point.
            r = shapes.get((k, j), 0.0) * max((shapes.get((k, n), 0.0) for n in NODES), key=abs)
            h += r / (1j * w - lam) + np.conj(r) / (1j * w - np.conj(lam))
        h *= -(w ** 2)  # accelerance
        rms = np.sqrt(np.mean(np.abs(h) ** 2))
        h += NOISE * rms * (rng.standard_normal(N_LINES) + 1j * rng.standard_normal(N_LINES)) / np.sqrt(2)
        frf.append(h)
    return f, np.array(frf)


def write_uff(path, f, frf, reciprocal):
    import pyuff
    if os.path.exists(path):
        os.remove(path)
    u = pyuff.UFF(path)
    for j, h in zip(NODES, frf):
        rsp, ref = ((j, -3), (RESPONSE, -3)) if reciprocal else ((RESPONSE, -3), (j, -3))
        d = pyuff.prepare_58(binary=1, func_type=4, rsp_node=rsp[0], rsp_dir=rsp[1], ref_node=ref[0],
                             ref_dir=ref[1], data=h, x=f, id1="FRF H1",
                             id2="UFSC beam modal model resynthesized on 51,201 lines, 1 % noise",
                             abscissa_spacing=1, abscissa_min=0.0, abscissa_inc=float(f[1] - f[0]),
                             abscissa_spec_data_type=18, abscissa_axis_units_lab="Hz",
                             ordinate_spec_data_type=12, ordinate_axis_units_lab="m/s^2",
                             orddenom_spec_data_type=13, orddenom_axis_units_lab="N",
                             rsp_ent_name="beam", ref_ent_name="beam")
        u.write_sets(d, mode="add")


def sdypy_child(path, out):
    pc.SETS["speed"] = {"files": [path], "band": BAND}
    frf, freq = pc.load_set("speed")
    json.dump(pc.run_sdypy(frf, freq, *BAND), open(out, "w"))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--modalflow", required=False)
    ap.add_argument("--n", type=int, default=3)
    ap.add_argument("--workdir", default="/tmp/modalflow_speed_51k")
    ap.add_argument("--child", nargs=2)
    ap.add_argument("--refit", action="store_true", help="identify the modal model anew instead of the frozen one")
    a = ap.parse_args()
    if a.child:
        return sdypy_child(*a.child)
    os.makedirs(a.workdir, exist_ok=True)
    modes, shapes = modal_model(a.modalflow, a.workdir, a.refit)
    f, frf = synthesize(modes, shapes)
    files = {}
    for name, recip in (("as_measured", False), ("reciprocal", True)):
        files[name] = os.path.join(a.workdir, f"beam51k_{name}.uff")
        write_uff(files[name], f, frf, recip)
        pc.SETS[f"beam51k_{name}"] = {"files": [files[name]], "band": BAND}
    print(f"{len(modes)} modes, {frf.shape[0]} FRFs x {frf.shape[1]} lines", flush=True)
    best = {}
    result = {}
    for i in range(a.n):
        for tool in ("modalflow as_measured", "modalflow reciprocal", "sdypy"):
            if tool == "sdypy":
                out = os.path.join(a.workdir, "sdypy.json")
                cpu, rss = pc.measured([sys.executable, os.path.abspath(__file__), "--child",
                                        files["as_measured"], out])
                r = json.load(open(out))
            else:
                r = pc.run_modalflow(a.modalflow, "beam51k_" + tool.split()[1], a.workdir)
                cpu, rss = r["cpu_s"], r["peak_rss_mib"]
            n = len(r["frequency_hz"])
            print(f"run {i + 1} {tool:22s} cpu {cpu:6.2f} s  rss {rss:5.0f} MiB  {n} modes", flush=True)
            if tool not in best or cpu < best[tool][0]:
                best[tool] = (cpu, rss)
                result[tool] = r["frequency_hz"]
    ref = sorted(m[0] for m in modes.values() if BAND[0] <= m[0] <= BAND[1])
    print(f"\nbest of {a.n} (CPU s, peak RSS MiB), modes found within 1 % of the {len(ref)} synthesized:")
    for tool, (cpu, rss) in best.items():
        found = len(pc.match(result[tool], ref))
        print(f"  {tool:22s} {cpu:6.2f} s  {rss:5.0f} MiB  {found}/{len(ref)} found, "
              f"{len(result[tool]) - found} extra")
    s = best["sdypy"][0]
    print(f"ratios: sdypy / modalflow as measured = {s / best['modalflow as_measured'][0]:.2f}, "
          f"as measured / reciprocal = "
          f"{best['modalflow as_measured'][0] / best['modalflow reciprocal'][0]:.2f}")


if __name__ == "__main__":
    main()
