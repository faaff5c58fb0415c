//! The compensator's own unit test: which layouts take the step compiled
//! for the paper's.
use super::*;
use crate::realtime::parameters::{CreepParameters, HysteresisParameters};
use crate::realtime::simd::StepSource;
use crate::realtime::{nominal, Inline};

/// The paper's layout is recognised exactly: 12 plays and creep of 12
/// thresholds × 5 eigenvalues, not one play, threshold or eigenvalue
/// more or less, nor without creep.
#[test]
fn the_paper_layout_is_recognised_exactly() {
    type C = Compensator<f64, Inline<13, 78>>;
    let settings = CompensatorSettings::default();
    let p = nominal::PARAMETERS;
    let (h, c) = (p.hysteresis, p.creep.unwrap());
    // the paper's layout and one more of each
    let plays_r = [h.thresholds, &[h.thresholds[11] + 10.0]].concat();
    let plays_w = [h.weights, &[0.01]].concat();
    let creep_r = [c.thresholds, &[c.thresholds[11] + 10.0]].concat();
    let creep_w = [c.weights, &[0.0]].concat();
    let creep_a = [c.eigenvalues, &[0.01]].concat();
    let is_paper = |plays: usize, creep: Option<(usize, usize)>| {
        let parameters = ModelParameters {
            hysteresis: HysteresisParameters {
                thresholds: &plays_r[..plays],
                weights: &plays_w[..plays],
            },
            creep: creep.map(|(n, m)| CreepParameters {
                thresholds: &creep_r[..n],
                weights: &creep_w[..n],
                eigenvalues: &creep_a[..m],
            }),
            ..p
        };
        C::new(&parameters.validate().unwrap(), settings)
            .unwrap()
            .paper_layout()
    };
    assert!(is_paper(12, Some((12, 5))));
    for (plays, creep) in [
        (11, Some((12, 5))),
        (13, Some((12, 5))),
        (12, Some((11, 5))),
        (12, Some((13, 5))),
        (12, Some((12, 4))),
        (12, Some((12, 6))),
        (12, None),
    ] {
        assert!(!is_paper(plays, creep), "{plays} plays, creep {creep:?}");
    }
}
