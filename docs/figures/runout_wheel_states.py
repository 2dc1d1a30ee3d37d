"""Numbers and figure of docs/validation.md, "Post-impact wheel states and contacts".

Run from the repository root: ``PYTHONPATH=. python docs/figures/runout_wheel_states.py``.
Writes ``benchmarks/results/runout-wheel-states.json`` and
``docs/figures/runout_wheel_states.png``:

1. the closed forms of the run-out with post-impact inputs: a locked car's slide against
   v^2 / (2 mu g), a free-rolling car with extra drag against v^2 / (2 (f_r + f_d) g), a
   steered rolling car's circle against the kinematic R = L / tan(delta) at walking pace
   (narrow and real track);
2. the bundled default database run with solved contacts (``RunoutParams(contact=True)``)
   against the default run-out (vehicles pass through each other): how many cases change and
   by how much, and the CPU time of both.
"""

from __future__ import annotations

import json
import math
import time
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from vfs.atomic import write_figure, write_text
from vfs.database import open_database
from vfs.physics.runout import RunoutParams, RunoutState, run_out
from vfs.physics.vehicle import VehicleParams, stack_vehicles
from vfs.simulation import CaseBatch, SimulationParams, results_table, simulate_cases
from vfs.units import G

ROOT = Path(__file__).resolve().parents[2]
RECORD = ROOT / "benchmarks" / "results" / "runout-wheel-states.json"
FIGURE = ROOT / "docs" / "figures" / "runout_wheel_states.png"


def closed_forms() -> dict[str, object]:
    """Run-out against its closed forms (SI)."""
    car = stack_vehicles([VehicleParams()])
    out: dict[str, object] = {}
    speed, mu = 10.0, 0.8
    locked = run_out(car, RunoutState.from_arrays(0, 0, 0, speed, 0, 0), mu,
                     wheel_brake=(1, 1, 1, 1), steer=0.3)
    out["locked_slide_with_steer"] = {"model_m": float(locked.rest_x[0]),
                                      "closed_form_m": speed**2 / (2 * mu * G)}
    drag = []
    for f_d in (0.02, 0.1, 0.3):
        res = run_out(car, RunoutState.from_arrays(0, 0, 0, 6.0, 0, 0), mu,
                      wheel_brake=(0, 0, 0, 0), wheel_drag=(f_d,) * 4)
        drag.append({"drag": f_d, "model_m": float(res.rest_x[0]),
                     "closed_form_m": 36.0 / (2 * (0.015 + f_d) * G)})
    out["free_roll_with_drag"] = drag
    circles = []
    params = RunoutParams(rolling_resistance=0.0, max_time=12.0)
    for track in (0.3, 1.55):
        vehicle = stack_vehicles([VehicleParams(track_width=track)])
        lr = float(vehicle.cg_to_rear_axle[0])
        for delta in (0.05, 0.15, 0.3):
            res = run_out(vehicle, RunoutState.from_arrays(0, 0, 0, 1.0, 0, 0), mu, params,
                          wheel_brake=(0, 0, 0, 0), steer=delta)
            p = res.path[0]
            x, y = p[:, 0] - lr * np.cos(p[:, 2]), p[:, 1] - lr * np.sin(p[:, 2])
            a = np.c_[2 * x, 2 * y, np.ones_like(x)]
            cx, cy, c = np.linalg.lstsq(a, x * x + y * y, rcond=None)[0]
            radius = math.sqrt(c + cx * cx + cy * cy)
            expected = float(vehicle.wheelbase[0]) / math.tan(delta)
            circles.append({"track_m": track, "steer_rad": delta, "radius_m": radius,
                            "kinematic_m": expected, "relative_error": radius / expected - 1})
    out["kinematic_circle_1ms"] = circles
    return out


def contacts_on_default() -> tuple[dict[str, object], np.ndarray, np.ndarray]:
    """The default database with and without solved contacts."""
    db = open_database("default")
    batch = CaseBatch.from_database(db)
    tables = {}
    cpu = {}
    for name, runout in (("pass_through", RunoutParams()),
                         ("contact", RunoutParams(contact=True))):
        t0 = time.process_time()
        tables[name] = results_table(batch, simulate_cases(
            batch, params=SimulationParams(runout=runout)))
        cpu[name] = time.process_time() - t0
    a, b = tables["pass_through"], tables["contact"]
    moved = np.concatenate([np.hypot(b[f"rest_x{i}"] - a[f"rest_x{i}"],
                                     b[f"rest_y{i}"] - a[f"rest_y{i}"]).to_numpy()
                            for i in (1, 2)])
    collided = a["collided"].to_numpy(bool)
    moved = moved[np.concatenate([collided, collided])]
    changed = moved > 0.01
    record = {
        "cases": int(collided.sum()),
        "secondary_collisions_pass_through": int(a["secondary_collision"].sum()),
        "secondary_collisions_contact": int(b["secondary_collision"].sum()),
        "vehicles_rest_moved_over_1cm": int(changed.sum()),
        "vehicles": int(moved.size),
        "rest_change_m_median_of_changed": float(np.median(moved[changed])) if changed.any()
        else 0.0,
        "rest_change_m_p90_of_changed": float(np.quantile(moved[changed], 0.9))
        if changed.any() else 0.0,
        "rest_change_m_max": float(moved.max()),
        "cpu_s": cpu,
    }
    return record, moved, changed


def main() -> None:
    """Write the record and the figure."""
    record: dict[str, object] = {"closed_forms": closed_forms()}
    contacts, moved, changed = contacts_on_default()
    record["contacts_default_database"] = contacts
    record["note"] = ("CPU time by time.process_time on a shared 2-core machine (load from "
                      "other jobs); the figures of docs/validation.md come from this file")
    RECORD.parent.mkdir(parents=True, exist_ok=True)
    write_text(RECORD, json.dumps(record, indent=1, sort_keys=True) + "\n")
    fig = Figure(figsize=(9, 3.6))
    ax1, ax2 = fig.subplots(1, 2)
    circ = record["closed_forms"]["kinematic_circle_1ms"]  # type: ignore[index]
    for track in (0.3, 1.55):
        rows = [c for c in circ if c["track_m"] == track]
        ax1.plot([math.degrees(c["steer_rad"]) for c in rows],
                 [100 * c["relative_error"] for c in rows], "o-", label=f"track {track} m")
    ax1.axhline(0.0, color="k", lw=0.8)
    ax1.set_xlabel("steer angle [deg]")
    ax1.set_ylabel("circle radius - L / tan(delta) [%]")
    ax1.set_title("steered rolling car at 1 m/s")
    ax1.legend()
    ax2.hist(moved[changed], bins=30)
    ax2.set_xlabel("rest position moved by solved contacts [m]")
    ax2.set_ylabel("vehicles")
    ax2.set_title(f"default database: {int(changed.sum())} of {moved.size} vehicles move")
    fig.tight_layout()
    write_figure(FIGURE, fig)
    print(json.dumps(record, indent=1))


if __name__ == "__main__":
    main()
