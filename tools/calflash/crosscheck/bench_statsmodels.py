#!/usr/bin/env python3
"""Times statsmodels on the design of calflash's fit benchmark (benches/fit.rs): OLS, then
every OLSInfluence diagnostic calflash reports (leverage, both studentized residuals, Cook's
distance, DFFITS, DFBETAS), for n = 10^4, 10^5, 10^6 by 10 terms.

statsmodels computes DFBETAS (and, through them, the summary frame) by refitting without each
observation in turn, which is O(n^2 p^2): sizes whose estimated time exceeds --budget seconds are
not run, and the estimate (from the largest size run, scaled by n^2) is printed instead.

    python3 tools/calflash/crosscheck/bench_statsmodels.py [--budget 120]
"""

import argparse
import time

import numpy as np
import statsmodels.api as sm
from statsmodels.stats.outliers_influence import OLSInfluence


def data(n, seed=0x2545F4914F6CDD1D):
    """The same xorshift sequence and design as benches/fit.rs."""
    state = seed
    mask = (1 << 64) - 1

    def uniform():
        nonlocal state
        state ^= (state << 13) & mask
        state ^= state >> 7
        state ^= (state << 17) & mask
        return (state >> 11) / float(1 << 53) * 2.0 - 1.0

    X = np.empty((n, 10))
    y = np.empty(n)
    for i in range(n):
        a, b, c, d, e = (uniform() for _ in range(5))
        X[i] = (1.0, a, b, c, d, e, a * a, b * b, a * b, c * abs(c))
        y[i] = 2.5 + 0.4 * a - 0.3 * b + 0.05 * c + 0.01 * a * a + 1e-3 * uniform()
    return X, y


def closed_form(X, y):
    """The fit and the diagnostics statsmodels computes in closed form."""
    res = sm.OLS(y, X).fit()
    inf = OLSInfluence(res)
    return [res.params, res.bse, res.pvalues, res.conf_int(), inf.hat_matrix_diag,
            inf.resid_studentized_internal, inf.cooks_distance[0]]


def everything(X, y):
    """Every diagnostic calflash reports: the externally studentized residuals, DFFITS and
    DFBETAS come from leave-one-out refits in statsmodels."""
    res = sm.OLS(y, X).fit()
    inf = OLSInfluence(res)
    return closed_form(X, y) + [inf.resid_studentized_external, inf.dffits[0], inf.dfbetas]


def timed(f, *args):
    start = time.perf_counter()
    f(*args)
    return time.perf_counter() - start


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--budget", type=float, default=120.0, help="seconds per size at most")
    args = ap.parse_args()
    measured = None
    for n in (10_000, 100_000, 1_000_000):
        X, y = data(n)
        print(f"statsmodels n={n}, fit + closed-form diagnostics (no external studentized, DFFITS, DFBETAS): {timed(closed_form, X, y):.3f} s")
        if measured is not None:
            n0, t0 = measured
            estimate = t0 * (n / n0) ** 2
            if estimate > args.budget:
                print(f"statsmodels n={n}, every diagnostic: not run; estimated {estimate:.0f} s (O(n^2) from n={n0})")
                continue
        t = timed(everything, X, y)
        print(f"statsmodels n={n}, every diagnostic: {t:.3f} s")
        measured = (n, t)

if __name__ == "__main__":
    main()
