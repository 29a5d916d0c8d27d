//! Every `tmo` command the README, CONTRIBUTING.md and docs/ give parses against the
//! command line as it is, so the documentation cannot drift from the CLI (issue 56).
//!
//! A command in a code block must parse whole. A synopsis (`[--seed N]`, `sim|rail`,
//! `K/N`, `...`) and an inline `tmo ...` in prose, which may leave out what the sentence
//! names elsewhere, are held to what they do say: each command name is a command, each
//! option is one of that command's, and each value listed for an option with a fixed set of
//! values is one of them. The README's first commands are also run for real:
//! `tests/cli_reproduce.rs` runs the quick preset end to end.

use clap::error::ErrorKind;
use clap::CommandFactory;
use std::path::{Path, PathBuf};

/// One documented command: where it is, and its words after `tmo`.
struct Documented {
    place: String,
    words: Vec<String>,
    in_block: bool,
}

fn documents(root: &Path) -> Vec<PathBuf> {
    let mut files = vec![root.join("README.md"), root.join("CONTRIBUTING.md")];
    let mut docs: Vec<PathBuf> = std::fs::read_dir(root.join("docs"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "md"))
        .collect();
    docs.sort();
    files.extend(docs);
    files
}

/// The words of a shell line up to its first pipe, redirection, `&&`, `;` or comment,
/// from its `tmo` on; `None` if it does not run `tmo`.
fn tmo_words(line: &str) -> Option<Result<Vec<String>, String>> {
    let line = line.trim().trim_start_matches("$ ");
    if !line.starts_with("tmo ") && line != "tmo" {
        return None;
    }
    let cut = [" |", " >", " 2>", " &&", ";", " #"]
        .iter()
        .filter_map(|s| line.find(s))
        .min()
        .unwrap_or(line.len());
    Some(shlex::split(&line[..cut]).ok_or_else(|| format!("unbalanced quotes in `{line}`")))
}

/// Every command in the code blocks (fenced or indented by four spaces) and inline code
/// spans of `text`.
fn commands_in(text: &str, file: &str) -> Vec<Result<Documented, String>> {
    let mut found = Vec::new();
    let mut fenced = false;
    let lines: Vec<&str> = text.lines().collect();
    let mut i = 0;
    while i < lines.len() {
        let (start, mut line) = (i, lines[i].to_string());
        i += 1;
        let place = format!("{file}:{}", start + 1);
        if line.trim_start().starts_with("```") {
            fenced = !fenced;
            continue;
        }
        let block = fenced || (line.starts_with("    ") && !line.trim_start().starts_with("- "));
        if block {
            // a shell line continued with a backslash
            while line.ends_with('\\') && i < lines.len() {
                line.pop();
                line.push_str(lines[i]);
                i += 1;
            }
            if let Some(words) = tmo_words(&line) {
                found.push(words.map(|words| Documented {
                    place,
                    words,
                    in_block: true,
                }));
            }
            continue;
        }
        for (k, span) in line.split('`').enumerate() {
            if k % 2 == 1 {
                if let Some(words) = tmo_words(span) {
                    found.push(words.map(|words| Documented {
                        place: place.clone(),
                        words,
                        in_block: false,
                    }));
                }
            }
        }
    }
    found
}

/// The command line with its global options and `help` subcommands in place.
fn root_command() -> clap::Command {
    let mut cmd = crate::Cli::command();
    cmd.build();
    cmd
}

/// A usage line rather than a command: optional parts, alternatives, repetition or a
/// placeholder in capitals (`FILE`, `K/N`, `PART_1`).
fn is_synopsis(words: &[String]) -> bool {
    words.iter().skip(1).any(|w| {
        w.contains(['[', ']', '|'])
            || w.contains("...")
            || (w.chars().any(|c| c.is_ascii_uppercase())
                && w.chars()
                    .all(|c| c.is_ascii_uppercase() || c.is_ascii_digit() || "_/.:-,".contains(c)))
    })
}

/// What a synopsis or a mention says exists: its commands, the options it names on the
/// command they follow, and the values it lists for an option with a fixed set of them.
fn names_exist(root: &clap::Command, words: &[String]) -> Result<(), String> {
    let mut cmd = root;
    let mut path = vec!["tmo".to_string()];
    let bare: Vec<String> = words
        .iter()
        .skip(1)
        .map(|w| w.trim_matches(['[', ']']).to_string())
        // `tmo ...`: "any command"
        .filter(|w| !w.is_empty() && !w.contains("..."))
        .collect();
    let mut i = 0;
    while i < bare.len() {
        let word = &bare[i];
        i += 1;
        if let Some(long) = word.strip_prefix("--") {
            let (name, inline) = match long.split_once('=') {
                Some((n, v)) => (n, Some(v.to_string())),
                None => (long, None),
            };
            let arg = cmd
                .get_arguments()
                .find(|a| a.get_long() == Some(name))
                .ok_or_else(|| format!("`{}` has no option --{name}", path.join(" ")))?;
            let values = arg.get_possible_values();
            let value = inline.or_else(|| {
                (arg.get_action().takes_values() && i < bare.len() && !bare[i].starts_with('-'))
                    .then(|| bare[i].clone())
            });
            if let (false, Some(value)) = (values.is_empty(), value) {
                for alternative in value.split(['|', ',']) {
                    if !values.iter().any(|v| v.matches(alternative, false)) {
                        return Err(format!(
                            "--{name} takes no `{alternative}` (it takes {})",
                            values
                                .iter()
                                .map(|v| v.get_name())
                                .collect::<Vec<_>>()
                                .join(", ")
                        ));
                    }
                }
            }
        } else if let Some(sub) = cmd.find_subcommand(word) {
            path.push(word.clone());
            cmd = sub;
        } else if path.len() == 1 {
            return Err(format!("`{word}` is not a tmo command"));
        }
    }
    Ok(())
}

#[test]
fn every_documented_command_parses() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut checked = 0;
    let mut wrong = Vec::new();
    for file in documents(root) {
        let text = std::fs::read_to_string(&file).unwrap();
        let name = file.strip_prefix(root).unwrap().display().to_string();
        for found in commands_in(&text, &name) {
            let doc = match found {
                Ok(doc) => doc,
                Err(e) => {
                    wrong.push(format!("{name}: {e}"));
                    continue;
                }
            };
            checked += 1;
            let said = doc.words.join(" ");
            if !doc.in_block || is_synopsis(&doc.words) {
                if let Err(e) = names_exist(&root_command(), &doc.words) {
                    wrong.push(format!("{}: `{said}`: {e}", doc.place));
                }
                continue;
            }
            let Err(e) = crate::Cli::command().try_get_matches_from(&doc.words) else {
                continue;
            };
            if !matches!(e.kind(), ErrorKind::DisplayHelp | ErrorKind::DisplayVersion) {
                let first = e.to_string().lines().next().unwrap_or_default().to_string();
                wrong.push(format!("{}: `{said}`: {first}", doc.place));
            }
        }
    }
    assert!(checked >= 50, "found only {checked} documented commands");
    assert!(
        wrong.is_empty(),
        "{} of {checked} documented commands do not parse:\n{}",
        wrong.len(),
        wrong.join("\n")
    );
}

#[test]
fn a_command_is_read_up_to_its_pipe_redirection_or_comment() {
    let words = |l: &str| tmo_words(l).unwrap().unwrap().join(" ");
    assert_eq!(
        words("tmo completions bash > out # note"),
        "tmo completions bash"
    );
    assert_eq!(words("$ tmo report 'a b' | head"), "tmo report a b");
    assert!(tmo_words("cargo test").is_none());
    let text = "text `tmo sim parameters` and\n\n    tmo run p.toml\n    tmo report a \\\n        b --plots f\n";
    let found = commands_in(text, "x");
    let found: Vec<_> = found.into_iter().map(Result::unwrap).collect();
    assert_eq!(found.len(), 3);
    assert_eq!(found[2].words.join(" "), "tmo report a b --plots f");
    assert!(!found[0].in_block && found[1].in_block);
    assert_eq!(found[1].place, "x:3");
}

#[test]
fn a_synopsis_is_held_to_the_names_and_values_it_gives() {
    let words = |l: &str| tmo_words(l).unwrap().unwrap();
    let root = root_command();
    let synopsis = words("tmo run PROTOCOL.toml [--backend sim|replay] [--seed N]");
    assert!(is_synopsis(&synopsis));
    names_exist(&root, &synopsis).unwrap();
    assert!(!is_synopsis(&words(
        "tmo run protocols/rail_catch.toml --seed 3"
    )));
    let e = names_exist(&root, &words("tmo run P [--backend sim|moon]")).unwrap_err();
    assert!(e.contains("`moon`"), "{e}");
    let e = names_exist(&root, &words("tmo sim collect [--trails N]")).unwrap_err();
    assert!(
        e.contains("`tmo sim collect` has no option --trails"),
        "{e}"
    );
    let e = names_exist(&root, &words("tmo simulate [--seed N]")).unwrap_err();
    assert!(e.contains("not a tmo command"), "{e}");
}
