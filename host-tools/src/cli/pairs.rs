//! Options given as `(name, value)` pairs (a script's keyword arguments)
//! read through a subcommand's own clap definition: one source for the
//! defaults, the value checks and their one-line messages.

use anyhow::{anyhow, Result};
use clap::{Args, FromArgMatches};

/// `A` from `pairs`, each as `--name value` (underscores in a name stand
/// for dashes; a value `"true"` alone sets a flag); every other option
/// keeps its default. `subcommand` prefixes the error message.
pub fn args_from_pairs<A: Args + FromArgMatches>(
    subcommand: &'static str,
    pairs: &[(String, String)],
) -> Result<A> {
    let cmd = A::augment_args(clap::Command::new(subcommand).no_binary_name(true))
        .disable_help_flag(true);
    let mut argv = Vec::new();
    for (k, v) in pairs {
        let flag = format!("--{}", k.replace('_', "-"));
        let is_flag = cmd
            .get_arguments()
            .find(|a| a.get_long() == Some(&flag[2..]))
            .is_some_and(|a| !a.get_action().takes_values());
        match (is_flag, v.as_str()) {
            (true, "true") => argv.push(flag),
            (true, "false") => {}
            _ => argv.extend([flag, v.clone()]),
        }
    }
    let matches = cmd.try_get_matches_from(argv).map_err(|e| {
        let text = e.to_string();
        let line = text.lines().next().unwrap_or("");
        anyhow!("{subcommand}: {}", line.trim_start_matches("error: "))
    })?;
    Ok(A::from_arg_matches(&matches)?)
}
