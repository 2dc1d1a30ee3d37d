"""Insert the run-out battery section into docs/diagnosis.md from the committed records."""
import json
from pathlib import Path

R = Path("benchmarks/results/battery_runout_240_quick")
doc = Path("docs/diagnosis.md")
s = doc.read_text()
start, end = "<!-- battery-runout -->", "<!-- /battery-runout -->"
if start in s:
    s = s[:s.index(start)] + s[s.index(end) + len(end) + 1:]
def md(part, name):
    """The table of one part's records (battery.md written by --table-only)."""
    p = R / part / name
    return p.read_text().strip() if p.exists() else "(not run)"
mimic = R / "mimic_check.json"
mimic_text = ""
if mimic.exists():
    m = json.loads(mimic.read_text())
    rej = "; ".join(f"{r['name']}: {r['reason']}" for r in m["rejected"]
                    if r["reason"] != "not significant") or "none but 'not significant'"
    mimic_text = (
        "**The rule alone** (`benchmarks/runout_mimic_check.py`, record `mimic_check.json`): the "
        f"`{m['law']}` database diagnosed with the eleven channels of the last round only (no "
        f"run-out channel for a law of both cars; {m['cases']} cases, `--quick`, "
        f"{m['cpu_s']:.0f} s CPU, {m['wall_s']:.0f} s wall on the loaded machine) claims "
        f"{', '.join(m['claims']) or 'nothing'}; its verdict begins: *\"{m['verdict'][0]}\"*; "
        f"rejected with reasons: {rej}.  The rule did not fire here: on this database the "
        "tyre impulse alone explains nothing (0.0 %: in the light crashes the law releases the "
        "brakes and the run-outs are longer than the model's, which an impulse that only "
        "shortens them cannot mimic), so the false claim of issue 36 does not arise; the "
        "per-vehicle laws stand in for the shared one (both named, CV RMSE "
        f"{m['steps'][-1]['cv_rmse']:.2f} against 1.27 with the `runout_brake` law above).  The "
        "rule itself is checked on synthetic reductions (tests/test_selection.py).\n\n")
sec = f"""{start}
### The run-out part (issue 36)

Laws of what happens after separation, of the three kinds the diagnosis failed on in
issue 36: a brake law of crash severity on **both** cars (`runout_brake`), the wheel at the
**impact corner** locked by damage (`corner_brake`; the other wheels at the default 0.8), and
the latter **paired with a restitution law** (`benchmarks/battery_laws.py`, `RUNOUT`,
`RUNOUT_PAIRS`; held out and run once at the end: `HELD_OUT_3`, `HELD_OUT_3_PAIRS` and
`null5`).  All were written before any run of them.  They ran on the project's shared 2-core
machine at load 16-30 (eight sessions at once), so the wall times are 10-25 times the CPU
times; **240 cases drawn** per database (216-218 colliding), `--quick`, every library effect and
all thirteen channels.  Records: `benchmarks/results/battery_runout_240_quick/`.  With the
same settings a few databases of the main part were rerun as a regression check of the
changes to the selection (the rule "no output worse", library effects tried on top, two more
channels): `tyre_friction_speed`, `brake1_logistic`, `null1`.

    PYTHONPATH=. python benchmarks/diagnosis_battery.py --out OUT/runout --cases 240 \\
        --quick --runout
    PYTHONPATH=. python benchmarks/diagnosis_battery.py --out OUT/held3 --cases 240 \\
        --quick --held-out-3 --jobs 2
    PYTHONPATH=. python benchmarks/diagnosis_battery.py --out OUT/main --cases 240 --quick \\
        --only brake1_logistic,tyre_friction_speed,null1

Run-out part:

{md("runout", "battery_runout.md")}

Held out, run once:

{md("held3", "battery_held_out_3.md")}

The held-out part misses one target: in the pair `brake_both_overlap+mu_overlap_bell` both
hidden laws are claimed (98 % of the truth's reduction), but a third claim, a
`runout_brake2` law on top of the shared `runout_brake` law, is an absent claim by the
judge's rule (a brake law of vehicle 2 alone; it lowered the joint CV RMSE from 2.41 to
2.22, ledger in the record): the shared law, learned from one value per case with the
contact-friction law not yet right, left a part of vehicle 2's run-out that a per-vehicle
law took up.  We report it as it is; it was seen only in this one run.

Regression check (main part, 240 cases; the 400-case results above):

{md("main", "battery.md")}

{mimic_text}Steering after the impact has no channel yet (an effect's `post_impact` hook sets brake
factors only; the run-out steers by the cases' `post_steer` columns), so the battery has no
steering law; extra rolling drag is a brake factor to the data ("Identification" above).
{end}
"""
anchor = "<!-- /battery -->\n"
s = s.replace(anchor, anchor + "\n" + sec, 1)
doc.write_text(s)
