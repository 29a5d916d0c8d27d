#!/usr/bin/env python3
"""scikit-learn's GridSearchCV on the rows tmo trains on, for `tmo train --search grid`'s
agreement test (`tests/cli_import.rs`, issue 56).

Reads two feature CSVs written by `tmo dataset export` (training and test trials), fits
GridSearchCV(StandardScaler + SVC(rbf)) over the given C and gamma grids with
GroupKFold(FOLDS) by trial and macro F1 (ties to the first point, C outer, gamma inner, as
tmo's grid), refits the best on every training row, and writes the chosen point, every
point's mean cross-validated macro F1 and the test macro F1 as JSON (a test CSV of `-`: no
test trials, no test macro F1).

    tmo import csv tests/fixtures/xela/xela-4-trials.csv --out xela --split-column split \\
        --units counts --sensor-name xela-uskin-4x4
    tmo dataset export xela/train --n-slip 30 --downsample 1 --out train.csv
    tmo dataset export xela/test --n-slip 30 --downsample 1 --out test.csv
    python3 scripts/sklearn_grid_reference.py train.csv test.csv 3 1,10,100 0.009375,0.03125,0.09375 \\
        tests/fixtures/xela/sklearn_grid_reference.json

and, for `tmo train --fold-assignment group-k-fold` (all four trials in training, so that
GroupKFold(3) puts two trials in one fold and its assignment matters):

    tmo import csv tests/fixtures/xela/xela-4-trials.csv --out xela-all \
        --units counts --sensor-name xela-uskin-4x4
    tmo dataset export xela-all --n-slip 30 --downsample 1 --out all.csv
    python3 scripts/sklearn_grid_reference.py all.csv - 3 1,10,100,1000 0.009375,0.03125,0.09375 \
        tests/fixtures/xela/sklearn_group_k_fold_reference.json

Needs numpy, pandas and scikit-learn (`pip install scikit-learn pandas`). CI does not run
this: the output is committed.
"""
import json
import sys

import numpy as np
import pandas as pd
import sklearn
from sklearn.metrics import f1_score
from sklearn.model_selection import GridSearchCV, GroupKFold
from sklearn.pipeline import Pipeline
from sklearn.preprocessing import StandardScaler
from sklearn.svm import SVC


def rows(path):
    df = pd.read_csv(path)
    features = [c for c in df.columns if c.startswith("dr_") or c.startswith("dtheta_")]
    x = df[features].to_numpy(dtype=np.float64)
    y = (df.label == "slip").to_numpy().astype(int)
    return x, y, df.trial_id.to_numpy()


def main(train_csv, test_csv, folds, cs, gammas, out):
    x, y, groups = rows(train_csv)
    cs = [float(v) for v in cs.split(",")]
    gammas = [float(v) for v in gammas.split(",")]
    pipe = Pipeline([("scale", StandardScaler()), ("svc", SVC(kernel="rbf", tol=1e-3, cache_size=200))])
    grid = GridSearchCV(
        pipe,
        {"svc__C": cs, "svc__gamma": gammas},
        scoring="f1_macro",
        cv=GroupKFold(n_splits=int(folds)),
        refit=True,
    )
    grid.fit(x, y, groups=groups)
    best = grid.best_params_
    test_f1 = None
    test_rows = 0
    if test_csv != "-":
        xt, yt, _ = rows(test_csv)
        test_f1 = float(f1_score(yt, grid.predict(xt), average="macro"))
        test_rows = int(len(yt))
    points = [
        {"C": p["svc__C"], "gamma": p["svc__gamma"], "cv_macro_f1": float(s)}
        for p, s in zip(grid.cv_results_["params"], grid.cv_results_["mean_test_score"])
    ]
    summary = {
        "sklearn": sklearn.__version__,
        "folds": int(folds),
        "train_rows": int(len(y)),
        "test_rows": test_rows,
        "best": {"C": best["svc__C"], "gamma": best["svc__gamma"]},
        "test_macro_f1": test_f1,
        "points": points,
    }
    with open(out, "w") as f:
        json.dump(summary, f, indent=2)
        f.write("\n")
    print(json.dumps({"best": summary["best"], "test_macro_f1": test_f1}))


if __name__ == "__main__":
    main(*sys.argv[1:7])
