//! `cellmech example`.

use std::process::ExitCode;

use crate::args::ExampleArgs;

pub fn example(args: &ExampleArgs) -> anyhow::Result<ExitCode> {
    match &args.name {
        None => {
            for e in cellmech::examples::EXAMPLES {
                out!("{:<28} {}", e.name, e.summary);
            }
        }
        Some(name) => {
            let e = cellmech::examples::find(name).ok_or_else(|| {
                let names: Vec<&str> = cellmech::examples::EXAMPLES
                    .iter()
                    .map(|e| e.name)
                    .collect();
                anyhow::anyhow!(
                    "no example named \"{name}\"; available: {}",
                    names.join(", ")
                )
            })?;
            out_text!("{}", e.text);
        }
    }
    Ok(ExitCode::SUCCESS)
}
