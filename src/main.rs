//! `tdeploy`: the command-line front end: parse, check the options, run,
//! and exit with the code `cli::finish` gives (0 done, 1 goal not
//! reached, 2 bad input or I/O error).

mod cli;

fn main() -> std::process::ExitCode {
    let matches = cli::command().get_matches();
    cli::finish(cli::Options::from_matches(&matches).and_then(|options| cli::run(&options)))
}
