#!/usr/bin/env python3
"""onnxruntime's cost per frame for the per-frame ONNX fixtures, the anchor of
`cargo bench --bench onnx_latency` (which times tmo on the same rows and prints the ratio).

    python3 scripts/time_onnxruntime.py [OUT.json]

Runs each fixture of tests/fixtures/onnx on every row of rows.csv at batch 1, 20 times,
one thread (as tmo runs a frame), and prints the median and p99 in microseconds with the
versions and the machine as JSON; given OUT.json it writes them there too (the committed
anchor is tests/fixtures/onnx/onnxruntime_timing.json: name it to renew it).
Run it on the machine the bench runs on, in the same session: the ratio is the figure.
"""
import json
import os
import platform
import sys
import time

import numpy as np
import onnxruntime as ort
import pandas as pd

HERE = os.path.join(os.path.dirname(__file__), "..", "tests", "fixtures", "onnx")
MODELS = ["logreg", "svm_rbf", "frame_mlp", "mlp_pipeline", "forest", "boosted"]


def main(out):
    df = pd.read_csv(os.path.join(HERE, "rows.csv"))
    x = df[[c for c in df.columns if c.startswith(("dr_", "dtheta_"))]].to_numpy("float32")
    options = ort.SessionOptions()
    options.intra_op_num_threads = 1
    options.inter_op_num_threads = 1
    result = {
        "onnxruntime": ort.__version__,
        "machine": f"{platform.machine()}, {os.cpu_count()} cores, {platform.processor() or platform.platform()}",
        "rows": len(x),
        "models": {},
    }
    for name in MODELS:
        session = ort.InferenceSession(os.path.join(HERE, f"{name}.onnx"), options, providers=["CPUExecutionProvider"])
        feed = session.get_inputs()[0].name
        for i in range(100):  # warm up
            session.run(None, {feed: x[i % len(x)][None, :]})
        times = []
        for _ in range(20):
            for row in x:
                t = time.perf_counter()
                session.run(None, {feed: row[None, :]})
                times.append((time.perf_counter() - t) * 1e6)
        times = np.sort(times)
        result["models"][name] = {
            "median_us": round(float(np.median(times)), 2),
            "p99_us": round(float(times[int(0.99 * len(times))]), 2),
        }
        print(name, result["models"][name])
    print(json.dumps(result, indent=1))
    if out:
        json.dump(result, open(out, "w"), indent=1)
        print(f"wrote {out}")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else None)
