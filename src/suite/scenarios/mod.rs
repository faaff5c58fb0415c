//! The paper's scenarios (SPEC section 9), each a deterministic function of
//! the nominal models (SPEC section 8) that produces one trace: the inputs
//! and every intermediate signal.
//!
//! | id | paper | what it shows |
//! |---|---|---|
//! | `rectangle` | Fig. 2 | creep after a 500 V step held 40 s, remanent offset |
//! | `staircase` | Fig. 3 | hysteresis loop over the full range, creep at each step |
//! | `minor-loops` | Fig. 8a | nested reversals: Madelung rules, Masing congruence |
//! | `intersection` | Fig. 8b | three histories reaching one point, different slopes |
//! | `log-creep` | Fig. 9 | long plateaus: creep linear in log t |
//! | `identification` | Sec. 4.1 | shrinking periodic staircase and the identified fit |
//! | `compensated` | Fig. 10 | the staircase through `W⁻¹` then `W`: linear |
//! | `step` | Figs. 12–13 | a step through the beam with and without compensation |
//! | `feedforward` | Fig. 14 | rest-to-rest move through compensator, `W` and beam |
//!
//! Every scenario runs at the full 5 kHz; long ones keep every `k`-th row
//! (`decimation`) in the golden files and are compared at those rows.
//! The plant's `W` is pluggable ([`ScenarioContext::plant`]) so that an
//! alternative or deliberately faulty implementation can be run through the
//! same scenarios and compared against the golden traces.

use crate::beam::modal::ModalModel;
use crate::beam::simulation::DiscreteBeam;
use crate::beam::step_response_fit::{modal_model, BeamModelKind};
use crate::beam::BeamParameters;
use crate::feedforward::{compensate, design, FeedforwardSettings, FlatParametrization};
use crate::identification::{identify, IdentificationSettings};
use crate::operators::compensator::{Compensator, CompensatorSettings};
use crate::operators::model::HysteresisCreepModel;
use crate::operators::nominal::{nominal_model, SAMPLE_TIME};
use crate::operators::supply::Supply;
use crate::operators::traits::Operator;
use crate::suite::signal::Staircase;

/// One sample in, one sample out: any `W` a scenario can drive.
pub trait Siso {
    fn step(&mut self, v: f64) -> f64;
}

impl<T: Operator> Siso for T {
    fn step(&mut self, v: f64) -> f64 {
        Operator::step(self, v)
    }
}

/// Builds the plant's `W` from a model.
pub type PlantFactory = Box<dyn Fn(&HysteresisCreepModel) -> Box<dyn Siso>>;

/// The models a scenario runs on.
pub struct ScenarioContext {
    /// The hysteresis and creep model (compensator and plant).
    pub model: HysteresisCreepModel,
    /// The beam.
    pub beam: BeamParameters,
    /// Its `modal` model (240 elements → 15 modes).
    pub modal: ModalModel,
    /// How the plant's `W` is built (default: the model itself).
    pub plant: PlantFactory,
}

impl ScenarioContext {
    /// The nominal models of SPEC section 8.
    pub fn nominal() -> Self {
        let beam = BeamParameters::nominal();
        let modal = modal_model(&beam, BeamModelKind::default()).expect("nominal beam is valid");
        Self {
            model: nominal_model(),
            beam,
            modal,
            plant: Box::new(|m| Box::new(m.clone())),
        }
    }

    fn plant_w(&self) -> Box<dyn Siso> {
        (self.plant)(&self.model)
    }

    fn beam(&self) -> DiscreteBeam {
        DiscreteBeam::new(&self.modal, SAMPLE_TIME).expect("nominal beam discretizes")
    }
}

/// A scenario's description.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Scenario {
    pub id: &'static str,
    pub paper: &'static str,
    pub description: &'static str,
    /// Keep every `decimation`-th row in the golden file.
    pub decimation: usize,
}

/// Every scenario of SPEC section 9.
pub const SCENARIOS: [Scenario; 9] = [
    Scenario { id: "rectangle", paper: "Fig. 2", description: "u = 500 V on [5, 45) s, else 0, 90 s: creep after the step, remanent offset", decimation: 50 },
    Scenario { id: "staircase", paper: "Fig. 3", description: "smooth staircase over the full range [-1000, 1000] V: hysteresis loop with creep at each step", decimation: 20 },
    Scenario { id: "minor-loops", paper: "Fig. 8a", description: "nested reversals inside the major loop: Madelung rules, Masing congruence", decimation: 10 },
    Scenario { id: "intersection", paper: "Fig. 8b", description: "three histories of H reaching one point with the input increasing", decimation: 10 },
    Scenario { id: "log-creep", paper: "Fig. 9", description: "smooth staircase with 20 s plateaus: creep linear in log t", decimation: 50 },
    Scenario { id: "identification", paper: "Sec. 4.1", description: "periodic staircase shrinking each period, 40 s, and the identified model's fit", decimation: 20 },
    Scenario { id: "compensated", paper: "Fig. 10", description: "the staircase of Fig. 3 (as desired effective voltage) through W^-1 then W and the beam", decimation: 20 },
    Scenario { id: "step", paper: "Figs. 12-13", description: "a 100 V step at 1 s held 44 s through the beam, without and with compensation", decimation: 25 },
    Scenario { id: "feedforward", paper: "Fig. 14", description: "1 mm in 75 ms from 2.9 s (sigma 1.1) through compensator, W and beam", decimation: 1 },
];

/// Look a scenario up by id.
pub fn scenario(id: &str) -> Option<&'static Scenario> {
    SCENARIOS.iter().find(|s| s.id == id)
}

/// A computed scenario: named columns at the full sample rate.
#[derive(Debug, Clone, PartialEq)]
pub struct ScenarioTrace {
    pub columns: Vec<(&'static str, Vec<f64>)>,
}

impl ScenarioTrace {
    /// A column by name.
    pub fn column(&self, name: &str) -> Option<&[f64]> {
        self.columns
            .iter()
            .find(|c| c.0 == name)
            .map(|c| c.1.as_slice())
    }

    /// Number of rows.
    pub fn len(&self) -> usize {
        self.columns.first().map_or(0, |c| c.1.len())
    }

    /// Whether there are no rows.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Every `k`-th row, starting with the first.
    pub fn decimated(&self, k: usize) -> ScenarioTrace {
        ScenarioTrace {
            columns: self
                .columns
                .iter()
                .map(|(n, v)| (*n, v.iter().step_by(k.max(1)).copied().collect()))
                .collect(),
        }
    }
}

fn time(len: usize) -> Vec<f64> {
    (0..len).map(|k| k as f64 * SAMPLE_TIME).collect()
}

fn samples(duration: f64) -> usize {
    (duration / SAMPLE_TIME).round() as usize + 1
}

/// Piecewise-linear path through `points` from 0 at `rate` V/s.
fn ramps(points: &[f64], rate: f64) -> Vec<f64> {
    let mut out = vec![0.0];
    let mut last = 0.0;
    for &p in points {
        let n = (((p - last).abs() / rate) / SAMPLE_TIME).ceil().max(1.0) as usize;
        for j in 1..=n {
            out.push(if j == n {
                p
            } else {
                last + (p - last) * j as f64 / n as f64
            });
        }
        last = p;
    }
    out
}

/// The staircase input of Fig. 3 (and, as a target, of Fig. 10).
pub fn fig3_staircase(amplitude: f64) -> Vec<f64> {
    Staircase::full_loop(amplitude, 4, 0.2, 1.8).sample(SAMPLE_TIME)
}

/// Run one scenario at the full sample rate.
pub fn run(id: &str, ctx: &ScenarioContext) -> Option<ScenarioTrace> {
    let trace = match id {
        "rectangle" => {
            let n = samples(90.0);
            let u: Vec<f64> = (0..n)
                .map(|k| {
                    let t = k as f64 * SAMPLE_TIME;
                    if (5.0..45.0).contains(&t) {
                        500.0
                    } else {
                        0.0
                    }
                })
                .collect();
            let w = run_siso(ctx.plant_w().as_mut(), &u);
            let tip = ctx.beam().simulate(&w);
            ScenarioTrace {
                columns: vec![("t", time(n)), ("u", u), ("w", w), ("tip", tip)],
            }
        }
        "staircase" => {
            let u = fig3_staircase(1000.0);
            let w = run_siso(ctx.plant_w().as_mut(), &u);
            let h = ctx.model.hysteresis().clone().run(&u);
            let tip = ctx.beam().simulate(&w);
            ScenarioTrace {
                columns: vec![
                    ("t", time(u.len())),
                    ("u", u),
                    ("w", w),
                    ("h", h),
                    ("tip", tip),
                ],
            }
        }
        "minor-loops" => {
            let u = ramps(
                &[
                    900.0, -900.0, 600.0, -300.0, 400.0, 0.0, 300.0, -300.0, 400.0, 0.0, 300.0,
                    -900.0, 900.0,
                ],
                400.0,
            );
            let w = run_siso(ctx.plant_w().as_mut(), &u);
            let h = ctx.model.hysteresis().clone().run(&u);
            ScenarioTrace {
                columns: vec![("t", time(u.len())), ("u", u), ("w", w), ("h", h)],
            }
        }
        "intersection" => {
            // virgin curve to 200 V; and branches rising from reversals on the
            // descending branches from 1000 V and 900 V that cross it at 200 V
            let paths = [
                ramps(&[300.0], 400.0),
                ramps(&[1000.0, -483.5, 300.0], 400.0),
                ramps(&[900.0, -465.7, 300.0], 400.0),
            ];
            let n = paths.iter().map(Vec::len).max().unwrap_or(0);
            let mut columns = vec![("t", time(n))];
            let names = [("u_a", "h_a"), ("u_b", "h_b"), ("u_c", "h_c")];
            for (p, (un, hn)) in paths.iter().zip(names) {
                let mut u = p.clone();
                let last = *u.last().unwrap();
                u.resize(n, last); // hold the end value
                let h = ctx.model.hysteresis().clone().run(&u);
                columns.push((un, u));
                columns.push((hn, h));
            }
            ScenarioTrace { columns }
        }
        "log-creep" => {
            let s = Staircase {
                start: 0.0,
                levels: vec![200.0, 400.0, 600.0, 300.0, 0.0, -400.0],
                rise: 0.1,
                plateau: 19.9,
            };
            let u = s.sample(SAMPLE_TIME);
            let w = run_siso(ctx.plant_w().as_mut(), &u);
            let c = ctx
                .model
                .creep()
                .map(|c| c.clone().run(&u))
                .unwrap_or(vec![0.0; u.len()]);
            ScenarioTrace {
                columns: vec![("t", time(u.len())), ("u", u), ("w", w), ("c", c)],
            }
        }
        "identification" => {
            let u = Staircase::shrinking_loops(1000.0, 4, 3, 0.1, 40.0 / 48.0 - 0.1)
                .sample(SAMPLE_TIME);
            let y = run_siso(ctx.plant_w().as_mut(), &u);
            let id = identify(&u, &y, SAMPLE_TIME, &IdentificationSettings::default()).ok()?;
            let fit = id.model.clone().run(&u);
            ScenarioTrace {
                columns: vec![("t", time(u.len())), ("u", u), ("y", y), ("y_fit", fit)],
            }
        }
        "compensated" => {
            let y_d = fig3_staircase(500.0);
            let mut comp = Compensator::new(&ctx.model, CompensatorSettings::default()).ok()?;
            let supply = Supply::default();
            let (mut u, mut sat, mut fs, mut bs) = (vec![], vec![], vec![], vec![]);
            for &t in &y_d {
                let c = comp.compensate(t);
                let (p, _) = supply.patch_voltages_saturating(c.u);
                u.push(c.u);
                sat.push(if c.saturated { 1.0 } else { 0.0 });
                fs.push(p.front);
                bs.push(p.back);
            }
            let y = run_siso(ctx.plant_w().as_mut(), &u);
            let tip = ctx.beam().simulate(&y);
            ScenarioTrace {
                columns: vec![
                    ("t", time(y_d.len())),
                    ("y_d", y_d),
                    ("u", u),
                    ("saturated", sat),
                    ("u_fs", fs),
                    ("u_bs", bs),
                    ("y", y),
                    ("tip", tip),
                ],
            }
        }
        "step" => {
            let n = samples(45.0);
            let v: Vec<f64> = (0..n)
                .map(|k| {
                    if k as f64 * SAMPLE_TIME < 1.0 {
                        0.0
                    } else {
                        100.0
                    }
                })
                .collect();
            // without compensation: the voltage step goes straight to W
            let w_raw = run_siso(ctx.plant_w().as_mut(), &v);
            let tip_raw = ctx.beam().simulate(&w_raw);
            // with: the compensator shapes the voltage so that W gives the step
            let mut comp = Compensator::new(&ctx.model, CompensatorSettings::default()).ok()?;
            let u: Vec<f64> = v.iter().map(|&t| comp.compensate(t).u).collect();
            let w = run_siso(ctx.plant_w().as_mut(), &u);
            let tip = ctx.beam().simulate(&w);
            ScenarioTrace {
                columns: vec![
                    ("t", time(n)),
                    ("v", v),
                    ("w_raw", w_raw),
                    ("tip_raw", tip_raw),
                    ("u", u),
                    ("w", w),
                    ("tip", tip),
                ],
            }
        }
        "feedforward" => {
            let flat = FlatParametrization::new(&ctx.modal).ok()?;
            let ff = design(&flat, &FeedforwardSettings::default()).ok()?;
            let c = compensate(&ff.u_d, &ctx.model, &Supply::default()).ok()?;
            let w = run_siso(ctx.plant_w().as_mut(), &c.u);
            let tip = ctx.beam().simulate(&w);
            ScenarioTrace {
                columns: vec![
                    ("t", ff.t),
                    ("y_d", ff.y_d),
                    ("u_d", ff.u_d),
                    ("u", c.u),
                    ("u_fs", c.u_fs),
                    ("u_bs", c.u_bs),
                    ("w", w),
                    ("tip", tip),
                ],
            }
        }
        _ => return None,
    };
    Some(trace)
}

fn run_siso(op: &mut dyn Siso, u: &[f64]) -> Vec<f64> {
    u.iter().map(|&v| op.step(v)).collect()
}
