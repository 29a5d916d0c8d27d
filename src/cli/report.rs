//! `tmo report INPUT... [--format md|csv|json] [--out DIR] [--plots DIR]`.

use std::path::PathBuf;

use anyhow::{Context, Result};
use tmo::report::{self, Format};

#[derive(clap::Args)]
pub struct ReportArgs {
    /// Batch directories (from `tmo run`), sweeps (`sweep.csv` or its directory) and
    /// evaluations (`tmo evaluate --out`).
    #[arg(required = true)]
    inputs: Vec<PathBuf>,
    #[arg(long, value_enum, default_value = "md")]
    format: Format,
    /// Also write each table to DIR/<table>.<md|csv|json>.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Draw the figures (SVG and PNG) into DIR.
    #[arg(long)]
    plots: Option<PathBuf>,
}

fn extension(f: Format) -> &'static str {
    match f {
        Format::Md => "md",
        Format::Csv => "csv",
        Format::Json => "json",
    }
}

pub fn report(args: ReportArgs) -> Result<()> {
    let inputs = report::inputs::load(&args.inputs)?;
    let tables = report::build::tables(&inputs);
    anyhow::ensure!(
        !tables.is_empty() || args.plots.is_some(),
        "nothing to report: the inputs hold no finished trials, sweep cells or evaluations \
         (directories of collected trials give figures only: add --plots DIR)"
    );
    if !tables.is_empty() {
        print!("{}", report::render(&tables, args.format)?);
    }
    let mut written = Vec::new();
    if let Some(dir) = &args.out {
        std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
        for t in &tables {
            let path = dir.join(format!("{}.{}", t.name, extension(args.format)));
            let text = report::render(std::slice::from_ref(t), args.format)?;
            std::fs::write(&path, text)
                .with_context(|| format!("cannot write {}", path.display()))?;
            written.push(path);
        }
    }
    if let Some(dir) = &args.plots {
        written.extend(tmo::plots::draw_all(&inputs, dir)?);
    }
    for p in &written {
        eprintln!("wrote {}", p.display());
    }
    Ok(())
}
