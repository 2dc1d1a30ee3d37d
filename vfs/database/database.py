"""The in-memory accident-case database: four tables and a meta dict.

:class:`Database` holds and selects; it computes nothing physical.  Its
tables follow :mod:`vfs.database.schema`; reading, writing and validation live
in :mod:`vfs.database.io` and :mod:`vfs.database.validation`.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np
import pandas as pd

from vfs.database.schema import SCHEMA_VERSION, TABLE_NAMES, normalise_table
from vfs.errors import DataError, DataProblem
from vfs.physics.vehicle import DEFAULT_YAW_INERTIA_FORMULA, VehicleArrays, vehicle_arrays


def default_meta(name: str = "", created_by: str = "", description: str = "") -> dict[str, object]:
    """A ``meta`` dict of the current schema version.

    Parameters
    ----------
    name, created_by, description : str
        Free text, see :data:`vfs.database.schema.META_KEYS`.

    Returns
    -------
    dict
        ``{"schema_version": "1.0", "name": ..., "created_by": ..., "description": ...}``.
    """
    return {
        "schema_version": SCHEMA_VERSION,
        "name": name,
        "created_by": created_by,
        "description": description,
    }


@dataclass(frozen=True, eq=False)
class Database:
    """An accident-case database (schema :data:`~vfs.database.schema.SCHEMA_VERSION`).

    Treat the frames as read-only: methods return new objects and never
    modify them.  Build one with :func:`vfs.database.load_database`,
    :func:`vfs.database.import_pcm`, :func:`vfs.scenarios.example_database.make_example_database`
    or directly (then call :meth:`normalised` and
    :func:`vfs.database.validate_database`).

    Attributes
    ----------
    cases : pandas.DataFrame
        One row per case (``case_id``, ``accident_type``, ``road_friction`` [-],
        ``road_surface``, ``road_curvature`` [1/m], ``weight`` [-],
        ``collision``, ``description``).
    participants : pandas.DataFrame
        One row per vehicle (``case_id``, ``participant`` in {1, 2} and the
        :class:`vfs.physics.vehicle.VehicleParams` fields in SI units).
    trajectories : pandas.DataFrame
        Pre-crash samples (``case_id``, ``participant``, ``t`` [s], ``x``,
        ``y`` [m], ``yaw`` [rad], ``speed`` [m/s], ``accel`` [m/s^2]).
    reconstruction : pandas.DataFrame
        The expert's reconstruction, one row per colliding case, SI units
        (PDOF and change of velocity angle in rad, although the files store
        them in degrees: :mod:`vfs.database.io` converts on reading and
        writing).
    meta : dict
        Contents of ``meta.json`` (``schema_version``, ``name``,
        ``created_by``, ``description``, optional ``has_reconstruction``).
    """

    cases: pd.DataFrame
    participants: pd.DataFrame
    trajectories: pd.DataFrame
    reconstruction: pd.DataFrame
    meta: dict[str, object] = field(default_factory=default_meta)

    # ------------------------------------------------------------------ tables

    def tables(self) -> dict[str, pd.DataFrame]:
        """The four tables by name, in schema order."""
        return {name: getattr(self, name) for name in TABLE_NAMES}

    def normalised(self) -> Database:
        """Copy with schema dtypes, defaults and column order (see :func:`normalise_table`)."""
        from vfs.database.metadata import with_units

        # units and descriptions (SI, as in memory) in each frame's attrs
        frames = {name: with_units(normalise_table(df, name), name)
                  for name, df in self.tables().items()}
        return Database(**frames, meta=dict(self.meta))

    @property
    def case_ids(self) -> np.ndarray:
        """Case identifiers in the order of the cases table, shape (n_cases,)."""
        return self.cases["case_id"].to_numpy()

    @property
    def n_cases(self) -> int:
        """Number of cases."""
        return len(self.cases)

    @property
    def has_reconstruction(self) -> bool:
        """False if ``meta["has_reconstruction"]`` says the database has no reconstruction."""
        return self.meta.get("has_reconstruction", True) is not False

    # ------------------------------------------------------------ convenience

    def vehicles(
        self, yaw_inertia_formula: str = DEFAULT_YAW_INERTIA_FORMULA
    ) -> tuple[VehicleArrays, VehicleArrays]:
        """Vehicle parameters of participants 1 and 2, aligned with :attr:`case_ids`.

        Parameters
        ----------
        yaw_inertia_formula : str
            Formula (key of :data:`vfs.physics.vehicle.YAW_INERTIA_FORMULAS`) used where
            ``yaw_inertia`` is NaN (unknown).

        Returns
        -------
        tuple of VehicleArrays
            ``(vehicles_1, vehicles_2)``, each of length :attr:`n_cases`, SI units.

        Raises
        ------
        DataError
            If a case lacks participant 1 or 2.
        """
        ids = self.case_ids
        result: list[VehicleArrays] = []
        problems: list[DataProblem] = []
        for number in (1, 2):
            rows = self.participants[self.participants["participant"] == number]
            rows = rows.drop_duplicates("case_id").set_index("case_id")
            missing = ~np.isin(ids, rows.index.to_numpy())
            problems += [
                DataProblem("participants", "participant", None, python_scalar(cid),
                            f"case has no participant {number}")
                for cid in ids[missing]
            ]
            if missing.any():
                continue
            rows = rows.reindex(ids)
            result.append(vehicle_arrays(
                mass=rows["mass"], length=rows["length"], width=rows["width"],
                wheelbase=rows["wheelbase"], cg_to_front_axle=rows["cg_to_front_axle"],
                front_overhang=rows["front_overhang"], track_width=rows["track_width"],
                cg_height=rows["cg_height"], yaw_inertia=rows["yaw_inertia"],
                yaw_inertia_formula=yaw_inertia_formula,
            ))
        if problems:
            raise DataError(problems)
        return result[0], result[1]

    @cached_property
    def _trajectory_rows(self) -> dict[tuple[object, object], np.ndarray]:
        """Row positions of each (case_id, participant) trajectory, in table order."""
        if self.trajectories.empty:
            return {}
        groups = self.trajectories.groupby(["case_id", "participant"], sort=False).indices
        return {(python_scalar(c), python_scalar(p)): rows for (c, p), rows in groups.items()}

    def trajectory(self, case_id: object, participant: int) -> pd.DataFrame:
        """Trajectory samples of one participant of one case.

        Parameters
        ----------
        case_id : int
            Case identifier.
        participant : int
            1 or 2.

        Returns
        -------
        pandas.DataFrame
            Rows of :attr:`trajectories` (``t`` [s], ``x``, ``y`` [m], ``yaw``
            [rad], ``speed`` [m/s], ``accel`` [m/s^2]) with a fresh index.

        Raises
        ------
        DataError
            If there is no such trajectory.
        """
        rows = self._trajectory_rows.get((python_scalar(case_id), python_scalar(participant)))
        if rows is None:
            raise DataError(DataProblem(
                "trajectories", "participant", None, python_scalar(case_id),
                f"no trajectory for participant {participant!r}",
            ))
        return self.trajectories.iloc[rows].reset_index(drop=True)

    def subset(self, case_ids: Iterable[object]) -> Database:
        """Database restricted to the given cases (rows keep their table order).

        Parameters
        ----------
        case_ids : iterable
            Case identifiers (list or array); each must exist in :attr:`cases`.

        Returns
        -------
        Database
            New database with the same ``meta``.

        Raises
        ------
        DataError
            If a case identifier is unknown.
        """
        wanted = np.asarray(list(case_ids))
        unknown = wanted[~np.isin(wanted, self.case_ids)] if wanted.size else wanted
        if unknown.size:
            raise DataError([
                DataProblem("cases", "case_id", None, python_scalar(cid), "unknown case_id")
                for cid in unknown
            ])
        frames = {
            name: df[df["case_id"].isin(wanted)].reset_index(drop=True)
            if "case_id" in df.columns else df.iloc[0:0]
            for name, df in self.tables().items()
        }
        return dataclasses.replace(self, **frames, meta=dict(self.meta))

    def __repr__(self) -> str:
        return (
            f"Database(name={self.meta.get('name', '')!r}, n_cases={self.n_cases}, "
            f"participants={len(self.participants)}, "
            f"trajectory_samples={len(self.trajectories)}, "
            f"reconstructions={len(self.reconstruction)})"
        )


def python_scalar(value: object) -> object:
    """Numpy scalar -> Python scalar (for readable messages and dict keys)."""
    return value.item() if isinstance(value, np.generic) else value
