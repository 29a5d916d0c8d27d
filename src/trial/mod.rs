//! Trial logs: one MCAP file per trial (the robotics log format), JSON messages on one
//! channel per sensor (`/tactile/<id>`), one for the marker tracker (`/marker`) and one per
//! runner event topic, each with a JSON schema of its messages (`schema`), in
//! zstd-compressed chunks, and a metadata record `tmo.trial` with the trial's provenance.
//! Log times are wall-clock nanoseconds: the trial's start plus its own clock, so a viewer
//! shows when a trial ran (format 1 counted from 0, which viewers show as 1970).
//!
//! A log is written to a temporary name and renamed into place when complete, so a crash
//! never leaves a half-written trial under a trial's name.

use std::collections::BTreeMap;
use std::fs;
use std::io::BufWriter;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use tmo_hal::{MarkerSample, PinFrame};

mod read;
pub mod schema;
pub mod state;

pub use read::{read_trial, read_trial_bytes, read_trial_for_scoring, MAX_PIN_COORDINATE_PX};

/// Version of the log layout; readers refuse newer ones and read every older one.
/// 2: pins as `x[]`, `y[]`; typed event schemas; zstd chunks; wall-clock log times.
pub const TRIAL_FORMAT_VERSION: u32 = 2;

/// Where a trial came from: enough to reproduce it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TrialMeta {
    pub format_version: u32,
    pub trial_id: String,
    /// What was run, e.g. `hand_release_collect`.
    pub kind: String,
    pub backend: String,
    pub seed: u64,
    pub object: String,
    pub grasp_deg: f64,
    pub sensors: u8,
    pub pins: usize,
    pub tmo_version: String,
    pub git_revision: String,
    /// The protocol file and its SHA-256, when a protocol ran it.
    pub protocol: Option<String>,
    pub protocol_sha256: Option<String>,
    /// SHA-256 of the model that ran online, if any.
    pub model_sha256: Option<String>,
    /// Wall-clock start, seconds since the Unix epoch.
    pub started_unix_s: u64,
    /// Free-form parameters of the run (e.g. the release speed), as text.
    pub parameters: BTreeMap<String, String>,
}

impl TrialMeta {
    /// The held object's length along the slip axis, mm, where the trial records it
    /// ([`OBJECT_LENGTH_PARAMETER`]).
    pub fn object_length_mm(&self) -> Option<f64> {
        self.parameters
            .get(OBJECT_LENGTH_PARAMETER)
            .and_then(|v| v.parse::<f64>().ok())
            .filter(|l| l.is_finite() && *l > 0.0)
    }

    pub fn code_version() -> (String, String) {
        (
            env!("CARGO_PKG_VERSION").to_string(),
            env!("TMO_GIT_REVISION").to_string(),
        )
    }
}

/// A recorded trial.
#[derive(Debug, Clone, PartialEq)]
pub struct Trial {
    pub meta: TrialMeta,
    /// In the order they reached the host (across sensors; by `seq` within one).
    pub frames: Vec<PinFrame>,
    /// When each frame reached the host, on the runner's clock, s (the MCAP log time;
    /// the frame's own `time_s` is its capture time). Replay delivers frames at these times
    /// and in this order, so a detector sees them as the live one did.
    pub arrivals_s: Vec<f64>,
    pub markers: Vec<MarkerSample>,
    /// What the runner did and decided (commands, phases, classifier outputs, detector
    /// events), each on its own channel named by `topic`.
    pub events: Vec<TrialEvent>,
    /// The files the trial ran from (its protocol; on the real backend, its hardware
    /// file), whole, each in its own metadata record `tmo.<role>`.
    pub sources: Vec<SourceFile>,
}

/// A file a trial ran from, kept whole in its log.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SourceFile {
    /// `protocol` or `hardware`: the metadata record is `tmo.<role>`.
    pub role: String,
    pub path: String,
    pub sha256: String,
    pub text: String,
}

impl SourceFile {
    pub fn new(role: &str, path: &Path, text: &str) -> Self {
        Self {
            role: role.into(),
            path: path.display().to_string(),
            sha256: sha256_hex(text.as_bytes()),
            text: text.into(),
        }
    }
}

impl Trial {
    /// Why this log cannot be learnt from, labelled or scored, if it cannot: a log with no
    /// tactile frames has nothing to classify, and one with no marker track has no slip
    /// onset to label or score against. Such a log is refused, never counted as a trial.
    pub fn unusable(&self) -> Option<&'static str> {
        if self.frames.is_empty() {
            Some("it has no tactile frames (nothing to classify)")
        } else if self.markers.is_empty() && !self.events.iter().any(|e| e.topic == LABEL_TOPIC) {
            Some("it has neither a marker track nor slip labels (no slip onset to label or score against)")
        } else {
            None
        }
    }
}

/// The trial parameter recording the held object's length along the slip axis, mm (from the
/// object library, where it knows the object): how far the object can slide before it has
/// left the fingers, which the slip labels use.
pub const OBJECT_LENGTH_PARAMETER: &str = "object_length_mm";

/// The trial parameter naming the largest per-frame step of an element that is still a
/// measurement (in the sensor's units), or `off`; features treat larger steps as a lost
/// element. Imported trials carry their sensor's own.
pub const MAX_STEP_PARAMETER: &str = "max_element_step";

/// The topic of a trial's slip labels, where another lab's recording gives them instead of
/// a marker track (`tmo import`).
pub const LABEL_TOPIC: &str = "/label";

/// Trial metadata `kind` of an imported trial (`tmo import`); here, below both the importer
/// and the datasets that read its logs.
pub const IMPORTED_KIND: &str = "imported";

/// One runner message: `topic` is its channel (e.g. `/classifier`, `/detector`,
/// `/command/hand`), `data` its JSON body.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TrialEvent {
    pub time_s: f64,
    #[serde(skip)]
    pub topic: String,
    pub data: serde_json::Value,
}

/// Is `e` a reaction of the detector (as opposed to its being armed or disarmed)?
pub fn is_reaction(e: &TrialEvent) -> bool {
    e.topic == "/detector" && e.data.get("event").and_then(|v| v.as_str()) == Some("reaction")
}

/// Channels that are not runner events.
fn is_event_topic(topic: &str) -> bool {
    topic != "/marker" && !topic.starts_with("/tactile/")
}

#[derive(Debug, thiserror::Error)]
pub enum TrialError {
    #[error("cannot write the trial log {path}: {message}")]
    Write { path: PathBuf, message: String },
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("{path}: not a readable MCAP trial log: {message}")]
    Mcap { path: PathBuf, message: String },
    #[error("{path}: no `tmo.trial` metadata record; not a tmo trial log")]
    NoMetadata { path: PathBuf },
    #[error("{path}: message {index} on {topic}: {message}")]
    BadMessage {
        path: PathBuf,
        topic: String,
        index: usize,
        message: String,
    },
    #[error("{path}: trial format version {found} is newer than this tmo understands ({supported}); upgrade tmo")]
    NewerFormat {
        path: PathBuf,
        found: u32,
        supported: u32,
    },
    #[error("{path} is the same trial log as {first} (a copy, or given twice): each trial counts once; leave one of them out")]
    Duplicate { path: PathBuf, first: PathBuf },
    #[error("{path}: {what}, not a trial log: expected a regular .mcap file (a device, pipe or socket would be read for ever)")]
    NotAFile { path: PathBuf, what: &'static str },
}

/// What `path` is, if it is not a regular file or a directory (links followed).
fn special_file(path: &Path) -> Option<&'static str> {
    use std::os::unix::fs::FileTypeExt;
    let t = fs::metadata(path).ok()?.file_type();
    if t.is_file() || t.is_dir() {
        None
    } else if t.is_fifo() {
        Some("a named pipe (FIFO)")
    } else if t.is_char_device() || t.is_block_device() {
        Some("a device")
    } else if t.is_socket() {
        Some("a socket")
    } else {
        Some("not a regular file")
    }
}

/// A trial log's bytes, read only from a regular file: `/dev/zero`, `/dev/stdin` or a FIFO
/// named `*.mcap` is refused, not read until memory runs out or for ever.
pub fn read_log_file(path: &Path) -> Result<Vec<u8>, TrialError> {
    if let Some(what) = special_file(path) {
        return Err(TrialError::NotAFile {
            path: path.into(),
            what,
        });
    }
    fs::read(path).map_err(|source| TrialError::Io {
        path: path.into(),
        source,
    })
}

/// Refuses a set of logs in which one file's bytes repeat another's: a copied log (or a
/// folder given twice) would otherwise count its trial twice.
pub fn refuse_duplicates<'a>(
    logs: impl IntoIterator<Item = (&'a Path, &'a str)>,
) -> Result<(), TrialError> {
    let mut seen: std::collections::HashMap<&str, &Path> = std::collections::HashMap::new();
    for (path, hash) in logs {
        if let Some(first) = seen.insert(hash, path) {
            return Err(TrialError::Duplicate {
                path: path.into(),
                first: first.into(),
            });
        }
    }
    Ok(())
}

/// Why a write failed, in words that name a full disk as such.
fn describe_write_error(e: &std::io::Error) -> String {
    // ENOSPC and EDQUOT: the kind is not stable on every toolchain, the OS code is
    if e.kind() == std::io::ErrorKind::StorageFull || matches!(e.raw_os_error(), Some(28 | 122)) {
        format!("the disk is full ({e}); free space and run again")
    } else {
        e.to_string()
    }
}

fn mcap_write_err(path: &Path) -> impl Fn(mcap::McapError) -> TrialError + '_ {
    move |e| TrialError::Write {
        path: path.into(),
        message: match &e {
            mcap::McapError::Io(io) => describe_write_error(io),
            other => other.to_string(),
        },
    }
}

fn mcap_err(path: &Path) -> impl Fn(mcap::McapError) -> TrialError + '_ {
    move |e| TrialError::Mcap {
        path: path.into(),
        message: e.to_string(),
    }
}

fn nanos(t: f64) -> u64 {
    (t.max(0.0) * 1e9).round() as u64
}

/// Log time of trial-clock time 0, ns since the Unix epoch (0 for format 1).
/// Where a log's times start: the trial's wall-clock start, ns (format 1: 0).
pub(crate) fn time_base_ns(meta: &TrialMeta) -> u64 {
    if meta.format_version >= 2 {
        meta.started_unix_s.saturating_mul(1_000_000_000)
    } else {
        0
    }
}

/// The trial's provenance as MCAP metadata records, one per concern, each field its own
/// entry: `tmo.trial` (with the whole of it as `json` too, which readers read), `tmo.code`,
/// `tmo.parameters`, `tmo.model`, and one `tmo.<role>` per source file with its text.
/// A command line as a POSIX shell would take it back: each argument single-quoted when it
/// holds anything but letters, digits and `-_./:=,+@%`.
fn command_line(args: impl Iterator<Item = String>) -> String {
    let plain = |c: char| c.is_ascii_alphanumeric() || "-_./:=,+@%".contains(c);
    args.map(|a| {
        if !a.is_empty() && a.chars().all(plain) {
            a
        } else {
            format!("'{}'", a.replace('\'', "'\\''"))
        }
    })
    .collect::<Vec<_>>()
    .join(" ")
}

fn metadata_records(trial: &Trial) -> Vec<(String, BTreeMap<String, String>)> {
    let m = &trial.meta;
    let fields = |pairs: &[(&str, String)]| -> BTreeMap<String, String> {
        pairs
            .iter()
            .map(|(k, v)| (k.to_string(), v.clone()))
            .collect()
    };
    let mut records = vec![
        (
            "tmo.trial".to_string(),
            fields(&[
                (
                    "json",
                    serde_json::to_string(m).expect("metadata serialises"),
                ),
                ("format_version", m.format_version.to_string()),
                ("trial_id", m.trial_id.clone()),
                ("kind", m.kind.clone()),
                ("backend", m.backend.clone()),
                ("seed", m.seed.to_string()),
                ("object", m.object.clone()),
                ("grasp_deg", m.grasp_deg.to_string()),
                ("sensors", m.sensors.to_string()),
                ("pins", m.pins.to_string()),
                ("started_unix_s", m.started_unix_s.to_string()),
            ]),
        ),
        (
            "tmo.code".to_string(),
            fields(&[
                ("tmo_version", m.tmo_version.clone()),
                ("git_revision", m.git_revision.clone()),
                ("command_line", command_line(std::env::args())),
            ]),
        ),
        ("tmo.parameters".to_string(), m.parameters.clone()),
    ];
    if let Some(model) = &m.model_sha256 {
        records.push(("tmo.model".into(), fields(&[("sha256", model.clone())])));
    }
    for s in &trial.sources {
        records.push((
            format!("tmo.{}", s.role),
            fields(&[
                ("path", s.path.clone()),
                ("sha256", s.sha256.clone()),
                ("text", s.text.clone()),
            ]),
        ));
    }
    records
}

/// Writes `trial` to `path` atomically (temporary file, then rename).
pub fn write_trial(path: &Path, trial: &Trial) -> Result<(), TrialError> {
    let io = |source: std::io::Error| TrialError::Write {
        path: path.into(),
        message: describe_write_error(&source),
    };
    if let Some(dir) = path.parent() {
        fs::create_dir_all(dir).map_err(io)?;
    }
    crate::output::target::check_file(path).map_err(|e| io(e.into()))?;
    let tmp = path.with_extension("mcap.partial");
    {
        let file = crate::output::atomic::create_fresh(&tmp).map_err(io)?;
        let mut w = mcap::WriteOptions::new()
            .compression(Some(mcap::Compression::Zstd))
            // Level 1: on the paper preset's 240 hand-release trials it wrote 38 % of the
            // uncompressed bytes in 11.1 s, where the default level 3 wrote 40 % in 12.4 s
            // and level 9 37 % in 17.0 s (format 1, uncompressed: 10.3 s).
            .compression_level(1)
            // On the calling thread: batches already run a trial per core, and zstd's own
            // workers (by default one per core, a pool per log) only contended with them.
            .compression_threads(0)
            .create(BufWriter::new(file))
            .map_err(mcap_write_err(path))?;
        let base = time_base_ns(&trial.meta);
        let at = |t: f64| base.saturating_add(nanos(t));
        let frame_schema = w
            .add_schema(
                schema::PIN_FRAME.0,
                "jsonschema",
                schema::PIN_FRAME.1.as_bytes(),
            )
            .map_err(mcap_write_err(path))?;
        let marker_schema = w
            .add_schema(schema::MARKER.0, "jsonschema", schema::MARKER.1.as_bytes())
            .map_err(mcap_write_err(path))?;
        let none = BTreeMap::new();
        let marker_channel = w
            .add_channel(marker_schema, "/marker", "json", &none)
            .map_err(mcap_write_err(path))?;
        let mut sensor_channels = BTreeMap::new();
        for s in 0..trial.meta.sensors {
            let id = w
                .add_channel(frame_schema, &format!("/tactile/{s}"), "json", &none)
                .map_err(mcap_write_err(path))?;
            sensor_channels.insert(s, id);
        }
        let mut sequence = 0u32;
        for (k, f) in trial.frames.iter().enumerate() {
            let arrival = trial.arrivals_s.get(k).copied().unwrap_or(f.time_s);
            let channel_id = *sensor_channels
                .get(&f.sensor)
                .ok_or_else(|| TrialError::Write {
                    path: path.into(),
                    message: format!(
                        "frame from sensor {} but the trial has {} sensors",
                        f.sensor, trial.meta.sensors
                    ),
                })?;
            let data = serde_json::to_vec(&schema::PinFrameOut::from(f)).expect("frames serialise");
            let header = mcap::records::MessageHeader {
                channel_id,
                sequence,
                log_time: at(arrival),
                // captured before it arrived (a sensor clock ahead of the host's is clamped)
                publish_time: at(f.time_s.min(arrival)),
            };
            w.write_to_known_channel(&header, &data)
                .map_err(mcap_write_err(path))?;
            sequence += 1;
        }
        for m in &trial.markers {
            let data = serde_json::to_vec(m).expect("samples serialise");
            let header = mcap::records::MessageHeader {
                channel_id: marker_channel,
                sequence,
                log_time: at(m.time_s),
                publish_time: at(m.time_s),
            };
            w.write_to_known_channel(&header, &data)
                .map_err(mcap_write_err(path))?;
            sequence += 1;
        }
        let mut event_schemas: BTreeMap<&str, u16> = BTreeMap::new();
        let mut event_channels: BTreeMap<&str, u16> = BTreeMap::new();
        for e in &trial.events {
            if !is_event_topic(&e.topic) || !e.topic.starts_with('/') {
                return Err(TrialError::Mcap {
                    path: path.into(),
                    message: format!("`{}` cannot be an event channel", e.topic),
                });
            }
            let channel_id = match event_channels.get(e.topic.as_str()) {
                Some(id) => *id,
                None => {
                    let (name, text) = schema::event_channel_schema(&e.topic);
                    let schema_id = match event_schemas.get(name) {
                        Some(id) => *id,
                        None => {
                            let id = w
                                .add_schema(name, "jsonschema", text.as_bytes())
                                .map_err(mcap_write_err(path))?;
                            event_schemas.insert(name, id);
                            id
                        }
                    };
                    let id = w
                        .add_channel(schema_id, &e.topic, "json", &none)
                        .map_err(mcap_write_err(path))?;
                    event_channels.insert(&e.topic, id);
                    id
                }
            };
            let data = serde_json::to_vec(e).expect("events serialise");
            let header = mcap::records::MessageHeader {
                channel_id,
                sequence,
                log_time: at(e.time_s),
                publish_time: at(e.time_s),
            };
            w.write_to_known_channel(&header, &data)
                .map_err(mcap_write_err(path))?;
            sequence += 1;
        }
        for (name, metadata) in metadata_records(trial) {
            w.write_metadata(&mcap::records::Metadata { name, metadata })
                .map_err(mcap_write_err(path))?;
        }
        w.finish().map_err(mcap_write_err(path))?;
        let file = w
            .into_inner()
            .into_inner()
            .map_err(|e| io(e.into_error()))?;
        file.sync_all().map_err(io)?;
    }
    fs::rename(&tmp, path).map_err(io)
}

/// SHA-256 of a file's bytes, hex.
pub fn sha256_hex(bytes: &[u8]) -> String {
    use sha2::Digest;
    sha2::Sha256::digest(bytes)
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
}

/// Reads every trial in `paths` (directories expanded); returns each with its file's hash.
pub fn load_trials(paths: &[PathBuf]) -> Result<Vec<(PathBuf, String, Trial)>, TrialError> {
    use rayon::prelude::*;
    // Files are read on every core (parsing took most of a sweep's 2.5 s start on 80
    // trials); the results keep the files' order, and the first failing file in that order
    // is the one reported, as when they were read one by one.
    expand_trial_paths(paths)?
        .into_par_iter()
        .map(|path| {
            let bytes = read_log_file(&path)?;
            let hash = sha256_hex(&bytes);
            let trial = read_trial_bytes(&path, &bytes)?;
            Ok((path, hash, trial))
        })
        .collect::<Vec<Result<_, TrialError>>>()
        .into_iter()
        .collect::<Result<Vec<(PathBuf, String, Trial)>, TrialError>>()
        .and_then(|loaded| {
            refuse_duplicates(loaded.iter().map(|(p, h, _)| (p.as_path(), h.as_str())))?;
            Ok(loaded)
        })
}

/// The `.mcap` files among `paths`, with directories expanded (sorted by name); in a
/// directory, logs of aborted trials (`*.aborted.mcap`) are left out.
pub fn expand_trial_paths(paths: &[PathBuf]) -> Result<Vec<PathBuf>, TrialError> {
    let mut out = Vec::new();
    for p in paths {
        if p.is_dir() {
            let mut found: Vec<PathBuf> = fs::read_dir(p)
                .map_err(|source| TrialError::Io {
                    path: p.clone(),
                    source,
                })?
                .filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|q| q.extension().is_some_and(|x| x == "mcap"))
                // logs kept beside a batch as evidence, not as its trials
                .filter(|q| {
                    !q.file_name().is_some_and(|n| {
                        let n = n.to_string_lossy();
                        n.ends_with(".aborted.mcap") || n.contains(".faulted-")
                    })
                })
                .collect();
            found.sort();
            if let Some((q, what)) = found.iter().find_map(|q| Some((q, special_file(q)?))) {
                return Err(TrialError::NotAFile {
                    path: q.clone(),
                    what,
                });
            }
            out.extend(found);
        } else if let Some(what) = special_file(p) {
            return Err(TrialError::NotAFile {
                path: p.clone(),
                what,
            });
        } else if p.exists() {
            out.push(p.clone());
        } else {
            return Err(TrialError::Io {
                path: p.clone(),
                source: std::io::Error::new(
                    std::io::ErrorKind::NotFound,
                    "no such file or directory",
                ),
            });
        }
    }
    Ok(out)
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    #[test]
    fn a_write_that_fails_says_so_and_names_a_full_disk() {
        let full = std::io::Error::from_raw_os_error(28);
        assert!(describe_write_error(&full).starts_with("the disk is full"));
        let other = std::io::Error::from_raw_os_error(13);
        assert!(!describe_write_error(&other).contains("disk is full"));
        // a file where the log's folder should be: a write error, not "not readable"
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("f"), b"").unwrap();
        let e = write_trial(&dir.path().join("f/t.mcap"), &sample_trial()).unwrap_err();
        assert!(
            e.to_string().starts_with("cannot write the trial log"),
            "{e}"
        );
    }

    pub(crate) fn sample_trial() -> Trial {
        let (tmo_version, git_revision) = TrialMeta::code_version();
        Trial {
            meta: TrialMeta {
                format_version: TRIAL_FORMAT_VERSION,
                trial_id: "t1".into(),
                kind: "test".into(),
                backend: "sim".into(),
                seed: 3,
                object: "crisps_can".into(),
                grasp_deg: 0.0,
                sensors: 2,
                pins: 2,
                tmo_version,
                git_revision,
                protocol: None,
                protocol_sha256: None,
                model_sha256: None,
                started_unix_s: 0,
                parameters: BTreeMap::from([("release_speed".into(), "0.01".into())]),
            },
            frames: vec![
                PinFrame {
                    sensor: 0,
                    seq: 1,
                    time_s: 0.01,
                    pins: vec![[1.0, 2.0], [3.0, 4.0]],
                },
                PinFrame {
                    sensor: 1,
                    seq: 1,
                    time_s: 0.012,
                    pins: vec![[5.0, 6.0], [7.0, 8.5]],
                },
                PinFrame {
                    sensor: 0,
                    seq: 2,
                    time_s: 0.027,
                    pins: vec![[1.5, 2.0], [3.0, 4.0]],
                },
            ],
            arrivals_s: vec![0.011, 0.013, 0.028],
            markers: vec![MarkerSample {
                time_s: 0.005,
                object_mm: 300.1,
                hand_mm: 360.0,
            }],
            events: vec![
                TrialEvent {
                    time_s: 0.01,
                    topic: "/classifier".into(),
                    data: serde_json::json!({"sensor": 0, "seq": 1, "class": "static"}),
                },
                TrialEvent {
                    time_s: 0.027,
                    topic: "/detector".into(),
                    data: serde_json::json!({"event": "reaction", "sensor": 0}),
                },
            ],
            sources: vec![SourceFile::new(
                "protocol",
                Path::new("protocols/test.toml"),
                "kind = \"hand_release\"\n# a comment\n",
            )],
        }
    }

    #[test]
    fn round_trip() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.mcap");
        let trial = sample_trial();
        write_trial(&path, &trial).unwrap();
        assert!(!dir.path().join("t.mcap.partial").exists());
        assert_eq!(read_trial(&path).unwrap(), trial);
    }

    #[test]
    fn trials_load_in_name_order_and_the_first_bad_file_is_the_one_named() {
        let dir = tempfile::tempdir().unwrap();
        let mut trial = sample_trial();
        for k in 0..12 {
            trial.meta.trial_id = format!("t{k:02}");
            write_trial(&dir.path().join(format!("t{k:02}.mcap")), &trial).unwrap();
        }
        let loaded = load_trials(&[dir.path().to_path_buf()]).unwrap();
        let ids: Vec<String> = loaded
            .iter()
            .map(|(_, _, t)| t.meta.trial_id.clone())
            .collect();
        let want: Vec<String> = (0..12).map(|k| format!("t{k:02}")).collect();
        assert_eq!(ids, want);
        // two broken files among them: the first by name is reported, whichever is read first
        for k in [3, 9] {
            fs::write(dir.path().join(format!("t{k:02}.mcap")), b"not a log").unwrap();
        }
        for _ in 0..5 {
            let err = load_trials(&[dir.path().to_path_buf()]).unwrap_err();
            assert!(err.to_string().contains("t03.mcap"), "{err}");
        }
    }

    #[test]
    fn a_command_line_is_quoted_as_a_shell_reads_it() {
        let args = ["tmo", "run", "p q.toml", "--out", "it's", "", "--seed=3"];
        assert_eq!(
            command_line(args.iter().map(|s| s.to_string())),
            r#"tmo run 'p q.toml' --out 'it'\''s' '' --seed=3"#
        );
    }

    #[test]
    fn provenance_is_one_metadata_record_per_concern() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.mcap");
        write_trial(&path, &sample_trial()).unwrap();
        let bytes = fs::read(&path).unwrap();
        let summary = mcap::read::Summary::read(&bytes).unwrap().unwrap();
        let records: BTreeMap<String, BTreeMap<String, String>> = summary
            .metadata_indexes
            .iter()
            .map(|i| {
                let m = mcap::read::metadata(&bytes, i).unwrap();
                (m.name, m.metadata)
            })
            .collect();
        assert_eq!(records["tmo.trial"]["seed"], "3");
        assert_eq!(records["tmo.trial"]["kind"], "test");
        assert_eq!(records["tmo.parameters"]["release_speed"], "0.01");
        assert_eq!(
            records["tmo.code"]["git_revision"],
            TrialMeta::code_version().1
        );
        let protocol = &records["tmo.protocol"];
        assert!(protocol["text"].contains("# a comment"));
        assert_eq!(protocol["sha256"], sha256_hex(protocol["text"].as_bytes()));
        assert!(!records.contains_key("tmo.model"), "no model ran");
        // the command that wrote the log (here the test binary)
        let argv0 = std::env::args().next().unwrap();
        assert!(
            records["tmo.code"]["command_line"].starts_with(&argv0),
            "{:?}",
            records["tmo.code"]
        );
    }

    #[test]
    fn a_format_1_log_still_reads() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/trial-format1.mcap");
        let trial = read_trial(&path).unwrap();
        let mut expected = sample_trial();
        expected.meta.format_version = 1;
        expected.meta.started_unix_s = 1_764_000_000;
        expected.meta.tmo_version = "0.1.0".into();
        expected.meta.git_revision = "92ab12d".into();
        expected.sources.clear(); // format 1 did not keep them
        assert_eq!(trial, expected);
    }

    #[test]
    fn log_times_are_wall_clock_and_frames_are_published_before_they_are_logged() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.mcap");
        let mut trial = sample_trial();
        trial.meta.started_unix_s = 1_764_000_000;
        // a sensor clock ahead of the host's: captured "after" it arrived
        trial.frames[0].time_s = 0.02;
        write_trial(&path, &trial).unwrap();
        let bytes = fs::read(&path).unwrap();
        let stream = mcap::MessageStream::new(&bytes).unwrap();
        let mut tactile = 0;
        for m in stream {
            let m = m.unwrap();
            assert!(m.log_time >= 1_764_000_000_000_000_000, "{}", m.log_time);
            assert!(
                m.publish_time <= m.log_time,
                "{} > {}",
                m.publish_time,
                m.log_time
            );
            if m.channel.topic == "/tactile/0" && tactile == 0 {
                tactile += 1;
                assert_eq!(m.log_time, 1_764_000_000_011_000_000);
            }
        }
        let back = read_trial(&path).unwrap();
        assert_eq!(back.arrivals_s, trial.arrivals_s);
        assert_eq!(back, trial);
    }
}
