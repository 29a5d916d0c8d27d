#!/usr/bin/env python3
"""Times scikit-learn's SVC on the rows `cargo run --release --example bench_rows` wrote (and `cargo bench -p tmo-learn --bench svm_speed` reads), with the same
hyperparameters, sizes and scaling, for comparison with tmo's solver.

    python3 scripts/time_sklearn.py target/bench/svm_rows.csv [CACHE_MB]

CACHE_MB is libsvm's kernel cache (default 4000: at scikit-learn's own default of 200 MB the
cache thrashes from about 20,000 rows, which would flatter tmo). libsvm runs on one thread.
"""
import sys
import time

import numpy as np
import pandas as pd
from sklearn.preprocessing import StandardScaler
from sklearn.svm import SVC

C, GAMMA = 3.989, 0.02


def main(path, cache_mb=4000):
    df = pd.read_csv(path)
    features = [c for c in df.columns if c.startswith("dr_") or c.startswith("dtheta_")]
    x = df[features].to_numpy(dtype=np.float64)
    y = (df.label == "slip").to_numpy().astype(int)
    print(f"scikit-learn SVC rbf, C = {C}, gamma = {GAMMA}, tol 1e-3, cache {cache_mb} MB, {len(df)} rows")
    model = scaler = None
    for n in [2000, 5000, 10000, 20000, len(df)]:
        t0 = time.perf_counter()
        scaler = StandardScaler().fit(x[:n])
        model = SVC(kernel="rbf", C=C, gamma=GAMMA, tol=1e-3, cache_size=cache_mb).fit(scaler.transform(x[:n]), y[:n])
        print(f"  fit {n:>6} rows: {time.perf_counter() - t0:>7.3f} s  ({model.n_support_.sum()} support vectors)")
        if n == 20000:  # per-frame prediction is timed on the 20k-row model, as the bench does
            predictor = (scaler, model)
    scaler, model = predictor
    rows = x[-5000:]
    times = []
    for i in range(20000):
        r = rows[i % len(rows)].reshape(1, -1)
        t0 = time.perf_counter()
        model.decision_function(scaler.transform(r))
        times.append((time.perf_counter() - t0) * 1e6)
    times.sort()
    print(f"  predict one frame: median {times[len(times) // 2]:.1f} us, p99 {times[int(0.99 * (len(times) - 1))]:.1f} us")


if __name__ == "__main__":
    main(sys.argv[1], *map(int, sys.argv[2:3]))
