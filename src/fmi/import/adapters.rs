//! An instance of a loaded FMU as the conformance traits see it: the
//! variables of a kind found by name ([`bind`]), one sample per `doStep` of
//! one sample time, and NaN outputs after an error (noted once), so that
//! every property comparing them fails.

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};

use super::{Fmu, FmuInstance, ImportError, ImportedDescription, VariableType};
use crate::operators::traits::{
    ActuatorCompensator, ActuatorModel, Compensated, InverseHysteresis, Operator, SavedState,
};

/// Which conformance kind an FMU is checked as: the variables it needs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ImportKind {
    /// `W` (or `H` alone): `u` in, `y` out.
    Model,
    /// `W⁻¹`: `y_d` in, `u` out, `saturated` (and optionally `fault`,
    /// `u_min`, `u_max`).
    Compensator,
    /// `H⁻¹`: `y` in, `u` out.
    InverseHysteresis,
}

/// The value references the adapters use.
#[derive(Debug, Clone, PartialEq)]
pub struct Bindings {
    pub input: u32,
    pub output: u32,
    pub saturated: Option<u32>,
    pub fault: Option<u32>,
    pub limits: Option<(u32, u32)>,
}

/// Find the variables of `kind` by name; `map` renames (`(ours, the FMU's)`).
pub fn bind(
    description: &ImportedDescription,
    kind: ImportKind,
    map: &[(String, String)],
) -> Result<Bindings, ImportError> {
    let name = |ours: &str| -> String {
        map.iter()
            .find(|(a, _)| a == ours)
            .map(|(_, b)| b.clone())
            .unwrap_or_else(|| ours.to_string())
    };
    let find = |ours: &str, ty: VariableType, what: &str| -> Result<u32, ImportError> {
        let n = name(ours);
        match description.variable(&n) {
            Some(v) if v.ty == Some(ty) => Ok(v.value_reference),
            Some(_) => Err(ImportError::NoVariable {
                name: n,
                what: format!("{what}, of type {ty:?}"),
            }),
            None => Err(ImportError::NoVariable {
                name: n,
                what: what.into(),
            }),
        }
    };
    let optional = |ours: &str, ty: VariableType| -> Option<u32> {
        description
            .variable(&name(ours))
            .filter(|v| v.ty == Some(ty))
            .map(|v| v.value_reference)
    };
    use VariableType::{Boolean, Float64};
    Ok(match kind {
        ImportKind::Model => Bindings {
            input: find("u", Float64, "the input voltage")?,
            output: find("y", Float64, "the output")?,
            saturated: None,
            fault: None,
            limits: None,
        },
        ImportKind::InverseHysteresis => Bindings {
            input: find("y", Float64, "the input of H^-1")?,
            output: find("u", Float64, "the output of H^-1")?,
            saturated: None,
            fault: None,
            limits: None,
        },
        ImportKind::Compensator => Bindings {
            input: find("y_d", Float64, "the target")?,
            output: find("u", Float64, "the compensated voltage")?,
            saturated: Some(find("saturated", Boolean, "the saturation flag")?),
            fault: optional("fault", Boolean),
            limits: optional("u_min", Float64).zip(optional("u_max", Float64)),
        },
    })
}

/// An FMU ready to be instantiated for the checks: the loaded FMU, its
/// bindings and the sample time of one step.
#[derive(Debug, Clone)]
pub struct FmuCandidate {
    pub fmu: Arc<Fmu>,
    pub bindings: Bindings,
    pub sample_time: f64,
    /// The first error any run met (its outputs became NaN).
    pub first_error: Arc<Mutex<Option<ImportError>>>,
    count: Arc<AtomicUsize>,
}

impl FmuCandidate {
    pub fn new(fmu: Arc<Fmu>, bindings: Bindings, sample_time: f64) -> Self {
        Self {
            fmu,
            bindings,
            sample_time,
            first_error: Arc::new(Mutex::new(None)),
            count: Arc::new(AtomicUsize::new(0)),
        }
    }

    /// A fresh initialized instance; `limits` set first where the FMU has
    /// limit parameters.
    pub fn instance(&self, limits: Option<(f64, f64)>) -> Result<FmuInstance, ImportError> {
        let n = self.count.fetch_add(1, Ordering::Relaxed);
        let mut i = FmuInstance::new(self.fmu.clone(), &format!("conform{n}"))?;
        if let (Some((lo, hi)), Some((vlo, vhi))) = (limits, self.bindings.limits) {
            i.set_f64(vlo, lo)?;
            i.set_f64(vhi, hi)?;
        }
        i.initialize(0.0)?;
        Ok(i)
    }

    fn note(&self, e: ImportError) {
        let mut first = self.first_error.lock().unwrap_or_else(|e| e.into_inner());
        if first.is_none() {
            *first = Some(e);
        }
    }

    /// One sample: set the input, one step, read the output (and flags).
    pub(crate) fn sample(
        &self,
        i: &mut FmuInstance,
        x: f64,
    ) -> Result<(f64, bool, bool), ImportError> {
        let b = &self.bindings;
        i.set_f64(b.input, x)?;
        i.do_step(self.sample_time)?;
        let out = i.get_f64(b.output)?;
        let saturated = match b.saturated {
            Some(vr) => i.get_bool(vr)?,
            None => false,
        };
        let fault = match b.fault {
            Some(vr) => i.get_bool(vr)?,
            None => false,
        };
        Ok((out, saturated, fault))
    }
}

/// A saved FMU state: its index in the instance and the time.
struct SavedFmuState(usize, f64);

/// The shared body of the adapters.
struct Adapter {
    candidate: FmuCandidate,
    instance: Option<FmuInstance>,
}

impl Adapter {
    fn new(candidate: &FmuCandidate, limits: Option<(f64, f64)>) -> Result<Self, ImportError> {
        let instance = candidate.instance(limits)?;
        Ok(Self {
            candidate: candidate.clone(),
            instance: Some(instance),
        })
    }

    /// NaN outputs after an error (and the error noted): every property
    /// comparing them then fails.
    fn sample(&mut self, x: f64) -> (f64, bool, bool) {
        let Some(i) = self.instance.as_mut() else {
            return (f64::NAN, false, false);
        };
        match self.candidate.sample(i, x) {
            Ok(r) => r,
            Err(e) => {
                self.candidate.note(e);
                self.instance = None;
                (f64::NAN, false, false)
            }
        }
    }

    fn save(&mut self) -> Option<SavedState> {
        if !self.candidate.fmu.description.can_get_and_set_state {
            return None;
        }
        let i = self.instance.as_mut()?;
        let t = i.time();
        match i.save() {
            Ok(k) => Some(SavedState(Box::new(SavedFmuState(k, t)))),
            Err(e) => {
                self.candidate.note(e);
                None
            }
        }
    }

    fn restore(&mut self, state: &SavedState) -> bool {
        let (Some(i), Some(s)) = (
            self.instance.as_mut(),
            state.0.downcast_ref::<SavedFmuState>(),
        ) else {
            return false;
        };
        match i.restore(s.0, s.1) {
            Ok(()) => true,
            Err(e) => {
                self.candidate.note(e);
                false
            }
        }
    }

    fn reset(&mut self, limits: Option<(f64, f64)>) {
        self.instance = None;
        match self.candidate.instance(limits) {
            Ok(i) => self.instance = Some(i),
            Err(e) => self.candidate.note(e),
        }
    }
}

/// An FMU as a single-input single-output operator of kind `$kind`.
macro_rules! fmu_operator {
    ($(#[$doc:meta])* $name:ident: $kind:ident) => {
        $(#[$doc])*
        pub struct $name(Adapter);

        impl $name {
            pub fn new(candidate: &FmuCandidate) -> Result<Self, ImportError> {
                Adapter::new(candidate, None).map(Self)
            }
        }

        impl Operator for $name {
            fn step(&mut self, x: f64) -> f64 {
                self.0.sample(x).0
            }
            fn reset(&mut self) {
                self.0.reset(None);
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

fmu_operator!(
    /// `W` (or `H`) of an FMU.
    FmuModel: ActuatorModel
);
fmu_operator!(
    /// `H⁻¹` of an FMU.
    FmuInverseHysteresis: InverseHysteresis
);

/// `W⁻¹` of an FMU: per sample, the memory part's inverse (the FMU cannot
/// preview; `compensate_all` previews by `delay`).
pub struct FmuCompensator {
    adapter: Adapter,
    limits: Option<(f64, f64)>,
    delay: usize,
}

impl FmuCompensator {
    /// An instance with `limits` (`None`: the FMU's own).
    pub fn new(
        candidate: &FmuCandidate,
        limits: Option<(f64, f64)>,
        delay: usize,
    ) -> Result<Self, ImportError> {
        Ok(Self {
            adapter: Adapter::new(candidate, limits)?,
            limits,
            delay,
        })
    }
}

impl ActuatorCompensator for FmuCompensator {
    fn compensate(&mut self, target: f64) -> Compensated {
        let (u, saturated, fault) = self.adapter.sample(target);
        Compensated {
            u,
            saturated,
            fault,
        }
    }
    fn reset(&mut self) {
        self.adapter.reset(self.limits);
    }
    fn delay(&self) -> usize {
        self.delay
    }
    fn save_state(&mut self) -> Option<SavedState> {
        self.adapter.save()
    }
    fn restore_state(&mut self, state: &SavedState) -> bool {
        self.adapter.restore(state)
    }
}
