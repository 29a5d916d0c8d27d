#!/usr/bin/env python3
"""Fits scikit-learn's SVC(kernel="linear") on the rows `cargo bench -p tmo-learn --bench linear_svm`
read, at the C values it used, and prints both side by side: seconds and their ratio,
iterations, the relative distance between the weight vectors and the rows whose predicted
class differs.

    python3 scripts/time_sklearn_linear.py target/bench [MAX_C]

MAX_C skips the larger values of C (libsvm's time grows with C: 417 s at C = 5 here).
"""
import json
import sys
import time

import numpy as np
import pandas as pd
from sklearn.preprocessing import StandardScaler
from sklearn.svm import SVC


def main(folder, max_c=float("inf")):
    df = pd.read_csv(f"{folder}/linear_rows.csv")
    ours = json.load(open(f"{folder}/linear_fits.json"))
    features = [c for c in df.columns if c.startswith("dr_") or c.startswith("dtheta_")]
    x = StandardScaler().fit_transform(df[features].to_numpy(dtype=np.float64))
    y = (df.label == "slip").to_numpy().astype(int)
    print(f"scikit-learn SVC linear, tol 1e-3, cache 200 MB, {len(df)} rows")
    for fit in ours:
        c = fit["C"]
        if c > max_c:
            print(f"  C = {c:>7}: skipped (above {max_c})")
            continue
        t0 = time.perf_counter()
        model = SVC(kernel="linear", C=c, tol=1e-3, cache_size=200).fit(x, y)
        secs = time.perf_counter() - t0
        w_ref = model.coef_.ravel()
        w = np.array(fit["weights"])
        ours_pred = (x @ w - fit["rho"]) > 0
        ref_pred = model.predict(x) == 1
        print(
            f"  C = {c:>7}: scikit-learn {secs:8.3f} s ({int(model.n_iter_.sum())} iterations), "
            f"tmo {fit['seconds']:8.3f} s ({fit['iterations']} iterations"
            f"{'' if fit['converged'] else ', not converged'}): ratio tmo/sklearn "
            f"{fit['seconds'] / secs:.2f}; |w - w_ref| / |w_ref| = "
            f"{np.linalg.norm(w - w_ref) / np.linalg.norm(w_ref):.4f}; "
            f"{int((ours_pred != ref_pred).sum())} of {len(y)} rows predicted differently"
        )


if __name__ == "__main__":
    main(sys.argv[1], *map(float, sys.argv[2:3]))
