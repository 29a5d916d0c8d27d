//! `tmo report`: the paper's tables from recorded batches, sweeps and evaluations, as
//! Markdown, CSV or JSON. Rates carry their counts and a Wilson 95 % interval.

pub mod build;
pub mod checks;
pub mod html;
pub mod inputs;
pub mod stats;

use serde::Serialize;

use stats::{wilson, Z95};

/// One table cell.
#[derive(Debug, Clone, PartialEq)]
pub enum Cell {
    Text(String),
    Count(u64),
    /// A number shown with `decimals` places.
    Number {
        value: f64,
        decimals: usize,
    },
    /// Mean and standard deviation.
    MeanSd {
        mean: f64,
        sd: f64,
        decimals: usize,
    },
    /// `count` of `trials`, with its percentage and Wilson 95 % interval.
    Rate {
        count: u64,
        trials: u64,
    },
    /// Nothing to show (no data for the cell).
    Empty,
}

impl Cell {
    pub fn text(s: impl Into<String>) -> Self {
        Cell::Text(s.into())
    }

    pub fn number(value: Option<f64>, decimals: usize) -> Self {
        value.map_or(Cell::Empty, |value| Cell::Number { value, decimals })
    }

    pub fn mean_sd(values: &[f64], decimals: usize) -> Self {
        stats::mean_sd(values).map_or(Cell::Empty, |(mean, sd)| Cell::MeanSd {
            mean,
            sd,
            decimals,
        })
    }

    /// As shown in Markdown and in the terminal.
    pub fn display(&self) -> String {
        match self {
            Cell::Text(s) => s.clone(),
            Cell::Count(n) => n.to_string(),
            Cell::Number { value, decimals } => format!("{value:.decimals$}"),
            Cell::MeanSd { mean, sd, decimals } => format!("{mean:.decimals$} ± {sd:.decimals$}"),
            Cell::Rate { count, trials } => {
                let (pct, lo, hi) = percent_and_interval(*count, *trials);
                format!("{count}/{trials} ({pct:.0} %; {lo:.0}–{hi:.0})")
            }
            Cell::Empty => "–".into(),
        }
    }

    /// As typeset in a LaTeX table: the same content as [`Self::display`], in LaTeX's own
    /// symbols (`\pm`, `--`, `\%`) with special characters escaped.
    fn latex(&self) -> String {
        match self {
            Cell::Text(t) => latex_escape(t),
            Cell::MeanSd { mean, sd, decimals } => {
                format!("{mean:.decimals$} $\\pm$ {sd:.decimals$}")
            }
            Cell::Rate { count, trials } => {
                let (pct, lo, hi) = percent_and_interval(*count, *trials);
                format!("{count}/{trials} ({pct:.0}\\,\\%; {lo:.0}--{hi:.0})")
            }
            Cell::Empty => "--".into(),
            other => other.display(),
        }
    }

    /// CSV columns of this cell under header `name`: rates and means split into plain
    /// numbers so a spreadsheet or pandas can use them.
    fn csv(&self, name: &str) -> Vec<(String, String)> {
        let f = |v: f64, d: usize| format!("{v:.d$}");
        match self {
            Cell::Rate { count, trials } => {
                let (lo, hi) = wilson(*count, *trials, Z95);
                vec![
                    (name.to_string(), count.to_string()),
                    (format!("{name} trials"), trials.to_string()),
                    (format!("{name} ci95 low"), f(lo, 4)),
                    (format!("{name} ci95 high"), f(hi, 4)),
                ]
            }
            Cell::MeanSd { mean, sd, decimals } => vec![
                (name.to_string(), f(*mean, *decimals)),
                (format!("{name} sd"), f(*sd, *decimals)),
            ],
            Cell::Empty => vec![(name.to_string(), String::new())],
            other => vec![(name.to_string(), other.display())],
        }
    }
}

impl Serialize for Cell {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeMap;
        match self {
            Cell::Text(t) => s.serialize_str(t),
            Cell::Count(n) => s.serialize_u64(*n),
            Cell::Number { value, .. } => s.serialize_f64(*value),
            Cell::MeanSd { mean, sd, .. } => {
                let mut m = s.serialize_map(Some(2))?;
                m.serialize_entry("mean", mean)?;
                m.serialize_entry("sd", sd)?;
                m.end()
            }
            Cell::Rate { count, trials } => {
                let (lo, hi) = wilson(*count, *trials, Z95);
                let mut m = s.serialize_map(Some(3))?;
                m.serialize_entry("count", count)?;
                m.serialize_entry("trials", trials)?;
                m.serialize_entry("ci95", &[lo, hi])?;
                m.end()
            }
            Cell::Empty => s.serialize_none(),
        }
    }
}

#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Table {
    /// Short name (file names, JSON keys): `rail_catch`, `hand_online`, ...
    pub name: String,
    pub title: String,
    pub columns: Vec<String>,
    pub rows: Vec<Vec<Cell>>,
}

impl Table {
    pub fn new(name: &str, title: &str, columns: &[&str]) -> Self {
        Self {
            name: name.into(),
            title: title.into(),
            columns: columns.iter().map(|c| c.to_string()).collect(),
            rows: Vec::new(),
        }
    }

    pub fn push(&mut self, row: Vec<Cell>) {
        debug_assert_eq!(row.len(), self.columns.len());
        self.rows.push(row);
    }

    pub fn markdown(&self) -> String {
        let mut out = format!("### {}\n\n", self.title);
        let line = |cells: Vec<String>| format!("| {} |\n", cells.join(" | "));
        out += &line(self.columns.clone());
        out += &line(self.columns.iter().map(|_| "---".to_string()).collect());
        for r in &self.rows {
            out += &line(r.iter().map(|c| c.display().replace('|', "\\|")).collect());
        }
        out
    }

    /// A booktabs table (`\\usepackage{booktabs}`) with the title as its caption and
    /// `tab:<name>` as its label, ready for `\\input` into a paper.
    pub fn latex(&self) -> String {
        let mut out = String::from("\\begin{table}[htbp]\n\\centering\n");
        out += &format!("\\caption{{{}}}\n", latex_escape(&self.title));
        out += &format!("\\label{{tab:{}}}\n", self.name);
        let align: String = std::iter::once('l')
            .chain(std::iter::repeat_n(
                'r',
                self.columns.len().saturating_sub(1),
            ))
            .collect();
        out += &format!("\\begin{{tabular}}{{{align}}}\n\\toprule\n");
        let line = |cells: Vec<String>| format!("{} \\\\\n", cells.join(" & "));
        out += &line(self.columns.iter().map(|c| latex_escape(c)).collect());
        out += "\\midrule\n";
        for r in &self.rows {
            out += &line(r.iter().map(Cell::latex).collect());
        }
        out += "\\bottomrule\n\\end{tabular}\n\\end{table}\n";
        out
    }

    pub fn csv(&self) -> Result<String, csv::Error> {
        let mut w = csv::Writer::from_writer(Vec::new());
        let split = |r: &Vec<Cell>| -> Vec<(String, String)> {
            r.iter()
                .zip(&self.columns)
                .flat_map(|(c, name)| c.csv(name))
                .collect()
        };
        // The header comes from the widest row shape: a column whose cells are rates in
        // some rows and empty in others still gets all its sub-columns.
        let mut header: Vec<String> = Vec::new();
        for (i, name) in self.columns.iter().enumerate() {
            let widest = self
                .rows
                .iter()
                .map(|r| r[i].csv(name))
                .max_by_key(|v| v.len())
                .unwrap_or_else(|| vec![(name.clone(), String::new())]);
            header.extend(widest.into_iter().map(|(h, _)| h));
        }
        w.write_record(&header)?;
        for r in &self.rows {
            let cells = split(r);
            let record: Vec<String> = header
                .iter()
                .map(|h| {
                    cells
                        .iter()
                        .find(|(k, _)| k == h)
                        .map_or(String::new(), |(_, v)| v.clone())
                })
                .collect();
            w.write_record(&record)?;
        }
        let bytes = w.into_inner().map_err(|e| e.into_error())?;
        Ok(String::from_utf8_lossy(&bytes).into_owned())
    }
}

/// `text` with LaTeX's special characters escaped (and the en dash and plus-minus sign
/// written as LaTeX writes them).
/// A rate's percentage and its Wilson 95 % interval, in percent.
fn percent_and_interval(count: u64, trials: u64) -> (f64, f64, f64) {
    let (lo, hi) = wilson(count, trials, Z95);
    let pct = if trials == 0 {
        0.0
    } else {
        100.0 * count as f64 / trials as f64
    };
    (pct, 100.0 * lo, 100.0 * hi)
}

pub fn latex_escape(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for ch in text.chars() {
        match ch {
            '\\' => out += "\\textbackslash{}",
            '&' | '%' | '$' | '#' | '_' | '{' | '}' => {
                out.push('\\');
                out.push(ch);
            }
            '~' => out += "\\textasciitilde{}",
            '^' => out += "\\textasciicircum{}",
            '–' => out += "--",
            '±' => out += "$\\pm$",
            _ => out.push(ch),
        }
    }
    out
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Format {
    Md,
    Csv,
    Json,
    /// booktabs tables (`\\usepackage{booktabs}`), one `table` environment each.
    Latex,
    /// One self-contained page (figures inline when `tmo report --plots` drew them).
    Html,
}

/// All tables in one document: Markdown sections, CSV blocks (each after a `# name` line;
/// `--out` writes one file per table, a CSV file holding the table alone), or one JSON
/// object keyed by table name.
pub fn render(tables: &[Table], format: Format) -> Result<String, ReportError> {
    Ok(match format {
        Format::Md => tables
            .iter()
            .map(|t| t.markdown())
            .collect::<Vec<_>>()
            .join("\n"),
        Format::Csv => {
            let mut out = String::new();
            for (i, t) in tables.iter().enumerate() {
                if i > 0 {
                    out.push('\n');
                }
                out += &format!("# {}\n{}", t.name, t.csv()?);
            }
            out
        }
        Format::Json => {
            let map: serde_json::Map<String, serde_json::Value> = tables
                .iter()
                .map(|t| Ok((t.name.clone(), serde_json::to_value(t)?)))
                .collect::<Result<_, serde_json::Error>>()?;
            serde_json::to_string_pretty(&map)? + "\n"
        }
        Format::Latex => tables
            .iter()
            .map(|t| t.latex())
            .collect::<Vec<_>>()
            .join("\n"),
        Format::Html => html::tables_page("tmo report", tables, &[], &|_| None),
    })
}

#[derive(Debug, thiserror::Error)]
pub enum ReportError {
    #[error(transparent)]
    Csv(#[from] csv::Error),
    #[error(transparent)]
    Json(#[from] serde_json::Error),
    #[error(transparent)]
    Input(#[from] inputs::InputError),
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn latex_tables_are_booktabs_with_every_special_character_escaped() {
        let mut t = Table::new(
            "hand_online",
            "Whole hand: 100 % of n_slip & more",
            &["strategy", "TP", "D (mm)", "note"],
        );
        t.push(vec![
            Cell::text("1Fr2Sen"),
            Cell::Rate {
                count: 8,
                trials: 10,
            },
            Cell::MeanSd {
                mean: 21.8,
                sd: 3.2,
                decimals: 1,
            },
            Cell::Empty,
        ]);
        t.push(vec![
            Cell::text("a_b #1 {x} ~ ^ \\ $ – ±"),
            Cell::Count(3),
            Cell::Empty,
            Cell::text("ok"),
        ]);
        let tex = t.latex();
        for env in ["table", "tabular"] {
            assert_eq!(
                tex.matches(&format!("\\begin{{{env}}}")).count(),
                tex.matches(&format!("\\end{{{env}}}")).count()
            );
        }
        assert!(tex.contains("\\begin{tabular}{lrrr}"));
        assert!(
            tex.contains("\\toprule") && tex.contains("\\midrule") && tex.contains("\\bottomrule")
        );
        assert!(tex.contains("\\caption{Whole hand: 100 \\% of n\\_slip \\& more}"));
        assert!(tex.contains("\\label{tab:hand_online}"));
        assert!(tex.contains("1Fr2Sen & 8/10 (80\\,\\%; 49--94) & 21.8 $\\pm$ 3.2 & -- \\\\"));
        assert!(tex.contains(
            "a\\_b \\#1 \\{x\\} \\textasciitilde{} \\textasciicircum{} \\textbackslash{} \\$ -- $\\pm$ & 3 & -- & ok \\\\"
        ));
        // every row has one cell per column: three unescaped column separators
        let body = tex.split("\\midrule\n").nth(1).unwrap();
        for line in body.lines().take_while(|l| !l.starts_with("\\bottomrule")) {
            let separators = line
                .match_indices('&')
                .filter(|(i, _)| !line[..*i].ends_with('\\'))
                .count();
            assert_eq!(separators, 3, "{line}");
        }
        // no character LaTeX would take as markup is left bare (a label may hold `_`)
        for line in tex.lines().filter(|l| !l.starts_with("\\label")) {
            for (i, ch) in line.char_indices() {
                if matches!(ch, '%' | '_' | '#') {
                    assert!(line[..i].ends_with('\\'), "bare {ch}: {line}");
                }
            }
        }
    }

    #[test]
    fn rates_show_counts_percent_and_interval_and_split_in_csv() {
        let mut t = Table::new("t", "A table", &["what", "caught"]);
        t.push(vec![
            Cell::text("a|b"),
            Cell::Rate {
                count: 8,
                trials: 10,
            },
        ]);
        t.push(vec![Cell::text("none"), Cell::Empty]);
        assert_eq!(
            t.markdown(),
            "### A table\n\n| what | caught |\n| --- | --- |\n| a\\|b | 8/10 (80 %; 49–94) |\n| none | – |\n"
        );
        assert_eq!(
            t.csv().unwrap(),
            "what,caught,caught trials,caught ci95 low,caught ci95 high\na|b,8,10,0.4902,0.9433\nnone,,,,\n"
        );
        let json = render(&[t], Format::Json).unwrap();
        assert!(json.contains("\"count\": 8"), "{json}");
    }
}
