//! An ONNX slip model as slow as a test needs: the logreg fixture behind a chain of
//! matrix products whose result is multiplied by zero and added to its input, so its
//! classes are logreg's and its cost is the chain's.

use std::path::Path;

use prost::Message;
use tract_onnx::pb;

fn tensor(name: &str, dims: &[i64], value: f32) -> pb::TensorProto {
    let n: i64 = dims.iter().product();
    pb::TensorProto {
        name: name.into(),
        dims: dims.to_vec(),
        data_type: pb::tensor_proto::DataType::Float as i32,
        float_data: vec![value; n as usize],
        ..Default::default()
    }
}

fn node(op: &str, inputs: &[&str], output: &str) -> pb::NodeProto {
    pb::NodeProto {
        op_type: op.into(),
        input: inputs.iter().map(|s| s.to_string()).collect(),
        output: vec![output.into()],
        name: output.into(),
        ..Default::default()
    }
}

/// Writes `dest`: logreg.onnx with `layers` products of a `width`-wide layer before it.
pub fn write_slow_logreg(dest: &Path, layers: usize, width: i64, name: &str) {
    let bytes = std::fs::read(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/onnx/logreg.onnx"),
    )
    .unwrap();
    let mut proto = pb::ModelProto::decode(bytes.as_slice()).unwrap();
    let graph = proto.graph.as_mut().unwrap();
    #[allow(non_snake_case)]
    let WIDTH = width;
    let features = 60;
    graph
        .initializer
        .push(tensor("slow_in", &[features, WIDTH], 1e-3));
    graph
        .initializer
        .push(tensor("slow_w", &[WIDTH, WIDTH], 1.0 / WIDTH as f32));
    graph
        .initializer
        .push(tensor("slow_out", &[WIDTH, features], 0.0));
    let mut chain = vec![node("MatMul", &["features", "slow_in"], "slow_0")];
    for k in 1..=layers {
        let (from, to) = (format!("slow_{}", k - 1), format!("slow_{k}"));
        chain.push(node("MatMul", &[&from, "slow_w"], &to));
    }
    let last = format!("slow_{layers}");
    chain.push(node("MatMul", &[&last, "slow_out"], "slow_zero"));
    chain.push(node("Add", &["features", "slow_zero"], "features_slowly"));
    for n in graph.node.iter_mut() {
        for input in n.input.iter_mut().filter(|i| *i == "features") {
            *input = "features_slowly".into();
        }
    }
    chain.append(&mut graph.node);
    graph.node = chain;
    for e in proto.metadata_props.iter_mut() {
        if e.key == "tmo.name" {
            e.value = name.into();
        }
    }
    std::fs::write(dest, proto.encode_to_vec()).unwrap();
}
