"""Figures drawn again only when their inputs changed: a content hash of each material's figure
inputs (the study, the material's fit and probe records, the bytes of every image those records
name, the report's own code and matplotlib's version), stored beside the figures with the
records figures.json lists for them. A rerun of the report after a study that changed one
material draws that material's grids and probe figures only (issue 46 item 2, as the jobs' hashes
do for the fits).

Reads files (the images, to hash them; the stored hashes) and writes the stored hashes; draws
nothing.
"""

import dataclasses
import glob
import hashlib
import json
import os

import matplotlib

REPORT_DIR = os.path.dirname(os.path.abspath(__file__))
# Bumped by hand when a stored record's meaning changes without a code change (never so far).
CACHE_SCHEMA = "shadefit.report.figure-cache/1"


def _sha256_file(path, h):
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)


def code_fingerprint():
    """The report's code (every .py and .tsv of report/, by content) and matplotlib's version:
    a change to how a figure is drawn redraws it."""
    h = hashlib.sha256(CACHE_SCHEMA.encode())
    h.update(matplotlib.__version__.encode())
    for path in sorted(glob.glob(os.path.join(REPORT_DIR, "*.py"))
                       + glob.glob(os.path.join(REPORT_DIR, "*.tsv"))):
        h.update(os.path.basename(path).encode() + b"\0")
        _sha256_file(path, h)
    return h.hexdigest()


def material_key(study_dir, study, fits, probes, material, code, digests):
    """The hash of everything one material's figures are drawn from. Its fit and probe records
    count by the SHA-256 of the files they were read from (`digests`: report_inputs.read_jobs'):
    a measured study's records are ~50 MB of JSON, and writing them out again for the hash took
    ~2 s before the figure workers could start."""
    mine = {label: job for (m, label), job in sorted(fits.items()) if m == material}
    keys = [("fit", material, label) for label in mine] + (
        [("probe", material)] if material in probes else [])
    h = hashlib.sha256(code.encode())
    h.update(json.dumps({"study": study, "material": material,
                         "jobs": [[k, digests[k]] for k in keys]}, sort_keys=True).encode())
    images = sorted({rel for job in mine.values() for e in job["evaluations"]
                     for rel in (e.get("images") or {}).values() if isinstance(rel, str)})
    for rel in images:
        path = os.path.join(study_dir, rel)
        h.update(rel.encode() + b"\0")
        if os.path.exists(path):
            _sha256_file(path, h)
        else:
            h.update(b"missing")
    return h.hexdigest()


def _path(fig_dir, material):
    # A material's name may hold any character; the file is named by its hash.
    name = hashlib.sha256(material.encode()).hexdigest()[:16]
    return os.path.join(fig_dir, f"material-{name}.hash")


def load(fig_dir, material, key):
    """The stored records (grids, probe figures) of `material` when its key matches and every
    file they name is there; else None."""
    try:
        with open(_path(fig_dir, material), encoding="utf-8") as f:
            stored = json.load(f)
    except (OSError, ValueError):
        return None
    if not isinstance(stored, dict) or stored.get("key") != key:
        return None
    grids, probe_figs = stored["records"]
    report_dir = os.path.dirname(fig_dir)
    for r in grids + probe_figs:
        if not all(os.path.exists(os.path.join(report_dir, r[k])) for k in ("png", "pdf")):
            return None
    return grids, probe_figs


def store(fig_dir, material, key, records, write_text):
    write_text(_path(fig_dir, material), json.dumps({"material": material, "key": key,
                                                     "records": list(records)}))


def _jsonable(value):
    """Records (dataclasses) as their fields; anything else JSON lacks by its repr."""
    if hasattr(value, "to_json"):
        return value.to_json()
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return dataclasses.asdict(value)
    return repr(value)


def group_key(code, inputs, files=()):
    """The hash of a study-level figure group's inputs: `inputs` (JSON-able; tuple keys are
    written as lists) and the bytes of `files`."""
    h = hashlib.sha256(code.encode())
    h.update(json.dumps(inputs, sort_keys=True, default=_jsonable).encode())
    for path in sorted(files):
        h.update(path.encode() + b"\0")
        if os.path.exists(path):
            _sha256_file(path, h)
    return h.hexdigest()


def cached_group(fig_dir, name, key, draw, write_text):
    """The records of figure group `name`: the stored ones when `key` matches and their files
    exist, else draw(manifest) is called and its records stored."""
    stored = load(fig_dir, f"group:{name}", key)
    if stored is not None:
        return stored[0]
    manifest = []
    draw(manifest)
    store(fig_dir, f"group:{name}", key, (manifest, []), write_text)
    return manifest
