"""Every tool's modes on one yardstick: how well does each mode set reproduce the measured FRFs?

The tools of `peer_compare.py` each report a mean FRAC from their own fit (or none), so their
figures are not comparable. Here one least-squares frequency-domain fit (LSFD: per channel, a
complex residue per pole in conjugate pairs, 1/(jω − λ) + conj, plus a constant and a 1/ω² residual
term) is made at each tool's poles (frequency, damping ratio) on the set's band, and the mean FRAC
over the channels (eq. 2.66) is reported. Then, for modalflow's result against the set's reference
(published modes plus the peers' consensus, as in `peer_compare.py`):

- each **missed** reference mode: the nearest peer pole is added to modalflow's poles — how much
  FRAC does the data give for it?
- each **extra** modalflow mode: it is dropped — how much FRAC does the data lose?

FRAC weighs every line by its power, so a weak mode moves it little wherever it is real; the
differences rank the misses and extras by what the data say, they do not prove a mode absent.

Usage (after `peer_compare.py --modalflow <binary> --out OUT`, which writes OUT.json):

    python benchmarks/real_sets/same_yardstick.py OUT.json [set ...]

Needs numpy and pyuff (the venv of `peer_compare.py`).
"""

import json
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import peer_compare as pc  # noqa: E402

TOOLS = ("modalflow", "sdypy", "pub5")


def frac(h, g):
    """FRAC of two FRFs (eq. 2.66)."""
    return abs(np.vdot(g, h)) ** 2 / (np.vdot(h, h).real * np.vdot(g, g).real)


def lsfd_frac(H, f, fr, zr):
    """Mean FRAC of the LSFD fit of H (channels × lines at f, Hz) at the poles (fr Hz, zr)."""
    w = 2 * np.pi * np.asarray(f)
    fr, zr = np.asarray(fr, dtype=float), np.asarray(zr, dtype=float)
    lam = 2 * np.pi * fr * (-zr + 1j * np.sqrt(1 - zr**2))
    n = len(lam)
    pos = 1 / (1j * w[:, None] - lam[None, :])
    neg = 1 / (1j * w[:, None] - np.conj(lam)[None, :])
    # H = B x + C conj(x): residues R_r with their conjugates, a constant, a 1/ω² term.
    B = np.hstack([pos, np.ones((len(w), 1)), (1 / w**2)[:, None]])
    C = np.hstack([neg, np.zeros((len(w), 2))])
    # x = a + ib: H = (B + C) a + i (B − C) b, stacked as real equations.
    M = np.vstack(
        [np.hstack([(B + C).real, -(B - C).imag]), np.hstack([(B + C).imag, (B - C).real])]
    )
    fracs = []
    for h in H:
        x, *_ = np.linalg.lstsq(M, np.concatenate([h.real, h.imag]), rcond=None)
        xc = x[: n + 2] + 1j * x[n + 2 :]
        fracs.append(frac(h, B @ xc + C @ np.conj(xc)))
    return float(np.mean(fracs))


def poles(result, lo, hi):
    fr = np.asarray(result["frequency_hz"], dtype=float)
    zr = np.asarray(result["damping_ratio"], dtype=float)
    keep = (fr >= lo) & (fr <= hi) & (zr > 0) & (zr < 1)
    return list(fr[keep]), list(zr[keep])


def report(name, rr):
    H, f = pc.load_set(name)
    lo, hi = pc.SETS[name]["band"]
    band = (f >= lo) & (f <= hi)
    H, f = H[:, band], f[band]
    line = [f"{name}:"]
    for tool in TOOLS:
        fr, zr = poles(rr[name][tool], lo, hi)
        line.append(f"{tool} {len(fr)} modes FRAC {lsfd_frac(H, f, fr, zr):.3f}")
    print("  ".join(line))
    fr, zr = poles(rr[name]["modalflow"], lo, hi)
    ref, _ = pc.reference(name, rr[name])
    pairs = pc.match(fr, ref)
    base = lsfd_frac(H, f, fr, zr)
    found_ref = {j for _, j in pairs}
    peers = [
        (a, z, t)
        for t in ("sdypy", "pub5")
        for a, z in zip(*poles(rr[name][t], lo, hi))
    ]
    for j, r in enumerate(ref):
        if j in found_ref or not peers:
            continue
        a, z, t = min(peers, key=lambda p: abs(p[0] - r))
        if abs(a - r) > 0.01 * r:
            print(f"  missed {r:8.1f} Hz: no peer pole within 1 %")
            continue
        g = lsfd_frac(H, f, fr + [a], zr + [z])
        print(f"  missed {r:8.1f} Hz: with {t}'s {a:.1f} Hz (ζ {100 * z:.2f} %) FRAC {g - base:+.4f}")
    found_est = {i for i, _ in pairs}
    for i in range(len(fr)):
        if i in found_est:
            continue
        g = lsfd_frac(H, f, fr[:i] + fr[i + 1 :], zr[:i] + zr[i + 1 :])
        print(f"  extra  {fr[i]:8.1f} Hz (ζ {100 * zr[i]:.2f} %): without it FRAC {g - base:+.4f}")


def main():
    rr = json.load(open(sys.argv[1]))
    names = sys.argv[2:] or [n for n in pc.SETS if n in rr]
    for name in names:
        if not all(os.path.exists(fn) for fn in pc.SETS[name]["files"]):
            print(f"{name}: data not here, skipped")
            continue
        if not all(t in rr[name] for t in TOOLS):
            print(f"{name}: not every tool's result in {sys.argv[1]}, skipped")
            continue
        report(name, rr)


if __name__ == "__main__":
    main()
