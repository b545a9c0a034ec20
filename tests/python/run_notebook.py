"""Executes a notebook top to bottom with nbclient (Debian python3-nbclient) and writes the
executed copy (outputs, figures) to the given path in the build tree. Exit 1, with the failing
cell's error, when any cell raises; exit 1 too when the notebook has no code cell.

usage: run_notebook.py NOTEBOOK OUTPUT
"""

import os
import sys
import time

import nbclient
import nbformat


def main(notebook, output):
    nb = nbformat.read(notebook, as_version=4)
    cells = [c for c in nb.cells if c.cell_type == "code"]
    if not cells:
        print(f"{notebook}: no code cell: nothing was tested", file=sys.stderr)
        return 1
    os.makedirs(os.path.dirname(os.path.abspath(output)), exist_ok=True)
    start = time.monotonic()
    client = nbclient.NotebookClient(nb, timeout=300, kernel_name="python3",
                                     resources={"metadata": {"path": os.getcwd()}})
    try:
        client.execute()
    except nbclient.exceptions.CellExecutionError as e:
        nbformat.write(nb, output)
        print(f"{notebook}: a cell failed (executed copy: {output})\n{e}", file=sys.stderr)
        return 1
    nbformat.write(nb, output)
    print(f"{notebook}: {len(cells)} code cells ran in {time.monotonic() - start:.1f} s "
          f"-> {output}")
    return 0


if __name__ == "__main__":
    if len(sys.argv) != 3:
        print(__doc__, file=sys.stderr)
        sys.exit(2)
    sys.exit(main(sys.argv[1], sys.argv[2]))
