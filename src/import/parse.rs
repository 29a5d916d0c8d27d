//! Reading the interchange CSV: columns, rows, and the checks that name file and line.

use std::collections::{BTreeMap, HashMap};
use std::path::Path;

use tmo_hal::MarkerSample;

use super::{
    build_trial, FrameRows, ImportError, ImportOptions, ImportSummary, LabelSource, TrialRows,
};

const REQUIRED: [&str; 7] = ["trial", "sensor", "frame", "t_s", "element", "x", "y"];
/// Every interchange column a `--columns` mapping may name.
pub const INTERCHANGE_COLUMNS: [&str; 13] = [
    "trial",
    "sensor",
    "frame",
    "t_s",
    "element",
    "x",
    "y",
    "z",
    "slip",
    "onset_s",
    "object_mm",
    "hand_mm",
    "object",
];
/// Largest element value a trial log holds (the log reader's bound on pin coordinates).
const MAX_VALUE: f64 = 1e5;
/// More elements than any sensor has; a bigger index is a typo, not a sensor.
const MAX_ELEMENTS: u64 = 4096;

struct Columns {
    required: [usize; 7],
    slip: Option<usize>,
    onset: Option<usize>,
    heights: Option<(usize, usize)>,
    object: Option<usize>,
    split: Option<usize>,
    z: Option<usize>,
}

fn columns(
    header: &csv::StringRecord,
    opts: &ImportOptions,
) -> Result<(Columns, LabelSource, Vec<String>), String> {
    if let Some(unknown) = opts
        .columns
        .keys()
        .find(|k| !INTERCHANGE_COLUMNS.contains(&k.as_str()))
    {
        return Err(format!(
            "--columns {unknown}=...: `{unknown}` is not an interchange column (expected one of {})",
            INTERCHANGE_COLUMNS.join(", ")
        ));
    }
    // one file column read as two interchange columns would be read twice, and the real
    // one left out (T4-8)
    let mut mapped: Vec<(&String, &String)> = opts.columns.iter().collect();
    mapped.sort_by_key(|(_, theirs)| theirs.as_str());
    if let Some(w) = mapped.windows(2).find(|w| w[0].1 == w[1].1) {
        return Err(format!(
            "--columns {}={} and {}={}: the file's `{}` column is mapped twice; map each file column to one interchange column",
            w[0].0, w[0].1, w[1].0, w[1].1, w[0].1
        ));
    }
    // a column named twice in the file: which one is meant cannot be told (I-c)
    let names: Vec<&str> = header.iter().map(str::trim).collect();
    if let Some((i, name)) = names
        .iter()
        .enumerate()
        .find(|(i, n)| names[..*i].contains(n))
    {
        return Err(format!(
            "the header names `{name}` twice (columns {} and {}): rename one",
            names.iter().position(|n| n == name).expect("seen") + 1,
            i + 1
        ));
    }
    let in_file = |h: &str| header.iter().any(|c| c.trim() == h);
    for (ours, theirs) in &opts.columns {
        if !in_file(theirs) {
            return Err(format!(
                "--columns {ours}={theirs}: no `{theirs}` column (found: {})",
                header.iter().collect::<Vec<_>>().join(", ")
            ));
        }
    }
    // An interchange column is read under the file's own name where --columns gives one;
    // a file column renamed away is not also read under its own name.
    let find = |name: &str| match opts.columns.get(name) {
        Some(theirs) => header.iter().position(|h| h.trim() == theirs),
        None if opts.columns.values().any(|v| v == name) => None,
        None => header.iter().position(|h| h.trim() == name),
    };
    // Every missing column is named at once, with the one --columns that maps them all.
    let missing: Vec<&str> = REQUIRED
        .iter()
        .copied()
        .filter(|n| find(n).is_none())
        .collect();
    let mut problems = Vec::new();
    if !missing.is_empty() {
        let quoted: Vec<String> = missing.iter().map(|n| format!("`{n}`")).collect();
        let mapping: Vec<String> = missing.iter().map(|n| format!("{n}=<its name>")).collect();
        problems.push(format!(
            "no {} column; the interchange CSV needs {} (found: {}); {} mapped with --columns {}",
            quoted.join(" or "),
            REQUIRED.join(", "),
            header.iter().collect::<Vec<_>>().join(", "),
            if missing.len() == 1 {
                "a column of another name is"
            } else {
                "columns of other names are"
            },
            mapping.join(",")
        ));
    }
    if let Some(name) = &opts.split_column {
        if find(name).is_none() {
            problems.push(format!("no `{name}` column (--split-column)"));
        }
    }
    if !problems.is_empty() {
        return Err(problems.join("; "));
    }
    let required: [usize; 7] = REQUIRED.map(|n| find(n).expect("checked above"));
    let slip = find("slip");
    let onset = find("onset_s");
    let heights = match (find("object_mm"), find("hand_mm")) {
        (Some(o), Some(h)) => Some((o, h)),
        (None, None) => None,
        _ => return Err("`object_mm` and `hand_mm` come together (marker heights)".into()),
    };
    let source = match (slip, onset, heights) {
        (Some(_), None, None) => LabelSource::SlipColumn,
        (None, Some(_), None) => LabelSource::OnsetColumn,
        (None, None, Some(_)) => LabelSource::MarkerHeights,
        (None, None, None) => {
            return Err("no labels: expected one of a `slip` column (0/1 per frame), an `onset_s` column (per trial) or `object_mm` and `hand_mm` (marker heights)".into())
        }
        _ => return Err("more than one label source (`slip`, `onset_s`, `object_mm`/`hand_mm`): keep one".into()),
    };
    let split = opts
        .split_column
        .as_ref()
        .map(|name| find(name).expect("checked above"));
    let object = find("object");
    let z = find("z");
    let known: Vec<usize> = required
        .iter()
        .copied()
        .chain(slip)
        .chain(onset)
        .chain(heights.map(|h| h.0))
        .chain(heights.map(|h| h.1))
        .chain(object)
        .chain(split)
        .chain(z)
        .collect();
    let ignored = header
        .iter()
        .enumerate()
        .filter(|(i, _)| !known.contains(i))
        .map(|(_, h)| h.to_string())
        .collect();
    Ok((
        Columns {
            required,
            slip,
            onset,
            heights,
            object,
            split,
            z,
        },
        source,
        ignored,
    ))
}

fn number(record: &csv::StringRecord, i: usize, name: &str) -> Result<f64, String> {
    let text = record.get(i).unwrap_or("").trim();
    match text.parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v),
        _ => Err(format!("column `{name}`: `{text}` is not a finite number")),
    }
}

fn whole(record: &csv::StringRecord, i: usize, name: &str) -> Result<u64, String> {
    let text = record.get(i).unwrap_or("").trim();
    text.parse::<u64>()
        .map_err(|_| format!("column `{name}`: `{text}` is not a whole number >= 0"))
}

fn text<'r>(record: &'r csv::StringRecord, i: usize, name: &str) -> Result<&'r str, String> {
    let t = record.get(i).unwrap_or("").trim();
    if t.is_empty() {
        return Err(format!("column `{name}` is empty"));
    }
    Ok(t)
}

/// Sets `slot` to `value` or checks it already holds it (a per-trial column).
fn same<T: PartialEq + std::fmt::Debug>(
    slot: &mut Option<T>,
    value: T,
    what: &str,
) -> Result<(), String> {
    match slot {
        Some(old) if *old != value => Err(format!(
            "{what} is {value:?} here but {old:?} earlier in the same trial; it is one value per trial"
        )),
        Some(_) => Ok(()),
        None => {
            *slot = Some(value);
            Ok(())
        }
    }
}

/// Reads one interchange CSV into trials (in the order they first appear).
pub fn read_interchange(path: &Path, opts: &ImportOptions) -> Result<ImportSummary, ImportError> {
    let bytes = std::fs::read(path).map_err(|source| ImportError::Io {
        path: path.into(),
        source,
    })?;
    let sha256 = crate::trial::sha256_hex(&bytes);
    let file_err = |message: String| ImportError::File {
        path: path.into(),
        message,
    };
    let mut reader = csv::ReaderBuilder::new()
        .comment(Some(b'#'))
        .from_reader(bytes.as_slice());
    let header = reader
        .headers()
        .map_err(|e| file_err(format!("cannot read the header: {e}")))?
        .clone();
    let (cols, source, ignored_columns) = columns(&header, opts).map_err(file_err)?;
    let mut order: Vec<String> = Vec::new();
    let mut trials: HashMap<String, TrialRows> = HashMap::new();
    let mut sensor_names: Vec<String> = Vec::new();
    let mut elements = 0usize;
    let mut lowest_element = u64::MAX;
    let mut rows = 0u64;
    let mut record = csv::StringRecord::new();
    loop {
        let line = reader.position().line();
        match reader.read_record(&mut record) {
            Ok(false) => break,
            Ok(true) => {}
            Err(e) => {
                let line = e.position().map_or(line, |p| p.line());
                return Err(ImportError::Row {
                    path: path.into(),
                    line,
                    message: e.to_string(),
                });
            }
        }
        let line = record.position().map_or(line, |p| p.line());
        rows += 1;
        let row_err = |message: String| ImportError::Row {
            path: path.into(),
            line,
            message,
        };
        let [c_trial, c_sensor, c_frame, c_t, c_element, c_x, c_y] = cols.required;
        let name = text(&record, c_trial, "trial")
            .map_err(row_err)?
            .to_string();
        let sensor = text(&record, c_sensor, "sensor")
            .map_err(row_err)?
            .to_string();
        let frame = whole(&record, c_frame, "frame").map_err(row_err)?;
        let t = number(&record, c_t, "t_s").map_err(row_err)?;
        if t.abs() > crate::import::MAX_TIME_S {
            return Err(row_err(format!(
                "column `t_s`: {} is beyond +-{:e} s; times are in seconds",
                crate::quote::number(t),
                crate::import::MAX_TIME_S
            )));
        }
        let mut element = whole(&record, c_element, "element").map_err(row_err)?;
        if opts.one_based {
            element = element.checked_sub(1).ok_or_else(|| {
                row_err("column `element`: 0 with --one-based (indices from 1)".into())
            })?;
        }
        lowest_element = lowest_element.min(element);
        if element >= MAX_ELEMENTS {
            return Err(row_err(format!(
                "column `element`: {element}: expected an index below {MAX_ELEMENTS}"
            )));
        }
        let mut xy = [0f32; 2];
        for (v, (c, n)) in xy.iter_mut().zip([(c_x, "x"), (c_y, "y")]) {
            let value = number(&record, c, n).map_err(row_err)?;
            if value.abs() > MAX_VALUE {
                return Err(row_err(format!(
                    "column `{n}`: {} is beyond +-{MAX_VALUE:e}; subtract each element's baseline (e.g. its first frame) first",
                    crate::quote::number(value)
                )));
            }
            *v = value as f32;
        }
        let z = match cols.z {
            // an empty cell: no z for this row (see FrameRows::z)
            Some(c) if record.get(c).is_some_and(|v| v.trim().is_empty()) => None,
            Some(c) => {
                let value = number(&record, c, "z").map_err(row_err)?;
                if value.abs() > MAX_VALUE {
                    return Err(row_err(format!(
                        "column `z`: {} is beyond +-{MAX_VALUE:e}; subtract each element's baseline (e.g. its first frame) first",
                        crate::quote::number(value)
                    )));
                }
                Some(value as f32)
            }
            None => None,
        };
        if !sensor_names.contains(&sensor) {
            sensor_names.push(sensor.clone());
        }
        let trial = trials.entry(name.clone()).or_insert_with(|| {
            order.push(name.clone());
            TrialRows::default()
        });
        if let Some(c) = cols.split {
            let split = text(&record, c, "split").map_err(row_err)?.to_string();
            same(&mut trial.split, split, "the split").map_err(row_err)?;
        }
        if let Some(c) = cols.object {
            let object = text(&record, c, "object").map_err(row_err)?.to_string();
            same(&mut trial.object, object, "the object").map_err(row_err)?;
        }
        let key = t.to_bits();
        if let Some(c) = cols.slip {
            let label = match record.get(c).unwrap_or("").trim() {
                "0" | "0.0" | "false" => false,
                "1" | "1.0" | "true" => true,
                other => {
                    return Err(row_err(format!(
                        "column `slip`: `{other}`: expected 0 or 1"
                    )))
                }
            };
            match trial.labels.get(&key) {
                Some(&(_, old)) if old != label => {
                    return Err(row_err(format!(
                        "slip is {} at t_s {t} but another row of the same trial and time says {}",
                        u8::from(label),
                        u8::from(old)
                    )))
                }
                _ => {
                    trial.labels.insert(key, (t, label));
                }
            }
        }
        if let Some(c) = cols.onset {
            let text = record.get(c).unwrap_or("").trim();
            let onset = if text.is_empty() {
                None
            } else {
                Some(number(&record, c, "onset_s").map_err(row_err)?)
            };
            // compared bit for bit, said as the numbers they are (T4-12)
            let show = |bits: Option<u64>| {
                bits.map_or("empty".to_string(), |b| {
                    crate::quote::number(f64::from_bits(b))
                })
            };
            match trial.onset_s {
                Some(old) if old != onset.map(f64::to_bits) => {
                    return Err(row_err(format!(
                        "onset_s is {} here but {} earlier in the same trial; it is one value per trial",
                        show(onset.map(f64::to_bits)),
                        show(old)
                    )))
                }
                Some(_) => {}
                None => trial.onset_s = Some(onset.map(f64::to_bits)),
            }
        }
        if let Some((co, ch)) = cols.heights {
            let m = MarkerSample {
                time_s: t,
                object_mm: number(&record, co, "object_mm").map_err(row_err)?,
                hand_mm: number(&record, ch, "hand_mm").map_err(row_err)?,
            };
            match trial.markers.get(&key) {
                Some(old) if *old != m => {
                    return Err(row_err(format!(
                        "heights at t_s {t} differ from another row of the same trial and time"
                    )))
                }
                _ => {
                    trial.markers.insert(key, m);
                }
            }
        }
        let by_frame = match trial.sensors.iter_mut().position(|(n, _)| *n == sensor) {
            Some(i) => &mut trial.sensors[i].1,
            None => {
                trial.sensors.push((sensor.clone(), BTreeMap::new()));
                &mut trial.sensors.last_mut().expect("just pushed").1
            }
        };
        let f = by_frame.entry(frame).or_insert_with(|| FrameRows {
            time_s: t,
            line,
            elements: Vec::new(),
            z: Vec::new(),
        });
        if f.time_s != t {
            return Err(row_err(format!(
                "frame {frame} of sensor `{sensor}` has t_s {t} here but {} on line {}",
                f.time_s, f.line
            )));
        }
        let e = element as usize;
        if f.elements.len() <= e {
            f.elements.resize(e + 1, None);
        }
        if f.elements[e].is_some() {
            return Err(row_err(format!(
                "element {e} of frame {frame}, sensor `{sensor}`, trial `{name}` is given twice"
            )));
        }
        f.elements[e] = Some(xy);
        if z.is_some() {
            if f.z.len() <= e {
                f.z.resize(e + 1, None);
            }
            f.z[e] = z;
        }
        elements = elements.max(e + 1);
    }
    if order.is_empty() {
        return Err(file_err("no rows after the header".into()));
    }
    // Indices as the file numbers them: with --one-based, the file's 1 is element 0.
    let base = u64::from(opts.one_based);
    match lowest_element {
        0 => {}
        1 if !opts.one_based => {
            return Err(file_err(
                "no row has element 0: the element indices look 1-based; pass --one-based"
                    .into(),
            ))
        }
        lowest => {
            return Err(file_err(format!(
                "no row has element {base}: the lowest element index is {}; expected indices from {base}{}",
                lowest + base,
                if opts.one_based { " (--one-based)" } else { " (or from 1 with --one-based)" }
            )))
        }
    }
    if sensor_names.len() > usize::from(u8::MAX) {
        return Err(file_err(format!(
            "{} sensors; at most {}",
            sensor_names.len(),
            u8::MAX
        )));
    }
    let mut out = ImportSummary {
        ignored_columns,
        rows,
        ..Default::default()
    };
    for name in order {
        let rows = trials.remove(&name).expect("every name has rows");
        let t = build_trial(
            &name,
            rows,
            &sensor_names,
            elements,
            source,
            (path, &sha256),
            opts,
        )
        .map_err(file_err)?;
        out.trials.push(t);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::import::{ImportError, Units, LABEL_TOPIC};
    use crate::slip::labels::{trial_slip_window, OnsetSpec};

    fn opts() -> ImportOptions {
        ImportOptions {
            sensor_name: "test-skin".into(),
            units: Units::Counts,
            split_column: None,
            max_step: None,
            ..Default::default()
        }
    }

    /// Writes `text` to a temporary file and reads it.
    fn read(text: &str, opts: &ImportOptions) -> Result<ImportSummary, ImportError> {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("in.csv");
        std::fs::write(&path, text).unwrap();
        read_interchange(&path, opts)
    }

    /// Two sensors of `elements` taxels at 30 Hz, frames 0..frames, slip from frame `slip_from`.
    fn csv(elements: usize, frames: u64, slip_from: u64, extra_header: &str) -> String {
        let mut s = format!("trial,sensor,frame,t_s,element,x,y,slip{extra_header}\n");
        for f in 0..frames {
            for sensor in ["left", "right"] {
                for e in 0..elements {
                    let x = 100.0 * e as f64 + if f >= slip_from { 5.0 * f as f64 } else { 0.0 };
                    let slip = u8::from(f >= slip_from);
                    s += &format!(
                        "a,{sensor},{f},{:.6},{e},{x},{},{slip}\n",
                        f as f64 / 30.0,
                        e
                    );
                }
            }
        }
        s
    }

    fn message(e: ImportError) -> String {
        e.to_string()
    }

    #[test]
    fn a_slip_column_gives_frames_of_every_element_and_a_label_track() {
        let s = read(&csv(16, 10, 6, ""), &opts()).unwrap();
        assert_eq!(s.trials.len(), 1);
        assert_eq!(s.rows, 10 * 2 * 16);
        let t = &s.trials[0].trial;
        assert_eq!((t.meta.sensors, t.meta.pins), (2, 16));
        assert_eq!(t.frames.len(), 20);
        assert!(t.frames.iter().all(|f| f.pins.len() == 16));
        assert_eq!(t.meta.parameters["units"], "counts");
        assert_eq!(t.meta.parameters["rate_hz"], "30.000");
        assert_eq!(t.meta.parameters["sensor_names"], "left,right");
        let labels = t.events.iter().filter(|e| e.topic == LABEL_TOPIC).count();
        assert_eq!(labels, 10, "one label per frame time");
        let (onset, end) = trial_slip_window(t, &OnsetSpec::default());
        assert!((onset.unwrap() - 6.0 / 30.0).abs() < 1e-6);
        assert_eq!(end, None);
        assert_eq!(t.unusable(), None, "labels stand in for a marker track");
    }

    #[test]
    fn a_z_column_is_carried_per_frame_and_a_bad_z_is_named() {
        let text = "trial,sensor,frame,t_s,element,x,y,z,slip\na,s,0,0.0,0,1,1,7,0\na,s,0,0.0,1,2,1,8,0\na,s,1,0.02,0,1,2,9.5,1\na,s,1,0.02,1,2,2,10,1\n";
        let s = read(text, &opts()).unwrap();
        assert!(s.ignored_columns.is_empty(), "{:?}", s.ignored_columns);
        let t = &s.trials[0].trial;
        let z = crate::import::z_by_frame(t);
        assert_eq!(z[&(0, 0)], vec![7.0, 8.0]);
        assert_eq!(z[&(0, 1)], vec![9.5, 10.0]);
        assert_eq!(t.meta.parameters["z"], "/element_z/<sensor>");
        let e = message(read(&text.replace(",9.5,", ",x,"), &opts()).unwrap_err());
        assert!(e.contains("in.csv:4:") && e.contains("column `z`"), "{e}");
        // z on some of a frame's elements only
        let e = message(read(&text.replace(",9.5,", ",,"), &opts()).unwrap_err());
        assert!(
            e.contains("frame 1") && e.contains("`z` is given for some"),
            "{e}"
        );
        // no z on a whole frame: that frame has none
        let s = read(&text.replace(",9.5,", ",,").replace(",10,", ",,"), &opts()).unwrap();
        let z = crate::import::z_by_frame(&s.trials[0].trial);
        assert_eq!(z.keys().collect::<Vec<_>>(), vec![&(0, 0)]);
    }

    #[test]
    fn the_slip_run_ends_at_the_first_static_label_after_it() {
        let text = csv(4, 10, 3, "");
        // frames 8 and 9 back to static
        let text: String = text
            .lines()
            .map(|l| {
                let f: Vec<&str> = l.split(',').collect();
                if f.len() > 2 && (f[2] == "8" || f[2] == "9") {
                    format!("{},0\n", f[..7].join(","))
                } else {
                    format!("{l}\n")
                }
            })
            .collect();
        let s = read(&text, &opts()).unwrap();
        let (onset, end) = trial_slip_window(&s.trials[0].trial, &OnsetSpec::default());
        assert!((onset.unwrap() - 0.1).abs() < 1e-6);
        assert!((end.unwrap() - 8.0 / 30.0).abs() < 1e-6);
    }

    #[test]
    fn an_onset_column_and_marker_heights_are_label_sources_too() {
        let onset = "trial,sensor,frame,t_s,element,x,y,onset_s\nb,s,0,0.0,0,1,1,0.05\nb,s,1,0.02,0,1,2,0.05\nb,s,2,0.04,0,1,3,0.05\nb,s,3,0.06,0,1,4,0.05\nc,s,0,0.0,0,1,1,\nc,s,1,0.02,0,1,1,\n";
        let s = read(onset, &opts()).unwrap();
        let w: Vec<_> = s
            .trials
            .iter()
            .map(|t| trial_slip_window(&t.trial, &OnsetSpec::default()).0)
            .collect();
        assert_eq!(w, vec![Some(0.05), None]);
        let heights = "trial,sensor,frame,t_s,element,x,y,object_mm,hand_mm\nb,s,0,0.0,0,1,1,300,360\nb,s,1,0.02,0,1,2,299,360\n";
        let s = read(heights, &opts()).unwrap();
        assert_eq!(s.trials[0].trial.markers.len(), 2);
        assert!(s.trials[0].trial.events.is_empty());
    }

    #[test]
    fn bad_rows_are_named_by_file_line_and_column() {
        let mut text = csv(3, 4, 2, "");
        text = text.replacen(
            "a,right,1,0.033333,2,200,2,0",
            "a,right,1,0.033333,2,2o0,2,0",
            1,
        );
        let e = message(read(&text, &opts()).unwrap_err());
        assert!(
            e.contains("in.csv:13:") && e.contains("column `x`: `2o0`"),
            "{e}"
        );

        let e = message(read(&csv(3, 4, 2, "").replace(",1\n", ",7\n"), &opts()).unwrap_err());
        assert!(e.contains("column `slip`: `7`: expected 0 or 1"), "{e}");

        let missing: String = csv(3, 4, 2, "")
            .lines()
            .filter(|l| *l != "a,left,2,0.066667,1,110,1,1")
            .map(|l| format!("{l}\n"))
            .collect();
        let e = message(read(&missing, &opts()).unwrap_err());
        assert!(
            e.contains("sensor `left`, frame 2") && e.contains("element 1 is missing"),
            "{e}"
        );

        let twice = csv(3, 2, 2, "") + "a,left,1,0.033333,0,0,0,0\n";
        let e = message(read(&twice, &opts()).unwrap_err());
        assert!(
            e.contains("element 0 of frame 1") && e.contains("twice"),
            "{e}"
        );

        let backwards =
            "trial,sensor,frame,t_s,element,x,y,slip\na,s,0,0.5,0,1,1,0\na,s,1,0.4,0,1,1,0\n";
        let e = message(read(backwards, &opts()).unwrap_err());
        assert!(e.contains("times must rise"), "{e}");

        let huge = "trial,sensor,frame,t_s,element,x,y,slip\na,s,0,0.5,0,1e6,1,0\n";
        let e = message(read(huge, &opts()).unwrap_err());
        assert!(e.contains(":2:") && e.contains("baseline"), "{e}");
    }

    #[test]
    fn two_onsets_of_one_trial_are_said_as_numbers() {
        let text = "trial,sensor,frame,t_s,element,x,y,onset_s\nb,s,0,0.0,0,1,1,0.05\nb,s,1,0.02,0,1,2,0.07\n";
        let e = read(text, &opts()).unwrap_err().to_string();
        assert!(e.contains("onset_s is 0.07 here but 0.05 earlier"), "{e}");
        assert!(!e.contains("Some("), "{e}");
    }

    #[test]
    fn a_file_column_mapped_twice_or_named_twice_is_refused() {
        let header = csv::StringRecord::from(vec![
            "trial", "sensor", "frame", "t_s", "element", "x", "y", "slip",
        ]);
        let opts = ImportOptions {
            columns: [
                ("x".to_string(), "x".to_string()),
                ("y".to_string(), "x".to_string()),
            ]
            .into(),
            ..Default::default()
        };
        let e = columns(&header, &opts).err().unwrap();
        assert!(e.contains("`x` column is mapped twice"), "{e}");
        let doubled = csv::StringRecord::from(vec![
            "trial", "sensor", "frame", "t_s", "element", "x", "x", "slip",
        ]);
        let e = columns(&doubled, &ImportOptions::default()).err().unwrap();
        assert!(e.contains("names `x` twice (columns 6 and 7)"), "{e}");
    }

    #[test]
    fn the_columns_must_say_where_labels_come_from_once() {
        let e = message(read("trial,sensor,frame,t_s,element,x,y\n", &opts()).unwrap_err());
        assert!(e.contains("no labels"), "{e}");
        let e = message(
            read("trial,sensor,frame,t_s,element,x,y,slip,onset_s\n", &opts()).unwrap_err(),
        );
        assert!(e.contains("more than one label source"), "{e}");
        let e = message(read("trial,sensor,t_s,element,x,y,slip\n", &opts()).unwrap_err());
        assert!(e.contains("no `frame` column"), "{e}");
        let e = message(read("trial,sensor,frame,t_s,element,x,y,slip\n", &opts()).unwrap_err());
        assert!(e.contains("no rows"), "{e}");
    }

    #[test]
    fn a_split_column_is_one_value_per_trial_and_unknown_columns_are_reported() {
        let with_split = |b_split: &str| {
            format!("trial,sensor,frame,t_s,element,x,y,slip,split,note\na,s,0,0,0,1,1,0,train,x\na,s,1,0.1,0,1,1,0,train,y\nb,s,0,0,0,1,1,0,test,z\nb,s,1,0.1,0,1,1,0,{b_split},w\n")
        };
        let o = ImportOptions {
            split_column: Some("split".into()),
            ..opts()
        };
        let s = read(&with_split("test"), &o).unwrap();
        let splits: Vec<_> = s.trials.iter().map(|t| t.split.clone().unwrap()).collect();
        assert_eq!(splits, ["train", "test"]);
        assert_eq!(s.ignored_columns, ["note"]);
        let e = message(read(&with_split("train"), &o).unwrap_err());
        assert!(
            e.contains(":5:") && e.contains("one value per trial"),
            "{e}"
        );
    }

    #[test]
    fn names_times_and_onsets_that_make_no_trial_are_refused() {
        let row = |trial: &str, t0: &str, t1: &str, onset: &str| {
            format!("trial,sensor,frame,t_s,element,x,y,onset_s\n{trial},s,0,{t0},0,1,1,{onset}\n{trial},s,1,{t1},0,1,2,{onset}\n")
        };
        for name in [".", ".."] {
            let e = message(read(&row(name, "0", "0.02", ""), &opts()).unwrap_err());
            assert!(e.contains("no file name"), "{e}");
        }
        let e = message(read(&row("a", "0", "1e-300", ""), &opts()).unwrap_err());
        assert!(e.contains("expected 0.1 to 100000 Hz"), "{e}");
        let e = message(read(&row("a", "0", "1e12", ""), &opts()).unwrap_err());
        assert!(
            e.contains(":3:") && e.contains("times are in seconds"),
            "{e}"
        );
        for onset in ["-0.5", "1e308", "0.03"] {
            let e = message(read(&row("a", "0", "0.02", onset), &opts()).unwrap_err());
            assert!(e.contains("outside its frames' times"), "{onset}: {e}");
            // quoted as written, not as 309 digits
            assert!(
                e.len() < 400 && e.contains(&format!("onset_s {onset} ")),
                "{e}"
            );
        }
        assert!(read(&row("a", "0", "0.02", "0.02"), &opts()).is_ok());
    }

    #[test]
    fn mapped_columns_one_based_elements_and_repeated_readings_are_read_as_asked() {
        let text = "run,sensor,frame,t_s,taxel,x,y,slip\na,s,0,0.0,1,1,1,0\na,s,1,0.01,1,1,1,0\na,s,2,0.02,1,2,1,0\na,s,3,0.03,1,2,1,1\na,s,4,0.04,1,3,1,1\n";
        let e = message(read(text, &opts()).unwrap_err());
        assert!(
            e.contains("no `trial` or `element` column")
                && e.contains("--columns trial=<its name>,element=<its name>"),
            "{e}"
        );
        // a missing split column is named in the same message
        let with_split = ImportOptions {
            split_column: Some("part".into()),
            ..opts()
        };
        let e = message(read(text, &with_split).unwrap_err());
        assert!(
            e.contains("element=<its name>; no `part` column (--split-column)"),
            "{e}"
        );
        let mapped = ImportOptions {
            columns: [("trial", "run"), ("element", "taxel")]
                .map(|(a, b)| (a.to_string(), b.to_string()))
                .into(),
            ..opts()
        };
        let e = message(read(text, &mapped).unwrap_err());
        assert!(e.contains("look 1-based; pass --one-based"), "{e}");
        let one_based = ImportOptions {
            one_based: true,
            ..mapped.clone()
        };
        let s = read(text, &one_based).unwrap();
        let t = &s.trials[0];
        assert_eq!(t.trial.frames.len(), 5);
        assert_eq!(t.repeated_frames, 2);
        let deduped = read(
            text,
            &ImportOptions {
                dedupe: true,
                ..one_based.clone()
            },
        )
        .unwrap();
        let t = &deduped.trials[0];
        assert_eq!((t.dropped_repeats, t.trial.frames.len()), (2, 3));
        let seqs: Vec<_> = t.trial.frames.iter().map(|f| (f.seq, f.time_s)).collect();
        assert_eq!(seqs, [(0, 0.0), (1, 0.02), (2, 0.04)]);
        // the labels stay at their times: the slip starts at 0.03 s still
        let (onset, _) = trial_slip_window(&t.trial, &OnsetSpec::default());
        assert_eq!(onset, Some(0.03));
        let unknown = ImportOptions {
            columns: [("taxel".to_string(), "x".to_string())].into(),
            ..opts()
        };
        let e = message(read(text, &unknown).unwrap_err());
        assert!(e.contains("`taxel` is not an interchange column"), "{e}");
        // T4-12: indices from 2 are not 1-based, with --one-based or without
        let from_two = text
            .replace(",1,1,1,", ",2,1,1,")
            .replace(",1,2,1,", ",2,2,1,")
            .replace(",1,3,1,", ",2,3,1,");
        let e = message(read(&from_two, &mapped).unwrap_err());
        assert!(
            e.contains("the lowest element index is 2; expected indices from 0 (or from 1 with --one-based)"),
            "{e}"
        );
        let e = message(read(&from_two, &one_based).unwrap_err());
        assert!(
            e.contains("no row has element 1: the lowest element index is 2; expected indices from 1 (--one-based)"),
            "{e}"
        );
    }

    #[test]
    fn numbers_beyond_any_sensor_are_quoted_short() {
        let text = "trial,sensor,frame,t_s,element,x,y,slip\na,s,0,0.5,0,1e300,1,0\n";
        let e = message(read(text, &opts()).unwrap_err());
        assert!(e.contains("column `x`: 1e300 is beyond"), "{e}");
        let text = "trial,sensor,frame,t_s,element,x,y,slip\na,s,0,-1e300,0,1,1,0\n";
        let e = message(read(text, &opts()).unwrap_err());
        assert!(e.contains("column `t_s`: -1e300 is beyond"), "{e}");
    }
}
