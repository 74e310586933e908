"""Convert the two measured FRFs shipped in the PyPI package `vibration-toolbox` 0.6.10
(`vibration_toolbox/data/case1.mat`, `case2.mat`, MIT) into UFF 58 ASCII files with pyuff:
- `caseN.uff`: the FRF record alone (function type 4, complex double), as stored;
- `caseN_with_coherence.uff`: the same FRF record followed by its coherence (function type 6,
  real double), as stored. case 1's stored coherence exceeds 1 on 5 lines below 18 Hz (1.246 at
  0 Hz), which modalflow's import refuses, hence the FRF-only files for the benchmarks.

What the .mat files hold (a signal analyser's export, 1280 samples/s, 4096 samples, 1601
lines 0-500 Hz, 0.3125 Hz):
- `Hf_chan_2`  : H1 of channel 2 over channel 1 (= 3.2 * Hf_Cross_Spec_chan_2 / PSD_chan_1, i.e. the
                 cross spectrum over the input auto spectrum; 3.2 = 1/df, PSD per Hz);
- `Hf_coh_chan_2`: the coherence of that pair;
- `Time_chan_1/2`: the last time record (channel 1 an impulse at the start of case 1's record:
                 an impact hammer; channel 2 the response).
The units are not stored (no calibration in the file): the FRF is written with NONE unit labels
and is imported uncalibrated (`calibrated: false`). The two channels are written as node 1
(reference, hammer) and node 2 (response), direction +Z; the test layout is not documented.

Run:  /tmp/aeenv/bin/python convert.py      (numpy, scipy, pyuff)
"""
import os
import sys

import numpy as np
import pyuff
import scipy.io as sio

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))
from uff58 import frf_record  # noqa: E402


def record(func_type, data, freq, name, ord_type, label):
    return frf_record(
        data, freq,
        ids=(f"vibration_toolbox {name}: {label}",
             f"vibration-toolbox 0.6.10 data/{name}.mat ({'Hf_chan_2' if func_type == 4 else 'Hf_coh_chan_2'})",
             "channel 1 (hammer) -> channel 2 (response); units not stored"),
        rsp=("VTB", 2, 3), ref=("VTB", 1, 3),
        func_type=func_type, ord_data_type=ord_type)


def main():
    for name in ("case1", "case2"):
        d = sio.loadmat(os.path.join(HERE, f"{name}.mat"))
        f = d["Freq_domain"].ravel().astype(float)
        h = d["Hf_chan_2"].ravel().astype(complex)
        coh = d["Hf_coh_chan_2"].ravel().astype(float)
        df = float(d["PSD_DeltaF"].item())
        assert len(f) == 1601 and f[0] == 0.0 and np.allclose(np.diff(f), df, rtol=1e-6)
        for suffix, sets in (("", [record(4, h, f, name, 6, "FRF H1")]),
                             ("_with_coherence", [record(4, h, f, name, 6, "FRF H1"),
                                                  record(6, coh, f, name, 4, "coherence")])):
            out = os.path.join(HERE, f"{name}{suffix}.uff")
            if os.path.exists(out):
                os.remove(out)
            pyuff.UFF(out).write_sets(sets, mode="add")
            back = pyuff.UFF(out).read_sets()
            back = [back] if isinstance(back, dict) else back
            assert np.max(np.abs(back[0]["data"] - h)) <= 1e-10 * np.max(np.abs(h))  # 12 significant digits
            if suffix:
                assert np.max(np.abs(back[1]["data"] - coh)) <= 1e-10
            print(f"{out}: {len(back)} record(s), {len(f)} lines, df {df} Hz")


if __name__ == "__main__":
    main()
