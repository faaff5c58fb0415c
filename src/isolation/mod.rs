//! Candidates that may crash, hang or lie, run where they cannot take the
//! checker down: FMUs and step libraries are loaded in a host process (the
//! `mfcbeam` program itself, `mfcbeam host`), and the checker talks to it
//! over its standard input and output.
//!
//! * A crash (a signal), an `abort`, an `exit` of the candidate's own and
//!   a hang past the timeout end the host, not the checker: each becomes a
//!   [`Finding`] that names what the host was doing (a step, creating an
//!   instance, …), the sample of the batch, and the case.
//! * The host's address space is limited ([`DEFAULT_MEMORY_LIMIT`]), so an
//!   allocation without end fails inside it.
//! * The host runs in a process group of its own; ending it ends whatever
//!   the candidate started.
//! * Timing runs inside the host ([`HostedInstance::run_timed`]): a batch
//!   of samples goes in one message and each step is bracketed by the
//!   timer ([`timer`]) there, so isolation adds nothing to a step's time.
//!
//! A shared library candidate has the **step ABI**: three functions named
//! by a prefix ([`DEFAULT_SYMBOL_PREFIX`] unless another is given), in
//! `f64` or `f32` ([`Precision`]):
//!
//! ```c
//! void  *PREFIX_create(const char *model_file, double lower_limit, double upper_limit);
//! double PREFIX_step(void *candidate, double input);   /* or float, float */
//! void   PREFIX_free(void *candidate);
//! int    PREFIX_saturated(const void *candidate);      /* optional */
//! ```
//!
//! `create` gets the model file to implement (`NULL` for a fixed
//! implementation) and a compensator's limits (infinite for the other
//! kinds), and returns `NULL` to refuse; `step` is one sample. Without
//! `saturated`, a compensator's `u` at a limit is taken as clipped. The
//! ABI has no state functions: a saved state is the inputs so far,
//! replayed into a fresh instance.
//!
//! The parts:
//!
//! * `protocol`: the messages, length-prefixed, numbers as IEEE bits;
//! * `host`: the host's loop, its shared progress page;
//! * `process`: the checker's side, with the watchdog;
//! * `library`: the step ABI of a shared library candidate;
//! * `candidate`: a hosted candidate as the conformance traits see it;
//! * [`timer`]: the step timer.

mod candidate;
mod host;
mod library;
mod process;
mod protocol;
pub mod timer;

pub use candidate::{
    model_error, Finding, HostedCandidate, HostedCompensator, HostedController, HostedInstance,
    HostedInverseHysteresis, HostedModel,
};
pub use host::{pin_this_thread, serve, Phase};
pub use library::DEFAULT_SYMBOL_PREFIX;
pub use process::{describe_status, HostError, HostSettings, DEFAULT_MEMORY_LIMIT};
pub use protocol::{CandidateSpec, Loaded, Precision, Role};
