//! `cellmech`: run virtual mechanical tests on single cells. A thin layer over the library.

/// `println!` that ends the program quietly (exit code 0) when stdout is a closed pipe
/// (`cellmech build | head -1`), as ripgrep and cargo do, instead of panicking; other write
/// errors are ignored (`println!` would panic on any).
macro_rules! out {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let written = writeln!(std::io::stdout().lock(), $($arg)*);
        $crate::quiet_on_broken_pipe(written);
    }};
}

/// `print!` with [`out!`]'s handling of a closed pipe.
macro_rules! out_text {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let written = write!(std::io::stdout().lock(), $($arg)*);
        $crate::quiet_on_broken_pipe(written);
    }};
}

/// Exits with code 0 when a write to stdout failed because its reader has gone.
fn quiet_on_broken_pipe(written: std::io::Result<()>) {
    if let Err(e) = written {
        if e.kind() == std::io::ErrorKind::BrokenPipe {
            std::process::exit(0);
        }
    }
}

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
