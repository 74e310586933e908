"""Execute a notebook headless (as CI does) and fail on the first error:
`python examples/run_notebook.py examples/quickstart.ipynb` from the
repository's top, after the quickstart has run."""

import sys
from pathlib import Path

import nbformat
from nbclient import NotebookClient

for name in sys.argv[1:] or ["examples/quickstart.ipynb"]:
    path = Path(name)
    nb = nbformat.read(path, as_version=4)
    NotebookClient(nb, timeout=300, kernel_name="python3",
                   resources={"metadata": {"path": str(Path.cwd())}}).execute()
    figures = sum(
        1 for cell in nb.cells if cell.cell_type == "code"
        for out in cell.get("outputs", []) if "image/png" in out.get("data", {})
    )
    print(f"{path}: {len(nb.cells)} cells executed, {figures} figures")
    if figures == 0:
        sys.exit(f"{path}: no figure was drawn")
