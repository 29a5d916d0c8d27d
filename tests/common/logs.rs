//! Checks of written trial logs with the `mcap` crate's own reader, as a viewer reads them.

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

/// Opens `path` with chunk CRCs checked and validates every message against its channel's
/// JSON schema; returns the topics it saw.
pub fn check_log_schemas(path: &Path) -> BTreeSet<String> {
    let bytes = std::fs::read(path).unwrap();
    let mut validators: BTreeMap<u16, jsonschema::Validator> = BTreeMap::new();
    let mut topics = BTreeSet::new();
    let stream = mcap::MessageStream::new_with_options(
        &bytes,
        mcap::read::Options::ValidateChunkCrcs.into(),
    )
    .unwrap();
    for message in stream {
        let m = message.unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let channel = &m.channel;
        let schema = channel.schema.as_ref().expect("every channel has a schema");
        assert_eq!(schema.encoding, "jsonschema", "{}", channel.topic);
        assert_eq!(channel.message_encoding, "json", "{}", channel.topic);
        let validator = validators.entry(channel.id).or_insert_with(|| {
            let text: serde_json::Value = serde_json::from_slice(&schema.data).unwrap();
            jsonschema::validator_for(&text)
                .unwrap_or_else(|e| panic!("{}: not a JSON schema: {e}", channel.topic))
        });
        let value: serde_json::Value = serde_json::from_slice(&m.data).unwrap();
        if let Err(e) = validator.validate(&value) {
            panic!(
                "{}: {} does not fit its schema: {e}\n{value}",
                path.display(),
                channel.topic
            );
        }
        assert!(m.publish_time <= m.log_time, "{}", channel.topic);
        topics.insert(channel.topic.clone());
    }
    topics
}
