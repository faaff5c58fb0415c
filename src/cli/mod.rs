//! The `mfcbeam` command line: [`args`] defines the arguments, [`commands`]
//! carries them out (the larger commands in files of their own:
//! [`identify`], [`conform`], [`fmu`], [`control`]). Errors end the program with exit code 2 and one line on
//! stderr naming the file, row or field.

pub mod args;
pub mod commands;
pub mod conform;
pub mod control;
pub mod fmu;
pub mod identify;

pub use args::Cli;
pub use commands::run;

/// An exit code without an error message: the command has printed its
/// report (`conform` exits 1 when a property fails).
#[derive(Debug)]
pub struct Exit(pub i32);

impl std::fmt::Display for Exit {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "exit code {}", self.0)
    }
}

impl std::error::Error for Exit {}
