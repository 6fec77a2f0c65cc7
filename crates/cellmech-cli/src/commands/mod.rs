//! Subcommands.

mod bench;
mod build;
mod check;
mod example;
mod fit;
mod params;
mod run;
mod study;

use std::process::ExitCode;

use crate::args::{Cli, Command};

/// Runs the chosen subcommand. `Err` is a usage or input error (exit code 2).
pub fn dispatch(cli: Cli) -> anyhow::Result<ExitCode> {
    match cli.command {
        Command::Run(args) => run::run(&args),
        Command::Check(args) => check::check(&args),
        Command::Build(args) => build::build(&args),
        Command::Example(args) => example::example(&args),
        Command::Bench(args) => bench::bench(&args),
        Command::Params(args) => params::params(&args),
        Command::Study(args) => study::study(&args),
        Command::Fit(args) => fit::fit(&args),
    }
}
