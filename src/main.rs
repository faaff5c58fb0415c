//! The `mfcbeam` command line (SPEC section 11). Errors end the program with
//! exit code 2 and one line on stderr naming the file, row or field.

mod cli;

use clap::Parser;

fn main() {
    let args = cli::Cli::parse();
    if let Err(e) = cli::run(args) {
        // `{:#}` joins the context chain on one line; keep it one line.
        let msg = format!("{e:#}").replace(['\n', '\r'], " ");
        eprintln!("mfcbeam: error: {msg}");
        std::process::exit(2);
    }
}
