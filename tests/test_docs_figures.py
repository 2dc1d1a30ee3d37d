"""Docs that stay true: figures quoted in README and docs/ against their committed records.

Every figure the documentation quotes from a measurement must come from a record a script
wrote (``results/reference/``, ``benchmarks/results/``).  :data:`QUOTES` is the table that binds
them: a document, a regular expression whose groups are the quoted numbers, the record file and
a function that reads the same numbers from the record.  A quoted number passes when it equals
the record's value rounded to the quoted number of decimals (``18 %`` for a record of 18.1 %);
so a rerun that changes a record, or an edit that changes a quote, fails here until the two
agree again.  A pattern that no longer matches fails too: rewording a quoted figure means
updating its row.

The same module checks two lists the docs repeat from the code: the exit codes (README against
the docstring of :mod:`vfs.cli`) and the ``vfs.*`` names the docs and the unreleased changelog
mention (each must exist, outside a short list of names that are not Python objects).

``test_a_planted_stale_number_fails`` changes each quoted number of each row in a copy of its
document and checks that the comparison reports it: every row can fail.
"""

from __future__ import annotations

import importlib
import json
import re
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import pytest

from vfs.analysis.paper_reference import PAPER_TABLE1, table1_label

ROOT = Path(__file__).resolve().parents[1]
NUMBER = r"(\d[\d,]*(?:\.\d+)?)"


@dataclass(frozen=True)
class Quote:
    """Figures of one document bound to the record they come from.

    Attributes
    ----------
    doc : str
        The quoting document, relative to the repository root.
    pattern : str
        A regular expression (multiline) whose groups are the quoted numbers.
    record : str
        The committed record (one file, or several separated by ``,``).
    values : callable
        ``values(root) -> list[float]``: the record's numbers in the order of the groups.
    what : str
        What the figures are (shown when a check fails).
    """

    doc: str
    pattern: str
    record: str
    values: Callable[[Path], list[float]]
    what: str


def _md_numbers(record: str, pattern: str) -> Callable[[Path], list[float]]:
    """The groups of ``pattern`` in a Markdown/text record, as numbers."""
    def read(root: Path) -> list[float]:
        m = re.search(pattern, (root / record).read_text(encoding="utf-8"), re.M)
        if m is None:
            raise AssertionError(f"{record}: no match for {pattern!r}")
        return [float(g.replace(",", "")) for g in m.groups()]
    return read


MUTATION = ("benchmarks/results/mutation-2026-11-28-second-before.json,"
            "benchmarks/results/mutation-2026-11-28-second-after.json")


def _mutation_row(module: str) -> Callable[[Path], list[float]]:
    """Rate [%], killed, scored of the before and after records, then the equivalents."""
    def read(root: Path) -> list[float]:
        out: list[float] = []
        for record in MUTATION.split(","):
            s = json.loads((root / record).read_text())["modules"][module]["summary"]
            scored = s["mutants"] - s["equivalent"]
            out += [100.0 * s["all_rate"], s["killed_all"], scored]
        return out + [s["equivalent"]]
    return read
#: The latest mutation record of each module (docs/testing.md, third pass).
MUTATION_LATEST = {
    "vfs/physics/impact.py": "after", "vfs/physics/geometry.py": "after",
    "vfs/analysis/stats.py": "after", "vfs/analysis/euro_ncap.py": "after",
    "vfs/physics/precrash.py": "third-precrash", "vfs/physics/runout.py": "second-after",
    "vfs/effects/learned.py": "third-after",
}


def _mutation_record(module: str) -> str:
    return f"benchmarks/results/mutation-2026-11-28-{MUTATION_LATEST[module]}.json"


def _mutation_latest(module: str) -> Callable[[Path], list[float]]:
    """Rate [%], killed, scored, equivalent and surviving (with not covered) of a module's
    latest record."""
    def read(root: Path) -> list[float]:
        s = json.loads((root / _mutation_record(module)).read_text())["modules"][module][
            "summary"]
        scored = s["mutants"] - s["equivalent"]
        return [100.0 * s["all_rate"], s["killed_all"], scored, s["equivalent"],
                s["survived"] + s["not_covered"]]
    return read


IMPACT_BENCH = "benchmarks/results/core_37_impact.json"
IMPACT_BREAKDOWN = "benchmarks/results/core_37_impact_breakdown.json"
SESSION3_START = "benchmarks/results/core_37_session3_start.json"
SESSION3_END = "benchmarks/results/core_37_session3_end.json"
SESSION4_START = "benchmarks/results/core_37_session4_start.json"
SESSION4_END = "benchmarks/results/core_37_session4_end.json"
FLOOR = "benchmarks/results/core_37_floor.json"
FLOOR_BEFORE = "benchmarks/results/core_37_floor_before.json"
FLOOR_ROUNDS = "benchmarks/results/core_37_floor_rounds.json"


def _floor_kernel(record: str, run: str, kernel: str, per_unit: bool = False
                  ) -> Callable[[Path], float]:
    """CPU time [s] of one kernel of one run of a core_37_floor record, or ns per unit."""
    def read(root: Path) -> float:
        k = _json(record, root)["runs"][run]["kernels"][kernel]
        return 1e9 * k["cpu_s"] / k["units"] if per_unit else k["cpu_s"]
    return read


def _diagnose_steps(root: Path) -> list[float]:
    """Run-out CPU [s], diagnosis CPU [s], vehicle-steps, vehicles, ns per vehicle-step and
    the median steps per vehicle of core_37_diagnose_steps.txt, as quoted."""
    text = (root / "benchmarks/results/core_37_diagnose_steps.txt").read_text(encoding="utf-8")

    def grab(pattern: str) -> float:
        found = re.search(pattern, text)
        if found is None:
            raise AssertionError(f"{pattern!r} not in core_37_diagnose_steps.txt")
        return float(found.group(1).replace(",", ""))

    return [grab(r"compiled run-out: ([\d.]+) s"), grab(r"diagnosis: ([\d.]+) s CPU"),
            grab(r"vehicle-steps: ([\d,]+)"), grab(r"vehicles run out: ([\d,]+)"),
            grab(r"\((\d+) ns each\)"), grab(r"median (\d+)")]


def _floor_quotes(root: Path) -> list[float]:
    """The figures of the paragraph on what a case-run costs, in their order."""
    end = _json(FLOOR, root)
    rounds = _json(FLOOR_ROUNDS, root)
    runs = end["runs"]
    replay = runs["baseline"]["kernels"]["pre-crash replay"]
    return [*(r["simulation_cpu_s"] for r in rounds["start"]),
            *(r["simulation_cpu_s"] for r in rounds["end"]),
            end["simulation_cpu_s"], end["case_runs_per_s_simulation"], end["kernel_cpu_s"],
            _floor_kernel(FLOOR, "baseline", "pre-crash replay", True)(root),
            replay["units"] / 1e6,
            _floor_kernel(FLOOR, "three-stage", "pre-crash step", True)(root),
            _floor_kernel(FLOOR, "ideal", "pre-crash step", True)(root),
            _floor_kernel(FLOOR, "three-stage", "AEB kernels", True)(root),
            _floor_kernel(FLOOR, "ideal", "AEB kernels", True)(root),
            min(_floor_kernel(FLOOR, r, "run-out", True)(root) for r in runs),
            max(_floor_kernel(FLOOR, r, "run-out", True)(root) for r in runs),
            end["case_runs_per_s_kernels_only"]]


def _breakdown(root: Path) -> list[float]:
    """Load, kernel [ms], ns per impact, arctan2, PDOF kernel, fresh and reused arrays [ms]
    and the kernel again, as quoted."""
    b = _json(IMPACT_BREAKDOWN, root)
    ms = [1e3 * b[k] for k in ("arctan2_s", "finish_s", "fresh_result_arrays_s",
                               "reused_arrays_write_s")]
    return [b["load_average_1min"], 1e3 * b["kernel_s"], b["kernel_ns_per_impact"], *ms,
            1e3 * b["kernel_s"]]
AEB_BENCH = tuple(f"benchmarks/results/core_37_aeb_{k}.json"
                  for k in ("before", "after", "before_quick", "after_quick"))
AEB_PROFILE = "benchmarks/results/core_37_aeb_profile.txt"
STUDYIO_BENCH = tuple(f"benchmarks/results/core_37_studyio_{k}.json"
                      for k in ("before2", "after2", "before", "after"))
STUDYIO_WARMUP = tuple(f"benchmarks/results/core_37_studyio_warmup_{k}.json"
                       for k in ("before", "after"))
STUDYIO_PROFILE = "benchmarks/results/core_37_studyio_profile.txt"
STARTUP_BENCH = tuple(f"benchmarks/results/core_37_startup_{k}.json"
                      for k in ("before", "after", "before2", "after2"))
STARTUP_AB = "benchmarks/results/core_37_startup_ab.json"
STARTUP_AB_MAIN = "benchmarks/results/core_37_startup_ab_main.json"
STARTUP_PROFILE = "benchmarks/results/core_37_startup_profile.txt"


def _startup_ab(record: str, load: bool = False) -> Callable[[Path], list[float]]:
    """Medians (CPU s, case-runs/s) and the pairs of interleaved fixed-costs runs (the load
    first where quoted)."""
    def read(root: Path) -> list[float]:
        ab = _json(record, root)
        return [*([ab["load_average_1min_at_end"]] if load else []),
                ab["before_median_cpu_s"], ab["after_median_cpu_s"],
                ab["before_median_case_runs_per_s_cpu"], ab["after_median_case_runs_per_s_cpu"],
                ab["pairs_after_faster"], ab["pairs"]]
    return read


def _startup_bench(root: Path) -> list[float]:
    """The fixed-costs round's `vfs bench study` pairs and its start, as quoted."""
    before, after, before2, after2 = (_json(r, root)["study"] for r in STARTUP_BENCH)
    return [before["case_runs_per_s_cpu"], after["case_runs_per_s_cpu"], before["cpu_s"],
            after["cpu_s"], before2["case_runs_per_s_cpu"], after2["case_runs_per_s_cpu"],
            before["startup_cpu_s"], after["startup_cpu_s"]]


def _startup_part(label: str) -> Callable[[Path], list[float]]:
    """Before and after of one part in the fixed-costs profile's table."""
    return _md_numbers(STARTUP_PROFILE, rf"^# +{re.escape(label)} +([\d.]+) +([\d.]+)$")


def _studyio_study(root: Path) -> list[float]:
    """Case-runs/s, CPU s and loads of the study-loading round's records, as quoted: the
    back-to-back pair, then the round's first and last run."""
    before2, after2, before, after = (_json(r, root)["study"] for r in STUDYIO_BENCH)
    return [before2["case_runs_per_s_cpu"], after2["case_runs_per_s_cpu"], before2["cpu_s"],
            after2["cpu_s"], before2["load_average_1min"], after2["load_average_1min"],
            before["case_runs_per_s_cpu"], before["cpu_s"], before["load_average_1min"],
            after["case_runs_per_s_cpu"], after["cpu_s"], after["load_average_1min"]]


def _studyio_resume(root: Path) -> list[float]:
    before2, after2 = (_json(r, root)["study"] for r in STUDYIO_BENCH[:2])
    return [before2["resume_case_runs_per_s_cpu"], after2["resume_case_runs_per_s_cpu"],
            before2["resume_cpu_s"], after2["resume_cpu_s"]]


def _studyio_warmup(root: Path) -> list[float]:
    before, after = (_json(r, root)["warmup"] for r in STUDYIO_WARMUP)
    return [before["cold_cpu_s"], after["cold_cpu_s"], before["compile_cpu_s"],
            after["compile_cpu_s"], before["load_average_1min"], after["load_average_1min"]]


def _cumulative(record: str, function: str) -> Callable[[Path], list[float]]:
    """The cumulative time [s] of ``function`` (``file.py:line(name)`` tail) in a cProfile
    text record."""
    return _md_numbers(record, r"[\d.]+ +[\d.]+ +[\d.]+ +([\d.]+) +[\d.]+ \S+"
                       + re.escape(function).replace(r"LINE", r"\d+"))


def _aeb_study(root: Path) -> list[float]:
    """Case-runs/s, CPU s and loads of the compiled-controller records, as quoted."""
    before, after, before_quick, after_quick = (_json(r, root)["study"] for r in AEB_BENCH)
    return [before["case_runs_per_s_cpu"], after["case_runs_per_s_cpu"], before["cpu_s"],
            after["cpu_s"], before["load_average_1min"], after["load_average_1min"],
            before_quick["case_runs_per_s_cpu"], after_quick["case_runs_per_s_cpu"]]


def _json(record: str, root: Path) -> dict:
    return json.loads((root / record).read_text(encoding="utf-8"))


def _jsonl(record: str) -> list[dict]:
    return [json.loads(line) for line in (ROOT / record).read_text().splitlines() if line]


def _battery_sum(label: str, part: str) -> Callable[[Path], list[float]]:
    """A summary count of the hidden-law battery summed over its three parts."""
    files = ("battery.md", "battery_held_out.md", "battery_held_out_2.md")

    def read(root: Path) -> list[float]:
        total = [0.0, 0.0]
        for name in files:
            text = (root / "benchmarks/results/battery_400_quick" / name).read_text()
            m = re.search(rf"^- {re.escape(label)}: (\d+) of (\d+)", text, re.M)
            assert m is not None, f"{name}: no line '- {label}: ...'"
            total[0] += float(m.group(1))
            total[1] += float(m.group(2))
        return total if part == "both" else [total[0 if part == "count" else 1]]
    return read


BATTERY = "benchmarks/results/battery_400_quick/battery.md"
REPORT = "results/reference/study-default/report.md"
COVERAGE = {  # column of the table in docs/diagnosis.md, "Interval coverage" -> record, mode
    "before": ("benchmarks/results/coverage_before_100.jsonl", "before"),
    "67fc7c5": ("benchmarks/results/coverage_after_100.jsonl", "after"),
    "after": ("benchmarks/results/coverage_profile_100.jsonl", "after"),
}


def _coverage(channel: str) -> Callable[[Path], list[float]]:
    """identifiable, coverage before / 67fc7c5 / after [%] and the after count of a channel."""
    def read(root: Path) -> list[float]:
        out: list[float] = []
        for column, (record, mode) in COVERAGE.items():
            rows = [r for r in _jsonl(record) if r["channel"] == channel]
            assert len(rows) == 1, f"{record}: {len(rows)} rows of {channel}"
            covered, identifiable = rows[0][mode]
            if column == "before":
                out.append(float(identifiable))
            out.append(100.0 * covered / identifiable)
            if column == "after":
                out.append(float(covered))
        return out
    return read


def _coverage_pooled(root: Path) -> list[float]:
    out: list[float] = []
    for column, (record, mode) in COVERAGE.items():
        covered = sum(r[mode][0] for r in _jsonl(record))
        identifiable = sum(r[mode][1] for r in _jsonl(record))
        if column == "before":
            out.append(float(identifiable))
        out.append(100.0 * covered / identifiable)
        if column == "after":
            out.append(float(covered))
    return out


CHANNELS = ("restitution", "contact_friction", "poi_along", "poi_across", "cp_angle",
            "penetration_time", "ees_stiffness_ratio", "yaw_inertia_factor", "tyre_impulse",
            "runout_brake1", "runout_brake2")

RUNOUT_MICRO = "benchmarks/results/core_37_runout_micro.json"


def _bench(record: str, bench: str, *keys: str) -> Callable[[Path], list[float]]:
    """Figures of one benchmark of a ``vfs bench --json`` record; ``key*100``: in %,
    ``key*1e13``: in units of 1e-13."""
    def read(root: Path) -> list[float]:
        data = json.loads((root / record).read_text(encoding="utf-8"))[bench]
        out = []
        for key in keys:
            name, _, scale = key.partition("*")
            out.append(float(data[name]) * (float(scale) if scale else 1.0))
        return out
    return read


GYM2_BENCH = ("benchmarks/results/core_37_gym2_before.json",
              "benchmarks/results/core_37_gym2_after.json")


def _gym2_cpu(root: Path) -> list[float]:
    """Single and 32,768-env steps per CPU-second (k for the vectors), before then after,
    then the 8,192 and 1,024 envs' before -> after (k), as quoted."""
    before, after = (_json(r, root)["gym_env"] for r in GYM2_BENCH)
    return [before["single_steps_per_cpu_s"], before["vector_32768_steps_per_cpu_s"] / 1e3,
            after["single_steps_per_cpu_s"], after["vector_32768_steps_per_cpu_s"] / 1e3,
            before["vector_8192_steps_per_cpu_s"] / 1e3,
            after["vector_8192_steps_per_cpu_s"] / 1e3,
            before["vector_1024_steps_per_cpu_s"] / 1e3,
            after["vector_1024_steps_per_cpu_s"] / 1e3]


RUNOUT_STUDY = tuple(f"benchmarks/results/core_37_runout_study_{w}.json"
                     for w in ("before", "before2", "after", "after2"))
RUNOUT_DIAG = tuple(f"benchmarks/results/core_37_runout_diagnose_quick_{w}.json"
                    for w in ("before", "before2", "after", "after2"))
RUNOUT_UNC = tuple(f"benchmarks/results/core_37_runout_uncertainty_{w}.json"
                   for w in ("before", "before2", "after", "after2"))


ROTHREADS = "benchmarks/results/core_37_rothreads_"
ROTHREADS_MC = tuple(f"{ROTHREADS}{w}.json" for w in ("before", "before2", "after", "after2"))
ROTHREADS_DIAG = tuple(f"{ROTHREADS}diagq_{w}.json"
                       for w in ("before1", "before2", "after1", "after2"))
ROTHREADS_WARM = (f"{ROTHREADS}warmup_before.json", f"{ROTHREADS}warmup_after.json")
ROTHREADS_T12 = (f"{ROTHREADS}threads1.json", f"{ROTHREADS}threads2.json")


def _rothreads_t12(root: Path) -> list[float]:
    """Wall of 1 and 2 threads, then CPU of 1 and 2 threads (Monte-Carlo)."""
    one, two = (_json(r, root)["uncertainty"] for r in ROTHREADS_T12)
    return [one["uncertainty_seconds"], two["uncertainty_seconds"],
            one["uncertainty_cpu_seconds"], two["uncertainty_cpu_seconds"]]


def _rothreads_warm(root: Path) -> list[float]:
    """Cold CPU and compile CPU before -> after, then the cache load after and before."""
    before, after = (_json(r, root)["warmup"] for r in ROTHREADS_WARM)
    return [before["cold_cpu_s"], after["cold_cpu_s"], before["compile_cpu_s"],
            after["compile_cpu_s"], after["cache_load_cpu_s"], before["cache_load_cpu_s"]]


def _runs(records: tuple[str, ...], bench: str, *keys: str) -> Callable[[Path], list[float]]:
    """``keys`` of one benchmark over several records: for the quoted layout "before1 and
    before2 (k1, k2) | after1 and after2 (k1, k2)", the first key of the two befores, the
    second key of them, then the same for the two afters.
    """
    def read(root: Path) -> list[float]:
        data = [json.loads((root / r).read_text(encoding="utf-8"))[bench] for r in records]
        out = []
        for pair in (data[:2], data[2:]):
            for key in keys:
                out += [float(d[key]) for d in pair]
        return out
    return read


RUNOUT_PROFILE = "benchmarks/results/core_37_runout_study_profile.txt"

RUNMC_STEPS = "benchmarks/results/core_37_runmc_steps.txt"
RUNMC_THREADS = "benchmarks/results/core_37_runmc_threads.txt"
RUNMC_PROFILE = "benchmarks/results/core_37_runmc_profile.txt"
RUNMC_MC = "benchmarks/results/core_37_runmc_mc_before.json"
RUNMC_DIAGQ = "benchmarks/results/core_37_runmc_diagq_before.json"
RUNMC_DIAG = "benchmarks/results/core_37_runmc_diag_full.json"


def _runmc_steps(root: Path) -> dict[str, float]:
    """The figures of the Monte-Carlo run-out's step count (``core_37_runmc_steps.py``)."""
    text = (root / RUNMC_STEPS).read_text(encoding="utf-8")
    pct = re.search(r"pcts 0/10/50/90/99/100 \[([^\]]*)\]", text)
    distinct = re.search(r"distinct rows \(rows, distinct\): (.*)$", text, re.M)
    assert pct is not None and distinct is not None
    p = [float(v) for v in pct.group(1).split()]
    out: dict[str, float] = {}
    for k, v in re.findall(r"(calls|vehicles|sum|mean|ns/vehicle-step|run_to_rest cpu) "
                           r"([\d.]+)", text):
        out.setdefault(k, float(v))  # the first: "steered vehicles" comes later
    out["median"], out["largest"] = p[2], p[5]
    out["distinct"] = float(sum(int(d) for d in re.findall(r", (\d+)\)", distinct.group(1))))
    return out


def _profile(record: str, *functions: str) -> Callable[[Path], list[float]]:
    """Cumulative times [s] of functions (``file.py:function``) in a pstats listing."""
    def read(root: Path) -> list[float]:
        text = (root / record).read_text(encoding="utf-8")
        out = []
        for fn in functions:
            module, name = fn.split(":")
            m = re.search(rf"^\s*[\d/]+\s+[\d.]+\s+[\d.]+\s+([\d.]+)\s+[\d.]+\s+\S*"
                          rf"{re.escape(module)}:\d+\({re.escape(name)}\)$", text, re.M)
            if m is None:
                raise AssertionError(f"{record}: no line of {fn}")
            out.append(float(m.group(1)))
        return out
    return read


GYM = "benchmarks/results/gym-benchmark.json"
GYM_POLICIES = ("ppo-reference", "ppo-quick", "three-stage", "openpass-like", "ideal",
                "never-brake", "always-brake")
SIGNED = r"(-?\d[\d,]*(?:\.\d+)?)"


def _gym(policy: str, keys: tuple[str, ...]) -> Callable[[Path], list[float]]:
    """Numbers of one policy of the gym benchmark's record (shares in %)."""
    def read(root: Path) -> list[float]:
        rows = [r for r in json.loads((root / GYM).read_text())["policies"]
                if r["policy"] == policy]
        assert len(rows) == 1, f"{GYM}: {len(rows)} rows of {policy}"
        return [100.0 * rows[0][k[1:]] if k.startswith("%") else float(rows[0][k])
                for k in keys]
    return read


STUDY36 = "benchmarks/results/study36-side-by-side/study36.json"


def _study36_runs(root: Path = ROOT) -> dict[tuple[int, str], dict]:
    path = root / STUDY36
    if not path.is_file():
        return {}
    return {(r["seed"], r["setting"]): r
            for r in json.loads(path.read_text(encoding="utf-8"))["runs"]}


def _p_cell(p: float | None) -> str:
    """A p-value as docs/compare.md prints it: ``< 0.001`` below 0.001 (bound: 0.001)."""
    return r"< " + NUMBER if p is not None and p < 0.001 else NUMBER


def _study36_table1(parameter: str) -> tuple[str, Callable[[Path], list[float]]]:
    """Pattern and reader of the two lines (defaults, reconstruction) of a Table 1 row of
    docs/compare.md's seed table: per seed VFS - rec. and p, significant and higher counts."""
    runs = _study36_runs()
    seeds = range(5)
    lines = []
    for setting, label in (("default", "defaults"), ("reconstruction", "reconstruction")):
        cells = []
        for seed in seeds:
            rows = [r for r in runs.get((seed, setting), {}).get("table1", [])
                    if r["parameter"] == parameter]
            cells.append(r"\+?" + SIGNED + r" \(" + _p_cell(rows[0]["p_value"] if rows else None)
                         + r"\)")
        first = (rf"{re.escape(parameter)} \| [^|\n]*" if setting == "default" else r" \| ")
        lines.append(rf"^\| {first} \| {label} \| " + "; ".join(cells)
                     + rf" \| {NUMBER}/5 \| {NUMBER}/5 \|$")

    def read(root: Path) -> list[float]:
        runs = _study36_runs(root)
        out: list[float] = []
        for setting in ("default", "reconstruction"):
            rows = [next(r for r in runs[seed, setting]["table1"] if r["parameter"] == parameter)
                    for seed in seeds]
            for r in rows:
                out += [r["difference"], max(r["p_value"], 0.001)]
            out += [sum(r["p_value"] < 0.05 for r in rows), sum(r["difference"] > 0 for r in rows)]
        return out
    return "\n".join(lines), read


def _study36_types(seed: int, setting: str) -> Callable[[Path], list[float]]:
    """Impact-type cells, chi-squared p and mean POI distances [m] of one seed and setting."""
    def read(root: Path) -> list[float]:
        r = _study36_runs(root)[seed, setting]
        c = r["contingency"]
        poi = r["poi_distance_m"]
        return [c["full->full"], c["full->sliding"], c["sliding->full"], c["sliding->sliding"],
                r["chi2_pvalue"], *(poi[g] for g in ("all", "both full", "both sliding",
                                                     "type changed"))]
    return read


STUDY36_PARAMETERS = tuple(table1_label(r.outcome, r.group) for r in PAPER_TABLE1)

#: The table: every quoted figure with its record.
QUOTES: tuple[Quote, ...] = (
    Quote("docs/performance.md",
          r"the full `vfs bench\s+diagnose` " + NUMBER + r" s CPU \(" + NUMBER + r" s wall, load "
          + NUMBER + r"\)",
          RUNMC_DIAG, _bench(RUNMC_DIAG, "diagnose", "cpu_s", "wall_s", "load_average_1min"),
          "runmc round: full diagnose"),
    Quote("docs/performance.md",
          r"the loaded machine\); " + NUMBER + r" s CPU at main 1d0b947 \(" + NUMBER
          + r" variants\)",
          RUNMC_DIAG, _bench(RUNMC_DIAG, "diagnose", "cpu_s", "variants"),
          "issue-37 table: full diagnose at main 1d0b947"),
    Quote("docs/performance.md",
          r"pre-crash; " + NUMBER + r" s CPU at main 1d0b947, low load \| < 3 s \| the "
          r"compiled run-out's " + NUMBER + r" M vehicle-steps \(" + NUMBER + r" s\)",
          ",".join((RUNMC_MC, RUNMC_STEPS, RUNMC_PROFILE)),
          lambda root: [*_bench(RUNMC_MC, "uncertainty", "uncertainty_cpu_seconds")(root),
                        _runmc_steps(root)["sum"] / 1e6,
                        *_profile(RUNMC_PROFILE, "core_runout.py:run_to_rest")(root)],
          "issue-37 table: the Monte-Carlo at main 1d0b947"),
    Quote("docs/performance.md",
          r"\*\*" + NUMBER + r" s CPU\*\* \(" + NUMBER + r" s wall\),\s+`vfs bench diagnose "
          r"--quick` " + NUMBER + r" s CPU \(load " + NUMBER + r"\)",
          ",".join((RUNMC_MC, RUNMC_DIAGQ)),
          lambda root: [*_bench(RUNMC_MC, "uncertainty", "uncertainty_cpu_seconds",
                                "uncertainty_seconds")(root),
                        *_bench(RUNMC_DIAGQ, "diagnose", "cpu_s", "load_average_1min")(root)],
          "runmc round: Monte-Carlo and diagnose --quick"),
    Quote("docs/performance.md",
          r"the run-out's " + NUMBER + r" M vehicle-steps \(all\s+" + NUMBER
          + r" vehicles distinct, none at the time limit\) take " + NUMBER + r"-" + NUMBER
          + r" s of the Monte-Carlo at " + NUMBER + r" ns\s+each",
          ",".join((RUNMC_STEPS, RUNMC_PROFILE)),
          lambda root: [_runmc_steps(root)["sum"] / 1e6, _runmc_steps(root)["distinct"],
                        _runmc_steps(root)["run_to_rest cpu"],
                        *_profile(RUNMC_PROFILE, "core_runout.py:run_to_rest")(root),
                        _runmc_steps(root)["ns/vehicle-step"]],
          "runmc round: the run-out's vehicle-steps"),
    Quote("docs/performance-kernels.md",
          r"load average " + NUMBER + r";\s+`benchmarks/results/core_37_runmc_profile.txt`, CPU "
          + NUMBER + r" s under the profiler\): of\s+`run_uncertainty` " + NUMBER
          + r" s, the compiled run-out `run_to_rest` takes " + NUMBER + r" s, the\s+contact "
          r"geometry `contact_geometry` " + NUMBER + r" s, sampling `sample_inputs` " + NUMBER
          + r" s, `distinct_rows`\s+" + NUMBER + r" s",
          RUNMC_PROFILE,
          lambda root: [*_md_numbers(RUNMC_PROFILE, r"CPU ([\d.]+) s under the profiler; load "
                                     r"average ([\d.]+)")(root)[::-1],
                        *_profile(RUNMC_PROFILE, "bands.py:run_uncertainty",
                                  "core_runout.py:run_to_rest", "geometry.py:contact_geometry",
                                  "sampling.py:sample_inputs", "runout.py:distinct_rows")(root)],
          "runmc round: the Monte-Carlo's profile at low load"),
    Quote("docs/performance-kernels.md",
          NUMBER + r" vehicles in " + NUMBER + r" batches, dt 20 ms, all\s+" + NUMBER
          + r" rows distinct(?s:.*?)" + NUMBER + r" vehicle-steps \(mean\s+" + NUMBER
          + r", median " + NUMBER + r", largest " + NUMBER + r" steps per vehicle\), " + NUMBER
          + r" ns per vehicle-step. So the\s+one-thread floor of the run-out alone is "
          + NUMBER + r" s",
          RUNMC_STEPS,
          lambda root: [_runmc_steps(root)[k] for k in (
              "vehicles", "calls", "distinct", "sum", "mean", "median", "largest",
              "ns/vehicle-step", "run_to_rest cpu")],
          "runmc round: the Monte-Carlo run-out's steps"),
    Quote("docs/performance-kernels.md",
          r"\(load average " + NUMBER + r"\) " + NUMBER + r" s wall with 2 threads\s+against "
          + NUMBER + r" s with one",
          RUNMC_THREADS,
          lambda root: _md_numbers(RUNMC_THREADS, r"(?s)load average ([\d.]+)(?<=.)|"
                                   r"x")(root)[:1] + _md_numbers(
              RUNMC_THREADS, r"(?s)2 threads: CPU [\d.]+ s, wall ([\d.]+) s")(root) + _md_numbers(
              RUNMC_THREADS, r"one thread: CPU [\d.]+ s, wall ([\d.]+) s")(root),
          "runmc round: numba threads"),
    Quote("docs/getting-started.md",
          r"`three-stage`\s+avoids " + NUMBER + r" % \[" + NUMBER + r" %, " + NUMBER
          + r" %\] of the\s+" + NUMBER + r" crashes and `ideal` " + NUMBER + r" % \["
          + NUMBER + r" %, " + NUMBER + r" %\]",
          REPORT,
          lambda root: [
              *_md_numbers(REPORT, r"`three-stage` avoids ([\d.]+) % \[([\d.]+) %, ([\d.]+) %\]"
                           r" of the (\d+) baseline")(root),
              *_md_numbers(REPORT, r"`ideal` avoids ([\d.]+) % \[([\d.]+) %, ([\d.]+) %\]")(root)],
          "avoided shares of the bundled-database study"),
    Quote("docs/getting-started.md",
          r"named the hidden channel in " + NUMBER + r"\s+of " + NUMBER + r" singles",
          BATTERY, _battery_sum("first sentence right", "both"),
          "battery: first sentence right, singles"),
    Quote("docs/getting-started.md",
          r"named both laws in " + NUMBER + r" of " + NUMBER + r" pairs",
          BATTERY, _battery_sum("both named", "both"), "battery: pairs named"),
    Quote("docs/getting-started.md",
          r"claimed nothing on " + NUMBER + r" null databases",
          BATTERY, _battery_sum("nulls claiming nothing", "count"), "battery: nulls"),
    Quote("docs/getting-started.md",
          r"no absent effect or\s+law in any of the " + NUMBER,
          BATTERY, _battery_sum("entries with an absent effect or law claimed", "total"),
          "battery: databases without an absent claim"),
    *(Quote("docs/diagnosis.md",
            rf"^\| `{ch}` \| [\d.]+ \| {NUMBER} \| {NUMBER} % \| {NUMBER} % \| {NUMBER} % "
            rf"\({NUMBER}\) \|$",
            ",".join(r for r, _ in COVERAGE.values()), _coverage(ch),
            f"interval coverage of {ch}")
      for ch in CHANNELS),
    Quote("docs/diagnosis.md",
          rf"^\| all, pooled \| \| {NUMBER} \| {NUMBER} % \| {NUMBER} % \| {NUMBER} % "
          rf"\({NUMBER}\) \|$",
          ",".join(r for r, _ in COVERAGE.values()), _coverage_pooled,
          "interval coverage, pooled"),
    *(Quote("docs/testing.md",
            rf"^\| {module} \| {NUMBER} % \({NUMBER}/{NUMBER}\) \| {NUMBER} % "
            rf"\({NUMBER}/{NUMBER}\) \| {NUMBER} \|",
            MUTATION, _mutation_row(module), f"mutation testing: {module} (second pass)")
      for module in ("vfs/physics/precrash.py", "vfs/physics/runout.py")),
    *(Quote("docs/testing.md",
            rf"^\| {module} \| {NUMBER} % \({NUMBER}/{NUMBER}\) \| {NUMBER} \| {NUMBER} \| "
            rf"`mutation-2026-11-28-{MUTATION_LATEST[module]}` \|$",
            _mutation_record(module), _mutation_latest(module),
            f"mutation testing: {module} (latest record)")
      for module in MUTATION_LATEST),
    Quote("docs/testing.md",
          r"`mutation-2026-11-28-third-after` \(" + NUMBER + r" s wall, " + NUMBER
          + r" s CPU",
          "benchmarks/results/mutation-2026-11-28-third-after.json",
          lambda root: [_json("benchmarks/results/mutation-2026-11-28-third-after.json",
                              root)["meta"][k] for k in ("wall_s", "cpu_s")],
          "mutation testing: time of the learned.py run"),
    Quote("docs/testing.md",
          r"rerun with\s+the tests of this pass, " + NUMBER + r" s wall\)",
          "benchmarks/results/mutation-2026-11-28-third-precrash.json",
          lambda root: [_json("benchmarks/results/mutation-2026-11-28-third-precrash.json",
                              root)["meta"]["wall_s"]],
          "mutation testing: time of the precrash rerun"),
    *(Quote("docs/gym.md",
            rf"^\| {p} \| {NUMBER} \[{NUMBER}, {NUMBER}\] \| .* \| {NUMBER} \| "
            rf"{NUMBER} / {NUMBER} \|$",
            GYM, _gym(p, ("avoided", "avoided_low", "avoided_high", "new_crashes",
                          "near_miss_brakes", "near_misses")),
            f"gym benchmark: crashes avoided by {p}")
      for p in GYM_POLICIES),
    *(Quote("docs/gym.md",
            rf"^\| {p} \| {NUMBER} / {NUMBER} \| {NUMBER} \({NUMBER} %\) \| {NUMBER} \| "
            rf"{NUMBER} \| {NUMBER} \| {NUMBER} \| {SIGNED} \|$",
            GYM, _gym(p, ("unnecessary", "near_misses", "unnecessary_speed_loss_kmh",
                          "%unnecessary_speed_share", "unnecessary_brake_time", "peak_decel",
                          "peak_jerk", "harsh_time", "score")),
            f"gym benchmark: braking, comfort and score of {p}")
      for p in GYM_POLICIES),
    Quote("docs/performance.md",
          r"`vfs bench study`\) \| " + NUMBER + r" and " + NUMBER + r" case-runs/s \("
          + NUMBER + r" s, " + NUMBER + r" s\) \| \*\*" + NUMBER + r" and " + NUMBER
          + r" case-runs/s\*\* \(" + NUMBER + r" s, " + NUMBER + r" s\)",
          ",".join(RUNOUT_STUDY), _runs(RUNOUT_STUDY, "study", "case_runs_per_s_cpu", "cpu_s"),
          "compiled run-out round: study before and after"),
    Quote("docs/performance.md",
          r"resume of the last 1,600 cases \| " + NUMBER + r" and " + NUMBER
          + r" case-runs/s \| " + NUMBER + r" and " + NUMBER + r" case-runs/s \|",
          ",".join(RUNOUT_STUDY), _runs(RUNOUT_STUDY, "study", "resume_case_runs_per_s_cpu"),
          "compiled run-out round: study resume before and after"),
    Quote("docs/performance.md",
          r"\(`vfs bench uncertainty`\) \| " + NUMBER + r" s and " + NUMBER + r" s \| \*\*"
          + NUMBER + r" s and " + NUMBER + r" s\*\*",
          ",".join(RUNOUT_UNC), _runs(RUNOUT_UNC, "uncertainty", "uncertainty_cpu_seconds"),
          "compiled run-out round: Monte-Carlo before and after"),
    Quote("docs/performance.md",
          r"4,000 pairs\) \| " + NUMBER + r" pairs/s \| \*\*" + NUMBER + r" pairs/s\*\*: "
          + NUMBER + r"x",
          RUNOUT_MICRO, _bench(RUNOUT_MICRO, "runout", "numpy_pairs_per_cpu_s",
                               "compiled_pairs_per_cpu_s", "speed_up"),
          "compiled run-out round: the run-out alone"),
    Quote("docs/performance.md",
          r"`simulate_cases` " + NUMBER + r" s, the generic AEB controller in Python takes "
          r"`demand` " + NUMBER + r" s, two\s+thirds: the ideal system's last-moment rule "
          r"`_last_moment` " + NUMBER + r" s \(its braked-contact sweep\s+`braked_contact` "
          + NUMBER + r" s\), the sampled CTRV/CTRA predictions `sampled_contact` " + NUMBER
          + r" s; the\s+compiled step with its Python bookkeeping \(`advance`\) " + NUMBER
          + r" s; the replay " + NUMBER + r" s; the run-out\s+`run_out_pair` " + NUMBER + r" s",
          RUNOUT_PROFILE, _profile(RUNOUT_PROFILE, "simulation.py:simulate_cases",
                                   "controller.py:demand", "controller.py:_last_moment",
                                   "threat.py:braked_contact", "threat.py:sampled_contact",
                                   "precrash.py:advance", "core.py:replay_precrash",
                                   "runout.py:run_out_pair"),
          "compiled run-out round: the study's profile after"),
    Quote("docs/performance.md",
          r"now with both run-out kernels\) \| " + NUMBER + r" s CPU \(" + NUMBER
          + r" s compiling\) \| " + NUMBER + r" s CPU \(" + NUMBER + r" s compiling, " + NUMBER
          + r" s wall at load " + NUMBER + r"\); later processes load the cache in " + NUMBER
          + r" s CPU",
          "benchmarks/results/core_37_warmup.json,benchmarks/results/core_37_runout_warmup.json",
          lambda root: [*_bench("benchmarks/results/core_37_warmup.json", "warmup",
                                "cold_cpu_s", "compile_cpu_s")(root),
                        *_bench("benchmarks/results/core_37_runout_warmup.json", "warmup",
                                "cold_cpu_s", "compile_cpu_s", "cold_wall_s",
                                "load_average_1min", "cache_load_cpu_s")(root)],
          "compiled run-out round: cold start"),
    Quote("docs/performance-kernels.md",
          r"`run_to_rest`\s+" + NUMBER + r" s of " + NUMBER + r" s, the impact's contact "
          r"geometry `contact_geometry` " + NUMBER + r" s, sampling the inputs\s+"
          r"`sample_inputs` " + NUMBER + r" s",
          "benchmarks/results/core_37_runout_mc_profile.txt",
          _profile("benchmarks/results/core_37_runout_mc_profile.txt",
                   "core_runout.py:run_to_rest", "bands.py:run_uncertainty",
                   "geometry.py:contact_geometry", "sampling.py:sample_inputs"),
          "compiled run-out: the Monte-Carlo's profile"),
    Quote("docs/performance-kernels.md",
          r"samples; " + NUMBER + r"-" + NUMBER + r" s\s+CPU now",
          ",".join(RUNOUT_UNC[2:]),
          lambda root: sorted(_runs(RUNOUT_UNC, "uncertainty",
                                    "uncertainty_cpu_seconds")(root)[2:]),
          "compiled run-out: the Monte-Carlo after"),
    Quote("docs/performance.md",
          r"compiled impact\) \| " + NUMBER + r" s and " + NUMBER + r" s \| \*\*" + NUMBER
          + r" s and " + NUMBER + r" s\*\* \(the same " + NUMBER + r" variants, " + NUMBER
          + r" case-runs\)",
          ",".join(RUNOUT_DIAG),
          lambda root: [*_runs(RUNOUT_DIAG, "diagnose", "cpu_s")(root),
                        *_bench(RUNOUT_DIAG[2], "diagnose", "variants", "case_runs")(root)],
          "compiled run-out round: diagnose --quick before and after"),
    Quote("docs/performance.md",
          r"main 2c4ada4\) \| " + NUMBER + r" s CPU \| \*\*" + NUMBER + r" s CPU\*\* \(the "
          r"same " + NUMBER + r" variants; load " + NUMBER + r"\)",
          "benchmarks/results/core_37_runout_diagnose_before.json,"
          "benchmarks/results/core_37_runout_diagnose_after.json",
          lambda root: [*_bench("benchmarks/results/core_37_runout_diagnose_before.json",
                                "diagnose", "cpu_s")(root),
                        *_bench("benchmarks/results/core_37_runout_diagnose_after.json",
                                "diagnose", "cpu_s", "variants", "load_average_1min")(root)],
          "compiled run-out round: full diagnose before and after"),
    Quote("docs/performance.md",
          NUMBER + r" s under the profiler\) the compiled loop `_vehicle_loop` takes " + NUMBER
          + r" s, the learning of\s+the laws `learn` " + NUMBER + r" s, the identification "
          r"`identify` " + NUMBER + r" s",
          "benchmarks/results/core_37_runout_diagnose_profile.txt",
          _profile("benchmarks/results/core_37_runout_diagnose_profile.txt",
                   "diagnose.py:diagnose", "core_runout.py:_vehicle_loop", "learn.py:learn",
                   "identify.py:identify"),
          "compiled run-out round: the diagnosis profile"),
    Quote("docs/performance.md",
          r"\(" + NUMBER + r" s of " + NUMBER + r" s in the profile before\)",
          "benchmarks/results/core_37_study_profile.txt",
          _profile("benchmarks/results/core_37_study_profile.txt", "runout.py:run_out_pair",
                   "simulation.py:simulate_cases"),
          "compiled run-out round: the run-out in the study's profile before"),
    Quote("docs/performance-kernels.md",
          r"path samples and secondary-collision check \| " + NUMBER + r" pairs/s \(" + NUMBER
          + r" ns per vehicle-step\) \| \*\*" + NUMBER + r" pairs/s\*\* \(" + NUMBER
          + r" ns\) \| " + NUMBER + r"x \|",
          RUNOUT_MICRO, _bench(RUNOUT_MICRO, "runout", "numpy_pairs_per_cpu_s",
                               "numpy_ns_per_vehicle_step", "compiled_pairs_per_cpu_s",
                               "compiled_ns_per_vehicle_step", "speed_up"),
          "compiled run-out, the study's pairs"),
    Quote("docs/performance-kernels.md",
          r"rest poses only \| " + NUMBER + r" vehicles/s \(" + NUMBER
          + r" ns per vehicle-step\) \| " + NUMBER + r" vehicles/s \(" + NUMBER
          + r" ns\) \| " + NUMBER + r"x \|",
          RUNOUT_MICRO, _bench(RUNOUT_MICRO, "runout", "mc_numpy_vehicles_per_cpu_s",
                               "mc_numpy_ns_per_vehicle_step", "mc_compiled_vehicles_per_cpu_s",
                               "mc_compiled_ns_per_vehicle_step", "mc_speed_up"),
          "compiled run-out, the Monte-Carlo's vehicles"),
    Quote("docs/performance-kernels.md",
          r"at most " + NUMBER + r"e-13 m; " + NUMBER + r" % of the rest",
          RUNOUT_MICRO, _bench(RUNOUT_MICRO, "runout", "max_difference_m*1e13",
                               "bit_identical*100"),
          "compiled run-out: difference and bit-identical share"),
    Quote("docs/performance-kernels.md",
          r"the compiled loop wins " + NUMBER + r"x\. The Monte-Carlo's batch is 200,000 "
          r"vehicles, where numpy's\s+fixed cost vanishes: " + NUMBER + r"x",
          RUNOUT_MICRO, _bench(RUNOUT_MICRO, "runout", "speed_up", "mc_speed_up"),
          "compiled run-out: speed-ups in the text"),
    Quote("docs/performance.md",
          r"`core_37_gym2_after.json`: " + NUMBER + r" / " + NUMBER + r" k -> \*\*" + NUMBER
          + r" / " + NUMBER + r" k steps/s\*\* \(single [\d.]+x, goal met; 32,768 envs [\d.]+x\); "
          r"8,192 envs " + NUMBER + r" k -> " + NUMBER + r" k, 1,024 envs " + NUMBER + r" k -> "
          + NUMBER + r" k",
          f"{GYM2_BENCH[0]},{GYM2_BENCH[1]}", _gym2_cpu,
          "gym single and vector env steps per CPU-second, before and after (gym2)"),
    Quote("docs/gym.md",
          r"`AEBEnv`, single \| " + NUMBER + r" \|\n.*SyncVectorEnv.* \| " + NUMBER
          + r" \|\n.*1,024 envs \| " + NUMBER + r" \|\n.*8,192 envs \| " + NUMBER
          + r" \|\n.*32,768 envs \| " + NUMBER + r" \|",
          GYM2_BENCH[1],
          _bench(GYM2_BENCH[1], "gym_env", "single_steps_per_s", "sync_vector_8_steps_per_s",
                 "vector_1024_steps_per_s", "vector_8192_steps_per_s",
                 "vector_32768_steps_per_s"),
          "gym environments' steps per second"),
    Quote("docs/gym.md", r"a single `AEBEnv` runs at " + NUMBER + r" s/s", GYM2_BENCH[1],
          _bench(GYM2_BENCH[1], "gym_env", "single_simulated_s_per_s"),
          "simulated seconds per second of the single env"),
    Quote("docs/performance.md",
          r"numpy\s+reference: " + NUMBER + r" M/s \(load " + NUMBER + r"\) \| \*\*" + NUMBER
          + r" M/s\*\* compiled",
          IMPACT_BENCH,
          lambda root: [_json(IMPACT_BENCH, root)["impact"]["numpy_reference_impacts_per_s"] / 1e6,
                        _json(IMPACT_BENCH, root)["impact"]["load_average"],
                        _json(IMPACT_BENCH, root)["impact"]["impacts_per_s"] / 1e6],
          "impacts per second, compiled and numpy reference"),
    Quote("docs/performance.md",
          r"start of the next round: \*\*" + NUMBER + r" M/s\*\* \(load " + NUMBER
          + r", record `core_37_session3_start.json`\)",
          SESSION3_START, _bench(SESSION3_START, "impact", "impacts_per_s*1e-6",
                                 "load_average"),
          "impacts per second on an idle machine, unchanged code"),
    Quote("docs/performance.md",
          r"unchanged main\s+\(`core_37_session3_start.json`, load " + NUMBER
          + r"\), and at its end\s+\(`core_37_session3_end.json`, load " + NUMBER + r"\)",
          f"{SESSION3_START},{SESSION3_END}",
          lambda root: [*_bench(SESSION3_START, "study", "load_average_1min")(root),
                        *_bench(SESSION3_END, "study", "load_average_1min")(root)],
          "loads of the idle-machine benchmarks at the round's start and end"),
    Quote("docs/performance.md",
          r"one core, CPU time \| " + NUMBER + r" case-runs/s \| " + NUMBER
          + r" case-runs/s \| >= 5,000 \|\n\| the same, resume \| " + NUMBER
          + r" case-runs/s \| " + NUMBER + r" case-runs/s",
          f"{SESSION3_START},{SESSION3_END}",
          lambda root: [*_bench(SESSION3_START, "study", "case_runs_per_s_cpu")(root),
                        *_bench(SESSION3_END, "study", "case_runs_per_s_cpu")(root),
                        *_bench(SESSION3_START, "study", "resume_case_runs_per_s_cpu")(root),
                        *_bench(SESSION3_END, "study", "resume_case_runs_per_s_cpu")(root)],
          "study case-runs per CPU-second at the round's start and end, idle machine"),
    Quote("docs/performance.md",
          r"1,000 samples, CPU time \| " + NUMBER + r" s \| " + NUMBER + r" s \| < 3 s \|\n"
          r".*steps per CPU-second \| " + NUMBER + r" / " + NUMBER + r" k \| " + NUMBER
          + r" / " + NUMBER + r" k \|.*\n\| impacts \| " + NUMBER + r" M/s \| " + NUMBER
          + r" M/s .*\n.*cold start, CPU time \| \| " + NUMBER + r" s once",
          f"{SESSION3_START},{SESSION3_END}",
          lambda root: [
              *_bench(SESSION3_START, "uncertainty", "uncertainty_cpu_seconds")(root),
              *_bench(SESSION3_END, "uncertainty", "uncertainty_cpu_seconds")(root),
              *_bench(SESSION3_START, "gym_env", "single_steps_per_cpu_s",
                      "vector_32768_steps_per_cpu_s*1e-3")(root),
              *_bench(SESSION3_END, "gym_env", "single_steps_per_cpu_s",
                      "vector_32768_steps_per_cpu_s*1e-3")(root),
              *_bench(SESSION3_START, "impact", "impacts_per_s*1e-6")(root),
              *_bench(SESSION3_END, "impact", "impacts_per_s*1e-6")(root),
              *_bench(SESSION3_END, "warmup", "cold_cpu_s")(root)],
          "Monte-Carlo, gym, impacts and cold start at the round's start and end, idle"),
    Quote("docs/performance.md",
          r"`core_37_session4_start.json` \(load " + NUMBER + r"\), then the end,\s+"
          r"`core_37_session4_end.json` \(load " + NUMBER + r"\)",
          f"{SESSION4_START},{SESSION4_END}",
          lambda root: [*_bench(SESSION4_START, "study", "load_average_1min")(root),
                        *_bench(SESSION4_END, "study", "load_average_1min")(root)],
          "loads of the fourth round's start and end benchmarks"),
    Quote("docs/performance.md",
          r"one core, CPU time \| " + NUMBER + r" case-runs/s \(" + NUMBER + r" s\) \| \*\*"
          + NUMBER + r" case-runs/s\*\* \(" + NUMBER + r" s\) \| >= 5,000 \|\n"
          r"\| the same, resume, CPU time \| " + NUMBER + r" case-runs/s \| " + NUMBER
          + r" case-runs/s \| \|\n"
          r"\| Monte-Carlo 200 cases x 1,000 samples, wall \(CPU\) \| " + NUMBER + r" s \("
          + NUMBER + r" s\) \| \*\*" + NUMBER + r" s\*\* \(" + NUMBER + r" s\) on the "
          r"run-out's 2 threads \| < 3 s \|\n"
          r".*steps per CPU-second \| " + NUMBER + r" / " + NUMBER + r" k \| " + NUMBER
          + r" / " + NUMBER + r" k .*\n\| impacts \| " + NUMBER + r" M/s \| " + NUMBER
          + r" M/s .*\n\| cold start, CPU time \| " + NUMBER + r" s once \| " + NUMBER
          + r" s once",
          f"{SESSION4_START},{SESSION4_END}",
          lambda root: [
              *_bench(SESSION4_START, "study", "case_runs_per_s_cpu", "cpu_s")(root),
              *_bench(SESSION4_END, "study", "case_runs_per_s_cpu", "cpu_s")(root),
              *_bench(SESSION4_START, "study", "resume_case_runs_per_s_cpu")(root),
              *_bench(SESSION4_END, "study", "resume_case_runs_per_s_cpu")(root),
              *_bench(SESSION4_START, "uncertainty", "uncertainty_seconds",
                      "uncertainty_cpu_seconds")(root),
              *_bench(SESSION4_END, "uncertainty", "uncertainty_seconds",
                      "uncertainty_cpu_seconds")(root),
              *_bench(SESSION4_START, "gym_env", "single_steps_per_cpu_s",
                      "vector_32768_steps_per_cpu_s*1e-3")(root),
              *_bench(SESSION4_END, "gym_env", "single_steps_per_cpu_s",
                      "vector_32768_steps_per_cpu_s*1e-3")(root),
              *_bench(SESSION4_START, "impact", "impacts_per_s*1e-6")(root),
              *_bench(SESSION4_END, "impact", "impacts_per_s*1e-6")(root),
              *_bench(SESSION4_START, "warmup", "cold_cpu_s")(root),
              *_bench(SESSION4_END, "warmup", "cold_cpu_s")(root)],
          "the fourth round's start and end on the idle machine"),
    Quote("docs/performance.md",
          r"AEB\s+kernels cost " + NUMBER + r" s CPU of its run against " + NUMBER
          + r" s for `three-stage`",
          FLOOR_BEFORE,
          lambda root: [_floor_kernel(FLOOR_BEFORE, "ideal", "AEB kernels")(root),
                        _floor_kernel(FLOOR_BEFORE, "three-stage", "AEB kernels")(root)],
          "the AEB kernels' CPU of ideal and three-stage at the round's start"),
    Quote("docs/performance.md",
          r"AEB kernels fell to " + NUMBER + r" s \(gather included\), its run from " + NUMBER
          + r" to " + NUMBER + r" s CPU",
          f"{FLOOR},{FLOOR_BEFORE}",
          lambda root: [_floor_kernel(FLOOR, "ideal", "AEB kernels")(root),
                        _json(FLOOR_BEFORE, root)["runs"]["ideal"]["cpu_s"],
                        _json(FLOOR, root)["runs"]["ideal"]["cpu_s"]],
          "the ideal system's AEB kernels and run before and after the sweep's skip"),
    Quote("docs/performance.md",
          r"core_37_floor_rounds.json`:\s+" + NUMBER + r" and " + NUMBER
          + r" s at the start, " + NUMBER + r" and\s+" + NUMBER + r" s at the end\)\. The "
          r"9,000 case-runs' simulation takes " + NUMBER + r" s \(" + NUMBER
          + r" case-runs/s\), of which\s+the compiled kernels " + NUMBER + r" s: the "
          r"baseline's replay " + NUMBER + r" ns per row-step[^;]*;\s+" + NUMBER
          + r" M\s+row-steps, about 600 per case\), the controlled runs' step " + NUMBER + r"-"
          + NUMBER + r" ns per row-step, the AEB\s+kernels " + NUMBER
          + r" ns per ego and measurement for `three-stage` \(every 50 ms\) and " + NUMBER
          + r" ns for `ideal`\s+\(every 10 ms\), the run-out " + NUMBER + r"-" + NUMBER
          + r" ns per vehicle-step at 5 ms\. The kernels alone, with no\s+Python between them "
          r"and nothing before or after the simulation, would allow " + NUMBER,
          f"{FLOOR},{FLOOR_ROUNDS}", _floor_quotes,
          "what a case-run costs at the 10 ms grid"),
    Quote("docs/performance.md",
          r"compiled run-out takes\s+" + NUMBER + r" s of its " + NUMBER + r" s CPU, " + NUMBER
          + r" vehicle-steps of " + NUMBER + r" distinct vehicles \(the variants'\s+"
          r"post-impact states\) at " + NUMBER + r" ns each, a median of " + NUMBER
          + r" steps of 5 ms",
          "benchmarks/results/core_37_diagnose_steps.txt",
          _diagnose_steps,
          "the full diagnosis's run-out"),
    Quote("docs/performance-kernels.md",
          r"\(`benchmarks/results/core_37_runmc_threads_idle.txt`\): " + NUMBER
          + r" s wall with one thread, " + NUMBER + r" s\s+with 2 threads",
          "benchmarks/results/core_37_runmc_threads_idle.txt",
          lambda root: [float(v) for v in re.findall(
              r"wall ([\d.]+) s", (root / "benchmarks/results/core_37_runmc_threads_idle.txt")
              .read_text())],
          "the run-out with numba threads on the idle machine"),
    Quote("docs/performance.md",
          r"100,000 impacts, load " + NUMBER + r"\): the kernel " + NUMBER + r" ms \("
          + NUMBER + r" ns per impact: .*numpy's arctan2 " + NUMBER + r" ms, the PDOF kernel "
          + NUMBER + r" ms, and writing the result's fresh arrays \(20 MB\) " + NUMBER
          + r" ms\s+against " + NUMBER + r" ms for arrays written before.* the kernel alone is "
          + NUMBER,
          IMPACT_BREAKDOWN, _breakdown,
          "where the time of one impact call goes"),
    Quote("docs/performance.md",
          r"back to back against main [0-9a-f]{7} \(with the compiled run-out\): " + NUMBER
          + r" -> \*\*" + NUMBER + r" case-runs/s\*\* \("
          + NUMBER + r" -> " + NUMBER + r" s, loads " + NUMBER + r" and " + NUMBER
          + r"\): [\d.]+x \(`--quick`, 600 cases: " + NUMBER + r" -> " + NUMBER,
          ",".join(AEB_BENCH), _aeb_study, "study case-runs/s with the compiled AEB controller"),
    Quote("docs/performance.md",
          r"core_37_aeb_profile.txt`, wall clock at load " + NUMBER + r"\): `demand` " + NUMBER
          + r" s of `simulate_cases` " + NUMBER + r" s",
          AEB_PROFILE,
          lambda root: [*_md_numbers(AEB_PROFILE, r"load average ([\d.]+)")(root),
                        *_md_numbers(AEB_PROFILE, r"[\d.]+ +[\d.]+ +[\d.]+ +([\d.]+) +[\d.]+ "
                                     r"\S+controller.py:\d+\(demand\)")(root),
                        *_md_numbers(AEB_PROFILE, r"[\d.]+ +[\d.]+ +[\d.]+ +([\d.]+) +[\d.]+ "
                                     r"\S+simulation.py:\d+\(simulate_cases\)")(root)],
          "profile of the study with the compiled AEB controller"),
    Quote("docs/performance.md",
          r"back to back against the branch point 1d0b947: " + NUMBER + r" -> \*\*" + NUMBER
          + r" case-runs/s\*\* \(" + NUMBER + r" -> " + NUMBER + r" s CPU, loads " + NUMBER
          + r" and " + NUMBER + r"\): [\d.]+x; at the start of that round " + NUMBER + r" \("
          + NUMBER + r" s, load " + NUMBER + r"\), at its end " + NUMBER + r" \(" + NUMBER
          + r" s, load " + NUMBER + r"\)",
          ",".join(STUDYIO_BENCH), _studyio_study, "study case-runs/s after the loading round"),
    Quote("docs/performance.md",
          r"after the loading round " + NUMBER + r" -> \*\*" + NUMBER + r" case-runs/s\*\* \("
          + NUMBER + r" -> " + NUMBER + r" s CPU, back to back\)",
          ",".join(STUDYIO_BENCH[:2]), _studyio_resume, "resume case-runs/s, loading round"),
    Quote("docs/performance.md",
          r"back to back against 1d0b947, cold " + NUMBER + r" -> \*\*" + NUMBER
          + r" s CPU\*\* \(compiling " + NUMBER + r" -> " + NUMBER + r" s; loads " + NUMBER
          + r" and " + NUMBER + r";",
          ",".join(STUDYIO_WARMUP), _studyio_warmup, "cold start with the inlined helpers"),
    Quote("docs/performance.md",
          r"median \*\*" + NUMBER + r" -> " + NUMBER + r" s CPU\*\* \(" + NUMBER + r" -> "
          + NUMBER + r" case-runs/s\), the\s+branch faster in " + NUMBER + r" of " + NUMBER
          + r" pairs", STARTUP_AB, _startup_ab(STARTUP_AB), "fixed costs: interleaved study runs"),
    Quote("docs/performance.md",
          r"against it at load " + NUMBER + r"\s+\(`core_37_startup_ab_main.json`\): median "
          + NUMBER + r" -> " + NUMBER + r" s CPU \(" + NUMBER + r" -> " + NUMBER
          + r" case-runs/s\), " + NUMBER + r" of " + NUMBER + r"\s+pairs",
          STARTUP_AB_MAIN, _startup_ab(STARTUP_AB_MAIN, load=True),
          "fixed costs: interleaved study runs against main"),
    Quote("docs/performance.md",
          r"`vfs bench study` back to back: " + NUMBER + r" -> " + NUMBER + r" case-runs/s\s+\("
          + NUMBER + r" -> " + NUMBER + r" s\), a second pair " + NUMBER + r" and " + NUMBER
          + r" \(a single run moves by more than the gain at this\s+load\); the start of "
          r"`vfs study --help` " + NUMBER + r" -> " + NUMBER + r" s CPU",
          ",".join(STARTUP_BENCH), _startup_bench, "fixed costs: vfs bench study and its start"),
    Quote("docs/performance.md",
          r"Under the profiler: `build_parser`\s+" + NUMBER + r" -> " + NUMBER
          + r" s, `copy.deepcopy` " + NUMBER + r" -> " + NUMBER + r" s, `study_input` " + NUMBER
          + r" -> " + NUMBER + r" s",
          STARTUP_PROFILE,
          lambda root: [*_startup_part("build_parser")(root),
                        *_startup_part("copy.deepcopy (pandas attrs)")(root),
                        *_startup_part("study_input")(root)],
          "fixed costs: the profile's parts"),
    Quote("docs/performance.md",
          r"check, once: `check_database` " + NUMBER + r" s under the profiler\)",
          STARTUP_PROFILE, lambda root: _startup_part("check_database")(root)[1:],
          "fixed costs: the validation after"),
    Quote("docs/performance.md",
          r"minor page faults fell from " + NUMBER + r" to " + NUMBER + r" and\s+its system time "
          r"from " + NUMBER + r" to " + NUMBER + r" s in the first of three pairs",
          "benchmarks/results/core_37_startup_malloc.json",
          lambda root: [*(_json("benchmarks/results/core_37_startup_malloc.json", root)["pairs"][0]
                          [k]["minor_faults"] for k in ("default", "raised")),
                        *(_json("benchmarks/results/core_37_startup_malloc.json", root)["pairs"][0]
                          [k]["sys_s"] for k in ("default", "raised"))],
          "fixed costs: page faults with raised allocator thresholds"),
    Quote("docs/performance.md",
          r"core_37_studyio_profile.txt`, CPU time under the profiler at load " + NUMBER
          + r", " + NUMBER + r" s in all\): `simulate_cases` " + NUMBER + r" s, of it the "
          r"compiled step `_settle_rows` " + NUMBER + r" s",
          STUDYIO_PROFILE,
          lambda root: [*_md_numbers(STUDYIO_PROFILE, r"load average ([\d.]+)")(root),
                        *_md_numbers(STUDYIO_PROFILE, r"in ([\d.]+) seconds")(root),
                        *_cumulative(STUDYIO_PROFILE, "simulation.py:LINE(simulate_cases)")(root),
                        *_cumulative(STUDYIO_PROFILE, "core.py:LINE(_settle_rows)")(root)],
          "profile after the loading round: the step"),
    Quote("docs/performance.md",
          r"the controller's `demand` " + NUMBER + r" s \(its kernels about half\), the "
          r"replay with numba's cache " + NUMBER + r" s; before the tasks the validation of the "
          r"selection \(`study_input` " + NUMBER + r" s, of it `check_database` " + NUMBER
          + r" s",
          STUDYIO_PROFILE,
          lambda root: [*_cumulative(STUDYIO_PROFILE, "controller.py:LINE(demand)")(root),
                        *_cumulative(STUDYIO_PROFILE, "core.py:LINE(replay_precrash)")(root),
                        *_cumulative(STUDYIO_PROFILE, "inputs.py:LINE(study_input)")(root),
                        *_cumulative(STUDYIO_PROFILE, "checks.py:LINE(check_database)")(root)],
          "profile after the loading round: controller, replay, validation"),

    *(Quote("docs/compare.md", _study36_table1(parameter)[0], STUDY36,
            _study36_table1(parameter)[1], f"study36 seeds 0-4: {parameter}")
      for parameter in STUDY36_PARAMETERS),
    *(Quote("docs/compare.md",
            rf"^\| {seed} \| {label} \| {NUMBER} \| {NUMBER} \| {NUMBER} \| {NUMBER} \| {NUMBER} "
            rf"\| {NUMBER} / {NUMBER} / {NUMBER} / {NUMBER} \|$",
            STUDY36, _study36_types(seed, setting),
            f"study36 seed {seed}, {label}: impact types and POI distances")
      for seed in range(5)
      for setting, label in (("default", "defaults"), ("reconstruction", "reconstruction"))),
    Quote("docs/performance.md",
          r"`VFS_THREADS=1` and `2` took\s+\*\*" + NUMBER + r" s -> " + NUMBER
          + r" s wall\*\* \(" + NUMBER + r" s and " + NUMBER + r" s CPU",
          ",".join(ROTHREADS_T12), _rothreads_t12,
          "run-out threads: Monte-Carlo with 1 and 2 threads"),
    Quote("docs/performance.md",
          r"two\s+rounds before and after: " + NUMBER + r" s and " + NUMBER + r" s CPU \("
          + NUMBER + r" s and " + NUMBER + r" s wall\) before, " + NUMBER + r" s and\s+"
          + NUMBER + r" s CPU \(" + NUMBER + r" s and " + NUMBER + r" s wall\) after",
          ",".join(ROTHREADS_MC),
          _runs(ROTHREADS_MC, "uncertainty", "uncertainty_cpu_seconds", "uncertainty_seconds"),
          "run-out threads: Monte-Carlo before and after, niced"),
    Quote("docs/performance.md",
          r"`vfs bench diagnose --quick` " + NUMBER + r" s and " + NUMBER + r" s wall \("
          + NUMBER + r" s and " + NUMBER + r" s CPU\) before,\s+" + NUMBER + r" s and "
          + NUMBER + r" s wall \(" + NUMBER + r" s and " + NUMBER + r" s CPU\) after",
          ",".join(ROTHREADS_DIAG), _runs(ROTHREADS_DIAG, "diagnose", "wall_s", "cpu_s"),
          "run-out threads: diagnose --quick before and after"),
    Quote("docs/performance.md",
          r"the full `vfs bench diagnose` \(600\s+cases, load " + NUMBER + r"\) " + NUMBER
          + r" s -> " + NUMBER + r" s wall, " + NUMBER + r" s -> " + NUMBER + r" s CPU",
          f"{ROTHREADS}diagnose_before.json,{ROTHREADS}diagnose_after.json",
          lambda root: [_json(f"{ROTHREADS}diagnose_after.json", root)["diagnose"][
              "load_average_1min"], *(
              _json(f"{ROTHREADS}diagnose_{w}.json", root)["diagnose"][k]
              for k in ("wall_s", "cpu_s") for w in ("before", "after"))],
          "run-out threads: the full diagnosis before and after"),
    Quote("docs/performance.md",
          r"`vfs bench warmup` " + NUMBER + r" s -> " + NUMBER + r" s CPU\s+\(" + NUMBER
          + r" s -> " + NUMBER + r" s compiling\); later processes load the cache in "
          + NUMBER + r" s CPU instead of " + NUMBER + r" s",
          ",".join(ROTHREADS_WARM), _rothreads_warm,
          "run-out threads: cold start before and after"),
    Quote("docs/performance.md",
          r"the\s+run-out alone\s+went from " + NUMBER + r" s to " + NUMBER + r" s with two "
          r"threads \(`core_37_runmc_threads_idle.txt`\)",
          "benchmarks/results/core_37_runmc_threads_idle.txt",
          _md_numbers("benchmarks/results/core_37_runmc_threads_idle.txt",
                      r"one thread: CPU [\d.]+ s, wall ([\d.]+) s\n2 threads: CPU [\d.]+ s, "
                      r"wall ([\d.]+) s"),
          "run-out threads: the idle-machine experiment"),
)


def _decimals(text: str) -> int:
    return len(text.split(".")[1]) if "." in text else 0


def check(quote: Quote, text: str, root: Path = ROOT) -> list[str]:
    """The problems of one row of :data:`QUOTES` in a document's ``text`` (empty: true)."""
    matches = list(re.finditer(quote.pattern, text, re.M))
    if len(matches) != 1:
        return [f"{quote.doc}: the quote of {quote.what} is found {len(matches)} times "
                f"(pattern {quote.pattern!r}); update tests/test_docs_figures.py with the doc"]
    quoted = matches[0].groups()
    recorded = quote.values(root)
    if len(quoted) != len(recorded):
        return [f"{quote.doc}: {len(quoted)} numbers quoted, {len(recorded)} read from "
                f"{quote.record}"]
    problems = []
    for q, r in zip(quoted, recorded, strict=True):
        if round(r, _decimals(q)) != float(q.replace(",", "")):
            problems.append(f"{quote.doc}: {quote.what}: quotes {q}, {quote.record} has "
                            f"{r:g}")
    return problems


@pytest.mark.parametrize("quote", QUOTES, ids=lambda q: f"{q.doc}:{q.what}")
def test_quoted_figures_equal_their_records(quote: Quote) -> None:
    for record in quote.record.split(","):
        assert (ROOT / record).is_file(), f"{record}: the record is not committed"
    assert check(quote, (ROOT / quote.doc).read_text(encoding="utf-8")) == []


@pytest.mark.parametrize("quote", QUOTES, ids=lambda q: f"{q.doc}:{q.what}")
def test_a_planted_stale_number_fails(quote: Quote) -> None:
    text = (ROOT / quote.doc).read_text(encoding="utf-8")
    m = re.search(quote.pattern, text, re.M)
    assert m is not None
    for group in range(1, len(m.groups()) + 1):
        old = m.group(group)
        stale = str(int(float(old.replace(",", ""))) + 7)  # a different number, same shape
        planted = text[:m.start(group)] + stale + text[m.end(group):]
        problems = check(quote, planted)
        assert problems and stale in problems[0], (group, problems)


def test_a_removed_quote_fails() -> None:
    quote = QUOTES[0]
    assert "found 0 times" in check(quote, "")[0]


# -- lists the docs repeat from the code ----------------------------------------------------


def test_readme_lists_every_exit_code_of_the_cli() -> None:
    import vfs.cli

    code_codes = {int(c) for c in re.findall(r"(?:^\*|;) (\d+):", vfs.cli.__doc__ or "", re.M)}
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    readme_codes = {int(c) for c in re.findall(r"^\| (\d+) \|", readme, re.M)}
    assert code_codes >= {0, 1, 2, 3, 4, 130}
    assert readme_codes == code_codes


#: ``vfs.*`` names in the docs that are not Python objects, with the reason.
NOT_OBJECTS: dict[str, str] = {
    "vfs.executors": "an entry-point group (docs/study.md)",
    "vfs.controller_kinds": "an entry-point group (adas/README.md, CHANGELOG)",
    "vfs.database_formats": "an entry-point group (docs/data-format.md, CHANGELOG)",
    "vfs.systems": "an entry-point group (docs/aeb.md, CHANGELOG)",
    "vfs.study.AEBSystem": "the old name in the CHANGELOG's line on its renaming to System",
    "vfs.impact_table": "an old module name in docs/api.md, 'Moved modules'",
    "vfs.plotting": "an old module name in docs/api.md, 'Moved modules'",
}
#: Documents whose ``vfs.<name>`` words are OpenSCENARIO property names, not Python objects.
PROPERTY_DOCS = ("docs/interop.md",)


def _resolve(name: str) -> bool | None:
    """True when the dotted name exists; None when an optional dependency is missing."""
    parts = name.split(".")
    for i in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:i]))
        except ModuleNotFoundError as exc:
            if exc.name and not exc.name.startswith("vfs"):
                return None  # an optional dependency (stable-baselines3, ...)
            continue
        for attr in parts[i:]:
            if not hasattr(obj, attr):
                return False
            obj = getattr(obj, attr)
        return True
    return False


def _unreleased(text: str) -> str:
    start = text.index("## [Unreleased]")
    end = text.find("\n## ", start + 5)
    return text[start:end if end > 0 else len(text)]


def test_named_vfs_objects_exist() -> None:
    docs = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
    texts = {str(p.relative_to(ROOT)): p.read_text(encoding="utf-8") for p in docs
             if str(p.relative_to(ROOT)) not in PROPERTY_DOCS}
    texts["CHANGELOG.md (Unreleased)"] = _unreleased(
        (ROOT / "CHANGELOG.md").read_text(encoding="utf-8"))
    missing = []
    for where, text in texts.items():
        for name in sorted(set(re.findall(r"`(vfs(?:\.[A-Za-z_]\w*)+)(?:\(|`)", text))):
            if name not in NOT_OBJECTS and _resolve(name) is False:
                missing.append(f"{where}: `{name}`")
    assert missing == []
