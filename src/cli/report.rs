//! `tmo report INPUT... [--format md|csv|json|html] [--out DIR] [--plots DIR]`.

use std::path::PathBuf;

use anyhow::{Context, Result};
use tmo::report::{self, Format};

#[derive(clap::Args)]
pub struct ReportArgs {
    /// Batch directories (from `tmo run`), sweeps (`sweep.csv` or its directory) and
    /// evaluations (`tmo evaluate --out`).
    #[arg(required = true)]
    inputs: Vec<PathBuf>,
    /// How the tables are written.
    #[arg(long, value_enum, default_value = "md")]
    format: Format,
    /// Also write each table to DIR/<table>.<md|csv|json> (with html: the page to
    /// DIR/report.html, figures inline when --plots draws them).
    #[arg(long, value_parser = super::output::a_dir)]
    out: Option<PathBuf>,
    /// Draw the figures (SVG and PNG) into DIR.
    #[arg(long, value_parser = super::output::a_dir)]
    plots: Option<PathBuf>,
    /// Only the table of this name (the names are those of --out's files); CSV on standard
    /// output holds one table, so with several this picks it.
    #[arg(long)]
    table: Option<String>,
}

fn extension(f: Format) -> &'static str {
    match f {
        Format::Md => "md",
        Format::Csv => "csv",
        Format::Json => "json",
        Format::Latex => "tex",
        Format::Html => "html",
    }
}

pub fn report(args: ReportArgs) -> Result<()> {
    let inputs = report::inputs::load(&args.inputs)?;
    let mut tables = report::build::tables(&inputs);
    let names = |tables: &[report::Table]| {
        tables
            .iter()
            .map(|t| t.name.as_str())
            .collect::<Vec<_>>()
            .join(", ")
    };
    if let Some(name) = &args.table {
        anyhow::ensure!(
            tables.iter().any(|t| &t.name == name),
            "--table {name}: no such table in these inputs (they give: {})",
            names(&tables)
        );
        tables.retain(|t| &t.name == name);
    }
    // CSV on standard output is one table with its header first, as pandas reads it
    if args.format == Format::Csv && tables.len() > 1 && args.out.is_none() {
        anyhow::bail!(
            "{} tables ({}): CSV on standard output holds one; pick it with --table NAME, or write one file per table with --out DIR",
            tables.len(),
            names(&tables)
        );
    }
    anyhow::ensure!(
        !tables.is_empty() || args.plots.is_some(),
        "nothing to report: the inputs hold no finished trials, sweep cells or evaluations \
         (directories of collected trials give figures only: add --plots DIR)"
    );
    if args.format == Format::Html {
        return html_report(&args, &inputs, &tables);
    }
    if args.format == Format::Csv && tables.len() == 1 {
        crate::cli::output::write_out(format_args!("{}", tables[0].csv()?))?;
    } else if !tables.is_empty() && args.format != Format::Csv {
        // (CSV of several tables goes to --out's files only: refused above without it)
        crate::cli::output::write_out(format_args!("{}", report::render(&tables, args.format)?))?;
    }
    let mut written = Vec::new();
    if let Some(dir) = &args.out {
        std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
        for t in &tables {
            let path = dir.join(format!("{}.{}", t.name, extension(args.format)));
            // The file names the table, so a CSV file is the table alone: header first.
            let text = match args.format {
                Format::Csv => t.csv()?,
                _ => report::render(std::slice::from_ref(t), args.format)?,
            };
            tmo::output::atomic::write_atomic(&path, text.as_bytes())
                .with_context(|| format!("cannot write {}", path.display()))?;
            written.push(path);
        }
    }
    if let Some(dir) = &args.plots {
        written.extend(tmo::plots::draw_all(&inputs, dir)?);
    }
    for p in &written {
        super::output::note(format!("wrote {}", p.display()));
    }
    Ok(())
}

/// One self-contained page: to DIR/report.html with --out, else to standard output.
fn html_report(
    args: &ReportArgs,
    inputs: &report::inputs::Inputs,
    tables: &[report::Table],
) -> Result<()> {
    let figures = match &args.plots {
        Some(dir) => tmo::plots::draw_all(inputs, dir)?,
        None => Vec::new(),
    };
    let page = report::html::tables_page("tmo report", tables, &figures, &tmo::plots::caption);
    match &args.out {
        Some(dir) => {
            std::fs::create_dir_all(dir)
                .with_context(|| format!("cannot create {}", dir.display()))?;
            let path = dir.join("report.html");
            tmo::output::atomic::write_atomic(&path, page.as_bytes())
                .with_context(|| format!("cannot write {}", path.display()))?;
            super::output::note(format!("wrote {}", path.display()));
        }
        None => crate::cli::output::write_out(format_args!("{page}"))?,
    }
    for p in &figures {
        super::output::note(format!("wrote {}", p.display()));
    }
    Ok(())
}
