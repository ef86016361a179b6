//! `shadespace view` in a build without the cargo feature `viewer`: the
//! command is there, and says how to build the viewer in.

use clap::Args;

use super::output::shell_quote;
use super::{Failure, input};

/// `view` in a build without the viewer: whatever follows is kept only to
/// repeat it in the command that runs the viewer.
#[derive(Args)]
pub struct ViewArgs {
    /// The viewer's options (see `view --help` in a build with the viewer).
    #[arg(trailing_var_arg = true, allow_hyphen_values = true, value_name = "OPTIONS")]
    options: Vec<String>,
}

/// Why `view` cannot run here, and the cargo commands that build the viewer
/// in (the second one runs it with the same options).
pub fn message(options: &[String]) -> String {
    let mut run = "cargo run --release --features viewer -- view".to_string();
    for word in options {
        run.push(' ');
        run.push_str(&shell_quote(word));
    }
    format!(
        "this shadespace was built without the interactive viewer (cargo feature `viewer`, off by default \
         so that the renderer builds without a window toolkit). Build it in with\n  \
         cargo build --release --features viewer\nor build and run it in one step:\n  {run}"
    )
}

/// Fails with [`message`] (exit status 2).
pub fn run(a: ViewArgs) -> Result<(), Failure> {
    input(Err(anyhow::Error::msg(message(&a.options))))
}

#[cfg(test)]
mod tests {
    use clap::{FromArgMatches, Subcommand};

    use super::*;

    #[derive(clap::Parser)]
    struct Cli {
        #[command(subcommand)]
        command: Command,
    }

    #[derive(Subcommand)]
    enum Command {
        View(ViewArgs),
    }

    /// Any options, flags included, reach the message, and the run fails as
    /// bad input (exit 2) with the cargo command that builds the viewer.
    #[test]
    fn view_without_the_viewer_says_how_to_build_it() {
        let words = ["shadespace", "view", "--scene", "my scene.glb", "--pipeline", "objectspace", "--hide-ui"];
        let matches = <Cli as clap::CommandFactory>::command().try_get_matches_from(words).unwrap();
        let Command::View(a) = Cli::from_arg_matches(&matches).unwrap().command;
        let Err(failure) = run(a) else { panic!("view ran without the viewer") };
        assert_eq!(failure.exit_status(), 2);
        let text = failure.into_error().to_string();
        assert!(text.contains("\n  cargo build --release --features viewer\n"), "{text}");
        assert!(
            text.ends_with(
                "\n  cargo run --release --features viewer -- view --scene 'my scene.glb' --pipeline objectspace --hide-ui"
            ),
            "{text}"
        );
    }
}
