//! One convention across `supine`'s subcommands, checked on the clap definition itself
//! (every subcommand, walked through `CommandFactory`), so that a new flag or command that
//! breaks it fails here: one flag name per concept, the same default for the same
//! concept, `--json` wherever results are printed, and a help that ends with an example
//! that parses.

use std::collections::BTreeMap;

use clap::{Command, CommandFactory, Parser};
use supine_host::cli::{Cli, join_list_words};

/// Flag names that mean a concept that has another, canonical name: (wrong, right).
const SYNONYMS: &[(&str, &str)] = &[
    ("recording", "input"),
    ("ride", "input"),
    ("in", "input"),
    ("kind", "weighting"),
    ("greeting-timeout-s", "timeout-s"),
    ("timeout", "timeout-s"),
    ("band-seed", "seed"),
    ("output", "out"),
    ("out-dir", "out"),
    ("sample-rate", "fs"),
    ("fs-hz", "fs"),
    ("duration", "duration-s"),
    ("colour", "color"),
];

/// Subcommands that print no results of their own: `params` prints the parameter file
/// itself (TOML is its format), `completions` a shell script.
const NO_RESULTS: &[&str] = &["params", "completions", "archive remove", "archive export"];

/// Flags whose default may differ by command, and why.
const OWN_DEFAULTS: &[(&str, &str, &str)] = &[
    (
        "synth",
        "fs",
        "a synthetic laboratory dataset is sampled at the laboratory's 200 Hz (the paper's)",
    ),
    (
        "weighting",
        "fmin",
        "a weighting filter is drawn over its whole band, 0.1 Hz to Nyquist, not the model's 0.5-16 Hz",
    ),
    (
        "weighting",
        "fmax",
        "a weighting filter is drawn over its whole band, 0.1 Hz to Nyquist, not the model's 0.5-16 Hz",
    ),
];

fn subcommands() -> Vec<Command> {
    let mut cli = Cli::command();
    cli.build();
    cli.get_subcommands()
        .filter(|c| c.get_name() != "help")
        .cloned()
        .collect()
}

/// Visible long flags of a subcommand (hidden aliases are not listed by clap).
fn longs(cmd: &Command) -> Vec<String> {
    cmd.get_arguments()
        .filter(|a| !a.is_hide_set())
        .filter_map(|a| a.get_long().map(str::to_string))
        .collect()
}

#[test]
fn every_subcommand_uses_the_canonical_flag_names() {
    let mut wrong = Vec::new();
    for cmd in subcommands() {
        for long in longs(&cmd) {
            if let Some((_, right)) = SYNONYMS.iter().find(|(w, _)| *w == long) {
                wrong.push(format!("{} --{long} (say --{right})", cmd.get_name()));
            }
        }
    }
    assert!(wrong.is_empty(), "{wrong:?}");
}

#[test]
fn no_subcommand_has_two_flags_for_one_concept() {
    for cmd in subcommands() {
        let names = longs(&cmd);
        for (w, right) in SYNONYMS {
            assert!(
                !(names.iter().any(|n| n == w) && names.iter().any(|n| n == right)),
                "{}: both --{w} and --{right}",
                cmd.get_name()
            );
        }
        let mut sorted = names.clone();
        sorted.sort();
        sorted.dedup();
        assert_eq!(sorted.len(), names.len(), "{}: {names:?}", cmd.get_name());
    }
}

#[test]
fn the_same_flag_has_the_same_default_everywhere() {
    let mut defaults: BTreeMap<String, BTreeMap<String, Vec<String>>> = BTreeMap::new();
    for cmd in subcommands() {
        for arg in cmd.get_arguments() {
            let (Some(long), false) = (arg.get_long(), arg.get_default_values().is_empty()) else {
                continue;
            };
            if OWN_DEFAULTS
                .iter()
                .any(|(c, f, _)| *c == cmd.get_name() && *f == long)
            {
                continue;
            }
            let value: Vec<String> = arg
                .get_default_values()
                .iter()
                .map(|v| v.to_string_lossy().into_owned())
                .collect();
            defaults
                .entry(long.to_string())
                .or_default()
                .entry(value.join(","))
                .or_default()
                .push(cmd.get_name().to_string());
        }
    }
    let differing: Vec<_> = defaults
        .iter()
        .filter(|(_, by_value)| by_value.len() > 1)
        .collect();
    assert!(differing.is_empty(), "{differing:?}");
    // The concepts the issue named, with the values the README documents.
    assert_eq!(defaults["seed"].keys().collect::<Vec<_>>(), ["1"]);
    assert_eq!(defaults["duration-s"].keys().collect::<Vec<_>>(), ["60"]);
    assert!(defaults["seed"].values().flatten().count() >= 5);
}

#[test]
fn every_command_that_prints_results_has_json() {
    for cmd in subcommands() {
        let name = cmd.get_name();
        if NO_RESULTS.contains(&name) {
            continue;
        }
        // A command of subcommands (archive): each of them that prints results.
        if cmd.has_subcommands() {
            for sub in cmd.get_subcommands().filter(|c| c.get_name() != "help") {
                let full = format!("{name} {}", sub.get_name());
                if !NO_RESULTS.contains(&full.as_str()) {
                    assert!(
                        longs(sub).iter().any(|l| l == "json"),
                        "supine {full} has no --json"
                    );
                }
            }
            continue;
        }
        assert!(
            longs(&cmd).iter().any(|l| l == "json"),
            "supine {name} has no --json"
        );
    }
}

#[test]
fn every_command_that_builds_a_model_takes_preset_and_params() {
    for name in [
        "model", "modes", "params", "predict", "validate", "exposure", "replay", "monitor",
        "flash", "demo",
    ] {
        let cmd = subcommands()
            .into_iter()
            .find(|c| c.get_name() == name)
            .expect(name);
        let l = longs(&cmd);
        assert!(
            l.iter().any(|f| f == "preset") && l.iter().any(|f| f == "params"),
            "supine {name}: {l:?}"
        );
    }
}

#[test]
fn ride_monitor_and_demo_offer_the_same_profiles() {
    let profiles = |name: &str| -> Vec<String> {
        let cmd = subcommands()
            .into_iter()
            .find(|c| c.get_name() == name)
            .expect(name);
        let arg = cmd
            .get_arguments()
            .find(|a| a.get_long() == Some("profile"))
            .expect("--profile");
        arg.get_possible_values()
            .iter()
            .map(|v| v.get_name().to_string())
            .collect()
    };
    let ride = profiles("ride");
    assert!(ride.contains(&"road-trip".to_string()), "{ride:?}");
    assert_eq!(profiles("demo"), ride);
    assert_eq!(profiles("monitor"), ride);
}

/// The words of an example line, up to a shell redirection.
fn example_words(line: &str) -> Vec<String> {
    line.split_whitespace()
        .take_while(|w| !w.starts_with('>'))
        .map(str::to_string)
        .collect()
}

#[test]
fn every_help_ends_with_an_example_that_parses() {
    let mut cli = Cli::command();
    let top = cli.render_help().to_string();
    assert!(top.contains("Start with `supine demo`"), "{top}");
    for mut cmd in subcommands() {
        let name = cmd.get_name().to_string();
        let help = cmd.render_help().to_string();
        let lines: Vec<&str> = help.trim_end().lines().collect();
        let (last, before) = (lines[lines.len() - 1], lines[lines.len() - 2]);
        assert_eq!(before, "Example:", "supine {name}: help ends with\n{help}");
        let words = example_words(last);
        assert_eq!(words[..2], ["supine".to_string(), name.clone()], "{last}");
        if let Err(e) = Cli::try_parse_from(join_list_words(words.iter().map(Into::into))) {
            panic!("supine {name}: the example `{last}` does not parse: {e}");
        }
    }
}

#[test]
fn completions_are_generated_for_bash_zsh_and_fish() {
    for shell in ["bash", "zsh", "fish"] {
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_supine"))
            .args(["completions", shell])
            .output()
            .expect("run supine");
        assert!(out.status.success(), "{shell}");
        let script = String::from_utf8(out.stdout).expect("utf-8");
        // Every subcommand and a flag of each shell's form are in the script.
        for word in ["demo", "monitor", "exposure", "weighting", "timeout-s"] {
            assert!(script.contains(word), "{shell}: no {word}");
        }
    }
}
