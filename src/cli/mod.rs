//! The `mfcbeam` command line: [`args`] defines the arguments, [`commands`]
//! carries them out. Errors end the program with exit code 2 and one line on
//! stderr naming the file, row or field.

pub mod args;
pub mod commands;
pub mod conform;
pub mod fmu;

pub use args::Cli;
pub use commands::run;
