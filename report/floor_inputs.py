"""The data floor's inputs (report/data_floor.py computes from them): geometry/index.json and
each photograph's geometry/<reference>.npy, the rows the runner wrote
(studies/runner/src/geometry_outputs.cpp). Read and checked with the other inputs, before the
report writes anything; a bad file is a FloorInputError naming it.

The arrays are memory-mapped: a photograph set's geometry can hold hundreds of MB (a 612 x 512
photograph is ~24 MB), so the pages are read when the floor uses them and dropped by the OS
after, as the floor used to read each test photograph, score it and drop it.
"""

import dataclasses
import json
import os

import numpy as np

from data_floor import FIXED_COLUMNS, LIGHT_COLUMNS  # the row's layout, which the floor reads


class FloorInputError(Exception):
    """A geometry file the floor cannot use; the message names it."""


@dataclasses.dataclass(frozen=True)
class GeometryReference:
    """One reference's rows: FIXED_COLUMNS, then LIGHT_COLUMNS per light slot."""
    reference: str
    material: str
    object: str          # "" for a set of one object
    lighting: str
    decoded_from: str    # the import's decoding of the stored values: "srgb" or "linear"
    light_slots: int
    rows: np.ndarray     # (pixels, FIXED_COLUMNS + LIGHT_COLUMNS * light_slots), float32


@dataclasses.dataclass(frozen=True)
class Geometry:
    references: list     # [GeometryReference], in index.json's order
    skipped: list        # [{"reference", "why"}]: references the runner wrote no rows for


def read_geometry(study_dir):
    """geometry/ of a study, or None when the runner wrote none (no photographs)."""
    index_path = os.path.join(study_dir, "geometry", "index.json")
    if not os.path.exists(index_path):
        return None
    try:
        with open(index_path, encoding="utf-8") as f:
            index = json.load(f)
    except (OSError, ValueError) as e:
        raise FloorInputError(f"{index_path}: cannot read ({e})")
    refs, skipped = [], []
    for e in index.get("references", []):
        if "skipped" in e:
            skipped.append({"reference": e["reference"], "why": e["skipped"]})
            continue
        path = os.path.join(study_dir, e["file"])
        try:
            rows = np.load(path, mmap_mode="r")
        except (OSError, ValueError) as err:
            raise FloorInputError(f"{path}: cannot read ({err})")
        slots = int(e.get("light_slots", 0))
        if rows.ndim != 2 or rows.shape[1] != FIXED_COLUMNS + LIGHT_COLUMNS * slots:
            raise FloorInputError(f"{path}: shape {rows.shape}, want (rows, "
                                  f"{FIXED_COLUMNS + LIGHT_COLUMNS * slots})")
        refs.append(GeometryReference(
            reference=e.get("reference", e["file"]), material=e["material"],
            object=e.get("object", ""), lighting=e["lighting"],
            decoded_from=e.get("decoded_from", "linear"), light_slots=slots, rows=rows))
    return Geometry(references=refs, skipped=skipped)
