//! How much tmo says beyond its results, set once from the global `-q`, `-v` and `--color`.
//!
//! Results (tables, JSON, the paths of what was written when a command's point is to write
//! it) go to standard output whatever the level. Progress bars and notes go to standard
//! error; `-q` silences them, `-v` adds a line per finished item (trial, cell, evaluation).
//! Warnings and errors are always said.

use std::fmt::Display;
use std::io::Write;
use std::sync::atomic::{AtomicI8, Ordering};

/// Writes a result to standard output, with an error rather than `println!`'s panic when it
/// fails (a full disk, `> /dev/full`): tmo then says so and exits 2. A closed pipe still
/// ends tmo quietly, as `main` restores SIGPIPE. Used through `outln!`.
pub fn write_out(text: std::fmt::Arguments<'_>) -> anyhow::Result<()> {
    let mut out = std::io::stdout().lock();
    out.write_fmt(text)
        .and_then(|()| out.flush())
        .map_err(|e| anyhow::anyhow!("cannot write to standard output: {e}"))
}

/// Below 0: quiet; 0: normal; above 0: verbose.
static LEVEL: AtomicI8 = AtomicI8::new(0);

/// Sets the level from the flags: `-q` wins over any `-v`.
pub fn set_level(quiet: bool, verbose: u8) {
    let level = if quiet {
        -1
    } else {
        i8::try_from(verbose).unwrap_or(i8::MAX)
    };
    LEVEL.store(level, Ordering::Relaxed);
}

pub fn quiet() -> bool {
    LEVEL.load(Ordering::Relaxed) < 0
}

pub fn verbose() -> bool {
    LEVEL.load(Ordering::Relaxed) > 0
}

/// A note to the user on standard error (where outputs went, what was assumed), unless
/// quiet.
pub fn note(text: impl Display) {
    if !quiet() {
        eprintln!("{text}");
    }
}

/// A line per finished item, on standard error above `bar`, when verbose. (indicatif's own
/// `println` says nothing when the bar is hidden, e.g. when standard error is not a
/// terminal, which is where a verbose log is most often wanted.)
pub fn detail(bar: &indicatif::ProgressBar, text: impl Display) {
    if verbose() {
        bar.suspend(|| eprintln!("{text}"));
    }
}

/// A progress bar with `template` (indicatif's syntax), drawn on standard error unless
/// quiet.
pub fn progress_bar(template: &str) -> indicatif::ProgressBar {
    let bar = if quiet() {
        indicatif::ProgressBar::hidden()
    } else {
        indicatif::ProgressBar::new(0)
    };
    bar.set_style(
        indicatif::ProgressStyle::with_template(template)
            .expect("valid template")
            .progress_chars("=> "),
    );
    bar
}

/// A bar in the style every batch shows: `verb [=====>  ] 12/40 unit, 3s (eta 7s) msg`.
pub fn counting_bar(verb: &str, unit: &str) -> indicatif::ProgressBar {
    progress_bar(&format!(
        "{verb} [{{bar:30}}] {{pos}}/{{len}} {unit}, {{elapsed}} (eta {{eta}}) {{msg}}"
    ))
}

/// When to colour what tmo writes to a terminal (clap's help and errors).
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum ColorWhen {
    /// When writing to a terminal and `NO_COLOR` is not set.
    Auto,
    Always,
    Never,
}

impl ColorWhen {
    /// The choice on a command line, read before clap parses it, so that clap's own help
    /// and errors already follow it. The last `--color` wins, as clap would have it.
    pub fn from_args<I: IntoIterator<Item = std::ffi::OsString>>(args: I) -> ColorWhen {
        let mut choice = ColorWhen::Auto;
        let mut args = args.into_iter().map(|a| a.to_string_lossy().into_owned());
        while let Some(arg) = args.next() {
            if arg == "--" {
                break;
            }
            let value = match arg.strip_prefix("--color") {
                Some("") => args.next(),
                Some(rest) => rest.strip_prefix('=').map(str::to_string),
                None => None,
            };
            choice = match value.as_deref() {
                Some("always") => ColorWhen::Always,
                Some("never") => ColorWhen::Never,
                Some("auto") => ColorWhen::Auto,
                _ => choice,
            };
        }
        choice
    }

    pub fn clap(self) -> clap::ColorChoice {
        match self {
            ColorWhen::Auto => clap::ColorChoice::Auto,
            ColorWhen::Always => clap::ColorChoice::Always,
            ColorWhen::Never => clap::ColorChoice::Never,
        }
    }
}

/// Whether `path` is `-`: standard output, where a command writes one file.
/// A CSV writer onto a file that appears at `path` whole or not at all.
pub fn atomic_csv(
    path: &std::path::Path,
) -> anyhow::Result<csv::Writer<tmo::output::atomic::AtomicFile>> {
    use anyhow::Context;
    let file = tmo::output::atomic::AtomicFile::create(path)
        .with_context(|| format!("cannot write {}", path.display()))?;
    Ok(csv::Writer::from_writer(file))
}

/// Flushes `w` and puts its file in place at `path`.
pub fn commit_csv(
    w: csv::Writer<tmo::output::atomic::AtomicFile>,
    path: &std::path::Path,
) -> anyhow::Result<()> {
    use anyhow::Context;
    w.into_inner()
        .map_err(|e| anyhow::anyhow!("cannot write {}: {}", path.display(), e.error()))?
        .commit()
        .with_context(|| format!("cannot write {}", path.display()))
}

pub fn is_stdout(path: &std::path::Path) -> bool {
    path.as_os_str() == "-"
}

const EMPTY: &str =
    "an empty path (an unset variable?) would write into the current directory; give a path";

const NOT_STDOUT: &str = "`-` (standard output) cannot hold what this command writes (a directory or several files); give a path. `tmo dataset export` and `tmo evaluate` take `--out -`";

// The value parsers below are the one check of every `--out`: an output is never empty,
// and it is refused before any work if writing it would replace something that is not an
// output (tmo::output::target). The writers check again when they write.

/// `s` as an output path that `check` accepts: never empty, never `-`.
fn checked(
    s: &str,
    check: fn(&std::path::Path) -> Result<(), tmo::output::target::TargetError>,
) -> Result<std::path::PathBuf, String> {
    match s {
        "" => Err(EMPTY.into()),
        "-" => Err(NOT_STDOUT.into()),
        _ => {
            check(s.as_ref()).map_err(|e| e.to_string())?;
            Ok(s.into())
        }
    }
}

/// An `--out` that is a directory of outputs.
pub fn a_dir(s: &str) -> Result<std::path::PathBuf, String> {
    checked(s, tmo::output::target::check_dir)
}

/// An `--out` that is one file (with, perhaps, files named after it beside it).
pub fn a_file(s: &str) -> Result<std::path::PathBuf, String> {
    checked(s, tmo::output::target::check_file)
}

/// An `--out` that is a file or `-` (standard output).
pub fn a_file_or_stdout(s: &str) -> Result<std::path::PathBuf, String> {
    match s {
        "" => Err(EMPTY.into()),
        "-" => Ok(s.into()),
        _ => a_file(s),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn color(args: &[&str]) -> ColorWhen {
        ColorWhen::from_args(args.iter().map(std::ffi::OsString::from))
    }

    #[test]
    fn the_color_choice_is_read_in_either_spelling_and_the_last_wins() {
        assert_eq!(color(&["tmo", "run", "p.toml"]), ColorWhen::Auto);
        assert_eq!(color(&["tmo", "--color", "never", "run"]), ColorWhen::Never);
        assert_eq!(color(&["tmo", "run", "--color=always"]), ColorWhen::Always);
        assert_eq!(
            color(&["tmo", "--color=never", "run", "--color", "always"]),
            ColorWhen::Always
        );
        // a value clap will refuse leaves the choice as it was; after `--` nothing is an option
        assert_eq!(color(&["tmo", "--color", "sometimes"]), ColorWhen::Auto);
        assert_eq!(color(&["tmo", "--", "--color=never"]), ColorWhen::Auto);
    }

    #[test]
    fn an_empty_output_path_is_refused_and_dash_only_where_standard_output_can_take_it() {
        for parse in [a_dir, a_file, a_file_or_stdout] {
            assert!(parse("").unwrap_err().contains("unset variable"));
        }
        assert!(a_dir("-").is_err() && a_file("-").is_err());
        assert_eq!(a_dir("r").unwrap(), std::path::PathBuf::from("r"));
        assert_eq!(
            a_file_or_stdout("-").unwrap(),
            std::path::PathBuf::from("-")
        );
        // only looked at: a device is neither a file nor a directory of outputs
        assert!(a_file("/dev/null")
            .unwrap_err()
            .contains("character device"));
        assert!(a_file_or_stdout("/dev/full").is_err());
        assert!(a_dir("/dev/null").unwrap_err().contains("not a directory"));
    }

    #[test]
    fn quiet_wins_over_verbose() {
        set_level(true, 2);
        assert!(quiet() && !verbose());
        set_level(false, 1);
        assert!(!quiet() && verbose());
        set_level(false, 0);
        assert!(!quiet() && !verbose());
    }
}
