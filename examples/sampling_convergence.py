"""Band accuracy against samples per case, plain Monte Carlo vs QMC (docs/uncertainty.md).

Runs the benchmark ``vfs bench uncertainty_sampling`` (about 30 s; ``--quick``: 6 s) and draws
``docs/figures/uncertainty_sampling_convergence.png``.  From the repository root:
``python -m examples.sampling_convergence [--quick]``.
"""

import sys
from pathlib import Path

import numpy as np

from vfs.bench.uncertainty import bench_uncertainty_sampling
from vfs.report.figures import new_figure, save_figure
from vfs.uncertainty.sampling import SAMPLING_METHODS

res = bench_uncertainty_sampling("--quick" in sys.argv)
sizes = np.asarray(res["sizes"])
fig = new_figure((5.5, 4.0))
ax = fig.add_subplot()
for method, marker in zip(SAMPLING_METHODS, "osd", strict=True):
    err = 100 * np.asarray(res[f"{method}_band_error"])
    ax.loglog(sizes, err, marker=marker, label=method)
    print(method, " ".join(f"{s}:{e:.2f}%" for s, e in zip(sizes, err, strict=True)))
ax.loglog(sizes, 100 * res["random_band_error"][0] * np.sqrt(sizes[0] / sizes), "k:", lw=1,
          label="slope -1/2")
ax.axhline(5, color="grey", lw=0.8, ls="--")
ax.axhline(3, color="grey", lw=0.8, ls="--")
ax.set_xlabel("samples per case")
ax.set_ylabel("error of the 5-95 % band ends [% of band width]")
ax.set_title(f"{res['cases']} cases, reference {res['reference_samples']} random samples",
             fontsize=9)
ax.legend()
out = Path(__file__).resolve().parents[1] / "docs" / "figures"
save_figure(fig, out / "uncertainty_sampling_convergence.png", tight=True)
