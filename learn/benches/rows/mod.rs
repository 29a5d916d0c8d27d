//! The rows the benches fit on: 60-feature tactile rows of simulated hand releases, as
//! `tmo train` sees them. Only `tmo` can make them (it owns the simulator and the features),
//! so it writes them to CSV first: `cargo run --release --example bench_rows` in the
//! workspace root. scikit-learn's timing scripts read the same files, so both sides fit
//! exactly the same numbers.

use std::path::PathBuf;

/// Rows in order: values row-major, a label each (positive = slip).
pub struct Rows {
    pub dim: usize,
    pub x: Vec<f32>,
    pub y: Vec<bool>,
}

impl Rows {
    pub fn len(&self) -> usize {
        self.y.len()
    }

    #[allow(dead_code)] // each bench compiles this module on its own and uses part of it
    pub fn row(&self, i: usize) -> &[f32] {
        &self.x[i * self.dim..(i + 1) * self.dim]
    }

    #[allow(dead_code)]
    pub fn positives(&self) -> usize {
        self.y.iter().filter(|y| **y).count()
    }
}

/// `target/bench/NAME` in the workspace, where `bench_rows` writes.
pub fn path(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../target/bench")
        .join(name)
}

/// Reads a rows file (`trial_id,sensor,seq,time_s,label,dr_0,...`), or stops the bench
/// saying how to make it.
pub fn read(name: &str) -> Rows {
    let file = path(name);
    let Ok(text) = std::fs::read_to_string(&file) else {
        eprintln!(
            "{} is missing: run `cargo run --release --example bench_rows` in the workspace root first",
            file.display()
        );
        std::process::exit(2);
    };
    let mut lines = text.lines();
    let head: Vec<&str> = lines.next().unwrap_or_default().split(',').collect();
    let column = |name: &str| {
        head.iter()
            .position(|h| *h == name)
            .unwrap_or_else(|| panic!("{}: no column {name}", file.display()))
    };
    let (label, first) = (column("label"), column("dr_0"));
    let mut rows = Rows {
        dim: head.len() - first,
        x: Vec::new(),
        y: Vec::new(),
    };
    for (n, line) in lines.enumerate().filter(|(_, l)| !l.is_empty()) {
        let fields: Vec<&str> = line.split(',').collect();
        rows.y.push(fields[label] == "slip");
        rows.x.extend(fields[first..].iter().map(|v| {
            v.parse::<f32>().unwrap_or_else(|_| {
                panic!("{} line {}: {v:?} is not a number", file.display(), n + 2)
            })
        }));
    }
    rows
}
