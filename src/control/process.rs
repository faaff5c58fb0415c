//! Any program as a controller: one line per sample over stdin/stdout
//! (`docs/FILES.md`, "Controller protocol").
//!
//! For each sample the program reads `k,t,reference,measurement` (decimal,
//! shortest round-trip form) and writes one line: `Δ_k` as a number, or an
//! empty line or `nan` for nothing (held and flagged). It gets the
//! scenario's name and sample time in the environment (`MFCBEAM_SCENARIO`,
//! `MFCBEAM_SAMPLE_TIME`). A program that exits, does not answer within the
//! timeout, or writes anything else ends the run with an error naming the
//! sample and what came; it is killed when the run ends.

use std::io::{BufRead, BufReader, Write};
use std::process::{Child, ChildStdin, Command, Stdio};
use std::sync::mpsc::{self, Receiver, RecvTimeoutError};
use std::time::Duration;

use super::{ControlError, Controller, LoopSample};

/// Longest answer line read (bytes); a longer one is garbage.
const MAX_LINE: usize = 4096;

/// A running controller program.
pub struct ProcessController {
    name: String,
    child: Child,
    stdin: Option<ChildStdin>,
    lines: Receiver<std::io::Result<String>>,
    timeout: Duration,
    line: String,
}

impl ProcessController {
    /// Start `program` with `args`; `env` adds to its environment.
    pub fn spawn(
        program: &str,
        args: &[String],
        env: &[(&str, String)],
        timeout: Duration,
    ) -> Result<Self, ControlError> {
        let name = std::iter::once(program.to_string())
            .chain(args.iter().cloned())
            .collect::<Vec<_>>()
            .join(" ");
        let fail = |reason: String| ControlError::Controller {
            name: name.clone(),
            reason,
        };
        let mut command = Command::new(program);
        command
            .args(args)
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit());
        for (k, v) in env {
            command.env(k, v);
        }
        // its own process group, so that killing it reaches what it started
        #[cfg(unix)]
        std::os::unix::process::CommandExt::process_group(&mut command, 0);
        let mut child = command
            .spawn()
            .map_err(|e| fail(format!("could not start: {e}")))?;
        let stdout = child.stdout.take().expect("stdout is piped");
        let stdin = child.stdin.take();
        let (sender, lines) = mpsc::sync_channel(1);
        std::thread::spawn(move || {
            let mut reader = BufReader::new(stdout);
            loop {
                let mut buf = Vec::new();
                let result = std::io::Read::take(&mut reader, MAX_LINE as u64 + 1)
                    .read_until(b'\n', &mut buf)
                    .map(|_| String::from_utf8_lossy(&buf).into_owned());
                let end = matches!(&result, Ok(s) if s.is_empty()) || result.is_err();
                if sender.send(result).is_err() || end {
                    break;
                }
            }
        });
        Ok(Self {
            name,
            child,
            stdin,
            lines,
            timeout,
            line: String::with_capacity(96),
        })
    }

    /// Kill the program and everything in its process group.
    fn kill(&mut self) {
        #[cfg(unix)]
        if let Ok(pid) = i32::try_from(self.child.id()) {
            // SAFETY: kill(2) on the group this program leads
            unsafe { libc::kill(-pid, libc::SIGKILL) };
        }
        let _ = self.child.kill();
    }

    fn fail(&mut self, k: usize, reason: impl std::fmt::Display) -> ControlError {
        self.kill();
        let status = self
            .child
            .try_wait()
            .ok()
            .flatten()
            .map(|s| format!(" ({s})"))
            .unwrap_or_default();
        ControlError::Controller {
            name: self.name.clone(),
            reason: format!("at sample {k}: {reason}{status}"),
        }
    }
}

impl Controller for ProcessController {
    fn name(&self) -> String {
        self.name.clone()
    }

    fn step(&mut self, s: &LoopSample) -> Result<Option<f64>, ControlError> {
        use std::fmt::Write as _;
        self.line.clear();
        let _ = writeln!(
            self.line,
            "{},{:?},{:?},{:?}",
            s.k, s.t, s.reference, s.measurement
        );
        let written = match self.stdin.as_mut() {
            Some(stdin) => stdin
                .write_all(self.line.as_bytes())
                .and_then(|_| stdin.flush()),
            None => Err(std::io::ErrorKind::BrokenPipe.into()),
        };
        if let Err(e) = written {
            return Err(self.fail(s.k, format!("could not write its input ({e}): it exited")));
        }
        let answer = match self.lines.recv_timeout(self.timeout) {
            Ok(Ok(text)) => text,
            Ok(Err(e)) => return Err(self.fail(s.k, format!("could not read its output: {e}"))),
            Err(RecvTimeoutError::Timeout) => {
                let t = self.timeout.as_secs_f64();
                return Err(self.fail(s.k, format!("no answer within {t} s")));
            }
            Err(RecvTimeoutError::Disconnected) => {
                return Err(self.fail(s.k, "it exited without answering"))
            }
        };
        if answer.is_empty() {
            return Err(self.fail(s.k, "it exited without answering"));
        }
        if answer.len() > MAX_LINE || !answer.ends_with('\n') {
            return Err(self.fail(s.k, "its answer is not a line of at most 4096 bytes"));
        }
        let text = answer.trim();
        if text.is_empty() || text.eq_ignore_ascii_case("nan") {
            return Ok(None);
        }
        match text.parse::<f64>() {
            Ok(v) => Ok(Some(v)),
            Err(_) => {
                let shown: String = text.chars().take(40).collect();
                Err(self.fail(s.k, format!("'{shown}' is not a number")))
            }
        }
    }
}

impl Drop for ProcessController {
    fn drop(&mut self) {
        drop(self.stdin.take()); // EOF: a well-behaved program exits
        if !matches!(self.child.try_wait(), Ok(Some(_))) {
            std::thread::sleep(Duration::from_millis(20));
            if !matches!(self.child.try_wait(), Ok(Some(_))) {
                self.kill();
            }
        }
        let _ = self.child.wait();
    }
}
