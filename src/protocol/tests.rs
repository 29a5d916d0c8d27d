use super::*;

fn check(text: &str) -> Result<Plan, ProtocolError> {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("m.json"), "{}").unwrap();
    let path = dir.path().join("p.toml");
    std::fs::write(&path, text).unwrap();
    load(&path, 3)
}

const MINIMAL: &str = "kind = \"hand_release\"\nmodels = [\"m.json\"]\n";

#[test]
fn a_minimal_file_takes_the_papers_values() {
    let plan = check(MINIMAL).unwrap();
    assert_eq!(plan.kind, Kind::HandRelease);
    assert_eq!(plan.objects.len(), 5);
    assert_eq!(plan.strategies.len(), 6);
    let KindParams::HandRelease(p) = &plan.params else {
        panic!("{plan:?}")
    };
    assert_eq!((p.release_speed_of_max, p.regrasp), (0.005, 0.02));
    assert_eq!(plan.outcome.onset_threshold_mm, 1.0);
    assert_eq!(plan.trial_count(), 5 * 6);
}

#[test]
fn unknown_fields_are_named_with_their_line() {
    let e = check("kind = \"hand_release\"\nmodels = [\"m.json\"]\n\n[hand_release]\nregrasp = 0.02\nrelease_sped = 0.1\n").unwrap_err();
    assert_eq!(e.line, 6, "{e}");
    assert!(e.message.contains("release_sped"), "{e}");
    assert!(e.to_string().contains("p.toml:6:"), "{e}");
}

#[test]
fn wrong_types_say_what_was_expected() {
    let e = check("kind = \"hand_release\"\nrepetitions = \"ten\"\n").unwrap_err();
    assert_eq!(e.line, 2, "{e}");
    assert_eq!(e.field, "repetitions", "{e}");
    assert!(e.message.contains("expected u32"), "{e}");
    let e = check(&format!("{MINIMAL}[outcome]\ndrop_limit_mm = \"far\"\n")).unwrap_err();
    assert_eq!(e.field, "outcome.drop_limit_mm", "{e}");
    let e = check("kind = \"juggling\"\n").unwrap_err();
    assert!(e.message.contains("hand_release"), "{e}");
}

#[test]
fn out_of_range_values_point_at_the_field() {
    let e = check(&format!("{MINIMAL}[hand_release]\nregrasp = 0.9\n")).unwrap_err();
    assert_eq!(e.field, "hand_release.regrasp");
    assert_eq!((e.line, e.column), (4, 11), "{e}");
    assert!(e.message.contains("0..=0.2"), "{e}");
    let e = check(&format!("{MINIMAL}repetitions = 0\n")).unwrap_err();
    assert_eq!(e.field, "repetitions");
    let e = check(&format!("{MINIMAL}[outcome]\ndrop_limit_mm = 0.5\n")).unwrap_err();
    assert_eq!(e.field, "outcome.drop_limit_mm", "{e}");
}

#[test]
fn a_missing_model_file_is_named() {
    let e = check("kind = \"rice_pour\"\nmodels = [\"m.json\", \"gone.json\"]\n").unwrap_err();
    assert_eq!(e.field, "models.1");
    assert_eq!((e.line, e.column), (2, 21), "{e}");
    assert!(e.message.contains("gone.json"), "{e}");
    let e = check("kind = \"rice_pour\"\n").unwrap_err();
    assert!(e.message.contains("models"), "{e}");
}

#[test]
fn impossible_grids_are_refused() {
    let e =
        check("kind = \"hand_release\"\nmodels = [\"m.json\"]\nstrategies = [\"1x2\", \"1x4\"]\n")
            .unwrap_err();
    assert_eq!(e.field, "strategies.1");
    assert!(e.message.contains("3"), "{e}");
    let e = check("kind = \"rail_catch\"\nmodels = [\"m.json\"]\nstrategies = [\"1x2\"]\n")
        .unwrap_err();
    assert_eq!(e.field, "strategies.0", "{e}");
    let e = check(&format!("{MINIMAL}objects = [\"anvil\"]\n")).unwrap_err();
    assert_eq!(e.field, "objects.0");
    let e = check(&format!("{MINIMAL}grasps_deg = []\n")).unwrap_err();
    assert_eq!(e.field, "grasps_deg");
    let e = check(&format!("{MINIMAL}[rice_pour]\ntotal_g = 100\n")).unwrap_err();
    assert_eq!(e.field, "rice_pour", "{e}");
    let e = check(&format!("{MINIMAL}[hand_release]\nlift_mm = 30\n")).unwrap_err();
    assert_eq!(e.field, "hand_release.lift_mm", "{e}");
    let e = check("kind = \"first_time_lift\"\nmode = \"collect\"\n").unwrap_err();
    assert_eq!(e.field, "mode", "{e}");
}

#[test]
fn collect_mode_needs_no_model() {
    let plan = check("kind = \"rail_catch\"\nmode = \"collect\"\nrepetitions = 4\n").unwrap();
    assert!(plan.models.is_empty() && plan.strategies.is_empty());
    assert_eq!(plan.trial_count(), 4);
}

/// Every example in `protocols/` is valid once the models and tables it names exist.
#[test]
fn the_example_protocols_are_valid() {
    let examples = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("protocols");
    let mut seen = 0;
    for entry in std::fs::read_dir(&examples).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_none_or(|e| e != "toml") {
            continue;
        }
        let dir = tempfile::tempdir().unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        let file = ProtocolFile::parse(&path, &text).unwrap();
        std::fs::create_dir_all(dir.path().join("protocols")).unwrap();
        let tables = file
            .first_time_lift
            .iter()
            .filter_map(|p| p.calibration.clone());
        for m in file.models.iter().cloned().chain(tables) {
            let model = dir.path().join("protocols").join(m);
            std::fs::create_dir_all(model.parent().unwrap()).unwrap();
            std::fs::write(model, "{}").unwrap();
        }
        let copy = dir.path().join("protocols").join(path.file_name().unwrap());
        std::fs::write(&copy, &text).unwrap();
        let plan = load(&copy, 3).unwrap_or_else(|e| panic!("{e}"));
        assert!(plan.trial_count() >= 1, "{}", path.display());
        seen += 1;
    }
    assert_eq!(seen, 7);
}

#[test]
fn first_time_lift_grids_over_masses_and_names_a_missing_calibration_table() {
    let lift = "kind = \"first_time_lift\"\nmodels = [\"m.json\"]\nrepetitions = 2\n";
    let plan = check(lift).unwrap();
    assert_eq!(plan.masses_g().len(), 7);
    assert_eq!(plan.trial_count(), 7 * 2, "crisps can x 7 masses x 1x1 x 2");
    let e = check(&format!(
        "{lift}\n[first_time_lift]\ncalibration = \"g_min.json\"\n"
    ))
    .unwrap_err();
    assert_eq!(e.field, "first_time_lift.calibration", "{e}");
    assert_eq!(e.line, 6, "{e}");
    assert!(e.message.contains("calibrate_lift"), "{e}");
}

#[test]
fn safety_limits_come_from_the_protocol_and_bound_what_it_asks() {
    let plan = check(&format!("{MINIMAL}[safety]\nmax_grip = 0.8\n")).unwrap();
    assert_eq!(plan.safety.max_grip, 0.8);
    assert_eq!(
        plan.safety.max_arm_speed_mm_s, 100.0,
        "the rest keep their defaults"
    );
    let e = check(&format!("{MINIMAL}[safety]\nmax_grip = 1.5\n")).unwrap_err();
    assert_eq!(e.field, "safety.max_grip", "{e}");
    let e = check(&format!("{MINIMAL}[safety]\nmax_grp = 0.5\n")).unwrap_err();
    assert!(e.message.contains("max_grp"), "{e}");
    // a lift higher than the workspace allows would be refused mid-trial: refuse it now
    let e = check(&format!(
        "{MINIMAL}[hand_release]\nlift_mm = 200\n[safety]\nworkspace_mm = [50, 50, 150]\n"
    ))
    .unwrap_err();
    assert_eq!(e.field, "hand_release.lift_mm", "{e}");
    assert!(e.message.contains("safety.workspace_mm"), "{e}");
    let rail = "kind = \"rail_catch\"\nmodels = [\"m.json\"]\nstrategies = [\"1x1\"]\n";
    let e = check(&format!(
        "{rail}[rail_catch]\ninitial_torque = 0.9\n[safety]\nmax_torque = 0.7\n"
    ))
    .unwrap_err();
    assert_eq!(e.field, "rail_catch.initial_torque", "{e}");
}

#[test]
fn long_names_are_not_repeated_whole() {
    assert_eq!(
        super::shorten_quoted("unknown field `abc`"),
        "unknown field `abc`"
    );
    let long = "k".repeat(100_000);
    let m = super::shorten_quoted(&format!("unknown field `{long}`, expected `kind`"));
    assert!(m.len() < 120, "{m}");
    assert!(
        m.contains("(100000 characters)") && m.ends_with("expected `kind`"),
        "{m}"
    );
}

#[test]
fn a_kind_that_is_not_a_string_lists_the_kinds_and_a_nul_byte_is_named() {
    let e = ProtocolFile::parse(std::path::Path::new("p.toml"), "kind = true\n").unwrap_err();
    assert!(
        e.to_string().contains("\"rail_catch\", \"hand_release\""),
        "{e}"
    );
    let e = ProtocolFile::parse(
        std::path::Path::new("p.toml"),
        "# a \0 b\nkind = \"rail_catch\"\n",
    )
    .unwrap_err();
    assert!(e.to_string().contains("U+0000"), "{e}");
}

#[test]
fn a_file_that_cannot_be_read_is_named_without_a_made_up_line() {
    let e = load(Path::new("/nonexistent/p.toml"), 3).unwrap_err();
    assert_eq!(e.line, 0);
    let text = e.to_string();
    assert!(
        text.starts_with("/nonexistent/p.toml: cannot read: "),
        "{text}"
    );
    assert!(!text.contains(":1:1") && !text.contains("(file)"), "{text}");
}

#[test]
fn simulator_parameters_are_set_by_name_and_checked() {
    let plan = check(&format!(
        "{MINIMAL}\n[sim]\n\"rail.rail_mu\" = 0.1\n\n[sim.physics]\nfinger_stiffness_n_per_mm = 1.2\nsurface_wavelength_mm = [0.5, 10]\n"
    ))
    .unwrap();
    assert_eq!(plan.sim["rail.rail_mu"], 0.1);
    assert_eq!(plan.sim["physics.finger_stiffness_n_per_mm"], 1.2);
    assert_eq!(plan.sim["physics.surface_wavelength_mm[1]"], 10.0);
    assert!(check(MINIMAL).unwrap().sim.is_empty());
    let e = check(&format!("{MINIMAL}\n[sim.physics]\nstiffness = 1.2\n")).unwrap_err();
    assert_eq!(e.field, "sim.physics.stiffness", "{e}");
    assert!(e.message.contains("tmo sim parameters"), "{e}");
    let e = check(&format!("{MINIMAL}\n[sim.physics]\ngravity_m_s2 = -1\n")).unwrap_err();
    assert!(e.message.contains("gravity_m_s2"), "{e}");
    let e = check(&format!(
        "{MINIMAL}\n[sim.physics]\nfinger_travel_mm = \"long\"\n"
    ))
    .unwrap_err();
    assert_eq!(e.field, "sim.physics.finger_travel_mm", "{e}");
}

/// Issue 41, P-a and P-c: an empty list is not the default, and a repeated entry would run
/// (and count) its cells twice.
#[test]
fn empty_and_repeated_lists_are_refused() {
    let e = check(&format!("{MINIMAL}objects = []\n")).unwrap_err();
    assert_eq!(e.field, "objects", "{e}");
    assert!(e.message.contains("leave the field out"), "{e}");
    let e = check(&format!("{MINIMAL}strategies = []\n")).unwrap_err();
    assert_eq!(e.field, "strategies", "{e}");
    let e = check(&format!(
        "{MINIMAL}objects = [\"banana\", \"softball\", \"banana\"]\n"
    ))
    .unwrap_err();
    assert_eq!(e.field, "objects.2", "{e}");
    assert!(e.message.contains("objects.0"), "{e}");
    let e = check(&format!("{MINIMAL}strategies = [\"2x2\", \"2Fr2Sen\"]\n")).unwrap_err();
    assert_eq!(e.field, "strategies.1", "{e}");
    let e = check("kind = \"hand_release\"\nmodels = [\"m.json\", \"m.json\"]\n").unwrap_err();
    assert_eq!(e.field, "models.1", "{e}");
    let e = check(&format!("{MINIMAL}grasps_deg = [0, 180, 0]\n")).unwrap_err();
    assert_eq!(e.field, "grasps_deg.2", "{e}");
    // P-b: a strategy waiting for more frames than any trial has
    let e = check(&format!("{MINIMAL}strategies = [\"4294967295x1\"]\n")).unwrap_err();
    assert_eq!(e.field, "strategies.0", "{e}");
}
