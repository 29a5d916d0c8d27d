//! The steps of a reproduction, in the paper's order, and the counts each preset runs.
//!
//! Batch steps write a protocol file into their directory and run it through the batch loop
//! `tmo run` uses (so each can be rerun by hand with `tmo run DIR/protocol.toml`); offline
//! steps call the sweep, search, training and evaluation code of `tmo sweep`, `tmo train`
//! and `tmo evaluate`.

use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;

use super::measure::{NOVEL_OBJECTS, TRAINING_OBJECTS};
use super::{io, read_record, Backend, ReproduceError};
use crate::protocol::collect::{CollectPreset, CollectRig};
use crate::protocol::Kind;
use crate::runner::batch_run::{run_batch, BatchEnd, BatchRequest, BatchRig};
use crate::slip::dataset::{load_labelled, Dataset, LabelSpec, Scope};
use crate::slip::evaluation::Evaluation;
use crate::slip::labels::OnsetSpec;
use crate::slip::model::{ClassifierKind, Hyperparameters, ModelFile, TrainSpec};
use crate::slip::slip_model::SlipModel;
use crate::slip::sweep::{HyperChoice, SweepRow, SweepSpec};
use crate::slip::sweep_file::{run_to_file, SweepPart, SweepTarget};
use crate::slip::tuning::{self, TuneSpec};

/// C of the paper's best SVM, used for the sweep's cells when they are not searched (the
/// rail model's own C and gamma are searched for either way).
pub const SWEEP_C: f64 = 3.989;
/// gamma of the sweep's RBF cells when they are not searched. Our features are standardised per column before the
/// kernel (the paper does not say how it scaled them), so the paper's 1.104 does not carry
/// over; 0.02 is near 1/60, scikit-learn's "scale" default for 60 standardised features.
pub const SWEEP_GAMMA: f64 = 0.02;

/// tmo's own global model in the hand models' step.
const TMO_GLOBAL: &str = "global.json";

#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Preset {
    /// The fewest trials that run every step (a few seconds): checks an install, a
    /// cluster's setup or the pipeline's plumbing (resume, shards, merges); its verdicts
    /// mean nothing.
    Smoke,
    /// A scaled-down run for a first look (about 20 s on two cores).
    Quick,
    /// The paper's counts.
    Paper,
}

/// How much each step runs.
#[derive(Debug, Clone, PartialEq)]
pub struct Counts {
    /// Rail collect trials in each of train and test (paper 50 + 50).
    pub rail_collect: u32,
    pub sweep_downsample: Vec<f64>,
    pub sweep_n_slip: Vec<usize>,
    /// Bayesian search (evaluations, folds) in every sweep cell, as the paper's
    /// BayesSearchCV; `None` for the fixed C and gamma above.
    pub sweep_search: Option<(usize, usize)>,
    pub search_iterations: usize,
    pub search_folds: usize,
    /// Online rail trials per strategy (paper 50).
    pub rail_online: u32,
    /// Collect trials per training object in each of train and test (paper 10 + 10).
    pub hand_collect: u32,
    /// Trials per scope x strategy x grasp (paper 10).
    pub hand_online: u32,
    /// Trials per object x strategy (paper 10).
    pub objects: u32,
    /// Rice pours (paper 5).
    pub pour: u32,
    /// Calibration sweeps per mass.
    pub calibrate: u32,
    /// First-time lifts per mass (paper 10).
    pub lift: u32,
}

impl Preset {
    pub const ALL: [Preset; 3] = [Preset::Smoke, Preset::Quick, Preset::Paper];

    pub fn name(self) -> &'static str {
        match self {
            Preset::Smoke => "smoke",
            Preset::Quick => "quick",
            Preset::Paper => "paper",
        }
    }

    /// The preset a plan or record names, if it is one.
    pub fn from_name(name: &str) -> Option<Preset> {
        Preset::ALL.into_iter().find(|p| p.name() == name)
    }

    /// Replicates when none are asked for: five for the paper's counts, so that its
    /// verdicts rest on their spread; one for a first look.
    pub fn default_replicates(self) -> u32 {
        match self {
            Preset::Smoke | Preset::Quick => 1,
            Preset::Paper => 5,
        }
    }

    pub fn counts(self) -> Counts {
        match self {
            Preset::Paper => Counts {
                rail_collect: 50,
                sweep_downsample: (1..=10).map(|k| k as f64 / 10.0).collect(),
                sweep_n_slip: (1..=15).collect(),
                sweep_search: Some((12, 3)),
                search_iterations: 20,
                search_folds: 3,
                rail_online: 50,
                hand_collect: 10,
                hand_online: 10,
                objects: 10,
                pour: 5,
                calibrate: 3,
                lift: 10,
            },
            Preset::Smoke => Counts {
                rail_collect: 8,
                sweep_downsample: vec![0.4, 1.0],
                sweep_n_slip: vec![5, 11],
                sweep_search: None,
                search_iterations: 4,
                search_folds: 3,
                rail_online: 6,
                hand_collect: 2,
                hand_online: 1,
                objects: 1,
                pour: 1,
                calibrate: 1,
                lift: 1,
            },
            Preset::Quick => Counts {
                rail_collect: 25,
                sweep_downsample: vec![0.2, 0.4, 0.7, 1.0],
                sweep_n_slip: vec![1, 3, 5, 7, 9, 11, 13, 15],
                sweep_search: None,
                search_iterations: 8,
                search_folds: 3,
                rail_online: 20,
                hand_collect: 4,
                hand_online: 3,
                objects: 3,
                pour: 3,
                calibrate: 1,
                lift: 3,
            },
        }
    }
}

/// What every step can see.
pub struct Context<'a> {
    /// The replicate's directory, which holds its steps' directories.
    pub out: &'a Path,
    /// Which replicate (1-based): it sets every trial and learner seed.
    pub replicate: u32,
    /// Simulator parameters set for the batch steps whose rig has them (a sensitivity
    /// variant); empty for the baseline.
    pub sim: &'a std::collections::BTreeMap<String, f64>,
    /// A finished replicate of the same seeds to take a step from when its inputs are the
    /// same (a sensitivity variant takes the steps its parameter does not touch from the
    /// baseline).
    pub reuse: Option<&'a Path>,
    pub preset: &'a Preset,
    pub backend: &'a Backend,
    pub stop: &'a AtomicBool,
    pub bar: &'a indicatif::ProgressBar,
    /// The job's directory under the reproduction's (`replicate-01`,
    /// `sensitivity/<variant>/replicate-01`), as plans name it.
    pub job: &'a str,
    /// Where the rail sweep was run (`--sweep-from`): its rows are joined from these
    /// parts instead of computed here.
    pub sweep_from: Option<&'a dyn SweptElsewhere>,
    /// A user's model in place of the hand's global model (`--hand-model`).
    pub hand_model: Option<&'a super::hand_model::HandModel>,
}

/// A rail sweep run elsewhere (`--sweep-only` parts, [`super::sweep_parts`]), whose rows a
/// job joins instead of sweeping. A trait, so that the steps need not know how parts are
/// kept (the parts module builds on the steps).
pub trait SweptElsewhere: Sync {
    /// The rows of the job of `ctx`, swept with `spec` on the data whose digest is `data`
    /// ([`sweep_data_digest`]); an error names what does not fit.
    fn rows_for(
        &self,
        ctx: &Context,
        spec: &SweepSpec,
        data: &str,
    ) -> Result<Vec<SweepRow>, ReproduceError>;
}

/// What a sweep was computed from: the digest of its training and test rows.
pub fn sweep_data_digest(train: &Dataset, test: &Dataset) -> String {
    crate::trial::sha256_hex(format!("{} {}", train.digest(), test.digest()).as_bytes())
}

impl Context<'_> {
    /// The hand's global model's file in the hand models' step: a user's model, or tmo's.
    pub fn global_model(&self) -> &str {
        self.hand_model.map_or(TMO_GLOBAL, |m| m.file.as_str())
    }

    /// The seed of learners (sweep, search, training): 0 in the first replicate.
    pub fn learner_seed(&self) -> u64 {
        learner_seed(self.replicate)
    }
}

/// The seed of replicate `replicate`'s learners.
fn learner_seed(replicate: u32) -> u64 {
    u64::from(replicate.saturating_sub(1))
}

/// Replicate `r`'s seed for a protocol whose first replicate uses `base`: replicates are
/// 1000 apart, so no two protocols of a reproduction share a seed.
pub fn trial_seed(base: u32, replicate: u32) -> u64 {
    u64::from(base) + 1000 * u64::from(replicate.saturating_sub(1))
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Step {
    RailCollect,
    RailSweep,
    RailModel,
    RailOnline,
    HandCollect,
    HandModels,
    HandOnline,
    Objects,
    RicePour,
    Calibrate,
    FirstTimeLift,
}

/// The paper's eleven objects: its five training objects first, then the six novel ones.
fn paper_objects() -> Vec<&'static str> {
    TRAINING_OBJECTS
        .iter()
        .chain(&NOVEL_OBJECTS)
        .copied()
        .collect()
}

fn quoted(items: &[&str]) -> String {
    items
        .iter()
        .map(|s| format!("\"{s}\""))
        .collect::<Vec<_>>()
        .join(", ")
}

impl Step {
    pub const ALL: [Step; 11] = [
        Step::RailCollect,
        Step::RailSweep,
        Step::RailModel,
        Step::RailOnline,
        Step::HandCollect,
        Step::HandModels,
        Step::HandOnline,
        Step::Objects,
        Step::RicePour,
        Step::Calibrate,
        Step::FirstTimeLift,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Step::RailCollect => "rail_collect",
            Step::RailSweep => "rail_sweep",
            Step::RailModel => "rail_model",
            Step::RailOnline => "rail_online",
            Step::HandCollect => "hand_collect",
            Step::HandModels => "hand_models",
            Step::HandOnline => "hand_online",
            Step::Objects => "hand_objects",
            Step::RicePour => "rice_pour",
            Step::Calibrate => "calibrate_lift",
            Step::FirstTimeLift => "first_time_lift",
        }
    }

    /// The step's directory under the output directory.
    pub fn dir(self) -> String {
        let k = Step::ALL.iter().position(|s| *s == self).expect("listed") + 1;
        format!("{k:02}_{}", self.name())
    }

    pub fn title(self) -> &'static str {
        match self {
            Step::RailCollect => "single finger: collecting rail trials",
            Step::RailSweep => "single finger: classifier x d x n_slip sweep",
            Step::RailModel => "single finger: searching the best cell's SVM",
            Step::RailOnline => "single finger: online rail catch, 1 vs 2 frames",
            Step::HandCollect => "whole hand: collecting releases at 0 deg",
            Step::HandModels => "whole hand: local and global models, offline",
            Step::HandOnline => "whole hand: online release, 6 strategies x scopes x grasps",
            Step::Objects => "whole hand: eleven objects",
            Step::RicePour => "rice pour into the empty can",
            Step::Calibrate => "first-time lift: calibrating g_min",
            Step::FirstTimeLift => "first-time lift over the masses",
        }
    }

    fn depends_on(self) -> &'static [Step] {
        match self {
            Step::RailCollect | Step::HandCollect | Step::Calibrate => &[],
            Step::RailSweep => &[Step::RailCollect],
            Step::RailModel => &[Step::RailCollect, Step::RailSweep],
            Step::RailOnline => &[Step::RailModel],
            Step::HandModels => &[Step::RailModel, Step::HandCollect],
            Step::HandOnline | Step::Objects | Step::RicePour => &[Step::HandModels],
            Step::FirstTimeLift => &[Step::HandModels, Step::Calibrate],
        }
    }

    /// Whether the step's rig is the slip rail (else the hand).
    fn on_the_rail(self) -> bool {
        matches!(self, Step::RailCollect | Step::RailOnline)
    }

    /// The `[sim]` table of the step's protocols: the parameters its rig has.
    fn sim_table(self, sim: &std::collections::BTreeMap<String, f64>) -> String {
        let mine: Vec<String> = sim
            .iter()
            .filter(|(k, _)| !k.starts_with(super::sensitivity::PROTOCOL_PREFIX))
            .filter(|(k, _)| self.on_the_rail() || !k.starts_with("rail."))
            .map(|(k, v)| format!("\"{k}\" = {v:?}\n"))
            .collect();
        if mine.is_empty() {
            String::new()
        } else {
            format!("\n[sim]\n{}", mine.concat())
        }
    }

    /// Protocol files of a batch step in replicate `r` with simulator parameters `sim`, by
    /// sub-directory ("" for the step's own); the hand's global model is the file
    /// `global` of the hand models' step (tmo's `global.json`, or a user's model).
    fn protocols(
        self,
        c: &Counts,
        r: u32,
        sim: &std::collections::BTreeMap<String, f64>,
        global: &str,
    ) -> Vec<(&'static str, String)> {
        let table = self.sim_table(sim);
        let lines = self.protocol_lines(sim);
        self.base_protocols(c, r, global)
            .into_iter()
            .map(|(sub, text)| (sub, text + &lines + &table))
            .collect()
    }

    /// The protocol values of `sim` that this step's protocols take (`protocol.lift.*` in
    /// the lifts' own section, which each of their protocols ends with), as TOML lines.
    fn protocol_lines(self, sim: &std::collections::BTreeMap<String, f64>) -> String {
        let prefix = match self {
            Step::Calibrate | Step::FirstTimeLift => "protocol.lift.",
            _ => return String::new(),
        };
        sim.iter()
            .filter_map(|(k, v)| Some(format!("{} = {v:?}\n", k.strip_prefix(prefix)?)))
            .collect()
    }

    fn base_protocols(self, c: &Counts, r: u32, global: &str) -> Vec<(&'static str, String)> {
        let seed = |base: u32| trial_seed(base, r);
        let [s13, s23, s24, s25, s26, s27, s28, s29, s30] =
            [13, 23, 24, 25, 26, 27, 28, 29, 30].map(seed);
        // collect mode is the preset `tmo sim collect` runs too
        let rail_object = ["rail_object".to_string()];
        let training_objects: Vec<String> = TRAINING_OBJECTS.map(String::from).to_vec();
        let rail_collect = |seed: u64| {
            CollectPreset {
                rig: CollectRig::Rail,
                repetitions: c.rail_collect,
                seed,
                objects: &rail_object,
                grasps_deg: &[],
            }
            .protocol()
        };
        let hand_collect = |seed: u64| {
            CollectPreset {
                rig: CollectRig::Hand,
                repetitions: c.hand_collect,
                seed,
                objects: &training_objects,
                grasps_deg: &[0.0],
            }
            .protocol()
        };
        let models = "../06_hand_models";
        match self {
            Step::RailCollect => vec![("train", rail_collect(seed(11))), ("test", rail_collect(seed(12)))],
            Step::RailOnline => vec![(
                "",
                format!(
                    "kind = \"rail_catch\"\nrepetitions = {}\nseed = {s13}\nobjects = [\"rail_object\"]\nmodels = [\"../03_rail_model/rail.json\"]\nstrategies = [\"1x1\", \"2x1\"]\n",
                    c.rail_online
                ),
            )],
            Step::HandCollect => vec![("train", hand_collect(seed(21))), ("test", hand_collect(seed(22)))],
            Step::HandOnline => vec![(
                "",
                format!(
                    "kind = \"hand_release\"\nrepetitions = {}\nseed = {s23}\nobjects = [\"crisps_can\"]\ngrasps_deg = [0, 180]\nmodels = [\"{models}/{global}\", \"{models}/local.json\"]\nstrategies = [\"1x1\", \"2x1\", \"1x2\", \"2x2\", \"1x3\", \"2x3\"]\n",
                    c.hand_online
                ),
            )],
            Step::Objects => vec![
                (
                    "all",
                    format!(
                        "kind = \"hand_release\"\nrepetitions = {}\nseed = {s24}\nobjects = [{}]\ngrasps_deg = [0]\nmodels = [\"../{models}/{global}\"]\nstrategies = [\"2x2\", \"1x2\"]\n",
                        c.objects,
                        quoted(&paper_objects())
                    ),
                ),
                (
                    // the paper's cat again, with a 100 g mass adhered to its underside
                    "cat_100g",
                    format!(
                        "kind = \"hand_release\"\nrepetitions = {}\nseed = {s30}\nobjects = [\"toy_cat\"]\ngrasps_deg = [0]\nmodels = [\"../{models}/{global}\"]\nstrategies = [\"2x2\", \"1x2\"]\n\n[hand_release]\nmasses_g = [100]\n",
                        c.objects
                    ),
                ),
            ],
            Step::RicePour => vec![(
                "",
                format!(
                    "kind = \"rice_pour\"\nrepetitions = {}\nseed = {s25}\nobjects = [\"crisps_can_empty\"]\nmodels = [\"{models}/{global}\"]\nstrategies = [\"2x2\"]\n",
                    c.pour
                ),
            )],
            Step::Calibrate => vec![
                (
                    "can",
                    format!(
                        "kind = \"calibrate_lift\"\nrepetitions = {}\nseed = {s26}\nobjects = [\"crisps_can_empty\"]\n\n[calibrate_lift]\nmasses_g = [0, 50, 100, 150, 250, 350, 450]\n",
                        c.calibrate
                    ),
                ),
                (
                    "cat",
                    format!(
                        "kind = \"calibrate_lift\"\nrepetitions = {}\nseed = {s27}\nobjects = [\"toy_cat\"]\n\n[calibrate_lift]\nmasses_g = [0, 100]\n",
                        c.calibrate
                    ),
                ),
            ],
            Step::FirstTimeLift => vec![
                (
                    "can",
                    format!(
                        "kind = \"first_time_lift\"\nrepetitions = {}\nseed = {s28}\nobjects = [\"crisps_can_empty\"]\nmodels = [\"../{models}/{global}\"]\nstrategies = [\"1x1\"]\n\n[first_time_lift]\nmasses_g = [0, 50, 100, 150, 250, 350, 450]\ncalibration = \"../../10_calibrate_lift/can/g_min.json\"\n",
                        c.lift
                    ),
                ),
                (
                    "cat",
                    format!(
                        "kind = \"first_time_lift\"\nrepetitions = {}\nseed = {s29}\nobjects = [\"toy_cat\"]\nmodels = [\"../{models}/{global}\"]\nstrategies = [\"1x1\"]\n\n[first_time_lift]\nmasses_g = [0, 100]\ncalibration = \"../../10_calibrate_lift/cat/g_min.json\"\n",
                        c.lift
                    ),
                ),
            ],
            Step::RailSweep | Step::RailModel | Step::HandModels => Vec::new(),
        }
    }

    /// Everything the step's result depends on, as text (hashed into `step.json`): the
    /// code's version and git revision, its settings and the output digests of the steps
    /// it reads.
    pub fn inputs(self, ctx: &Context) -> Result<String, ReproduceError> {
        // The code is an input: a step made by another build of tmo is made again.
        let (version, revision) = crate::trial::TrialMeta::code_version();
        self.inputs_of_build(ctx, &version, &revision)
    }

    /// The step's inputs as the build `version` (`revision`) would state them: what a
    /// finished step's record is checked against when the page is written again by a
    /// later build (`--findings-only`).
    pub fn inputs_of_build(
        self,
        ctx: &Context,
        version: &str,
        revision: &str,
    ) -> Result<String, ReproduceError> {
        let c = ctx.preset.counts();
        let mut text = format!(
            "step {}\ntmo {version} {revision}\nreplicate {} learner seed {}\n",
            self.name(),
            ctx.replicate,
            ctx.learner_seed()
        );
        match self {
            Step::RailSweep => text.push_str(&format!(
                "d {:?}\nn_slip {:?}\nsearch {:?} else C {SWEEP_C} gamma {SWEEP_GAMMA}\n",
                c.sweep_downsample, c.sweep_n_slip, c.sweep_search
            )),
            Step::RailModel => text.push_str(&format!(
                "search {} x {} folds\n",
                c.search_iterations, c.search_folds
            )),
            _ => {}
        }
        for (sub, protocol) in self.protocols(&c, ctx.replicate, ctx.sim, ctx.global_model()) {
            text.push_str(&format!("[{sub}]\n{protocol}"));
        }
        if let (Step::HandModels, Some(m)) = (self, ctx.hand_model) {
            text.push_str(&m.inputs_line());
        }
        if let Backend::Real { hand, rail, .. } = ctx.backend {
            let file = if matches!(self, Step::RailCollect | Step::RailOnline) {
                rail
            } else {
                hand
            };
            let bytes = std::fs::read(file).map_err(io(file))?;
            text.push_str(&format!("real rig {}\n", crate::trial::sha256_hex(&bytes)));
        }
        for dep in self.depends_on() {
            let digest = read_record(&ctx.out.join(dep.dir()))
                .map_or("not finished".into(), |r| r.outputs_sha256);
            text.push_str(&format!("{} {digest}\n", dep.name()));
        }
        Ok(text)
    }

    /// Runs the step into `dir`; `Ok(false)` when it was interrupted.
    pub fn run(self, ctx: &Context, dir: &Path) -> Result<bool, ReproduceError> {
        let c = ctx.preset.counts();
        let step = self.name();
        match self {
            Step::RailSweep => rail_sweep(ctx, &c, dir),
            Step::RailModel => rail_model(ctx, &c, dir).map(|_| true),
            Step::HandModels => hand_models(ctx, dir).map(|_| true),
            _ => {
                for (sub, protocol) in
                    self.protocols(&c, ctx.replicate, ctx.sim, ctx.global_model())
                {
                    let batch_dir = if sub.is_empty() {
                        dir.to_path_buf()
                    } else {
                        dir.join(sub)
                    };
                    if !run_batch_step(ctx, step, &batch_dir, &protocol)? {
                        return Ok(false);
                    }
                }
                Ok(true)
            }
        }
    }
}

/// Runs one protocol as a batch in `dir` (resuming it if some trials are there).
fn run_batch_step(
    ctx: &Context,
    step: &'static str,
    dir: &Path,
    protocol: &str,
) -> Result<bool, ReproduceError> {
    std::fs::create_dir_all(dir).map_err(io(dir))?;
    let path = dir.join("protocol.toml");
    crate::output::atomic::write_atomic(&path, protocol.as_bytes()).map_err(io(&path))?;
    let mut plan = crate::protocol::load(&path, 3).map_err(|e| ReproduceError::step(step, e))?;
    let batch = |source| ReproduceError::Batch { step, source };
    let mut rig = match ctx.backend {
        Backend::Sim => BatchRig::Sim,
        Backend::Real {
            hand,
            rail,
            unattended,
        } => {
            let file = if plan.kind == Kind::RailCatch {
                rail
            } else {
                hand
            };
            let hw =
                crate::runner::hardware::load(file).map_err(|e| ReproduceError::step(step, e))?;
            crate::runner::real_trial::check_real_plan(&hw, &mut plan).map_err(batch)?;
            let staging = crate::runner::staging::Staging::for_batch(&hw, plan.kind, *unattended)
                .map_err(batch)?;
            let rig = crate::runner::real_trial::open_real(hw, plan.safety).map_err(batch)?;
            BatchRig::Real {
                staging,
                rig: Box::new(rig),
            }
        }
    };
    ctx.bar.reset();
    let request = BatchRequest {
        plan: &plan,
        out: dir,
        resume: true,
        rerun_faulted: false,
        shard: None,
        live: None,
        on_trial: None,
        on_warning: None,
        on_note: None,
        // lock-step outcomes do not depend on this machine's speed; a real rig's do
        allow_slow_model: matches!(rig, BatchRig::Sim),
    };
    let end = run_batch(&request, &mut rig, ctx.stop, ctx.bar).map_err(batch)?;
    Ok(matches!(end, BatchEnd::Finished(_)))
}

fn labels(n_slip: usize) -> LabelSpec {
    LabelSpec {
        n_slip,
        onset: OnsetSpec::default(),
    }
}

fn load(
    step: &'static str,
    paths: &[PathBuf],
    n_slip: usize,
) -> Result<
    (
        Dataset,
        Vec<crate::slip::model::TrialRef>,
        crate::slip::features::FeatureSpec,
    ),
    ReproduceError,
> {
    load_labelled(paths, &labels(n_slip)).map_err(|e| ReproduceError::step(step, e))
}

/// The sweep's rows, as `tmo sweep` writes them.
pub fn read_sweep(path: &Path) -> Result<Vec<SweepRow>, ReproduceError> {
    crate::slip::sweep_file::read_rows(path).map_err(|e| ReproduceError::step("rail_sweep", e))
}

/// The rail sweep's grid and learner settings in `ctx`'s replicate.
pub(crate) fn sweep_spec(ctx: &Context) -> SweepSpec {
    sweep_spec_for(ctx.preset, ctx.replicate)
}

/// The rail sweep's grid and learner settings for `preset` in replicate `replicate`.
pub(crate) fn sweep_spec_for(preset: &Preset, replicate: u32) -> SweepSpec {
    let c = preset.counts();
    SweepSpec {
        classifiers: vec![
            ClassifierKind::SvmRbf,
            ClassifierKind::Logreg,
            ClassifierKind::Threshold,
        ],
        downsample: c.sweep_downsample.clone(),
        n_slip: c.sweep_n_slip.clone(),
        scope: Scope::Global,
        hyper: match c.sweep_search {
            Some((iterations, folds)) => HyperChoice::Search {
                iterations,
                folds,
                ranges: Default::default(),
                max_fit_rows: None,
                held_out: Default::default(),
            },
            None => HyperChoice::Fixed(Hyperparameters {
                c: SWEEP_C,
                gamma: SWEEP_GAMMA,
                max_iterations: None,
            }),
        },
        seed: learner_seed(replicate),
    }
}

/// What the sweep's `sweep.csv.identity` records (the step's directory is fresh whenever
/// its inputs changed, so the preset and the search settings are all it needs to say).
pub(crate) fn sweep_identity(ctx: &Context, spec: &SweepSpec) -> String {
    format!("reproduce {} {:?}\n", ctx.preset.name(), spec.hyper)
}

/// The rail collect's training and test trials, labelled for the sweep's largest n_slip.
pub(crate) fn sweep_data(ctx: &Context, c: &Counts) -> Result<(Dataset, Dataset), ReproduceError> {
    let step = "rail_sweep";
    let collect = ctx.out.join(Step::RailCollect.dir());
    let max_n = c.sweep_n_slip.iter().copied().max().unwrap_or(15);
    let (train, _, _) = load(step, &[collect.join("train")], max_n)?;
    let (test, _, _) = load(step, &[collect.join("test")], max_n)?;
    Ok((train, test))
}

fn rail_sweep(ctx: &Context, c: &Counts, dir: &Path) -> Result<bool, ReproduceError> {
    let step = "rail_sweep";
    let spec = sweep_spec(ctx);
    let out = dir.join("sweep.csv");
    let identity = sweep_identity(ctx, &spec);
    let rows = if let Some(parts) = ctx.sweep_from {
        // Swept elsewhere (`--sweep-only`): joined from the parts, as a single run writes it.
        let (train, test) = sweep_data(ctx, c)?;
        let data = sweep_data_digest(&train, &test);
        let rows = parts.rows_for(ctx, &spec, &data)?;
        crate::slip::sweep_file::write_finished(&out, &identity, &rows)
            .map_err(|e| ReproduceError::step(step, e))?;
        rows
    } else {
        let (train, test) = sweep_data(ctx, c)?;
        // Finished cells are kept in sweep.csv.partial: an interrupted sweep resumes there.
        let target = SweepTarget {
            out: &out,
            resume: true,
            identity,
            stop: Some(ctx.stop),
            part: SweepPart::Whole,
        };
        let result = run_to_file(
            &train,
            &test,
            &spec,
            &target,
            |cells, _| ctx.bar.set_length(cells.len() as u64),
            |_| ctx.bar.inc(1),
        );
        match result {
            Ok(r) => r.rows,
            Err(e) if e.stopped() => return Ok(false),
            Err(e) => return Err(ReproduceError::step(step, e)),
        }
    };
    crate::plots::offline::sweep_heatmaps(&rows, dir, "")
        .map_err(|e| ReproduceError::step(step, e))?;
    Ok(true)
}

fn best<'r>(rows: &'r [SweepRow], classifier: &str) -> Option<&'r SweepRow> {
    rows.iter()
        .filter(|r| r.classifier == classifier && r.macro_f1.is_finite())
        .max_by(|a, b| a.macro_f1.total_cmp(&b.macro_f1))
}

fn rail_model(ctx: &Context, c: &Counts, dir: &Path) -> Result<(), ReproduceError> {
    let step = "rail_model";
    let rows = read_sweep(&ctx.out.join(Step::RailSweep.dir()).join("sweep.csv"))?;
    let train_dir = ctx.out.join(Step::RailCollect.dir()).join("train");
    for (classifier, file) in [
        (ClassifierKind::SvmRbf, "rail.json"),
        (ClassifierKind::Threshold, "threshold.json"),
    ] {
        let cell = best(&rows, classifier.name()).ok_or_else(|| {
            ReproduceError::step(step, format!("the sweep has no {} cell", classifier.name()))
        })?;
        let d: f64 = cell
            .downsample
            .parse()
            .map_err(|e| ReproduceError::step(step, e))?;
        let (ds, refs, features) = load(step, std::slice::from_ref(&train_dir), cell.n_slip)?;
        let (hyper, search) = if classifier == ClassifierKind::SvmRbf {
            ctx.bar.set_length(c.search_iterations as u64);
            let spec = TuneSpec {
                kind: classifier,
                scope: Scope::Global,
                downsample: d,
                seed: ctx.learner_seed(),
                iterations: c.search_iterations,
                folds: c.search_folds,
                ranges: Default::default(),
                max_fit_rows: None,
                held_out: Default::default(),
                assignment: Default::default(),
            };
            let (h, record) =
                tuning::search(&ds, &spec).map_err(|e| ReproduceError::step(step, e))?;
            ctx.bar.inc(c.search_iterations as u64);
            (h, Some(record))
        } else {
            (
                Hyperparameters {
                    c: SWEEP_C,
                    gamma: SWEEP_GAMMA,
                    max_iterations: None,
                },
                None,
            )
        };
        let spec = TrainSpec {
            kind: classifier,
            hyper,
            scope: Scope::Global,
            features,
            labels: labels(cell.n_slip),
            downsample: d,
            seed: ctx.learner_seed(),
        };
        let model = ModelFile::train(&ds, &spec, refs, search)
            .map_err(|e| ReproduceError::step(step, e))?;
        model
            .save(&dir.join(file))
            .map_err(|e| ReproduceError::step(step, e))?;
    }
    Ok(())
}

/// `timing.json`: how long the online model takes to classify one frame.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Timing {
    pub frames: usize,
    pub median_ms: f64,
    pub p99_ms: f64,
}

fn hand_models(ctx: &Context, dir: &Path) -> Result<(), ReproduceError> {
    let step = "hand_models";
    let rail_path = ctx.out.join(Step::RailModel.dir()).join("rail.json");
    let rail = ModelFile::load(&rail_path).map_err(|e| ReproduceError::step(step, e))?;
    let collect = ctx.out.join(Step::HandCollect.dir());
    // The paper trains the hand with the single finger's best cell and hyperparameters.
    let n_slip = rail.labels.n_slip;
    let (train, refs, features) = load(step, &[collect.join("train")], n_slip)?;
    let (test, test_refs, _) = load(step, &[collect.join("test")], n_slip)?;
    ctx.bar.set_length(5 + u64::from(ctx.hand_model.is_some()));
    for (scope, file) in [(Scope::Global, TMO_GLOBAL), (Scope::Local, "local.json")] {
        let spec = TrainSpec {
            kind: ClassifierKind::SvmRbf,
            hyper: rail.hyperparameters,
            scope,
            features,
            labels: labels(n_slip),
            downsample: rail.downsample,
            seed: ctx.learner_seed(),
        };
        let model = ModelFile::train(&train, &spec, refs.clone(), None)
            .map_err(|e| ReproduceError::step(step, e))?;
        model
            .save(&dir.join(file))
            .map_err(|e| ReproduceError::step(step, e))?;
        ctx.bar.inc(1);
    }
    // A user's model stands in for tmo's global one: it is the one evaluated as the
    // global model (with its own labels, as `tmo evaluate` reads them) and timed.
    let (global_eval, timed) = match ctx.hand_model {
        Some(m) => {
            let (user, data) = evaluate_users_model(m, dir, &collect.join("test"))?;
            ctx.bar.inc(1);
            (super::hand_model::TMO_GLOBAL_EVALUATION, (user, Some(data)))
        }
        None => {
            let tmo_global = SlipModel::load(&dir.join(TMO_GLOBAL))
                .map_err(|e| ReproduceError::step(step, e))?;
            ("eval_global.json", (tmo_global, None))
        }
    };
    for (model_path, out) in [
        (dir.join(TMO_GLOBAL), global_eval),
        (dir.join("local.json"), "eval_local.json"),
        (rail_path.clone(), "eval_rail_model.json"),
    ] {
        let model = ModelFile::load(&model_path).map_err(|e| ReproduceError::step(step, e))?;
        let (overall, per_sensor) = model
            .evaluate(&test)
            .map_err(|e| ReproduceError::step(step, e))?;
        write_evaluation(
            &dir.join(out),
            &model_path,
            &model.into(),
            test_refs.len(),
            test.len(),
            overall,
            per_sensor,
        )?;
        ctx.bar.inc(1);
    }
    let timing = time_classification(&timed.0, timed.1.as_ref().unwrap_or(&test))
        .map_err(|e| ReproduceError::step(step, e))?;
    let path = dir.join("timing.json");
    crate::output::atomic::write_atomic(
        &path,
        serde_json::to_string_pretty(&timing)
            .expect("timings serialise")
            .as_bytes(),
    )
    .map_err(io(&path))?;
    Ok(())
}

/// Copies a user's model into the hand models' step `dir` with its record, and scores it
/// on the hand's test trials in `test_dir` as the global model (`eval_global.json`), read
/// with its own labels; returns the model and the rows it was scored on, for timing.
fn evaluate_users_model(
    m: &super::hand_model::HandModel,
    dir: &Path,
    test_dir: &Path,
) -> Result<(SlipModel, Dataset), ReproduceError> {
    let step = "hand_models";
    let path = m
        .copy_into(dir)
        .map_err(|e| ReproduceError::step(step, e))?;
    let record = dir.join(super::hand_model::RECORD);
    crate::output::atomic::write_atomic(
        &record,
        serde_json::to_string_pretty(m)
            .expect("a model record serialises")
            .as_bytes(),
    )
    .map_err(io(&record))?;
    let user = SlipModel::load(&path).map_err(|e| ReproduceError::step(step, e))?;
    let (data, refs, data_features) = load_labelled(&[test_dir.to_path_buf()], user.labels())
        .map_err(|e| ReproduceError::step(step, e))?;
    if let Some((what, theirs, ours)) = user.features().mismatch(&data_features) {
        return Err(ReproduceError::step(
            step,
            format!(
                "{}: cannot read the hand's trials: their {what} is {theirs}, the model's {ours}",
                m.source
            ),
        ));
    }
    user.fits_trials(&data)
        .map_err(|why| ReproduceError::step(step, format!("{}: {why}", m.source)))?;
    let evaluated = user
        .evaluate(&data)
        .map_err(|e| ReproduceError::step(step, e))?;
    write_evaluation(
        &dir.join("eval_global.json"),
        &path,
        &user,
        refs.len(),
        data.len(),
        evaluated.overall,
        evaluated.per_sensor,
    )?;
    Ok((user, data))
}

/// Writes an evaluation of `model` (read from `model_path`) to `path`.
fn write_evaluation(
    path: &Path,
    model_path: &Path,
    model: &SlipModel,
    trials: usize,
    rows: usize,
    overall: crate::slip::metrics::Scores,
    per_sensor: Vec<(u8, crate::slip::metrics::Scores)>,
) -> Result<(), ReproduceError> {
    let e = Evaluation::of(model_path, model, trials, rows, overall, per_sensor)
        .map_err(io(model_path))?;
    crate::output::atomic::write_atomic(
        path,
        serde_json::to_string_pretty(&e)
            .expect("evaluations serialise")
            .as_bytes(),
    )
    .map_err(io(path))
}

/// Times the model's classification of up to 2000 test frames one at a time, as the online
/// detector calls it (a measurement for the findings table, not a benchmark). A windowed
/// model reads each frame's features repeated over its window: its cost does not depend on
/// the values.
fn time_classification(
    model: &SlipModel,
    test: &Dataset,
) -> Result<Timing, crate::slip::model::ModelFileError> {
    let n = test.len().min(2000);
    let mut ms: Vec<f64> = match model {
        SlipModel::Tmo(file) => {
            let mut m = file.models[0].clone();
            m.prepare();
            let mut scratch = Vec::new();
            (0..n)
                .map(|i| {
                    let t = std::time::Instant::now();
                    std::hint::black_box(m.predict(test.row(i), &mut scratch));
                    t.elapsed().as_secs_f64() * 1000.0
                })
                .collect()
        }
        SlipModel::Onnx(m) => {
            let k = m.meta.window;
            let mut input = Vec::with_capacity(m.input_len());
            let mut out = Vec::with_capacity(n);
            for i in 0..n {
                input.clear();
                for _ in 0..k {
                    input.extend_from_slice(test.row(i));
                }
                let t = std::time::Instant::now();
                std::hint::black_box(m.slip_value(&input)?);
                out.push(t.elapsed().as_secs_f64() * 1000.0);
            }
            out
        }
    };
    ms.sort_by(f64::total_cmp);
    let at = |q: f64| ms.get(((q * (n.max(1) - 1) as f64) as usize).min(n.saturating_sub(1)));
    Ok(Timing {
        frames: n,
        median_ms: at(0.5).copied().unwrap_or(f64::NAN),
        p99_ms: at(0.99).copied().unwrap_or(f64::NAN),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_batch_step_writes_a_protocol_that_loads() {
        let dir = tempfile::tempdir().unwrap();
        // the models and calibration tables the protocols name need to exist to load
        let models = dir.path().join("06_hand_models");
        std::fs::create_dir_all(&models).unwrap();
        for f in ["global.json", "local.json"] {
            std::fs::write(models.join(f), "{}").unwrap();
        }
        std::fs::create_dir_all(dir.path().join("03_rail_model")).unwrap();
        std::fs::write(dir.path().join("03_rail_model/rail.json"), "{}").unwrap();
        for sub in ["can", "cat"] {
            let d = dir.path().join("10_calibrate_lift").join(sub);
            std::fs::create_dir_all(&d).unwrap();
            std::fs::write(d.join("g_min.json"), "{}").unwrap();
        }
        for preset in [Preset::Quick, Preset::Paper] {
            for step in Step::ALL {
                let sim = [
                    ("physics.finger_stiffness_n_per_mm".to_string(), 1.2),
                    ("rail.rail_mu".to_string(), 0.1),
                    ("protocol.lift.lift_speed_mm_s".to_string(), 30.0),
                ]
                .into();
                for (sub, text) in step.protocols(&preset.counts(), 2, &sim, TMO_GLOBAL) {
                    // a protocol value goes to the lifts' own section, never to [sim]
                    let lifts = matches!(step, Step::Calibrate | Step::FirstTimeLift);
                    assert_eq!(
                        text.contains("\nlift_speed_mm_s = 30.0\n"),
                        lifts,
                        "{}",
                        step.name()
                    );
                    assert!(!text.contains("protocol."), "{text}");
                    let d = dir.path().join(step.dir()).join(sub);
                    std::fs::create_dir_all(&d).unwrap();
                    let p = d.join("protocol.toml");
                    std::fs::write(&p, &text).unwrap();
                    if let Err(e) = crate::protocol::load(&p, 3) {
                        panic!("{} {sub}: {e}\n{text}", step.name());
                    }
                }
            }
        }
    }

    #[test]
    fn the_first_replicate_keeps_the_base_seeds_and_no_two_replicates_share_one() {
        let seeds = |r: u32| -> Vec<String> {
            Step::ALL
                .iter()
                .flat_map(|s| {
                    s.protocols(&Preset::Paper.counts(), r, &Default::default(), TMO_GLOBAL)
                })
                .map(|(_, text)| {
                    text.lines()
                        .find(|l| l.starts_with("seed = "))
                        .unwrap()
                        .to_string()
                })
                .collect()
        };
        let first = seeds(1);
        assert!(first.contains(&"seed = 11".to_string()), "{first:?}");
        assert!(first.contains(&"seed = 30".to_string()), "{first:?}");
        let mut all: Vec<String> = (1..=5).flat_map(seeds).collect();
        let n = all.len();
        all.sort();
        all.dedup();
        assert_eq!(
            all.len(),
            n,
            "a seed is shared between protocols or replicates"
        );
        assert_eq!(trial_seed(13, 3), 2013);
    }

    #[test]
    fn steps_have_distinct_ordered_directories() {
        let dirs: Vec<String> = Step::ALL.iter().map(|s| s.dir()).collect();
        assert_eq!(dirs[0], "01_rail_collect");
        assert_eq!(dirs[10], "11_first_time_lift");
        let mut sorted = dirs.clone();
        sorted.sort();
        sorted.dedup();
        assert_eq!(sorted, dirs);
        // every dependency comes earlier
        for (k, s) in Step::ALL.iter().enumerate() {
            for d in s.depends_on() {
                assert!(
                    Step::ALL[..k].contains(d),
                    "{} before {}",
                    d.name(),
                    s.name()
                );
            }
        }
    }
}
