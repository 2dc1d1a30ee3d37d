"""Coverage of 95 % intervals of a share: percentile bootstrap vs Wilson (docs/statistics.md).

Run from the repository root: ``python -m examples.share_interval_coverage`` (about 10 s).
"""

import numpy as np

from vfs.analysis.stats import wilson_interval

rng = np.random.default_rng(0)
for n in (20, 100):
    for p in (0.02, 0.1, 0.5, 0.95):
        k = rng.binomial(n, p, 4000)
        boot = rng.binomial(n, (k / n)[:, None], (k.size, 1000)) / n
        lo, hi = np.quantile(boot, [0.025, 0.975], axis=1, method="inverted_cdf")
        wl, wh = wilson_interval(k, n)
        print(f"n={n} p={p}: percentile {np.mean((lo <= p) & (p <= hi)):.3f}  "
              f"wilson {np.mean((wl <= p) & (p <= wh)):.3f}  "
              f"at 0 or n {np.mean((k == 0) | (k == n)):.3f}")
