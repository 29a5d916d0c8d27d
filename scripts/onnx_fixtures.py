#!/usr/bin/env python3
"""ONNX slip models from `tmo dataset export` rows, and onnxruntime's outputs on them: the
fixtures of tmo's ONNX tests (issue 57). `scripts/onnx-fixtures.sh` makes the rows with tmo
on the simulator and runs this in a venv of its own; CI does not run it: what it writes
is committed under tests/fixtures/onnx/.

    python3 scripts/onnx_fixtures.py SPEC.json TRAIN.csv TEST.csv OUT_DIR

SPEC.json is a model file `tmo train` wrote on the same trials and labels: its `features`,
`labels` and `sensors` become the ONNX models' tmo metadata. Writes to OUT_DIR:

- logreg.onnx: StandardScaler + LogisticRegression by skl2onnx (the scaler as Sub and Div,
  the classifier as ai.onnx.ml's LinearClassifier, no ZipMap): slip probability, column 1
  of `probabilities`, threshold 0.5.
- svm_rbf.onnx: StandardScaler + SVC(rbf) as standard ONNX operators (skl2onnx writes an
  SVC as ai.onnx.ml's SVMClassifier, which tract does not run): the SVC's decision
  function, sum_i a_i exp(-gamma |x - sv_i|^2) + b, threshold 0 (slip above it, as
  scikit-learn's predict).
- svm_skl2onnx.onnx: the same SVC as skl2onnx writes it, for the refusal test (tmo names
  SVMClassifier as unsupported).
- window_mlp.onnx: an MLP over the last K = 15 frames of one sensor (input [N, 15, 60]),
  scikit-learn's MLPClassifier on standardised flattened windows, written as Reshape, Sub,
  Div, MatMul, Add, Relu and Sigmoid: slip probability, threshold 0.5.
- frame_mlp.onnx: the same kind of MLP on one frame's features (input [N, 60]).
- mlp_pipeline.onnx: StandardScaler + MLPClassifier as skl2onnx writes the pipeline (no
  hand-written graph): slip probability, column 1 of `probabilities`, threshold 0.5.
- forest.onnx: a RandomForestClassifier (50 trees, depth <= 10) as skl2onnx writes it
  (ai.onnx.ml TreeEnsembleClassifier): column 1 of `probabilities`, threshold 0.5.
- boosted.onnx: a GradientBoostingClassifier (50 trees, depth 3) as skl2onnx writes it (one
  base value and a logistic post-transform for the binary case): column 1 of
  `probabilities`, threshold 0.5.
- window_rows.onnx: the frame MLP applied to every frame of a window of K = 10, input
  [N, 10, 60], output one row per frame `[N, 10, 1]` (tmo.output_rows = per_frame: the newest
  frame's row is the frame's value).
- rows.csv: test rows (two sensors of the first test trial that slips), the inputs of the
  reference outputs, with the features as float32 values written exactly.
- reference.json: onnxruntime's slip value of each model for each row (for the windowed
  model, null where the row has fewer than K consecutive frames of its sensor behind it),
  and the packages' versions.
"""
import json
import sys

import numpy as np
import onnx
import onnxruntime as ort
import pandas as pd
import skl2onnx
import sklearn
from onnx import TensorProto, helper, numpy_helper
from skl2onnx import convert_sklearn
from skl2onnx.common.data_types import FloatTensorType
from sklearn.ensemble import GradientBoostingClassifier, RandomForestClassifier
from sklearn.linear_model import LogisticRegression
from sklearn.neural_network import MLPClassifier
from sklearn.pipeline import Pipeline
from sklearn.preprocessing import StandardScaler
from sklearn.svm import SVC

WINDOW = 15
ROWS_WINDOW = 10
OPSET = 17
SEED = 0


def read(path):
    df = pd.read_csv(path)
    features = [c for c in df.columns if c.startswith("dr_") or c.startswith("dtheta_")]
    x = df[features].to_numpy(dtype=np.float32)
    y = (df.label == "slip").to_numpy().astype(int)
    return df, x, y


def windows(df, x, k):
    """Each row's window of the last k consecutive frames of its trial and sensor (oldest
    first), or None; as tmo forms them (src/slip/onnx.rs, Windows)."""
    out = [None] * len(df)
    prev = {}
    chain = {}
    for i, (t, s, q) in enumerate(zip(df.trial_id, df.sensor, df.seq)):
        key = (t, s)
        j = prev.get(key)
        run = chain[j] + [i] if j is not None and q == df.seq.iloc[j] + 1 else [i]
        chain[i] = run[-k:]
        prev[key] = i
        if len(chain[i]) == k:
            out[i] = np.concatenate([x[r] for r in chain[i]])
    return out


def metadata(model, spec, name, output, column, threshold, window=1, output_rows=None):
    props = {
        "tmo.format": "tmo-onnx-slip-model",
        "tmo.version": "1",
        "tmo.name": name,
        "tmo.features": json.dumps(spec["features"]),
        "tmo.labels": json.dumps(spec["labels"]),
        "tmo.sensors": json.dumps(spec["sensors"]),
        "tmo.window": str(window),
        "tmo.slip_output": output,
        "tmo.slip_column": str(column),
        "tmo.threshold": repr(float(threshold)),
    }
    if output_rows is not None:
        props["tmo.output_rows"] = output_rows
    del model.metadata_props[:]
    for k, v in props.items():
        entry = model.metadata_props.add()
        entry.key, entry.value = k, v
    return model


def const(name, array):
    return numpy_helper.from_array(np.asarray(array), name)


def svm_graph(scaler, svc, features):
    """The SVC's decision function as standard operators, for input [N, F]. The kernel
    sums run in double precision, as scikit-learn's own: in float32, the order in which a
    runtime adds some hundred kernel terms moves the decision by about 1e-5."""
    f64 = np.float64
    inits = [
        const("mean", scaler.mean_.astype(np.float32)),
        const("scale", scaler.scale_.astype(np.float32)),
        const("axis1", np.array([1], dtype=np.int64)),
        const("axis2", np.array([2], dtype=np.int64)),
        const("sv", svc.support_vectors_.astype(f64)[None, :, :]),
        const("neg_gamma", np.array(-svc._gamma, dtype=f64)),
        const("dual", svc.dual_coef_.astype(f64).T),
        const("intercept", svc.intercept_.astype(f64)),
    ]
    nodes = [
        helper.make_node("Sub", ["features", "mean"], ["centred"]),
        helper.make_node("Div", ["centred", "scale"], ["scaled32"]),
        helper.make_node("Cast", ["scaled32"], ["scaled"], to=TensorProto.DOUBLE),
        helper.make_node("Unsqueeze", ["scaled", "axis1"], ["rows"]),
        helper.make_node("Sub", ["rows", "sv"], ["diff"]),
        helper.make_node("Mul", ["diff", "diff"], ["sq"]),
        helper.make_node("ReduceSum", ["sq", "axis2"], ["dist"], keepdims=0),
        helper.make_node("Mul", ["dist", "neg_gamma"], ["arg"]),
        helper.make_node("Exp", ["arg"], ["kernel"]),
        helper.make_node("MatMul", ["kernel", "dual"], ["sum"]),
        helper.make_node("Add", ["sum", "intercept"], ["decision64"]),
        helper.make_node("Cast", ["decision64"], ["decision"], to=TensorProto.FLOAT),
    ]
    graph = helper.make_graph(
        nodes,
        "svm_rbf",
        [helper.make_tensor_value_info("features", TensorProto.FLOAT, ["N", features])],
        [helper.make_tensor_value_info("decision", TensorProto.FLOAT, ["N", 1])],
        inits,
    )
    return helper.make_model(graph, opset_imports=[helper.make_opsetid("", OPSET)])


def mlp_graph(scaler, mlp, features, window, per_frame_rows=False):
    """An MLP (one hidden layer, ReLU, logistic output) for input [N, K, F] (K > 1: the
    window, flattened), or [N, F] (K = 1); with per_frame_rows, the per-frame MLP on each
    frame of a window of K, output [N, K, 1] (one row per frame, oldest first)."""
    (w1, w2), (b1, b2) = mlp.coefs_, mlp.intercepts_
    input_name = "window" if window > 1 else "features"
    output = "frame_probabilities" if per_frame_rows else "slip_probability"
    f32 = np.float32
    inits = [
        const("flat", np.array([-1, window * features], dtype=np.int64)),
        const("mean", scaler.mean_.astype(f32)),
        const("scale", scaler.scale_.astype(f32)),
        const("w1", w1.astype(f32)),
        const("b1", b1.astype(f32)),
        const("w2", w2.astype(f32)),
        const("b2", b2.astype(f32)),
    ]
    flat = [helper.make_node("Reshape", [input_name, "flat"], ["flattened"])]
    nodes = ([] if per_frame_rows else flat) + [
        helper.make_node("Sub", [input_name if per_frame_rows else "flattened", "mean"], ["centred"]),
        helper.make_node("Div", ["centred", "scale"], ["scaled"]),
        helper.make_node("MatMul", ["scaled", "w1"], ["h1"]),
        helper.make_node("Add", ["h1", "b1"], ["h1b"]),
        helper.make_node("Relu", ["h1b"], ["hidden"]),
        helper.make_node("MatMul", ["hidden", "w2"], ["h2"]),
        helper.make_node("Add", ["h2", "b2"], ["logit"]),
        helper.make_node("Sigmoid", ["logit"], [output]),
    ]
    shape = ["N", window, features] if window > 1 else ["N", features]
    graph = helper.make_graph(
        nodes,
        "window_rows" if per_frame_rows else "window_mlp" if window > 1 else "frame_mlp",
        [helper.make_tensor_value_info(input_name, TensorProto.FLOAT, shape)],
        [helper.make_tensor_value_info(output, TensorProto.FLOAT, ["N", window, 1] if per_frame_rows else ["N", 1])],
        inits if not per_frame_rows else inits[1:],
    )
    return helper.make_model(graph, opset_imports=[helper.make_opsetid("", OPSET)])


def run(model, name, inputs):
    session = ort.InferenceSession(model.SerializeToString(), providers=["CPUExecutionProvider"])
    outputs = [o.name for o in session.get_outputs()]
    return dict(zip(outputs, session.run(None, {session.get_inputs()[0].name: inputs})))


def main(spec_path, train_path, test_path, out):
    spec = json.load(open(spec_path))
    train, xtr, ytr = read(train_path)
    test, xte, yte = read(test_path)
    features = xtr.shape[1]
    rng = np.random.default_rng(SEED)

    # per frame: StandardScaler + LogisticRegression, every training row
    logreg = Pipeline([("scaler", StandardScaler()), ("clf", LogisticRegression(C=1.0, max_iter=2000))])
    logreg.fit(xtr, ytr)
    onx = convert_sklearn(
        logreg,
        initial_types=[("features", FloatTensorType([None, features]))],
        options={StandardScaler: {"div": "div"}, LogisticRegression: {"zipmap": False}},
        target_opset={"": OPSET, "ai.onnx.ml": 3},
    )
    models = {"logreg": metadata(onx, spec, "logreg (scikit-learn, skl2onnx)", "probabilities", 1, 0.5)}

    # per frame: StandardScaler + SVC(rbf), on 150 slip rows and as many static rows (a
    # few hundred support vectors: a fixture of some tens of kB)
    slip = rng.choice(np.flatnonzero(ytr == 1), size=150, replace=False)
    static = rng.choice(np.flatnonzero(ytr == 0), size=len(slip), replace=False)
    rows = np.concatenate([slip, static])
    scaler = StandardScaler().fit(xtr[rows])
    svc = SVC(C=1.0, gamma="scale").fit(scaler.transform(xtr[rows]), ytr[rows])
    models["svm_rbf"] = metadata(
        svm_graph(scaler, svc, features), spec, "svm rbf (scikit-learn, standard operators)", "decision", 0, 0.0
    )
    skl_svc = convert_sklearn(
        Pipeline([("scaler", scaler), ("clf", svc)]),
        initial_types=[("features", FloatTensorType([None, features]))],
        options={StandardScaler: {"div": "div"}, SVC: {"zipmap": False}},
        target_opset={"": OPSET, "ai.onnx.ml": 3},
    )
    skl_svc = metadata(skl_svc, spec, "svm rbf (skl2onnx)", "probabilities", 1, 0.5)

    # a window of 15 frames: MLP on standardised flattened windows
    wtr = windows(train, xtr, WINDOW)
    have = [i for i, w in enumerate(wtr) if w is not None]
    xw = np.stack([wtr[i] for i in have])
    yw = ytr[have]
    wscaler = StandardScaler().fit(xw)
    wscaler.scale_ = np.where(wscaler.scale_ > 0, wscaler.scale_, 1.0)
    mlp = MLPClassifier(hidden_layer_sizes=(16,), max_iter=300, random_state=SEED)
    mlp.fit(wscaler.transform(xw), yw)
    models["window_mlp"] = metadata(
        mlp_graph(wscaler, mlp, features, WINDOW), spec, "window mlp, 15 frames (scikit-learn)", "slip_probability", 0, 0.5, WINDOW
    )

    # per frame: the same MLP on one frame's features, every training row
    fscaler = StandardScaler().fit(xtr)
    fscaler.scale_ = np.where(fscaler.scale_ > 0, fscaler.scale_, 1.0)
    fmlp = MLPClassifier(hidden_layer_sizes=(16,), max_iter=300, random_state=SEED)
    fmlp.fit(fscaler.transform(xtr), ytr)
    models["frame_mlp"] = metadata(
        mlp_graph(fscaler, fmlp, features, 1), spec, "frame mlp (scikit-learn)", "slip_probability", 0, 0.5
    )

    # per frame: StandardScaler + MLPClassifier, the pipeline as skl2onnx writes it
    pipe = Pipeline([("scaler", StandardScaler()), ("clf", MLPClassifier(hidden_layer_sizes=(16,), max_iter=300, random_state=SEED))])
    pipe.fit(xtr, ytr)
    onx = convert_sklearn(
        pipe,
        initial_types=[("features", FloatTensorType([None, features]))],
        options={StandardScaler: {"div": "div"}, MLPClassifier: {"zipmap": False}},
        target_opset={"": OPSET, "ai.onnx.ml": 3},
    )
    models["mlp_pipeline"] = metadata(onx, spec, "mlp pipeline (skl2onnx)", "probabilities", 1, 0.5)

    # tree ensembles as skl2onnx writes them (ai.onnx.ml TreeEnsembleClassifier)
    forest = RandomForestClassifier(n_estimators=50, max_depth=10, min_samples_leaf=3, random_state=SEED, n_jobs=1)
    forest.fit(xtr, ytr)
    onx = convert_sklearn(
        forest,
        initial_types=[("features", FloatTensorType([None, features]))],
        options={RandomForestClassifier: {"zipmap": False}},
        target_opset={"": OPSET, "ai.onnx.ml": 3},
    )
    models["forest"] = metadata(onx, spec, "random forest, 50 trees (skl2onnx)", "probabilities", 1, 0.5)
    boosted = GradientBoostingClassifier(n_estimators=50, max_depth=3, random_state=SEED)
    boosted.fit(xtr, ytr)
    onx = convert_sklearn(
        boosted,
        initial_types=[("features", FloatTensorType([None, features]))],
        options={GradientBoostingClassifier: {"zipmap": False}},
        target_opset={"": OPSET, "ai.onnx.ml": 3},
    )
    models["boosted"] = metadata(onx, spec, "gradient boosting, 50 trees (skl2onnx)", "probabilities", 1, 0.5)

    # a window of 10 frames, one output row per frame (the newest is the frame's value)
    models["window_rows"] = metadata(
        mlp_graph(fscaler, fmlp, features, ROWS_WINDOW, per_frame_rows=True), spec, "frame mlp on each frame of 10", "frame_probabilities", 0, 0.5,
        ROWS_WINDOW, "per_frame",
    )

    # the rows of the reference: two sensors of the first test trial that slips, the 100
    # frames before each sensor's first slip row and the 20 from it
    first = test.trial_id[test.label == "slip"].iloc[0]
    keep = []
    for sensor in (0, 1):
        own = test.index[(test.trial_id == first) & (test.sensor == sensor)].to_numpy()
        onset = int(np.flatnonzero(test.label[own] == "slip")[0])
        keep.extend(own[max(0, onset - 100) : onset + 20])
    sub = test.loc[keep].reset_index(drop=True)
    # features rounded to 6 significant digits, so that the committed text is the input
    # exactly: the references are computed on the float32 values the text reads back as
    columns = [c for c in sub.columns if c.startswith("dr_") or c.startswith("dtheta_")]
    xs = np.array([[float(f"{v:.6g}") for v in row] for row in xte[keep]], dtype=np.float32)
    sub[columns] = xs
    sub.to_csv(f"{out}/rows.csv", index=False, float_format="%.6g")
    reference = {
        "versions": {
            "numpy": np.__version__,
            "scikit-learn": sklearn.__version__,
            "onnx": onnx.__version__,
            "onnxruntime": ort.__version__,
            "skl2onnx": skl2onnx.__version__,
        },
        "rows": len(sub),
        "models": {},
    }
    for name, model in models.items():
        onnx.checker.check_model(model)
        onnx.save(model, f"{out}/{name}.onnx")
        props = {p.key: p.value for p in model.metadata_props}
        output, column = props["tmo.slip_output"], int(props["tmo.slip_column"])
        if name in ("window_mlp", "window_rows"):
            k = WINDOW if name == "window_mlp" else ROWS_WINDOW
            ws = windows(sub, xs, k)
            have = [i for i, w in enumerate(ws) if w is not None]
            got = run(model, name, np.stack([ws[i] for i in have]).reshape(-1, k, features))[output]
            # one row per window, or (per_frame) the newest frame's row of each
            got = got[:, -1, :] if got.ndim == 3 else got
            values = [None] * len(sub)
            for i, v in zip(have, got[:, column]):
                values[i] = float(v)
        else:
            values = [float(v) for v in run(model, name, xs)[output][:, column]]
        reference["models"][name] = {
            "threshold": float(props["tmo.threshold"]),
            "values": values,
        }
        print(f"{name}: {sum(v is not None for v in values)} reference values")
    onnx.save(skl_svc, f"{out}/svm_skl2onnx.onnx")
    json.dump(reference, open(f"{out}/reference.json", "w"), indent=1)
    print(f"SVC support vectors: {len(svc.support_vectors_)}; MLP windows: {len(xw)}")


if __name__ == "__main__":
    main(*sys.argv[1:5])
