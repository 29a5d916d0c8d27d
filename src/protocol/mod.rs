//! Protocol files: TOML parsed into structs that reject unknown fields, then validated into
//! a [`Plan`], the only thing the runner sees. Every default is the paper's value (SPEC.md,
//! "Protocols") unless its doc comment says otherwise.
//!
//! Errors name the file, the line and column, the field and what was expected.

pub mod collect;
pub mod exact;
mod params;

use std::path::{Path, PathBuf};

use serde::Deserialize;

use crate::online::strategy::Strategy;
pub use params::{
    Calibration, FirstTimeLift, HandRelease, Outcome, PerObject, RailCatch, RicePour, SafetyLimits,
    PAPER_TRAINING_OBJECTS, RAIL_FORWARD_SPEED_MM_S,
};

#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Kind {
    RailCatch,
    HandRelease,
    RicePour,
    FirstTimeLift,
    /// Finds g_min for first_time_lift by a systematic sweep of closure.
    CalibrateLift,
}

/// Every kind, as protocol files spell them.
pub const KINDS: [Kind; 5] = [
    Kind::RailCatch,
    Kind::HandRelease,
    Kind::RicePour,
    Kind::FirstTimeLift,
    Kind::CalibrateLift,
];

impl std::fmt::Display for Kind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Kind::RailCatch => "rail_catch",
            Kind::HandRelease => "hand_release",
            Kind::RicePour => "rice_pour",
            Kind::FirstTimeLift => "first_time_lift",
            Kind::CalibrateLift => "calibrate_lift",
        })
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Mode {
    /// Detect slip and react.
    #[default]
    Online,
    /// Run without reacting, to record training data.
    Collect,
}

/// The file as written.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ProtocolFile {
    pub kind: Kind,
    #[serde(default)]
    pub mode: Mode,
    /// Trials per grid cell.
    #[serde(default = "one")]
    pub repetitions: u32,
    /// Batch seed; trial i of the batch runs with a seed derived from it.
    #[serde(default)]
    pub seed: u64,
    /// Objects from the library (`tmo sim objects`); default per kind when left out (an
    /// empty list is refused: it would not mean the default).
    #[serde(default)]
    pub objects: Option<Vec<String>>,
    /// Hand roll, degrees.
    #[serde(default = "default_grasps")]
    pub grasps_deg: Vec<f64>,
    /// Model files (relative to the protocol file), one per classifier scope to compare.
    #[serde(default)]
    pub models: Vec<PathBuf>,
    /// Strategies as `NFrxNSen` (`2x2`) or `2Fr2Sen`; default per kind.
    #[serde(default)]
    pub strategies: Option<Vec<String>>,
    #[serde(default)]
    pub outcome: Outcome,
    /// Limits checked before any command is sent; the defaults suit the T-MO on a UR5.
    #[serde(default)]
    pub safety: SafetyLimits,
    /// The online loop's real-time contract (docs/online.md, "The deadline").
    #[serde(default)]
    pub deadline: crate::online::deadline::DeadlineSpec,
    pub rail_catch: Option<RailCatch>,
    pub hand_release: Option<HandRelease>,
    pub rice_pour: Option<RicePour>,
    pub first_time_lift: Option<FirstTimeLift>,
    pub calibrate_lift: Option<Calibration>,
    /// Simulator parameters for this batch, by the names of `tmo sim parameters`
    /// (`[sim.physics]` `finger_stiffness_n_per_mm = 1.2`, or `"rail.rail_mu" = 0.1`);
    /// the simulated rig only. `tmo reproduce --sensitivity` writes them.
    #[serde(default)]
    pub sim: toml::Table,
}

fn one() -> u32 {
    1
}

fn default_grasps() -> Vec<f64> {
    vec![0.0]
}

/// Where something is wrong in a protocol file. Line 0 means the file as a whole (it could
/// not be read), and the message names no line or field.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{}", self.located())]
pub struct ProtocolError {
    pub path: PathBuf,
    pub line: usize,
    pub column: usize,
    /// Dotted path of the field, e.g. `hand_release.regrasp`.
    pub field: String,
    pub message: String,
}

impl ProtocolError {
    /// The file as a whole could not be read.
    pub fn unreadable(path: &Path, e: &std::io::Error) -> Self {
        Self {
            path: path.to_path_buf(),
            line: 0,
            column: 0,
            field: String::new(),
            message: format!("cannot read: {e}"),
        }
    }

    fn located(&self) -> String {
        if self.line == 0 {
            format!("{}: {}", self.path.display(), self.message)
        } else {
            format!(
                "{}:{}:{}: {}: {}",
                self.path.display(),
                self.line,
                self.column,
                self.field,
                self.message
            )
        }
    }
}

/// Kind-specific parameters, validated.
#[derive(Debug, Clone, PartialEq)]
pub enum KindParams {
    RailCatch(RailCatch),
    HandRelease(HandRelease),
    RicePour(RicePour),
    FirstTimeLift(FirstTimeLift),
    CalibrateLift(Calibration),
}

/// What the runner executes: every combination the file asks for.
#[derive(Debug, Clone, PartialEq)]
pub struct Plan {
    pub source: PathBuf,
    pub source_sha256: String,
    /// The file's text, kept in every trial log it runs.
    pub source_text: String,
    pub kind: Kind,
    pub mode: Mode,
    pub seed: u64,
    pub repetitions: u32,
    pub objects: Vec<String>,
    pub grasps_deg: Vec<f64>,
    /// Resolved model paths (empty in collect mode and for calibration).
    pub models: Vec<PathBuf>,
    pub strategies: Vec<Strategy>,
    pub outcome: Outcome,
    pub safety: SafetyLimits,
    /// The real-time contract every online trial is held to.
    pub deadline: crate::online::deadline::DeadlineSpec,
    pub params: KindParams,
    /// Simulator parameters set for the batch (the file's `[sim]`), checked.
    pub sim: std::collections::BTreeMap<String, f64>,
}

/// The `[sim]` table's numbers by dotted name (`physics.finger_stiffness_n_per_mm`,
/// `arm.start_mm[2]`), or the name of the first entry that is not a number.
fn sim_parameters(table: &toml::Table) -> Result<std::collections::BTreeMap<String, f64>, String> {
    let v = serde_json::to_value(table).map_err(|_| "sim".to_string())?;
    match tmo_sim::config::numbers_by_name(&v) {
        (numbers, others) if others.is_empty() => Ok(numbers.into_iter().collect()),
        (_, others) => Err(others[0].clone()),
    }
}

impl Plan {
    /// Masses added to the object, one grid level each (`[0]` for kinds without masses).
    pub fn masses_g(&self) -> Vec<f64> {
        match &self.params {
            KindParams::FirstTimeLift(p) => p.masses_g.clone(),
            KindParams::CalibrateLift(p) => p.masses_g.clone(),
            KindParams::HandRelease(p) => p.masses_g.clone(),
            _ => vec![0.0],
        }
    }

    /// Trials in the batch: objects x masses x grasps x models x strategies x repetitions.
    pub fn trial_count(&self) -> usize {
        self.objects.len()
            * self.masses_g().len()
            * self.grasps_deg.len()
            * self.models.len().max(1)
            * self.strategies.len().max(1)
            * self.repetitions as usize
    }
}

/// Line and column (1-based) of byte `offset` in `text`.
pub(crate) fn line_column(text: &str, offset: usize) -> (usize, usize) {
    let before = &text[..offset.min(text.len())];
    let line = before.matches('\n').count() + 1;
    let column = before
        .rfind('\n')
        .map_or(before.len(), |i| before.len() - i - 1)
        + 1;
    (line, column)
}

/// Byte span of the value at dotted `field` (e.g. `hand_release.regrasp` or `models.1`),
/// or of the nearest enclosing item that has one.
pub(crate) fn field_span(text: &str, field: &str) -> Option<std::ops::Range<usize>> {
    let doc = toml_edit::ImDocument::parse(text.to_string()).ok()?;
    let mut item = doc.as_item();
    let mut span = None;
    for part in field.split('.') {
        if let Ok(i) = part.parse::<usize>() {
            return item.as_array()?.get(i)?.span().or(span);
        }
        match item.as_table_like().and_then(|t| t.get(part)) {
            Some(next) => item = next,
            None => return span,
        }
        span = item.span().or(span);
    }
    span
}

/// Dotted path of the innermost key whose value spans byte `offset`, for parse errors.
pub(crate) fn field_at(text: &str, offset: usize) -> Option<String> {
    fn walk(item: &toml_edit::Item, offset: usize, path: &mut Vec<String>) {
        let Some(table) = item.as_table_like() else {
            return;
        };
        for (key, value) in table.iter() {
            let header_or_value = value.span().is_some_and(|s| s.contains(&offset));
            let nested = value.as_table_like().is_some() && !value.is_inline_table();
            if header_or_value || nested {
                path.push(key.to_string());
                let before = path.len();
                walk(value, offset, path);
                if header_or_value || path.len() > before {
                    return;
                }
                path.pop();
            }
        }
    }
    let doc = toml_edit::ImDocument::parse(text.to_string()).ok()?;
    let mut path = Vec::new();
    walk(doc.as_item(), offset, &mut path);
    (!path.is_empty()).then(|| path.join("."))
}

/// Longest name an error message repeats whole.
const MAX_ECHO: usize = 60;

/// `text` itself, or its start and its length when it is too long to repeat.
fn shorten(text: &str) -> String {
    let n = text.chars().count();
    if n <= MAX_ECHO {
        return text.to_string();
    }
    let head: String = text.chars().take(40).collect();
    format!("{head}... ({n} characters)")
}

/// `message` with every `quoted` name [`shorten`]ed.
fn shorten_quoted(message: &str) -> String {
    let parts: Vec<&str> = message.split('`').collect();
    if parts.len() < 3 {
        return message.to_string();
    }
    parts
        .iter()
        .enumerate()
        .map(|(i, p)| {
            // odd parts lie between backticks
            if i % 2 == 1 && i + 1 < parts.len() {
                shorten(p)
            } else {
                p.to_string()
            }
        })
        .collect::<Vec<_>>()
        .join("`")
}

/// Parses a TOML file into `T`; a syntax or type error names its line, column and field.
pub(crate) fn parse_toml<T: serde::de::DeserializeOwned>(
    path: &Path,
    text: &str,
) -> Result<T, ProtocolError> {
    toml::from_str(text).map_err(|e| {
        let start = e.span().map(|s| s.start);
        let (line, column) = start.map_or((1, 1), |s| line_column(text, s));
        let field = start
            .and_then(|s| field_at(text, s))
            .unwrap_or_else(|| "(file)".into());
        let mut message = e.message().trim().to_string();
        if message.is_empty() {
            // the parser has no words for some characters; say which one it stopped at
            message = match start
                .and_then(|s| text.get(s..))
                .and_then(|t| t.chars().next())
            {
                Some(c) if c.is_control() => format!(
                    "a control character (U+{:04X}) that TOML does not allow here",
                    u32::from(c)
                ),
                Some(c) => format!("TOML syntax error at {c:?}"),
                None => "TOML syntax error".into(),
            };
        }
        if field == "kind" && !message.contains("rail_catch") {
            message = format!(
                "{message}; expected one of {}",
                KINDS.map(|k| format!("\"{k}\"")).join(", ")
            );
        }
        ProtocolError {
            path: path.to_path_buf(),
            line,
            column,
            field: shorten(&field),
            message: shorten_quoted(&message),
        }
    })
}

impl ProtocolFile {
    pub fn parse(path: &Path, text: &str) -> Result<Self, ProtocolError> {
        parse_toml(path, text)
    }
}

/// A list field as given, or the kind's default when it was left out; an empty list is
/// refused, since it would not mean the default.
fn given_or_default(
    name: &str,
    given: &Option<Vec<String>>,
    err: &dyn Fn(&str, String) -> ProtocolError,
    default: impl FnOnce() -> Vec<String>,
) -> Result<Vec<String>, ProtocolError> {
    match given {
        Some(list) if list.is_empty() => Err(err(
            name,
            "expected at least one entry (leave the field out for the kind's default)".into(),
        )),
        Some(list) => Ok(list.clone()),
        None => Ok(default()),
    }
}

/// Refuses a list in which an entry repeats an earlier one: its cells would run (and count)
/// twice.
fn refuse_repeats<T: PartialEq>(
    name: &str,
    items: &[T],
    err: &dyn Fn(&str, String) -> ProtocolError,
) -> Result<(), ProtocolError> {
    for (i, item) in items.iter().enumerate() {
        if let Some(k) = items[..i].iter().position(|x| x == item) {
            return Err(err(
                &format!("{name}.{i}"),
                format!("the same as {name}.{k}: each cell runs once"),
            ));
        }
    }
    Ok(())
}

/// Reads, parses and validates a protocol file.
pub fn load(path: &Path, rig_sensors: u32) -> Result<Plan, ProtocolError> {
    let text = std::fs::read_to_string(path).map_err(|e| ProtocolError::unreadable(path, &e))?;
    from_text(path, &text, rig_sensors)
}

/// Parses and validates a protocol's text; `origin` names it in errors and in the plan.
pub fn from_text(origin: &Path, text: &str, rig_sensors: u32) -> Result<Plan, ProtocolError> {
    let file = ProtocolFile::parse(origin, text)?;
    validate(origin, text, file, rig_sensors)
}

/// Checks values and the grid; `text` locates the offending field.
pub fn validate(
    path: &Path,
    text: &str,
    file: ProtocolFile,
    rig_sensors: u32,
) -> Result<Plan, ProtocolError> {
    let err = |field: &str, message: String| {
        let (line, column) = field_span(text, field).map_or((1, 1), |s| line_column(text, s.start));
        ProtocolError {
            path: path.to_path_buf(),
            line,
            column,
            field: field.to_string(),
            message,
        }
    };
    let library = tmo_sim::ObjectLibrary::built_in();

    if file.repetitions == 0 {
        return Err(err("repetitions", "expected at least 1".into()));
    }
    let objects = given_or_default("objects", &file.objects, &err, || {
        params::default_objects(file.kind)
    })?;
    refuse_repeats("objects", &objects, &err)?;
    refuse_repeats(
        "grasps_deg",
        &file
            .grasps_deg
            .iter()
            .map(|g| g.to_bits())
            .collect::<Vec<_>>(),
        &err,
    )?;
    refuse_repeats("models", &file.models, &err)?;
    for (i, o) in objects.iter().enumerate() {
        if library.get(o).is_err() {
            return Err(err(
                &format!("objects.{i}"),
                format!("unknown object `{o}`; expected one of `tmo sim objects`"),
            ));
        }
        // The rail rig holds only its rail object, and the hand never holds that one.
        let rail_object = o == "rail_object";
        if rail_object != (file.kind == Kind::RailCatch) {
            return Err(err(
                &format!("objects.{i}"),
                if rail_object {
                    format!(
                        "`{o}` belongs to the slip rail; {} runs on the hand",
                        file.kind
                    )
                } else {
                    format!("`{o}` is a hand object; rail_catch holds only `rail_object`")
                },
            ));
        }
    }
    if file.grasps_deg.is_empty() {
        return Err(err("grasps_deg", "expected at least one angle".into()));
    }
    for (i, g) in file.grasps_deg.iter().enumerate() {
        if !(-360.0..=360.0).contains(g) {
            return Err(err(
                &format!("grasps_deg.{i}"),
                format!(
                    "expected an angle in -360..=360 degrees, got {}",
                    crate::quote::number(*g)
                ),
            ));
        }
    }

    let needs_models = file.mode == Mode::Online && file.kind != Kind::CalibrateLift;
    if file.mode == Mode::Collect
        && matches!(
            file.kind,
            Kind::FirstTimeLift | Kind::CalibrateLift | Kind::RicePour
        )
    {
        return Err(err(
            "mode",
            format!(
                "{} has no collect mode; expected mode = \"online\"",
                file.kind
            ),
        ));
    }
    let base = path.parent().unwrap_or(Path::new("."));
    let mut models = Vec::new();
    if needs_models {
        if file.models.is_empty() {
            return Err(err(
                "kind",
                "an online protocol needs `models = [\"model.json\", ...]`".into(),
            ));
        }
        for (i, m) in file.models.iter().enumerate() {
            let resolved = base.join(m);
            if resolved.exists() && !resolved.is_file() {
                return Err(err(
                    &format!("models.{i}"),
                    format!(
                        "{} is not a regular file; a model is the JSON file `tmo train` writes",
                        resolved.display()
                    ),
                ));
            }
            if !resolved.is_file() {
                return Err(err(
                    &format!("models.{i}"),
                    format!(
                        "model file {} not found; make one from collected trials with `tmo train TRIALS --out {}` (docs/commands.md, \"The pipeline, step by step\"), or run `tmo reproduce --preset quick`, which collects, trains and runs every protocol",
                        resolved.display(),
                        resolved.display()
                    ),
                ));
            }
            models.push(resolved);
        }
    } else if !file.models.is_empty() {
        return Err(err(
            "models",
            "models apply only to online protocols".into(),
        ));
    }

    let strategy_texts = given_or_default("strategies", &file.strategies, &err, || {
        params::default_strategies(file.kind)
    })?;
    let mut strategies = Vec::new();
    if !needs_models && file.strategies.is_some() {
        return Err(err(
            "strategies",
            "strategies apply only to online protocols (nothing reacts in this one)".into(),
        ));
    }
    if needs_models {
        for (i, s) in strategy_texts.iter().enumerate() {
            let field = format!("strategies.{i}");
            let strategy: Strategy = s.parse().map_err(|e| err(&field, format!("{e}")))?;
            let limit = if file.kind == Kind::RailCatch {
                1
            } else {
                rig_sensors
            };
            strategy
                .check(limit)
                .map_err(|e| err(&field, format!("{e}")))?;
            if let Some(k) = strategies.iter().position(|s| *s == strategy) {
                return Err(err(
                    &field,
                    format!("{strategy} again (strategies.{k}): each cell runs once"),
                ));
            }
            strategies.push(strategy);
        }
    }
    file.outcome
        .check()
        .map_err(|(f, m)| err(&format!("outcome.{f}"), m))?;

    let sections = [
        ("rail_catch", file.rail_catch.is_some(), Kind::RailCatch),
        (
            "hand_release",
            file.hand_release.is_some(),
            Kind::HandRelease,
        ),
        ("rice_pour", file.rice_pour.is_some(), Kind::RicePour),
        (
            "first_time_lift",
            file.first_time_lift.is_some(),
            Kind::FirstTimeLift,
        ),
        (
            "calibrate_lift",
            file.calibrate_lift.is_some(),
            Kind::CalibrateLift,
        ),
    ];
    for (name, present, kind) in sections {
        if present && kind != file.kind {
            return Err(err(
                name,
                format!("section [{name}] does not apply to kind {}", file.kind),
            ));
        }
    }
    let mut params = match file.kind {
        Kind::RailCatch => KindParams::RailCatch(file.rail_catch.clone().unwrap_or_default()),
        Kind::HandRelease => KindParams::HandRelease(file.hand_release.clone().unwrap_or_default()),
        Kind::RicePour => KindParams::RicePour(file.rice_pour.clone().unwrap_or_default()),
        Kind::FirstTimeLift => {
            KindParams::FirstTimeLift(file.first_time_lift.clone().unwrap_or_default())
        }
        Kind::CalibrateLift => {
            KindParams::CalibrateLift(file.calibrate_lift.clone().unwrap_or_default())
        }
    };
    params
        .check()
        .map_err(|(section, f, m)| err(&format!("{section}.{f}"), m))?;
    file.safety
        .check()
        .map_err(|(section, f, m)| err(&format!("{section}.{f}"), m))?;
    file.deadline
        .check()
        .map_err(|(f, m)| err(&format!("deadline.{f}"), m))?;
    // What the protocol asks of the arm must be within the limits, or every trial would be
    // refused mid-way.
    for (field, value, limit, limit_field) in params.demands(&file.safety) {
        if value > limit {
            return Err(err(
                field,
                format!(
                    "expected at most {limit_field} ({limit}), got {}",
                    crate::quote::number(value)
                ),
            ));
        }
    }
    if let KindParams::FirstTimeLift(p) = &mut params {
        if let Some(c) = p.calibration.as_mut() {
            let resolved = base.join(&*c);
            if !resolved.is_file() {
                return Err(err(
                    "first_time_lift.calibration",
                    format!(
                        "calibration table {} not found; expected the g_min.json a calibrate_lift batch writes",
                        resolved.display()
                    ),
                ));
            }
            *c = resolved;
        }
    }
    let grasp_table = match &params {
        KindParams::HandRelease(HandRelease {
            grasp_past_contact: Some(PerObject::Each(table)),
            ..
        }) => Some(("hand_release.grasp_past_contact", table)),
        KindParams::RicePour(RicePour {
            grasp_past_contact: Some(PerObject::Each(table)),
            ..
        }) => Some(("rice_pour.grasp_past_contact", table)),
        _ => None,
    };
    if let Some((field, table)) = grasp_table {
        if let Some(o) = objects
            .iter()
            .find(|o| !table.contains_key(*o) && !table.contains_key("default"))
        {
            return Err(err(
                field,
                format!("expected a value for {o} (or a `default`), one for each object"),
            ));
        }
    }
    if let (KindParams::HandRelease(p), Mode::Collect) = (&params, file.mode) {
        if p.lift_mm < 100.0 {
            return Err(err(
                "hand_release.lift_mm",
                format!(
                    "expected at least 100 mm in collect mode, so that a released object slides for the 15 frames the labels may use before it lands, got {}",
                    crate::quote::number(p.lift_mm)
                ),
            ));
        }
    }
    if let (KindParams::HandRelease(p), Mode::Online) = (&params, file.mode) {
        if p.lift_mm <= file.outcome.drop_limit_mm {
            return Err(err(
                "hand_release.lift_mm",
                format!(
                    "expected more than outcome.drop_limit_mm ({} mm) so that a drop shows in the marker track, got {}",
                    file.outcome.drop_limit_mm,
                    crate::quote::number(p.lift_mm)
                ),
            ));
        }
    }

    let sim = sim_parameters(&file.sim)
        .map_err(|name| err(&format!("sim.{name}"), "expected a number".into()))?;
    // Checked on both rigs, so that a value neither can stand for is refused here.
    for rig in [
        tmo_sim::RigSetup::Hand(Default::default()),
        tmo_sim::RigSetup::Rail(Default::default()),
    ] {
        let mut config = tmo_sim::SimConfig {
            rig,
            ..Default::default()
        };
        config
            .set_parameters(sim.iter().map(|(k, v)| (k.as_str(), *v)))
            .map_err(|e| err(&format!("sim.{}", e.field), format!("{e}")))?;
    }
    Ok(Plan {
        source: path.to_path_buf(),
        source_sha256: crate::trial::sha256_hex(text.as_bytes()),
        source_text: text.to_string(),
        kind: file.kind,
        mode: file.mode,
        seed: file.seed,
        repetitions: file.repetitions,
        objects,
        grasps_deg: file.grasps_deg,
        models,
        strategies,
        outcome: file.outcome,
        safety: file.safety,
        deadline: file.deadline,
        params,
        sim,
    })
}

#[cfg(test)]
mod tests;
