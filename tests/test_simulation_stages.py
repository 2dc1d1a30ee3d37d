"""One opening of the simulation stages (vfs.simulation.open_cases), used by simulate_cases
and by the gym environment: the effects' vehicle hook acts once, before the penetration rule
and the impact parameters, in both.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from vfs.database import bundled_database_path, load_database
from vfs.effects.base import Effect
from vfs.gym.config import EnvConfig
from vfs.gym.env import EpisodeBatch
from vfs.simulation import CaseBatch, SimulationParams, open_cases, simulate_cases

SEEN: list[np.ndarray] = []


class HeavierWithPenetration(Effect):
    """Test effect: vehicle 1 three times as heavy; records the mass the penetration rule sees
    and sets a penetration time of 0.02 s (not a physical model; a probe of the stage order).
    """

    name = "test_heavier_with_penetration"

    def vehicles(self, batch: CaseBatch) -> CaseBatch:
        return batch._replace(vehicle1=batch.vehicle1._replace(mass=3.0 * batch.vehicle1.mass))

    def penetration(self, ctx, penetration_time: np.ndarray) -> np.ndarray:  # noqa: ANN001
        SEEN.append(np.asarray(ctx.vehicle1.mass))
        return np.full_like(penetration_time, 0.02)


def _batch(n: int = 12) -> CaseBatch:
    db = load_database(bundled_database_path("default"))
    return CaseBatch.from_database(db, np.asarray(db.case_ids)[:n])


def test_open_cases_orders_the_stages() -> None:
    batch = _batch()
    params = SimulationParams(effects=(HeavierWithPenetration(),))
    opened = open_cases(batch, params)
    np.testing.assert_array_equal(opened.batch.vehicle1.mass, 3.0 * batch.vehicle1.mass)
    plain = open_cases(batch, SimulationParams())
    assert plain.penetration is None and opened.penetration is not None
    # the impact parameters do not depend on the vehicle hook: NaN -> the defaults
    np.testing.assert_array_equal(opened.restitution, plain.restitution)
    SEEN.clear()
    res = simulate_cases(batch, params=params)
    hit = res.precrash.collided
    assert hit.any() and SEEN
    # the penetration rule saw the hooked vehicles, once (not hooked twice: 9x)
    seen = np.concatenate(SEEN)
    assert np.all(np.isin(seen, 3.0 * batch.vehicle1.mass))
    # impact 0.02 s after first contact for the cases that did not graze
    gap = res.precrash.impact_time[hit] - res.precrash.contact_time[hit]
    assert np.isclose(np.median(gap), 0.02)


def test_gym_opens_its_cases_the_same_way() -> None:
    effect = HeavierWithPenetration()
    config = dataclasses.replace(EnvConfig(split="all"), effects=(effect,))
    episodes = EpisodeBatch(config, 1)
    reference = open_cases(CaseBatch.from_database(
        load_database(bundled_database_path("default")), episodes.split_ids,
        impact_parameters=config.impact_parameters), episodes.params)
    np.testing.assert_array_equal(episodes.batch.vehicle1.mass, reference.batch.vehicle1.mass)
    np.testing.assert_array_equal(episodes.eps, reference.restitution)
    np.testing.assert_array_equal(episodes.mu, reference.contact_friction)
