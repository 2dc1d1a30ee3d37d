"""The waterfall figure of the error ledger (:mod:`vfs.diagnosis.ledger`)."""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from vfs.report.figures import new_figure, save_figure


def plot_waterfall(chain: Sequence[Mapping[str, Any]], path: str | os.PathLike[str]) -> Path:
    """Waterfall figure of the chain: bars from the default CV RMSE down each step."""
    labels = ["default"] + [f"+ {r['added']}" for r in chain[1:]]
    values = [float(r["cv_rmse_overall"]) for r in chain]
    fig = new_figure((1.6 * len(values) + 2.0, 4.0))
    ax = fig.subplots()
    for k, v in enumerate(values):
        if k == 0:
            ax.bar(k, v, color="#7f7f7f")
        else:
            lo, hi = sorted((values[k - 1], v))
            ax.bar(k, hi - lo, bottom=lo, color="#2ca02c" if v < values[k - 1] else "#d62728")
            ax.plot([k - 1.4, k + 0.4], [values[k - 1]] * 2, "k:", lw=0.8)
        ax.text(k, v, f"{v:.3g}", ha="center", va="bottom", fontsize=8)
    ax.bar(len(values), values[-1], color="#1f77b4")
    ax.text(len(values), values[-1], f"{values[-1]:.3g}", ha="center", va="bottom", fontsize=8)
    ax.set_xticks(range(len(values) + 1), labels + ["final"], rotation=20, ha="right",
                  fontsize=8)
    ax.set_ylabel("cross-validated RMSE (standardised, all outputs)")
    ax.set_title("Error ledger: the model error falling with each added effect", fontsize=10)
    return save_figure(fig, path, dpi=110, tight=True)


__all__ = ["plot_waterfall"]
