//! `docs/commands.md` is the command reference: every command `tmo --help` lists (and every
//! subcommand of those) has an entry there, so the reference cannot fall behind the CLI.

mod common;

use common::{ok, tmo};

/// The command names under "Commands:" in a clap help text, `help` left out.
fn commands_in(help: &str) -> Vec<String> {
    help.lines()
        .skip_while(|l| !l.starts_with("Commands:"))
        .skip(1)
        .take_while(|l| l.starts_with("  "))
        .filter_map(|l| l.split_whitespace().next())
        .filter(|name| *name != "help")
        .map(str::to_string)
        .collect()
}

#[test]
fn every_command_has_an_entry_in_the_command_reference() {
    let dir = tempfile::tempdir().unwrap();
    let reference = std::fs::read_to_string(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/commands.md"),
    )
    .unwrap();
    let top = commands_in(&ok(&tmo(dir.path(), &["--help"])));
    assert!(top.len() >= 10, "read {top:?} from tmo --help");
    let mut missing = Vec::new();
    for command in &top {
        let help = ok(&tmo(dir.path(), &[command, "--help"]));
        // `tmo sweep` runs on its own and has `merge`; `tmo sim` is only its subcommands
        let runs_alone = !help.contains(&format!("Usage: tmo {command} [OPTIONS] <COMMAND>"));
        let mut paths: Vec<String> = runs_alone.then(|| command.clone()).into_iter().collect();
        paths.extend(commands_in(&help).iter().map(|s| format!("{command} {s}")));
        for path in paths {
            if !reference.contains(&format!("`tmo {path}")) {
                missing.push(path);
            }
        }
    }
    assert!(
        missing.is_empty(),
        "docs/commands.md has no entry for: {}",
        missing.join(", ")
    );
}

#[test]
fn the_help_lists_the_exit_codes() {
    let dir = tempfile::tempdir().unwrap();
    let help = ok(&tmo(dir.path(), &["--help"]));
    for code in ["0 ", "2 ", "3 ", "130 "] {
        assert!(help.contains(code), "no exit code {code}in:\n{help}");
    }
    assert!(help.contains("Exit codes"), "{help}");
}

/// The README's screenshot shows the headline the README quotes: the screenshot script
/// writes the headline it rendered beside the PNG (`scripts/screenshot-findings.sh`), and
/// the README's quoted result holds it word for word; it is at most 150 lines.
#[test]
fn the_readme_screenshot_shows_the_headline_the_readme_quotes() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let readme = std::fs::read_to_string(root.join("README.md")).unwrap();
    let shown = std::fs::read_to_string(root.join("docs/img/findings.headline.txt")).unwrap();
    let shown = shown.trim_end();
    assert!(shown.starts_with("evidence ("), "{shown}");
    assert!(
        readme.lines().any(|l| l.trim() == shown),
        "README.md does not quote the screenshot's headline (run scripts/screenshot-findings.sh on the run it quotes):\n{shown}"
    );
    assert!(readme.contains("](docs/img/findings.png)"));
    let lines = readme.lines().count();
    assert!(lines <= 150, "README.md is {lines} lines (at most 150)");
}
