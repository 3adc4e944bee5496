//! The file's structure: the TOML tables of a configuration as read (serde), before any check.

use crate::selfcontact::fold::FoldParams;
use crate::selfcontact::{DirectionSource, RegionOptions};
use nalgebra::Vector3;
use serde::de::{self, Deserializer, Visitor};
use serde::Deserialize;
use std::fmt;

/// A pseudo-stiffness: a number, or the string `"rigid"` (`f64::INFINITY`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Stiffness(pub f64);

impl<'de> Deserialize<'de> for Stiffness {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl Visitor<'_> for V {
            type Value = Stiffness;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a positive number or \"rigid\"")
            }
            fn visit_f64<E: de::Error>(self, v: f64) -> Result<Stiffness, E> {
                Ok(Stiffness(v))
            }
            fn visit_i64<E: de::Error>(self, v: i64) -> Result<Stiffness, E> {
                Ok(Stiffness(v as f64))
            }
            fn visit_u64<E: de::Error>(self, v: u64) -> Result<Stiffness, E> {
                Ok(Stiffness(v as f64))
            }
            fn visit_str<E: de::Error>(self, v: &str) -> Result<Stiffness, E> {
                match v {
                    "rigid" => Ok(Stiffness(f64::INFINITY)),
                    _ => Err(E::invalid_value(de::Unexpected::Str(v), &self)),
                }
            }
        }
        d.deserialize_any(V)
    }
}

/// A self-contact pair's mapping direction as written: `[x, y, z]` (W1's outward direction at
/// the fold), `"skeleton"` (the bones' bisector, the default) or `"motion"` (the relative
/// motion of the parts where they meet).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SelfDirection(pub DirectionSource);

impl<'de> Deserialize<'de> for SelfDirection {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = SelfDirection;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("[x, y, z], \"skeleton\" or \"motion\"")
            }
            fn visit_str<E: de::Error>(self, v: &str) -> Result<SelfDirection, E> {
                direction_mode(v)
                    .map(SelfDirection)
                    .ok_or_else(|| E::invalid_value(de::Unexpected::Str(v), &self))
            }
            fn visit_seq<A: de::SeqAccess<'de>>(
                self,
                mut seq: A,
            ) -> Result<SelfDirection, A::Error> {
                let mut v = [0.0; 3];
                for (k, x) in v.iter_mut().enumerate() {
                    *x = seq
                        .next_element()?
                        .ok_or_else(|| de::Error::invalid_length(k, &self))?;
                }
                if seq.next_element::<f64>()?.is_some() {
                    return Err(de::Error::invalid_length(4, &self));
                }
                Ok(SelfDirection(DirectionSource::Fixed(Vector3::from(v))))
            }
        }
        d.deserialize_any(V)
    }
}

/// The configuration's fixed-length arrays, read strictly: serde reads an array `[T; N]` as its
/// first `N` values and `toml` does not complain about the rest, so `objects = [0, 1, "x"]`
/// was taken as `[0, 1]` and a fourth coordinate of a direction was dropped (until
/// 2026-12-05). Each is read whole and refused unless it has exactly `N` values.
mod exact {
    use super::{de, Deserialize, Deserializer};

    fn sized<T, E: de::Error, const N: usize>(values: Vec<T>) -> Result<[T; N], E> {
        let len = values.len();
        values
            .try_into()
            .map_err(|_| E::invalid_length(len, &format!("an array of {N} values").as_str()))
    }

    /// `[T; N]`.
    pub fn array<'de, D, T, const N: usize>(d: D) -> Result<[T; N], D::Error>
    where
        D: Deserializer<'de>,
        T: Deserialize<'de>,
    {
        sized(Vec::deserialize(d)?)
    }

    /// `Option<[T; N]>`.
    pub fn option<'de, D, T, const N: usize>(d: D) -> Result<Option<[T; N]>, D::Error>
    where
        D: Deserializer<'de>,
        T: Deserialize<'de>,
    {
        Option::<Vec<T>>::deserialize(d)?.map(sized).transpose()
    }

    /// `Option<Vec<[T; N]>>`.
    pub fn option_list<'de, D, T, const N: usize>(d: D) -> Result<Option<Vec<[T; N]>>, D::Error>
    where
        D: Deserializer<'de>,
        T: Deserialize<'de>,
    {
        Option::<Vec<Vec<T>>>::deserialize(d)?
            .map(|list| list.into_iter().map(sized).collect())
            .transpose()
    }
}

/// `"skeleton"` or `"motion"`.
fn direction_mode(name: &str) -> Option<DirectionSource> {
    match name {
        "skeleton" => Some(DirectionSource::Skeleton),
        "motion" => Some(DirectionSource::Motion),
        _ => None,
    }
}

/// A body, by name or by index.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum BodyRef {
    /// A body name (or an index written as a string).
    Name(String),
    /// A body index.
    Index(usize),
}

impl fmt::Display for BodyRef {
    fn fmt(&self, f: &mut fmt::Formatter) -> fmt::Result {
        match self {
            BodyRef::Name(n) => f.write_str(n),
            BodyRef::Index(i) => write!(f, "{i}"),
        }
    }
}

impl<'de> Deserialize<'de> for BodyRef {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl Visitor<'_> for V {
            type Value = BodyRef;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a body name or a body index")
            }
            fn visit_str<E: de::Error>(self, v: &str) -> Result<BodyRef, E> {
                Ok(BodyRef::Name(v.to_string()))
            }
            fn visit_u64<E: de::Error>(self, v: u64) -> Result<BodyRef, E> {
                usize::try_from(v)
                    .map(BodyRef::Index)
                    .map_err(|_| E::invalid_value(de::Unexpected::Unsigned(v), &self))
            }
            fn visit_i64<E: de::Error>(self, v: i64) -> Result<BodyRef, E> {
                usize::try_from(v)
                    .map(BodyRef::Index)
                    .map_err(|_| E::invalid_value(de::Unexpected::Signed(v), &self))
            }
        }
        d.deserialize_any(V)
    }
}

/// Contact parameters as written (every one optional): `[defaults]`, or the parameters of an
/// `[[object]]`.
#[derive(Clone, Debug, Default, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ParamSpec {
    /// Pseudo-stiffness `k` (`"rigid"`: infinite).
    pub stiffness: Option<Stiffness>,
    /// `τ` (Eq. 4).
    pub tau: Option<f64>,
    /// `φ̄` in scene units.
    pub extent: Option<f64>,
    /// `φ̄` as a fraction of the object's rest size ([`super::rest_sizes`]).
    pub extent_factor: Option<f64>,
    /// `γ`.
    pub gamma: Option<f64>,
    /// `ω`.
    pub omega: Option<f64>,
}

impl ParamSpec {
    /// `over` on top of `self`: every value `over` gives wins; `extent` and `extent_factor`
    /// are one choice (an object giving either replaces both defaults).
    pub fn overlay(&self, over: &ParamSpec) -> ParamSpec {
        let own_extent = over.extent.is_some() || over.extent_factor.is_some();
        let (extent, extent_factor) = if own_extent {
            (over.extent, over.extent_factor)
        } else {
            (self.extent, self.extent_factor)
        };
        ParamSpec {
            stiffness: over.stiffness.or(self.stiffness),
            tau: over.tau.or(self.tau),
            extent,
            extent_factor,
            gamma: over.gamma.or(self.gamma),
            omega: over.omega.or(self.omega),
        }
    }
}

/// One `[[object]]` table.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObjectSpec {
    /// The body.
    pub name: BodyRef,
    /// See [`ParamSpec::stiffness`].
    pub stiffness: Option<Stiffness>,
    /// See [`ParamSpec::tau`].
    pub tau: Option<f64>,
    /// See [`ParamSpec::extent`].
    pub extent: Option<f64>,
    /// See [`ParamSpec::extent_factor`].
    pub extent_factor: Option<f64>,
    /// See [`ParamSpec::gamma`].
    pub gamma: Option<f64>,
    /// See [`ParamSpec::omega`].
    pub omega: Option<f64>,
    /// Painted bulge map: a text file (relative to the configuration's folder) or
    /// `attribute:NAME`.
    pub bulge_map: Option<String>,
    /// `false`: the body takes part in no contact between bodies
    /// ([`crate::pass::ObjectParams::contact`]).
    pub contact: Option<bool>,
}

impl ObjectSpec {
    /// The parameters this object sets.
    pub fn params(&self) -> ParamSpec {
        ParamSpec {
            stiffness: self.stiffness,
            tau: self.tau,
            extent: self.extent,
            extent_factor: self.extent_factor,
            gamma: self.gamma,
            omega: self.omega,
        }
    }
}

/// One `[[pair]]` table.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PairSpec {
    /// The two bodies; directions are outward for the first.
    #[serde(deserialize_with = "exact::array")]
    pub objects: [BodyRef; 2],
    /// `τ` of this pair.
    pub tau: Option<f64>,
    /// The safeguard angle of Sec. 4.4 in degrees, in `(0, 90]`
    /// ([`crate::contact::PairParams::safeguard_angle`]).
    pub safeguard_angle: Option<f64>,
    /// A constant mapping direction.
    #[serde(default, deserialize_with = "exact::option")]
    pub direction: Option<[f64; 3]>,
    /// Keyframed mapping directions `[time, x, y, z]`.
    #[serde(default, deserialize_with = "exact::option_list")]
    pub direction_keys: Option<Vec<[f64; 4]>>,
    /// `false`: the pair is not resolved; `true`: resolved even when the two bodies cross at
    /// rest, which leaves a pair out by default ([`crate::pass::PairOverride::enabled`]).
    pub enabled: Option<bool>,
}

/// The `[self_contact]` table as written (every value optional).
#[derive(Clone, Debug, Default, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SelfContactSpec {
    /// Run the self-contact pass (default `true`).
    pub enabled: Option<bool>,
    /// Sweeps over the folds per frame
    /// ([`crate::selfcontact::pass::SelfContactPass::with_passes`]): exactly these when
    /// `max_passes` is not given (`passes = 2` alone turns the default further sweeps off).
    pub passes: Option<usize>,
    /// Largest number of sweeps, the ones past `passes` run only while the folds' shared
    /// regions still hold penetrating vertices
    /// ([`crate::selfcontact::pass::SelfContactPass::with_max_passes`]; default
    /// [`crate::selfcontact::pass::DEFAULT_MAX_FOLD_PASSES`], or `passes` when `passes` is
    /// given).
    pub max_passes: Option<usize>,
    /// [`RegionOptions::threshold`]: weight above which a vertex belongs to a working region.
    pub threshold: Option<f64>,
    /// [`RegionOptions::grow_rings`].
    pub grow_rings: Option<usize>,
    /// `k̄` of the parent side W1 ([`FoldParams::stiffness_1`]), in `[0, 1]`.
    pub stiffness: Option<f64>,
    /// `τ` of Eq. 4.
    pub tau: Option<f64>,
    /// [`FoldParams::safeguard_angle`] in degrees, in `(0, 90]`.
    pub safeguard_angle: Option<f64>,
    /// `φ̄` in scene units.
    pub extent: Option<f64>,
    /// `φ̄` as a fraction of the body's rest size ([`super::rest_sizes`]).
    pub extent_factor: Option<f64>,
    /// `φ̄` as a multiple of each joint's size ([`FoldParams::joint_extent`], the default).
    pub joint_extent: Option<f64>,
    /// `γ`.
    pub gamma: Option<f64>,
    /// `ω`.
    pub omega: Option<f64>,
    /// [`FoldParams::turn_guard`] (default `true`).
    pub turn_guard: Option<bool>,
    /// [`FoldParams::bulge_guard`] (default `true`).
    pub bulge_guard: Option<bool>,
    /// [`FoldParams::free_isolated_crease`] (default `false`).
    pub free_isolated_crease: Option<bool>,
    /// Where the pairs without a `[[self_contact.pair]]` direction take theirs from:
    /// `"skeleton"` (default) or `"motion"`.
    pub direction: Option<SelfDirection>,
    /// Per-pair settings.
    #[serde(default, rename = "pair")]
    pub pairs: Vec<SelfPairSpec>,
    /// Separated working regions of one body named by their joints (`[[self_contact.
    /// separated]]`).
    #[serde(default)]
    pub separated: Vec<SeparatedSpec>,
    /// Also derive separated working regions from the skeleton (default `true`;
    /// [`crate::selfcontact::separated_from_skeleton`]).
    pub separated_from_skeleton: Option<bool>,
}

/// One `[[self_contact.separated]]` table: two working regions of one skinned body that share
/// no vertex, each the vertices weighted on its joints (2021 Sec. 4-5 on parts of one mesh,
/// the paper's Fig. 14: fingertips pressing their own palm;
/// [`crate::selfcontact::separated_regions`]).
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SeparatedSpec {
    /// The joints (node names) of each side: `[["forearm", "hand"], ["hips"]]`.
    #[serde(deserialize_with = "exact::array")]
    pub sides: [Vec<String>; 2],
}

/// One `[[self_contact.pair]]` table: what this pair does differently from the section.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SelfPairSpec {
    /// The pair's name as derived (`body/parent-child`, listed by `contact-skin info`).
    pub name: String,
    /// The mapping direction `d̂_12`: W1's (the parent side's) outward direction at the fold,
    /// or where it comes from (default: the section's `direction`).
    pub direction: Option<SelfDirection>,
    /// `τ` of Eq. 4 for this pair.
    pub tau: Option<f64>,
    /// `γ` for this pair (the bulge: 0 none, 1 exact volume).
    pub gamma: Option<f64>,
    /// `ω` of this pair's procedural bulge map.
    pub omega: Option<f64>,
    /// [`FoldParams::free_isolated_crease`] for this pair.
    pub free_isolated_crease: Option<bool>,
    /// `false` leaves the pair as it comes in every frame; `true` resolves it even when its
    /// two sides cross at rest, which `pose` otherwise leaves out
    /// ([`crate::selfcontact::pass::SelfContactPass::with_pair_enabled`]).
    pub enabled: Option<bool>,
}

impl SelfPairSpec {
    /// Whether it sets any of `τ`, `γ`, `ω`, `free_isolated_crease`.
    pub fn sets_params(&self) -> bool {
        self.tau.is_some()
            || self.gamma.is_some()
            || self.omega.is_some()
            || self.free_isolated_crease.is_some()
    }

    /// The section's fold parameters `section` with this pair's `τ`, `γ`, `ω` and
    /// `free_isolated_crease`; `None` when it sets none of them.
    pub fn params(&self, section: &FoldParams) -> Option<FoldParams> {
        if !self.sets_params() {
            return None;
        }
        let mut p = *section;
        if let Some(t) = self.tau {
            p.tau = t;
        }
        if let Some(g) = self.gamma {
            p.deform.gamma = g;
        }
        if let Some(w) = self.omega {
            p.deform.omega = w;
        }
        if let Some(free) = self.free_isolated_crease {
            p.free_isolated_crease = free;
        }
        Some(p)
    }
}

/// The self-contact pass settings resolved from a configuration: the inputs of
/// [`crate::selfcontact::pass::SelfContactPass::new`] and whether to run it.
#[derive(Clone, Debug, PartialEq)]
pub struct SelfContactSettings {
    /// Run the pass (`[self_contact] enabled`, default `true`).
    pub enabled: bool,
    /// How working regions are derived.
    pub regions: RegionOptions,
    /// Parameters of every fold.
    pub params: FoldParams,
    /// Where each pair's direction comes from, by pair name (fixed directions normalized);
    /// pairs not listed use the skeleton's.
    pub directions: Vec<(String, DirectionSource)>,
    /// The fold parameters of the pairs that set their own `τ`, `γ`, `ω` or
    /// `free_isolated_crease`, by pair name (the others use `params`).
    pub pair_params: Vec<(String, FoldParams)>,
    /// The pairs that set `enabled`, by pair name.
    pub pair_enabled: Vec<(String, bool)>,
    /// Sweeps over the folds per frame.
    pub passes: usize,
    /// Largest number of sweeps per frame (at least `passes`).
    pub max_passes: usize,
    /// The joints of both sides of each pair of separated regions
    /// (`[[self_contact.separated]]`), in the file's order.
    pub separated: Vec<[Vec<String>; 2]>,
    /// Whether separated regions are also derived from the skeleton
    /// ([`crate::selfcontact::separated_from_skeleton`]).
    pub separated_from_skeleton: bool,
}
