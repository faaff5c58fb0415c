//! The MFC-actuated cantilever, equations (26)–(27): parameters, the beam file
//! of `docs/FILES.md`, and the piecewise coefficients of the patched beam.
//!
//! ```text
//! μ ∂²w/∂t² + γ_e ∂w/∂t + ∂²/∂x² ( Λ ∂²w/∂x² + γ_i ∂³w/∂t∂x² ) = 2 u Γ_p ∂²Ω/∂x²
//! μ = A_c ρ_c + 2 A_p ρ_p Ω,  Λ = Λ_c + 2 Λ_p Ω,  γ_e = γ_e,c + 2 γ_e,p Ω,  γ_i = γ_i,c + 2 γ_i,p Ω
//! A_c = b_c h_c,  A_p = b_p h_p,  Λ_c = Y_c b_c h_c³/12,  Λ_p = c_p b_p ((h_c/2 + h_p)³ − (h_c/2)³)/3
//! ```
//!
//! clamped at `x = 0`, free at `x = L`, one patch pair on `[x_p, x_p + L_p]`.
//! `u` is the effective voltage `W[u_balanced]`. The input acts as a pair of
//! opposite bending moments `2 Γ_p u` at the patch ends.

use serde::{Deserialize, Serialize};
use thiserror::Error;

/// A beam parameter that is out of range.
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum BeamError {
    /// A parameter is NaN, infinite, or out of its range.
    #[error("{field}: {reason}, found {value}")]
    InvalidParameter {
        field: &'static str,
        value: f64,
        reason: &'static str,
    },
    /// The patch does not lie on the beam.
    #[error("patch: [{start}, {end}] must lie inside (0, {length}) m")]
    PatchOutside { start: f64, end: f64, length: f64 },
    /// A discretization setting is out of range.
    #[error("{field}: {reason}")]
    InvalidSetting { field: &'static str, reason: String },
    /// A numerical step failed (should not happen for valid parameters).
    #[error("{0}")]
    Numerical(String),
}

/// The patch pair part of a beam file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PatchData {
    /// `x_p` (m).
    pub start: f64,
    /// `L_p` (m).
    pub length: f64,
    /// `b_p` (m).
    pub width: f64,
    /// `h_p` (m); 0 for a uniform beam.
    pub thickness: f64,
    /// `ρ_p` (kg/m³).
    pub density: f64,
    /// `c_p` (Pa).
    pub stiffness: f64,
    /// `γ_e,p` (kg/(s m)).
    pub viscous_damping: f64,
    /// `γ_i,p` (kg m³/s).
    pub kelvin_voigt_damping: f64,
    /// `Γ_p` (N m/V).
    pub input_gain: f64,
}

/// A beam file (JSON, SI units), see `docs/FILES.md`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BeamParameters {
    /// `L` (m).
    pub length: f64,
    /// `b_c` (m).
    pub width: f64,
    /// `h_c` (m).
    pub thickness: f64,
    /// `ρ_c` (kg/m³).
    pub density: f64,
    /// `Y_c` (Pa).
    pub youngs_modulus: f64,
    /// `γ_e,c` (kg/(s m)).
    pub viscous_damping: f64,
    /// `γ_i,c` (kg m³/s).
    pub kelvin_voigt_damping: f64,
    pub patch: PatchData,
    /// `n`, the number of basis functions or modes (default 15).
    #[serde(default = "default_basis")]
    pub basis_functions: usize,
}

fn default_basis() -> usize {
    15
}

/// Coefficients `μ, Λ, γ_e, γ_i` of one uniform stretch of the beam.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SectionCoefficients {
    /// Mass per length `μ` (kg/m).
    pub mass: f64,
    /// Bending stiffness `Λ` (N m²).
    pub stiffness: f64,
    /// Viscous damping `γ_e`.
    pub viscous: f64,
    /// Kelvin–Voigt damping `γ_i`.
    pub kelvin_voigt: f64,
}

/// A stretch `[start, end]` of constant coefficients.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Segment {
    pub start: f64,
    pub end: f64,
    pub coefficients: SectionCoefficients,
}

impl BeamParameters {
    /// The nominal beam (`docs/MATHEMATICS.md` §8) (f₁ ≈ 12 Hz).
    pub fn nominal() -> Self {
        Self {
            length: 0.22,
            width: 0.075,
            thickness: 0.75e-3,
            density: 1900.0,
            youngs_modulus: 22e9,
            viscous_damping: 1e-3,
            kelvin_voigt_damping: 1e-6,
            patch: PatchData {
                start: 0.015,
                length: 0.085,
                width: 0.057,
                thickness: 0.3e-3,
                density: 5440.0,
                stiffness: 25e9,
                viscous_damping: 2.93,
                kelvin_voigt_damping: 1e-6,
                input_gain: 8.7e-5,
            },
            basis_functions: 15,
        }
    }

    /// Every parameter finite and in range, the patch on the beam, `n ≥ 1`.
    pub fn validate(&self) -> Result<(), BeamError> {
        let positive: [(&'static str, f64); 6] = [
            ("length", self.length),
            ("width", self.width),
            ("thickness", self.thickness),
            ("density", self.density),
            ("youngs_modulus", self.youngs_modulus),
            ("patch.length", self.patch.length),
        ];
        for (field, value) in positive {
            if !(value.is_finite() && value > 0.0) {
                return Err(BeamError::InvalidParameter {
                    field,
                    value,
                    reason: "must be a finite number > 0",
                });
            }
        }
        let non_negative: [(&'static str, f64); 10] = [
            ("viscous_damping", self.viscous_damping),
            ("kelvin_voigt_damping", self.kelvin_voigt_damping),
            ("patch.start", self.patch.start),
            ("patch.width", self.patch.width),
            ("patch.thickness", self.patch.thickness),
            ("patch.density", self.patch.density),
            ("patch.stiffness", self.patch.stiffness),
            ("patch.viscous_damping", self.patch.viscous_damping),
            (
                "patch.kelvin_voigt_damping",
                self.patch.kelvin_voigt_damping,
            ),
            ("patch.input_gain", self.patch.input_gain.abs()),
        ];
        for (field, value) in non_negative {
            if !(value.is_finite() && value >= 0.0) {
                return Err(BeamError::InvalidParameter {
                    field,
                    value,
                    reason: "must be a finite number >= 0",
                });
            }
        }
        let end = self.patch.start + self.patch.length;
        if !(self.patch.start > 0.0 && end < self.length) {
            return Err(BeamError::PatchOutside {
                start: self.patch.start,
                end,
                length: self.length,
            });
        }
        if self.basis_functions == 0 {
            return Err(BeamError::InvalidSetting {
                field: "basis_functions",
                reason: "must be at least 1".into(),
            });
        }
        crate::realtime::limits::check(
            "basis_functions",
            crate::realtime::limits::MAX_BASIS_FUNCTIONS,
            self.basis_functions,
        )
        .map_err(|e| BeamError::InvalidSetting {
            field: "basis_functions",
            reason: e.reason(),
        })?;
        Ok(())
    }

    /// `Λ_c = Y_c b_c h_c³ / 12`.
    pub fn core_stiffness(&self) -> f64 {
        self.youngs_modulus * self.width * self.thickness.powi(3) / 12.0
    }

    /// `Λ_p = c_p b_p ((h_c/2 + h_p)³ − (h_c/2)³) / 3` (one patch).
    pub fn patch_stiffness(&self) -> f64 {
        let a = 0.5 * self.thickness;
        let b = a + self.patch.thickness;
        // b³ − a³ = (b − a)(b² + ab + a²), free of cancellation for thin patches
        self.patch.stiffness * self.patch.width * (self.patch.thickness * (b * b + a * b + a * a))
            / 3.0
    }

    /// Coefficients off the patch (`Ω = 0`).
    pub fn bare(&self) -> SectionCoefficients {
        SectionCoefficients {
            mass: self.width * self.thickness * self.density,
            stiffness: self.core_stiffness(),
            viscous: self.viscous_damping,
            kelvin_voigt: self.kelvin_voigt_damping,
        }
    }

    /// Coefficients on the patch (`Ω = 1`).
    pub fn patched(&self) -> SectionCoefficients {
        let bare = self.bare();
        SectionCoefficients {
            mass: bare.mass + 2.0 * self.patch.width * self.patch.thickness * self.patch.density,
            stiffness: bare.stiffness + 2.0 * self.patch_stiffness(),
            viscous: bare.viscous + 2.0 * self.patch.viscous_damping,
            kelvin_voigt: bare.kelvin_voigt + 2.0 * self.patch.kelvin_voigt_damping,
        }
    }

    /// The three stretches `[0, x_p]`, `[x_p, x_p + L_p]`, `[x_p + L_p, L]`.
    pub fn segments(&self) -> [Segment; 3] {
        let (xp, xe) = (self.patch.start, self.patch.start + self.patch.length);
        [
            Segment {
                start: 0.0,
                end: xp,
                coefficients: self.bare(),
            },
            Segment {
                start: xp,
                end: xe,
                coefficients: self.patched(),
            },
            Segment {
                start: xe,
                end: self.length,
                coefficients: self.bare(),
            },
        ]
    }

    /// `2 Γ_p`: the bending moment per effective volt at each patch end.
    pub fn moment_per_volt(&self) -> f64 {
        2.0 * self.patch.input_gain
    }

    /// The exact static tip deflection per effective volt:
    /// `w(L) = κ L_p (L − x_p − L_p/2)`, `κ = 2 Γ_p / (Λ_c + 2 Λ_p)`.
    pub fn exact_static_gain(&self) -> f64 {
        let kappa = self.moment_per_volt() / self.patched().stiffness;
        kappa * self.patch.length * (self.length - self.patch.start - 0.5 * self.patch.length)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nominal_beam_is_valid_and_its_file_round_trips() {
        let b = BeamParameters::nominal();
        b.validate().unwrap();
        let text = serde_json::to_string(&b).unwrap();
        let back: BeamParameters = serde_json::from_str(&text).unwrap();
        assert_eq!(back, b);
    }

    #[test]
    fn patch_stiffness_matches_the_literal_formula() {
        let b = BeamParameters::nominal();
        let (hc, hp) = (b.thickness, b.patch.thickness);
        let literal =
            b.patch.stiffness * b.patch.width * ((hc / 2.0 + hp).powi(3) - (hc / 2.0).powi(3))
                / 3.0;
        assert!((b.patch_stiffness() - literal).abs() <= 1e-14 * literal);
    }

    #[test]
    fn invalid_parameters_are_named() {
        let mut b = BeamParameters::nominal();
        b.youngs_modulus = -1.0;
        assert!(b
            .validate()
            .unwrap_err()
            .to_string()
            .starts_with("youngs_modulus"));
        let mut b = BeamParameters::nominal();
        b.patch.start = 0.2;
        assert!(matches!(b.validate(), Err(BeamError::PatchOutside { .. })));
    }
}
