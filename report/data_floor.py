#!/usr/bin/python3
"""The data floor (issue 33, item 5; docs/measured_and_imported.md, "Data floor"): the error of
the best isotropic BRDF the photographs support, fitted without a model.

The BRDF is a table f_c(theta_h, theta_d) per channel c, a bivariate BRDF as in Romeiro,
Vasilyev and Zickler 2008 ("Passive reflectometry", ECCV), read by bilinear interpolation on a
grid of H_BINS x D_BINS nodes: theta_h in [0, pi/2] on square-root spacing (node i at
(i / (H_BINS - 1))^2 pi/2, as MERL's tables, dense near the highlight), theta_d uniform on
[0, pi/2]. A pixel's value is linear in the table:

    I_c = coverage sum_lights E_c (n.l) sum_k w_k(theta_h, theta_d) f_k,c

with the geometry the runner wrote (geometry/<reference>.npy: studies/runner/src/
geometry_outputs.cpp), read by report/floor_inputs.py; this module computes only (no file
opened, no word written: the floor's sentences and table are in section_words.py). A free exposure is absorbed into f (the floor is then relative, like the
free-exposure fits); with a fixed exposure it is absolute. The table is the non-negative
least-squares solution over the training photographs with a smoothness penalty,

    min_f  sum_pixels ((A f - I) / (|I| + eps))^2 + lambda s ||D f||^2,   f >= 0,

where the weights 1 / (|I| + eps) make the data term the study's relative RMSE (metrics/src/
pixel_metrics.cpp, eps = 0.01), D holds second differences along both axes of the table and
s = trace(A'A) / trace(D'D) makes lambda unitless. lambda is chosen from LAMBDAS by
leave-one-lighting-out over the training lightings. With 512 unknowns per channel the problem is
solved on its normal equations: R = chol(A'A + lambda s D'D), then min ||R f - R^-T A'I|| with
f >= 0 (scipy.optimize.nnls), which has the same minimiser.

Evaluated like any fit: relative RMSE over every covered pixel of each reference (RGB pooled),
training and test lightings alike; the floor of a training set is the mean over its test
lightings, compared with each fit's mean over the same lightings.
"""

import math

import numpy as np
from scipy import sparse

from report_records import DataFloor, DataFloorDecoding, DataFloorFit, DataFloorMaterial

H_BINS, D_BINS = 32, 16
LAMBDAS = (1e-6, 1e-5, 1e-4, 1e-3, 1e-2, 1e-1, 1.0, 10.0)
RELATIVE_EPSILON = 0.01  # metrics::PixelMetricParameters::relative_epsilon
# A geometry row (geometry/index.json; floor_inputs checks each file against these).
FIXED_COLUMNS = 13       # x y coverage train r g b nx ny nz vx vy vz
LIGHT_COLUMNS = 6        # lx ly lz Er Eg Eb, per light slot


def srgb_oetf(x):
    x = np.clip(x, 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055)


def redecode(values, decoded_from, decoding):
    """`values` decoded as a fit with encoding = "fit" chose (fit/src/encoding_search.cpp,
    Redecode): back to the stored values by the import's decoding (sRGB or linear), then decoded
    by `decoding` (a DataFloorDecoding: "srgb", "linear" or "gamma" g); None keeps them."""
    if decoding is None:
        return values
    stored = srgb_oetf(values) if decoded_from == "srgb" else values
    v = np.clip(stored, 0.0, 1.0)
    if decoding.chosen == "srgb":
        return np.where(v <= 0.04045, v / 12.92, np.power((v + 0.055) / 1.055, 2.4))
    if decoding.chosen == "gamma":
        return np.power(v, float(decoding.gamma))
    return v


def chosen_decoding(study, fits, material, train):
    """The decoding the study's baseline fit (else the first fit) of this material and training
    set chose with encoding = "fit", a DataFloorDecoding; None when it kept the import's: the
    floor is scored in the same values as that fit."""
    cands = [(label, f) for (m, label), f in sorted(fits.items())
             if m == material and list(f["train"]) == list(train)]
    base = study["baseline"]
    cands.sort(key=lambda lf: lf[1]["model"] != base)
    for label, f in cands:
        enc = f.get("encoding")  # optional: only a fit that searched the encoding has one
        if enc is not None:
            return DataFloorDecoding(enc["chosen"], enc["gamma"], label)
        return None
    return None


def table_weights(n, v, l):
    """(index, weight) of the 4 table nodes of each (n, v, l) triple (arrays of shape (m, 3)),
    and the cosine n.l: bilinear in (sqrt(theta_h / (pi/2)), theta_d / (pi/2))."""
    h = l + v
    h /= np.maximum(np.linalg.norm(h, axis=1, keepdims=True), 1e-12)
    theta_h = np.arccos(np.clip(np.sum(n * h, axis=1), -1.0, 1.0))
    theta_d = np.arccos(np.clip(np.sum(l * h, axis=1), -1.0, 1.0))
    u = np.sqrt(np.clip(theta_h / (math.pi / 2), 0.0, 1.0)) * (H_BINS - 1)
    w = np.clip(theta_d / (math.pi / 2), 0.0, 1.0) * (D_BINS - 1)
    i0 = np.minimum(np.floor(u).astype(int), H_BINS - 2)
    j0 = np.minimum(np.floor(w).astype(int), D_BINS - 2)
    fu, fw = u - i0, w - j0
    idx = [i0 * D_BINS + j0, (i0 + 1) * D_BINS + j0, i0 * D_BINS + j0 + 1,
           (i0 + 1) * D_BINS + j0 + 1]
    wts = [(1 - fu) * (1 - fw), fu * (1 - fw), (1 - fu) * fw, fu * fw]
    nol = np.clip(np.sum(n * l, axis=1), 0.0, None)
    return np.stack(idx, axis=1), np.stack(wts, axis=1), nol


class Reference:
    """One reference's rows: values (P, 3), train flags (P,), and its design matrix (P, K) per
    channel, K = H_BINS * D_BINS. `geometry`: a floor_inputs.GeometryReference."""

    def __init__(self, geometry, decoding=None):
        data = np.asarray(geometry.rows, dtype=np.float64)
        slots = geometry.light_slots
        self.lighting = geometry.lighting
        self.values = redecode(data[:, 4:7], geometry.decoded_from, decoding)
        self.train = data[:, 3] > 0.5
        coverage = data[:, 2]
        n, v = data[:, 7:10], data[:, 10:13]
        k = H_BINS * D_BINS
        p = data.shape[0]
        rows = np.arange(p)
        entries = [([], [], []) for _ in range(3)]  # (row, column, value) per channel
        for s in range(slots):
            block = data[:, FIXED_COLUMNS + LIGHT_COLUMNS * s:FIXED_COLUMNS + LIGHT_COLUMNS * (s + 1)]
            lit = np.any(block[:, 3:6] > 0, axis=1)
            if not lit.any():
                continue
            idx, wts, nol = table_weights(n[lit], v[lit], block[lit, 0:3])
            for c in range(3):
                scale = coverage[lit] * nol * block[lit, 3 + c]
                for q in range(4):
                    entries[c][0].append(rows[lit])
                    entries[c][1].append(idx[:, q])
                    entries[c][2].append(wts[:, q] * scale)
        # Sparse (4 entries a light a row): a 612 x 512 photograph has ~10^5 rows.
        self.design = []
        for r, col, val in entries:
            cat = (lambda xs, dt: np.concatenate(xs) if xs else np.zeros(0, dt))
            self.design.append(sparse.csr_matrix(
                (cat(val, float), (cat(r, int), cat(col, int))), shape=(p, k)))

    def normal_equations(self, c):
        """(A'WA, A'WI) of channel c over the training pixels, W the relative weights squared."""
        t = self.train
        wt = 1.0 / (np.abs(self.values[t, c]) + RELATIVE_EPSILON)
        a = sparse.diags(wt) @ self.design[c][t]
        b = self.values[t, c] * wt
        return (a.T @ a).toarray(), a.T @ b

    def predict(self, tables):
        return np.stack([self.design[c] @ tables[c] for c in range(3)], axis=1)

    def relative_rmse(self, tables):
        e = (self.predict(tables) - self.values) / (np.abs(self.values) + RELATIVE_EPSILON)
        return float(np.sqrt(np.mean(e * e))) if e.size else float("nan")


def smoothness_matrix():
    """D'D of the second differences along theta_h and along theta_d (table index space)."""
    rows = []
    k = H_BINS * D_BINS
    for i in range(H_BINS):
        for j in range(D_BINS):
            if 0 < i < H_BINS - 1:
                r = np.zeros(k)
                r[(i - 1) * D_BINS + j], r[i * D_BINS + j], r[(i + 1) * D_BINS + j] = 1, -2, 1
                rows.append(r)
            if 0 < j < D_BINS - 1:
                r = np.zeros(k)
                r[i * D_BINS + j - 1], r[i * D_BINS + j], r[i * D_BINS + j + 1] = 1, -2, 1
                rows.append(r)
    d = np.array(rows)
    return d.T @ d


def solve(gram, rhs, dtd, lam):
    """The non-negative minimiser of f'Gf - 2 f'r + lambda s f'D'Df (see the module text)."""
    from scipy.optimize import nnls
    s = np.trace(gram) / np.trace(dtd) if np.trace(gram) > 0 else 1.0
    m = gram + lam * s * dtd
    m += np.eye(m.shape[0]) * 1e-10 * max(np.trace(m) / m.shape[0], 1e-30)  # keeps chol defined
    r = np.linalg.cholesky(m).T                      # m = R'R
    c = np.linalg.solve(r.T, rhs)                    # R'c = A'I
    # Lawson-Hanson (scipy's nnls, Fortran): the same minimiser as lsq_linear's BVLS to 1e-10
    # here, 40 times faster (0.15 s against 6.5 s for 512 unknowns; BVLS loops in Python).
    return nnls(r, c, maxiter=50 * r.shape[1])[0]


def fit_tables(refs, dtd, lam):
    tables = []
    for c in range(3):
        k = H_BINS * D_BINS
        gram, rhs = np.zeros((k, k)), np.zeros(k)
        for r in refs:
            g, b = r.normal_equations(c)
            gram += g
            rhs += b
        tables.append(solve(gram, rhs, dtd, lam))
    return tables


def choose_lambda(train_refs, dtd):
    """The lambda of LAMBDAS with the lowest leave-one-lighting-out relative error (sum of squared
    relative errors over the held-out lightings' pixels); with one training lighting, the
    middle one."""
    if len(train_refs) < 2:
        return LAMBDAS[len(LAMBDAS) // 2], {}
    k = H_BINS * D_BINS
    parts = [[r.normal_equations(c) for c in range(3)] for r in train_refs]
    scores = {}
    for lam in LAMBDAS:
        sse = 0.0
        for i, held in enumerate(train_refs):
            tables = []
            for c in range(3):
                gram, rhs = np.zeros((k, k)), np.zeros(k)
                for j, p in enumerate(parts):
                    if j != i:
                        gram += p[c][0]
                        rhs += p[c][1]
                tables.append(solve(gram, rhs, dtd, lam))
            e = (held.predict(tables) - held.values) / (np.abs(held.values) + RELATIVE_EPSILON)
            sse += float(np.sum(e[held.train] ** 2))
        scores[lam] = sse
    return min(LAMBDAS, key=lambda lam: scores[lam]), scores


def mean(xs):
    xs = [x for x in xs if x is not None and math.isfinite(x)]
    return sum(xs) / len(xs) if xs else None


def fit_test_error(fit, lightings):
    """A fit job's mean relative RMSE over `lightings` (its evaluations' "metrics")."""
    vals = []
    for e in fit["evaluations"]:
        if e["lighting"] in lightings:
            v = e["metrics"].get("relative_rmse")
            vals.append(float(v) if v is not None else None)
    return mean(vals)


def compute_floor(geometry, study, fits):
    """The DataFloor (floor.json's record), or None when the study wrote no geometry.
    `geometry`: floor_inputs.read_geometry's; `fits`: make_report's {(material, label): job
    JSON}."""
    if geometry is None:
        return None
    dtd = smoothness_matrix()
    test_only = set(study["test_lightings"])
    materials = []
    by_material = {}
    for e in geometry.references:
        # Per material and object: a data set of several objects has a floor per object.
        by_material.setdefault((e.material, e.object), []).append(e)
    for material, obj in sorted(by_material):
        entries = by_material[(material, obj)]

        for train in study["training_sets"]:
            decoding = chosen_decoding(study, fits, material, train)

            # The training references' design matrices stay in memory; every other one is made,
            # scored and dropped (a 612 x 512 photograph's take ~25 MB).
            train_refs = [Reference(e, decoding) for e in entries if e.lighting in train]
            test_lightings = [e.lighting for e in entries if e.lighting not in train
                              and (not test_only or e.lighting in test_only)]
            if not train_refs or not any(r.train.any() for r in train_refs):
                continue
            lam, scores = choose_lambda(train_refs, dtd)
            tables = fit_tables(train_refs, dtd, lam)
            per = {r.lighting: r.relative_rmse(tables) for r in train_refs}
            for e in entries:
                if e.lighting not in per:
                    per[e.lighting] = Reference(e, decoding).relative_rmse(tables)
            floor = mean([per[l] for l in test_lightings])
            beside = []
            for (m, label), fit in sorted(fits.items()):
                if m != material or list(fit["train"]) != list(train):
                    continue
                err = fit_test_error(fit, set(test_lightings))
                beside.append(DataFloorFit(label, err, 100.0 * (err - floor)
                                           if err is not None and floor is not None else None))
            materials.append(DataFloorMaterial(
                material, obj, list(train), lam, decoding,
                {f"{k:g}": v for k, v in scores.items()},
                mean([per[r.lighting] for r in train_refs]), floor, per, test_lightings,
                [float(np.max(t)) for t in tables], beside))
    return DataFloor("shadefit.report.floor/1", [H_BINS, D_BINS], "square root", list(LAMBDAS),
                     RELATIVE_EPSILON, materials, [dict(s) for s in geometry.skipped])
