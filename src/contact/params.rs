//! The parameters of one contact pair (2021 Sec. 4): the mapping direction's mode (Sec. 4.1,
//! Eq. 2), the relative stiffness, `τ` of Eq. 4 and the safeguard angle of Sec. 4.4.

use super::zones;
use nalgebra::Vector3;

/// How the mapping direction of a pair is chosen (Sec. 4.1).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum DirectionMode {
    /// From the normals over the intersection regions (Eq. 2).
    Automatic,
    /// Set by the user: the direction of side A, outward for A (pointing from A toward B
    /// across the contact). Keyframed directions are sampled by the caller.
    Fixed(Vector3<f64>),
}

/// Parameters of one contact pair.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PairParams {
    /// `k̄_A = k_A / (k_A + k_B)`: A moves `(1 - k̄_A) δ`, B moves `k̄_A δ`.
    pub stiffness_a: f64,
    /// `τ` of Eq. 4 (apparent stiffness: extent of the contact zone).
    pub tau: f64,
    /// The safeguard of Sec. 4.4 in degrees, in `(0, 90]` (checked by the configuration, not
    /// here): a vertex stays out of the contact zone unless its normal is within this angle of
    /// its side's direction and the other side's normal at its mapping within this angle of the
    /// opposite direction. Default [`zones::DEFAULT_SAFEGUARD_ANGLE`] (80°, the paper's). A
    /// smaller angle leaves the grazing parts of a contact out of the zone: more residual
    /// penetration, and on CesiumMan fewer pops (measured in `README.md`).
    pub safeguard_angle: f64,
    /// The mapping direction.
    pub direction: DirectionMode,
    /// Whether two separate surfaces lying on each other are refused
    /// ([`ContactError::Coincident`]; default true). On skinned input only a duplicated or
    /// layered mesh puts faces exactly on each other; a contact pass after the first starts
    /// from the contact surface both sides share by construction, where a rigid side's faces
    /// hold the other's (the sphere on the slab: 352 vertices left 0.28 h deep when its second
    /// pass refused them).
    ///
    /// [`ContactError::Coincident`]: super::ContactError::Coincident
    pub refuse_coincident: bool,
}

impl Default for PairParams {
    fn default() -> Self {
        Self {
            stiffness_a: 0.5,
            tau: 0.0,
            safeguard_angle: zones::DEFAULT_SAFEGUARD_ANGLE,
            direction: DirectionMode::Automatic,
            refuse_coincident: true,
        }
    }
}

impl PairParams {
    /// The same contact seen with A and B swapped.
    pub fn swapped(&self) -> Self {
        Self {
            stiffness_a: 1.0 - self.stiffness_a,
            tau: self.tau,
            safeguard_angle: self.safeguard_angle,
            direction: match self.direction {
                DirectionMode::Automatic => DirectionMode::Automatic,
                DirectionMode::Fixed(d) => DirectionMode::Fixed(-d),
            },
            refuse_coincident: self.refuse_coincident,
        }
    }
}
