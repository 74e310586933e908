#!/usr/bin/env python3
"""How correlated along frequency the residual of AutoEMA's final fit is, per set: the data
less `frf_fit.uff` (the LSFD fit of the identified modes), on up to 8 channels.

    /tmp/aeenv/bin/python benchmarks/real_sets/residual_correlation.py WORKDIR

WORKDIR is a `peer_compare.py --workdir` (one folder per set: `data/` with the set's UFF and
`results/<set>/ema/frf_fit.uff`). Per set: the median over channels of the lag-1
autocorrelation rho(1) = Re sum r(f) r*(f+1) / sum |r|^2, and of the integrated correlation
length L = 1 + 2 sum_{j=1}^{200} (1 - j/201) rho(j) (Bartlett weights), in lines. Independent
lines give rho(1) ~ 0 and L ~ 1; what `ema::serial_correlation` inflates a root's evidence by
is this correlation seen through the root's own width. Needs numpy and pyuff.
"""
import glob
import os
import sys

import numpy as np
import pyuff


def frfs(path):
    """Every FRF (UFF 58, function type 4) of a file by (response, reference) DOF."""
    sets = pyuff.UFF(path).read_sets()
    sets = sets if isinstance(sets, list) else [sets]
    return {(d["rsp_node"], d["rsp_dir"], d["ref_node"], d["ref_dir"]): (np.asarray(d["x"], float), np.asarray(d["data"]))
            for d in sets if d.get("type") == 58 and d.get("func_type") == 4}


def autocorrelation(r, lags):
    power = np.sum(np.abs(r) ** 2)
    return np.array([np.real(np.sum(r[: len(r) - j] * np.conj(r[j:]))) / power for j in range(lags + 1)])


def main(workdir, lags=200):
    for d in sorted(glob.glob(os.path.join(workdir, "*"))):
        name = os.path.basename(d)
        fit_path = os.path.join(d, "results", name, "ema", "frf_fit.uff")
        if not os.path.exists(fit_path):
            continue
        fit, data = frfs(fit_path), {}
        for f in glob.glob(os.path.join(d, "data", "*")):
            if f.endswith((".uff", ".unv")):
                data.update(frfs(f))
        rho1, length = [], []
        for key, (xf, hf) in list(fit.items())[:8]:
            if key not in data:
                continue
            x, h = data[key]
            start = np.searchsorted(x, xf[0] - 1e-9)
            r = h[start:start + len(xf)] - hf
            a = autocorrelation(r, min(lags, len(r) - 1))
            j = np.arange(1, len(a))
            rho1.append(a[1])
            length.append(1 + 2 * np.sum((1 - j / len(a)) * a[1:]))
        if rho1:
            print(f"{name:24s} rho(1) {np.median(rho1):5.2f}   L {np.median(length):6.1f} lines   ({len(rho1)} channels)")


if __name__ == "__main__":
    main(sys.argv[1])
