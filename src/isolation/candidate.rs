//! A candidate in a host process as the conformance traits and the timing
//! see it. [`HostedCandidate`] is the loaded candidate (one host process,
//! calls serialised); [`HostedModel`], [`HostedCompensator`] and
//! [`HostedInverseHysteresis`] are instances of it, each keeping the
//! inputs it has been given, so that
//!
//! * a whole signal goes to the host as one batch (isolation costs one
//!   round trip per batch, not per sample);
//! * a candidate without state functions (a step library) saves by keeping
//!   that history and restores by replaying it into a fresh instance;
//! * when the candidate takes the host down, the [`Finding`] holds the
//!   model, the limits and the input up to the sample it happened at, and
//!   the property and case that were running. From then on every instance
//!   gives NaN at once, so the rest of the run ends quickly.

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};

use super::process::{HostError, HostProcess, HostSettings};
use super::protocol::{CandidateSpec, Loaded, Reply, Request, Role};
use crate::control::{ControlError, Controller, LoopSample};
use crate::error::ModelError;
use crate::io::scratch::ScratchDir;
use crate::operators::model::ModelFile;
use crate::operators::traits::{
    ActuatorCompensator, ActuatorModel, Compensated, InverseHysteresis, Operator, SavedState,
};

/// The first time the candidate took the host down.
#[derive(Debug, Clone, PartialEq)]
pub struct Finding {
    pub error: HostError,
    /// The conformance property and case index that were running.
    pub case: Option<(&'static str, usize)>,
    /// The instance's model file (`None`: a fixed candidate).
    pub model: Option<ModelFile>,
    pub limits: Option<(f64, f64)>,
    /// The instance's inputs from its start up to and including the
    /// sample it happened at (`Role::inputs` numbers per sample).
    pub input: Vec<f64>,
}

/// A candidate loaded in its host process.
pub struct HostedCandidate {
    host: Mutex<HostProcess>,
    pub spec: CandidateSpec,
    pub loaded: Loaded,
    first_error: Mutex<Option<String>>,
    finding: Mutex<Option<Finding>>,
    models: ScratchDir,
    made: AtomicUsize,
}

impl std::fmt::Debug for HostedCandidate {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("HostedCandidate")
            .field("spec", &self.spec)
            .finish()
    }
}

fn unexpected(r: Reply) -> HostError {
    HostError::Host(format!("an unexpected reply {r:?}"))
}

impl HostedCandidate {
    /// Start a host and load `spec` into it.
    pub fn start(settings: &HostSettings, spec: CandidateSpec) -> Result<Arc<Self>, HostError> {
        let mut host = HostProcess::start(settings)?;
        let loaded = match host.call(&Request::Load(spec.clone()))? {
            Reply::Loaded(l) => l,
            Reply::Refused(why) => return Err(HostError::Refused(why)),
            r => return Err(unexpected(r)),
        };
        let models = ScratchDir::new("mfcbeam-models")
            .map_err(|e| HostError::Host(format!("scratch directory: {e}")))?;
        Ok(Arc::new(Self {
            host: Mutex::new(host),
            spec,
            loaded,
            first_error: Mutex::new(None),
            finding: Mutex::new(None),
            models,
            made: AtomicUsize::new(0),
        }))
    }

    /// What the candidate computes.
    pub fn role(&self) -> Role {
        self.spec.role()
    }

    fn call(&self, r: &Request) -> Result<Reply, HostError> {
        self.host.lock().unwrap_or_else(|e| e.into_inner()).call(r)
    }

    /// Pin the host to a CPU.
    pub fn pin(&self, cpu: usize) -> Result<(), HostError> {
        match self.call(&Request::Pin(cpu))? {
            Reply::Done => Ok(()),
            Reply::Refused(why) => Err(HostError::Refused(why)),
            r => Err(unexpected(r)),
        }
    }

    /// The first time the candidate took the host down, if it did.
    pub fn finding(&self) -> Option<Finding> {
        self.finding
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .clone()
    }

    /// The first error a run met (its outputs became NaN), if any.
    pub fn first_error(&self) -> Option<String> {
        self.first_error
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .clone()
    }

    /// Forget the errors noted so far (after a smoke test).
    pub fn clear_errors(&self) {
        *self.first_error.lock().unwrap_or_else(|e| e.into_inner()) = None;
    }

    fn note(&self, e: &str) {
        let mut first = self.first_error.lock().unwrap_or_else(|e| e.into_inner());
        if first.is_none() {
            *first = Some(e.to_string());
        }
    }

    fn found(&self, f: Finding) {
        let mut finding = self.finding.lock().unwrap_or_else(|e| e.into_inner());
        if finding.is_none() {
            *finding = Some(f);
        }
    }

    /// A new instance for `model` (`None`: fixed) with `limits`.
    pub fn instance(
        self: &Arc<Self>,
        model: Option<&ModelFile>,
        limits: Option<(f64, f64)>,
    ) -> Result<HostedInstance, HostError> {
        let model_path = match model {
            Some(m) => {
                let n = self.made.fetch_add(1, Ordering::Relaxed);
                let path = self.models.path().join(format!("model-{n}.json"));
                let text = serde_json::to_string(m)
                    .map_err(|e| HostError::Host(format!("model file: {e}")))?;
                std::fs::write(&path, text)
                    .map_err(|e| HostError::Host(format!("{}: {e}", path.display())))?;
                Some(path)
            }
            None => None,
        };
        let mut instance = HostedInstance {
            candidate: self.clone(),
            id: None,
            model: model.cloned(),
            model_path,
            limits,
            history: Vec::new(),
        };
        instance.id = Some(instance.create()?);
        Ok(instance)
    }
}

/// One instance of a hosted candidate.
pub struct HostedInstance {
    candidate: Arc<HostedCandidate>,
    /// `None` after the candidate failed.
    id: Option<u32>,
    model: Option<ModelFile>,
    model_path: Option<std::path::PathBuf>,
    limits: Option<(f64, f64)>,
    history: Vec<f64>,
}

/// A saved state: the host's own, or the history to replay.
struct HostedState {
    native: Option<u32>,
    history: Vec<f64>,
}

impl HostedInstance {
    fn create(&mut self) -> Result<u32, HostError> {
        let request = Request::New {
            model_file: self.model_path.as_ref().map(|p| p.display().to_string()),
            limits: self.limits,
        };
        match self.candidate.call(&request) {
            Ok(Reply::Created(id)) => Ok(id),
            Ok(Reply::Refused(why)) => Err(HostError::Refused(why)),
            Ok(r) => Err(unexpected(r)),
            Err(e) => {
                self.fatal(&e, &[]);
                Err(e)
            }
        }
    }

    fn fatal(&self, e: &HostError, batch: &[f64]) {
        if !e.is_fatal() {
            return;
        }
        let n_in = self.candidate.role().inputs();
        let mut input = self.history.clone();
        if let Some(k) = e.sample() {
            input.extend_from_slice(&batch[..((k + 1) * n_in).min(batch.len())]);
        }
        self.candidate.found(Finding {
            error: e.clone(),
            case: crate::suite::conformance::current_case(),
            model: self.model.clone(),
            limits: self.limits,
            input,
        });
    }

    /// `inputs` through the instance, untimed: `Role::outputs` numbers per
    /// sample, NaN once it has failed.
    pub fn run(&mut self, inputs: &[f64]) -> Vec<f64> {
        match self.run_batch(inputs, false) {
            Ok((out, _)) => out,
            Err(_) => vec![f64::NAN; self.outputs_for(inputs)],
        }
    }

    fn outputs_for(&self, inputs: &[f64]) -> usize {
        let role = self.candidate.role();
        inputs.len() / role.inputs() * role.outputs()
    }

    /// `inputs` through the instance with each step's ticks, timed in the
    /// host.
    pub fn run_timed(&mut self, inputs: &[f64]) -> Result<(Vec<f64>, Vec<u64>), HostError> {
        self.run_batch(inputs, true)
    }

    fn run_batch(
        &mut self,
        inputs: &[f64],
        timed: bool,
    ) -> Result<(Vec<f64>, Vec<u64>), HostError> {
        let Some(id) = self.id else {
            return Err(HostError::Refused("the instance failed before".into()));
        };
        let request = Request::Run {
            instance: id,
            inputs: inputs.to_vec(),
            timed,
        };
        match self.candidate.call(&request) {
            Ok(Reply::Ran {
                outputs,
                ticks,
                error,
            }) => {
                self.history.extend_from_slice(inputs);
                if let Some(e) = error {
                    self.candidate.note(&e);
                    self.id = None;
                }
                if outputs.len() != self.outputs_for(inputs) {
                    return Err(HostError::Host("a reply of the wrong length".into()));
                }
                Ok((outputs, ticks))
            }
            Ok(Reply::Refused(why)) => {
                self.candidate.note(&why);
                self.id = None;
                Err(HostError::Refused(why))
            }
            Ok(r) => Err(unexpected(r)),
            Err(e) => {
                self.fatal(&e, inputs);
                self.candidate.note(&e.to_string());
                self.id = None;
                Err(e)
            }
        }
    }

    fn save(&mut self) -> Option<SavedState> {
        let id = self.id?;
        let native = if self.candidate.loaded.saves_state {
            match self.candidate.call(&Request::Save(id)) {
                Ok(Reply::Saved(Some(k))) => Some(k),
                Ok(_) => return None,
                Err(e) => {
                    self.fatal(&e, &[]);
                    self.id = None;
                    return None;
                }
            }
        } else {
            None
        };
        Some(SavedState(Box::new(HostedState {
            native,
            history: self.history.clone(),
        })))
    }

    fn restore(&mut self, state: &SavedState) -> bool {
        let Some(s) = state.0.downcast_ref::<HostedState>() else {
            return false;
        };
        match (s.native, self.id) {
            (Some(k), Some(id)) => {
                let r = self.candidate.call(&Request::Restore {
                    instance: id,
                    state: k,
                });
                match r {
                    Ok(Reply::Restored(true)) => {
                        self.history = s.history.clone();
                        true
                    }
                    Ok(_) => false,
                    Err(e) => {
                        self.fatal(&e, &[]);
                        self.id = None;
                        false
                    }
                }
            }
            (Some(_), None) => false,
            (None, _) => {
                // a fresh instance, and the history replayed into it
                self.reset();
                if self.id.is_none() {
                    return false;
                }
                let history = s.history.clone();
                self.run(&history);
                self.history = history;
                self.id.is_some()
            }
        }
    }

    /// Whether the instance has failed (its outputs are NaN from now on).
    pub fn failed(&self) -> bool {
        self.id.is_none()
    }

    /// A fresh instance in place of this one.
    pub fn reset(&mut self) {
        self.free();
        self.history.clear();
        match self.create() {
            Ok(id) => self.id = Some(id),
            Err(e) => self.candidate.note(&e.to_string()),
        }
    }

    fn free(&mut self) {
        if let Some(id) = self.id.take() {
            if let Err(e) = self.candidate.call(&Request::Free(id)) {
                self.fatal(&e, &[]);
            }
        }
    }
}

impl Drop for HostedInstance {
    fn drop(&mut self) {
        self.free();
        if let Some(p) = &self.model_path {
            let _ = std::fs::remove_file(p);
        }
    }
}

/// A hosted candidate as a refusal or a fatal failure the conformance
/// checks count.
pub fn model_error(e: HostError) -> ModelError {
    match e {
        HostError::Refused(why) => ModelError::Unsupported { part: why },
        e => ModelError::Inconsistent {
            field: "candidate".into(),
            reason: e.to_string(),
        },
    }
}

/// An operator of kind `$kind` in a host.
macro_rules! hosted_operator {
    ($(#[$doc:meta])* $name:ident: $kind:ident) => {
        $(#[$doc])*
        pub struct $name(pub HostedInstance);

        impl $name {
            pub fn new(
                candidate: &Arc<HostedCandidate>,
                model: Option<&ModelFile>,
            ) -> Result<Self, HostError> {
                candidate.instance(model, None).map(Self)
            }
        }

        impl Operator for $name {
            fn step(&mut self, x: f64) -> f64 {
                self.0.run(&[x])[0]
            }
            fn run(&mut self, input: &[f64]) -> Vec<f64> {
                self.0.run(input)
            }
            fn reset(&mut self) {
                self.0.reset();
            }
            fn save_state(&mut self) -> Option<SavedState> {
                self.0.save()
            }
            fn restore_state(&mut self, state: &SavedState) -> bool {
                self.0.restore(state)
            }
        }

        impl $kind for $name {}
    };
}

hosted_operator!(
    /// `W` (or `H`) in a host.
    HostedModel: ActuatorModel
);
hosted_operator!(
    /// `H⁻¹` in a host.
    HostedInverseHysteresis: InverseHysteresis
);

/// `W⁻¹` in a host: per sample the memory part's inverse; `compensate_all`
/// previews by `delay` and sends the whole signal at once.
pub struct HostedCompensator {
    pub instance: HostedInstance,
    delay: usize,
}

impl HostedCompensator {
    pub fn new(
        candidate: &Arc<HostedCandidate>,
        model: Option<&ModelFile>,
        limits: Option<(f64, f64)>,
        delay: usize,
    ) -> Result<Self, HostError> {
        Ok(Self {
            instance: candidate.instance(model, limits)?,
            delay,
        })
    }
}

fn compensated(o: &[f64]) -> Compensated {
    Compensated {
        u: o[0],
        saturated: o[1] != 0.0 && !o[1].is_nan(),
        fault: o[2] != 0.0 && !o[2].is_nan(),
    }
}

impl ActuatorCompensator for HostedCompensator {
    fn compensate(&mut self, target: f64) -> Compensated {
        compensated(&self.instance.run(&[target]))
    }
    fn reset(&mut self) {
        self.instance.reset();
    }
    fn delay(&self) -> usize {
        self.delay
    }
    fn save_state(&mut self) -> Option<SavedState> {
        self.instance.save()
    }
    fn restore_state(&mut self, state: &SavedState) -> bool {
        self.instance.restore(state)
    }
    fn compensate_all(&mut self, targets: &[f64]) -> Vec<Compensated> {
        let d = self.delay;
        let previewed: Vec<f64> = (0..targets.len())
            .map(|k| crate::realtime::preview(targets, d, k))
            .collect();
        self.instance
            .run(&previewed)
            .chunks_exact(3)
            .map(compensated)
            .collect()
    }
}

/// The closed loop's controller in a host: per sample one round trip with
/// the reference and the measurement, the correction and `held` back.
pub struct HostedController {
    name: String,
    instance: HostedInstance,
}

impl HostedController {
    /// A fresh instance of `candidate` (loaded as [`Role::Controller`]).
    pub fn new(candidate: &Arc<HostedCandidate>, name: &str) -> Result<Self, HostError> {
        Ok(Self {
            name: name.to_string(),
            instance: candidate.instance(None, None)?,
        })
    }
}

impl Controller for HostedController {
    fn name(&self) -> String {
        self.name.clone()
    }

    fn step(&mut self, s: &LoopSample) -> Result<Option<f64>, ControlError> {
        let fail = |reason: String| ControlError::Controller {
            name: self.name.clone(),
            reason: format!("at sample {}: {reason}", s.k),
        };
        let out = self
            .instance
            .run_batch(&[s.reference, s.measurement], false)
            .map_err(|e| fail(e.to_string()))?
            .0;
        if self.instance.failed() {
            let why = self.instance.candidate.first_error().unwrap_or_default();
            return Err(fail(why));
        }
        Ok((out[1] == 0.0).then_some(out[0]))
    }
}
