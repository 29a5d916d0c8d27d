//! Writes what a simulated scenario did as CSV: ground truth per tick, pin frames, marker
//! samples, and the configuration that produced them.

pub mod scenario;

use std::fs;
use std::path::{Path, PathBuf};

use tmo_hal::{MarkerSample, PinFrame};
use tmo_sim::{SimConfig, TruthState};

#[derive(Debug, thiserror::Error)]
pub enum TraceError {
    #[error("cannot write {path}: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("cannot write {path}: {source}")]
    Csv { path: PathBuf, source: csv::Error },
    #[error("cannot serialise the simulator configuration: {0}")]
    Config(#[from] toml::ser::Error),
}

/// The files one trace consists of.
#[derive(Debug, Clone)]
pub struct TraceFiles {
    pub truth: PathBuf,
    pub pins: PathBuf,
    pub markers: PathBuf,
    pub config: PathBuf,
}

impl TraceFiles {
    pub fn in_dir(dir: &Path) -> Self {
        Self {
            truth: dir.join("truth.csv"),
            pins: dir.join("pins.csv"),
            markers: dir.join("markers.csv"),
            config: dir.join("sim.toml"),
        }
    }
}

fn csv_writer(path: &Path) -> Result<csv::Writer<fs::File>, TraceError> {
    csv::Writer::from_path(path).map_err(|source| TraceError::Csv {
        path: path.into(),
        source,
    })
}

fn write_row(w: &mut csv::Writer<fs::File>, path: &Path, row: &[String]) -> Result<(), TraceError> {
    w.write_record(row).map_err(|source| TraceError::Csv {
        path: path.into(),
        source,
    })
}

fn finish(mut w: csv::Writer<fs::File>, path: &Path) -> Result<(), TraceError> {
    w.flush().map_err(|source| TraceError::Io {
        path: path.into(),
        source,
    })
}

/// Writes a trace into `dir` (created if missing).
pub fn write_trace(
    dir: &Path,
    config: &SimConfig,
    truth: &[TruthState],
    frames: &[PinFrame],
    markers: &[MarkerSample],
) -> Result<TraceFiles, TraceError> {
    fs::create_dir_all(dir).map_err(|source| TraceError::Io {
        path: dir.into(),
        source,
    })?;
    let files = TraceFiles::in_dir(dir);
    let header = format!(
        "# simulator configuration of a `tmo sim trace` run (tmo {})\n",
        env!("CARGO_PKG_VERSION")
    );
    crate::output::atomic::write_atomic(
        &files.config,
        (header + &toml::to_string(config)?).as_bytes(),
    )
    .map_err(|source| TraceError::Io {
        path: files.config.clone(),
        source,
    })?;

    let sensors = truth.first().map_or(0, |t| t.normal_n.len());
    let mut w = csv_writer(&files.truth)?;
    let mut head: Vec<String> = [
        "time_s",
        "object_mm",
        "object_velocity_mm_s",
        "hand_mm",
        "hand_velocity_mm_s",
        "mass_g",
        "weight_n",
        "capacity_n",
        "sliding",
        "in_grasp",
        "dropped",
        "turn_deg",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    for i in 0..sensors {
        for what in [
            "normal_n",
            "tangential_n",
            "local_slip",
            "indentation_mm",
            "shear_px",
            "roll_px",
            "finger_position",
        ] {
            head.push(format!("s{i}_{what}"));
        }
    }
    write_row(&mut w, &files.truth, &head)?;
    for t in truth {
        let mut row = vec![
            format!("{:.4}", t.time_s),
            format!("{:.4}", t.object_mm),
            format!("{:.4}", t.object_velocity_mm_s),
            format!("{:.4}", t.hand_mm),
            format!("{:.4}", t.hand_velocity_mm_s),
            format!("{:.3}", t.mass_g),
            format!("{:.5}", t.weight_n),
            format!("{:.5}", t.capacity_n),
            u8::from(t.sliding).to_string(),
            u8::from(t.in_grasp).to_string(),
            u8::from(t.dropped).to_string(),
            format!("{:.4}", t.turn_deg),
        ];
        for i in 0..sensors {
            row.push(format!("{:.5}", t.normal_n[i]));
            row.push(format!("{:.5}", t.tangential_n[i]));
            row.push(u8::from(t.local_slip[i]).to_string());
            row.push(format!("{:.5}", t.indentation_mm[i]));
            row.push(format!("{:.5}", t.shear_px[i]));
            row.push(format!("{:.5}", t.roll_px[i]));
            row.push(format!("{:.5}", t.finger_positions[i]));
        }
        write_row(&mut w, &files.truth, &row)?;
    }
    finish(w, &files.truth)?;

    let pins = frames.first().map_or(0, |f| f.pins.len());
    let mut w = csv_writer(&files.pins)?;
    let mut head = vec!["sensor".to_string(), "seq".into(), "time_s".into()];
    for j in 0..pins {
        head.push(format!("x{j}"));
        head.push(format!("y{j}"));
    }
    write_row(&mut w, &files.pins, &head)?;
    for f in frames {
        let mut row = vec![
            f.sensor.to_string(),
            f.seq.to_string(),
            format!("{:.6}", f.time_s),
        ];
        for p in &f.pins {
            row.push(format!("{:.3}", p[0]));
            row.push(format!("{:.3}", p[1]));
        }
        write_row(&mut w, &files.pins, &row)?;
    }
    finish(w, &files.pins)?;

    let mut w = csv_writer(&files.markers)?;
    write_row(
        &mut w,
        &files.markers,
        &["time_s".into(), "object_mm".into(), "hand_mm".into()],
    )?;
    for m in markers {
        write_row(
            &mut w,
            &files.markers,
            &[
                format!("{:.6}", m.time_s),
                format!("{:.3}", m.object_mm),
                format!("{:.3}", m.hand_mm),
            ],
        )?;
    }
    finish(w, &files.markers)?;
    Ok(files)
}
