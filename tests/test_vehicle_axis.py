"""One way to say which vehicle: the (N, 2) vehicle axis of the impact and run-out records.

The records from the impact result to the run-out carry a per-vehicle value as one array
whose axis 1 is the vehicle (vehicle 1 at index 0).  The names of the former
one-array-per-vehicle records (``delta_v1``, ``dvx2``, ...) survive only as read-only,
deprecated aliases for plugins (docs/effects.md); vfs itself must not read them.
"""

from __future__ import annotations

import ast
from pathlib import Path

import numpy as np
import pytest

from vfs.effects.base import VelocityChange
from vfs.errors import ParameterError
from vfs.physics.impact import CONFIG_COLUMNS, ImpactConfig, ImpactResult, solve_impact

PACKAGE = Path(__file__).resolve().parents[1] / "vfs"

#: Records with deprecated per-vehicle aliases.
RECORDS = (ImpactConfig, ImpactResult, VelocityChange)

#: Aliases that are also the fields of other vfs records (the scene pairs of
#: vfs.scenarios.placement carry ``yaw1``, ``yaw2``): a read cannot be told apart by name.
SHARED_NAMES = frozenset({"yaw1", "yaw2"})


def deprecated_aliases(cls: type) -> dict[str, tuple[str, int]]:
    """Alias name -> (field, vehicle index) of a record's deprecated aliases."""
    out = {}
    for name, value in vars(cls).items():
        if isinstance(value, property) and getattr(value.fget, "vehicle_alias", None):
            out[name] = value.fget.vehicle_alias
    return out


def alias_reads(source: str, names: set[str]) -> list[tuple[int, str]]:
    """(line, name) of every attribute read ``x.<name>`` and ``getattr(x, "<name>")``."""
    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Attribute) and node.attr in names:
            found.append((node.lineno, node.attr))
        elif (isinstance(node, ast.Call) and isinstance(node.func, ast.Name)
              and node.func.id == "getattr" and len(node.args) >= 2
              and isinstance(node.args[1], ast.Constant) and node.args[1].value in names):
            found.append((node.lineno, node.args[1].value))
    return found


def all_aliases() -> set[str]:
    return {name for cls in RECORDS for name in deprecated_aliases(cls)}


def test_every_record_has_its_aliases():
    assert set(deprecated_aliases(ImpactResult)) >= {"delta_v1", "ees2", "vx1_post",
                                                     "pdof_clock2"}
    assert set(deprecated_aliases(VelocityChange)) == {"dvx1", "dvy1", "dw1", "dvx2", "dvy2",
                                                       "dw2"}
    assert set(deprecated_aliases(ImpactConfig)) == set(CONFIG_COLUMNS) - set(
        ImpactConfig._fields)
    for cls in RECORDS:
        for alias, (field, j) in deprecated_aliases(cls).items():
            assert field in cls._fields and j in (0, 1), alias


def test_vfs_reads_no_deprecated_alias():
    names = all_aliases() - SHARED_NAMES
    offenders = []
    for path in sorted(PACKAGE.rglob("*.py")):
        for line, name in alias_reads(path.read_text(encoding="utf-8"), names):
            offenders.append(f"{path.relative_to(PACKAGE.parent)}:{line}: .{name}")
    assert not offenders, "vfs reads deprecated per-vehicle aliases:\n" + "\n".join(offenders)


def test_alias_check_can_fail():
    names = all_aliases()
    src = ("def f(result, change):\n"
           "    a = result.delta_v1 + change.dvx2\n"
           "    return a + getattr(result, 'ees1') + result.delta_v[:, 0]\n")
    assert sorted(alias_reads(src, names)) == [(2, "delta_v1"), (2, "dvx2"), (3, "ees1")]


def _config() -> ImpactConfig:
    """Two impacts given by table columns."""
    return ImpactConfig.from_columns(
        m1=[1500.0, 1200.0], izz1=2700.0, x1=0.0, y1=0.0, yaw1=0.0, vx1=[15.0, 8.0], vy1=0.0,
        yaw_rate1=0.0, m2=1000.0, izz2=1800.0, x2=4.2, y2=[0.9, -0.5], yaw2=np.pi,
        vx2=-10.0, vy2=0.0, yaw_rate2=0.0, poi_x=2.1, poi_y=0.3, cp_angle=np.pi / 2,
        restitution=0.1, contact_friction=0.6)


def _result() -> ImpactResult:
    return solve_impact(_config())


def test_config_from_arrays_equals_from_columns():
    """Per-vehicle fields as pairs or (N, 2), broadcast like the columns."""
    c = _config()
    d = ImpactConfig.from_arrays(
        m=[[1500.0, 1000.0], [1200.0, 1000.0]], izz=[2700.0, 1800.0], x=[0.0, 4.2],
        y=[[0.0, 0.9], [0.0, -0.5]], yaw=[0.0, np.pi], vx=[[15.0, -10.0], [8.0, -10.0]],
        vy=0.0, yaw_rate=0.0, poi_x=2.1, poi_y=0.3, cp_angle=np.pi / 2, restitution=0.1,
        contact_friction=0.6)
    for a, b in zip(c, d, strict=True):
        np.testing.assert_array_equal(a, b)
    assert c.m.shape == (2, 2) and c.poi_x.shape == (2,) and c.size == 2
    cols = c.columns()
    assert list(cols) == list(CONFIG_COLUMNS)
    np.testing.assert_array_equal(cols["y2"], [0.9, -0.5])
    np.testing.assert_array_equal(c.swapped().m, c.m[:, ::-1])
    with pytest.raises(ParameterError, match="from_columns"):
        ImpactConfig.from_arrays(**cols)
    with pytest.raises(ParameterError, match="per-vehicle"):
        ImpactConfig.from_arrays(**{**c._asdict(), "m": np.ones(3)})


@pytest.mark.parametrize("cls", RECORDS)
def test_aliases_warn_and_return_the_vehicle_column(cls):
    record = {ImpactResult: _result, ImpactConfig: _config}.get(cls, lambda: VelocityChange(
        *(np.arange(6.0).reshape(3, 2) + k for k in range(3))))()
    for alias, (field, j) in deprecated_aliases(cls).items():
        with pytest.warns(DeprecationWarning, match=f"{alias} is deprecated"):
            value = getattr(record, alias)
        np.testing.assert_array_equal(value, getattr(record, field)[:, j])
        with pytest.raises(AttributeError):
            setattr(record, alias, value)


def test_columns_are_the_table_names():
    """columns(): every per-vehicle field as two columns ``<name><i>``, vehicle 1 first."""
    r = _result()
    cols = r.columns()
    np.testing.assert_array_equal(cols["delta_v2"], r.delta_v[:, 1])
    np.testing.assert_array_equal(cols["yaw_rate1_post"], r.yaw_rate_post[:, 0])
    np.testing.assert_array_equal(cols["energy_loss"], r.energy_loss)
    per_vehicle = [f for f in r._fields if getattr(r, f).ndim == 2]
    assert len(cols) == len(r._fields) + len(per_vehicle)
    assert set(deprecated_aliases(ImpactResult)) == set(cols) - set(r._fields)
