//! The host process: `mfcbeam host` loads one candidate (an FMU or a step
//! library) and answers the checker's requests ([`super::protocol`]) on
//! its standard input and output until the checker closes them. Whatever
//! the candidate does to this process (a crash, an `abort`, an `exit`, a
//! hang, an allocation without end) the checker sees from outside.
//!
//! Before each call into the candidate the host notes in a shared page
//! what it is doing and at which sample of the batch, so that the checker
//! can name the sample a crash happened at. The candidate's own writes to
//! standard output go to standard error: the protocol's stream is a copy
//! of the original descriptor, which the candidate does not know.

use std::fs::File;
use std::io::{BufReader, BufWriter};
use std::path::Path;
use std::sync::Arc;

use super::library::{StepInstance, StepLibrary};
use super::protocol::{read_request, send_reply, CandidateSpec, Loaded, Reply, Request, Role};
use super::timer::ticks;
use crate::control::{Controller, LoopSample};
use crate::fmi::controller::{ControllerVariables, FmuController};
use crate::fmi::import::{bind, Fmu, FmuCandidate, FmuInstance, ImportKind};

/// What the host is doing, as the shared page holds it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u64)]
pub enum Phase {
    Idle = 0,
    Loading = 1,
    Creating = 2,
    Stepping = 3,
    Saving = 4,
    Restoring = 5,
    Freeing = 6,
}

impl Phase {
    pub(super) fn from_code(c: u64) -> Self {
        match c {
            1 => Self::Loading,
            2 => Self::Creating,
            3 => Self::Stepping,
            4 => Self::Saving,
            5 => Self::Restoring,
            6 => Self::Freeing,
            _ => Self::Idle,
        }
    }

    /// As a finding names it.
    pub fn describe(self) -> &'static str {
        match self {
            Self::Idle => "between calls",
            Self::Loading => "while it was loaded",
            Self::Creating => "while an instance was created",
            Self::Stepping => "in a step",
            Self::Saving => "while its state was saved",
            Self::Restoring => "while its state was restored",
            Self::Freeing => "while an instance was freed",
        }
    }
}

/// The shared page: the phase and the sample of the batch (two `u64`).
pub const PROGRESS_BYTES: usize = 16;

/// The host's side of the page, mapped from the file the checker made.
struct Progress {
    words: *mut u64,
}

impl Progress {
    #[cfg(unix)]
    fn map(path: &Path) -> Option<Self> {
        use std::os::fd::AsRawFd;
        let file = std::fs::OpenOptions::new()
            .read(true)
            .write(true)
            .open(path)
            .ok()?;
        if file.metadata().ok()?.len() < PROGRESS_BYTES as u64 {
            return None;
        }
        // SAFETY: a shared mapping of a file of at least 16 bytes; the
        // mapping outlives the descriptor, and the host lives with it
        let p = unsafe {
            libc::mmap(
                std::ptr::null_mut(),
                PROGRESS_BYTES,
                libc::PROT_READ | libc::PROT_WRITE,
                libc::MAP_SHARED,
                file.as_raw_fd(),
                0,
            )
        };
        (p != libc::MAP_FAILED).then(|| Self {
            words: p.cast::<u64>(),
        })
    }

    #[cfg(not(unix))]
    fn map(_: &Path) -> Option<Self> {
        None
    }

    #[inline]
    fn note(&self, phase: Phase, sample: usize) {
        // SAFETY: two aligned u64 in the mapping; volatile, so that each
        // store is made before the call that may not return
        unsafe {
            self.words.write_volatile(phase as u64);
            self.words.add(1).write_volatile(sample as u64);
        }
    }
}

fn note(p: &Option<Progress>, phase: Phase, sample: usize) {
    if let Some(p) = p {
        p.note(phase, sample);
    }
}

/// One instance of the candidate.
enum Instance {
    /// An FMU instance (gone after an error) and the time of each state
    /// it saved.
    Fmu(Option<FmuInstance>, Vec<f64>),
    Controller(Option<Box<FmuController>>),
    Library(StepInstance),
}

/// The loaded candidate.
enum Candidate {
    Fmu(FmuCandidate),
    Controller(Arc<Fmu>, ControllerVariables, f64),
    Library(StepLibrary),
}

struct Host {
    // instances first: dropped before the library that made them
    instances: Vec<Option<Instance>>,
    candidate: Option<Candidate>,
    role: Role,
    progress: Option<Progress>,
}

/// Serve the checker on standard input and output (see the module docs):
/// `progress` is the shared page's file, `memory_limit` the address space
/// the candidate may use (bytes).
pub fn serve(progress: Option<&Path>, memory_limit: Option<u64>) -> std::io::Result<()> {
    limit_memory(memory_limit);
    let (input, output) = protocol_streams()?;
    let mut reader = BufReader::new(input);
    let mut writer = BufWriter::new(output);
    let mut host = Host {
        instances: Vec::new(),
        candidate: None,
        role: Role::Model,
        progress: progress.and_then(Progress::map),
    };
    while let Some(request) = read_request(&mut reader)? {
        let reply = host.answer(request);
        note(&host.progress, Phase::Idle, 0);
        send_reply(&mut writer, &reply)?;
    }
    Ok(())
}

/// The protocol's streams: copies of standard input and output, with
/// standard input then reading nothing and standard output going to
/// standard error, for whatever the candidate prints.
#[cfg(unix)]
fn protocol_streams() -> std::io::Result<(File, File)> {
    use std::os::fd::FromRawFd;
    // SAFETY: descriptor calls on the process's own standard streams; each
    // copy is owned by exactly one File
    unsafe {
        let input = libc::dup(0);
        let output = libc::dup(1);
        if input < 0 || output < 0 {
            return Err(std::io::Error::last_os_error());
        }
        let null = libc::open(c"/dev/null".as_ptr(), libc::O_RDONLY);
        if null >= 0 {
            libc::dup2(null, 0);
            libc::close(null);
        }
        libc::dup2(2, 1);
        Ok((File::from_raw_fd(input), File::from_raw_fd(output)))
    }
}

#[cfg(windows)]
fn protocol_streams() -> std::io::Result<(File, File)> {
    use std::os::windows::io::{AsHandle, OwnedHandle};
    let input = std::io::stdin().as_handle().try_clone_to_owned()?;
    let output = std::io::stdout().as_handle().try_clone_to_owned()?;
    Ok((
        File::from(OwnedHandle::from(input)),
        File::from(OwnedHandle::from(output)),
    ))
}

#[cfg(unix)]
fn limit_memory(bytes: Option<u64>) {
    if let Some(b) = bytes {
        let limit = libc::rlimit {
            rlim_cur: b as libc::rlim_t,
            rlim_max: b as libc::rlim_t,
        };
        // SAFETY: plain data for a system call on this process
        unsafe { libc::setrlimit(libc::RLIMIT_AS, &limit) };
    }
}

#[cfg(not(unix))]
fn limit_memory(_: Option<u64>) {}

#[cfg(target_os = "linux")]
fn pin(cpu: usize) -> Result<(), String> {
    // SAFETY: a zeroed cpu_set_t is the empty set; the call reads it
    unsafe {
        let mut set: libc::cpu_set_t = std::mem::zeroed();
        if cpu >= 8 * std::mem::size_of::<libc::cpu_set_t>() {
            return Err(format!("CPU {cpu} does not exist"));
        }
        libc::CPU_SET(cpu, &mut set);
        if libc::sched_setaffinity(0, std::mem::size_of_val(&set), &set) == 0 {
            Ok(())
        } else {
            Err(format!("CPU {cpu}: {}", std::io::Error::last_os_error()))
        }
    }
}

#[cfg(not(target_os = "linux"))]
fn pin(_: usize) -> Result<(), String> {
    Err("pinning is implemented on Linux only".into())
}

/// Pin the calling thread (the checker's timing of the reference).
pub fn pin_this_thread(cpu: usize) -> Result<(), String> {
    pin(cpu)
}

impl Host {
    fn answer(&mut self, request: Request) -> Reply {
        match request {
            Request::Load(spec) => {
                note(&self.progress, Phase::Loading, 0);
                self.load(spec)
            }
            Request::Pin(cpu) => match pin(cpu) {
                Ok(()) => Reply::Done,
                Err(e) => Reply::Refused(e),
            },
            Request::New { model_file, limits } => {
                note(&self.progress, Phase::Creating, 0);
                match self.create(model_file.as_deref(), limits) {
                    Ok(i) => {
                        self.instances.push(Some(i));
                        Reply::Created((self.instances.len() - 1) as u32)
                    }
                    Err(e) => Reply::Refused(e),
                }
            }
            Request::Run {
                instance,
                inputs,
                timed,
            } => self.run(instance, &inputs, timed),
            Request::Save(i) => {
                note(&self.progress, Phase::Saving, 0);
                match self.instance(i) {
                    Some(Instance::Fmu(Some(f), times)) => {
                        let t = f.time();
                        Reply::Saved(f.save().ok().map(|k| {
                            times.resize(k + 1, t);
                            times[k] = t;
                            k as u32
                        }))
                    }
                    Some(_) => Reply::Saved(None),
                    None => Reply::Refused(format!("no instance {i}")),
                }
            }
            Request::Restore { instance, state } => {
                note(&self.progress, Phase::Restoring, 0);
                match self.instance(instance) {
                    Some(Instance::Fmu(Some(f), times)) => {
                        let k = state as usize;
                        Reply::Restored(times.get(k).is_some_and(|&t| f.restore(k, t).is_ok()))
                    }
                    Some(_) => Reply::Restored(false),
                    None => Reply::Refused(format!("no instance {instance}")),
                }
            }
            Request::Free(i) => {
                note(&self.progress, Phase::Freeing, 0);
                if let Some(slot) = self.instances.get_mut(i as usize) {
                    slot.take();
                }
                Reply::Done
            }
        }
    }

    fn instance(&mut self, i: u32) -> Option<&mut Instance> {
        self.instances.get_mut(i as usize)?.as_mut()
    }

    fn load(&mut self, spec: CandidateSpec) -> Reply {
        if self.candidate.is_some() {
            return Reply::Refused("a candidate is loaded already".into());
        }
        self.role = spec.role();
        let loaded = match spec {
            CandidateSpec::Fmu {
                path,
                role,
                variables,
                sample_time,
            } => {
                let fmu = match Fmu::load(Path::new(&path)) {
                    Ok(f) => f,
                    Err(e) => return Reply::Refused(e.to_string()),
                };
                let info = Loaded {
                    saves_state: fmu.description.can_get_and_set_state,
                    takes_limits: false,
                    step_size: fmu.description.step_size,
                };
                let kind = match role {
                    Role::Model => ImportKind::Model,
                    Role::Compensator => ImportKind::Compensator,
                    Role::InverseHysteresis => ImportKind::InverseHysteresis,
                    Role::Controller => {
                        let mut names = ControllerVariables::default();
                        for (ours, theirs) in variables {
                            match ours.as_str() {
                                "reference" => names.reference = theirs,
                                "measurement" => names.measurement = theirs,
                                "correction" => names.correction = theirs,
                                _ => {}
                            }
                        }
                        // bound once now, so that a wrong FMU is refused here
                        if let Err(e) = FmuController::new(fmu.clone(), &names, sample_time) {
                            return Reply::Refused(e.to_string());
                        }
                        self.candidate = Some(Candidate::Controller(fmu, names, sample_time));
                        return Reply::Loaded(info);
                    }
                };
                let bindings = match bind(&fmu.description, kind, &variables) {
                    Ok(b) => b,
                    Err(e) => return Reply::Refused(e.to_string()),
                };
                let info = Loaded {
                    takes_limits: bindings.limits.is_some(),
                    ..info
                };
                self.candidate = Some(Candidate::Fmu(FmuCandidate::new(
                    fmu,
                    bindings,
                    sample_time,
                )));
                info
            }
            CandidateSpec::Library {
                path,
                role,
                symbol_prefix,
                precision,
            } => {
                if role == Role::Controller {
                    return Reply::Refused(
                        "a controller is checked as an FMU or a program, not a step library".into(),
                    );
                }
                match StepLibrary::open(&path, &symbol_prefix, precision) {
                    Ok(l) => {
                        self.candidate = Some(Candidate::Library(l));
                        Loaded {
                            saves_state: false,
                            takes_limits: true,
                            step_size: None,
                        }
                    }
                    Err(e) => return Reply::Refused(e),
                }
            }
        };
        Reply::Loaded(loaded)
    }

    fn create(
        &mut self,
        model_file: Option<&str>,
        limits: Option<(f64, f64)>,
    ) -> Result<Instance, String> {
        match &self.candidate {
            None => Err("no candidate is loaded".into()),
            Some(Candidate::Fmu(c)) => c
                .instance(limits)
                .map(|i| Instance::Fmu(Some(i), Vec::new()))
                .map_err(|e| e.to_string()),
            Some(Candidate::Controller(fmu, names, ts)) => {
                FmuController::new(fmu.clone(), names, *ts)
                    .map(|c| Instance::Controller(Some(Box::new(c))))
                    .map_err(|e| e.to_string())
            }
            Some(Candidate::Library(l)) => l
                .create(
                    model_file,
                    limits.unwrap_or((f64::NEG_INFINITY, f64::INFINITY)),
                )
                .map(Instance::Library),
        }
    }

    fn run(&mut self, instance: u32, inputs: &[f64], timed: bool) -> Reply {
        let (n_in, n_out) = (self.role.inputs(), self.role.outputs());
        if !inputs.len().is_multiple_of(n_in) {
            return Reply::Refused(format!("{} inputs, not {n_in} per sample", inputs.len()));
        }
        let samples = inputs.len() / n_in;
        let mut outputs = vec![f64::NAN; samples * n_out];
        let mut ticks_out = if timed {
            vec![0u64; samples]
        } else {
            Vec::new()
        };
        let progress = self.progress.take();
        let candidate = &self.candidate;
        let result = match self
            .instances
            .get_mut(instance as usize)
            .and_then(Option::as_mut)
        {
            None => Err(format!("no instance {instance}")),
            Some(Instance::Library(l)) => {
                for k in 0..samples {
                    note(&progress, Phase::Stepping, k);
                    let t0 = ticks();
                    let (y, saturated) = l.step(inputs[k]);
                    let t1 = ticks();
                    if timed {
                        ticks_out[k] = t1.wrapping_sub(t0);
                    }
                    outputs[k * n_out] = y;
                    if n_out == 3 {
                        outputs[k * n_out + 1] = f64::from(u8::from(saturated));
                        outputs[k * n_out + 2] = 0.0;
                    }
                }
                Ok(())
            }
            Some(Instance::Fmu(slot, _)) => {
                let Some(Candidate::Fmu(c)) = candidate else {
                    return Reply::Refused("no FMU is loaded".into());
                };
                let mut error = None;
                if let Some(i) = slot {
                    for k in 0..samples {
                        note(&progress, Phase::Stepping, k);
                        let t0 = ticks();
                        let r = c.sample(i, inputs[k]);
                        let t1 = ticks();
                        if timed {
                            ticks_out[k] = t1.wrapping_sub(t0);
                        }
                        match r {
                            Ok((y, saturated, fault)) => {
                                outputs[k * n_out] = y;
                                if n_out == 3 {
                                    outputs[k * n_out + 1] = f64::from(u8::from(saturated));
                                    outputs[k * n_out + 2] = f64::from(u8::from(fault));
                                }
                            }
                            Err(e) => {
                                error = Some(format!("sample {k}: {e}"));
                                break;
                            }
                        }
                    }
                } else {
                    error = Some("the instance failed before".into());
                }
                if error.is_some() {
                    *slot = None;
                }
                error.map_or(Ok(()), Err)
            }
            Some(Instance::Controller(slot)) => {
                let mut error = None;
                if let Some(c) = slot {
                    for k in 0..samples {
                        note(&progress, Phase::Stepping, k);
                        let s = LoopSample {
                            k,
                            t: 0.0,
                            reference: inputs[2 * k],
                            measurement: inputs[2 * k + 1],
                        };
                        let t0 = ticks();
                        let r = c.step(&s);
                        let t1 = ticks();
                        if timed {
                            ticks_out[k] = t1.wrapping_sub(t0);
                        }
                        match r {
                            Ok(Some(d)) => {
                                outputs[2 * k] = d;
                                outputs[2 * k + 1] = 0.0;
                            }
                            Ok(None) => outputs[2 * k + 1] = 1.0,
                            Err(e) => {
                                error = Some(e.to_string());
                                break;
                            }
                        }
                    }
                } else {
                    error = Some("the instance failed before".into());
                }
                if error.is_some() {
                    *slot = None;
                }
                error.map_or(Ok(()), Err)
            }
        };
        self.progress = progress;
        Reply::Ran {
            outputs,
            ticks: ticks_out,
            error: result.err(),
        }
    }
}
