"""Insert the steer battery section into docs/diagnosis.md from the committed records."""
import json
from pathlib import Path

R = Path("benchmarks/results/battery_runout_240_quick/steer")
REC = Path("benchmarks/results/reconstruct_steer/reconstruct_steer.json")
doc = Path("docs/diagnosis.md")
s = doc.read_text()
start, end = "<!-- battery-steer -->", "<!-- /battery-steer -->"
i = s.index(start)
s = s[:i - 1 if s[i - 1:i] == "\n" else i] + s[s.index(end) + len(end) + 1:]  # idempotent


def md(part, name):
    """The table of one part's records (battery*.md written by the battery)."""
    p = R / part / name
    return p.read_text().strip() if p.exists() else "(not run)"


def cpu(part, name):
    """Diagnose CPU seconds of a part's records (min, max)."""
    p = R / part / name
    recs = [json.loads(x) for x in p.read_text().splitlines() if x.strip()] if p.exists() else []
    c = [r["diagnose_cpu_s"] for r in recs]
    return (min(c), max(c)) if c else (0.0, 0.0)


lo, hi = cpu(".", "battery_steer.jsonl")
rec_text = ""
if REC.exists():
    m = json.loads(REC.read_text())["summary"]
    k, d = m["known"], m["default"]
    rec_text = (
        "**Reconstructing the steer angles** (`benchmarks/reconstruct_steer.py`, record "
        "`benchmarks/results/reconstruct_steer/`): clean cases steered by 0.3 rad towards each "
        f"car's impact side.  Every other input known: the feasible range holds the truth in "
        f"{k['range_covers']} of {k['pairs']} (case, car) pairs, the median error of the "
        f"optimum is {k['median_abs_error_rad']:.3f} rad (largest {k['max_abs_error_rad']:.3f}), "
        f"the median 5-95 % band {k['median_band_width_rad']:.2f} rad wide.  Under the default "
        f"uncertainties (the brakes known): the range holds it in {d['range_covers']} of "
        f"{d['pairs']}, the 5-95 % band in {d['band_5_95_covers']}; median error "
        f"{d['median_abs_error_rad']:.3f} rad (largest {d['max_abs_error_rad']:.3f}), median "
        f"band {d['median_band_width_rad']:.2f} rad (the prior's: 1.08 rad): with the speeds and "
        "the friction free, a rest pose is reached by more than one steer angle.\n\n")
NOTES = (R / "notes.md").read_text().strip() + "\n\n" if (R / "notes.md").exists() else ""
sec = f"""{start}
### The steer part (issue 36, "steering after impact")

Laws of the front-wheel steer angle after the impact (`benchmarks/battery_laws.py`,
`STEER`, `STEER_PAIRS`; held out: `HELD_OUT_4` and `null6`), written before any run of
them: vehicle 2's front wheels turned away from the impact side by up to 0.4 rad in the
harder crashes (`runout_steer2`), both cars' wheels turned towards their impact side in
side impacts (`runout_steer`, a bell of the impact angle at 90 deg), the first paired with
the restitution law `eps_bell`; held out, vehicle 1's wheels turned away by up to 0.3 rad
with the overlap.  240 cases drawn per database, `--quick`, every library effect and all
sixteen channels, on the project's shared 2-core machine under load (load average 9-14:
the wall times are several times the CPU times; diagnose CPU {lo:.0f}-{hi:.0f} s per
database).  The held-out part was started once, after the singles had finished and while the
pair ran, with no change to the diagnosis in between.  Records:
`benchmarks/results/battery_runout_240_quick/steer/`.

    PYTHONPATH=. python benchmarks/diagnosis_battery.py --out OUT --cases 240 --quick \\
        --steer --jobs 3
    PYTHONPATH=. python benchmarks/diagnosis_battery.py --out OUT/held4 --cases 240 \\
        --quick --held-out-4 --jobs 2
    PYTHONPATH=. python benchmarks/diagnosis_battery.py --out OUT/regress --cases 240 \\
        --quick --runout --only brake_both_severity,corner_lock_speed --jobs 2

Steer part:

{md(".", "battery_steer.md")}

Held out, run once:

{md("held4", "battery_held_out_4.md")}

Regression check with the three steer channels present (run-out part; the results without
them above):

{md("regress", "battery_runout.md")}

{NOTES}{rec_text}{end}
"""
anchor = "<!-- /battery-runout -->\n"
s = s.replace(anchor, anchor + "\n" + sec, 1)
doc.write_text(s)
