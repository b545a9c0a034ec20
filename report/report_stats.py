"""Rank statistics of the report: Spearman's rho (scipy.stats.spearmanr, ties given their average
rank), None where it is undefined."""

import math
import warnings

from scipy import stats


def spearman(x, y):
    """Spearman's rank correlation of paired values; None below 3 pairs or where a side is
    constant (no ranking to correlate)."""
    if len(x) < 3:
        return None
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", stats.ConstantInputWarning)
        rho = float(stats.spearmanr(x, y).statistic)
    return rho if math.isfinite(rho) else None
