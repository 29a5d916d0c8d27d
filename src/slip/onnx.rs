//! Slip models brought from elsewhere as ONNX files (scikit-learn through skl2onnx, PyTorch,
//! hand-built graphs), run by tract, a pure-Rust runtime: nothing is downloaded at build or
//! run time. A model reads one sensor's per-frame features (input `[1, F]`) or the last K
//! frames' features of one sensor (input `[1, K, F]`), and gives a slip probability, score
//! or class; tmo's own metadata travels in the file's `metadata_props` (keys `tmo.*`,
//! docs/onnx.md) and is checked against the graph here and against the data where the
//! model is used, as a model file of tmo's own is.
//!
//! The model is global: the one graph classifies every sensor's frames (a window never
//! mixes sensors).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use tract_onnx::pb;
use tract_onnx::prelude::*;

use super::dataset::{Dataset, LabelSpec};
use super::features::FeatureSpec;
use super::Class;

/// `tmo.format` of a slip model.
pub const ONNX_FORMAT: &str = "tmo-onnx-slip-model";
/// The newest `tmo.version` this build reads.
pub const ONNX_FORMAT_VERSION: u32 = 1;
/// Longest window a model may ask for: 10 s at 60 fps (a longer one is a mistake, and its
/// input would not fit a trial).
pub const MAX_WINDOW: usize = 600;

#[derive(Debug, thiserror::Error)]
pub enum OnnxError {
    #[error("{path}: cannot read: {source}")]
    Io {
        path: String,
        source: std::io::Error,
    },
    #[error("{path}: not an ONNX model ({message})")]
    Decode { path: String, message: String },
    #[error("{path}: operator(s) {} not supported by tmo's ONNX runtime (tract {}): it runs the standard ONNX operators and, of ai.onnx.ml, LinearClassifier, LinearRegressor, Normalizer, TreeEnsembleClassifier and CategoryMapper; export the model without them (docs/onnx.md: a scikit-learn SVC's decision function as standard operators, say)", .operators.join(", "), TRACT_VERSION)]
    UnsupportedOperators {
        path: String,
        operators: Vec<String>,
    },
    #[error("{path}: metadata `{field}`: expected {expected}, found {found} (docs/onnx.md lists tmo's metadata_props)")]
    Metadata {
        path: String,
        field: String,
        expected: String,
        found: String,
    },
    #[error("{path}: {what}: expected {expected}, found {found}")]
    Shape {
        path: String,
        what: String,
        expected: String,
        found: String,
    },
    #[error("{path}: the ONNX runtime refused the model: {message}")]
    Runtime { path: String, message: String },
}

/// The tract release tmo runs models with, for messages.
const TRACT_VERSION: &str = "0.23";

/// tmo's metadata of a model, from its `tmo.*` metadata_props.
#[derive(Debug, Clone, PartialEq)]
pub struct OnnxMeta {
    /// The per-frame features the model reads (as a model file of tmo's own records them).
    pub features: FeatureSpec,
    /// The labels it was trained with (evaluate labels the data the same way).
    pub labels: LabelSpec,
    /// The sensors it was trained on.
    pub sensors: Vec<u8>,
    /// Frames per input: 1 for a per-frame model, K for a window of the last K frames.
    pub window: usize,
    /// The output that says slip, and the column of its last axis that does.
    pub slip_output: String,
    pub slip_column: usize,
    /// Slip where that value is at least this (a probability's 0.5, a class label's 1).
    pub threshold: f32,
    /// What the model is, for tables (`tmo.name`, else the file's stem).
    pub name: String,
}

type Plan = Arc<TypedRunnableModel>;

/// A loaded ONNX slip model, ready to classify.
#[derive(Debug, Clone)]
pub struct OnnxModel {
    pub path: PathBuf,
    pub meta: OnnxMeta,
    plan: Plan,
    /// Index of the slip output among the graph's outputs.
    output: usize,
}

impl OnnxModel {
    /// Reads, checks and prepares `path`: every refusal names the file, what was expected
    /// and what was found.
    pub fn load(path: &Path) -> Result<Self, OnnxError> {
        let p = path.display().to_string();
        let bytes = std::fs::read(path).map_err(|source| OnnxError::Io {
            path: p.clone(),
            source,
        })?;
        let onnx = tract_onnx::onnx();
        let proto = onnx
            .proto_model_for_read(&mut bytes.as_slice())
            .map_err(|e| OnnxError::Decode {
                path: p.clone(),
                message: e.to_string(),
            })?;
        let graph = proto.graph.as_ref().ok_or_else(|| OnnxError::Decode {
            path: p.clone(),
            message: "no graph".into(),
        })?;
        let unsupported = unsupported_operators(graph, &onnx);
        if !unsupported.is_empty() {
            return Err(OnnxError::UnsupportedOperators {
                path: p,
                operators: unsupported,
            });
        }
        let props: BTreeMap<&str, &str> = proto
            .metadata_props
            .iter()
            .map(|e| (e.key.as_str(), e.value.as_str()))
            .collect();
        let meta = read_meta(&p, path, &props)?;
        let input = only_input(&p, graph)?;
        check_input_shape(&p, input, &meta)?;
        let output = graph
            .output
            .iter()
            .position(|o| o.name == meta.slip_output)
            .ok_or_else(|| OnnxError::Metadata {
                path: p.clone(),
                field: "tmo.slip_output".into(),
                expected: format!(
                    "one of the graph's outputs ({})",
                    graph
                        .output
                        .iter()
                        .map(|o| o.name.as_str())
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
                found: format!("`{}`", meta.slip_output),
            })?;
        let runtime = |e: TractError| OnnxError::Runtime {
            path: p.clone(),
            message: format!("{e:#}"),
        };
        let shape: TVec<usize> = if meta.window == 1 {
            tvec![1, meta.features.len()]
        } else {
            tvec![1, meta.window, meta.features.len()]
        };
        let plan = onnx
            .model_for_proto_model(&proto)
            .map_err(runtime)?
            .with_input_fact(0, f32::fact(shape).into())
            .map_err(runtime)?
            .into_optimized()
            .map_err(runtime)?
            .into_runnable()
            .map_err(runtime)?;
        let model = OnnxModel {
            path: path.to_path_buf(),
            meta,
            plan,
            output,
        };
        // One run on zeros: an output too narrow for the slip column, or a graph that fails
        // at run time, is refused here rather than at the first frame of a trial.
        let zeros = vec![0.0; model.input_len()];
        model.slip_value(&zeros)?;
        Ok(model)
    }

    /// Floats per input: the window's frames times the features of one frame.
    pub fn input_len(&self) -> usize {
        self.meta.window * self.meta.features.len()
    }

    /// The model's slip value (probability, score or class label) for one input: `window`
    /// frames' features, oldest first, `input_len()` floats.
    pub fn slip_value(&self, input: &[f32]) -> Result<f32, OnnxError> {
        let p = || self.path.display().to_string();
        let shape: Vec<usize> = if self.meta.window == 1 {
            vec![1, self.meta.features.len()]
        } else {
            vec![1, self.meta.window, self.meta.features.len()]
        };
        let tensor = Tensor::from_shape(&shape, input).map_err(|e| OnnxError::Runtime {
            path: p(),
            message: e.to_string(),
        })?;
        let outputs = self
            .plan
            .run(tvec![tensor.into()])
            .map_err(|e| OnnxError::Runtime {
                path: p(),
                message: format!("{e:#}"),
            })?;
        let out = outputs[self.output]
            .cast_to::<f32>()
            .map_err(|e| OnnxError::Runtime {
                path: p(),
                message: format!("output `{}`: {e}", self.meta.slip_output),
            })?;
        let view = out
            .to_plain_array_view::<f32>()
            .map_err(|e| OnnxError::Runtime {
                path: p(),
                message: e.to_string(),
            })?;
        // a batch of one: the slip column of its row, whatever the output's rank
        let values: Vec<f32> = view.iter().copied().collect();
        values
            .get(self.meta.slip_column)
            .copied()
            .ok_or_else(|| OnnxError::Shape {
                path: p(),
                what: format!("output `{}`", self.meta.slip_output),
                expected: format!(
                    "a column {} (tmo.slip_column) in its one row",
                    self.meta.slip_column
                ),
                found: format!("{} value(s), shape {:?}", values.len(), out.shape()),
            })
    }

    /// The class a slip value means.
    pub fn class_of(&self, value: f32) -> Class {
        if value >= self.meta.threshold {
            Class::Slip
        } else {
            Class::Static
        }
    }

    /// The slip value of every row of `data`: each row with the window of its sensor's
    /// frames in its trial that ends at it, `None` where its trial shows fewer than K
    /// consecutive frames of its sensor up to it (online, such a frame gives no class).
    pub fn slip_values(&self, data: &Dataset) -> Result<Vec<Option<f32>>, OnnxError> {
        let windows = Windows::of(data, self.meta.window);
        let mut input = Vec::with_capacity(self.input_len());
        (0..data.len())
            .map(|i| {
                input.clear();
                if !windows.fill(data, i, &mut input) {
                    return Ok(None);
                }
                self.slip_value(&input).map(Some)
            })
            .collect()
    }

    /// The class of every row of `data` ([`Self::slip_values`]); a row without a window is
    /// classed static, and their count comes back beside the classes.
    pub fn predict_rows(&self, data: &Dataset) -> Result<(Vec<Class>, usize), OnnxError> {
        let values = self.slip_values(data)?;
        let without = values.iter().filter(|v| v.is_none()).count();
        let classes = values
            .into_iter()
            .map(|v| v.map_or(Class::Static, |v| self.class_of(v)))
            .collect();
        Ok((classes, without))
    }
}

/// Every row's window: the rows of its trial and sensor that come before it, in frame
/// order. A dataset lists a trial's rows in frame order per sensor; rows are linked by
/// (trial, sensor) and their sequence numbers must run on without a gap.
struct Windows {
    window: usize,
    /// For each row, the row of the same trial and sensor one frame before, if there is one.
    previous: Vec<Option<usize>>,
}

impl Windows {
    fn of(data: &Dataset, window: usize) -> Self {
        let mut last: BTreeMap<(u32, u8), usize> = BTreeMap::new();
        let previous = (0..data.len())
            .map(|i| {
                let key = (data.trial[i], data.sensor[i]);
                // a dropped frame or a down-sampled row breaks the window
                last.insert(key, i)
                    .filter(|&j| data.seq[i] == data.seq[j] + 1)
            })
            .collect();
        Windows { window, previous }
    }

    /// Appends row `i`'s window to `out`, oldest frame first; false if it has none.
    fn fill(&self, data: &Dataset, i: usize, out: &mut Vec<f32>) -> bool {
        let mut rows = Vec::with_capacity(self.window);
        let mut at = Some(i);
        while rows.len() < self.window {
            match at {
                Some(r) => {
                    rows.push(r);
                    at = self.previous[r];
                }
                None => return false,
            }
        }
        for &r in rows.iter().rev() {
            out.extend_from_slice(data.row(r));
        }
        true
    }
}

/// The operators of `graph` (and of its subgraphs) that tract does not implement, each
/// with its domain where that is not the standard one.
fn unsupported_operators(graph: &pb::GraphProto, onnx: &tract_onnx::Onnx) -> Vec<String> {
    let mut out: Vec<String> = Vec::new();
    let mut visit = vec![graph];
    while let Some(g) = visit.pop() {
        for node in &g.node {
            if !onnx.op_register.0.contains_key(&node.op_type) {
                let name = if node.domain.is_empty() || node.domain == "ai.onnx" {
                    node.op_type.clone()
                } else {
                    format!("{} ({})", node.op_type, node.domain)
                };
                if !out.contains(&name) {
                    out.push(name);
                }
            }
            for a in &node.attribute {
                visit.extend(a.g.iter());
                visit.extend(a.graphs.iter());
            }
        }
    }
    out
}

/// The graph's one real input (initializers listed as inputs, as older exporters do, are
/// weights, not inputs).
fn only_input<'g>(p: &str, graph: &'g pb::GraphProto) -> Result<&'g pb::ValueInfoProto, OnnxError> {
    let weights: Vec<&str> = graph.initializer.iter().map(|t| t.name.as_str()).collect();
    let inputs: Vec<&pb::ValueInfoProto> = graph
        .input
        .iter()
        .filter(|i| !weights.contains(&i.name.as_str()))
        .collect();
    match inputs.as_slice() {
        [one] => Ok(one),
        _ => Err(OnnxError::Shape {
            path: p.into(),
            what: "inputs".into(),
            expected: "one input, the frames' features".into(),
            found: format!(
                "{} ({})",
                inputs.len(),
                inputs
                    .iter()
                    .map(|i| i.name.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        }),
    }
}

/// The input's declared shape against the metadata: `[N, F]` for a per-frame model,
/// `[N, K, F]` for a window of K frames (N, the batch, may be named or 1).
fn check_input_shape(
    p: &str,
    input: &pb::ValueInfoProto,
    meta: &OnnxMeta,
) -> Result<(), OnnxError> {
    use pb::tensor_shape_proto::dimension::Value;
    use pb::type_proto::Value as Type;
    let Some(Type::TensorType(t)) = input.r#type.as_ref().and_then(|t| t.value.as_ref()) else {
        return Err(OnnxError::Shape {
            path: p.into(),
            what: format!("input `{}`", input.name),
            expected: "a tensor of float".into(),
            found: "no tensor type".into(),
        });
    };
    if t.elem_type != pb::tensor_proto::DataType::Float as i32 {
        return Err(OnnxError::Shape {
            path: p.into(),
            what: format!("input `{}`", input.name),
            expected: "a tensor of float (32 bits: tmo's features)".into(),
            found: format!(
                "element type {}",
                pb::tensor_proto::DataType::try_from(t.elem_type)
                    .map_or_else(|_| t.elem_type.to_string(), |d| format!("{d:?}"))
            ),
        });
    }
    let dims: Vec<Option<i64>> = t
        .shape
        .as_ref()
        .map(|s| {
            s.dim
                .iter()
                .map(|d| match &d.value {
                    Some(Value::DimValue(v)) => Some(*v),
                    _ => None,
                })
                .collect()
        })
        .unwrap_or_default();
    let f = meta.features.len() as i64;
    let k = meta.window as i64;
    let expected: Vec<Option<i64>> = if meta.window == 1 {
        vec![None, Some(f)]
    } else {
        vec![None, Some(k), Some(f)]
    };
    let fits = dims.len() == expected.len()
        && dims[0].is_none_or(|n| n == 1)
        && dims[1..].iter().zip(&expected[1..]).all(|(d, e)| d == e);
    if !fits {
        let show = |v: &[Option<i64>]| {
            format!(
                "[{}]",
                v.iter()
                    .map(|d| d.map_or("N".to_string(), |d| d.to_string()))
                    .collect::<Vec<_>>()
                    .join(", ")
            )
        };
        return Err(OnnxError::Shape {
            path: p.into(),
            what: format!("input `{}`", input.name),
            expected: format!(
                "{} ({} features of {} pins{}, per tmo.features and tmo.window)",
                show(&expected),
                f,
                meta.features.pins,
                if meta.window == 1 {
                    String::new()
                } else {
                    format!(", {k} frames")
                }
            ),
            found: show(&dims),
        });
    }
    Ok(())
}

/// tmo's metadata from the file's `tmo.*` properties.
fn read_meta(p: &str, path: &Path, props: &BTreeMap<&str, &str>) -> Result<OnnxMeta, OnnxError> {
    let bad = |field: &str, expected: &str, found: String| OnnxError::Metadata {
        path: p.into(),
        field: field.into(),
        expected: expected.into(),
        found,
    };
    let get = |field: &str, expected: &str| {
        props
            .get(field)
            .copied()
            .ok_or_else(|| bad(field, expected, "nothing (the key is missing)".into()))
    };
    let format = get("tmo.format", &format!("`{ONNX_FORMAT}`"))?;
    if format != ONNX_FORMAT {
        return Err(bad(
            "tmo.format",
            &format!("`{ONNX_FORMAT}`"),
            format!("`{format}`"),
        ));
    }
    let version_text = get("tmo.version", "a version number")?;
    let version: u32 = version_text.trim().parse().map_err(|_| {
        bad(
            "tmo.version",
            "a version number",
            format!("`{version_text}`"),
        )
    })?;
    if version == 0 || version > ONNX_FORMAT_VERSION {
        return Err(bad(
            "tmo.version",
            &format!("1..={ONNX_FORMAT_VERSION} (a newer tmo reads newer files)"),
            version.to_string(),
        ));
    }
    let json = |field: &str, expected: &str| -> Result<serde_json::Value, OnnxError> {
        let text = get(field, expected)?;
        serde_json::from_str(text).map_err(|e| bad(field, expected, format!("`{text}` ({e})")))
    };
    const FEATURES: &str = "a JSON feature spec (a tmo model file's `features`), like {\"pins\": 30, \"max_pin_step_px\": 20.0, \"units\": \"px\", \"frame_rate_hz\": 60.0}";
    let features: FeatureSpec = serde_json::from_value(json("tmo.features", FEATURES)?)
        .map_err(|e| bad("tmo.features", FEATURES, e.to_string()))?;
    if !(1..=100_000).contains(&features.pins) {
        return Err(bad(
            "tmo.features",
            "1..=100000 pins",
            features.pins.to_string(),
        ));
    }
    if !(features.max_pin_step_px.is_finite() && features.max_pin_step_px > 0.0) {
        return Err(bad(
            "tmo.features",
            "a positive max_pin_step_px",
            features.max_pin_step_px.to_string(),
        ));
    }
    const LABELS: &str = "the JSON label spec it was trained with (a tmo model file's `labels`)";
    let labels: LabelSpec = serde_json::from_value(json("tmo.labels", LABELS)?)
        .map_err(|e| bad("tmo.labels", LABELS, e.to_string()))?;
    const SENSORS: &str = "a JSON list of the sensors it was trained on, like [0, 1, 2]";
    let sensors: Vec<u8> = serde_json::from_value(json("tmo.sensors", SENSORS)?)
        .map_err(|e| bad("tmo.sensors", SENSORS, e.to_string()))?;
    if sensors.is_empty() {
        return Err(bad("tmo.sensors", SENSORS, "[]".into()));
    }
    const WINDOW: &str = "frames per input, 1 (per frame) or more";
    let window_text = props.get("tmo.window").copied().unwrap_or("1");
    let window: usize = window_text
        .trim()
        .parse()
        .map_err(|_| bad("tmo.window", WINDOW, format!("`{window_text}`")))?;
    if !(1..=MAX_WINDOW).contains(&window) {
        return Err(bad(
            "tmo.window",
            &format!("1..={MAX_WINDOW} frames"),
            window.to_string(),
        ));
    }
    let slip_output = get("tmo.slip_output", "the name of the output that says slip")?.to_string();
    let column_text = props.get("tmo.slip_column").copied().unwrap_or("0");
    let slip_column: usize = column_text.trim().parse().map_err(|_| {
        bad(
            "tmo.slip_column",
            "the column of the slip output's last axis that says slip (0 or more)",
            format!("`{column_text}`"),
        )
    })?;
    let threshold_text = get(
        "tmo.threshold",
        "the slip value at and above which a frame is slip",
    )?;
    let threshold: f32 = threshold_text
        .trim()
        .parse()
        .ok()
        .filter(|t: &f32| t.is_finite())
        .ok_or_else(|| {
            bad(
                "tmo.threshold",
                "a finite number (0.5 for a probability)",
                format!("`{threshold_text}`"),
            )
        })?;
    let name = props.get("tmo.name").map_or_else(
        || {
            path.file_stem()
                .map_or("onnx".into(), |s| s.to_string_lossy().into_owned())
        },
        |n| n.to_string(),
    );
    Ok(OnnxMeta {
        features,
        labels,
        sensors,
        window,
        slip_output,
        slip_column,
        threshold,
        name,
    })
}
