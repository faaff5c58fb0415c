//! The asymmetric voltage supply of the patch pair, equation (1).
//!
//! The front and back patches receive `u_fs = ū + u` and `u_bs = ū − u`,
//! `ū = (u_max + u_min)/2`. With the MFC limits `u_min = −500 V`,
//! `u_max = 1500 V` the offset is `ū = 500 V` and the balanced input is limited
//! to `u ∈ [−1000, 1000]` V. Every voltage emitted for a patch lies in
//! `[u_min, u_max]`.

use crate::error::SupplyError;

/// Voltages of the two patches.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PatchVoltages {
    /// Front side patch `u_fs = ū + u`.
    pub front: f64,
    /// Back side patch `u_bs = ū − u`.
    pub back: f64,
}

/// The supply range `[u_min, u_max]` of one patch.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Supply {
    u_min: f64,
    u_max: f64,
}

impl Default for Supply {
    /// The MFC range: `[−500, 1500]` V.
    fn default() -> Self {
        Self {
            u_min: -500.0,
            u_max: 1500.0,
        }
    }
}

impl Supply {
    /// A supply with `u_min < u_max`, both finite.
    pub fn new(u_min: f64, u_max: f64) -> Result<Self, SupplyError> {
        if u_min.is_finite() && u_max.is_finite() && u_min < u_max {
            Ok(Self { u_min, u_max })
        } else {
            Err(SupplyError::InvalidRange { u_min, u_max })
        }
    }

    /// The offset `ū = (u_max + u_min)/2`.
    pub fn offset(&self) -> f64 {
        0.5 * (self.u_max + self.u_min)
    }

    /// The balanced range `[−(u_max − u_min)/2, (u_max − u_min)/2]`.
    pub fn balanced_limits(&self) -> (f64, f64) {
        let half = 0.5 * (self.u_max - self.u_min);
        (-half, half)
    }

    /// `(u_fs, u_bs)` for a balanced `u`; an error if a patch would leave `[u_min, u_max]`.
    pub fn patch_voltages(&self, u: f64) -> Result<PatchVoltages, SupplyError> {
        let (lower, upper) = self.balanced_limits();
        if !(lower..=upper).contains(&u) {
            return Err(SupplyError::OutOfRange { u, lower, upper });
        }
        Ok(self.split(u))
    }

    /// `(u_fs, u_bs)` for `u` clipped to the balanced range, and whether it was clipped.
    pub fn patch_voltages_saturating(&self, u: f64) -> (PatchVoltages, bool) {
        let (lower, upper) = self.balanced_limits();
        let clipped = u.clamp(lower, upper);
        (self.split(clipped), clipped != u)
    }

    fn split(&self, u: f64) -> PatchVoltages {
        let offset = self.offset();
        // Clamp guards the last ulp: ū + u_half may round just past u_max.
        PatchVoltages {
            front: (offset + u).clamp(self.u_min, self.u_max),
            back: (offset - u).clamp(self.u_min, self.u_max),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nominal_supply_splits_balanced_voltage() {
        let s = Supply::default();
        assert_eq!(s.offset(), 500.0);
        assert_eq!(s.balanced_limits(), (-1000.0, 1000.0));
        let p = s.patch_voltages(1000.0).unwrap();
        assert_eq!((p.front, p.back), (1500.0, -500.0));
        let p = s.patch_voltages(-250.0).unwrap();
        assert_eq!((p.front, p.back), (250.0, 750.0));
        assert!(s.patch_voltages(1000.5).is_err());
        let (p, clipped) = s.patch_voltages_saturating(-2000.0);
        assert!(clipped);
        assert_eq!((p.front, p.back), (-500.0, 1500.0));
        assert!(Supply::new(1.0, 1.0).is_err());
    }
}
