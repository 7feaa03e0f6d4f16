//! The `supine` command line: a thin shell over `supine_host::cli`.
use std::process::ExitCode;

fn main() -> ExitCode {
    supine_host::cli::main()
}
