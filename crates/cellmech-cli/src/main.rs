//! `cellmech`: run virtual mechanical tests on single cells. A thin layer over the library.

mod args;
mod commands;
mod progress;

use clap::Parser;

fn main() -> std::process::ExitCode {
    let args = args::Cli::parse();
    match commands::dispatch(args) {
        Ok(code) => code,
        Err(err) => {
            eprintln!("error: {err:#}");
            std::process::ExitCode::from(2)
        }
    }
}
