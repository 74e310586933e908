"""UFF dataset 58 / 58b reader for modalflow's `frf` artifact (`frf.uff`).

A data set is a dataset-number line (`    58` ASCII, `    58b ...` binary),
records 1–11 as text (80 columns) and record 12, the data: ASCII numbers or
a binary block right after record 11, ending with `    -1`. modalflow
writes one FRF per (position, response, reference): record 6's load case is
the position index and ID line 4 `position=<label>` its label (`%XX`
escapes); an uncalibrated FRF says `uncalibrated` as its ordinate unit.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from typing import List, Optional

import numpy as np
import pandas as pd

#: Record 8 "specific data type" of the ordinate → FRF quantity.
QUANTITY = {8: "receptance", 11: "mobility", 12: "accelerance"}
_DIRECTIONS = {1: "X", 2: "Y", 3: "Z", 4: "RX", 5: "RY", 6: "RZ"}
FRF, COHERENCE = 4, 6


def dof_text(node: int, direction: int) -> str:
    """`1+X`, `3-RZ`: a node and signed direction as modalflow writes them."""
    sign = "+" if direction >= 0 else "-"
    return f"{node}{sign}{_DIRECTIONS.get(abs(direction), str(abs(direction)))}"


@dataclass
class Dataset58:
    function: int
    load_case: int
    label: str
    response: str
    reference: str
    ordinate_type: int
    ordinate_unit: str
    x: np.ndarray
    y: np.ndarray


def _unescape(label: str) -> str:
    return re.sub(
        r"(%[0-9A-F]{2})+",
        lambda m: bytes.fromhex(m.group(0).replace("%", "")).decode("utf-8", "replace"),
        label,
    )


def _records(lines: List[bytes]):
    ids = [l.decode("latin-1").rstrip() for l in lines[0:5]]
    r6 = lines[5].decode("latin-1")
    function, _fid, _ver, load_case = (int(r6[0:5]), int(r6[5:15]), int(r6[15:20]), int(r6[20:30]))
    resp_node, resp_dir = int(r6[41:51]), int(r6[51:55])
    ref_node, ref_dir = int(r6[66:76]), int(r6[76:80])
    r7 = lines[6].decode("latin-1").split()
    otype, npts, even = int(r7[0]), int(r7[1]), int(r7[2])
    xmin, dx = float(r7[3]), float(r7[4])
    r9 = lines[8].decode("latin-1")
    spec = int(r9[0:10])
    unit = r9[47:67].strip() if len(r9) > 47 else ""
    label = ids[3][len("position="):] if ids[3].startswith("position=") else ""
    return dict(
        function=function,
        load_case=load_case,
        label=_unescape(label),
        response=dof_text(resp_node, resp_dir),
        reference=dof_text(ref_node, ref_dir),
        ordinate_type=spec,
        ordinate_unit=unit,
    ), (otype, npts, even, xmin, dx)


def _values(raw: np.ndarray, layout) -> tuple:
    otype, npts, even, xmin, dx = layout
    complex_ = otype in (5, 6)
    per = (2 if complex_ else 1) + (0 if even else 1)
    raw = raw[: npts * per].reshape(npts, per)
    x = xmin + dx * np.arange(npts) if even else raw[:, 0].astype(float)
    first = 0 if even else 1
    y = raw[:, first] + 1j * raw[:, first + 1] if complex_ else raw[:, first]
    return x, y


_DELIMITER = re.compile(rb"^ {4}-1[ \t\r]*$", re.M)


def read_uff58(path) -> List[Dataset58]:
    """Every dataset 58 / 58b of a UFF file, in file order (other datasets
    are skipped)."""
    data = open(path, "rb").read()
    out, pos = [], 0
    while True:
        m = _DELIMITER.search(data, pos)
        if m is None:
            break
        line_end = data.find(b"\n", m.end() + 1)
        if line_end < 0:
            break
        head = data[m.end() + 1 : line_end].decode("latin-1")
        number = head.split()[0] if head.split() else ""
        if number not in ("58", "58b"):
            end = _DELIMITER.search(data, line_end)
            pos = end.end() if end else len(data)
            continue
        lines, cursor = [], line_end + 1
        for _ in range(11):
            nl = data.index(b"\n", cursor)
            lines.append(data[cursor:nl].rstrip(b"\r"))
            cursor = nl + 1
        meta, layout = _records(lines)
        otype, npts, even = layout[0], layout[1], layout[2]
        per = (2 if otype in (5, 6) else 1) + (0 if even else 1)
        if number == "58b":
            order = "<" if head.split()[1] == "1" else ">"
            dtype = np.dtype(order + ("f4" if otype in (2, 5) else "f8"))
            nbytes = npts * per * dtype.itemsize
            raw = np.frombuffer(data[cursor : cursor + nbytes], dtype=dtype).astype(float)
            # The block ends with `    -1`, directly or after a line feed.
            close = data.find(b"    -1", cursor + nbytes)
            pos = len(data) if close < 0 else close + 6
        else:
            end = _DELIMITER.search(data, cursor)
            text = data[cursor : end.start() if end else len(data)].decode("latin-1")
            raw = np.array(text.replace("D", "E").split(), dtype=float)
            pos = end.end() if end else len(data)
        x, y = _values(raw, layout)
        out.append(Dataset58(x=x, y=y, **meta))
    return out


@dataclass
class FrfSet:
    """The FRFs of one position: `values[k]` is channel `k`'s complex FRF
    over `frequency_hz`, in SI units of `quantity` (m/N, m/s/N, m/s²/N)
    unless `calibrated` is false; `channels` names each channel's response
    and reference DOF (`1+X`)."""

    position: int
    label: str
    quantity: str
    calibrated: bool
    frequency_hz: np.ndarray
    channels: pd.DataFrame
    values: np.ndarray
    coherence: Optional[np.ndarray] = field(default=None, repr=False)

    def channel(self, response: str, reference: str) -> np.ndarray:
        """The FRF of one response/reference pair (`"2+X"`, `"1+X"`)."""
        hit = self.channels.index[
            (self.channels["response"] == response) & (self.channels["reference"] == reference)
        ]
        if len(hit) == 0:
            raise KeyError(f"no channel {response}/{reference} at position {self.position}")
        return self.values[hit[0]]


def read_frf(path) -> List[FrfSet]:
    """An `frf` artifact: one `FrfSet` per position, in position order."""
    sets: dict = {}
    coherence: dict = {}
    for d in read_uff58(path):
        key = (d.load_case, d.label)
        if d.function == COHERENCE:
            coherence[(key, d.response, d.reference)] = d.y.real
            continue
        if d.function != FRF:
            continue
        s = sets.setdefault(key, dict(x=d.x, rows=[], values=[], quantity=None, calibrated=True))
        s["rows"].append((d.response, d.reference))
        s["values"].append(np.asarray(d.y, dtype=complex))
        s["quantity"] = QUANTITY.get(d.ordinate_type, str(d.ordinate_type))
        if d.ordinate_unit.lower() == "uncalibrated":
            s["calibrated"] = False
    out = []
    for key in sorted(sets):
        s = sets[key]
        coh = [coherence.get((key, r, q)) for r, q in s["rows"]]
        out.append(
            FrfSet(
                position=key[0],
                label=key[1],
                quantity=s["quantity"],
                calibrated=s["calibrated"],
                frequency_hz=np.asarray(s["x"], dtype=float),
                channels=pd.DataFrame(s["rows"], columns=["response", "reference"]),
                values=np.vstack(s["values"]),
                coherence=np.vstack(coh) if all(c is not None for c in coh) else None,
            )
        )
    return out
