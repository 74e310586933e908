"""Convert zoom bands of the ModeLAB roving-hammer beam test (Data Physics SignalCalc ASCII
export, one file per hammer point; README.md) into UFF 58 files with pyuff, one file per band
and layout:

- band_X_as_measured.uff: as measured, one reference per hammer point (+X) x 1 response
  (the accelerometer at point 4, z = 0.5 m, -X per the repository's setup.csv);
- band_X_reciprocal.uff: the same numbers transposed by Maxwell-Betti reciprocity (1
  reference at point 4 x one response per hammer point).

Input: N_X.txt (N = 1..9 hammer point; the points present are used, X = A-D band), the complete data lines of
`Example/SignalCalc/ASCII0000N/Hxysv0000N.txt` inside the band, exactly as published
(tab-separated frequency, Re, Im; accelerance (m/s^2)/N; 0.01953125 Hz lines). They were
fetched in parts (the files hold 51,201 lines each) and are not redistributable (no licence):
put them beside this script, then

    /tmp/aeenv/bin/python convert.py
"""
import os
import sys

import numpy as np

here = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(here))
from uff58 import frf_record, write_checked  # noqa: E402

DF = 0.01953125
# The fetched zoom bands, Hz, each around one of the author's modes (setup.csv fLMode/fHMode).
BANDS = {"A": (104.0, 120.0), "B": (296.0, 316.0), "C": (586.0, 604.0), "D": (966.0, 984.0)}
AUTHOR_BANDS = {"A": (108, 116), "B": (300, 312), "C": (590, 600), "D": (970, 980)}
DRIVING = 4  # the accelerometer's point (z = 0.5 m)


def convert(band, lo, hi):
    paths = [os.path.join(here, f"{n}_{band}.txt") for n in range(1, 10)]
    points = [n for n, p in zip(range(1, 10), paths) if os.path.exists(p)]
    if len(points) < 2:
        print("band", band, "has fewer than two hammer points: skipped")
        return
    cols, freq = [], None
    for p in (paths[n - 1] for n in points):
        d = np.loadtxt(p)
        f = d[:, 0]
        assert np.allclose(np.diff(f), DF, rtol=0, atol=1e-6), p
        assert f[0] <= lo + 0.02 and f[-1] >= hi - 0.02, p
        if freq is None:
            freq = f
        assert np.array_equal(f, freq), p
        cols.append(d[:, 1] + 1j * d[:, 2])
    for name, pairs in [(f"band_{band}_as_measured.uff", [((DRIVING, -1), (n, 1)) for n in points]),
                        (f"band_{band}_reciprocal.uff", [((n, 1), (DRIVING, -1)) for n in points])]:
        write_checked(os.path.join(here, name), [frf_record(
            h, freq,
            ids=("ModeLAB roving-hammer beam (alxhslm/ModeLAB, Data Physics SignalCalc)",
                 f"Hxysv0000{n}.txt, accelerance (m/s^2)/N, band {lo}-{hi} Hz",
                 f"response node {rsp[0]} dir {rsp[1]}, reference node {ref[0]} dir {ref[1]}"),
            rsp=("BEAM", rsp[0], rsp[1]), ref=("BEAM", ref[0], ref[1]),
            ordinate=(12, 1, 0, "m/s^2"), denominator=(13, 0, 1, "N"), ord_data_type=5)
            for n, h, (rsp, ref) in zip(points, cols, pairs)])


if __name__ == "__main__":
    for band, (lo, hi) in BANDS.items():
        convert(band, lo, hi)
