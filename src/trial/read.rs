//! Reading a trial log back, refusing a damaged or hostile file with an error that names it
//! before anything large is allocated for it.

use std::path::Path;

use tmo_hal::PinFrame;

use super::{mcap_err, schema, time_base_ns, Trial, TrialError, TrialMeta, TRIAL_FORMAT_VERSION};
use super::{MarkerSample, SourceFile, TrialEvent};

/// Largest chunk, and largest record, a log may declare, uncompressed. The writer closes a
/// chunk once it passes 1 MiB (mcap's default), so a trial's chunks hold at most 1 MiB and one
/// message (a frame is a few kB); 64 times that leaves room for any trial while a damaged or
/// hostile length is refused before anything is allocated for it.
const MAX_CHUNK_BYTES: u64 = 64 << 20;

/// Reads a trial log; frames and samples come back in arrival order.
pub fn read_trial(path: &Path) -> Result<Trial, TrialError> {
    read(path, Channels::All)
}

/// [`read_trial`] without the channels no outcome is scored from: the pin frames and the
/// classifier's output for each (their CRCs are still checked, their messages not parsed).
/// A batch scores every log it writes from the log; parsing these was most of that work
/// (240 hand-release logs, one thread: 21 ms a log read whole, 6.4 ms read for scoring).
pub fn read_trial_for_scoring(path: &Path) -> Result<Trial, TrialError> {
    read(path, Channels::ForScoring)
}

#[derive(Clone, Copy, PartialEq)]
enum Channels {
    All,
    ForScoring,
}

fn read(path: &Path, channels: Channels) -> Result<Trial, TrialError> {
    let buf = super::read_log_file(path)?;
    parse(path, &buf, channels)
}

/// [`read_trial`] of a log already read into `buf` from `path` (named in errors).
pub fn read_trial_bytes(path: &Path, buf: &[u8]) -> Result<Trial, TrialError> {
    parse(path, buf, Channels::All)
}

fn parse(path: &Path, buf: &[u8], channels: Channels) -> Result<Trial, TrialError> {
    let summary = mcap::read::Summary::read(buf)
        .map_err(mcap_err(path))?
        .ok_or_else(|| TrialError::Mcap {
            path: path.into(),
            message: "no summary section (the file is truncated or was not closed)".into(),
        })?;
    let mut meta: Option<TrialMeta> = None;
    let mut sources = Vec::new();
    for index in &summary.metadata_indexes {
        // mcap adds offset and length unchecked: a damaged index would overflow (a panic)
        if index
            .offset
            .checked_add(index.length)
            .is_none_or(|end| end > buf.len() as u64)
        {
            return Err(TrialError::Mcap {
                path: path.into(),
                message: format!(
                    "the metadata index of `{}` points past the file's end",
                    index.name
                ),
            });
        }
        if let Some(role) = index.name.strip_prefix("tmo.") {
            if matches!(role, "protocol" | "hardware") {
                let record = mcap::read::metadata(buf, index).map_err(mcap_err(path))?;
                let field = |k: &str| record.metadata.get(k).cloned().unwrap_or_default();
                sources.push(SourceFile {
                    role: role.into(),
                    path: field("path"),
                    sha256: field("sha256"),
                    text: field("text"),
                });
            }
        }
        if index.name != "tmo.trial" {
            continue;
        }
        let record = mcap::read::metadata(buf, index).map_err(mcap_err(path))?;
        let json = record
            .metadata
            .get("json")
            .ok_or_else(|| TrialError::NoMetadata { path: path.into() })?;
        meta = Some(
            serde_json::from_str(json).map_err(|e| TrialError::BadMessage {
                path: path.into(),
                topic: "tmo.trial metadata".into(),
                index: 0,
                message: e.to_string(),
            })?,
        );
    }
    let meta = meta.ok_or_else(|| TrialError::NoMetadata { path: path.into() })?;
    if meta.format_version > TRIAL_FORMAT_VERSION {
        return Err(TrialError::NewerFormat {
            path: path.into(),
            found: meta.format_version,
            supported: TRIAL_FORMAT_VERSION,
        });
    }
    check_chunk_sizes(buf, path)?;
    let base = time_base_ns(&meta);
    let mut frames = Vec::new();
    let mut markers = Vec::new();
    let mut events = Vec::new();
    // Chunk CRCs are checked: a log damaged on disk is refused, never scored. Every record's
    // length is bounded: a chunk's records come out of the decompressor unchecked by any CRC
    // until the chunk ends, and mcap reserves a record's declared length before reading it
    // (a fuzzed log that declared 4e18 bytes aborted the process).
    let options = mcap::sans_io::LinearReaderOptions::default()
        .with_validate_chunk_crcs(true)
        .with_record_length_limit(MAX_CHUNK_BYTES as usize);
    for (index, message) in mcap::io::MessageReader::new_with_options(buf, options).enumerate() {
        let message = message.map_err(mcap_err(path))?;
        let topic = message.channel.topic.as_str();
        let bad = |e: serde_json::Error| TrialError::BadMessage {
            path: path.into(),
            topic: topic.to_string(),
            index,
            message: e.to_string(),
        };
        if channels == Channels::ForScoring
            && (topic.starts_with("/tactile/") || topic == "/classifier")
        {
            continue;
        }
        if topic == "/marker" {
            markers.push(serde_json::from_slice::<MarkerSample>(&message.data).map_err(bad)?);
        } else if let Some(channel_sensor) = topic.strip_prefix("/tactile/") {
            let wire = serde_json::from_slice::<schema::PinFrameIn>(&message.data).map_err(bad)?;
            let f = PinFrame::try_from(wire).map_err(|message| TrialError::BadMessage {
                path: path.into(),
                topic: topic.to_string(),
                index,
                message,
            })?;
            // The channel names the sensor; a frame filed under another sensor's channel
            // is a damaged or hand-edited log (viewers and features would disagree on it).
            if channel_sensor != f.sensor.to_string() {
                return Err(TrialError::BadMessage {
                    path: path.into(),
                    topic: topic.to_string(),
                    index,
                    message: format!("a frame of sensor {} on this channel", f.sensor),
                });
            }
            frames.push((message_time_s(message.log_time, base), f));
        } else {
            let mut e: TrialEvent = serde_json::from_slice(&message.data).map_err(bad)?;
            e.topic = topic.to_string();
            events.push(e);
        }
    }
    // Stable: frames that arrived in one poll keep the order they were logged in.
    frames.sort_by(|a, b| a.0.total_cmp(&b.0));
    let (arrivals_s, frames): (Vec<f64>, Vec<PinFrame>) = frames.into_iter().unzip();
    markers.sort_by(|a, b| a.time_s.total_cmp(&b.time_s));
    // stable: events of one instant keep the order they were logged in
    events.sort_by(|a, b| a.time_s.total_cmp(&b.time_s));
    // Frames must be what the metadata says the rig had: features assume it.
    if let Some((index, f)) = frames
        .iter()
        .enumerate()
        .find(|(_, f)| f.sensor >= meta.sensors || f.pins.len() != meta.pins)
    {
        return Err(TrialError::BadMessage {
            path: path.into(),
            topic: format!("/tactile/{}", f.sensor),
            index,
            message: format!(
                "a frame of sensor {} with {} pins, but the trial's metadata says {} sensor(s) of {} pins",
                f.sensor,
                f.pins.len(),
                meta.sensors,
                meta.pins
            ),
        });
    }
    // The metadata's sensor count is what strategies and local models are checked
    // against: every sensor it names must have sent frames (a log with none at all is
    // unusable, said by `Trial::unusable`, not an error). A trial that ended in a fault
    // (Ctrl-C in its first frames, a device lost) may stop before every sensor's first
    // frame: it is kept to be read, and scored as faulted, never as a detection.
    let faulted = events.iter().any(|e| e.topic == "/fault");
    if !frames.is_empty() && !faulted {
        let silent: Vec<String> = (0..meta.sensors)
            .filter(|s| !frames.iter().any(|f| f.sensor == *s))
            .map(|s| s.to_string())
            .collect();
        if !silent.is_empty() {
            return Err(TrialError::BadMessage {
                path: path.into(),
                topic: "tmo.trial metadata".into(),
                index: 0,
                message: format!(
                    "sensors = {}, but sensor(s) {} sent no frame: expected frames from every sensor the metadata names",
                    meta.sensors,
                    silent.join(", ")
                ),
            });
        }
    }
    // A tracker reports positions in its image; a coordinate beyond any camera's image is
    // a damaged log, not a pin (features and figures would take it as a number).
    if let Some((index, f, [x, y])) = frames.iter().enumerate().find_map(|(i, f)| {
        f.pins
            .iter()
            .find(|[x, y]| !(x.abs() <= MAX_PIN_COORDINATE_PX && y.abs() <= MAX_PIN_COORDINATE_PX))
            .map(|p| (i, f, *p))
    }) {
        return Err(TrialError::BadMessage {
            path: path.into(),
            topic: format!("/tactile/{}", f.sensor),
            index,
            message: format!(
                "a pin at ({x:e}, {y:e}) px: expected image coordinates within +-{MAX_PIN_COORDINATE_PX:e}"
            ),
        });
    }
    Ok(Trial {
        meta,
        frames,
        arrivals_s,
        markers,
        events,
        sources,
    })
}

/// A log time as trial-clock seconds.
fn message_time_s(log_time_ns: u64, base_ns: u64) -> f64 {
    // whole seconds and nanoseconds apart: wall-clock nanoseconds exceed f64's exact range
    let t = log_time_ns.saturating_sub(base_ns);
    (t / 1_000_000_000) as f64 + (t % 1_000_000_000) as f64 / 1e9
}

/// Refuses a log whose chunks declare more than [`MAX_CHUNK_BYTES`] uncompressed, before the
/// MCAP reader allocates for them: walks the top-level records (opcode, length, body).
fn check_chunk_sizes(buf: &[u8], path: &Path) -> Result<(), TrialError> {
    const CHUNK: u8 = 0x06;
    const DATA_END: u8 = 0x0F;
    let damaged = |message: String| TrialError::Mcap {
        path: path.into(),
        message,
    };
    let u64_at = |at: usize| -> Option<u64> {
        Some(u64::from_le_bytes(buf.get(at..at + 8)?.try_into().ok()?))
    };
    let mut at = 8; // past the magic
    while at < buf.len() {
        let op = buf[at];
        let len =
            u64_at(at + 1).ok_or_else(|| damaged("a record header runs past the end".into()))?;
        let body = at + 9;
        if op == CHUNK {
            // message start time, end time, then the uncompressed size
            let size = u64_at(body + 16)
                .ok_or_else(|| damaged("a chunk header runs past the end".into()))?;
            if size > MAX_CHUNK_BYTES {
                return Err(damaged(format!(
                    "a chunk declares {size} bytes uncompressed (at most {MAX_CHUNK_BYTES} are read)"
                )));
            }
        }
        if op == DATA_END {
            break;
        }
        at = usize::try_from(len)
            .ok()
            .and_then(|l| body.checked_add(l))
            .ok_or_else(|| damaged("a record's length runs past the end".into()))?;
    }
    Ok(())
}

/// Largest pin coordinate a log may hold, px: far beyond any camera's image (the T-MO's
/// are 340 x 280), so only damage is refused.
pub const MAX_PIN_COORDINATE_PX: f32 = 1e5;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::trial::tests::sample_trial;
    use crate::trial::write_trial;
    use std::fs;

    /// The sample trial written as a log `t.mcap` in a fresh directory: the directory (kept
    /// for as long as the test needs the file), the log's path and its bytes.
    fn sample_log() -> (tempfile::TempDir, std::path::PathBuf, Vec<u8>) {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.mcap");
        write_trial(&path, &sample_trial()).unwrap();
        let bytes = fs::read(&path).unwrap();
        (dir, path, bytes)
    }

    /// What reading `bytes` as the log at `path` says: it must be refused.
    fn refusal(path: &Path, bytes: &[u8]) -> String {
        fs::write(path, bytes).unwrap();
        read_trial(path).unwrap_err().to_string()
    }

    #[test]
    fn a_read_for_scoring_is_the_whole_log_but_its_frames_and_classifier_outputs() {
        let (_dir, path, _) = sample_log();
        let whole = read_trial(&path).unwrap();
        let scoring = read_trial_for_scoring(&path).unwrap();
        assert!(whole.events.iter().any(|e| e.topic == "/classifier"));
        let expected = Trial {
            frames: Vec::new(),
            arrivals_s: Vec::new(),
            events: whole
                .events
                .iter()
                .filter(|e| e.topic != "/classifier")
                .cloned()
                .collect(),
            ..whole
        };
        assert_eq!(scoring, expected);
    }

    #[test]
    fn truncated_log_is_a_clear_error() {
        let (_dir, path, bytes) = sample_log();
        let err = refusal(&path, &bytes[..bytes.len() / 2]);
        assert!(err.contains("t.mcap"), "{err}");
    }

    /// Where the first chunk record's body starts in a log.
    fn first_chunk_body(bytes: &[u8]) -> usize {
        let mut at = 8;
        while bytes[at] != 0x06 {
            at += 9 + u64::from_le_bytes(bytes[at + 1..at + 9].try_into().unwrap()) as usize;
        }
        at + 9
    }

    /// Where the first chunk's compressed records lie in a log.
    fn first_chunk_records(bytes: &[u8]) -> std::ops::Range<usize> {
        let u64_at = |at: usize| u64::from_le_bytes(bytes[at..at + 8].try_into().unwrap());
        let body = first_chunk_body(bytes);
        let compression_len =
            u32::from_le_bytes(bytes[body + 28..body + 32].try_into().unwrap()) as usize;
        let records_len_at = body + 32 + compression_len;
        let start = records_len_at + 8;
        start..start + u64_at(records_len_at) as usize
    }

    #[test]
    fn a_record_in_a_chunk_that_claims_a_huge_length_is_refused_before_it_is_read() {
        let (_dir, path, mut bytes) = sample_log();
        let body = first_chunk_body(&bytes);
        let compressed = first_chunk_records(&bytes);
        let mut records = zstd::decode_all(&bytes[compressed.clone()]).unwrap();
        // the first record's length, after its opcode: what a fuzzed log declared
        records[1..9].copy_from_slice(&3_975_613_272_709_804_599u64.to_le_bytes());
        let recompressed = zstd::encode_all(&records[..], 19).unwrap();
        assert!(recompressed.len() <= compressed.len());
        // same chunk length: the new records, then padding; CRC 0 (none), so only the
        // length can refuse it
        bytes[body + 24..body + 28].fill(0);
        let size_at = compressed.start - 8;
        bytes[size_at..compressed.start]
            .copy_from_slice(&(recompressed.len() as u64).to_le_bytes());
        bytes[compressed.clone()].fill(0);
        bytes[compressed.start..compressed.start + recompressed.len()]
            .copy_from_slice(&recompressed);
        let err = refusal(&path, &bytes);
        assert!(err.contains("t.mcap") && err.contains("exceeds"), "{err}");
    }

    #[test]
    fn a_metadata_index_past_the_end_is_refused() {
        let (_dir, path, mut bytes) = sample_log();
        // the summary's index of `tmo.trial`: offset, length, then the name (u32 length first)
        let name = b"\x09\x00\x00\x00tmo.trial";
        let at = bytes.windows(name.len()).rposition(|w| w == name).unwrap();
        for offset in [u64::MAX - 3, bytes.len() as u64] {
            bytes[at - 16..at - 8].copy_from_slice(&offset.to_le_bytes());
            let err = refusal(&path, &bytes);
            assert!(
                err.contains("t.mcap") && err.contains("past the file's end"),
                "{err}"
            );
        }
    }

    #[test]
    fn one_changed_byte_in_a_chunk_is_refused() {
        let (_dir, path, clean) = sample_log();
        let records = first_chunk_records(&clean);
        for at in [records.start + records.len() / 2, records.end - 10] {
            let mut bytes = clean.clone();
            bytes[at] ^= 0x10;
            let err = refusal(&path, &bytes);
            assert!(err.contains("t.mcap"), "{err}");
        }
    }

    #[test]
    fn a_chunk_that_claims_a_huge_size_is_refused_before_it_is_read() {
        let (_dir, path, mut bytes) = sample_log();
        // the uncompressed size sits 16 bytes into the first chunk's body
        let size_at = first_chunk_body(&bytes) + 16;
        bytes[size_at..size_at + 8].copy_from_slice(&(1u64 << 50).to_le_bytes());
        let err = refusal(&path, &bytes);
        assert!(
            err.contains("t.mcap") && err.contains("uncompressed"),
            "{err}"
        );
    }

    #[test]
    fn frames_the_metadata_does_not_allow_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.mcap");
        // (a frame of a sensor the trial does not have is refused by the writer already)
        let mut five = sample_trial();
        five.frames[1].pins.push([1.0, 1.0]);
        write_trial(&path, &five).unwrap();
        let err = read_trial(&path).unwrap_err().to_string();
        assert!(err.contains("3 pins") && err.contains("of 2 pins"), "{err}");
    }

    #[test]
    fn a_sensor_the_metadata_names_that_sent_no_frame_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.mcap");
        let mut three = sample_trial();
        three.meta.sensors = 3;
        write_trial(&path, &three).unwrap();
        let err = read_trial(&path).unwrap_err().to_string();
        assert!(
            err.contains("sensors = 3") && err.contains("sensor(s) 2 sent no frame"),
            "{err}"
        );
        // unless the trial ended in a fault before that sensor's first frame (Ctrl-C
        // early in a trial: CI saw an aborted log refused so)
        let mut aborted = three.clone();
        aborted.events.push(TrialEvent {
            time_s: 0.01,
            topic: "/fault".into(),
            data: serde_json::json!({"fault": "interrupted"}),
        });
        write_trial(&path, &aborted).unwrap();
        assert!(read_trial(&path).is_ok());
        // a log with no frames at all is read, and called unusable where it is used
        let mut none = sample_trial();
        none.frames.clear();
        none.arrivals_s.clear();
        write_trial(&path, &none).unwrap();
        assert!(read_trial(&path).unwrap().unusable().is_some());
    }

    #[test]
    fn a_frame_on_another_sensors_channel_is_refused() {
        // the writer files each frame under its own sensor's channel, so the log is built
        // by hand: sensor 1's frame on /tactile/0
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.mcap");
        let trial = sample_trial();
        let mut w =
            mcap::Writer::new(std::io::BufWriter::new(fs::File::create(&path).unwrap())).unwrap();
        let schema = w
            .add_schema(
                schema::PIN_FRAME.0,
                "jsonschema",
                schema::PIN_FRAME.1.as_bytes(),
            )
            .unwrap();
        let none = std::collections::BTreeMap::new();
        let channel = w.add_channel(schema, "/tactile/0", "json", &none).unwrap();
        for (sequence, f) in trial.frames.iter().enumerate() {
            let data = serde_json::to_vec(&schema::PinFrameOut::from(f)).unwrap();
            let header = mcap::records::MessageHeader {
                channel_id: channel,
                sequence: sequence as u32,
                log_time: time_base_ns(&trial.meta) + (f.time_s * 1e9) as u64,
                publish_time: time_base_ns(&trial.meta) + (f.time_s * 1e9) as u64,
            };
            w.write_to_known_channel(&header, &data).unwrap();
        }
        w.write_metadata(&mcap::records::Metadata {
            name: "tmo.trial".into(),
            metadata: std::collections::BTreeMap::from([(
                "json".to_string(),
                serde_json::to_string(&trial.meta).unwrap(),
            )]),
        })
        .unwrap();
        w.finish().unwrap();
        drop(w);
        let err = read_trial(&path).unwrap_err().to_string();
        assert!(
            err.contains("/tactile/0") && err.contains("a frame of sensor 1 on this channel"),
            "{err}"
        );
    }

    #[test]
    fn newer_format_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.mcap");
        let mut trial = sample_trial();
        trial.meta.format_version = TRIAL_FORMAT_VERSION + 1;
        write_trial(&path, &trial).unwrap();
        let err = read_trial(&path).unwrap_err();
        assert!(matches!(err, TrialError::NewerFormat { .. }), "{err}");
    }
}
