#!/usr/bin/env python3
"""Reference outputs for calflash's regression engine, from statsmodels (an independent
implementation: OLS by pinv/SVD, OLSInfluence with leave-one-out refits), and from the same
formulas evaluated in 50-digit arithmetic with mpmath (the truth both are held to).

Writes, for each dataset, tests/data/<name>.csv (the observations) and
tests/data/<name>.reference.json (the model formula, statsmodels' numbers under
"statsmodels", the 50-digit values under "exact"). The Rust test tests/crosscheck.rs fits the
same formula with calflash and requires agreement to 1e-9 relative with both. statsmodels'
DFBETAS come from leave-one-out refits, whose cancellation costs it up to a few 1e-9 on the
nearly collinear sets; the file records that error ("statsmodels_dfbetas_error") so the test
can say which side is off. Regenerate (needs numpy, scipy, statsmodels, mpmath from PyPI):

    python3 tools/calflash/crosscheck/statsmodels_reference.py

The datasets are seeded, so a rerun reproduces the files exactly on the same library versions.
"""

import json
import pathlib

import mpmath as mp
import numpy as np
import statsmodels
import statsmodels.api as sm
from statsmodels.sandbox.stats.runs import runstest_1samp
from statsmodels.stats.outliers_influence import OLSInfluence, variance_inflation_factor
from statsmodels.stats.stattools import durbin_watson

OUT = pathlib.Path(__file__).resolve().parent.parent / "tests" / "data"


def design(columns, terms, intercept):
    """The model matrix: intercept first, then each term as a product of factors."""
    n = len(next(iter(columns.values())))
    cols = [np.ones(n)] if intercept else []
    for term in terms:
        v = np.ones(n)
        for var, absolute, power in term:
            x = columns[var]
            v = v * (np.abs(x) if absolute else x) ** power
        cols.append(v)
    return np.column_stack(cols)


def exact(X, y, intercept, predict_rows):
    """The OLS quantities in 50-digit arithmetic, by the textbook formulas."""
    mp.mp.dps = 50
    n, p = X.shape
    Xm = mp.matrix([[mp.mpf(float(v)) for v in row] for row in X])
    ym = mp.matrix([mp.mpf(float(v)) for v in y])
    C = (Xm.T * Xm) ** -1
    b = C * (Xm.T * ym)
    e = ym - Xm * b
    rss = sum(v**2 for v in e)
    dof = n - p
    s2 = rss / dof
    se = [mp.sqrt(s2 * C[j, j]) for j in range(p)]
    t = [b[j] / se[j] for j in range(p)]
    pv = [mp.betainc(dof / mp.mpf(2), mp.mpf(1) / 2, 0, dof / (dof + tj**2), regularized=True) for tj in t]
    if intercept:
        mean = sum(ym) / n
        tss = sum((v - mean) ** 2 for v in ym)
    else:
        tss = sum(v**2 for v in ym)
    hat, si, se_, cook, dff, dfb = [], [], [], [], [], []
    for i in range(n):
        xi = Xm[i, :]
        h = (xi * C * xi.T)[0]
        r = e[i] / mp.sqrt(s2 * (1 - h))
        s2i = (rss - e[i] ** 2 / (1 - h)) / (dof - 1)
        ti = e[i] / mp.sqrt(s2i * (1 - h))
        cx = C * xi.T
        hat.append(h)
        si.append(r)
        se_.append(ti)
        cook.append(r**2 * h / (p * (1 - h)))
        dff.append(ti * mp.sqrt(h / (1 - h)))
        dfb.append([cx[j] * e[i] / (1 - h) / mp.sqrt(s2i * C[j, j]) for j in range(p)])
    preds = []
    for row in predict_rows:
        x0 = mp.matrix([[mp.mpf(float(v)) for v in row]])
        var = s2 * (x0 * C * x0.T)[0]
        preds.append({"value": float((x0 * b)[0]), "variance": float(var), "observation_variance": float(var + s2)})
    f = lambda v: [float(x) for x in v]
    return {
        "params": f(b),
        "bse": f(se),
        "tvalues": f(t),
        "pvalues": f(pv),
        "cov_params": [[float(s2 * C[i, j]) for j in range(p)] for i in range(p)],
        "ssr": float(rss),
        "scale": float(s2),
        "rsquared": float(1 - rss / tss),
        "resid": f(e),
        "hat": f(hat),
        "student_internal": f(si),
        "student_external": f(se_),
        "cooks_distance": f(cook),
        "dffits": f(dff),
        "dfbetas": [f(r) for r in dfb],
        "predictions": preds,
    }


PER_TERM = ["params", "bse", "tvalues", "pvalues"]
PER_OBS = ["resid", "hat", "student_internal", "student_external", "cooks_distance", "dffits"]


def rel_error(got, want, floor):
    got, want = np.asarray(got, float), np.asarray(want, float)
    return float(np.max(np.abs(got - want) / np.maximum(np.abs(want), floor)))


def statsmodels_errors(sm_ref, truth):
    """statsmodels' relative error against the exact values, by the rules of the Rust test:
    per-term vectors with a floor of 1e-6 of their largest entry, per-observation vectors with
    the RMS of each column as the floor."""
    out = {}
    for k in PER_TERM + ["cov_params"]:
        w = np.asarray(truth[k], float)
        out[k] = rel_error(sm_ref[k], w, 1e-6 * np.max(np.abs(w)))
    for k in ["ssr", "scale", "rsquared"]:
        out[k] = rel_error([sm_ref[k]], [truth[k]], 0.0)
    for k in PER_OBS + ["dfbetas"]:
        w = np.asarray(truth[k], float)
        rms = np.sqrt(np.mean(w * w, axis=0))
        out[k] = rel_error(sm_ref[k], w, rms)
    pv = [[p[k] for k in ("value", "variance", "observation_variance")] for p in sm_ref["predictions"]]
    pe = [[p[k] for k in ("value", "variance", "observation_variance")] for p in truth["predictions"]]
    out["predictions"] = rel_error(pv, pe, 0.0) if pv else 0.0
    return out


def write_case(name, formula, columns, terms, intercept, predict_at, reduced=None):
    OUT.mkdir(parents=True, exist_ok=True)
    names = list(columns)
    with open(OUT / f"{name}.csv", "w") as f:
        f.write(",".join(names) + "\n")
        for row in zip(*columns.values()):
            f.write(",".join(repr(float(v)) for v in row) + "\n")
    response = formula.split("~")[0].strip()
    y = columns[response]
    X = design(columns, terms, intercept)
    res = sm.OLS(y, X).fit()
    inf = OLSInfluence(res)
    ci = res.conf_int(0.05)
    first = 1 if intercept else 0
    vif = [None] * first + [variance_inflation_factor(X, j) for j in range(first, X.shape[1])]
    z, p_runs = runstest_1samp(res.resid, cutoff=0, correction=False)
    preds = []
    for point in predict_at:
        x0 = design({k: np.array([v]) for k, v in point.items()}, terms, intercept)
        pr = res.get_prediction(x0)
        preds.append(
            {
                "at": point,
                "value": float(pr.predicted_mean[0]),
                "variance": float(pr.se_mean[0] ** 2),
                "observation_variance": float(pr.se_obs[0] ** 2),
            }
        )
    rows = [design({k: np.array([v]) for k, v in pt.items()}, terms, intercept)[0] for pt in predict_at]
    truth = exact(X, y, intercept, rows)
    sm_ref = {
        "n": int(res.nobs),
        "params": res.params.tolist(),
        "bse": res.bse.tolist(),
        "tvalues": res.tvalues.tolist(),
        "pvalues": res.pvalues.tolist(),
        "ci_lower": ci[:, 0].tolist(),
        "ci_upper": ci[:, 1].tolist(),
        "cov_params": res.cov_params().tolist(),
        "ssr": res.ssr,
        "scale": res.scale,
        "rsquared": res.rsquared,
        "rsquared_adj": res.rsquared_adj,
        "fvalue": float(res.fvalue),
        "f_pvalue": float(res.f_pvalue),
        "llf": res.llf,
        "aic": res.aic,
        "bic": res.bic,
        "condition_number_svd": float(np.linalg.cond(X)),
        "vif": vif,
        "durbin_watson": float(durbin_watson(res.resid)),
        "runs_z": float(z),
        "runs_p": float(p_runs),
        "resid": res.resid.tolist(),
        "hat": inf.hat_matrix_diag.tolist(),
        "student_internal": inf.resid_studentized_internal.tolist(),
        "student_external": inf.resid_studentized_external.tolist(),
        "cooks_distance": inf.cooks_distance[0].tolist(),
        "dffits": inf.dffits[0].tolist(),
        "dfbetas": inf.dfbetas.tolist(),
        "predictions": preds,
    }
    errors = statsmodels_errors(sm_ref, truth)
    ref = {
        "source": f"statsmodels {statsmodels.__version__}, numpy {np.__version__}, mpmath {mp.__version__}",
        "formula": formula,
        "statsmodels_error": errors,
        "statsmodels": sm_ref,
        "exact": truth,
    }
    if reduced is not None:
        r_formula, r_terms, r_intercept = reduced
        r_res = sm.OLS(y, design(columns, r_terms, r_intercept)).fit()
        f, p, df = res.compare_f_test(r_res)
        ref["compare"] = {"formula": r_formula, "f": float(f), "p": float(p), "df_num": int(df)}
    with open(OUT / f"{name}.reference.json", "w") as f:
        json.dump(ref, f, indent=1)
    worst = {k: v for k, v in errors.items() if v > 1e-9}
    print(
        f"{name}: n = {int(res.nobs)}, p = {X.shape[1]}, condition number {np.linalg.cond(X):.3g}; "
        f"statsmodels beyond 1e-9 of the exact values: {worst or 'nothing'}"
    )


def main():
    rng = np.random.default_rng(20261122)

    # 1. A single-axis accelerometer tumbled on a dividing head: input g cos(angle), with
    #    g-squared and cubic terms.
    angles = np.deg2rad(np.tile(np.arange(0, 360, 15), 3))
    a = 9.80665 * np.cos(angles)
    volts = 2.5 + 0.0408 * (a + 1.5e-4 * a**2 - 4e-6 * a**3) + rng.normal(0, 2e-5, a.size)
    write_case(
        "tumble_cubic",
        "volts ~ 1 + a + a^2 + a^3",
        {"a": a, "volts": volts},
        [[("a", False, 1)], [("a", False, 2)], [("a", False, 3)]],
        True,
        [{"a": 0.0}, {"a": 9.80665}, {"a": -15.0}],
        reduced=("volts ~ 1 + a", [[("a", False, 1)]], True),
    )

    # 2. A rate table with temperature steps and one outlier (a slipped reading), with the
    #    odd-quadratic term rate:abs(rate).
    rate = np.repeat(np.linspace(-600, 600, 21), 4)
    temp = np.tile([-20.0, 10.0, 40.0, 70.0], 21)
    noise = rng.normal(0, 1e-3, rate.size)
    out = 2.5 + 0.004 * rate + 3e-8 * rate * np.abs(rate) + 2e-4 * (temp - 25) + noise
    out[37] += 0.012
    write_case(
        "rate_outlier",
        "out ~ 1 + rate + rate:abs(rate) + temp",
        {"rate": rate, "temp": temp, "out": out},
        [[("rate", False, 1)], [("rate", False, 1), ("rate", True, 1)], [("temp", False, 1)]],
        True,
        [{"rate": 100.0, "temp": 25.0}, {"rate": -900.0, "temp": 85.0}],
        reduced=("out ~ 1 + rate + temp", [[("rate", False, 1)], [("temp", False, 1)]], True),
    )

    # 3. A thermal run where the supply voltage sagged with temperature: nearly collinear.
    temp = np.repeat(np.linspace(-40, 85, 20), 3)
    supply = 5.0 - 0.004 * (temp - 25) + rng.normal(0, 4e-4, temp.size)
    rate = np.tile([-300.0, 0.0, 300.0], 20)
    v = 1.0 + 0.002 * rate + 3e-4 * temp + 0.05 * supply + rng.normal(0, 5e-4, temp.size)
    write_case(
        "collinear_thermal",
        "v ~ 1 + rate + temp + supply",
        {"rate": rate, "temp": temp, "supply": supply, "v": v},
        [[("rate", False, 1)], [("temp", False, 1)], [("supply", False, 1)]],
        True,
        [{"rate": 150.0, "temp": 25.0, "supply": 5.0}],
    )

    # 4. A model without intercept (uncentered R^2 and VIF).
    x = np.linspace(-3, 3, 31)
    y = 0.7 * x + 0.05 * x**2 + rng.normal(0, 0.02, x.size)
    write_case(
        "no_intercept",
        "y ~ 0 + x + x^2",
        {"x": x, "y": y},
        [[("x", False, 1)], [("x", False, 2)]],
        False,
        [{"x": 1.5}],
    )


if __name__ == "__main__":
    main()
