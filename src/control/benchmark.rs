//! The closed-loop benchmark: the paper's Fig. 14 move (1 mm in 75 ms from
//! 2.9 s, σ = 1.1) on the nominal models, in five scenarios every
//! controller runs (`docs/MATHEMATICS.md` §11.3):
//!
//! | id | what differs from Fig. 14 |
//! |---|---|
//! | `nominal` | nothing |
//! | `impulse` | tip impulses of [`IMPULSE`] at 2.93 s (during the move) and 3.1 s (after) |
//! | `step-load` | a tip force of [`STEP_LOAD`] from 3.2 s |
//! | `model-error` | the true `W` has its hysteresis weights × 1.1 and its creep weights × 1.3 |
//!
//! The controller's model, the true `W` and the beam can be others
//! ([`Benchmark::new`], [`Benchmark::with_plant`]); the scenarios then apply
//! to them (the model error scales the true `W`).
//! | `noise` | Gaussian sensor noise of [`NOISE`] rms (seeded) |
//!
//! The disturbances are sized to the stroke: the impulse makes the first
//! mode ring at about 0.1 mm, the load deflects the tip by about 0.15 mm.

use super::file::{ControllerDesign, ControllerFile};
use super::pid::{PidGains, PidSettings};
use super::state_feedback::{StateFeedbackDesign, StateFeedbackSettings};
use super::{
    run_loop, score, ControlError, Controller, LoopSetup, LoopTrace, Scores, ZeroController,
};
use crate::beam::modal::ModalModel;
use crate::beam::step_response_fit::{modal_model, BeamModelKind};
use crate::beam::BeamParameters;
use crate::feedforward::{design, Feedforward, FeedforwardSettings, FlatParametrization};
use crate::operators::model::HysteresisCreepModel;
use crate::operators::nominal::nominal_model;
use crate::operators::supply::Supply;

/// Tip impulse (N·s), one sample of `IMPULSE/T_s`.
pub const IMPULSE: f64 = 5e-5;
/// When the impulses hit (s).
pub const IMPULSE_TIMES: [f64; 2] = [2.93, 3.1];
/// Tip step load (N).
pub const STEP_LOAD: f64 = 5e-3;
/// When the load is applied (s).
pub const STEP_LOAD_TIME: f64 = 3.2;
/// Sensor noise standard deviation (m).
pub const NOISE: f64 = 1e-6;
/// Seed of the sensor noise.
pub const NOISE_SEED: u64 = 2011;
/// The model error: factors on the true `W`'s hysteresis and creep weights.
pub const MODEL_ERROR: (f64, f64) = (1.1, 1.3);

/// A scenario of the benchmark.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BenchmarkScenario {
    pub id: &'static str,
    pub description: &'static str,
}

/// Every scenario, in order.
pub const BENCHMARK_SCENARIOS: [BenchmarkScenario; 5] = [
    BenchmarkScenario {
        id: "nominal",
        description: "Fig. 14 as in the paper",
    },
    BenchmarkScenario {
        id: "impulse",
        description: "tip impulses of 5e-5 N s at 2.93 s and 3.1 s",
    },
    BenchmarkScenario {
        id: "step-load",
        description: "a tip load of 5 mN from 3.2 s",
    },
    BenchmarkScenario {
        id: "model-error",
        description: "true W: hysteresis weights x 1.1, creep weights x 1.3",
    },
    BenchmarkScenario {
        id: "noise",
        description: "sensor noise 1 um rms",
    },
];

/// The built-in controllers.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BuiltinController {
    /// `Δ = 0`: the open loop.
    Open,
    /// The filtered PID ([`super::pid`]).
    Pid,
    /// LQ with a Kalman observer ([`super::state_feedback`]).
    StateFeedback,
}

impl BuiltinController {
    /// All of them, in the order of the score table.
    pub const ALL: [BuiltinController; 3] = [Self::Open, Self::Pid, Self::StateFeedback];

    /// The name on the command line: `open`, `pid`, `lq`.
    pub fn id(&self) -> &'static str {
        match self {
            Self::Open => "open",
            Self::Pid => "pid",
            Self::StateFeedback => "lq",
        }
    }

    /// By its command-line name.
    pub fn from_id(id: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|c| c.id() == id)
    }
}

/// The nominal plant, beam and Fig. 14 feedforward the scenarios share.
#[derive(Debug, Clone)]
pub struct Benchmark {
    /// The model whose `W⁻¹` the controller uses.
    pub model: HysteresisCreepModel,
    /// The true actuator `W` (the same as `model` unless set apart).
    pub plant: HysteresisCreepModel,
    pub beam: ModalModel,
    pub settings: FeedforwardSettings,
    pub feedforward: Feedforward,
    pub supply: Supply,
}

/// One controller's run of one scenario.
#[derive(Debug, Clone)]
pub struct BenchmarkRun {
    pub scenario: BenchmarkScenario,
    pub controller: String,
    pub trace: LoopTrace,
    pub scores: Scores,
}

impl Benchmark {
    /// The nominal models and the paper's move.
    pub fn nominal() -> Result<Self, ControlError> {
        let beam = modal_model(&BeamParameters::nominal(), BeamModelKind::default())?;
        Self::new(nominal_model(), beam)
    }

    /// The paper's move on `model` and `beam`.
    pub fn new(model: HysteresisCreepModel, beam: ModalModel) -> Result<Self, ControlError> {
        let settings = FeedforwardSettings::default();
        let feedforward = design(&FlatParametrization::new(&beam)?, &settings)?;
        Ok(Self {
            plant: model.clone(),
            model,
            beam,
            settings,
            feedforward,
            supply: Supply::default(),
        })
    }

    /// The same with another true actuator `W` (its sample time must be
    /// the benchmark's; checked when a loop runs).
    pub fn with_plant(mut self, plant: HysteresisCreepModel) -> Self {
        self.plant = plant;
        self
    }

    /// The transition `[t₀, t₀ + T)` (s).
    pub fn transition(&self) -> (f64, f64) {
        (
            self.settings.start,
            self.settings.start + self.settings.duration,
        )
    }

    /// A scenario by id.
    pub fn scenario(id: &str) -> Result<BenchmarkScenario, ControlError> {
        BENCHMARK_SCENARIOS
            .into_iter()
            .find(|s| s.id == id)
            .ok_or_else(|| ControlError::Invalid {
                field: "scenario",
                reason: format!(
                    "'{id}' is not one of {}",
                    BENCHMARK_SCENARIOS.map(|s| s.id).join(", ")
                ),
            })
    }

    /// The loop of scenario `id`.
    pub fn setup(&self, id: &str) -> Result<LoopSetup, ControlError> {
        let scenario = Self::scenario(id)?;
        let ts = self.settings.sample_time;
        let n = self.feedforward.t.len();
        let mut setup = LoopSetup {
            plant: self.plant.clone(),
            model: self.model.clone(),
            beam: self.beam.clone(),
            sample_time: ts,
            reference: self.feedforward.y_d.clone(),
            feedforward: self.feedforward.u_d.clone(),
            force: vec![0.0; n],
            noise: vec![0.0; n],
            supply: self.supply,
        };
        let index = |t: f64| ((t / ts).round() as usize).min(n.saturating_sub(1));
        match scenario.id {
            "impulse" => {
                for t in IMPULSE_TIMES {
                    setup.force[index(t)] = IMPULSE / ts;
                }
            }
            "step-load" => setup.force[index(STEP_LOAD_TIME)..].fill(STEP_LOAD),
            "model-error" => {
                let mut file = self.plant.to_file();
                file.hysteresis
                    .weights
                    .iter_mut()
                    .for_each(|w| *w *= MODEL_ERROR.0);
                if let Some(c) = file.creep.as_mut() {
                    c.weights.iter_mut().for_each(|w| *w *= MODEL_ERROR.1);
                }
                setup.plant = HysteresisCreepModel::from_file(&file)?;
            }
            "noise" => setup.noise = gaussian_noise(n, NOISE, NOISE_SEED),
            _ => {}
        }
        Ok(setup)
    }

    /// A built-in controller designed for the nominal models (it never sees
    /// the scenario).
    pub fn controller(&self, kind: BuiltinController) -> Result<Box<dyn Controller>, ControlError> {
        Ok(match kind {
            BuiltinController::Open => Box::new(ZeroController),
            _ => Box::new(self.controller_file(kind)?.build()?),
        })
    }

    /// A built-in design as a controller file (what its FMU carries); the
    /// open loop has none.
    pub fn controller_file(&self, kind: BuiltinController) -> Result<ControllerFile, ControlError> {
        let ts = self.settings.sample_time;
        let design = match kind {
            BuiltinController::Open => {
                return Err(ControlError::Invalid {
                    field: "controller",
                    reason: "the open loop is no design".into(),
                })
            }
            BuiltinController::Pid => {
                ControllerDesign::Pid(PidGains::design(&self.beam, &PidSettings::default())?)
            }
            BuiltinController::StateFeedback => {
                let (_, hi) = self.supply.balanced_limits();
                let settings = StateFeedbackSettings {
                    voltage_limit: hi,
                    ..StateFeedbackSettings::default()
                };
                ControllerDesign::StateFeedback(StateFeedbackDesign::design(
                    &self.beam,
                    ts,
                    &self.feedforward.y_d,
                    &self.feedforward.u_d,
                    &settings,
                )?)
            }
        };
        Ok(ControllerFile {
            sample_time: ts,
            design,
        })
    }

    /// Run scenario `id` with `controller` and score it.
    pub fn run(
        &self,
        id: &str,
        controller: &mut dyn Controller,
    ) -> Result<BenchmarkRun, ControlError> {
        let scenario = Self::scenario(id)?;
        let trace = run_loop(&self.setup(id)?, controller)?;
        let (start, end) = self.transition();
        Ok(BenchmarkRun {
            scenario,
            controller: controller.name(),
            scores: score(&trace, start, end),
            trace,
        })
    }
}

/// `n` samples of zero-mean Gaussian noise of standard deviation `sigma`:
/// SplitMix64 uniforms (53 bits), Box–Muller pairs. Deterministic in
/// `seed` on every platform.
pub fn gaussian_noise(n: usize, sigma: f64, seed: u64) -> Vec<f64> {
    let mut state = seed;
    let mut uniform = || {
        state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        ((z >> 11) as f64 + 0.5) / (1u64 << 53) as f64 // in (0, 1)
    };
    let mut out = Vec::with_capacity(n);
    while out.len() < n {
        let (a, b) = (uniform(), uniform());
        let r = sigma * (-2.0 * a.ln()).sqrt();
        let phase = 2.0 * std::f64::consts::PI * b;
        out.push(r * phase.cos());
        if out.len() < n {
            out.push(r * phase.sin());
        }
    }
    out
}
