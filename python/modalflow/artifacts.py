"""Readers of modalflow's artifacts (docs/artifacts.md), one per kind, each
returning pandas or numpy objects with the documented dtypes."""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Optional

import pandas as pd

from .uff import read_frf  # noqa: F401  (re-exported: the `frf` reader)

#: The newest `schema_version` of each JSON artifact this package reads.
SCHEMA_VERSIONS = {"metrics.json": 2, "cost.json": 4, "identifiability.json": 3, "model.json": 3}

#: Columns renamed in schema version 2 (old → new), read under both names.
RENAMED = {
    "std_error": "std_error_rel",
    "std_error_with_fixed": "std_error_with_fixed_rel",
    "suggested_change": "suggested_change_rel",
    "frequency_spread": "frequency_std_rel",
    "damping_spread": "damping_std_rel",
}

#: Columns that hold booleans (empty cells: not applicable → <NA>).
BOOLEAN = {
    "identified", "identifiable", "implicated", "used", "ambiguous", "undecided", "significant",
    "physical", "stable_frequency", "stable_damping", "stable_vector", "selected",
}
#: Columns that are text even when every cell looks like a number.
TEXT = {"parameter", "position_label", "label", "direction", "reason", "nominal_mode", "kind",
        "scale", "response", "reference", "class", "stage"}
#: Whole-number columns (nullable where a cell may be empty).
INTEGER = {"position", "mode", "node", "reference_mode", "candidate_mode", "model_mode",
           "evaluation", "order", "samples_needed", "cluster", "root"}


def _boolean(s: pd.Series) -> pd.Series:
    text = s.astype("string").str.strip().str.lower()
    mapped = text.map({"true": True, "false": False, "1": True, "0": False})
    return mapped.astype("boolean")


def read_table(path) -> pd.DataFrame:
    """A CSV artifact with typed columns: booleans as pandas `boolean`,
    whole numbers as `Int64`, text as `string`, everything else float64;
    renamed columns of schema version 1 under their current names."""
    df = pd.read_csv(path, dtype=str, keep_default_na=False)
    df = df.rename(columns={k: v for k, v in RENAMED.items() if k in df.columns})
    for c in df.columns:
        col = df[c]
        if c in BOOLEAN:
            df[c] = _boolean(col)
        elif c in TEXT:
            df[c] = col.astype("string")
        elif c in INTEGER:
            df[c] = pd.to_numeric(col.replace("", None), errors="coerce").astype("Int64")
        else:
            num = pd.to_numeric(col.replace("", None), errors="coerce")
            # A column with text that is not a number stays text.
            if num.isna().sum() > (col == "").sum():
                df[c] = col.astype("string")
            else:
                df[c] = num.astype("float64")
    return df


def read_json(path) -> dict:
    """A JSON artifact as a dict; a `schema_version` newer than this package
    reads is refused with the fix."""
    path = Path(path)
    with open(path, encoding="utf-8") as f:
        value = json.load(f)
    newest = SCHEMA_VERSIONS.get(path.name)
    got = value.get("schema_version", 1) if isinstance(value, dict) else 1
    if newest is not None and got > newest:
        raise ValueError(
            f"{path}: schema_version {got} is newer than this modalflow package reads "
            f"({newest}); pip install the package of the same modalflow version"
        )
    return value


@dataclass
class Modes:
    """A `modes` artifact: `modes` (position, position_label, mode,
    frequency_hz, damping_ratio), `shapes` (position, mode, node, direction
    and the complex coefficient `shape`), the stated relative uncertainty
    per mode when the estimate gives it, and whether the shapes are
    mass-normalized (computed modes) or of arbitrary scale."""

    modes: pd.DataFrame
    shapes: pd.DataFrame
    uncertainty: Optional[pd.DataFrame]
    mass_normalized: bool

    def shape_matrix(self, position: int = 0) -> pd.DataFrame:
        """Complex mode shapes of one position: DOFs (`1+X`) × modes."""
        s = self.shapes[self.shapes["position"] == position]
        dof = s["node"].astype(str) + s["direction"].astype(str)
        return (
            s.assign(dof=dof.values)
            .pivot(index="dof", columns="mode", values="shape")
            .reindex(pd.unique(dof))
        )


def read_modes(path) -> Modes:
    path = Path(path)
    shapes = read_table(path / "mode_shapes.csv")
    shapes["shape"] = shapes["real"].to_numpy() + 1j * shapes["imag"].to_numpy()
    unc = path / "uncertainty.csv"
    scaling = path / "scaling.json"
    mass = scaling.exists() and read_json(scaling).get("scaling") == "mass_normalized"
    return Modes(
        modes=read_table(path / "modes.csv"),
        shapes=shapes,
        uncertainty=read_table(unc) if unc.exists() else None,
        mass_normalized=bool(mass),
    )


@dataclass
class AutoemaAccount:
    """Why an autoema stage kept or dropped each root, from its metrics.json,
    as tables: `modes`, one row per identified mode (position, frequency_hz,
    damping_ratio, multiplicity, stable_orders, bandwidth_lines, support,
    serial_inflation, accepted_by and what it was accepted by: score,
    peak_hz, ratio); `rejected`, one row per root validation removed
    (position, frequency_hz, damping_ratio, n_orders, reason and the
    reason's own figures; a figure another reason lacks is NaN); and
    `positions`, one row per position (goal_reached, mean_frac, n_modes,
    consensus_of, the number of warnings). The fields are those of
    docs/stage-kinds.md (autoema)."""

    modes: pd.DataFrame
    rejected: pd.DataFrame
    positions: pd.DataFrame


def autoema_account(metrics) -> AutoemaAccount:
    """An `AutoemaAccount` of an autoema stage's metrics (the dict a `Stage`
    holds as `metrics`, or the path of its metrics.json)."""
    if not isinstance(metrics, dict):
        metrics = read_json(metrics)
    positions = metrics.get("positions")
    if positions is None:
        raise ValueError("not an autoema metrics.json: it has no `positions` (other kinds' metrics differ)")

    def rows(key):
        return [{"position": p["index"], **r} for p in positions for r in p.get(key, [])]

    def frame(records, first):
        df = pd.DataFrame.from_records(records)
        if df.empty:
            return pd.DataFrame(columns=first)
        df["position"] = df["position"].astype("Int64")
        for c in ("accepted_by", "reason"):
            if c in df.columns:
                df[c] = df[c].astype("string")
        return df[first + [c for c in df.columns if c not in first]]

    summary = [{"position": p["index"], "goal_reached": p["goal_reached"], "mean_frac": p["mean_frac"],
                "n_modes": p["n_modes"], "consensus_of": p.get("consensus_of"),
                "warnings": len(p.get("warnings", []))} for p in positions]
    return AutoemaAccount(
        modes=frame(rows("modes"), ["position", "frequency_hz", "damping_ratio"]),
        rejected=frame(rows("rejected"), ["position", "frequency_hz", "damping_ratio", "reason"]),
        positions=pd.DataFrame.from_records(summary),
    )


def read_parameters(path) -> pd.DataFrame:
    """A parameters.csv indexed by parameter name: value, bounds and (from an
    identification) the relative standard errors and the absolute 95 %
    interval `ci_low`, `ci_high`."""
    return read_table(path).set_index("parameter")


def read_path(path):
    """Any artifact by its file name (docs/artifacts.md): `frf.uff` and other
    `.uff` → list of `FrfSet`; a folder with `modes.csv` → `Modes`;
    `parameters.csv` → DataFrame indexed by parameter; other `.csv` →
    DataFrame; `.json` → dict; a folder → dict of its entries read the same
    way; anything else (SVG, HTML) → its `Path`."""
    path = Path(path)
    if path.is_dir():
        if (path / "modes.csv").exists():
            return read_modes(path)
        return {p.name: read_path(p) for p in sorted(path.iterdir()) if p.name != "manifest.json"}
    suffix = path.suffix.lower()
    if suffix == ".uff":
        return read_frf(path)
    if path.name == "parameters.csv":
        return read_parameters(path)
    if suffix == ".csv":
        return read_table(path)
    if suffix == ".json":
        return read_json(path)
    return path


