//! The book's reference pages, generated: the command line from the clap
//! definitions of the `skin` program, the configuration from the defaults
//! and key list of [`config`](crate::config). A test compares them with the
//! committed pages, so the book cannot drift from the program.

use std::fmt::Write;

use crate::config::{keys, Config};

/// How to write the pages again, said on every page and by the test.
pub const REGENERATE: &str = "SKIN_BLESS=1 cargo test -p skin-host --test docs_reference";

fn header(title: &str, source: &str) -> String {
    format!("# {title}\n\n<!-- Generated from {source}; do not edit. Regenerate with `{REGENERATE}`. -->\n\n")
}

/// The command-line reference of `cmd` and its subcommands, as Markdown:
/// one section per command with its usage, description, arguments and
/// options. Hidden commands and options, `--help` and `--version` are left
/// out.
pub fn cli_markdown(cmd: &clap::Command) -> String {
    let mut cmd = cmd.clone();
    cmd.build();
    let mut out = header("Command-line reference", "the clap definitions in `host/src/cli/`");
    let _ = writeln!(
        out,
        "Every subcommand of `{}` in the default build (the `sim` feature on). `{} <command> --help` \
         prints the same text.\n",
        cmd.get_name(),
        cmd.get_name()
    );
    for sub in documented(&cmd) {
        let _ = writeln!(out, "- [`{}`](#{})", full_name(sub), anchor(&full_name(sub)));
    }
    out.push('\n');
    command_section(&mut out, &cmd);
    out
}

fn full_name(cmd: &clap::Command) -> String {
    cmd.get_bin_name().unwrap_or(cmd.get_name()).to_owned()
}

/// The id mdBook gives a heading made of plain words.
fn anchor(heading: &str) -> String {
    heading.to_lowercase().replace(' ', "-")
}

fn command_section(out: &mut String, cmd: &clap::Command) {
    let is_root = cmd.get_bin_name().is_none_or(|b| !b.contains(' '));
    if !is_root {
        let _ = writeln!(out, "## {}\n", full_name(cmd));
        if let Some(about) = cmd.get_long_about().or(cmd.get_about()) {
            let _ = writeln!(out, "{}\n", sentence(&about.to_string()));
        }
        let usage = cmd.clone().render_usage().to_string();
        let usage = usage.trim_start_matches("Usage:").trim();
        let _ = writeln!(out, "```text\n{usage}\n```\n");
        let args: Vec<_> = cmd.get_arguments().filter(|a| !a.is_hide_set() && !is_builtin(a)).collect();
        let (positional, options): (Vec<_>, Vec<_>) = args.into_iter().partition(|a| a.is_positional());
        for (title, list) in [("Arguments", positional), ("Options", options)] {
            if list.is_empty() {
                continue;
            }
            let _ = writeln!(out, "{title}:\n");
            for arg in list {
                let _ = writeln!(out, "{}", argument(arg));
            }
            out.push('\n');
        }
    }
    for sub in documented(cmd) {
        command_section(out, sub);
    }
}

/// The subcommands a user reads about: not hidden, not clap's own `help`.
fn documented(cmd: &clap::Command) -> impl Iterator<Item = &clap::Command> {
    cmd.get_subcommands().filter(|s| !s.is_hide_set() && s.get_name() != "help")
}

/// A sentence from help text, which clap writes without its last period.
fn sentence(text: &str) -> String {
    let text = escape(text.trim_end());
    if text.ends_with(['.', '!', '?']) {
        text
    } else {
        format!("{text}.")
    }
}

fn is_builtin(arg: &clap::Arg) -> bool {
    matches!(arg.get_id().as_str(), "help" | "version")
}

/// One argument as a list item: its spelling, help, default and values.
fn argument(arg: &clap::Arg) -> String {
    let names: Vec<String> =
        arg.get_value_names().map(|v| v.iter().map(|n| format!("<{n}>")).collect()).unwrap_or_default();
    let takes_value = arg.get_num_args().is_some_and(|n| n.takes_values());
    let value = if takes_value && !names.is_empty() {
        names.join(" ")
    } else if takes_value {
        format!("<{}>", arg.get_id().as_str().to_uppercase())
    } else {
        String::new()
    };
    let spelling = if arg.is_positional() {
        value
    } else {
        let flag = match (arg.get_short(), arg.get_long()) {
            (Some(s), Some(l)) => format!("-{s}, --{l}"),
            (Some(s), None) => format!("-{s}"),
            (None, Some(l)) => format!("--{l}"),
            (None, None) => arg.get_id().to_string(),
        };
        if value.is_empty() {
            flag
        } else {
            format!("{flag} {value}")
        }
    };
    let mut item = format!("- `{spelling}`");
    if arg.is_required_set() {
        item.push_str(" (required)");
    }
    let mut parts = Vec::new();
    if let Some(help) = arg.get_long_help().or(arg.get_help()) {
        // Later paragraphs indented into the list item, blank lines kept blank.
        let text = sentence(&help.to_string());
        let lines: Vec<String> = text
            .lines()
            .enumerate()
            .map(|(i, l)| if i == 0 || l.is_empty() { l.to_owned() } else { format!("  {l}") })
            .collect();
        parts.push(lines.join("\n"));
    }
    let values: Vec<String> = arg
        .get_possible_values()
        .iter()
        .filter(|v| !v.is_hide_set())
        .map(|v| match v.get_help() {
            Some(help) => format!("`{}` ({})", v.get_name(), escape(&help.to_string())),
            None => format!("`{}`", v.get_name()),
        })
        .collect();
    if !values.is_empty() {
        parts.push(format!("Values: {}.", values.join(", ")));
    }
    // A flag's implicit `false` is no default worth stating.
    if takes_value && !arg.get_default_values().is_empty() {
        let defaults: Vec<String> =
            arg.get_default_values().iter().map(|v| format!("`{}`", v.to_string_lossy())).collect();
        parts.push(format!("Default: {}.", defaults.join(" ")));
    }
    if !parts.is_empty() {
        let _ = write!(item, ": {}", parts.join(" "));
    }
    item
}

/// Help text made safe for Markdown: angle brackets outside code spans
/// would be read as HTML tags and vanish.
fn escape(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    let mut in_code = false;
    for c in text.chars() {
        match c {
            '`' => {
                in_code = !in_code;
                out.push(c);
            }
            '<' if !in_code => out.push_str("&lt;"),
            '>' if !in_code => out.push_str("&gt;"),
            _ => out.push(c),
        }
    }
    out
}

/// The configuration reference: the default file as `skin config --default`
/// writes it, then every key with its unit, accepted values and meaning.
pub fn config_markdown() -> String {
    let mut out = header("Configuration reference", "`host/src/config.rs` and `host/src/config/keys.rs`");
    out.push_str(
        "`skin run --config FILE` reads a TOML file; every key is optional, an unknown key is an error, and a \
         value out of range is refused with the key's name. `skin config --default` writes the defaults below, \
         `skin config --check FILE` checks a file.\n\n## Keys\n\n\
         | key | unit | accepted values | meaning |\n|---|---|---|---|\n",
    );
    for k in keys() {
        let _ = writeln!(out, "| `{}` | {} | {} | {} |", k.key, k.unit, escape(&k.range), k.meaning);
    }
    let _ = write!(out, "\n## The defaults\n\n```toml\n{}```\n", Config::default().to_toml());
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn help_text_keeps_its_angle_brackets_visible() {
        assert_eq!(escape("a <FILE> `b <c>`"), "a &lt;FILE&gt; `b <c>`");
    }

    #[test]
    fn every_subcommand_option_and_value_is_rendered() {
        let cmd = clap::Command::new("tool").subcommand(
            clap::Command::new("go")
                .about("Go somewhere.")
                .arg(clap::Arg::new("target").required(true).help("Where to."))
                .arg(clap::Arg::new("speed").long("speed").short('s').value_name("M_S").default_value("1.5"))
                .arg(clap::Arg::new("mode").long("mode").value_parser(["walk", "run"]))
                .arg(clap::Arg::new("secret").long("secret").hide(true)),
        );
        let text = cli_markdown(&cmd);
        assert!(text.contains("- [`tool go`](#tool-go)"), "{text}");
        assert!(text.contains("## tool go\n\nGo somewhere.\n"), "{text}");
        assert!(text.contains("- `<TARGET>` (required): Where to."), "{text}");
        assert!(!text.contains("tool help"), "{text}");
        assert!(text.contains("- `-s, --speed <M_S>`: Default: `1.5`."), "{text}");
        assert!(text.contains("- `--mode <MODE>`: Values: `walk`, `run`."), "{text}");
        assert!(!text.contains("secret") && !text.contains("`-h, --help`"), "{text}");
    }

    #[test]
    fn the_configuration_page_lists_every_key_and_the_defaults() {
        let text = config_markdown();
        for k in keys() {
            assert!(text.contains(&format!("| `{}` |", k.key)), "{}", k.key);
        }
        assert!(text.contains(&Config::default().to_toml()));
    }
}
