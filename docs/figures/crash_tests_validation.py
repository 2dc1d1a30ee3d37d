"""Figures and numbers of docs/validation.md: the default model on ``--db crash-tests``.

Run from the repository root: ``python docs/figures/crash_tests_validation.py``.
Nothing is tuned: the default model (restitution 0.1, contact friction 0.6,
30 ms penetration, free-rolling run-out) meets the measured outcomes.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from vfs.atomic import write_figure
from vfs.database import open_database
from vfs.scenarios import crash_tests as ct
from vfs.simulation import CaseBatch, simulate_cases
from vfs.units import KMH_PER_MS

HERE = Path(__file__).parent


def main() -> None:
    """Draw the crash-test validation figures into docs/figures."""
    db = open_database("crash-tests")
    batch = CaseBatch.from_database(db)
    res = simulate_cases(batch)
    imp = res.impact
    rec = db.reconstruction.set_index("case_id").loc[batch.case_id]
    print("case  type  eps  mu   E_loss model [kJ]  measured [kJ] (sd)  diff")
    for i, cid in enumerate(batch.case_id):
        meas = rec["energy_loss"].iloc[i]
        sd = rec["energy_loss_sd"].iloc[i] if "energy_loss_sd" in rec else np.nan
        print(f"{cid:4d}  {int(imp.impact_type[i])}  {res.restitution[i]:.2f} "
              f"{res.contact_friction[i]:.2f}  {imp.energy_loss[i] / 1e3:8.1f}  "
              f"{meas / 1e3:8.1f} ({sd / 1e3:.1f})  {(imp.energy_loss[i] - meas) / 1e3:+.1f}")
        print(f"      dv1 {imp.delta_v[i, 0] * KMH_PER_MS:.1f} "
              f"dv2 {imp.delta_v[i, 1] * KMH_PER_MS:.1f}"
              f" km/h, ees1 {imp.ees[i, 0] * KMH_PER_MS:.1f} ees2 {imp.ees[i, 1] * KMH_PER_MS:.1f}"
              f" km/h, post v1 ({imp.vx_post[i, 0]:.2f}, {imp.vy_post[i, 0]:.2f}) v2 "
              f"({imp.vx_post[i, 1]:.2f}, {imp.vy_post[i, 1]:.2f}) m/s, w1 "
              f"{imp.yaw_rate_post[i, 0]:.2f} w2 {imp.yaw_rate_post[i, 1]:.2f} rad/s, rest1 "
              f"({res.runout.rest_x[i, 0]:.2f}, {res.runout.rest_y[i, 0]:.2f}) rest2 "
              f"({res.runout.rest_x[i, 1]:.2f}, {res.runout.rest_y[i, 1]:.2f}) m")

    fig = Figure(figsize=(8.0, 4.2))
    ax = fig.add_subplot()
    parts = [("deformation_work", "E_D deformation", "#4c72b0"),
             ("body_friction_work", "E_T body friction", "#55a868"),
             ("other_loss", "E_p rest", "#8172b2"),
             ("tyre_road_work", "E_tAB tyre-road", "#c44e52")]
    x = np.arange(3)
    bottom = np.zeros(3)
    for key, label, colour in parts:
        values = np.array(ct.AB_ENERGY_KJ[key])
        ax.bar(x - 0.2, values, 0.38, bottom=bottom, label=f"measured {label}", color=colour)
        bottom += values
    model = imp.energy_loss[:3] / 1e3
    ax.bar(x + 0.2, model, 0.38, color="#dd8452", label="model loss (impulse, eps 0.1)")
    for k in range(3):
        ax.text(x[k] + 0.2, model[k] + 1.5, f"{model[k]:.1f}", ha="center", fontsize=8)
        ax.text(x[k] - 0.2, bottom[k] + 1.5, f"{bottom[k]:.1f}", ha="center", fontsize=8)
    ax.set_xticks(x, ["AB1", "AB2", "AB3"])
    ax.set_ylabel("energy lost in the contact phase [kJ]")
    ax.set_title("Energy budget: Table 2 of the energy-balance paper vs the impulse model")
    ax.legend(fontsize=7, loc="upper right")
    ax.set_ylim(0, 135)
    write_figure(HERE / "validation_energy_budget.png", fig, dpi=110)

    # barrier: rebound speed and run-out vs restitution (the paper's identified 0.19)
    fig2 = Figure(figsize=(6.0, 3.4))
    ax2 = fig2.add_subplot()
    eps = np.linspace(0.0, 0.4, 41)
    v = ct.C300_SPEED_KMH / KMH_PER_MS
    ax2.plot(eps, eps * v * KMH_PER_MS, label="rebound speed eps v [km/h]")
    ax2.axvline(res.restitution[4], color="grey", ls=":", label="vfs default 0.1")
    ax2.axvline(ct.C300_RESTITUTION, color="k", ls="--", label="paper identified 0.19")
    ax2.set_xlabel("restitution eps (impulse ratio = velocity ratio at a fixed barrier)")
    ax2.set_ylabel("km/h")
    ax2.legend(fontsize=8)
    ax2.set_title("C300 barrier: what eps implies (no measured rebound in the text)")
    write_figure(HERE / "validation_barrier.png", fig2, dpi=110)


if __name__ == "__main__":
    main()
