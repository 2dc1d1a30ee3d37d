"""PreCrash-Matrix (PCM) CSV folders: import into and export from a vfs database.

A GIDAS PCM export holds, among others, the tables ``participant_data`` (one
row per participant: FALL = case number, BETNR = participant number, vehicle
dimensions and inertia), ``dynamics`` (one row per participant and time
step: STEP, XPOS, YPOS, VX, VY, AX, PSI) and ``global_data`` (one row per
case).  Here each table is a CSV file ``<table>.csv`` in one folder.

The column meanings follow the way Eclipse openPASS reads PCM databases
(``DatabaseReaderPcm.cpp``, ``pcm_participantData.h``, ``pcm_trajectory.cpp``
and ``ConfigGeneratorPcm.cpp`` of its PCM GUI plugin): DISTCGFA is the
distance from the CG to the front axle, CGFRONT from the CG to the front of
the vehicle; STEP is time in seconds (openPASS stores ``round(STEP * 1000)``
ms); VX/VY are the longitudinal/lateral velocity in the vehicle frame
(openPASS integrates ``x += (u cos psi - v sin psi) dt``); PSI is in radians;
XPOS/YPOS are the CG in the global frame (openPASS shifts them by
WHEELBASE - DISTCGFA along PSI to reach its rear-axle reference point).  All
values are SI, no unit conversion is needed.  :data:`PCM_COLUMNS` is the
mapping, as data; ``docs/data-format.md`` renders it.

PCM has no expert reconstruction: an imported database has an empty
reconstruction table and ``meta["has_reconstruction"] = False``.  Columns
vfs needs but PCM lacks get the defaults of :class:`PcmDefaults`; the
importer lists which it used in ``meta["pcm_import"]``.
"""

from __future__ import annotations

import dataclasses
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from vfs.database.database import Database, default_meta, python_scalar
from vfs.database.io import check_before_write, write_folder_atomically
from vfs.database.schema import TABLE_NAMES, empty_table, normalise_table
from vfs.database.validation import check_values
from vfs.errors import DataError, DataProblem, ParameterError
from vfs.physics.vehicle import VehicleParams

PARTICIPANT_DATA = "participant_data"
DYNAMICS = "dynamics"
GLOBAL_DATA = "global_data"

#: PCM participant type codes (TYPEPCM), as in openPASS's ``AgentVehicleType``.
PCM_VEHICLE_TYPES: dict[int, str] = {
    0: "car", 1: "pedestrian", 2: "motorbike", 3: "bicycle", 4: "truck",
}
#: TYPEPCM written for a vehicle class not in :data:`PCM_VEHICLE_TYPES`.
PCM_UNKNOWN_TYPE = -1


@dataclass(frozen=True)
class PcmDefaults:
    """Values used where a PCM export lacks what vfs needs (one place for each default).

    Attributes
    ----------
    accident_type : int
        Accident type when global_data has no UTYP: 799, "other accident"
        (type 7) of the German/Austrian catalogue.
    road_friction : float
        Tyre-road friction [-] when participant_data has no MUE (dry asphalt;
        openPASS's PCM 5.0 reader falls back to 0.9).
    road_surface : str
        Road surface when global_data has no VFS_ROAD_SURFACE.
    road_curvature : float
        Road curvature [1/m] when global_data has no VFS_ROAD_CURVATURE (straight).
    weight : float
        Case weight [-] when global_data has no VFS_WEIGHT.
    collision : bool
        Collision flag when global_data has no VFS_COLLISION.
    vehicle_class : str
        Vehicle class when participant_data has no TYPEPCM.
    cg_height : float
        CG height [m] when HEIGHTCG is missing (default of :class:`VehicleParams`).
    track_width : float
        Track width [m] when TRACKWIDTH is missing, limited to the vehicle width
        (default of :class:`VehicleParams`).
    front_overhang_share : float
        Share of the overhangs (LENGTH - WHEELBASE) put in front of the front
        axle when CGFRONT is missing [-].
    """

    accident_type: int = 799
    road_friction: float = 0.8
    road_surface: str = "dry"
    road_curvature: float = 0.0
    weight: float = 1.0
    collision: bool = True
    vehicle_class: str = "car"
    cg_height: float = VehicleParams.cg_height
    track_width: float = VehicleParams.track_width
    front_overhang_share: float = 0.5

    def __post_init__(self) -> None:
        values = dataclasses.asdict(self)
        problems = check_values("cases", values) + check_values("participants", values)
        messages = [p.message for p in problems]
        if not 0.0 <= self.front_overhang_share <= 1.0:
            messages.append(f"front_overhang_share={self.front_overhang_share:g} outside [0, 1]")
        if messages:
            raise ParameterError("invalid PcmDefaults: " + "; ".join(messages))


@dataclass(frozen=True)
class PcmColumn:
    """How one PCM column maps to vfs.

    Attributes
    ----------
    table : str
        PCM table (``participant_data``, ``dynamics``, ``global_data``).
    column : str
        PCM column name (upper case).
    unit : str
        Unit of the PCM values.
    vfs : str
        vfs column(s) (``table.column``), or ``"-"`` if not used.
    meaning : str
        Meaning and conversion.
    if_absent : str
        What the importer does when the column is absent or empty; a
        template formatted with the :class:`PcmDefaults` in use as ``d``.
        ``"required"`` for mandatory columns.
    """

    table: str
    column: str
    unit: str
    vfs: str
    meaning: str
    if_absent: str = "required"

    @property
    def required(self) -> bool:
        """True if the import fails without this column."""
        return self.if_absent == "required"


#: The PCM <-> vfs column mapping (rendered into docs/data-format.md).
PCM_COLUMNS: tuple[PcmColumn, ...] = (
    PcmColumn(PARTICIPANT_DATA, "FALL", "-", "*.case_id", "case number"),
    PcmColumn(PARTICIPANT_DATA, "BETNR", "-", "*.participant",
              "participant number; the two participants of a case become 1 and 2 in "
              "ascending BETNR order (cases without exactly two are skipped)"),
    PcmColumn(PARTICIPANT_DATA, "TYPEPCM", "-", "participants.vehicle_class",
              "0 car, 1 pedestrian, 2 motorbike, 3 bicycle, 4 truck (openPASS "
              f"AgentVehicleType); export writes {PCM_UNKNOWN_TYPE} for other classes",
              "{d.vehicle_class!r}"),
    PcmColumn(PARTICIPANT_DATA, "WIDTH", "m", "participants.width", "vehicle width"),
    PcmColumn(PARTICIPANT_DATA, "LENGTH", "m", "participants.length", "vehicle length"),
    PcmColumn(PARTICIPANT_DATA, "DISTCGFA", "m", "participants.cg_to_front_axle",
              "distance CG to front axle (not to the bumper)"),
    PcmColumn(PARTICIPANT_DATA, "WEIGHT", "kg", "participants.mass", "vehicle mass"),
    PcmColumn(PARTICIPANT_DATA, "HEIGHTCG", "m", "participants.cg_height",
              "CG height above ground", "{d.cg_height:g} m"),
    PcmColumn(PARTICIPANT_DATA, "WHEELBASE", "m", "participants.wheelbase", "wheelbase"),
    PcmColumn(PARTICIPANT_DATA, "IZZ", "kg m^2", "participants.yaw_inertia",
              "yaw moment of inertia; values <= 0 count as unknown",
              "NaN (vfs.physics.vehicle default formula)"),
    PcmColumn(PARTICIPANT_DATA, "MUE", "-", "cases.road_friction",
              "tyre-road friction of the participant; the case value is the mean of "
              "its two participants; export writes the case value for both",
              "{d.road_friction:g}"),
    PcmColumn(PARTICIPANT_DATA, "TRACKWIDTH", "m", "participants.track_width", "track width",
              "min({d.track_width:g} m, WIDTH)"),
    PcmColumn(PARTICIPANT_DATA, "CGFRONT", "m", "participants.front_overhang",
              "distance CG to the front of the vehicle; front_overhang = CGFRONT - "
              "DISTCGFA", "{d.front_overhang_share:g} x (LENGTH - WHEELBASE)"),
    PcmColumn(PARTICIPANT_DATA, "IXX, IYY, HEIGHT", "", "-",
              "roll/pitch inertia and vehicle height: not used, not written", "ignored"),
    PcmColumn(DYNAMICS, "FALL, BETNR", "-", "trajectories.case_id, participant",
              "as in participant_data"),
    PcmColumn(DYNAMICS, "STEP", "s", "trajectories.t",
              "time of the sample in seconds (openPASS: round(STEP x 1000) ms); rows are "
              "sorted by STEP within each participant"),
    PcmColumn(DYNAMICS, "XPOS, YPOS", "m", "trajectories.x, y", "CG position, global frame"),
    PcmColumn(DYNAMICS, "PSI", "rad", "trajectories.yaw", "yaw angle, global frame"),
    PcmColumn(DYNAMICS, "VX", "m/s", "trajectories.speed",
              "longitudinal velocity u in the vehicle frame; speed = sqrt(VX^2 + VY^2) "
              "(sign and side slip are lost); export writes VX = speed"),
    PcmColumn(DYNAMICS, "VY", "m/s", "trajectories.speed",
              "lateral velocity v in the vehicle frame; export writes 0", "0 (speed = |VX|)"),
    PcmColumn(DYNAMICS, "AX", "m/s^2", "trajectories.accel", "longitudinal acceleration",
              "NaN (unknown)"),
    PcmColumn(DYNAMICS, "AY", "m/s^2", "-", "lateral acceleration: not used, not written",
              "ignored"),
    PcmColumn(GLOBAL_DATA, "FALL", "-", "cases.case_id", "case number",
              "file optional: all case defaults"),
    PcmColumn(GLOBAL_DATA, "UTYP", "-", "cases.accident_type",
              "3-digit accident type (assumed GIDAS column name)", "{d.accident_type}"),
    PcmColumn(GLOBAL_DATA, "OFFSETX, OFFSETY", "m", "-",
              "offset of the PCM coordinate system: not applied; export writes 0", "ignored"),
    PcmColumn(GLOBAL_DATA, "PARTICIP", "-", "-",
              "number of participants: not used (counted from participant_data); export "
              "writes 2", "ignored"),
    PcmColumn(GLOBAL_DATA, "VFS_ROAD_SURFACE", "", "cases.road_surface",
              "vfs extension (not GIDAS)", "{d.road_surface!r}"),
    PcmColumn(GLOBAL_DATA, "VFS_ROAD_CURVATURE", "1/m", "cases.road_curvature",
              "vfs extension (not GIDAS)", "{d.road_curvature:g}"),
    PcmColumn(GLOBAL_DATA, "VFS_WEIGHT", "-", "cases.weight", "vfs extension (not GIDAS)",
              "{d.weight:g}"),
    PcmColumn(GLOBAL_DATA, "VFS_COLLISION", "", "cases.collision",
              "vfs extension (not GIDAS)", "{d.collision}"),
    PcmColumn(GLOBAL_DATA, "VFS_DESCRIPTION", "", "cases.description",
              "vfs extension (not GIDAS)", "''"),
)


def pcm_mapping_markdown(defaults: PcmDefaults | None = None) -> str:
    """Render :data:`PCM_COLUMNS` as a Markdown table.

    Parameters
    ----------
    defaults : PcmDefaults, optional
        Defaults to show in the "if absent" column; default ``PcmDefaults()``.

    Returns
    -------
    str
        Markdown table (ends with a newline).
    """
    d = PcmDefaults() if defaults is None else defaults
    lines = ["| PCM table | PCM column | unit | vfs column | meaning and conversion | "
             "if absent |", "|---|---|---|---|---|---|"]
    for c in PCM_COLUMNS:
        lines.append(f"| {c.table} | {c.column} | {c.unit} | {c.vfs} | {c.meaning} | "
                     f"{c.if_absent.format(d=d)} |")
    return "\n".join(lines) + "\n"


# ----------------------------------------------------------------------------
# Import
# ----------------------------------------------------------------------------


def _find_file(folder: Path, table: str) -> Path | None:
    for path in sorted(folder.iterdir()):
        if path.is_file() and path.name.lower() == f"{table}.csv":
            return path
    return None


def read_pcm_table(file: Path) -> pd.DataFrame:
    """Read one PCM CSV table (``,`` or ``;`` separated); column names upper-cased.

    Parameters
    ----------
    file : Path
        CSV file with a header line.

    Returns
    -------
    pandas.DataFrame
    """
    with file.open(encoding="utf-8", errors="replace") as handle:
        header = handle.readline()
    sep = ";" if header.count(";") > header.count(",") else ","
    df = pd.read_csv(file, sep=sep, encoding_errors="replace")
    df.columns = [str(c).strip().upper() for c in df.columns]
    return df


def _required_columns(table: str) -> list[str]:
    names: list[str] = []
    for c in PCM_COLUMNS:
        if c.table == table and c.required:
            names += [n.strip() for n in c.column.split(",")]
    return names


def _to_numeric(
    df: pd.DataFrame, table: str, columns: list[str], problems: list[DataProblem]
) -> pd.DataFrame:
    """Columns converted to float; non-numeric entries reported as problems."""
    out = df.copy()
    for name in columns:
        if name not in out.columns:
            continue
        values = pd.to_numeric(out[name], errors="coerce")
        bad = np.flatnonzero((values.isna() & out[name].notna()).to_numpy())
        for pos in bad[:20]:
            case_id = python_scalar(out["FALL"].iat[pos]) if "FALL" in out else None
            problems.append(DataProblem(table, name, int(pos), case_id,
                                        f"value {out[name].iat[pos]!r} is not a number"))
        out[name] = values.astype(float)
    return out


class _DefaultsLog:
    """Which defaults the import used, for ``meta["pcm_import"]["defaults_used"]``."""

    def __init__(self) -> None:
        self.used: dict[str, str] = {}

    def fill(self, column: str, values: pd.Series, default: object, reason: str) -> pd.Series:
        missing = values.isna()
        if missing.any():
            self.used[column] = (f"{int(missing.sum())} of {len(values)} rows: {reason} -> "
                                 f"{default!r}")
            values = values.astype(object).where(~missing, default)
        return values


def _column(df: pd.DataFrame, name: str) -> pd.Series:
    """Column ``name`` or an all-NaN column if absent."""
    if name in df.columns:
        return df[name].reset_index(drop=True)
    return pd.Series(np.nan, index=range(len(df)), dtype=float)


def import_pcm(
    folder: str | os.PathLike[str], *, defaults: PcmDefaults | None = None,
    validate: bool = True, name: str | None = None,
) -> Database:
    """Import a PreCrash-Matrix CSV folder (participant_data, dynamics, global_data).

    Parameters
    ----------
    folder : path
        Folder with ``participant_data.csv`` and ``dynamics.csv`` (required)
        and ``global_data.csv`` (optional); file names are case-insensitive,
        separator ``,`` or ``;``, decimal point ``.``.
    defaults : PcmDefaults, optional
        Values for what PCM lacks; default ``PcmDefaults()``.
    validate : bool
        Validate the result and raise :class:`DataError` listing every problem.
    name : str, optional
        ``meta["name"]``; default the folder name.

    Returns
    -------
    Database
        Cases, participants and trajectories; empty reconstruction;
        ``meta["has_reconstruction"] = False``; ``meta["pcm_import"]`` lists
        ``defaults_used`` (vfs column -> how many rows and which value),
        ``skipped_cases`` (not exactly two participants), ``renumbered_cases``
        (BETNR not 1 and 2) and ``dropped_dynamics_rows``.

    Raises
    ------
    DataError
        Missing files or columns, non-numeric values, or (with ``validate``)
        a database violating the schema.
    """
    d = PcmDefaults() if defaults is None else defaults
    src = Path(folder)
    problems: list[DataProblem] = []
    if not src.is_dir():
        raise DataError(DataProblem(PARTICIPANT_DATA, "", None, None,
                                    f"PCM folder {src} does not exist"))
    frames: dict[str, pd.DataFrame] = {}
    for table in (PARTICIPANT_DATA, DYNAMICS, GLOBAL_DATA):
        file = _find_file(src, table)
        if file is None:
            if table != GLOBAL_DATA:
                problems.append(DataProblem(table, "", None, None,
                                            f"file {table}.csv missing in {src}"))
            continue
        df = read_pcm_table(file)
        for col in _required_columns(table):
            if col not in df.columns:
                problems.append(DataProblem(table, col, None, None, "required PCM column "
                                                                    "missing"))
        text_columns = {"VFS_ROAD_SURFACE", "VFS_DESCRIPTION", "VFS_COLLISION"}
        frames[table] = _to_numeric(df, table, [c for c in df.columns
                                                if c not in text_columns], problems)
    if problems:
        raise DataError(problems, header=f"cannot import PCM folder {src}:")
    log = _DefaultsLog()
    part, dyn = frames[PARTICIPANT_DATA], frames[DYNAMICS]
    glob = frames.get(GLOBAL_DATA, pd.DataFrame({"FALL": pd.Series([], dtype=float)}))

    # participants: exactly two per case, numbered 1, 2 by ascending BETNR
    part = part.dropna(subset=["FALL", "BETNR"])
    rows_per_case = part.groupby("FALL", sort=False)["BETNR"].agg(["size", "nunique"])
    good = rows_per_case.index[(rows_per_case["size"] == 2) & (rows_per_case["nunique"] == 2)]
    dyn_cases = pd.Index(dyn["FALL"].dropna().unique())
    skipped = sorted({int(c) for c in rows_per_case.index.difference(good)}
                     | {int(c) for c in dyn_cases.difference(rows_per_case.index)})
    part = part[part["FALL"].isin(good)].reset_index(drop=True)
    part["participant"] = part.groupby("FALL")["BETNR"].rank(method="dense").astype(np.int64)
    renumbered = sorted({int(c) for c in part.loc[part["BETNR"] != part["participant"], "FALL"]})

    length, wheelbase = _column(part, "LENGTH"), _column(part, "WHEELBASE")
    cg_to_front_axle, width = _column(part, "DISTCGFA"), _column(part, "WIDTH")
    izz = _column(part, "IZZ")
    type_codes = _column(part, "TYPEPCM")
    vehicle_class = type_codes.map(
        lambda code: np.nan if pd.isna(code) else PCM_VEHICLE_TYPES.get(int(code),
                                                                         f"pcm type {code:g}"))
    participants = pd.DataFrame({
        "case_id": part["FALL"].astype(np.int64),
        "participant": part["participant"],
        "mass": _column(part, "WEIGHT"),
        "yaw_inertia": izz.where(izz > 0),
        "length": length,
        "width": width,
        "wheelbase": wheelbase,
        "cg_to_front_axle": cg_to_front_axle,
        "front_overhang": _column(part, "CGFRONT") - cg_to_front_axle,
        "track_width": _column(part, "TRACKWIDTH"),
        "cg_height": log.fill("participants.cg_height", _column(part, "HEIGHTCG"),
                              d.cg_height, "HEIGHTCG missing"),
        "vehicle_class": log.fill("participants.vehicle_class", vehicle_class,
                                  d.vehicle_class, "TYPEPCM missing"),
    })
    if participants["yaw_inertia"].isna().any():
        n = int(participants["yaw_inertia"].isna().sum())
        log.used["participants.yaw_inertia"] = (
            f"{n} of {len(participants)} rows: IZZ missing or <= 0 -> NaN (default formula "
            "of vfs.physics.vehicle)")
    overhang_default = d.front_overhang_share * (length - wheelbase)
    missing_overhang = participants["front_overhang"].isna()
    if missing_overhang.any():
        log.used["participants.front_overhang"] = (
            f"{int(missing_overhang.sum())} of {len(participants)} rows: CGFRONT missing -> "
            f"{d.front_overhang_share:g} x (LENGTH - WHEELBASE)")
        participants["front_overhang"] = participants["front_overhang"].fillna(overhang_default)
    missing_track = participants["track_width"].isna()
    if missing_track.any():
        log.used["participants.track_width"] = (
            f"{int(missing_track.sum())} of {len(participants)} rows: TRACKWIDTH missing -> "
            f"min({d.track_width:g}, WIDTH)")
        participants["track_width"] = participants["track_width"].fillna(
            np.minimum(d.track_width, width))

    # trajectories
    mapping = part[["FALL", "BETNR", "participant"]]
    merged = dyn.merge(mapping, on=["FALL", "BETNR"], how="inner")
    dropped = len(dyn) - len(merged)
    merged = merged.sort_values(["FALL", "participant", "STEP"], kind="mergesort")
    merged = merged.reset_index(drop=True)
    vx = _column(merged, "VX")
    if "VY" not in merged.columns:
        log.used["trajectories.speed"] = "VY missing -> speed = |VX|"
    vy = _column(merged, "VY").fillna(0.0)
    accel = _column(merged, "AX")
    if accel.isna().any():
        log.used["trajectories.accel"] = (f"{int(accel.isna().sum())} of {len(accel)} rows: "
                                          "AX missing -> NaN (unknown)")
    trajectories = pd.DataFrame({
        "case_id": merged["FALL"].astype(np.int64),
        "participant": merged["participant"],
        "t": merged["STEP"],
        "x": merged["XPOS"],
        "y": merged["YPOS"],
        "yaw": merged["PSI"],
        "speed": np.hypot(vx, vy),
        "accel": accel,
    })

    # cases
    case_ids = pd.unique(participants["case_id"])
    glob = glob.dropna(subset=["FALL"]).drop_duplicates("FALL").set_index("FALL")
    glob.index = glob.index.astype(np.int64)

    def case_column(pcm: str, vfs: str, default: object) -> pd.Series:
        values = (glob[pcm].reindex(case_ids) if pcm in glob.columns
                  else pd.Series(np.nan, index=case_ids, dtype=float))
        return log.fill(f"cases.{vfs}", values.reset_index(drop=True), default,
                        f"global_data.{pcm} missing")

    friction = (part.assign(case_id=participants["case_id"]).groupby("case_id", sort=False)
                ["MUE"].mean().reindex(case_ids) if "MUE" in part.columns
                else pd.Series(np.nan, index=case_ids, dtype=float))
    cases = pd.DataFrame({
        "case_id": case_ids,
        "accident_type": case_column("UTYP", "accident_type", d.accident_type),
        "road_friction": log.fill("cases.road_friction", friction.reset_index(drop=True),
                                  d.road_friction, "participant_data.MUE missing"),
        "road_surface": case_column("VFS_ROAD_SURFACE", "road_surface", d.road_surface),
        "road_curvature": case_column("VFS_ROAD_CURVATURE", "road_curvature",
                                      d.road_curvature),
        "weight": case_column("VFS_WEIGHT", "weight", d.weight),
        "collision": case_column("VFS_COLLISION", "collision", d.collision),
        "description": (glob["VFS_DESCRIPTION"].reindex(case_ids).reset_index(drop=True)
                        if "VFS_DESCRIPTION" in glob.columns else ""),
    })

    meta = default_meta(
        name=src.name if name is None else name, created_by="vfs.database.import_pcm",
        description=f"imported from the PreCrash-Matrix CSV folder {src.name}",
    )
    meta["has_reconstruction"] = False
    meta["pcm_import"] = {
        "defaults_used": dict(sorted(log.used.items())),
        "skipped_cases": skipped,
        "renumbered_cases": renumbered,
        "dropped_dynamics_rows": int(dropped),
    }
    frames_out = {"cases": cases, "participants": participants,
                  "trajectories": trajectories, "reconstruction": empty_table("reconstruction")}
    db = Database(**{n: normalise_table(frames_out[n], n) for n in TABLE_NAMES}, meta=meta)
    if validate:
        from vfs.database.checks import check_database, settle

        checked = check_database(db)
        settle(checked.errors, checked.warnings,
               header=f"PCM import of {src}: {len(checked.errors)} problem(s):")
    return db


# ----------------------------------------------------------------------------
# Export
# ----------------------------------------------------------------------------


def export_pcm(
    db: Database, folder: str | os.PathLike[str], *, validate: bool = True
) -> Path:
    """Write a database as a PreCrash-Matrix CSV folder (atomically).

    Writes ``participant_data.csv``, ``dynamics.csv`` and ``global_data.csv``
    as described by :data:`PCM_COLUMNS`.  The reconstruction table has no PCM
    equivalent and is not written; ``yaw_inertia`` NaN and ``accel`` NaN are
    written as empty fields.

    Parameters
    ----------
    db : Database
        The database.
    folder : path
        Target folder; an existing PCM folder there is replaced.
    validate : bool
        Refuse to write an invalid database.

    Returns
    -------
    Path
        The folder.
    """
    norm = check_before_write(db, validate)
    parts = norm.participants.merge(norm.cases[["case_id", "road_friction"]], on="case_id",
                                    how="left")
    codes = {name: code for code, name in PCM_VEHICLE_TYPES.items()}
    participant_data = pd.DataFrame({
        "FALL": parts["case_id"],
        "BETNR": parts["participant"],
        "TYPEPCM": parts["vehicle_class"].map(lambda c: codes.get(c, PCM_UNKNOWN_TYPE)),
        "WIDTH": parts["width"],
        "LENGTH": parts["length"],
        "DISTCGFA": parts["cg_to_front_axle"],
        "WEIGHT": parts["mass"],
        "HEIGHTCG": parts["cg_height"],
        "WHEELBASE": parts["wheelbase"],
        "IZZ": parts["yaw_inertia"],
        "MUE": parts["road_friction"],
        "TRACKWIDTH": parts["track_width"],
        "CGFRONT": parts["front_overhang"] + parts["cg_to_front_axle"],
    })
    traj = norm.trajectories
    dynamics = pd.DataFrame({
        "FALL": traj["case_id"],
        "BETNR": traj["participant"],
        "STEP": traj["t"],
        "XPOS": traj["x"],
        "YPOS": traj["y"],
        "VX": traj["speed"],
        "VY": 0.0,
        "AX": traj["accel"],
        "PSI": traj["yaw"],
    })
    cases = norm.cases
    global_data = pd.DataFrame({
        "FALL": cases["case_id"],
        "PARTICIP": 2,
        "OFFSETX": 0.0,
        "OFFSETY": 0.0,
        "UTYP": cases["accident_type"],
        "VFS_ROAD_SURFACE": cases["road_surface"],
        "VFS_ROAD_CURVATURE": cases["road_curvature"],
        "VFS_WEIGHT": cases["weight"],
        "VFS_COLLISION": cases["collision"],
        "VFS_DESCRIPTION": cases["description"],
    })

    def write(out: Path) -> None:
        for table, df in ((PARTICIPANT_DATA, participant_data), (DYNAMICS, dynamics),
                          (GLOBAL_DATA, global_data)):
            df.to_csv(out / f"{table}.csv", index=False, lineterminator="\n")

    return write_folder_atomically(folder, write, [f"{PARTICIPANT_DATA}.csv"])
