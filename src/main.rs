//! The `mfcbeam` command line (`docs/FILES.md`). Errors end the program with
//! exit code 2 and one line on stderr naming the file, row or field.

mod cli;

use clap::Parser;

fn main() {
    // scratch directories and candidates go on Ctrl-C too (first: it must
    // run before any thread starts)
    mfcbeam::io::scratch::clean_up_on_termination_signals();
    let args = match cli::Cli::try_parse() {
        Ok(args) => args,
        Err(e) if !e.use_stderr() => {
            // --help and --version
            let _ = e.print();
            return;
        }
        Err(e) => {
            // Usage errors too end in one line and exit code 2.
            let text = e.render().to_string();
            let first = text.lines().next().unwrap_or("invalid arguments");
            eprintln!("mfcbeam: {first}");
            std::process::exit(2);
        }
    };
    let result = cli::run(args);
    // a termination signal being handled decides the exit code (it may
    // have killed the candidate this run just saw fail)
    use mfcbeam::io::scratch::exit_unless_terminating;
    if let Err(e) = result {
        if let Some(cli::Exit(code)) = e.downcast_ref::<cli::Exit>() {
            exit_unless_terminating(*code);
        }
        if mfcbeam::io::scratch::terminating() {
            exit_unless_terminating(2);
        }
        // `{:#}` joins the context chain on one line; keep it one line.
        let msg = format!("{e:#}").replace(['\n', '\r'], " ");
        eprintln!("mfcbeam: error: {msg}");
        exit_unless_terminating(2);
    }
    exit_unless_terminating(0);
}
