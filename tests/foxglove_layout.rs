//! The Foxglove layout in `docs/foxglove/` reads only what tmo writes: every panel it lays
//! out is configured, and every message path names a channel of a trial log and fields its
//! schema has (a renamed field would otherwise leave a panel silently empty).

use std::collections::BTreeSet;

use serde_json::Value;
use tmo::trial::schema::{event_channel_schema, MARKER, PIN_FRAME};

fn layout() -> Value {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/docs/foxglove/tmo-layout.json");
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

/// The panel ids a layout tree places.
fn placed(node: &Value, out: &mut BTreeSet<String>) {
    match node {
        Value::String(id) => {
            out.insert(id.clone());
        }
        Value::Object(split) => {
            placed(&split["first"], out);
            placed(&split["second"], out);
        }
        other => panic!("not a layout node: {other}"),
    }
}

/// The JSON schema of a topic tmo writes, or `None`.
fn schema_of(topic: &str) -> Option<Value> {
    let text = if topic.starts_with("/tactile/") {
        PIN_FRAME.1.to_string()
    } else if topic == "/marker" {
        MARKER.1.to_string()
    } else {
        let (name, text) = event_channel_schema(topic);
        if name == "tmo.Event" {
            return None; // the schema of topics tmo does not know
        }
        text
    };
    Some(serde_json::from_str(&text).unwrap())
}

/// The schema of the field chain `a.b.c` (array indexes `[n]` dropped), if it has it.
fn field<'s>(schema: &'s Value, chain: &str) -> Option<&'s Value> {
    let mut at = schema;
    for field in chain.split('.').filter(|f| !f.is_empty()) {
        let name = field.split('[').next().unwrap();
        at = at["properties"].get(name)?;
    }
    Some(at)
}

/// Whether `schema` has the field chain `a.b.c`.
fn has_fields(schema: &Value, chain: &str) -> bool {
    field(schema, chain).is_some()
}

/// Checks one message path, `/topic{a.b==1}.c.d`, against the schemas.
fn check_path(path: &str) -> Result<(), String> {
    let end = path.find(['.', '{']).unwrap_or(path.len());
    let (topic, mut rest) = path.split_at(end);
    let schema = schema_of(topic).ok_or(format!("{path}: tmo writes no topic {topic}"))?;
    if let Some(filter) = rest.strip_prefix('{') {
        let (inside, after) = filter
            .split_once('}')
            .ok_or(format!("{path}: unclosed filter"))?;
        let field = inside.split("==").next().unwrap();
        if !has_fields(&schema, field) {
            return Err(format!(
                "{path}: the filter's {field} is not a field of {topic}"
            ));
        }
        rest = after;
    }
    if !has_fields(&schema, rest) {
        return Err(format!("{path}: {rest} is not a field of {topic}"));
    }
    // A Plot panel plots numbers: an array field needs an index or a slice (`[:]`), or
    // the open-source Plot panel plots nothing for it.
    let last = rest.rsplit('.').next().unwrap_or("");
    if leaf_is_array(&schema, rest) && !last.ends_with(']') {
        return Err(format!(
            "{path}: {rest} is an array; plot its items with [:] or one with [n]"
        ));
    }
    Ok(())
}

/// Whether the field chain ends at an array (an index or slice after it counts as taken).
fn leaf_is_array(schema: &Value, chain: &str) -> bool {
    field(schema, chain).is_some_and(|f| f["type"] == "array")
}

#[test]
fn every_panel_is_configured_and_reads_fields_tmo_writes() {
    let layout = layout();
    let configs = layout["configById"].as_object().unwrap();
    let mut ids = BTreeSet::new();
    placed(&layout["layout"], &mut ids);
    let configured: BTreeSet<String> = configs.keys().cloned().collect();
    assert_eq!(ids, configured, "placed panels against configured ones");

    let mut paths = Vec::new();
    for config in configs.values() {
        for p in config["paths"].as_array().into_iter().flatten() {
            paths.push(p["value"].as_str().unwrap().to_string());
        }
        if let Some(x) = config["xAxisPath"]["value"].as_str() {
            paths.push(x.to_string());
        }
        if let Some(t) = config["topicPath"].as_str() {
            paths.push(t.to_string());
        }
        // a Log panel reads the live view's foxglove.Log lines
        if let Some(t) = config["topicToRender"].as_str() {
            assert_eq!(t, tmo::live::LOG_TOPIC, "a Log panel shows {t}");
        }
        // a 3D panel's topics: the live view's pin scene
        for topic in config["topics"]
            .as_object()
            .into_iter()
            .flat_map(|t| t.keys())
        {
            assert_eq!(
                topic,
                tmo::live::scene::SCENE_TOPIC,
                "a 3D panel shows {topic}"
            );
        }
    }
    // the pins of all three fingertips, the classifier, the heights, the commands and the
    // hand's and arm's state
    for topic in [
        "/tactile/0",
        "/tactile/1",
        "/tactile/2",
        "/classifier",
        "/marker",
        "/command/hand",
        "/state/hand",
        "/state/arm",
    ] {
        assert!(
            paths.iter().any(|p| p.starts_with(topic)),
            "no panel shows {topic}"
        );
    }
    let wrong: Vec<String> = paths.iter().filter_map(|p| check_path(p).err()).collect();
    assert!(wrong.is_empty(), "{wrong:#?}");
}

#[test]
fn the_path_check_refuses_what_is_not_written() {
    assert!(check_path("/classifier{data.sensor==0}.data.slip").is_ok());
    assert!(check_path("/tactile/2.x[:]").is_ok());
    assert!(
        check_path("/tactile/2.x").is_err(),
        "an array plots nothing"
    );
    assert!(check_path("/state/hand.data.positions[2]").is_ok());
    assert!(check_path("/state/arm.data.pose").is_err());
    assert!(check_path("/classifier.data.speed").is_err());
    assert!(check_path("/classifier{data.finger==0}.data.slip").is_err());
    assert!(check_path("/camera.x").is_err());
}
