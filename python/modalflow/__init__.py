"""modalflow's results in pandas and numpy.

    import modalflow
    results = modalflow.load("results/quickstart")      # every stage
    results["truth"]["modes"].modes                       # a DataFrame
    results["score[measurement=noisy]"]["metrics"]        # a dict

`load` reads a pipeline's results folder (a dict of `Stage`s by stage name),
one stage's folder (a `Stage`) or one artifact (by its file name, see
`read_path`). `run` runs a pipeline through the `modalflow` command line and
returns its stages. The files are documented in docs/artifacts.md.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
from pathlib import Path
from typing import Dict, Optional

from .artifacts import (
    AutoemaAccount,
    Modes,
    autoema_account,
    read_frf,
    read_json,
    read_modes,
    read_parameters,
    read_path,
    read_table,
)
from .uff import FrfSet

__all__ = [
    "AutoemaAccount", "FrfSet", "Modes", "Stage", "autoema_account", "load", "run", "read_frf", "read_json", "read_modes",
    "read_parameters", "read_path", "read_table",
]
__version__ = "0.1.0"


class Stage(dict):
    """One stage's outputs by output name (`modes`, `frf`, `metrics`, ...),
    each read by `read_path`; `kind`, `manifest` (its manifest.json) and
    `path` say where they came from, `warnings` what the run warned about."""

    def __init__(self, path):
        self.path = Path(path)
        self.manifest = read_json(self.path / "manifest.json")
        self.kind = self.manifest.get("kind", "")
        self.name = self.manifest.get("stage", self.path.name)
        self.warnings = list(self.manifest.get("warnings", []))
        super().__init__()
        for output, record in self.manifest.get("outputs", {}).items():
            self[output] = read_path(self.path / record["file"])

    def __repr__(self):
        return f"Stage({self.name!r}, kind={self.kind!r}, outputs={list(self)})"


def load(path):
    """Read results: a pipeline's results folder (`results/<pipeline>`) → dict
    of `Stage` by stage name; a stage folder (with manifest.json) → `Stage`;
    an artifact (file or folder) → its object (`read_path`)."""
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"{path}: no such results folder or artifact; run the pipeline first")
    if (path / "manifest.json").exists():
        return Stage(path)
    if path.is_dir() and any((p / "manifest.json").exists() for p in path.iterdir() if p.is_dir()):
        # `os.listdir`, not glob: matrix stages are named `score[a=b]`.
        return {
            s.name: s
            for s in (Stage(p) for p in sorted(path.iterdir()) if (p / "manifest.json").exists())
        }
    return read_path(path)


def _binary(binary: Optional[str]) -> str:
    found = binary or os.environ.get("MODALFLOW") or shutil.which("modalflow")
    if not found:
        raise FileNotFoundError(
            "no `modalflow` command: put it on PATH (cargo install --path .), or pass "
            "binary=... or set MODALFLOW to its path"
        )
    return found


def run(pipeline, binary: Optional[str] = None, cwd=None, **set) -> Dict[str, Stage]:
    """Run `pipeline` (the path to its YAML file) with `modalflow run` and load
    its stages (a dict of `Stage` by name). Each keyword is one `--set`
    override, `stage__param` for `stage.param` (`run("p.yaml",
    truth__noise={"relative": 0.02})`); values that are not text are passed
    as JSON. A failed run raises `RuntimeError` with modalflow's message.
    `binary`: the modalflow command (default: `$MODALFLOW`, else on PATH)."""
    args = [_binary(binary), "run", str(pipeline), "--json", "--progress", "none"]
    for key, value in set.items():
        text = value if isinstance(value, str) else json.dumps(value)
        args += ["--set", f"{key.replace('__', '.')}={text}"]
    done = subprocess.run(args, capture_output=True, text=True, cwd=cwd)
    if done.returncode != 0:
        raise RuntimeError(
            f"modalflow run failed (exit {done.returncode}):\n{done.stderr}{done.stdout}"
        )
    report = json.loads(done.stdout)
    base = Path(cwd) if cwd is not None else Path.cwd()
    if "trace" in report:
        # The trace sits in the results folder (`results/<name>/trace.csv`).
        results = base / Path(report["trace"]).parent
    else:
        results = base / "results" / report.get("results_name", report["pipeline"])
    return load(results)
