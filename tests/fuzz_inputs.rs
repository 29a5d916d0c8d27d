//! Fuzzing of every file a user hands tmo: protocol TOML, hardware TOML, model JSON, MCAP
//! trial logs and report inputs (a batch's `outcomes.json` and `batch.json`, a sweep CSV).
//!
//! Each target starts from real files (the repository's protocols and hardware file, and
//! models, logs and batches made here by the real binary on the simulator) and mutates
//! their bytes: flips, inserts, deletions, repeats of a slice, and splices of interesting
//! tokens (huge and non-finite numbers, NUL, quotes, brackets). Whatever comes out, reading
//! it must end in a value or an error: never a panic, never a hang (a watchdog fails the
//! case after 20 s).
//!
//! CI runs a few hundred cases per target; set `TMO_FUZZ_CASES` for a long local run, e.g.
//! `TMO_FUZZ_CASES=100000 cargo test --release --test fuzz_inputs`.

mod common;

use std::path::{Path, PathBuf};
use std::sync::{mpsc, OnceLock};
use std::time::Duration;

use proptest::prelude::*;

use common::*;

/// Cases per target: `TMO_FUZZ_CASES`, or a CI-sized default.
fn cases() -> u32 {
    std::env::var("TMO_FUZZ_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(300)
}

/// Seed files made once for every target: real outputs of the binary.
struct Seeds {
    _dir: tempfile::TempDir,
    models: Vec<Vec<u8>>,
    trial_log: Vec<u8>,
    outcomes: Vec<u8>,
    batch: Vec<u8>,
    sweep_csv: Vec<u8>,
}

fn seeds() -> &'static Seeds {
    static SEEDS: OnceLock<Seeds> = OnceLock::new();
    SEEDS.get_or_init(|| {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        ok(&tmo(
            d,
            &[
                "sim", "collect", "--rig", "rail", "--trials", "4", "--out", "t",
            ],
        ));
        let mut models = Vec::new();
        for (kind, extra) in [
            ("svm-rbf", &["--C", "1"][..]),
            ("svm-linear", &["--C", "0.1"][..]),
            ("logreg", &["--C", "1"][..]),
            ("threshold", &[][..]),
        ] {
            let out = format!("{kind}.json");
            let mut args = vec!["train", "t", "--classifier", kind, "--out", &out];
            args.extend_from_slice(extra);
            ok(&tmo(d, &args));
            models.push(std::fs::read(d.join(&out)).unwrap());
        }
        let protocol = Path::new(env!("CARGO_MANIFEST_DIR")).join("protocols/rail_collect.toml");
        ok(&tmo(
            d,
            &[
                "run",
                protocol.to_str().unwrap(),
                "--repeat",
                "2",
                "--out",
                "b",
            ],
        ));
        ok(&tmo(
            d,
            &[
                "sweep",
                "t",
                "--classifiers",
                "threshold",
                "--n-slip",
                "3:4",
                "--downsample",
                "1.0",
                "--out",
                "s/sweep.csv",
            ],
        ));
        Seeds {
            models,
            trial_log: std::fs::read(d.join("b/trial-00000.mcap")).unwrap(),
            outcomes: std::fs::read(d.join("b/outcomes.json")).unwrap(),
            batch: std::fs::read(d.join("b/batch.json")).unwrap(),
            sweep_csv: std::fs::read(d.join("s/sweep.csv")).unwrap(),
            _dir: dir,
        }
    })
}

/// The repository's own files of one folder, read once.
fn repo_files(dir: &'static str) -> &'static [Vec<u8>] {
    static PROTOCOLS: OnceLock<Vec<Vec<u8>>> = OnceLock::new();
    static HARDWARE: OnceLock<Vec<Vec<u8>>> = OnceLock::new();
    let cell = if dir == "protocols" {
        &PROTOCOLS
    } else {
        &HARDWARE
    };
    cell.get_or_init(|| read_repo_files(dir))
}

fn read_repo_files(dir: &str) -> Vec<Vec<u8>> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join(dir);
    let mut files: Vec<PathBuf> = std::fs::read_dir(root)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "toml"))
        .collect();
    files.sort();
    files.iter().map(|p| std::fs::read(p).unwrap()).collect()
}

/// Tokens that have broken parsers before.
const TOKENS: &[&[u8]] = &[
    b"1e308",
    b"-1e308",
    b"nan",
    b"inf",
    b"-0",
    b"18446744073709551616",
    b"4294967295",
    b"\0",
    b"\"",
    b"[",
    b"]]",
    b"{",
    b"}",
    b"=",
    b",",
    b"\n",
    b"null",
    b"true",
    b"[[",
    b"\xff\xfe",
    b"0.0",
    b"-1",
];

#[derive(Debug, Clone)]
enum Edit {
    Flip(usize, u8),
    Insert(usize, u8),
    Delete(usize, usize),
    Repeat(usize, usize, usize),
    Token(usize, usize),
    /// The whole line at a position, k times more: duplicated rows (issue 41's R-a, R-d and
    /// D-b were rows and inputs given twice).
    RepeatLine(usize, usize),
}

fn edits() -> impl Strategy<Value = Vec<Edit>> {
    let edit = prop_oneof![
        (any::<usize>(), any::<u8>()).prop_map(|(p, b)| Edit::Flip(p, b)),
        (any::<usize>(), any::<u8>()).prop_map(|(p, b)| Edit::Insert(p, b)),
        (any::<usize>(), 1usize..64).prop_map(|(p, n)| Edit::Delete(p, n)),
        (any::<usize>(), 1usize..64, 1usize..20).prop_map(|(p, n, k)| Edit::Repeat(p, n, k)),
        (any::<usize>(), any::<usize>()).prop_map(|(p, t)| Edit::Token(p, t)),
        (any::<usize>(), 1usize..4).prop_map(|(p, k)| Edit::RepeatLine(p, k)),
    ];
    prop::collection::vec(edit, 1..6)
}

fn mutate(seed: &[u8], edits: &[Edit]) -> Vec<u8> {
    let mut b = seed.to_vec();
    for e in edits {
        let len = b.len();
        let at = |p: usize| if len == 0 { 0 } else { p % (len + 1) };
        match *e {
            Edit::Flip(p, x) if len > 0 => b[p % len] ^= x.max(1),
            Edit::Flip(..) => {}
            Edit::Insert(p, x) => b.insert(at(p), x),
            Edit::Delete(p, n) => {
                let s = at(p);
                b.drain(s..(s + n).min(len));
            }
            Edit::Repeat(p, n, k) => {
                let s = at(p);
                let slice: Vec<u8> = b[s..(s + n).min(len)].to_vec();
                for _ in 0..k {
                    b.splice(s..s, slice.iter().copied());
                }
            }
            Edit::Token(p, t) => {
                let s = at(p);
                b.splice(s..s, TOKENS[t % TOKENS.len()].iter().copied());
            }
            Edit::RepeatLine(p, k) => {
                let s = at(p).min(len);
                let start = b[..s]
                    .iter()
                    .rposition(|&c| c == b'\n')
                    .map_or(0, |i| i + 1);
                let end = b[s..]
                    .iter()
                    .position(|&c| c == b'\n')
                    .map_or(len, |i| s + i + 1);
                let mut line = b[start..end].to_vec();
                if line.last() != Some(&b'\n') {
                    line.push(b'\n');
                }
                for _ in 0..k {
                    b.splice(start..start, line.iter().copied());
                }
            }
        }
    }
    b
}

/// Runs `read` on `bytes` written to `name` in a fresh directory (with the unmutated files
/// `beside` next to it); fails the case on a panic or if it takes longer than a watchdog's
/// 20 s.
fn survives(
    name: &str,
    bytes: Vec<u8>,
    beside: &[(&str, &[u8])],
    read: fn(&Path),
) -> Result<(), TestCaseError> {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join(name);
    let parent = path.parent().unwrap().to_path_buf();
    std::fs::create_dir_all(&parent).unwrap();
    for (other, content) in beside {
        std::fs::write(parent.join(other), content).unwrap();
    }
    std::fs::write(&path, &bytes).unwrap();
    let (tx, rx) = mpsc::channel();
    let worker = std::thread::spawn(move || {
        let outcome = std::panic::catch_unwind(|| read(&path));
        let _ = tx.send(outcome.is_ok());
    });
    let shown = || String::from_utf8_lossy(&bytes[..bytes.len().min(400)]).into_owned();
    match rx.recv_timeout(Duration::from_secs(20)) {
        Ok(true) => {
            let _ = worker.join();
            Ok(())
        }
        Ok(false) => Err(TestCaseError::fail(format!(
            "{name}: panicked on {} bytes: {:?}",
            bytes.len(),
            shown()
        ))),
        Err(_) => Err(TestCaseError::fail(format!(
            "{name}: no answer within 20 s on {} bytes: {:?}",
            bytes.len(),
            shown()
        ))),
    }
}

fn read_protocol(path: &Path) {
    // models named by a mutated protocol are looked up beside it: none exist, which is an error
    let _ = tmo::protocol::load(path, 3);
}

fn read_hardware(path: &Path) {
    let _ = tmo::runner::hardware::load(path);
}

fn read_model(path: &Path) {
    if let Ok(m) = tmo::slip::model::ModelFile::load(path) {
        // a model that loads saves and loads again as the same model
        let again = path.with_file_name("again.json");
        m.save(&again).expect("a loaded model saves");
        let back = tmo::slip::model::ModelFile::load(&again).expect("a saved model loads");
        assert_eq!(
            serde_json::to_value(&back).unwrap(),
            serde_json::to_value(&m).unwrap()
        );
        // a model that loads must also classify and describe itself without panicking
        let _ = m.fits(1, m.features.pins);
        let _ = m.unconverged();
        let frame = vec![0.5f32; 2 * m.features.pins];
        if let Some(s) = m.for_sensor(0) {
            let _ = s.predict(&frame, &mut Vec::new());
        }
    }
}

fn read_trial_log(path: &Path) {
    if let Ok(t) = tmo::trial::read_trial(path) {
        let _ = t.unusable();
        let _ = tmo::runner::score::score_trial(&t, &Default::default());
    }
}

fn read_trial_deeply(path: &Path) {
    if let Ok(t) = tmo::trial::read_trial(path) {
        let _ = t.unusable();
        let _ = tmo::runner::score::score_trial(&t, &Default::default());
        let features = tmo::slip::features::FeatureSpec::new(t.meta.pins);
        let labels = tmo::slip::dataset::LabelSpec {
            n_slip: 13,
            onset: Default::default(),
        };
        let _ = tmo::slip::dataset::Dataset::from_trials(&[t], &features, &labels);
    }
}

#[derive(Debug, Clone)]
enum ContentChange {
    Pin {
        frame: usize,
        pin: usize,
        at: [f32; 2],
    },
    Sensor {
        frame: usize,
        id: u8,
    },
    PinCount {
        frame: usize,
        keep: usize,
    },
    FrameTime {
        frame: usize,
        time_s: f64,
    },
    Marker {
        sample: usize,
        object_mm: f64,
        hand_mm: f64,
        time_s: f64,
    },
    DropMarkers {
        from: usize,
    },
    MetaPins(usize),
    MetaSensors(u8),
}

impl ContentChange {
    fn apply(&self, t: &mut tmo::trial::Trial) {
        let nf = t.frames.len().max(1);
        let nm = t.markers.len().max(1);
        match *self {
            ContentChange::Pin { frame, pin, at } => {
                if let Some(f) = t.frames.get_mut(frame % nf) {
                    let n = f.pins.len().max(1);
                    if let Some(p) = f.pins.get_mut(pin % n) {
                        *p = at;
                    }
                }
            }
            ContentChange::Sensor { frame, id } => {
                if let Some(f) = t.frames.get_mut(frame % nf) {
                    f.sensor = id;
                }
            }
            ContentChange::PinCount { frame, keep } => {
                if let Some(f) = t.frames.get_mut(frame % nf) {
                    f.pins.truncate(keep);
                }
            }
            ContentChange::FrameTime { frame, time_s } => {
                if let Some(f) = t.frames.get_mut(frame % nf) {
                    f.time_s = time_s;
                }
            }
            ContentChange::Marker {
                sample,
                object_mm,
                hand_mm,
                time_s,
            } => {
                if let Some(m) = t.markers.get_mut(sample % nm) {
                    *m = tmo::hal::MarkerSample {
                        time_s,
                        object_mm,
                        hand_mm,
                    };
                }
            }
            ContentChange::DropMarkers { from } => t.markers.truncate(from % nm),
            ContentChange::MetaPins(p) => t.meta.pins = p,
            ContentChange::MetaSensors(n) => t.meta.sensors = n,
        }
    }
}

/// Numbers that break arithmetic, and ordinary ones.
fn wild_f64() -> impl Strategy<Value = f64> {
    prop_oneof![
        -1e4f64..1e4,
        Just(f64::MAX),
        Just(-f64::MAX),
        Just(1e308),
        Just(0.0),
        Just(-0.0),
        Just(f64::MIN_POSITIVE),
    ]
}

fn content_change() -> impl Strategy<Value = ContentChange> {
    let wild_f32 = prop_oneof![
        -1e3f32..1e3,
        Just(f32::MAX),
        Just(-f32::MAX),
        Just(1e5f32),
        Just(0.0f32)
    ];
    prop_oneof![
        (any::<usize>(), any::<usize>(), [wild_f32.clone(), wild_f32])
            .prop_map(|(frame, pin, at)| ContentChange::Pin { frame, pin, at }),
        (any::<usize>(), any::<u8>()).prop_map(|(frame, id)| ContentChange::Sensor { frame, id }),
        (any::<usize>(), 0usize..40)
            .prop_map(|(frame, keep)| ContentChange::PinCount { frame, keep }),
        (any::<usize>(), wild_f64())
            .prop_map(|(frame, time_s)| ContentChange::FrameTime { frame, time_s }),
        (any::<usize>(), wild_f64(), wild_f64(), wild_f64()).prop_map(
            |(sample, object_mm, hand_mm, time_s)| {
                ContentChange::Marker {
                    sample,
                    object_mm,
                    hand_mm,
                    time_s,
                }
            }
        ),
        any::<usize>().prop_map(|from| ContentChange::DropMarkers { from }),
        (0usize..100).prop_map(ContentChange::MetaPins),
        any::<u8>().prop_map(ContentChange::MetaSensors),
    ]
}

fn read_batch_dir(path: &Path) {
    // `path` is the mutated outcomes.json or batch.json inside a batch directory
    let dir = path.parent().unwrap().to_path_buf();
    if let Ok(inputs) = tmo::report::inputs::load(&[dir]) {
        let _ = tmo::report::build::tables(&inputs);
    }
}

/// The first frames of the real Xela recordings `tmo import csv` is tested on: 1,200 rows,
/// both sensors' first frames of one trial, with slip labels and a split column.
fn interchange_csv() -> &'static [u8] {
    static CSV: OnceLock<Vec<u8>> = OnceLock::new();
    CSV.get_or_init(|| {
        let path =
            Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/xela/xela-4-trials.csv");
        let text = std::fs::read_to_string(path).unwrap();
        let lines: Vec<&str> = text.lines().take(1201).collect();
        (lines.join("\n") + "\n").into_bytes()
    })
}

fn interchange_options() -> tmo::import::ImportOptions {
    tmo::import::ImportOptions {
        sensor_name: "xela-uskin-4x4".into(),
        units: tmo::import::Units::Counts,
        split_column: Some("split".into()),
        max_step: None,
        ..Default::default()
    }
}

#[test]
fn the_interchange_seed_imports_as_one_trial_of_two_sensors() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("x.csv");
    std::fs::write(&path, interchange_csv()).unwrap();
    let summary = tmo::import::read_interchange(&path, &interchange_options()).unwrap();
    assert_eq!(summary.trials.len(), 1);
    let trial = &summary.trials[0].trial;
    assert_eq!((trial.meta.sensors, trial.meta.pins), (2, 16));
    assert!(trial.frames.len() >= 70, "{}", trial.frames.len());
}

fn read_interchange(path: &Path) {
    if let Ok(summary) = tmo::import::read_interchange(path, &interchange_options()) {
        // What imports is written as trial logs that every later reader takes: read back,
        // usable, and loaded as train loads a dataset (an import that accepts what the
        // project's own readers refuse fails the case with a panic).
        let out = path.with_file_name("logs");
        let mut written = Vec::new();
        for t in &summary.trials {
            let log = tmo::import::log_path(&out, t);
            tmo::trial::write_trial(&log, &t.trial).expect("an imported trial writes");
            let back = tmo::trial::read_trial(&log).expect("an imported log reads back");
            assert_eq!(back.unusable(), None, "{}", log.display());
            written.push(log);
        }
        let labels = tmo::slip::dataset::LabelSpec {
            n_slip: 5,
            onset: Default::default(),
        };
        if let Err(e) = tmo::slip::dataset::load_labelled(&written, &labels) {
            panic!("imported, then refused by train's loader: {e}");
        }
    }
}

/// The import's flags on: repeated frames dropped, names mapped (to themselves).
fn read_interchange_with_flags(path: &Path) {
    let opts = tmo::import::ImportOptions {
        dedupe: true,
        columns: [("element".to_string(), "element".to_string())].into(),
        ..interchange_options()
    };
    if let Ok(summary) = tmo::import::read_interchange(path, &opts) {
        let _ = tmo::import::import_notes(&summary.trials, true);
    }
}

fn read_sweep(path: &Path) {
    if let Ok(inputs) = tmo::report::inputs::load(&[path.to_path_buf()]) {
        let _ = tmo::report::build::tables(&inputs);
    }
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: cases(),
        failure_persistence: None,
        ..ProptestConfig::default()
    })]

    #[test]
    fn protocol_files(pick in any::<usize>(), e in edits()) {
        let seeds = repo_files("protocols");
        survives("p.toml", mutate(&seeds[pick % seeds.len()], &e), &[], read_protocol)?;
    }

    #[test]
    fn hardware_files(pick in any::<usize>(), e in edits()) {
        let seeds = repo_files("hardware");
        survives("hw.toml", mutate(&seeds[pick % seeds.len()], &e), &[], read_hardware)?;
    }

    #[test]
    fn model_files(pick in any::<usize>(), e in edits()) {
        let models = &seeds().models;
        survives("m.json", mutate(&models[pick % models.len()], &e), &[], read_model)?;
    }

    #[test]
    fn trial_logs(e in edits()) {
        survives("trial-00000.mcap", mutate(&seeds().trial_log, &e), &[], read_trial_log)?;
    }

    #[test]
    fn batch_outcomes(e in edits(), outcomes in any::<bool>()) {
        let s = seeds();
        // one of the batch's two files is mutated, the other stays as written
        let (name, bytes, beside) = if outcomes {
            ("b/outcomes.json", mutate(&s.outcomes, &e), ("batch.json", &s.batch[..]))
        } else {
            ("b/batch.json", mutate(&s.batch, &e), ("outcomes.json", &s.outcomes[..]))
        };
        survives(name, bytes, &[beside], read_batch_dir)?;
    }

    /// The MCAP layer's CRCs refuse most byte edits of a log; this target changes what a
    /// log says instead (pins, sensor ids, pin counts, times, marker heights, any numbers)
    /// and writes it as tmo would, so that the readers behind the CRCs are reached.
    #[test]
    fn trial_log_contents(changes in prop::collection::vec(content_change(), 1..8)) {
        let s = seeds();
        let path = s._dir.path().join("b/trial-00000.mcap");
        let mut trial = tmo::trial::read_trial(&path).unwrap();
        for c in &changes {
            c.apply(&mut trial);
        }
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("t.mcap");
        // a log tmo cannot even write (numbers JSON has no words for) is not a reader's input
        if tmo::trial::write_trial(&out, &trial).is_ok() {
            let bytes = std::fs::read(&out).unwrap();
            survives("t.mcap", bytes, &[], read_trial_deeply)?;
        }
    }

    #[test]
    fn interchange_csvs(e in edits()) {
        survives("x.csv", mutate(interchange_csv(), &e), &[], read_interchange)?;
    }

    #[test]
    fn interchange_csvs_with_flags(e in edits()) {
        survives("x.csv", mutate(interchange_csv(), &e), &[], read_interchange_with_flags)?;
    }

    #[test]
    fn sweep_csvs(e in edits()) {
        survives("s/sweep.csv", mutate(&seeds().sweep_csv, &e), &[], read_sweep)?;
    }

    /// What an output path names (T4-2, T4-5): nothing, a file, a link to a file, a
    /// dangling link, a FIFO, a directory, or an empty path; a file written there either
    /// replaces a regular file or an absent one, or is refused with the node left as it
    /// was, and a stale temporary planted as a link never writes through.
    #[cfg(unix)]
    #[test]
    fn output_targets(shape in 0u8..7, planted_partial in any::<bool>(), bytes in prop::collection::vec(any::<u8>(), 0..64)) {
        let dir = tempfile::tempdir().unwrap();
        let precious = dir.path().join("precious");
        std::fs::write(&precious, b"keep").unwrap();
        let target = dir.path().join("out");
        match shape {
            0 => {}
            1 => std::fs::write(&target, b"old").unwrap(),
            2 => std::os::unix::fs::symlink(&precious, &target).unwrap(),
            3 => std::os::unix::fs::symlink(dir.path().join("nowhere"), &target).unwrap(),
            4 => {
                let name = std::ffi::CString::new(target.as_os_str().as_encoded_bytes()).unwrap();
                // SAFETY: a valid C string; mkfifo only creates the node
                prop_assert_eq!(unsafe { libc::mkfifo(name.as_ptr(), 0o600) }, 0);
            }
            5 => std::fs::create_dir(&target).unwrap(),
            _ => {}
        }
        let target = if shape == 6 { std::path::PathBuf::new() } else { target };
        if planted_partial && shape != 6 {
            let partial = tmo::output::atomic::partial_path(&target);
            let _ = std::os::unix::fs::symlink(&precious, partial);
        }
        let before = std::fs::symlink_metadata(&target).ok().map(|m| m.file_type());
        // the directory check agrees: a directory output is absent or a directory
        let dir_ok = tmo::output::target::check_dir(&target).is_ok();
        prop_assert_eq!(dir_ok, matches!(shape, 0 | 5));
        let written = tmo::output::atomic::write_atomic(&target, &bytes);
        match shape {
            0 | 1 => {
                prop_assert!(written.is_ok(), "{:?}", written);
                prop_assert_eq!(std::fs::read(&target).unwrap(), bytes);
            }
            _ => {
                prop_assert!(written.is_err(), "shape {} was written", shape);
                let after = std::fs::symlink_metadata(&target).ok().map(|m| m.file_type());
                prop_assert_eq!(before, after);
            }
        }
        // nothing was ever written through a link
        prop_assert_eq!(std::fs::read(&precious).unwrap(), b"keep".to_vec());
    }
}
