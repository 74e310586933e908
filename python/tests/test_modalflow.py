"""Tests of the modalflow package: the readers on files written here by
hand (known values), and `run`/`load` on the quickstart when the
`modalflow` command is at hand (`$MODALFLOW`, PATH, or the repository's
target/release)."""

import json
import os
import shutil
import struct
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import modalflow
from modalflow.uff import read_frf

REPO = Path(__file__).resolve().parents[2]


def _rec6(load_case, resp, ref):
    (rn, rd), (qn, qd) = resp, ref
    return (f"{4:5d}{0:10d}{0:5d}{load_case:10d} {'NONE':<10}{rn:10d}{rd:4d}"
            f" {'NONE':<10}{qn:10d}{qd:4d}")


def _dataset(values, start, step, load_case=0, label="", resp=(2, 1), ref=(1, 1),
             unit="m", binary=True):
    """A dataset 58 of a complex FRF written as modalflow writes one."""
    n = len(values)
    rows = [
        "FRF 2+X/1+X", "modalflow", "NONE", f"position={label}", "NONE",
        _rec6(load_case, resp, ref),
        f"{6:10d}{n:10d}{1:10d} {start:12.5E} {step:12.5E} {0.0:12.5E}",
        f"{18:10d}{0:5d}{0:5d}{0:5d} {'Frequency':<20} {'Hz':<20}",
        f"{8:10d}{1:5d}{0:5d}{0:5d} {'Displacement':<20} {unit:<20}",
        f"{13:10d}{0:5d}{1:5d}{0:5d} {'Force':<20} {'N':<20}",
        f"{0:10d}{0:5d}{0:5d}{0:5d} {'NONE':<20} {'NONE':<20}",
    ]
    text = "".join(r.ljust(80) + "\n" for r in rows)
    flat = [x for v in values for x in (v.real, v.imag)]
    if binary:
        head = f"{58:6d}b{1:6d}{2:6d}{11:12d}{16 * n:12d}{0:6d}{0:6d}{0:12d}{0:12d}\n"
        return (b"    -1\n" + head.encode() + text.encode()
                + struct.pack(f"<{2 * n}d", *flat) + b"    -1\n")
    body = "".join(f"{x:25.17E}" + ("\n" if k % 2 else "") for k, x in enumerate(flat))
    return b"    -1\n" + f"{58:6d}\n".encode() + text.encode() + body.encode() + b"    -1\n"


@pytest.mark.parametrize("binary", [True, False])
def test_frf_reads_values_channels_positions_and_scale(tmp_path, binary):
    a = np.array([1e-6 - 2e-7j, -3.25e-5 + 0j, 7e-9j])
    b = np.array([2.0 + 1j, 0.5 - 0.5j, -1.0 + 0j])
    path = tmp_path / "frf.uff"
    path.write_bytes(
        _dataset(a, 10.0, 0.5, binary=binary)
        + _dataset(b, 10.0, 0.5, load_case=3, label="x%3D1", resp=(3, -6), binary=binary)
    )
    sets = read_frf(path)
    assert [s.position for s in sets] == [0, 3]
    assert sets[1].label == "x=1"
    assert sets[0].quantity == "receptance" and sets[0].calibrated
    np.testing.assert_array_equal(sets[0].frequency_hz, [10.0, 10.5, 11.0])
    np.testing.assert_allclose(sets[0].values[0], a, rtol=1e-15)
    assert sets[1].channels.iloc[0].tolist() == ["3-RZ", "1+X"]
    np.testing.assert_allclose(sets[1].channel("3-RZ", "1+X"), b)
    path.write_bytes(_dataset(a, 0.0, 1.0, unit="uncalibrated", binary=binary))
    assert not read_frf(path)[0].calibrated


def test_tables_are_typed_and_version_1_columns_renamed(tmp_path):
    p = tmp_path / "parameters.csv"
    p.write_text(
        "parameter,value,lower,upper,initial,identified,identifiable,std_error,ci_low,ci_high\n"
        "k1,2e6,1e6,4e6,1.5e6,true,true,0.01,1.9e6,2.1e6\n"
        "c1,40,10,160,40,false,,,,\n"
    )
    df = modalflow.load(p)
    assert list(df.index) == ["k1", "c1"]
    assert df["std_error_rel"]["k1"] == 0.01
    assert str(df["identified"].dtype) == "boolean"
    assert df["identifiable"]["k1"] == True  # noqa: E712 (a pandas boolean)
    assert pd.isna(df["identifiable"]["c1"])
    assert df["value"].dtype == np.float64


def test_newer_schema_versions_are_refused(tmp_path):
    p = tmp_path / "metrics.json"
    p.write_text(json.dumps({"schema_version": 99}))
    with pytest.raises(ValueError, match="schema_version 99"):
        modalflow.load(p)
    p.write_text(json.dumps({"modes": {"paired": 3}}))
    assert modalflow.load(p)["modes"]["paired"] == 3


def _binary():
    for c in (os.environ.get("MODALFLOW"), shutil.which("modalflow"),
              REPO / "target" / "release" / "modalflow"):
        if c and Path(c).is_file():
            return str(c)
    return None


@pytest.fixture(scope="module")
def quickstart(tmp_path_factory):
    binary = _binary()
    if binary is None:
        pytest.skip("no modalflow command (build it: cargo build --release)")
    root = tmp_path_factory.mktemp("quickstart")
    shutil.copytree(REPO / "pipelines", root / "pipelines")
    return modalflow.run(root / "pipelines" / "quickstart.yaml", binary=binary, cwd=root)


def test_quickstart_loads_every_artifact(quickstart):
    assert set(quickstart) >= {"truth", "noisy", "hammer", "ema[measurement=noisy]",
                               "score[measurement=hammer]", "report", "export"}
    truth = quickstart["truth"]
    assert truth.kind == "synthesize"
    assert truth.warnings == []  # the manifest's warnings: the quickstart has none
    modes = truth["modes"]
    assert modes.mass_normalized and len(modes.modes) == 3
    assert modes.modes["frequency_hz"].dtype == np.float64
    assert modes.shapes["shape"].dtype == np.complex128
    (frf,) = truth["frf"]
    assert frf.values.dtype == np.complex128 and frf.values.shape == (3, 1601)
    assert frf.quantity == "receptance"
    # The receptance peaks near the modes' frequencies (damping and the
    # neighbouring modes shift a peak by a few tenths of a percent).
    peaks = frf.frequency_hz[
        [k for k in range(1, 1600)
         if abs(frf.values[0, k]) > abs(frf.values[0, k - 1])
         and abs(frf.values[0, k]) > abs(frf.values[0, k + 1])]
    ]
    np.testing.assert_allclose(peaks, modes.modes["frequency_hz"], rtol=0.005)
    # model.json names referenced files by path, size and hash, never their text
    assert truth["model"]["schema_version"] == 3
    assert "external" not in truth["model"]
    assert quickstart["hammer"]["frf"][0].coherence is not None
    ema = quickstart["ema[measurement=noisy]"]
    assert ema["modes"].uncertainty is not None
    assert str(ema["poles"]["selected"].dtype) == "boolean"


def test_quickstart_mac_matches_an_independent_computation(quickstart):
    """metrics.json's mean MAC, recomputed here from the two modes artifacts
    and evaluate's pairs (MAC = |φᵣᴴφ꜀|² / (φᵣᴴφᵣ · φ꜀ᴴφ꜀), eq. 2.63)."""
    score = quickstart["score[measurement=noisy]"]
    ref = quickstart["truth"]["modes"].shape_matrix(0)
    cand = quickstart["ema[measurement=noisy]"]["modes"].shape_matrix(0).reindex(ref.index)
    pairs = score["tables"]["pairs.csv"]
    macs = []
    for r, c in zip(pairs["reference_mode"], pairs["candidate_mode"]):
        a, b = ref[r].to_numpy(), cand[c].to_numpy()
        macs.append(abs(np.vdot(a, b)) ** 2 / (np.vdot(a, a).real * np.vdot(b, b).real))
    assert len(macs) == 3
    assert np.mean(macs) == pytest.approx(score["metrics"]["modes"]["mean_mac"], abs=1e-12)


def test_autoema_account_tables_why_each_root_was_kept_or_dropped(quickstart):
    """The account's modes are the stage's modes (same frequencies, per
    position), each with why it was kept; its rejections carry a reason."""
    ema = quickstart["ema[measurement=noisy]"]
    account = modalflow.autoema_account(ema["metrics"])
    modes = ema["modes"].modes
    assert len(account.modes) == len(modes)
    for pos, group in modes.groupby("position"):
        mine = account.modes[account.modes["position"] == pos]
        np.testing.assert_allclose(sorted(mine["frequency_hz"]), sorted(group["frequency_hz"]), rtol=1e-12)
    assert account.modes["accepted_by"].notna().all()
    assert set(account.modes["accepted_by"]) <= {"cmif_peak", "significance", "data_peak"}
    assert (account.modes["serial_inflation"] >= 1.0).all()
    assert (account.modes["support"] <= account.positions["consensus_of"].max()).all()
    if len(account.rejected):
        assert account.rejected["reason"].notna().all()
    assert list(account.positions["n_modes"]) == [
        int((account.modes["position"] == p).sum()) for p in account.positions["position"]]
    # The same from the file, and a clear refusal of another kind's metrics.
    same = modalflow.autoema_account(ema.path / "metrics.json")
    pd.testing.assert_frame_equal(same.modes, account.modes)
    with pytest.raises(ValueError, match="not an autoema metrics.json"):
        modalflow.autoema_account(quickstart["score[measurement=noisy]"]["metrics"])
