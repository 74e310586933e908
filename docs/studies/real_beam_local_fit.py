"""An independent check of the hammer test's bending frequencies
(docs/studies/real_beam.md): per bending mode, one complex pole shared by
all 30 FRFs of `frf_hammer_as_measured.uff`, fitted by nonlinear least
squares to the measured accelerance in a band around the peak, with each
FRF's residues and two residual terms (constant and 1/ω²) solved linearly
at every trial pole (variable projection). No stabilization, no model
order: a different estimator from modalflow's PolyMAX + LSFD and from the
author's stabilization diagram.

    python3 docs/studies/real_beam_local_fit.py   # numpy, scipy, pyuff; ~2 s
"""
import os

import numpy as np
import pyuff
from scipy.optimize import least_squares

HERE = os.path.dirname(os.path.abspath(__file__))
DATA = os.path.join(HERE, "..", "..", "..", "shared", "data", "real", "beam_ufsc_ss")
# Band and start frequency per bending mode, Hz (bands hold one peak each).
BANDS = {"B1": (10, 30, 17.2), "B2": (55, 85, 69.0), "B3": (140, 170, 155.5),
         "B4": (250, 272, 265.5), "B5": (395, 435, 414.3), "B6": (550, 585, 567.6)}
# AutoEMA of the same file (docs/studies/real_beam.md) and the author's list.
AUTOEMA = {"B1": 17.13, "B2": 69.19, "B3": 155.64, "B4": 265.55, "B5": 414.50, "B6": 567.61}
AUTHOR = {"B1": 17.212, "B2": 68.840, "B3": 155.391, "B4": 265.219, "B5": 414.118, "B6": 567.539}


def fit(f, H, lo, hi, f0):
    m = (f >= lo) & (f <= hi)
    s, Y = 2j * np.pi * f[m], H[:, m]

    def residual(p):
        wn, z = 2 * np.pi * p[0], p[1]
        lam = -z * wn + 1j * wn * np.sqrt(1 - z * z)
        B = np.array([1 / (s - lam), 1 / (s - np.conj(lam)), np.ones_like(s), 1 / s**2]).T
        R = np.linalg.lstsq(B, Y.T, rcond=None)[0]
        d = (B @ R - Y.T).ravel()
        return np.concatenate([d.real, d.imag])

    return least_squares(residual, [f0, 0.005], x_scale=[1, 1e-3]).x


def main():
    sets = [s for s in pyuff.UFF(os.path.join(DATA, "frf_hammer_as_measured.uff")).read_sets()
            if s["type"] == 58]
    f = np.real(sets[0]["x"])
    H = np.array([s["data"] for s in sets])
    print("| mode | local fit Hz (ζ %) | AutoEMA Hz | author Hz |")
    print("|---|---|---|---|")
    got = {}
    for name, (lo, hi, f0) in BANDS.items():
        fn, z = fit(f, H, lo, hi, f0)
        got[name] = fn
        print(f"| {name} | {fn:.2f} ({100 * z:.2f}) | {AUTOEMA[name]:.2f} | {AUTHOR[name]:.2f} |")
    print(f"B2/B1: local fit {got['B2'] / got['B1']:.3f}, AutoEMA "
          f"{AUTOEMA['B2'] / AUTOEMA['B1']:.3f}, author {AUTHOR['B2'] / AUTHOR['B1']:.3f}")


main()
