//! Outside the paper (issue 70, item 6): published numbers from other studies and from the
//! hardware's makers that the simulator can be set against without the rig, each with its
//! source, the simulator's number and the interval it lies in, and how the simulator's was
//! measured (`docs/outside.toml`). None was used to choose a simulator value: a test checks
//! that no parameter record cites a row's source.
//!
//! The rows are measured by scripts and examples at a recorded commit, not by the
//! reproduction (they need settings of their own: another frame rate, a pour until the
//! object slips), so the page shows them as recorded.

use std::fmt::Write as _;

use crate::report::html;

pub const OUTSIDE: &str = include_str!("../../docs/outside.toml");

/// One published number against the simulator's.
#[derive(Debug, Clone, PartialEq, serde::Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields)]
pub struct OutsideRow {
    /// What is compared, in words.
    pub quantity: String,
    /// Who published it and where (a citation a reader can find).
    pub source: String,
    /// A phrase every parameter record citing this source would contain (a test checks
    /// that none does: the row was never used to choose a value).
    pub source_key: String,
    /// The source's number, as it gives it.
    pub published: String,
    /// The published number's range for the comparison `[low, high]` (one value: twice).
    pub published_range: [f64; 2],
    /// The simulator's number and its 95 % interval `[estimate, low, high]`.
    pub simulator: [f64; 3],
    pub unit: String,
    /// How the simulator's number was measured: command, commit, seeds, counts.
    pub measured: String,
    /// What differs between the source's setup and the simulated one, and what the
    /// comparison says.
    pub reading: String,
}

impl OutsideRow {
    /// Whether the published range and the simulator's interval overlap.
    pub fn agrees(&self) -> bool {
        let [_, lo, hi] = self.simulator;
        lo <= self.published_range[1] && self.published_range[0] <= hi
    }

    fn verdict(&self) -> &'static str {
        if self.agrees() {
            "overlaps"
        } else if self.simulator[2] < self.published_range[0] {
            "simulator below"
        } else {
            "simulator above"
        }
    }

    fn simulator_cell(&self) -> String {
        let [x, lo, hi] = self.simulator;
        format!("{x:.1} [{lo:.1}, {hi:.1}] {}", self.unit)
    }
}

#[derive(Debug, Clone, Default, serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct File {
    #[serde(default)]
    outside: Vec<OutsideRow>,
}

/// Parses the records, checking each row's numbers (`origin` names the file in errors).
pub fn parse(text: &str, origin: &str) -> Result<Vec<OutsideRow>, String> {
    let f: File = toml::from_str(text).map_err(|e| format!("{origin}: {e}"))?;
    for (n, r) in f.outside.iter().enumerate() {
        let at = format!("{origin}: [[outside]] {} (`{}`)", n + 1, r.quantity);
        let [x, lo, hi] = r.simulator;
        if !(lo <= x && x <= hi && x.is_finite()) {
            return Err(format!(
                "{at}: simulator = [estimate, low, high] expects low <= estimate <= high, found {:?}",
                r.simulator
            ));
        }
        if r.published_range[0] > r.published_range[1] {
            return Err(format!(
                "{at}: published_range expects [low, high], found {:?}",
                r.published_range
            ));
        }
        if r.source_key.trim().is_empty() {
            return Err(format!("{at}: source_key is empty"));
        }
    }
    Ok(f.outside)
}

/// The shipped rows.
pub fn shipped() -> Vec<OutsideRow> {
    parse(OUTSIDE, "docs/outside.toml").expect("the shipped outside rows parse")
}

const WHY: &str = "Published numbers from outside the paper, set against the simulator without the rig: none was used to choose a simulator value (a test checks that no parameter record cites their sources). Each was measured by the command it names, not by this reproduction.";

/// The section as Markdown (empty without rows).
pub fn markdown(rows: &[OutsideRow]) -> String {
    if rows.is_empty() {
        return String::new();
    }
    let mut out = format!(
        "## Outside the paper\n\n{WHY}\n\n| quantity | source | published | simulator [95 % interval] | comparison | how measured; reading |\n| --- | --- | --- | --- | --- | --- |\n"
    );
    for r in rows {
        let _ = writeln!(
            out,
            "| {} | {} | {} | {} | {} | {} {} |",
            r.quantity,
            r.source,
            r.published,
            r.simulator_cell(),
            r.verdict(),
            r.measured,
            r.reading
        );
    }
    out + "\n"
}

/// The section as HTML (empty without rows).
pub fn html_section(rows: &[OutsideRow]) -> String {
    if rows.is_empty() {
        return String::new();
    }
    let mut out = format!(
        "<h2>Outside the paper</h2>\n<p>{}</p>\n<table>\n<tr><th>quantity</th><th>source</th><th>published</th><th>simulator [95 % interval]</th><th>comparison</th></tr>\n",
        html::escape(WHY)
    );
    for r in rows {
        let class = if r.agrees() { "yes" } else { "no" };
        let _ = writeln!(
            out,
            "<tr><td>{}<div class=\"details\">{} {}</div></td><td>{}</td><td>{}</td><td>{}</td><td class=\"{class}\">{}</td></tr>",
            html::escape(&r.quantity),
            html::inline_markdown(&r.measured),
            html::inline_markdown(&r.reading),
            html::inline_markdown(&r.source),
            html::escape(&r.published),
            html::escape(&r.simulator_cell()),
            r.verdict()
        );
    }
    out + "</table>\n"
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_shipped_rows_parse() {
        let rows = shipped();
        assert!(!rows.is_empty());
    }

    /// A row's source must never have chosen a simulator value: no parameter record (and
    /// no object record) cites it.
    #[test]
    fn no_parameter_record_cites_an_outside_source() {
        let records = tmo_sim::parameters::built_in();
        for r in shipped() {
            let key = r.source_key.to_lowercase();
            for p in &records {
                assert!(
                    !p.source.to_lowercase().contains(&key),
                    "`{}`'s record cites `{}`, the source of outside row `{}`",
                    p.name,
                    r.source_key,
                    r.quantity
                );
            }
        }
    }

    #[test]
    fn a_row_compares_its_range_with_the_interval() {
        let mut r = shipped().remove(0);
        r.published_range = [16.0, 16.0];
        r.simulator = [7.8, 5.0, 10.5];
        assert!(!r.agrees());
        assert_eq!(r.verdict(), "simulator below");
        r.simulator = [14.0, 12.0, 17.0];
        assert_eq!(r.verdict(), "overlaps");
        r.simulator = [20.0, 18.0, 22.0];
        assert_eq!(r.verdict(), "simulator above");
        let md = markdown(&[r]);
        assert!(md.contains("## Outside the paper") && md.contains("simulator above"));
    }

    #[test]
    fn bad_rows_are_refused_naming_the_row_and_the_field() {
        let row = |sim: &str| {
            format!(
                "[[outside]]\nquantity = \"q\"\nsource = \"s\"\nsource_key = \"k\"\npublished = \"1\"\npublished_range = [1.0, 1.0]\nsimulator = {sim}\nunit = \"mm\"\nmeasured = \"m\"\nreading = \"r\"\n"
            )
        };
        assert!(parse(&row("[1.0, 0.5, 2.0]"), "x.toml").is_ok());
        let e = parse(&row("[3.0, 0.5, 2.0]"), "x.toml").unwrap_err();
        assert!(
            e.contains("x.toml: [[outside]] 1 (`q`)") && e.contains("low <= estimate <= high"),
            "{e}"
        );
        let e = parse(&format!("{}extra = 1\n", row("[1.0, 0.5, 2.0]")), "x.toml").unwrap_err();
        assert!(e.contains("x.toml") && e.contains("extra"), "{e}");
    }
}
