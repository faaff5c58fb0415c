//! The checker's side of a host process: start `mfcbeam host` in a
//! process group of its own, send it requests, and turn whatever ends it
//! into a [`HostError`]: a signal, an exit, a hang past the timeout (a
//! watchdog kills the group), a protocol broken. Once the host is gone,
//! every later call fails at once, saying so. Dropping a
//! [`HostProcess`] ends the host and every process it started.

use std::collections::VecDeque;
use std::io::{BufRead, BufReader, BufWriter};
use std::path::PathBuf;
use std::process::{Child, ChildStdin, ChildStdout, Command, Stdio};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use thiserror::Error;

use super::host::{Phase, PROGRESS_BYTES};
use super::protocol::{read_reply, send_request, Reply, Request};
use crate::io::scratch::{self, ScratchDir};

/// How the host process is started and watched.
#[derive(Debug, Clone, PartialEq)]
pub struct HostSettings {
    /// The `mfcbeam` program that serves as host (`PROGRAM host`).
    pub program: PathBuf,
    /// The longest a request may take before the host is killed.
    pub timeout: Duration,
    /// The address space the host may use (bytes); `None`: no limit.
    pub memory_limit: Option<u64>,
}

/// The address space a host may use unless told otherwise: an FMU or a
/// compensator needs some megabytes; this leaves room for large ones and
/// turns an allocation without end into a failed allocation.
pub const DEFAULT_MEMORY_LIMIT: u64 = 4 << 30;

impl HostSettings {
    /// This program as host, with `timeout` and the default memory limit.
    pub fn this_program(timeout: Duration) -> std::io::Result<Self> {
        Ok(Self {
            program: std::env::current_exe()?,
            timeout,
            memory_limit: Some(DEFAULT_MEMORY_LIMIT),
        })
    }
}

/// What ended a call to the host.
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum HostError {
    /// The host could not be started, or broke the protocol.
    #[error("the host process: {0}")]
    Host(String),
    /// The candidate refused the request (it returned an error or NULL);
    /// the host goes on.
    #[error("{0}")]
    Refused(String),
    /// The candidate ended the host process (a signal, or an exit of its
    /// own).
    #[error("the candidate {how} {}{}{}", .during.describe(), sample_text(*.sample), stderr_text(.stderr))]
    Ended {
        how: String,
        during: Phase,
        /// The sample of the batch, for a step.
        sample: Option<usize>,
        /// The last line the host wrote on standard error.
        stderr: Option<String>,
    },
    /// A request took longer than the timeout; the host was killed.
    #[error("the candidate did not answer within {seconds} s (killed) {}{}", .during.describe(), sample_text(*.sample))]
    Timeout {
        seconds: f64,
        during: Phase,
        sample: Option<usize>,
    },
}

fn sample_text(s: Option<usize>) -> String {
    s.map(|k| format!(" at sample {k} of the batch"))
        .unwrap_or_default()
}

fn stderr_text(s: &Option<String>) -> String {
    s.as_ref()
        .map(|l| format!(" (its last words on stderr: {l})"))
        .unwrap_or_default()
}

impl HostError {
    /// The candidate took the host down (crash, exit or hang): a finding
    /// about the candidate, not a refusal.
    pub fn is_fatal(&self) -> bool {
        matches!(self, Self::Ended { .. } | Self::Timeout { .. })
    }

    /// The sample of the batch it happened at, if in a step.
    pub fn sample(&self) -> Option<usize> {
        match self {
            Self::Ended { sample, .. } | Self::Timeout { sample, .. } => *sample,
            Self::Host(_) | Self::Refused(_) => None,
        }
    }
}

/// The watchdog's view of the call in progress.
struct Watch {
    base: Instant,
    /// Nanoseconds after `base` when the call in progress must end; 0: none.
    deadline: AtomicU64,
    fired: AtomicBool,
    stop: AtomicBool,
}

/// How often the watchdog looks: what a timeout may overrun by.
const WATCH_PERIOD: Duration = Duration::from_millis(20);

/// The last lines the host wrote on standard error (bounded).
const STDERR_LINES: usize = 8;

/// A running host process.
pub struct HostProcess {
    child: Child,
    pid: u32,
    /// Closed when the host is dropped.
    input: Option<BufWriter<ChildStdin>>,
    output: BufReader<ChildStdout>,
    watch: Arc<Watch>,
    watchdog: Option<std::thread::JoinHandle<()>>,
    stderr: Arc<Mutex<VecDeque<String>>>,
    progress: PathBuf,
    timeout: Duration,
    dead: Option<HostError>,
    _scratch: ScratchDir,
}

impl HostProcess {
    /// Start a host.
    pub fn start(settings: &HostSettings) -> Result<Self, HostError> {
        let fail = |what: &str, e: std::io::Error| HostError::Host(format!("{what}: {e}"));
        let scratch = ScratchDir::new("mfcbeam-host").map_err(|e| fail("scratch directory", e))?;
        let progress = scratch.path().join("progress");
        std::fs::write(&progress, [0u8; PROGRESS_BYTES]).map_err(|e| fail("progress page", e))?;
        let mut command = Command::new(&settings.program);
        command
            .arg("host")
            .arg("--progress")
            .arg(&progress)
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped());
        if let Some(m) = settings.memory_limit {
            command.arg("--memory-limit").arg(m.to_string());
        }
        // whatever the host or the candidate leaves in the temporary
        // directory (an unpacked FMU) goes with the scratch directory
        command.env(if cfg!(windows) { "TMP" } else { "TMPDIR" }, scratch.path());
        #[cfg(unix)]
        std::os::unix::process::CommandExt::process_group(&mut command, 0);
        let mut child = command.spawn().map_err(|e| {
            HostError::Host(format!(
                "could not start '{} host': {e}",
                settings.program.display()
            ))
        })?;
        let pid = child.id();
        scratch::register_child(pid);
        let (Some(input), Some(output), Some(err)) =
            (child.stdin.take(), child.stdout.take(), child.stderr.take())
        else {
            kill_group(pid, &mut child);
            return Err(HostError::Host("its pipes were not made".into()));
        };
        let stderr = Arc::new(Mutex::new(VecDeque::new()));
        let tail = stderr.clone();
        // detached: a grandchild may keep the pipe open after the host ends
        std::thread::spawn(move || {
            for line in BufReader::new(err).split(b'\n') {
                let Ok(line) = line else { break };
                let text: String = String::from_utf8_lossy(&line).chars().take(300).collect();
                let mut t = tail.lock().unwrap_or_else(|e| e.into_inner());
                if t.len() == STDERR_LINES {
                    t.pop_front();
                }
                t.push_back(text);
            }
        });
        let watch = Arc::new(Watch {
            base: Instant::now(),
            deadline: AtomicU64::new(0),
            fired: AtomicBool::new(false),
            stop: AtomicBool::new(false),
        });
        let w = watch.clone();
        let watchdog = std::thread::spawn(move || {
            while !w.stop.load(Ordering::Relaxed) {
                std::thread::sleep(WATCH_PERIOD);
                let d = w.deadline.load(Ordering::Relaxed);
                if d != 0 && w.base.elapsed().as_nanos() as u64 > d {
                    w.fired.store(true, Ordering::SeqCst);
                    kill_pid_group(pid);
                    break;
                }
            }
        });
        Ok(Self {
            child,
            pid,
            input: Some(BufWriter::new(input)),
            output: BufReader::new(output),
            watch,
            watchdog: Some(watchdog),
            stderr,
            progress,
            timeout: settings.timeout,
            dead: None,
            _scratch: scratch,
        })
    }

    /// One request and its reply, within the timeout.
    pub fn call(&mut self, request: &Request) -> Result<Reply, HostError> {
        // the call that saw the host end has its error; the later ones are
        // not findings of their own
        if let Some(e) = &self.dead {
            return Err(HostError::Host(format!("it ended before: {e}")));
        }
        let deadline = self.watch.base.elapsed() + self.timeout;
        self.watch
            .deadline
            .store(deadline.as_nanos().max(1) as u64, Ordering::Relaxed);
        let reply = match self.input.as_mut() {
            Some(input) => send_request(input, request).and_then(|()| read_reply(&mut self.output)),
            None => Err(std::io::ErrorKind::BrokenPipe.into()),
        };
        self.watch.deadline.store(0, Ordering::Relaxed);
        match reply {
            Ok(Some(r)) => Ok(r),
            Ok(None) => Err(self.died(None)),
            Err(e) if e.kind() == std::io::ErrorKind::InvalidData => {
                Err(self.died(Some(format!("it broke the protocol: {e}"))))
            }
            Err(_) => Err(self.died(None)),
        }
    }

    /// The host is gone (or must go): the error that says how, kept.
    fn died(&mut self, broken: Option<String>) -> HostError {
        kill_group(self.pid, &mut self.child);
        let status = self.child.wait().ok();
        scratch::unregister_child(self.pid);
        let (phase, sample) = self.progress();
        let sample = (phase == Phase::Stepping).then_some(sample);
        let error = if self.watch.fired.load(Ordering::SeqCst) {
            HostError::Timeout {
                seconds: self.timeout.as_secs_f64(),
                during: phase,
                sample,
            }
        } else if let Some(b) = broken {
            HostError::Host(b)
        } else {
            // the stderr thread reads what was written before the end
            std::thread::sleep(Duration::from_millis(50));
            let stderr = self
                .stderr
                .lock()
                .unwrap_or_else(|e| e.into_inner())
                .iter()
                .rev()
                .find(|l| !l.trim().is_empty())
                .map(|l| l.trim().to_string());
            HostError::Ended {
                how: status.map_or("ended the host process".into(), describe_status),
                during: phase,
                sample,
                stderr,
            }
        };
        self.dead = Some(error.clone());
        error
    }

    /// The phase and sample the host noted last.
    fn progress(&self) -> (Phase, usize) {
        match std::fs::read(&self.progress) {
            Ok(b) if b.len() >= PROGRESS_BYTES => {
                let word = |i: usize| {
                    let mut a = [0u8; 8];
                    a.copy_from_slice(&b[8 * i..8 * i + 8]);
                    u64::from_ne_bytes(a)
                };
                (Phase::from_code(word(0)), word(1) as usize)
            }
            _ => (Phase::Idle, 0),
        }
    }
}

impl Drop for HostProcess {
    fn drop(&mut self) {
        self.watch.stop.store(true, Ordering::Relaxed);
        if self.dead.is_none() {
            // end of input: the host leaves its loop; it gets a moment to
            // free its instances, then the group goes in any case
            drop(self.input.take());
            let start = Instant::now();
            while start.elapsed() < Duration::from_secs(1) {
                if let Ok(Some(_)) = self.child.try_wait() {
                    break;
                }
                std::thread::sleep(Duration::from_millis(2));
            }
        }
        kill_group(self.pid, &mut self.child);
        let _ = self.child.wait();
        scratch::unregister_child(self.pid);
        if let Some(w) = self.watchdog.take() {
            let _ = w.join();
        }
    }
}

/// Kill the host and every process in its group.
fn kill_group(pid: u32, child: &mut Child) {
    kill_pid_group(pid);
    let _ = child.kill();
}

#[cfg(unix)]
fn kill_pid_group(pid: u32) {
    if let Ok(p) = libc::pid_t::try_from(pid) {
        // SAFETY: kill has no memory effects; the group is the host's own
        unsafe {
            libc::kill(-p, libc::SIGKILL);
        }
    }
}

#[cfg(not(unix))]
fn kill_pid_group(_: u32) {}

/// An exit status as a finding says it.
pub fn describe_status(status: std::process::ExitStatus) -> String {
    #[cfg(unix)]
    {
        use std::os::unix::process::ExitStatusExt;
        if let Some(s) = status.signal() {
            let name = match s {
                libc::SIGSEGV => " (SIGSEGV: an invalid memory access)",
                libc::SIGABRT => " (SIGABRT: an abort)",
                libc::SIGBUS => " (SIGBUS: a bus error)",
                libc::SIGILL => " (SIGILL: an illegal instruction)",
                libc::SIGFPE => " (SIGFPE: an arithmetic exception)",
                libc::SIGKILL => " (SIGKILL)",
                libc::SIGTERM => " (SIGTERM)",
                libc::SIGXCPU => " (SIGXCPU)",
                _ => "",
            };
            return format!("crashed: killed by signal {s}{name}");
        }
    }
    match status.code() {
        Some(c) => format!("ended the process with exit code {c}"),
        None => "ended the process".into(),
    }
}
