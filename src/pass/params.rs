//! What the contact pass is given: each object's parameters (2021 Sec. 4-5, 7), each pair's
//! overrides and its mapping direction's track over time.

use nalgebra::Vector3;

/// Default `φ̄` as a fraction of the object's rest size ([`crate::mesh::surface_size`]): one
/// half, as when the size was the diagonal of the object's axis-aligned rest bounding box
/// (until 2026-12-02; a rotation of the rig changed it). On the committed object scenes the
/// two sizes agree to 0.3 % (balls), 2 % (capsules), 7 % (fingertips) and 11 % (the slab), and
/// the scenes' metrics are those of the former default. A diameter-based default, also
/// rotation-invariant, fitted either round or long objects, not both (half a diameter let the
/// sphere on the slab keep 38 penetrating vertices; √3/2 of one made the fingertips 45 %
/// slower).
pub const DEFAULT_EXTENT_FACTOR: f64 = 0.5;

/// Contact parameters of one object (2021 Sec. 4.3, 4.4, 5, 7).
#[derive(Clone, Debug, PartialEq)]
pub struct ObjectParams {
    /// Pseudo-stiffness `k` (`k̄_A = k_A / (k_A + k_B)`); `f64::INFINITY` makes the object rigid.
    pub stiffness: f64,
    /// `τ` (Eq. 4) used when this object is the softer one of a pair.
    pub tau: f64,
    /// `φ̄`, extent of the deformation (scene units); `None`: [`DEFAULT_EXTENT_FACTOR`] times
    /// the object's rest size ([`crate::mesh::surface_size`]).
    pub extent: Option<f64>,
    /// `γ`: 0 no bulge, 1 exact volume, > 1 exaggeration.
    pub gamma: f64,
    /// `ω` of the procedural bulge map.
    pub omega: f64,
    /// Painted bulge map per welded vertex (multiplies `η`; negative values allowed).
    pub painted: Option<Vec<f64>>,
    /// Whether the object takes part in contacts between bodies (`[[object]] contact =
    /// false`: an outline shell, a garment layered on the skin, a duplicate, which the pass
    /// would take for one deep interpenetration and crumple).
    pub contact: bool,
}

impl Default for ObjectParams {
    fn default() -> Self {
        Self {
            stiffness: 1.0,
            tau: 0.0,
            extent: None,
            gamma: 1.0,
            omega: 2.0,
            painted: None,
            contact: true,
        }
    }
}

/// Per-pair overrides ([`PairOverride::new`]: none).
#[derive(Clone, Debug, PartialEq)]
pub struct PairOverride {
    /// The two bodies (indices).
    pub bodies: [usize; 2],
    /// `τ` of this pair.
    pub tau: Option<f64>,
    /// The safeguard angle of this pair in degrees
    /// ([`crate::contact::PairParams::safeguard_angle`]).
    pub safeguard_angle: Option<f64>,
    /// Mapping direction, outward for `bodies[0]` (constant or keyframed).
    pub direction: Option<DirectionTrack>,
    /// Whether the pair is resolved: `Some(false)` (`[[pair]] enabled = false`) leaves the
    /// two bodies as they come where they meet; `Some(true)` resolves the pair even when the
    /// two surfaces cross at rest and the pass leaves such pairs out
    /// ([`RestOverlaps::LeftOut`]); `None`, the default, follows the pass.
    pub enabled: Option<bool>,
}

/// What [`super::ContactPass`] does with the pairs of bodies whose surfaces already cross at rest
/// ([`super::ContactPass::crossing_at_rest`]; [`super::ContactPass::with_rest_overlaps`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum RestOverlaps {
    /// Resolves them like any other (the library's default: a caller may build the pass on
    /// any positions, such as a frame's, where every contact crosses).
    #[default]
    Resolved,
    /// Leaves them out unless an override enables the pair: on a rig's true rest pose (what
    /// `contact-skin pose` does), such an overlap is modeled on purpose, as a robot's rigid
    /// pieces at their hinges or a head sunk into a torso, and resolving it in every frame
    /// works against the model (until 2026-12-05 the CLI did: the Quaternius robot's 11
    /// hinges, with zones of 1-9 vertices, faces turned over and its open pieces' volumes
    /// changed).
    LeftOut,
}

impl PairOverride {
    /// No override of the pair `bodies`: the objects' parameters, the automatic direction,
    /// resolved.
    pub fn new(bodies: [usize; 2]) -> Self {
        Self {
            bodies,
            tau: None,
            safeguard_angle: None,
            direction: None,
            enabled: None,
        }
    }
}

/// A user mapping direction over time (2021 Sec. 4.1: "specify it manually and even key-frame
/// it"): keys `(time, direction)`, normalized linear interpolation between them, held
/// constant before the first and after the last.
#[derive(Clone, Debug, PartialEq)]
pub struct DirectionTrack {
    keys: Vec<(f64, Vector3<f64>)>,
}

impl DirectionTrack {
    /// A constant direction.
    pub fn constant(direction: Vector3<f64>) -> Self {
        Self {
            keys: vec![(0.0, direction)],
        }
    }

    /// Keyframes; `None` when empty, when a time or direction is not finite or a direction is
    /// zero. Keys are sorted by time.
    pub fn keyed(mut keys: Vec<(f64, Vector3<f64>)>) -> Option<Self> {
        let valid = |(t, d): &(f64, Vector3<f64>)| {
            t.is_finite() && d.iter().all(|x| x.is_finite()) && d.norm() > 0.0
        };
        if keys.is_empty() || !keys.iter().all(valid) {
            return None;
        }
        keys.sort_by(|a, b| a.0.total_cmp(&b.0));
        Some(Self { keys })
    }

    /// The direction at time `t` (unit unless two consecutive keys are opposite, where the
    /// earlier key is used).
    pub fn at(&self, t: f64) -> Vector3<f64> {
        let k = &self.keys;
        let first = k[0].1.normalize();
        if k.len() == 1 || t <= k[0].0 {
            return first;
        }
        for w in k.windows(2) {
            let ((t0, d0), (t1, d1)) = (w[0], w[1]);
            if t <= t1 {
                let s = if t1 > t0 { (t - t0) / (t1 - t0) } else { 1.0 };
                let (d0, d1) = (d0.normalize(), d1.normalize());
                return (d0 * (1.0 - s) + d1 * s).try_normalize(1e-12).unwrap_or(d0);
            }
        }
        k[k.len() - 1].1.normalize()
    }
}
