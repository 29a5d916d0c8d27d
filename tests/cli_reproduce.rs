//! `tmo reproduce` on the simulator: the quick preset end to end, a reproduction killed
//! mid-way that `--resume` finishes without rerunning its finished steps, and the same
//! reproduction as shards joined by `tmo reproduce merge` (these on the smoke preset: the
//! plumbing, not the findings, is under test, at a third of the quick preset's work).

mod common;

use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use common::*;

#[test]
fn the_quick_preset_writes_every_step_and_the_findings_report() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let run = tmo(d, &["reproduce", "--preset", "quick", "--out", "paper"]);
    let out = ok(&run);
    // standard error is no terminal here: each step says itself as it ends
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(
        err.contains("reproduce: replicate-01/rail_collect: ran ("),
        "{err}"
    );
    assert!(
        out.contains("evidence (pre-registered or never-seen findings): "),
        "{out}"
    );
    assert!(out.contains("  calibrated: rule "), "{out}");
    assert!(out.contains("  pipeline check: rule "), "{out}");
    assert!(out.contains("findings.html"), "{out}");
    assert!(out.contains("ground truth"), "{out}");
    for step in [
        "01_rail_collect",
        "02_rail_sweep",
        "03_rail_model",
        "04_rail_online",
        "05_hand_collect",
        "06_hand_models",
        "07_hand_online",
        "08_hand_objects",
        "09_rice_pour",
        "10_calibrate_lift",
        "11_first_time_lift",
    ] {
        assert!(
            d.join("paper/replicate-01")
                .join(step)
                .join("step.json")
                .is_file(),
            "{step}"
        );
        // the logs of every protocol open in the mcap crate's reader, CRCs checked, and
        // every message fits its channel's schema
        let mut logs: Vec<_> = walk(&d.join("paper/replicate-01").join(step))
            .into_iter()
            .filter(|p| p.extension().is_some_and(|x| x == "mcap"))
            .collect();
        logs.sort();
        for log in logs.iter().take(2) {
            logs::check_log_schemas(log);
        }
    }
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("paper/findings.json")).unwrap())
            .unwrap();
    let findings = json["findings"].as_array().unwrap();
    assert!(findings.len() >= 25);
    assert_eq!(json["replicates"], 1);
    // every finding has one standing: the standings' counts add up to all of them
    let standings = json["standings"].as_array().unwrap();
    let total: u64 = standings
        .iter()
        .map(|t| t["shape"]["total"].as_u64().unwrap())
        .sum();
    assert_eq!(total, findings.len() as u64);
    assert!(standings.iter().any(|t| t["standing"] == "calibrated"));
    assert!(findings.iter().all(|f| f["standing"].is_string()));
    // every finding was measured: each step gave what its rows read. Slip distances are
    // means over caught trials only, and the quick preset's three trials per strategy may
    // catch none with some strategy, so those rows need only be measured somewhere.
    let mut distances_measured = 0;
    for f in findings {
        if f["id"].as_str().unwrap().contains("distance") {
            distances_measured += usize::from(f["reproduced"] != "not_measured");
            continue;
        }
        assert_ne!(f["reproduced"], "not_measured", "{f}");
    }
    assert!(distances_measured > 0, "no slip distance was measured");
    let html = std::fs::read_to_string(d.join("paper/findings.html")).unwrap();
    assert!(
        html.contains("<table>") && html.contains("<svg"),
        "html has tables and figures"
    );
    // the page leads with the evidence: each prediction stated once, linked from its rows,
    // before the central claims (the Markdown in the same order)
    let at = |text: &str, what: &str| {
        text.find(what)
            .unwrap_or_else(|| panic!("no {what:?} in the page"))
    };
    assert!(at(&html, "<h2>Evidence") < at(&html, "<h2>Central claims"));
    let md = std::fs::read_to_string(d.join("paper/findings.md")).unwrap();
    assert!(at(&md, "## Evidence") < at(&md, "## Every finding"));
    if html.contains("<h2>Evidence: none shown yet") {
        // no row is evidence (docs/standings.toml, 2026-12-08): the section lists the
        // unshown rows, each with its verdicts under the switches
        assert!(
            md.contains("- `wh-thumb-best`") && md.contains("null simulator `"),
            "{md}"
        );
    } else {
        assert!(html.contains("counts as evidence all the same"), "{html}");
        let link = "href=\"#prediction-";
        let after = &html[at(&html, link) + link.len()..];
        let n = &after[..after.find('"').unwrap()];
        assert!(html.contains(&format!("id=\"prediction-{n}\"")), "{html}");
        assert!(
            md.contains(&format!("[prediction {n}](#prediction-{n})")),
            "{md}"
        );
    }
    assert!(md.contains("| sf-offline-order |"), "{md}");
    assert!(md.contains("| rule | finding | value | paper |"), "{md}");
    // nothing names where the reproduction was made: a copy of it reads the same (X-b)
    let here = d.to_str().unwrap();
    for page in ["findings.md", "findings.html", "findings.json"] {
        let text = std::fs::read_to_string(d.join("paper").join(page)).unwrap();
        assert!(!text.contains(here), "{page} names {here}");
    }

    // the report again from the finished steps, running nothing (and with no study)
    let again = ok(&tmo(d, &["reproduce", "--out", "paper", "--findings-only"]));
    assert!(again.contains("evidence (pre-registered"), "{again}");
    let rewritten = std::fs::read_to_string(d.join("paper/findings.md")).unwrap();
    assert_eq!(
        rewritten.lines().take(3).collect::<Vec<_>>(),
        md.lines().take(3).collect::<Vec<_>>()
    );
    let none = fails(&tmo(
        d,
        &["reproduce", "--out", "nothing", "--findings-only"],
    ));
    assert!(none.contains("holds no reproduction"), "{none}");

    // everything done: a resume runs nothing; without --resume the directory is refused
    let again = ok(&tmo(d, &["reproduce", "--out", "paper", "--resume"]));
    assert!(again.contains("0 step(s) run, 11 already done"), "{again}");
    let refused = fails(&tmo(d, &["reproduce", "--out", "paper"]));
    assert!(refused.contains("--resume"), "{refused}");

    // a finished step's output replaced since: the resume notices, says so and makes the
    // step again (and, had it come out different, every step that reads it)
    let model = d.join("paper/replicate-01/06_hand_models/global.json");
    let original = std::fs::read(&model).unwrap();
    std::fs::write(&model, original.replace_first(b"\"c\": ", b"\"c\": 1")).unwrap();
    let resumed = tmo(d, &["reproduce", "--out", "paper", "--resume"]);
    let (said, warned) = (ok(&resumed), String::from_utf8_lossy(&resumed.stderr));
    assert!(
        warned.contains("ran again replicate-01/hand_models: its outputs changed"),
        "{warned}"
    );
    assert_eq!(
        std::fs::read(&model).unwrap(),
        original,
        "the model made again"
    );
    let (ran, kept) = counts(&said);
    assert!(ran >= 1 && ran + kept == 11, "{said}");
    // a step record that says another build made it is made again too
    let record = d.join("paper/replicate-01/11_first_time_lift/step.json");
    let text = std::fs::read_to_string(&record).unwrap();
    let mut v: serde_json::Value = serde_json::from_str(&text).unwrap();
    v["git_revision"] = "0000000".into();
    std::fs::write(&record, v.to_string()).unwrap();
    let resumed = tmo(d, &["reproduce", "--out", "paper", "--resume"]);
    assert!(
        String::from_utf8_lossy(&resumed.stderr)
            .contains("ran again replicate-01/first_time_lift: made by tmo"),
        "{}",
        String::from_utf8_lossy(&resumed.stderr)
    );
    assert_eq!(counts(&ok(&resumed)), (1, 10));
}

/// A sensitivity study of one parameter, whose two variants rerun only what it touches,
/// beside its noise reference (other seeds, every step again); on the smoke preset, since
/// the study's bookkeeping, not the findings, is under test.
#[test]
fn a_sensitivity_study_reruns_only_what_its_parameter_touches() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let study = [
        "reproduce",
        "--preset",
        "smoke",
        "--out",
        "paper",
        "--sensitivity",
        "--sensitivity-parameters",
        "rail.rail_mu",
    ];
    ok(&tmo(d, &study));
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("paper/findings.json")).unwrap())
            .unwrap();
    let findings = json["findings"].as_array().unwrap();
    let md = std::fs::read_to_string(d.join("paper/findings.md")).unwrap();
    // the sensitivity study: the rail's friction varied at both ends of its range
    for end in ["low", "high"] {
        let variant = d.join(format!("paper/sensitivity/rail.rail_mu@{end}/replicate-01"));
        let record = |dir: &std::path::Path, step: &str| {
            std::fs::read_to_string(dir.join(step).join("step.json")).unwrap()
        };
        let base = d.join("paper/replicate-01");
        // the hand's collection and the lift's calibration do not involve the rail: taken
        // from the baseline as they were
        for step in ["05_hand_collect", "10_calibrate_lift"] {
            assert_eq!(record(&variant, step), record(&base, step), "{end} {step}");
        }
        // the rail's trials ran again with the parameter in their protocol
        assert_ne!(
            record(&variant, "01_rail_collect"),
            record(&base, "01_rail_collect")
        );
        let protocol =
            std::fs::read_to_string(variant.join("01_rail_collect/train/protocol.toml")).unwrap();
        assert!(
            protocol.contains("[sim]\n\"rail.rail_mu\" = "),
            "{protocol}"
        );
        let hand = std::fs::read_to_string(variant.join("07_hand_online/protocol.toml")).unwrap();
        assert!(!hand.contains("[sim]"), "{hand}");
        // once finished, a variant keeps its outcomes but not its trial logs (but the rail
        // collect's, which the pin speeds are read from), each listed with its digest
        let logs: Vec<_> = walk(&variant)
            .into_iter()
            .filter(|p| p.extension().is_some_and(|x| x == "mcap"))
            .collect();
        assert!(
            logs.iter()
                .all(|p| p.starts_with(variant.join("01_rail_collect"))),
            "{logs:?}"
        );
        assert!(variant.join("07_hand_online/pruned.json").is_file());
        assert!(variant.join("07_hand_online/outcomes.json").is_file());
    }
    // the pruned variants are still finished: the study again runs nothing (a finished
    // baseline is built on without --resume)
    let again = ok(&tmo(d, &study));
    assert!(again.contains("0 step(s) run, 44 already done"), "{again}");
    assert!(
        again.contains("Other seeds alone (the noise reference"),
        "{again}"
    );
    let table = std::fs::read_to_string(d.join("paper/sensitivity.md")).unwrap();
    assert!(
        table.contains("2 variants (1 parameter at each end of its range)"),
        "{table}"
    );
    // beside them the noise reference: the baseline's parameters with other seeds, every
    // step run again
    assert!(table.contains("The noise reference (`reseeded`"), "{table}");
    let reseeded = d.join("paper/sensitivity/reseeded/replicate-01");
    let base = d.join("paper/replicate-01");
    for step in ["01_rail_collect", "05_hand_collect", "10_calibrate_lift"] {
        let protocol = |dir: &std::path::Path| {
            let dir = dir.join(step);
            let file = ["protocol.toml", "train/protocol.toml", "can/protocol.toml"]
                .iter()
                .map(|f| dir.join(f))
                .find(|p| p.is_file())
                .unwrap_or_else(|| panic!("no protocol in {}", dir.display()));
            std::fs::read_to_string(file).unwrap()
        };
        let (here, there) = (protocol(&reseeded), protocol(&base));
        assert_ne!(here, there, "{step}: the same seeds");
        assert!(!here.contains("[sim]"), "{step}: {here}");
    }
    for f in findings {
        assert!(f["sensitive_to"].is_array(), "{f}");
    }
    assert!(md.contains("## Sensitivity"), "{md}");
    // the reference alone judges only how firmly each verdict is decided
    let alone = ok(&tmo(
        d,
        &[
            "reproduce",
            "--preset",
            "smoke",
            "--out",
            "paper",
            "--findings-only",
            "--sensitivity",
            "--sensitivity-parameters",
            "reseeded",
        ],
    ));
    assert!(alone.contains("Other seeds alone"), "{alone}");
    let table = std::fs::read_to_string(d.join("paper/sensitivity.md")).unwrap();
    assert!(
        table.contains("Only the noise reference was run"),
        "{table}"
    );
    assert!(!table.contains("Robust ("), "{table}");
}

/// Byte strings with their first `from` replaced.
trait ReplaceFirst {
    fn replace_first(&self, from: &[u8], to: &[u8]) -> Vec<u8>;
}

impl ReplaceFirst for Vec<u8> {
    fn replace_first(&self, from: &[u8], to: &[u8]) -> Vec<u8> {
        let at = self
            .windows(from.len())
            .position(|w| w == from)
            .expect("the text to replace is there");
        [&self[..at], to, &self[at + from.len()..]].concat()
    }
}

/// `from` copied to `to`, file by file.
fn copy_tree(from: &std::path::Path, to: &std::path::Path) {
    for f in walk(from) {
        let target = to.join(f.strip_prefix(from).unwrap());
        std::fs::create_dir_all(target.parent().unwrap()).unwrap();
        std::fs::copy(&f, &target).unwrap();
    }
}

/// Every file under `dir`.
fn walk(dir: &std::path::Path) -> Vec<std::path::PathBuf> {
    let mut out = Vec::new();
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            out.extend(walk(&p));
        } else {
            out.push(p);
        }
    }
    out
}

/// A reproduction killed in its first step, resumed with a second replicate: the finished
/// step is kept, the rest run, and the findings pool both replicates.
#[test]
fn a_reproduction_killed_mid_way_resumes_without_rerunning_finished_steps() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mut child = Command::new(env!("CARGO_BIN_EXE_tmo"))
        .current_dir(d)
        .args(["reproduce", "--preset", "smoke", "--out", "r"])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    // kill -9 once the first step is done and the second has started
    let first = d.join("r/replicate-01/01_rail_collect/step.json");
    let started = Instant::now();
    while !(first.exists() && d.join("r/replicate-01/02_rail_sweep").exists()) {
        assert!(
            started.elapsed() < Duration::from_secs(120),
            "the first step never finished"
        );
        std::thread::sleep(Duration::from_millis(5));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    let record = std::fs::read_to_string(&first).unwrap();
    let modified = std::fs::metadata(&first).unwrap().modified().unwrap();
    let trials = std::fs::read_dir(d.join("r/replicate-01/01_rail_collect/train"))
        .unwrap()
        .count();

    let out = ok(&tmo(
        d,
        &[
            "reproduce",
            "--preset",
            "smoke",
            "--out",
            "r",
            "--resume",
            "--replicates",
            "2",
        ],
    ));
    assert!(out.contains("(2 replicates)"), "{out}");
    assert!(
        out.contains("1 already done") || out.contains("already done"),
        "{out}"
    );
    let (ran, kept) = counts(&out);
    assert_eq!(ran + kept, 22, "{out}");
    assert!(kept >= 1, "{out}");
    // the finished step was kept as it was
    assert_eq!(std::fs::read_to_string(&first).unwrap(), record);
    assert_eq!(
        std::fs::metadata(&first).unwrap().modified().unwrap(),
        modified
    );
    assert_eq!(
        std::fs::read_dir(d.join("r/replicate-01/01_rail_collect/train"))
            .unwrap()
            .count(),
        trials
    );
    for r in ["replicate-01", "replicate-02"] {
        assert!(d
            .join("r")
            .join(r)
            .join("11_first_time_lift/step.json")
            .is_file());
    }
    // the second replicate ran its own trials
    let outcomes = |r: &str| {
        std::fs::read_to_string(d.join("r").join(r).join("04_rail_online/outcomes.json")).unwrap()
    };
    assert_ne!(outcomes("replicate-01"), outcomes("replicate-02"));
    // every row counts the replicates it held in, and the trial rates pool both
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("r/findings.json")).unwrap()).unwrap();
    assert_eq!(json["replicates"], 2);
    let caught = json["findings"]
        .as_array()
        .unwrap()
        .iter()
        .find(|f| f["id"] == "sf-rail-caught")
        .unwrap();
    assert_eq!(caught["held_in"][1], 2, "{caught}");
    assert_eq!(
        caught["ours"]["rail.online.caught.1fr"]["n"], 12,
        "{caught}"
    );

    // T4-3: the page is never written from replicates or steps the run does not have: one
    // asked for beyond those there, a step unfinished, a replicate that is another's copy
    let e = fails(&tmo(
        d,
        &[
            "reproduce",
            "--preset",
            "smoke",
            "--out",
            "r",
            "--findings-only",
            "--replicates",
            "3",
        ],
    ));
    assert!(e.contains("replicate-03: no such replicate"), "{e}");
    // a page asked of this smoke run with the paper preset names the preset that fits
    let e = fails(&tmo(
        d,
        &[
            "reproduce",
            "--out",
            "r",
            "--findings-only",
            "--replicates",
            "2",
            "--preset",
            "paper",
        ],
    ));
    assert!(
        e.contains("holds a reproduction with the smoke preset") && e.contains("--preset smoke"),
        "{e}"
    );
    let page_of_two = |out: &str| {
        fails(&tmo(
            d,
            &[
                "reproduce",
                "--preset",
                "smoke",
                "--out",
                out,
                "--findings-only",
                "--replicates",
                "2",
            ],
        ))
    };
    copy_tree(&d.join("r"), &d.join("c"));
    std::fs::remove_dir_all(d.join("c/replicate-02")).unwrap();
    copy_tree(&d.join("r/replicate-01"), &d.join("c/replicate-02"));
    let e = page_of_two("c");
    assert!(e.contains("a copy of replicate 1"), "{e}");
    std::fs::remove_file(d.join("c/replicate-02/07_hand_online/step.json")).unwrap();
    let e = page_of_two("c");
    assert!(e.contains("07_hand_online: not finished"), "{e}");
    // T4-13: the default count on a 2-replicate run says what it leaves out (on a copy:
    // the page it writes is of one replicate)
    copy_tree(&d.join("r"), &d.join("one"));
    let page = tmo(
        d,
        &[
            "reproduce",
            "--preset",
            "smoke",
            "--out",
            "one",
            "--findings-only",
        ],
    );
    let said = String::from_utf8_lossy(&page.stderr);
    assert!(said.contains("also holds replicate(s) 2"), "{said}");

    // the two replicates ran side by side (one job per core); run one a process as two
    // shards (side by side, as a cluster's jobs) and merged, they give the same trials,
    // sweep, models and findings
    let shards = tmo_side_by_side(d, 2, |k| {
        owned(&[
            "reproduce",
            "--preset",
            "smoke",
            "--out",
            &format!("part{k}"),
            "--replicates",
            "2",
            "--jobs",
            "1",
            "--shard",
            &format!("{k}/2"),
        ])
    });
    for (k, run) in shards.iter().enumerate() {
        let out = ok(run);
        assert!(out.contains(&format!("shard {}/2", k + 1)), "{out}");
    }
    // parts missing or altered are refused, and nothing is written
    let e = fails(&tmo(d, &["reproduce", "merge", "part1", "--out", "seq"]));
    assert!(e.contains("2/2 not given"), "{e}");
    let e = fails(&tmo(
        d,
        &["reproduce", "merge", "part1", "part1", "--out", "seq"],
    ));
    assert!(e.contains("are both shard 1/2"), "{e}");
    let touched = d.join("part2/replicate-02/09_rice_pour/outcomes.json");
    let original = std::fs::read(&touched).unwrap();
    let mut altered = original.clone();
    altered[10] ^= 1;
    std::fs::write(&touched, &altered).unwrap();
    let e = fails(&tmo(
        d,
        &["reproduce", "merge", "part1", "part2", "--out", "seq"],
    ));
    assert!(e.contains("09_rice_pour") && e.contains("changed"), "{e}");
    assert!(!d.join("seq").exists());
    std::fs::write(&touched, &original).unwrap();
    // T4-6: a shard whose replicate is a copy of another's, or whose plan names another
    // preset, is refused before anything is written
    copy_tree(&d.join("part2"), &d.join("swapped"));
    std::fs::remove_dir_all(d.join("swapped/replicate-02")).unwrap();
    copy_tree(
        &d.join("part1/replicate-01"),
        &d.join("swapped/replicate-02"),
    );
    let e = fails(&tmo(
        d,
        &["reproduce", "merge", "part1", "swapped", "--out", "seq"],
    ));
    assert!(e.contains("a copy of replicate 1"), "{e}");
    std::fs::remove_dir_all(d.join("swapped")).unwrap();
    copy_tree(&d.join("part1"), &d.join("relabelled"));
    copy_tree(&d.join("part2"), &d.join("relabelled2"));
    for part in ["relabelled", "relabelled2"] {
        let path = d.join(part).join("shard.json");
        let text = std::fs::read_to_string(&path).unwrap();
        assert!(text.contains("\"preset\": \"smoke\""), "{text}");
        std::fs::write(
            &path,
            text.replace("\"preset\": \"smoke\"", "\"preset\": \"paper\""),
        )
        .unwrap();
    }
    let e = fails(&tmo(
        d,
        &[
            "reproduce",
            "merge",
            "relabelled",
            "relabelled2",
            "--out",
            "seq",
        ],
    ));
    assert!(e.contains("made for other inputs"), "{e}");
    assert!(!d.join("seq").exists());
    let out = ok(&tmo(
        d,
        &["reproduce", "merge", "part2", "part1", "--out", "seq"],
    ));
    assert!(out.contains("merged 2 shards (2 jobs"), "{out}");
    assert!(out.contains("evidence (pre-registered"), "{out}");
    same_results(d, "r", "seq");

    // T4-1: merges into one --out at once (a requeued cluster job): one succeeds, the
    // others are refused, and no input shard loses a byte; an --out inside an input is
    // refused before anything is written.
    let shard_bytes = || -> Vec<(std::path::PathBuf, Vec<u8>)> {
        ["part1", "part2"]
            .iter()
            .flat_map(|p| walk(&d.join(p)))
            .map(|f| {
                let bytes = std::fs::read(&f).unwrap();
                (f, bytes)
            })
            .collect()
    };
    let before = shard_bytes();
    let merges: Vec<_> = (0..4)
        .map(|_| {
            Command::new(env!("CARGO_BIN_EXE_tmo"))
                .current_dir(d)
                .args(["reproduce", "merge", "part1", "part2", "--out", "twice"])
                .stdout(Stdio::null())
                .stderr(Stdio::piped())
                .spawn()
                .unwrap()
        })
        .collect();
    let ends: Vec<_> = merges
        .into_iter()
        .map(|m| m.wait_with_output().unwrap())
        .collect();
    let succeeded = ends.iter().filter(|o| o.status.success()).count();
    assert_eq!(succeeded, 1, "{ends:?}");
    for e in ends.iter().filter(|o| !o.status.success()) {
        assert_eq!(e.status.code(), Some(2), "{e:?}");
    }
    assert!(before == shard_bytes(), "an input shard changed");
    same_results(d, "r", "twice");
    let e = fails(&tmo(
        d,
        &["reproduce", "merge", "part1", "part2", "--out", "twice"],
    ));
    assert!(e.contains("already holds a reproduction"), "{e}");
    let e = fails(&tmo(
        d,
        &[
            "reproduce",
            "merge",
            "part1",
            "part2",
            "--out",
            "part1/replicate-01/sub",
        ],
    ));
    assert!(e.contains("lies inside the input"), "{e}");
    assert!(!d.join("part1/replicate-01/sub").exists());
    assert!(before == shard_bytes(), "an input shard changed");

    // In two stages: the two replicates' sweeps dealt over three parts, then the other
    // steps in two shards that join the parts' rows; the same sweeps and findings.
    let parts = tmo_side_by_side(d, 3, |k| {
        owned(&[
            "reproduce",
            "--preset",
            "smoke",
            "--out",
            &format!("sweep{k}"),
            "--replicates",
            "2",
            "--sweep-only",
            "--shard",
            &format!("{k}/3"),
        ])
    });
    for (k, run) in parts.iter().enumerate() {
        let out = ok(run);
        assert!(out.contains(&format!("sweep part {}/3", k + 1)), "{out}");
    }
    let stage_two_args = |k: u32, parts: &[&str]| {
        let mut args = vec![
            "reproduce".to_string(),
            "--preset".into(),
            "smoke".into(),
            "--out".into(),
            format!("steps{k}"),
            "--replicates".into(),
            "2".into(),
            "--shard".into(),
            format!("{k}/2"),
            "--sweep-from".into(),
        ];
        args.extend(parts.iter().map(|p| p.to_string()));
        args
    };
    let stage_two = |k: u32, parts: &[&str]| {
        let args = stage_two_args(k, parts);
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        tmo(d, &args)
    };
    // a part missing, or altered after it finished, is refused
    let e = fails(&stage_two(1, &["sweep1", "sweep3"]));
    assert!(e.contains("2/3 not given"), "{e}");
    let part = ["replicate-01", "replicate-02"]
        .map(|r| {
            d.join("sweep2")
                .join(r)
                .join("02_rail_sweep.part/sweep.csv")
        })
        .into_iter()
        .find(|p| p.is_file())
        .expect("part 2 swept for some replicate");
    let original = std::fs::read(&part).unwrap();
    std::fs::write(&part, [original.as_slice(), b"\n"].concat()).unwrap();
    let e = fails(&stage_two(1, &["sweep1", "sweep2", "sweep3"]));
    assert!(e.contains("changed after the part finished"), "{e}");
    std::fs::write(&part, &original).unwrap();
    assert!(!d.join("steps1").exists(), "refused before anything ran");
    for run in tmo_side_by_side(d, 2, |k| stage_two_args(k, &["sweep3", "sweep1", "sweep2"])) {
        ok(&run);
    }
    let e = fails(&tmo(
        d,
        &["reproduce", "merge", "sweep1", "sweep2", "--out", "nope"],
    ));
    assert!(e.contains("--sweep-from"), "{e}");
    ok(&tmo(
        d,
        &["reproduce", "merge", "steps1", "steps2", "--out", "two"],
    ));
    same_results(d, "r", "two");

    // A study sharded: the baseline in one shard, the noise reference in the other; the
    // merge judges the reference against the baseline as a single run does.
    let study = tmo_side_by_side(d, 2, |k| {
        owned(&[
            "reproduce",
            "--preset",
            "smoke",
            "--out",
            &format!("study{k}"),
            "--shard",
            &format!("{k}/2"),
            "--sensitivity",
            "--sensitivity-parameters",
            "reseeded",
        ])
    });
    for run in study {
        ok(&run);
    }
    let out = ok(&tmo(
        d,
        &["reproduce", "merge", "study1", "study2", "--out", "study"],
    ));
    assert!(out.contains("merged 2 shards (2 jobs"), "{out}");
    assert!(out.contains("Other seeds alone"), "{out}");
    let table = std::fs::read_to_string(d.join("study/sensitivity.md")).unwrap();
    assert!(
        table.contains("Only the noise reference was run"),
        "{table}"
    );
}

/// The trials, sweeps, models and findings of reproductions `a` and `b` (under `d`) are
/// the same, but for what records when and how fast it ran.
fn same_results(d: &std::path::Path, a: &str, b: &str) {
    for r in ["replicate-01", "replicate-02"] {
        for file in [
            "04_rail_online/outcomes.json",
            "07_hand_online/outcomes.json",
            "08_hand_objects/all/outcomes.json",
            "11_first_time_lift/can/outcomes.json",
        ] {
            let read = |out: &str| std::fs::read_to_string(d.join(out).join(r).join(file)).unwrap();
            assert_eq!(read(a), read(b), "{r}/{file}");
        }
        // the fitted models (their files also name the training logs, which record when
        // they were made)
        let model = |out: &str| -> serde_json::Value {
            let text =
                std::fs::read_to_string(d.join(out).join(r).join("06_hand_models/global.json"))
                    .unwrap();
            let v: serde_json::Value = serde_json::from_str(&text).unwrap();
            serde_json::json!([v["models"], v["hyperparameters"], v["labels"]])
        };
        assert_eq!(model(a), model(b), "{r} model");
        // the sweep's rows but their timing column
        let rows = |out: &str| -> Vec<String> {
            std::fs::read_to_string(d.join(out).join(r).join("02_rail_sweep/sweep.csv"))
                .unwrap()
                .lines()
                .map(|l| l.rsplit_once(',').unwrap().0.to_string())
                .collect()
        };
        assert_eq!(rows(a), rows(b), "{r} sweep");
    }
    // the findings but the time to classify a frame, which is measured anew each run
    let findings = |out: &str| -> serde_json::Value {
        let text = std::fs::read_to_string(d.join(out).join("findings.json")).unwrap();
        let mut v: serde_json::Value = serde_json::from_str(&text).unwrap();
        v["findings"]
            .as_array_mut()
            .unwrap()
            .retain(|f| f["id"] != "sf-classify-time");
        v["measures"]
            .as_object_mut()
            .unwrap()
            .retain(|k, _| !k.contains("classify"));
        // the counts include that row's verdict, which a busy machine can flip
        for count in ["all", "values", "evidence", "standings", "headline"] {
            v.as_object_mut().unwrap().remove(count);
        }
        v
    };
    assert_eq!(findings(a), findings(b));
}

/// "N step(s) run, M already done" from reproduce's output.
fn counts(out: &str) -> (usize, usize) {
    let line = out.lines().find(|l| l.contains("step(s) run")).unwrap();
    let words: Vec<&str> = line.split_whitespace().collect();
    let at = |w: &str| {
        let k = words.iter().position(|x| x.starts_with(w)).unwrap();
        words[k - 1].trim_end_matches(',').parse().unwrap()
    };
    (at("step(s)"), at("already"))
}
