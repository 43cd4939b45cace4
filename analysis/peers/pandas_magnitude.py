#!/usr/bin/env python3
"""An independent peer of `frictionlab analyze` for magnitude estimation,
in pandas and scipy: the same statistics from the same data CSVs, timed.

    python analysis/peers/pandas_magnitude.py RESULTS_DIR [SUMMARY_JSON]

It reads every `data/*_data.csv` of the folder (completed, non-practice
rows), computes what `summary.json`'s `magnitude_estimation` holds
(definitions in src/kinds/magnitude/analysis.rs and CONTRACT.md):
- `geometric_means`, both normalizations: value, gsd, 95% t interval, n;
- `correlations`: per delta_mu, Pearson r of the displays' per_display
  values across mu_s, with its p;
- `display_ratio` and `display_effect` (a one-sample t test of each
  participant's first-minus-second display mean log answer);
prints the seconds it took (reading, then computing), and, given
frictionlab's `summary.json`, the largest relative difference of each
statistic. It is a development tool (the speed comparison of issue 33),
not a test dependency: `pip install pandas scipy`.

Displays go in the order the protocol's sets have them when a log header
says so; here, as frictionlab does without logs: `order` below, then
alphabetical.
"""

import glob
import json
import math
import os
import sys
import time

import numpy as np
import pandas as pd
from scipy import stats

COLUMNS = ["participant", "status", "practice", "display", "mu_s", "mu_k", "delta_mu", "magnitude"]


def read(folder):
    files = sorted(glob.glob(os.path.join(folder, "data", "*_data.csv")))
    frames = [pd.read_csv(f, usecols=COLUMNS, dtype={"participant": str, "display": str,
                                                     "status": str, "practice": str})
              for f in files]
    rows = pd.concat(frames, ignore_index=True)
    return rows[(rows.status == "completed") & (rows.practice == "false")]


def summary(rows, order):
    # delta_mu as written: the design's levels (issue 42), no rounding.
    rows = rows.assign(ln=np.log(rows.magnitude))
    present = set(rows.display.unique())
    displays = [d for d in order if d in present]
    displays += sorted(present - set(displays))
    grand = rows.ln.mean()
    by_p = rows.groupby("participant").ln.transform("mean")
    by_pd = rows.groupby(["participant", "display"]).ln.transform("mean")
    rows = rows.assign(pooled=rows.ln + grand - by_p, per_display=rows.ln - by_pd)
    means = []
    keys = ["display", "mu_s", "mu_k", "delta_mu"]
    for norm in ["pooled", "per_display"]:
        g = rows.groupby(keys)[norm].agg(["mean", "std", "count"]).reset_index()
        t = stats.t.ppf(0.975, g["count"] - 1)
        half = t * g["std"] / np.sqrt(g["count"])
        g = g.assign(normalization=norm, value=np.exp(g["mean"]), gsd=np.exp(g["std"]),
                     ci_low=np.exp(g["mean"] - half), ci_high=np.exp(g["mean"] + half))
        means.append(g)
    means = pd.concat(means, ignore_index=True)
    correlations = []
    if len(displays) == 2:
        per = means[means.normalization == "per_display"]
        for dm, s in per.groupby("delta_mu"):
            a = s[s.display == displays[0]].set_index("mu_s").value
            b = s[s.display == displays[1]].set_index("mu_s").value
            both = pd.concat([a, b], axis=1, join="inner")
            r, p = stats.pearsonr(both.iloc[:, 0], both.iloc[:, 1])
            correlations.append({"delta_mu": dm, "r": r, "p": p, "n": len(both)})
    pooled = means[means.normalization == "pooled"]
    ratio = None
    effect = None
    if len(displays) == 2:
        gm = lambda d: math.exp(np.log(pooled[pooled.display == d].value).mean())
        ratio = gm(displays[0]) / gm(displays[1])
        per_p = rows.groupby(["participant", "display"]).ln.mean().unstack()
        diff = (per_p[displays[0]] - per_p[displays[1]]).dropna()
        test = stats.ttest_1samp(diff, 0.0)
        effect = {"ratio": math.exp(diff.mean()), "t": test.statistic, "p": test.pvalue,
                  "n": len(diff)}
    return {"displays": displays, "means": means, "correlations": correlations,
            "display_ratio": ratio, "display_effect": effect}


def compare(mine, summary_json):
    theirs = json.load(open(summary_json))["magnitude_estimation"]
    worst = {}

    def note(name, a, b):
        if a is None or b is None:
            return
        d = abs(a - b) / max(abs(b), 1e-300)
        worst[name] = max(worst.get(name, 0.0), d)

    index = {(m["display"], m["mu_s"], m["mu_k"], m["normalization"]): m
             for m in theirs["geometric_means"]}
    for _, m in mine["means"].iterrows():
        t = index[(m.display, m.mu_s, m.mu_k, m.normalization)]
        for k in ["value", "gsd", "ci_low", "ci_high"]:
            note(k, m[k], t[k])
        note("n", m["count"], t["n"])
    cor = {c["delta_mu"]: c for c in theirs["correlations"]}
    for c in mine["correlations"]:
        note("correlation r", c["r"], cor[c["delta_mu"]]["r"])
        note("correlation p", c["p"], cor[c["delta_mu"]]["p"])
    note("display_ratio", mine["display_ratio"], theirs["display_ratio"])
    if mine["display_effect"]:
        for k in ["ratio", "t", "p"]:
            note("display_effect." + k, mine["display_effect"][k], theirs["display_effect"][k])
    return worst


def main():
    folder = sys.argv[1]
    order = ["tactile", "force"]
    t0 = time.perf_counter()
    rows = read(folder)
    t1 = time.perf_counter()
    mine = summary(rows, order)
    t2 = time.perf_counter()
    print(f"pandas {pd.__version__}, scipy: {len(rows)} rows read in {t1 - t0:.3f} s, "
          f"statistics in {t2 - t1:.3f} s, {t2 - t0:.3f} s in all")
    if len(sys.argv) > 2:
        for name, d in sorted(compare(mine, sys.argv[2]).items()):
            print(f"  largest relative difference of {name}: {d:.2e}")


if __name__ == "__main__":
    main()
