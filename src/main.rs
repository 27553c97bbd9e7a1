//! `tdeploy`: the command-line front end. All work happens in `cli::run`.

mod cli;

fn main() {
    let matches = cli::command().get_matches();
    if let Err(e) = cli::run(&matches) {
        eprintln!("error: {e:#}");
        std::process::exit(1);
    }
}
