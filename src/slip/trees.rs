//! Tree ensembles as ONNX-ML's `TreeEnsembleClassifier` states them (scikit-learn's random
//! forests and gradient boosting, as skl2onnx writes them), evaluated by tmo itself.
//!
//! Why not the ONNX runtime: tract evaluates a 50-tree forest in about 1 ms a frame (some
//! hundred times onnxruntime's 8.6 us) and refuses skl2onnx's binary gradient boosting (one
//! base value for two classes). Here every tree's nodes lie in one flat array of 16-byte
//! nodes, walked from each root with one comparison per level.
//!
//! The outputs follow onnxruntime's reading of the operator, which is what a model's author
//! saw when they checked it:
//! - each class's score is the sum of its leaves' weights over the trees (classifiers have
//!   no other aggregation);
//! - **one weighted class of two** (skl2onnx's binary forests and boosting): the score `s`
//!   plus the one base value is the positive class's; with every weight at least 0 the
//!   probabilities are `[1 - s, s]` and the label positive where `s > 0.5`; with mixed signs
//!   they are `[sigmoid(-s), sigmoid(s)]` under a `LOGISTIC` post-transform (`[-s, s]`
//!   without one) and the label positive where `s > 0`;
//! - otherwise each class its own score, plus its base value, through the post-transform
//!   (`NONE`, `LOGISTIC` or `SOFTMAX`), the label the first class of the highest score.
//!
//! A configuration outside these (a `PROBIT` transform, string labels, two weighted
//! classes with base values) is left to the runtime, which runs or refuses it.

use tract_onnx::pb;

/// How a branch node compares its feature with its threshold (`nodes_modes`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Mode {
    Leq,
    Lt,
    Gte,
    Gt,
    Eq,
    Neq,
    Leaf,
}

impl Mode {
    fn parse(text: &[u8]) -> Option<Self> {
        Some(match text {
            b"BRANCH_LEQ" => Mode::Leq,
            b"BRANCH_LT" => Mode::Lt,
            b"BRANCH_GTE" => Mode::Gte,
            b"BRANCH_GT" => Mode::Gt,
            b"BRANCH_EQ" => Mode::Eq,
            b"BRANCH_NEQ" => Mode::Neq,
            b"LEAF" => Mode::Leaf,
            _ => return None,
        })
    }
}

/// One node, 16 bytes: a branch's feature, threshold and children (indices into the flat
/// array), or a leaf's range of weights.
#[derive(Debug, Clone, Copy)]
struct Node {
    threshold: f32,
    feature: u32,
    /// Branch: (true child, false child). Leaf: (first weight, end of its weights).
    next: [u32; 2],
    mode: Mode,
    /// A NaN feature goes the true way (`nodes_missing_value_tracks_true`).
    missing_true: bool,
}

/// The post-transform of the classes' scores.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Post {
    None,
    Logistic,
    Softmax,
}

/// A `TreeEnsembleClassifier` ready to evaluate one row at a time.
#[derive(Debug, Clone)]
pub struct TreeEnsemble {
    nodes: Vec<Node>,
    roots: Vec<u32>,
    /// (class, weight) of every leaf, leaf by leaf.
    weights: Vec<(u32, f32)>,
    classes: usize,
    labels: Vec<i64>,
    base_values: Vec<f32>,
    post: Post,
    /// Only one class is weighted (its score is the positive class's): see the module doc.
    one_weighted_class: bool,
    weights_all_positive: bool,
    /// Features a row must have: one more than the highest feature a node reads.
    pub features_read: usize,
}

/// What one row gives: the label and each class's probability (or score).
#[derive(Debug, Clone, PartialEq)]
pub struct TreeOutput {
    pub label: i64,
    pub probabilities: Vec<f32>,
}

/// Why a node cannot be evaluated here (the runtime may still run it).
pub type Unsupported = String;

fn attribute<'a>(node: &'a pb::NodeProto, name: &str) -> Option<&'a pb::AttributeProto> {
    node.attribute.iter().find(|a| a.name == name)
}

fn ints<'a>(node: &'a pb::NodeProto, name: &str) -> &'a [i64] {
    attribute(node, name).map_or(&[], |a| a.ints.as_slice())
}

/// Floats of `name`, or of `name_as_tensor` (double or float data), as f32: the type the
/// runtime compares a float input in.
fn floats(node: &pb::NodeProto, name: &str) -> Result<Vec<f32>, Unsupported> {
    if let Some(a) = attribute(node, name) {
        return Ok(a.floats.clone());
    }
    let Some(t) = attribute(node, &format!("{name}_as_tensor")).and_then(|a| a.t.as_ref()) else {
        return Ok(Vec::new());
    };
    if !t.float_data.is_empty() {
        return Ok(t.float_data.clone());
    }
    if !t.double_data.is_empty() {
        return Ok(t.double_data.iter().map(|&v| v as f32).collect());
    }
    if !t.raw_data.is_empty() {
        let width = if t.data_type == pb::tensor_proto::DataType::Double as i32 {
            8
        } else {
            4
        };
        return Ok(t
            .raw_data
            .chunks_exact(width)
            .map(|b| {
                if width == 8 {
                    f64::from_le_bytes(b.try_into().expect("8 bytes")) as f32
                } else {
                    f32::from_le_bytes(b.try_into().expect("4 bytes"))
                }
            })
            .collect());
    }
    Ok(Vec::new())
}

fn index(v: i64, what: &str) -> Result<u32, Unsupported> {
    u32::try_from(v).map_err(|_| format!("{what} {v} out of range"))
}

impl TreeEnsemble {
    /// The ensemble of a `TreeEnsembleClassifier` node, or why it is not one tmo evaluates.
    pub fn from_node(node: &pb::NodeProto) -> Result<Self, Unsupported> {
        let tree_ids = ints(node, "nodes_treeids");
        let node_ids = ints(node, "nodes_nodeids");
        let feature_ids = ints(node, "nodes_featureids");
        let true_ids = ints(node, "nodes_truenodeids");
        let false_ids = ints(node, "nodes_falsenodeids");
        let missing = ints(node, "nodes_missing_value_tracks_true");
        let values = floats(node, "nodes_values")?;
        let modes = attribute(node, "nodes_modes").map_or(&[][..], |a| a.strings.as_slice());
        let n = tree_ids.len();
        if n == 0
            || [
                node_ids.len(),
                feature_ids.len(),
                true_ids.len(),
                false_ids.len(),
            ]
            .iter()
            .chain([&values.len(), &modes.len()])
            .any(|&len| len != n)
            || !(missing.is_empty() || missing.len() == n)
        {
            return Err("the nodes' attributes differ in length".into());
        }
        let labels = ints(node, "classlabels_int64s").to_vec();
        if labels.is_empty() {
            return Err("no int64 class labels (string labels are left to the runtime)".into());
        }
        let classes = labels.len();
        let post = match attribute(node, "post_transform").map_or(&b"NONE"[..], |a| &a.s[..]) {
            b"NONE" => Post::None,
            b"LOGISTIC" => Post::Logistic,
            b"SOFTMAX" => Post::Softmax,
            other => return Err(format!("post_transform {}", String::from_utf8_lossy(other))),
        };
        // (tree, node id) -> flat index, trees in order of first appearance
        let mut at = std::collections::HashMap::with_capacity(n);
        let mut roots: Vec<u32> = Vec::new();
        let mut tree_root: std::collections::HashMap<i64, u32> = Default::default();
        for i in 0..n {
            if at.insert((tree_ids[i], node_ids[i]), i as u32).is_some() {
                return Err(format!(
                    "node {} of tree {} is given twice",
                    node_ids[i], tree_ids[i]
                ));
            }
        }
        let mut nodes = Vec::with_capacity(n);
        let mut features_read = 0;
        for i in 0..n {
            let mode = Mode::parse(&modes[i])
                .ok_or_else(|| format!("node mode {}", String::from_utf8_lossy(&modes[i])))?;
            let child = |id: i64| {
                at.get(&(tree_ids[i], id))
                    .copied()
                    .ok_or_else(|| format!("tree {} has no node {id}", tree_ids[i]))
            };
            let next = if mode == Mode::Leaf {
                [0, 0]
            } else {
                features_read = features_read.max(index(feature_ids[i], "feature")? as usize + 1);
                [child(true_ids[i])?, child(false_ids[i])?]
            };
            nodes.push(Node {
                threshold: values[i],
                feature: if mode == Mode::Leaf {
                    0
                } else {
                    index(feature_ids[i], "feature")?
                },
                next,
                mode,
                missing_true: missing.get(i).is_some_and(|&m| m != 0),
            });
        }
        // a tree's root is the node no other node of its tree points to
        let mut pointed = vec![false; n];
        for node in nodes.iter().filter(|nd| nd.mode != Mode::Leaf) {
            pointed[node.next[0] as usize] = true;
            pointed[node.next[1] as usize] = true;
        }
        for i in 0..n {
            if !pointed[i] {
                if tree_root.insert(tree_ids[i], i as u32).is_some() {
                    return Err(format!("tree {} has more than one root", tree_ids[i]));
                }
                roots.push(i as u32);
            }
        }
        // the leaves' weights, gathered leaf by leaf
        let class_trees = ints(node, "class_treeids");
        let class_nodes = ints(node, "class_nodeids");
        let class_ids = ints(node, "class_ids");
        let class_weights = floats(node, "class_weights")?;
        let m = class_trees.len();
        if [class_nodes.len(), class_ids.len(), class_weights.len()]
            .iter()
            .any(|&len| len != m)
        {
            return Err("the class weights' attributes differ in length".into());
        }
        let mut per_leaf: Vec<Vec<(u32, f32)>> = vec![Vec::new(); n];
        for k in 0..m {
            let leaf = at
                .get(&(class_trees[k], class_nodes[k]))
                .copied()
                .ok_or_else(|| {
                    format!(
                        "a class weight for node {} of tree {}, which does not exist",
                        class_nodes[k], class_trees[k]
                    )
                })?;
            let class = index(class_ids[k], "class id")?;
            if class as usize >= classes {
                return Err(format!("class id {class} of {classes} classes"));
            }
            per_leaf[leaf as usize].push((class, class_weights[k]));
        }
        let mut weights = Vec::with_capacity(m);
        for (i, node) in nodes.iter_mut().enumerate() {
            if node.mode == Mode::Leaf {
                let start = weights.len() as u32;
                weights.extend_from_slice(&per_leaf[i]);
                node.next = [start, weights.len() as u32];
            }
        }
        let mut weighted: Vec<u32> = weights.iter().map(|&(c, _)| c).collect();
        weighted.sort_unstable();
        weighted.dedup();
        let one_weighted_class = classes == 2 && weighted.len() == 1;
        let weights_all_positive = weights.iter().all(|&(_, w)| w >= 0.0);
        let base_values = floats(node, "base_values")?;
        let base_ok = if one_weighted_class {
            base_values.len() <= 1
        } else if classes == 2 {
            base_values.is_empty()
        } else {
            base_values.is_empty() || base_values.len() == classes
        };
        if !base_ok {
            return Err(format!(
                "{} base values for {classes} classes ({} weighted)",
                base_values.len(),
                weighted.len()
            ));
        }
        Ok(TreeEnsemble {
            nodes,
            roots,
            weights,
            classes,
            labels,
            base_values,
            post,
            one_weighted_class,
            weights_all_positive,
            features_read,
        })
    }

    /// The leaf row `x` reaches from `root`.
    #[inline]
    fn leaf(&self, root: u32, x: &[f32]) -> &Node {
        let mut node = &self.nodes[root as usize];
        loop {
            let v = x[node.feature as usize];
            let t = node.threshold;
            let go_true = match node.mode {
                Mode::Leaf => return node,
                _ if v.is_nan() => node.missing_true,
                Mode::Leq => v <= t,
                Mode::Lt => v < t,
                Mode::Gte => v >= t,
                Mode::Gt => v > t,
                Mode::Eq => v == t,
                Mode::Neq => v != t,
            };
            node = &self.nodes[node.next[usize::from(!go_true)] as usize];
        }
    }

    /// The label and probabilities of one row of features (at least `features_read` of
    /// them).
    pub fn evaluate(&self, x: &[f32]) -> TreeOutput {
        let mut scores = vec![0.0f32; self.classes];
        for &root in &self.roots {
            let leaf = self.leaf(root, x);
            for &(class, w) in &self.weights[leaf.next[0] as usize..leaf.next[1] as usize] {
                scores[class as usize] += w;
            }
        }
        if self.one_weighted_class {
            let class = self.weights.first().map_or(0, |&(c, _)| c as usize);
            let s = scores[class] + self.base_values.first().copied().unwrap_or(0.0);
            let (positive, probabilities) = if self.weights_all_positive {
                (s > 0.5, vec![1.0 - s, s])
            } else if self.post == Post::Logistic {
                (s > 0.0, vec![logistic(-s), logistic(s)])
            } else {
                (s > 0.0, vec![-s, s])
            };
            return TreeOutput {
                label: self.labels[usize::from(positive)],
                probabilities,
            };
        }
        for (s, b) in scores.iter_mut().zip(&self.base_values) {
            *s += b;
        }
        let label = if self.classes == 2 {
            self.labels[usize::from(scores[1] > 0.0)]
        } else {
            let best = (0..self.classes).fold(0, |b, c| if scores[c] > scores[b] { c } else { b });
            self.labels[best]
        };
        let probabilities = match self.post {
            Post::None => scores,
            Post::Logistic => scores.into_iter().map(logistic).collect(),
            Post::Softmax => {
                let max = scores.iter().copied().fold(f32::NEG_INFINITY, f32::max);
                let e: Vec<f32> = scores.iter().map(|s| (s - max).exp()).collect();
                let sum: f32 = e.iter().sum();
                e.into_iter().map(|v| v / sum).collect()
            }
        };
        TreeOutput {
            label,
            probabilities,
        }
    }

    pub fn classes(&self) -> usize {
        self.classes
    }
}

fn logistic(v: f32) -> f32 {
    1.0 / (1.0 + (-v).exp())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn attr_ints(name: &str, v: &[i64]) -> pb::AttributeProto {
        pb::AttributeProto {
            name: name.into(),
            ints: v.to_vec(),
            ..Default::default()
        }
    }

    fn attr_floats(name: &str, v: &[f32]) -> pb::AttributeProto {
        pb::AttributeProto {
            name: name.into(),
            floats: v.to_vec(),
            ..Default::default()
        }
    }

    /// Two stumps on features 0 and 1 (x <= 0.5 goes to node 1, else node 2), the leaves'
    /// weights on class 0 only, as skl2onnx writes a binary ensemble.
    fn stumps(weights: [f32; 4], base: &[f32], post: &str) -> pb::NodeProto {
        let modes: Vec<Vec<u8>> = ["BRANCH_LEQ", "LEAF", "LEAF"]
            .iter()
            .cycle()
            .take(6)
            .map(|m| m.as_bytes().to_vec())
            .collect();
        let mut attribute = vec![
            attr_ints("nodes_treeids", &[0, 0, 0, 1, 1, 1]),
            attr_ints("nodes_nodeids", &[0, 1, 2, 0, 1, 2]),
            attr_ints("nodes_featureids", &[0, 0, 0, 1, 0, 0]),
            attr_floats("nodes_values", &[0.5, 0.0, 0.0, 0.5, 0.0, 0.0]),
            attr_ints("nodes_truenodeids", &[1, 0, 0, 1, 0, 0]),
            attr_ints("nodes_falsenodeids", &[2, 0, 0, 2, 0, 0]),
            pb::AttributeProto {
                name: "nodes_modes".into(),
                strings: modes,
                ..Default::default()
            },
            attr_ints("class_treeids", &[0, 0, 1, 1]),
            attr_ints("class_nodeids", &[1, 2, 1, 2]),
            attr_ints("class_ids", &[0, 0, 0, 0]),
            attr_floats("class_weights", &weights),
            attr_ints("classlabels_int64s", &[0, 1]),
            pb::AttributeProto {
                name: "post_transform".into(),
                s: post.as_bytes().to_vec(),
                ..Default::default()
            },
        ];
        if !base.is_empty() {
            attribute.push(attr_floats("base_values", base));
        }
        pb::NodeProto {
            op_type: "TreeEnsembleClassifier".into(),
            domain: "ai.onnx.ml".into(),
            attribute,
            ..Default::default()
        }
    }

    #[test]
    fn a_forest_averages_its_trees_positive_weights_into_the_positive_class() {
        // a forest of two: each leaf's weight is its tree's share of the slip probability
        let t = TreeEnsemble::from_node(&stumps([0.1, 0.4, 0.05, 0.45], &[], "NONE")).unwrap();
        let out = t.evaluate(&[0.9, 0.2]);
        // tree 0 goes false (0.9 > 0.5): 0.4; tree 1 true (0.2 <= 0.5): 0.05
        let s = 0.4f32 + 0.05;
        assert_eq!(out.probabilities, vec![1.0 - s, s]);
        assert_eq!(out.label, 0, "0.45 is not above 0.5");
        let out = t.evaluate(&[0.9, 0.9]);
        assert!((out.probabilities[1] - 0.85).abs() < 1e-6);
        assert_eq!(out.label, 1);
        // a NaN feature goes the false way unless the node says otherwise
        assert!((t.evaluate(&[f32::NAN, 0.9]).probabilities[1] - 0.85).abs() < 1e-6);
    }

    #[test]
    fn boosting_adds_its_one_base_value_and_reads_the_logistic_of_the_score() {
        let t =
            TreeEnsemble::from_node(&stumps([-1.0, 0.5, -0.25, 2.0], &[0.1], "LOGISTIC")).unwrap();
        let out = t.evaluate(&[0.0, 1.0]);
        let s: f32 = -1.0 + 2.0 + 0.1;
        assert_eq!(out.probabilities, vec![logistic(-s), logistic(s)]);
        assert_eq!(out.label, 1);
        let out = t.evaluate(&[0.0, 0.0]);
        assert_eq!(out.label, 0, "-1.25 + 0.1 < 0");
    }

    #[test]
    fn malformed_ensembles_are_named_not_evaluated() {
        let mut n = stumps([0.1, 0.4, 0.05, 0.45], &[], "NONE");
        n.attribute[4].ints = vec![1, 0, 0, 7, 0, 0];
        assert!(TreeEnsemble::from_node(&n)
            .unwrap_err()
            .contains("no node 7"));
        let n = stumps([0.1, 0.4, 0.05, 0.45], &[], "PROBIT");
        assert!(TreeEnsemble::from_node(&n).unwrap_err().contains("PROBIT"));
        let n = stumps([0.1, 0.4, 0.05, 0.45], &[0.0, 0.0, 0.0], "NONE");
        assert!(TreeEnsemble::from_node(&n)
            .unwrap_err()
            .contains("3 base values"));
    }
}
