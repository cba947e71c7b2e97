//! The `pathmix` command line. The engine knows no terminal: progress display,
//! messages and exit codes live here.

mod cli;

use clap::Parser;
use std::process::ExitCode;

fn main() -> ExitCode {
    let args = cli::Cli::parse();
    match cli::run(args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(failure) => {
            eprintln!("pathmix: error: {}", failure.message);
            ExitCode::from(failure.code)
        }
    }
}
