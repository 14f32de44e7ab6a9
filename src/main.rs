//! The `strahl` command: parses the arguments, runs the subcommand, and reports any failure
//! as one line `error: …`, with exit status 1 (2 for a malformed command line).

mod cli;

use std::process::ExitCode;

use clap::Parser;
use clap::error::ErrorKind;

fn main() -> ExitCode {
    // A panic is a bug in strahl; say so in one line instead of a backtrace hint.
    std::panic::set_hook(Box::new(|info| {
        let message = info.to_string().replace('\n', " ");
        // `strahl info … | head`: the reader closed standard output and nobody is left to tell
        // anything, so end quietly, with the status of a Unix tool that SIGPIPE ended (128 + 13).
        if message.contains("failed printing to stdout") && message.contains("Broken pipe") {
            std::process::exit(141);
        }
        eprintln!("error: internal error (a bug in strahl, please report it): {message}");
    }));
    let args = match cli::Cli::try_parse() {
        Ok(args) => args,
        // --version names the Embree library and ISA strahl traces with, so that a report says
        // which one a user has.
        Err(e) if e.kind() == ErrorKind::DisplayVersion => {
            println!("{}", cli::version_report());
            return ExitCode::SUCCESS;
        }
        // --help, and the help shown for a bare `strahl`.
        Err(e) if !e.use_stderr() || e.kind() == ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand => e.exit(),
        Err(e) => {
            // clap's message, without its usage block, on one line; status 2 for usage errors.
            let rendered = e.render().to_string();
            let message = rendered.split("\n\n").next().unwrap_or_default();
            let words: Vec<&str> = message.split_whitespace().collect();
            eprintln!("{} (see `strahl --help`)", words.join(" "));
            return ExitCode::from(2);
        }
    };
    match cli::run(args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {}", format!("{e:#}").replace('\n', "; "));
            ExitCode::FAILURE
        }
    }
}
