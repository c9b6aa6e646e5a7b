//! `plotd completions bash|zsh|fish|elvish|powershell` and `plotd man`: shell
//! completions and the man page, generated from the clap definitions
//! (`clap_complete`, `clap_mangen`; `cli.rs` passes its `clap::Command`), so
//! they never disagree with the commands they describe. Packaging writes them to files (README,
//! "Under systemd").

use crate::console::{print_bytes, StdoutError};
use std::io::Write;

/// Prints the completion script of `cmd` (the `plotd` command line) for `shell`.
///
/// # Errors
/// [`StdoutError`].
pub fn completions(cmd: clap::Command, shell: clap_complete::Shell) -> Result<(), StdoutError> {
    print_bytes(&completion_script(cmd, shell))
}

/// The completion script of `cmd` for `shell`.
#[must_use]
pub fn completion_script(mut cmd: clap::Command, shell: clap_complete::Shell) -> Vec<u8> {
    let mut script = Vec::new();
    clap_complete::generate(shell, &mut cmd, "plotd", &mut script);
    script
}

/// Prints the man page of `cmd` (the `plotd` command line).
///
/// # Errors
/// [`StdoutError`].
pub fn man_page(cmd: &clap::Command) -> Result<(), StdoutError> {
    print_bytes(&man_page_roff(cmd))
}

/// The man page `plotd(1)` in roff: the synopsis and options of `plotd`,
/// then a section per subcommand with its usage and arguments.
#[must_use]
pub fn man_page_roff(cmd: &clap::Command) -> Vec<u8> {
    let mut page = Vec::new();
    // Writing into a Vec cannot fail.
    let _ = render_man(cmd, &mut page);
    page
}

fn render_man(cmd: &clap::Command, page: &mut Vec<u8>) -> std::io::Result<()> {
    let man = clap_mangen::Man::new(cmd.clone());
    man.render_title(page)?;
    man.render_name_section(page)?;
    man.render_synopsis_section(page)?;
    man.render_description_section(page)?;
    man.render_options_section(page)?;
    page.extend_from_slice(b".SH COMMANDS\n");
    for sub in cmd.get_subcommands().filter(|s| !s.is_hide_set()) {
        let name = format!("plotd {}", sub.get_name());
        let about = sub.get_about().map(ToString::to_string).unwrap_or_default();
        writeln!(page, ".SS \"{}\"\n{}\n.PP", escape(&name), escape(&about))?;
        let usage = sub.clone().bin_name(&name).render_usage().to_string();
        writeln!(page, ".B {}", escape(usage.trim_start_matches("Usage: ")))?;
        for arg in sub.get_arguments().filter(|a| !a.is_hide_set() && a.get_id() != "help") {
            let flag = match (arg.get_long(), arg.get_short()) {
                (Some(l), Some(s)) => format!("-{s}, --{l}"),
                (Some(l), None) => format!("--{l}"),
                (None, Some(s)) => format!("-{s}"),
                (None, None) => arg
                    .get_value_names()
                    .and_then(|v| v.first())
                    .map_or_else(|| arg.get_id().to_string().to_uppercase(), ToString::to_string),
            };
            let help = arg.get_long_help().or_else(|| arg.get_help()).map(ToString::to_string).unwrap_or_default();
            writeln!(page, ".TP\n\\fB{}\\fR\n{}", escape(&flag), escape(&help))?;
        }
    }
    man.render_version_section(page)
}

/// Text made safe for a roff line: a leading `.` or `'` would be read as a
/// request, and `\` starts an escape.
fn escape(text: &str) -> String {
    let text = text.replace('\\', "\\e");
    text.lines().map(|l| if l.starts_with(['.', '\'']) { format!("\\&{l}") } else { l.to_owned() }).collect::<Vec<_>>().join("\n")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn roff_requests_and_escapes_are_quoted() {
        assert_eq!(escape(".hidden\n'also\nplain \\ text"), "\\&.hidden\n\\&'also\nplain \\e text");
    }
}
