"""The records the report's compute modules hand to its writers, declared in one place (issue 47
item 5): each a dataclass whose fields say what it holds. Compute modules make them; the words,
tables, figures and pages only format them. Nothing here reads a file or writes a word; a record
that comparisons.json or another JSON file holds says how (to_json), in the order the file has
always had."""

from dataclasses import dataclass


# ------------------------------------------------------------------------------------------------
# Ngan, Durand and Matusik 2005 (report_ngan.ngan_comparison)


@dataclass(frozen=True)
class NganRow:
    """One material and fit: our number (`ours_label`: what it is) next to Ngan's (`ngan_label`:
    which of their fits)."""
    material: str
    fit: str
    ours_label: str
    ours: float
    ngan_label: str
    theirs: float


@dataclass(frozen=True)
class NganCorrelation:
    """Spearman's rho of one fit's `ours` quantity with Ngan's column `ngan` over `materials`
    materials; None where it is undefined (report_stats.spearman)."""
    fit: str
    model: str
    ours: str
    ngan: str
    materials: int
    spearman: float


@dataclass(frozen=True)
class NganComparison:
    """Every row and correlation; `source`: the ngan2005-fits.tsv read."""
    source: str
    rows: list
    correlations: list
