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
    #[error("{path}: operator(s) {} not supported by tmo's ONNX runtime (tract {}): it runs the standard ONNX operators and, of ai.onnx.ml, ArrayFeatureExtractor, CategoryMapper, LinearClassifier, LinearRegressor, Normalizer and TreeEnsembleClassifier; export the model without them (docs/onnx.md: a scikit-learn SVC's decision function as standard operators, say)", .operators.join(", "), TRACT_VERSION)]
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
    #[error(
        "{path}: metadata `{key}`, `{field}`: {message} (the same check as a tmo model file's)"
    )]
    MetadataValue {
        path: String,
        key: String,
        field: String,
        message: String,
    },
    #[error("{path}: the slip value is {value}{at}: a model's output must be a finite number (a non-finite value is neither slip nor static)")]
    NonFinite {
        path: String,
        value: f32,
        at: String,
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
    /// Which row of that output is the frame's: the batch's one row, or (for a windowed
    /// model that gives one row per frame of its window) the newest frame's.
    pub output_rows: OutputRows,
    /// Slip where that value is at least this (a probability's 0.5, a class label's 1).
    pub threshold: f32,
    /// What the model is, for tables (`tmo.name`, else the file's stem).
    pub name: String,
}

/// How a model's slip output is laid out (`tmo.output_rows`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum OutputRows {
    /// One row for the batch of one: `[1]`, `[1, 1]` or `[1, C]` (`one`, the default).
    One,
    /// One row per frame of the window, oldest first: `[1, K]` or `[1, K, C]`; the newest
    /// frame's row is the frame's value (`per_frame`).
    PerFrame,
}

impl OutputRows {
    pub fn name(self) -> &'static str {
        match self {
            OutputRows::One => "one",
            OutputRows::PerFrame => "per_frame",
        }
    }
}

/// The slip value in an output of `shape` (its values row-major), as `rows` and `column`
/// say the model lays it out for a batch of one; `window` is K. Any other shape is an error
/// that says what was expected: a flattened output read at its first row would score a
/// model that answers for its newest frame by its oldest.
pub fn slip_value_in(
    shape: &[usize],
    values: &[f32],
    rows: OutputRows,
    column: usize,
    window: usize,
) -> Result<f32, String> {
    let at = match (rows, shape) {
        (OutputRows::One, [1]) if column == 0 => Some(0),
        (OutputRows::One, [1, c]) if column < *c => Some(column),
        (OutputRows::PerFrame, [1, k]) if *k == window && column == 0 => Some(k - 1),
        (OutputRows::PerFrame, [1, k, c]) if *k == window && column < *c => {
            Some((k - 1) * c + column)
        }
        _ => None,
    };
    at.and_then(|i| values.get(i).copied()).ok_or_else(|| {
        let expected = match rows {
            OutputRows::One => format!(
                "one row for the batch of one with column {column} (tmo.slip_column): [1]{}, or [1, C] with C > {column}",
                if column == 0 { ", [1, 1]" } else { "" }
            ),
            OutputRows::PerFrame => format!(
                "one row per frame of the window (tmo.output_rows = per_frame): [1, {window}]{} or [1, {window}, C] with C > {column}",
                if column == 0 { "" } else { " (column 0 only)" }
            ),
        };
        format!("{expected}; found shape {shape:?}")
    })
}

type Plan = Arc<TypedRunnableModel>;

/// What runs a model: tract, or (a graph that is one tree ensemble) tmo's own evaluator.
#[derive(Debug, Clone)]
enum Engine {
    Tract {
        plan: Plan,
        /// Index of the slip output among the graph's outputs.
        output: usize,
    },
    Trees {
        ensemble: Arc<super::trees::TreeEnsemble>,
        /// Whether the slip output is the ensemble's probabilities (else its label).
        probabilities: bool,
    },
}

impl Engine {
    /// The engine's name, for the cost said at load.
    pub fn name(&self) -> &'static str {
        match self {
            Engine::Tract { .. } => "tract",
            Engine::Trees { .. } => "tmo's tree evaluator",
        }
    }
}

/// A loaded ONNX slip model, ready to classify.
#[derive(Debug, Clone)]
pub struct OnnxModel {
    pub path: PathBuf,
    pub meta: OnnxMeta,
    engine: Engine,
}

/// The tree ensemble a graph is, if it is one tmo evaluates itself: a single
/// `TreeEnsembleClassifier` on the graph's input, its outputs passed on directly or through
/// `Identity` nodes. `slip_output` names the graph output read; the flag says whether it is
/// the probabilities (the node's second output) rather than the label.
fn tree_engine(graph: &pb::GraphProto, input: &str, slip_output: &str) -> Option<Engine> {
    let trees: Vec<&pb::NodeProto> = graph
        .node
        .iter()
        .filter(|n| n.op_type == "TreeEnsembleClassifier")
        .collect();
    let [tree] = trees.as_slice() else {
        return None;
    };
    let others_are_identities = graph
        .node
        .iter()
        .all(|n| n.op_type == "Identity" || n.op_type == "TreeEnsembleClassifier");
    if domain_name(&tree.domain) != "ai.onnx.ml"
        || !others_are_identities
        || tree.input.as_slice() != [input.to_string()]
    {
        return None;
    }
    // follow Identity nodes back from the slip output to one of the tree's outputs
    let mut name = slip_output.to_string();
    for _ in 0..=graph.node.len() {
        if let Some(k) = tree.output.iter().position(|o| *o == name) {
            let ensemble = super::trees::TreeEnsemble::from_node(tree).ok()?;
            return Some(Engine::Trees {
                ensemble: Arc::new(ensemble),
                probabilities: k == 1,
            });
        }
        let step = graph
            .node
            .iter()
            .find(|n| n.op_type == "Identity" && n.output.first() == Some(&name))?;
        name = step.input.first()?.clone();
    }
    None
}

/// A model whose weights live in files beside it (ONNX external data) is refused by name:
/// the SHA-256 each trial records would not cover them, and the runtime's own words ("no
/// model path was specified in the parsing context") do not say what is wrong.
fn refuse_external_data(path: &str, bytes: &[u8]) -> Result<(), OnnxError> {
    use prost::Message;
    let Ok(raw) = tract_onnx::pb::ModelProto::decode(bytes) else {
        return Ok(()); // the runtime's decode says what is wrong
    };
    let external = tract_onnx::pb::tensor_proto::DataLocation::External as i32;
    let outside = raw
        .graph
        .iter()
        .flat_map(|g| &g.initializer)
        .find(|t| t.data_location == Some(external) || !t.external_data.is_empty());
    match outside {
        Some(t) => Err(OnnxError::Decode {
            path: path.to_string(),
            message: format!(
                "its weights (`{}` and maybe more) are kept in external data files beside it (ONNX external data); tmo reads a model whole from one file, whose SHA-256 every trial records: save it with its weights inside (in Python: onnx.save_model(model, path, save_as_external_data=False))",
                t.name
            ),
        }),
        None => Ok(()),
    }
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
        refuse_external_data(&p, &bytes)?;
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
        check_opsets(&p, &proto.opset_import)?;
        let unsupported = unsupported_operators(graph, &onnx);
        if !unsupported.is_empty() {
            return Err(OnnxError::UnsupportedOperators {
                path: p,
                operators: unsupported,
            });
        }
        let props = metadata_props(&p, &proto.metadata_props)?;
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
        let engine = match tree_engine(graph, &input.name, &meta.slip_output) {
            Some(trees) if meta.window == 1 => trees,
            _ => {
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
                Engine::Tract { plan, output }
            }
        };
        if let Engine::Trees { ensemble, .. } = &engine {
            if ensemble.features_read > meta.features.len() {
                return Err(OnnxError::Shape {
                    path: p,
                    what: "the tree ensemble's features".into(),
                    expected: format!("at most {} (tmo.features)", meta.features.len()),
                    found: format!("a node reading feature {}", ensemble.features_read - 1),
                });
            }
        }
        let model = OnnxModel {
            path: path.to_path_buf(),
            meta,
            engine,
        };
        // One run on zeros: an output too narrow for the slip column, or a graph that fails
        // at run time, is refused here rather than at the first frame of a trial.
        let zeros = vec![0.0; model.input_len()];
        model.slip_value(&zeros).map_err(|e| match e {
            OnnxError::NonFinite { path, value, .. } => OnnxError::NonFinite {
                path,
                value,
                at: " for an input of zeros (the run at load)".into(),
            },
            e => e,
        })?;
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
        let (plan, output) = match &self.engine {
            Engine::Tract { plan, output } => (plan, *output),
            Engine::Trees {
                ensemble,
                probabilities,
            } => {
                let out = ensemble.evaluate(input);
                let (shape, values) = if *probabilities {
                    (vec![1, out.probabilities.len()], out.probabilities)
                } else {
                    (vec![1], vec![out.label as f32])
                };
                return self.checked_value(&shape, &values);
            }
        };
        let (k, f) = (self.meta.window, self.meta.features.len());
        let tensor = if k == 1 {
            Tensor::from_shape(&[1, f], input)
        } else {
            Tensor::from_shape(&[1, k, f], input)
        }
        .map_err(|e| OnnxError::Runtime {
            path: p(),
            message: e.to_string(),
        })?;
        let outputs = plan
            .run(tvec![tensor.into()])
            .map_err(|e| OnnxError::Runtime {
                path: p(),
                message: format!("{e:#}"),
            })?;
        let out = outputs[output]
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
        // a contiguous output is read in place (no copy a frame)
        match view.as_slice() {
            Some(values) => self.checked_value(out.shape(), values),
            None => self.checked_value(out.shape(), &view.iter().copied().collect::<Vec<f32>>()),
        }
    }

    /// What runs the model: `tract`, or tmo's own tree evaluator.
    pub fn engine(&self) -> &'static str {
        self.engine.name()
    }

    /// The slip value in an output of `shape`, checked: where the metadata says, and finite.
    fn checked_value(&self, shape: &[usize], values: &[f32]) -> Result<f32, OnnxError> {
        let p = || self.path.display().to_string();
        let value = slip_value_in(
            shape,
            values,
            self.meta.output_rows,
            self.meta.slip_column,
            self.meta.window,
        )
        .map_err(|found| OnnxError::Shape {
            path: p(),
            what: format!("output `{}`", self.meta.slip_output),
            expected: "the slip value where tmo.output_rows and tmo.slip_column say".into(),
            found,
        })?;
        if !value.is_finite() {
            return Err(OnnxError::NonFinite {
                path: p(),
                value,
                at: String::new(),
            });
        }
        Ok(value)
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
                self.slip_value(&input).map(Some).map_err(|e| match e {
                    OnnxError::NonFinite { path, value, .. } => OnnxError::NonFinite {
                        path,
                        value,
                        at: format!(
                            " at trial {}, sensor {}, frame {}",
                            data.trial_ids[data.trial[i] as usize], data.sensor[i], data.seq[i]
                        ),
                    },
                    e => e,
                })
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

/// The operators tract implements from the ONNX-ML domain (`ai.onnx.ml`); every other
/// operator it registers is a standard (`ai.onnx`) one. tract registers operators by name
/// alone, so the domain is checked here: an operator of a custom domain that shares a
/// standard operator's name is not that operator.
const ML_OPERATORS: [&str; 6] = [
    "ArrayFeatureExtractor",
    "CategoryMapper",
    "LinearClassifier",
    "LinearRegressor",
    "Normalizer",
    "TreeEnsembleClassifier",
];

/// Newest operator set of each domain this build knows (ONNX 1.20's: `ai.onnx` 25,
/// `ai.onnx.ml` 5); a model that asks for a newer one may use operators whose meaning
/// changed after tract was written, so it is refused rather than run by older rules.
const NEWEST_OPSETS: [(&str, i64); 2] = [("ai.onnx", 25), ("ai.onnx.ml", 5)];

/// The domain's canonical name: the standard domain is written `""` or `ai.onnx`.
fn domain_name(domain: &str) -> &str {
    if domain.is_empty() {
        "ai.onnx"
    } else {
        domain
    }
}

/// Refuses an operator set newer than [`NEWEST_OPSETS`] (a domain tmo knows nothing of is
/// left to the operator check, which names its operators).
fn check_opsets(p: &str, imports: &[pb::OperatorSetIdProto]) -> Result<(), OnnxError> {
    for import in imports {
        let domain = domain_name(&import.domain);
        if let Some((_, newest)) = NEWEST_OPSETS.iter().find(|(d, _)| *d == domain) {
            if import.version > *newest || import.version < 1 {
                return Err(OnnxError::Shape {
                    path: p.into(),
                    what: format!("operator set of `{domain}`"),
                    expected: format!(
                        "1..={newest}, the newest this tmo's runtime knows (export with an older opset, e.g. skl2onnx's target_opset or torch.onnx.export's opset_version)"
                    ),
                    found: import.version.to_string(),
                });
            }
        }
    }
    Ok(())
}

/// The operators of `graph` (and of its subgraphs) that tract does not implement, by
/// domain and name, each named with its domain where that is not the standard one.
fn unsupported_operators(graph: &pb::GraphProto, onnx: &tract_onnx::Onnx) -> Vec<String> {
    let mut out: Vec<String> = Vec::new();
    let mut visit = vec![graph];
    while let Some(g) = visit.pop() {
        for node in &g.node {
            let domain = domain_name(&node.domain);
            let op = node.op_type.as_str();
            let known = match domain {
                "ai.onnx" => onnx.op_register.0.contains_key(op) && !ML_OPERATORS.contains(&op),
                "ai.onnx.ml" => ML_OPERATORS.contains(&op),
                _ => false,
            };
            if !known {
                let name = if domain == "ai.onnx" {
                    op.to_string()
                } else {
                    format!("{op} ({domain})")
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

/// The keys tmo reads from a model's `metadata_props`.
const TMO_KEYS: [&str; 11] = [
    "tmo.format",
    "tmo.version",
    "tmo.features",
    "tmo.labels",
    "tmo.sensors",
    "tmo.window",
    "tmo.slip_output",
    "tmo.slip_column",
    "tmo.output_rows",
    "tmo.threshold",
    "tmo.name",
];

/// The model's metadata as a map; a key given twice (which one would count?) or a `tmo.*`
/// key tmo does not read (a misspelt `tmo.treshold` would otherwise be ignored) is refused.
fn metadata_props<'a>(
    p: &str,
    props: &'a [pb::StringStringEntryProto],
) -> Result<BTreeMap<&'a str, &'a str>, OnnxError> {
    let mut map = BTreeMap::new();
    for e in props {
        if map.insert(e.key.as_str(), e.value.as_str()).is_some() {
            return Err(OnnxError::Metadata {
                path: p.into(),
                field: e.key.clone(),
                expected: "each key once".into(),
                found: "the key twice".into(),
            });
        }
        if e.key.starts_with("tmo.") && !TMO_KEYS.contains(&e.key.as_str()) {
            return Err(OnnxError::Metadata {
                path: p.into(),
                field: e.key.clone(),
                expected: format!("one of tmo's keys ({})", TMO_KEYS.join(", ")),
                found: "a key tmo does not read".into(),
            });
        }
    }
    Ok(map)
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
    // Straight from the text into the spec's type: a key given twice inside the JSON is
    // refused (through a JSON value the last one would silently win).
    fn json<T: serde::de::DeserializeOwned>(
        text: &str,
        on_error: impl FnOnce(String) -> OnnxError,
    ) -> Result<T, OnnxError> {
        serde_json::from_str(text).map_err(|e| on_error(format!("`{text}` ({e})")))
    }
    const FEATURES: &str = "a JSON feature spec (a tmo model file's `features`), like {\"pins\": 30, \"max_pin_step_px\": 20.0, \"units\": \"px\", \"frame_rate_hz\": 60.0}";
    let features: FeatureSpec = json(get("tmo.features", FEATURES)?, |found| {
        bad("tmo.features", FEATURES, found)
    })?;
    let checked = |key: &str, check: Result<(), (&'static str, String)>| {
        check.map_err(|(field, message)| OnnxError::MetadataValue {
            path: p.into(),
            key: key.into(),
            field: field.into(),
            message,
        })
    };
    checked("tmo.features", features.check())?;
    // A model brought from elsewhere says the rate it was trained at: velocities are per
    // frame, and the loop's deadline is one frame period.
    if features.frame_rate_hz.is_none() {
        checked(
            "tmo.features",
            Err((
                "frame_rate_hz",
                "expected the frames' rate in Hz that the model was trained at, got none".into(),
            )),
        )?;
    }
    const LABELS: &str = "the JSON label spec it was trained with (a tmo model file's `labels`)";
    let labels: LabelSpec = json(get("tmo.labels", LABELS)?, |found| {
        bad("tmo.labels", LABELS, found)
    })?;
    checked("tmo.labels", labels.check())?;
    const SENSORS: &str = "a JSON list of the sensors it was trained on, like [0, 1, 2]";
    let sensors: Vec<u8> = json(get("tmo.sensors", SENSORS)?, |found| {
        bad("tmo.sensors", SENSORS, found)
    })?;
    let mut listed = sensors.clone();
    listed.sort_unstable();
    listed.dedup();
    if sensors.is_empty() || listed.len() != sensors.len() {
        return Err(bad(
            "tmo.sensors",
            "the sensors it was trained on, each once, like [0, 1, 2]",
            format!("{sensors:?}"),
        ));
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
    let rows_text = props.get("tmo.output_rows").copied().unwrap_or("one");
    let output_rows = [OutputRows::One, OutputRows::PerFrame]
        .into_iter()
        .find(|r| r.name() == rows_text.trim())
        .ok_or_else(|| {
            bad(
                "tmo.output_rows",
                "`one` (a row for the batch of one) or `per_frame` (a row per frame of the window; the newest is read)",
                format!("`{rows_text}`"),
            )
        })?;
    if output_rows == OutputRows::PerFrame && window == 1 {
        return Err(bad(
            "tmo.output_rows",
            "`one` for a per-frame model (tmo.window 1): `per_frame` is for a window's rows",
            "`per_frame`".into(),
        ));
    }
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
        output_rows,
        threshold,
        name,
    })
}
