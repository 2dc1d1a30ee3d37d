"""The Momentum Based Impact Model paper's published results beside a comparison's.

"Evaluation of a momentum based impact model in frontal car collisions for the
prospective assessment of ADAS" compared its virtual forward simulation (VFS) with the
reconstructions of 36 fatal head-on accidents.  Its text gives:

* Table 1: n, the mean of the reconstruction and of the VFS and the paired t-test's p
  for delta-v, EES and the change of velocity angle, full and sliding impacts (vehicles
  of the cases with the same impact type in both), means to 0.01 km/h or deg, p to
  0.001 (section 7);
* the impact types (Figure 4, numbers in section 7): 13 accidents full in both, 6
  sliding in both, 17 changed, the chi-squared test "highly significant (p <= 0.01)";
* the POI distances (section 7, Figure 5): 0.190 m over all 72 vehicles, 0.167 m
  (n = 26) both full, 0.148 m (n = 12) both sliding, 0.222 m (n = 34) type changed.

Its protocol: the VFS used generic default impact parameters ("Due to lack of
information, the input-parameters of the impact model are set to the default values in
case of VFS"), a fixed 30 ms penetration and the geometric POI/contact-plane rule.
:func:`side_by_side_table1` and :func:`side_by_side_types` put these numbers beside a
:class:`vfs.analysis.compare.Comparison`'s; ``vfs compare`` writes both into its report
and as ``paper_table1.csv`` / ``paper_types.csv``.
"""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np
import pandas as pd

from vfs.analysis.compare import GROUP_ALL, GROUP_CHANGED, GROUP_FULL, GROUP_SLIDING


class PaperTable1Row(NamedTuple):
    """One row of the paper's Table 1 (km/h or deg as printed)."""

    outcome: str
    """Outcome name of :data:`vfs.analysis.compare.TABLE1_OUTCOMES`."""
    group: str
    """Impact-type group (both full or both sliding)."""
    n: int
    """Number of vehicles [-]."""
    mean_reconstruction: float
    """Mean of the reconstructions [km/h or deg]."""
    mean_vfs: float
    """Mean of the paper's VFS [km/h or deg]."""
    p_value: float
    """Paired t-test p [-]."""


#: The paper's Table 1, as printed (section 7).
PAPER_TABLE1: tuple[PaperTable1Row, ...] = (
    PaperTable1Row("delta_v", GROUP_FULL, 26, 51.42, 50.54, 0.482),
    PaperTable1Row("ees", GROUP_FULL, 26, 50.19, 48.85, 0.398),
    PaperTable1Row("velocity_angle_change", GROUP_FULL, 26, 92.42, 93.71, 0.723),
    PaperTable1Row("delta_v", GROUP_SLIDING, 12, 24.25, 31.92, 0.255),
    PaperTable1Row("ees", GROUP_SLIDING, 12, 44.75, 55.33, 0.180),
    PaperTable1Row("velocity_angle_change", GROUP_SLIDING, 12, 12.83, 17.33, 0.301),
)
#: Half a unit of the last printed digit of the paper's means [km/h or deg] and p [-]:
#: the resolution of any comparison with them.
PAPER_MEAN_RESOLUTION, PAPER_P_RESOLUTION = 0.005, 0.0005
#: The paper's impact-type counts (accidents) and POI distances [m] by group (section 7).
PAPER_TYPE_COUNTS: dict[str, int] = {GROUP_FULL: 13, GROUP_SLIDING: 6, GROUP_CHANGED: 17}
PAPER_POI_DISTANCES: dict[str, tuple[float, int]] = {
    GROUP_ALL: (0.190, 72), GROUP_FULL: (0.167, 26), GROUP_SLIDING: (0.148, 12),
    GROUP_CHANGED: (0.222, 34)}
#: The paper's chi-squared result: "highly significant (p <= 0.01)".
PAPER_CHI2_P_AT_MOST = 0.01
#: A reconstruction mean differing from the paper's by more than this factor (either way)
#: marks a different population: the comparison of the VFS with it is not the paper's.
POPULATION_FACTOR = 1.5

PROTOCOL = (
    "The paper's protocol: VFS with generic default impact parameters for every case (the "
    "paper names restitution 0.1; `vfs compare --impact-parameters defaults` uses the "
    "model's defaults), fixed 30 ms penetration, POI and contact plane by the geometric "
    "rule; n = vehicles of the cases with the same impact type in "
    "reconstruction and VFS; paired t-test. The paper's numbers come from 36 real fatal "
    "head-on accidents reconstructed with PC-Crash; ours from the database compared, so "
    "they agree only as far as the reconstructed populations agree (columns 'rec.' "
    "and 'paper rec.').")


def table1_label(outcome: str, group: str) -> str:
    """The Table 1 row label of an outcome and group, as ``Comparison.table1`` names it."""
    names = {"delta_v": "Delta-v", "ees": "EES",
             "velocity_angle_change": "Change of velocity angle"}
    unit = "deg" if outcome == "velocity_angle_change" else "km/h"
    kind = "full impacts" if group == GROUP_FULL else "sliding impacts"
    return f"{names[outcome]}, {kind} [{unit}]"


def side_by_side_table1(comparison: Any) -> pd.DataFrame:
    """The paper's Table 1 beside the comparison's (km/h, deg).

    Parameters
    ----------
    comparison : vfs.analysis.compare.Comparison
        A comparison (its ``table1``).

    Returns
    -------
    pandas.DataFrame
        One row per Table 1 row: ``parameter``; the paper's ``paper_n``,
        ``paper_reconstruction``, ``paper_vfs``, ``paper_difference`` (VFS -
        reconstruction), ``paper_p``; ours ``n``, ``reconstruction``, ``vfs``,
        ``difference``, ``p_value``; ``same_direction`` (the signs of the two
        differences agree), ``both_not_significant`` (p >= 0.05 in both) and
        ``population_ratio`` (our reconstruction mean / the paper's; outside
        1 / :data:`POPULATION_FACTOR` - :data:`POPULATION_FACTOR` the populations differ).
        Our values are NaN where the group is empty.
    """
    ours = comparison.table1.set_index(["outcome", "group"]) if len(comparison.table1) else None
    rows = []
    for r in PAPER_TABLE1:
        o = (ours.loc[(r.outcome, r.group)]
             if ours is not None and (r.outcome, r.group) in ours.index else None)
        n = int(o["n"]) if o is not None else 0
        rec = float(o["mean_reconstruction"]) if o is not None else np.nan
        vfs = float(o["mean_vfs"]) if o is not None else np.nan
        p = float(o["p_value"]) if o is not None else np.nan
        d_paper = r.mean_vfs - r.mean_reconstruction
        rows.append({
            "parameter": table1_label(r.outcome, r.group), "paper_n": r.n,
            "paper_reconstruction": r.mean_reconstruction, "paper_vfs": r.mean_vfs,
            "paper_difference": d_paper, "paper_p": r.p_value,
            "n": n, "reconstruction": rec, "vfs": vfs, "difference": vfs - rec, "p_value": p,
            "same_direction": bool(np.sign(vfs - rec) == np.sign(d_paper)),
            "both_not_significant": bool(p >= 0.05 and r.p_value >= 0.05),
            "population_ratio": rec / r.mean_reconstruction,
        })
    return pd.DataFrame(rows)


def side_by_side_types(comparison: Any) -> pd.DataFrame:
    """The paper's impact-type counts and POI distances beside the comparison's.

    Returns
    -------
    pandas.DataFrame
        Rows ``both full``, ``both sliding``, ``type changed``, ``all``: ``paper_cases``
        and ``cases`` (accidents; for ``all`` the compared cases), ``paper_poi_distance``
        and ``poi_distance`` [m] (NaN where not reported), ``paper_poi_n`` and
        ``poi_n`` (vehicles).  The chi-squared p is in :func:`chi2_sentence`.
    """
    groups = comparison.cases["group"]
    poi = comparison.poi_distances.set_index("group") if len(comparison.poi_distances) \
        else pd.DataFrame(columns=["mean", "n"])
    rows = []
    for g in (GROUP_FULL, GROUP_SLIDING, GROUP_CHANGED, GROUP_ALL):
        count = int(groups.notna().sum()) if g == GROUP_ALL else int((groups == g).sum())
        paper_count = sum(PAPER_TYPE_COUNTS.values()) if g == GROUP_ALL else PAPER_TYPE_COUNTS[g]
        d, n = PAPER_POI_DISTANCES[g]
        have = g in poi.index
        rows.append({"group": g, "paper_cases": paper_count, "cases": count,
                     "paper_poi_distance": d,
                     "poi_distance": float(poi.loc[g, "mean"]) if have else np.nan,
                     "paper_poi_n": n, "poi_n": int(poi.loc[g, "n"]) if have else 0})
    return pd.DataFrame(rows)


def chi2_sentence(comparison: Any) -> str:
    """The chi-squared result beside the paper's (p <= 0.01)."""
    p = float(comparison.contingency.chi2_pvalue)
    verdict = ("significant at the paper's level" if p <= PAPER_CHI2_P_AT_MOST
               else "not significant at the paper's level")
    return (f"Chi-squared test of the impact-type frequencies: p = {p:.4f} here, "
            f"{verdict} (paper: p <= {PAPER_CHI2_P_AT_MOST:g}).")


def population_notes(table: pd.DataFrame) -> list[str]:
    """Sentences naming the Table 1 rows whose reconstructions are not the paper's
    population (reconstruction mean off by more than :data:`POPULATION_FACTOR`).
    """
    notes = []
    for _, r in table.iterrows():
        ratio = float(r["population_ratio"])
        if np.isfinite(ratio) and not 1.0 / POPULATION_FACTOR <= ratio <= POPULATION_FACTOR:
            notes.append(
                f"{r['parameter']}: the reconstructions here average {r['reconstruction']:.1f}"
                f", the paper's {r['paper_reconstruction']:.2f} (ratio {ratio:.1f}); this row "
                "compares a different population of impacts, so agreement or disagreement "
                "with the paper's VFS row says little.")
    return notes


__all__ = ["PAPER_CHI2_P_AT_MOST", "PAPER_MEAN_RESOLUTION", "PAPER_POI_DISTANCES",
           "PAPER_P_RESOLUTION", "PAPER_TABLE1", "PAPER_TYPE_COUNTS", "POPULATION_FACTOR",
           "PROTOCOL", "PaperTable1Row", "chi2_sentence", "population_notes",
           "side_by_side_table1", "side_by_side_types", "table1_label"]
