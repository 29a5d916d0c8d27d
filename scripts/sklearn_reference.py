#!/usr/bin/env python3
"""Reference predictions from scikit-learn for tmo's classifier tests.

Reads a feature CSV written by `tmo dataset export`, splits it by trial (the first half of
the trial ids, sorted, for training; the rest for testing), standardises on the training
rows, fits scikit-learn's SVC (RBF), SVC (linear) and LogisticRegression at fixed
hyperparameters, and writes, for every test row, each model's decision value and prediction.
tmo-learn's test `learn/tests/sklearn_agreement.rs` fits its own models on the same rows and compares.

    python3 scripts/sklearn_reference.py learn/tests/fixtures/slip_features.csv learn/tests/fixtures/sklearn_reference.csv

Needs numpy, pandas and scikit-learn (`pip install scikit-learn pandas`). CI does not run
this: the output is committed.
"""
import json
import sys

import numpy as np
import pandas as pd
import sklearn
from sklearn.linear_model import LogisticRegression
from sklearn.metrics import f1_score
from sklearn.preprocessing import StandardScaler
from sklearn.svm import SVC

MODELS = {
    "svm_rbf": lambda: SVC(kernel="rbf", C=3.989, gamma=0.02, tol=1e-3, cache_size=200),
    "svm_linear": lambda: SVC(kernel="linear", C=0.1, tol=1e-3, cache_size=200),
    "logreg": lambda: LogisticRegression(C=1.0, tol=1e-10, max_iter=10000),
}
PARAMS = {
    "svm_rbf": {"C": 3.989, "gamma": 0.02},
    "svm_linear": {"C": 0.1},
    "logreg": {"C": 1.0},
}


def main(inp, out):
    df = pd.read_csv(inp)
    features = [c for c in df.columns if c.startswith("dr_") or c.startswith("dtheta_")]
    trials = sorted(df.trial_id.unique())
    train_trials = set(trials[: len(trials) // 2])
    train = df.trial_id.isin(train_trials).to_numpy()
    x = df[features].to_numpy(dtype=np.float64)
    y = (df.label == "slip").to_numpy().astype(int)
    scaler = StandardScaler().fit(x[train])
    xs = scaler.transform(x)
    result = pd.DataFrame({"row": np.nonzero(~train)[0], "label": y[~train]})
    summary = {"sklearn": sklearn.__version__, "train_rows": int(train.sum()), "test_rows": int((~train).sum()),
               "train_trials": sorted(train_trials), "models": {}}
    for name, make in MODELS.items():
        model = make().fit(xs[train], y[train])
        decision = model.decision_function(xs[~train])
        predicted = model.predict(xs[~train])
        result[f"{name}_decision"] = decision
        result[f"{name}_predicted"] = predicted
        summary["models"][name] = {
            "params": PARAMS[name],
            "macro_f1": float(f1_score(y[~train], predicted, average="macro")),
            "support_vectors": int(getattr(model, "n_support_", [0, 0]).sum()) if hasattr(model, "n_support_") else None,
        }
    result.to_csv(out, index=False, float_format="%.6g")
    with open(out.replace(".csv", ".json"), "w") as f:
        json.dump(summary, f, indent=2)
    print(json.dumps(summary["models"], indent=2))


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
