//! Any program as a controller: one line per sample over stdin/stdout
//! (`docs/FILES.md`, "Controller protocol").
//!
//! For each sample the program reads `k,t,reference,measurement` (decimal,
//! shortest round-trip form) and writes one line: `Δ_k` as a number, or an
//! empty line or `nan` for nothing (held and flagged). It gets the
//! scenario's name and sample time in the environment (`MFCBEAM_SCENARIO`,
//! `MFCBEAM_SAMPLE_TIME`). A program that exits, closes its output, does
//! not take its input or does not answer within the timeout, or writes
//! anything else, ends the run with an error naming the sample and what
//! came; it is killed when the run ends.
//!
//! Neither side blocks the run: a thread writes the program's input and
//! another reads its output, and each sample waits for both within the
//! timeout. A program that answers without reading (its input pipe full)
//! is caught as one that does not take its input.

use std::io::{BufRead, BufReader, Write};
use std::process::{Child, Command, Stdio};
use std::sync::mpsc::{self, Receiver, RecvTimeoutError, Sender};
use std::time::{Duration, Instant};

use super::{ControlError, Controller, LoopSample};

/// Longest answer line read (bytes); a longer one is garbage.
const MAX_LINE: usize = 4096;

/// A running controller program.
pub struct ProcessController {
    name: String,
    child: Child,
    /// Lines for the writer thread; dropped, the program's input closes.
    input: Option<Sender<String>>,
    /// The writer's answer for each line: written, or why not.
    written: Receiver<std::io::Result<()>>,
    lines: Receiver<std::io::Result<String>>,
    timeout: Duration,
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
        let mut stdin = child.stdin.take().expect("stdin is piped");
        let (input, to_write) = mpsc::channel::<String>();
        let (done, written) = mpsc::channel();
        std::thread::spawn(move || {
            for line in to_write {
                let result = stdin.write_all(line.as_bytes()).and_then(|_| stdin.flush());
                let failed = result.is_err();
                if done.send(result).is_err() || failed {
                    break;
                }
            }
            // the channel closed: stdin drops here, the program sees EOF
        });
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
            input: Some(input),
            written,
            lines,
            timeout,
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
        // how it ended, if it did, before it is killed
        let status = match self.child.try_wait() {
            Ok(Some(s)) => format!(" ({s})"),
            _ => String::new(),
        };
        self.kill();
        ControlError::Controller {
            name: self.name.clone(),
            reason: format!("at sample {k}: {reason}{status}"),
        }
    }

    /// Whether the program is still running.
    fn running(&mut self) -> bool {
        matches!(self.child.try_wait(), Ok(None))
    }
}

impl Controller for ProcessController {
    fn name(&self) -> String {
        self.name.clone()
    }

    fn step(&mut self, s: &LoopSample) -> Result<Option<f64>, ControlError> {
        let deadline = Instant::now() + self.timeout;
        let t = self.timeout.as_secs_f64();
        let line = format!("{},{:?},{:?},{:?}\n", s.k, s.t, s.reference, s.measurement);
        let sent = self.input.as_ref().is_some_and(|i| i.send(line).is_ok());
        let written = if sent {
            self.written
                .recv_timeout(deadline.saturating_duration_since(Instant::now()))
        } else {
            Err(RecvTimeoutError::Disconnected)
        };
        match written {
            Ok(Ok(())) => {}
            Ok(Err(_)) | Err(RecvTimeoutError::Disconnected) if !self.running() => {
                return Err(self.fail(s.k, "it exited"));
            }
            Ok(Err(e)) => {
                return Err(self.fail(s.k, format!("it closed its input ({e})")));
            }
            Err(RecvTimeoutError::Disconnected) => {
                return Err(self.fail(s.k, "its input could not be written"));
            }
            Err(RecvTimeoutError::Timeout) => {
                return Err(self.fail(
                    s.k,
                    format!("it did not take its input within {t} s (it does not read it)"),
                ));
            }
        }
        let answer = match self
            .lines
            .recv_timeout(deadline.saturating_duration_since(Instant::now()))
        {
            Ok(Ok(text)) => text,
            Ok(Err(e)) => return Err(self.fail(s.k, format!("could not read its output: {e}"))),
            Err(RecvTimeoutError::Timeout) => {
                return Err(self.fail(s.k, format!("no answer within {t} s")));
            }
            Err(RecvTimeoutError::Disconnected) => String::new(),
        };
        if answer.is_empty() {
            // the end of its output: it exited, or closed it and runs on
            std::thread::sleep(Duration::from_millis(20));
            let why = if self.running() {
                "it closed its output without answering (still running)"
            } else {
                "it exited without answering"
            };
            return Err(self.fail(s.k, why));
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
        drop(self.input.take()); // EOF: a well-behaved program exits
        if !matches!(self.child.try_wait(), Ok(Some(_))) {
            std::thread::sleep(Duration::from_millis(20));
            if !matches!(self.child.try_wait(), Ok(Some(_))) {
                self.kill();
            }
        }
        let _ = self.child.wait();
    }
}
