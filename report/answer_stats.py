"""The statistics of the comparative answers, and nothing else: a pair of fits' errors over the
units they share (materials, or a few objects' lightings: answer_rules.image_units) reduced to a
ratio or difference with a bootstrap 95% CI, closer-on-k-of-n and a paired test; and Holm's
step-down correction over the p-values of one compared pair (docs/studies.md, "Comparative
answers").

Which errors are compared, which pairs and questions there are, and what a verdict is: the rules,
answer_rules.py. The statistics are scipy's and statsmodels' (Debian python3-scipy,
python3-statsmodels); nothing here is a hand-written statistic. No file is read, no word written.
"""

import math
import warnings

import numpy as np
from scipy import stats

from report_records import Comparison
from report_util import frozen_heap

BOOTSTRAP_RESAMPLES = 10000


BOOTSTRAP_SEED = 20261204  # Fixed: a rerun of the report writes the same numbers.


SIGN_TEST_BELOW = 6        # Fewer non-tied materials than this: the exact sign test (the
                           # exact signed-rank test cannot reach p < 0.05 below 6 pairs).


MIN_MATERIALS_FOR_CI = 3   # Two materials give no meaningful interval.


class _BootstrapRng(np.random.Generator):
    """np.random.default_rng(BOOTSTRAP_SEED), whose first draw, the bootstrap's resample indices
    (scipy's _bootstrap_resample: integers(0, n, (BOOTSTRAP_RESAMPLES, n))), is the same for
    every sample of n values: drawn once per n and process, then handed out (read-only) with the
    generator left where drawing them leaves it. The same indices, the same intervals; ~0.5 of
    the measured report's ~4.5 CPU-s of answers were spent drawing them again."""

    _drawn = {}  # (low, high, size, dtype, endpoint) -> (indices, bit generator state after)

    def __init__(self):
        super().__init__(np.random.PCG64(BOOTSTRAP_SEED))
        self._fresh = True

    def integers(self, low, high=None, size=None, dtype=np.int64, endpoint=False):
        fresh, self._fresh = self._fresh, False
        if not fresh:
            return super().integers(low, high, size=size, dtype=dtype, endpoint=endpoint)
        key = (low, high, size if size is None else tuple(np.atleast_1d(size)), np.dtype(dtype),
               endpoint)
        held = self._drawn.get(key)
        if held is None:
            drawn = super().integers(low, high, size=size, dtype=dtype, endpoint=endpoint)
            if isinstance(drawn, np.ndarray):
                drawn.flags.writeable = False
            held = self._drawn[key] = (drawn, self.bit_generator.state)
        else:
            self.bit_generator.state = held[1]
        return held[0]

    def __getattribute__(self, name):
        # Any other draw first: the generator is no longer at its seed's first draw.
        if name not in ("integers", "_fresh", "_drawn", "bit_generator", "__class__",
                        "__dict__"):
            object.__getattribute__(self, "__dict__")["_fresh"] = False
        return super().__getattribute__(name)


def bootstrap_ci(values):
    """95% bootstrap interval of the mean of `values` (materials resampled; BCa, or the
    percentile interval where BCa is undefined). Constant values: the value itself."""
    values = np.asarray(values, dtype=float)
    if len(values) < MIN_MATERIALS_FOR_CI:
        return None, None
    if np.ptp(values) == 0:
        return float(values[0]), float(values[0])
    rng = _BootstrapRng()
    for method in ("BCa", "percentile"):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            res = stats.bootstrap((values,), np.mean, n_resamples=BOOTSTRAP_RESAMPLES,
                                  confidence_level=0.95, method=method, random_state=rng)
        lo, hi = res.confidence_interval
        if np.isfinite(lo) and np.isfinite(hi):
            return float(lo), float(hi)
    return None, None


def paired_test(x):
    """(p, test name) for paired values x (log ratios or differences; 0 = no difference): the
    Wilcoxon signed-rank test (zeros dropped), or the exact sign test when fewer than
    SIGN_TEST_BELOW are non-zero; p = 1 when every pair is tied (no evidence either way)."""
    x = np.asarray(x, dtype=float)
    nonzero = x[x != 0]
    if len(nonzero) == 0:
        return 1.0, "all tied"
    if len(nonzero) < SIGN_TEST_BELOW:
        wins = int(np.sum(nonzero > 0))
        return float(stats.binomtest(wins, len(nonzero), 0.5).pvalue), "sign test"
    return float(stats.wilcoxon(nonzero, zero_method="wilcox").pvalue), "Wilcoxon"


def quartiles(values):
    q1, med, q3 = np.percentile(np.asarray(values, dtype=float), [25, 50, 75])
    return float(med), float(q1), float(q3)


def compare_pair(errors, materials, label, base, mode):
    """The comparison of fit `label` with `base` over the materials where both have an error."""
    a, b, used = [], [], []
    for m in materials:
        ea, eb = errors.get((m, label)), errors.get((m, base))
        if ea is None or eb is None or not (math.isfinite(ea) and math.isfinite(eb)):
            continue
        a.append(ea)
        b.append(eb)
        used.append(m)
    n = len(used)
    if n == 0:
        return None
    a, b = np.asarray(a), np.asarray(b)
    if mode == "ratio" and not (np.all(a > 0) and np.all(b > 0)):
        mode = "difference"  # An error of 0 has no ratio.
    if mode == "ratio":
        x = np.log(b / a)  # > 0: `label` is closer.
        effect = float(np.exp(np.mean(x)))
        lo, hi = bootstrap_ci(x)
        ci = (None, None) if lo is None else (math.exp(lo), math.exp(hi))
    else:
        x = b - a
        effect = float(np.mean(x))
        ci = bootstrap_ci(x)
    p, test = paired_test(x)
    return Comparison(label, base, used, n, mode, effect, list(ci), int(np.sum(a < b)),
                      int(np.sum(a > b)), int(np.sum(a == b)), p, test, quartiles(a),
                      quartiles(b), {m: [float(ea), float(eb)] for m, ea, eb in zip(used, a, b)})


def holm_by_pair(tests):
    """Holm's step-down correction over `tests` (comparison records with `fit`, `baseline`,
    `p`), one family per compared pair: sets each record's `p_holm` and `holm_family`."""
    # Imported here: statsmodels brings pandas (~0.2 s), which only this needs, and the report
    # imports this module before its figure workers start (the import is then no longer serial).
    from statsmodels.stats.multitest import multipletests
    families = {}
    for c in tests:
        families.setdefault((c.fit, c.baseline), []).append(c)
    # statsmodels' Holm branch calls gc.collect() on every call (0.15 s each with the report's
    # heap: 20 s for the measured study's 140 families); frozen objects are not traversed.
    with frozen_heap():
        for family in families.values():
            adjusted = multipletests([c.p for c in family], method="holm")[1]
            for c, p in zip(family, adjusted):
                c.p_holm = float(p)
                c.holm_family = len(family)
