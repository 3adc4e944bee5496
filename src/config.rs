//! The contact configuration of a rig: a TOML file giving the parameters of the contact pass
//! ([`crate::pass`]) per object and per pair.
//!
//! ```toml
//! passes = 2                      # optional, ContactPass::with_passes
//! [defaults]                      # optional, for every object
//! stiffness = 1.0                 # pseudo-stiffness k, or "rigid"
//! tau = 0.0
//! extent = 0.3                    # φ̄ in scene units; or extent_factor = 0.5 (× rest size)
//! gamma = 1.0                     # bulge: 0 none, 1 the lost volume, at most 10
//! omega = 2.0
//! [[object]]
//! name = "ball"                   # a body name, or its index (integer or string)
//! stiffness = 0.5
//! bulge_map = "ball_bulge.txt"    # or "attribute:_BULGE"
//! [[pair]]
//! objects = ["ball", "thumb"]
//! tau = 0.6
//! safeguard_angle = 80.0          # degrees, in (0, 90]: Sec. 4.4's safeguard (default 80)
//! direction = [0.0, 1.0, 0.0]     # or direction_keys = [[t, x, y, z], ...]
//! [self_contact]                  # optional: joints folding into themselves
//! enabled = true
//! passes = 2                      # sweeps per frame (exactly, when given without max_passes)
//! max_passes = 6                  # up to this many while a fold still penetrates (default 6)
//! threshold = 0.05                # RegionOptions::threshold
//! grow_rings = 2
//! stiffness = 0.5                 # k̄ of the parent side, in [0, 1]
//! tau = -1.0                      # the paper's Fig. 13 and 15 (default)
//! safeguard_angle = 80.0          # degrees, in (0, 90] (default 80, the paper's)
//! joint_extent = 1.5              # φ̄ × the joint's size (default); or extent / extent_factor
//! gamma = 1.0                     # bulge: 0 none, 1 the lost volume, at most 10
//! omega = 2.0
//! turn_guard = true               # scale the displacement back where a face would turn over
//! bulge_guard = true              # scale the bulge back where it would enter the other part
//! free_isolated_crease = false    # true: isolated crease vertices stay out of the zones (lips)
//! direction = "skeleton"          # every pair's default: "skeleton" or "motion"
//! separated_from_skeleton = true  # also sibling subtrees and joints vs grandchildren (default)
//! [[self_contact.pair]]
//! name = "lips/head-jaw"          # a derived joint pair (`contact-skin info`)
//! direction = [0.0, -1.0, 0.0]    # W1's (parent side's) outward direction at the fold,
//!                                 # or "skeleton", or "motion" (relative motion of the parts)
//! gamma = 0.5                     # this pair's τ, γ, ω (each optional; default the section's)
//! free_isolated_crease = true     # and this (optional)
//! enabled = true                  # resolve it even if its sides cross at rest (or false: never)
//! [[self_contact.separated]]      # two regions of one body that share no vertex (Fig. 14)
//! sides = [["forearm", "hand"], ["hips"]]   # each side's joints (node names)
//! ```
//!
//! [`ContactConfig::load`] parses and checks every number (no rig needed);
//! [`ContactConfig::resolve`] maps names to bodies and reads the painted bulge maps, giving the
//! inputs of [`crate::pass::ContactPass::new`]; [`ContactConfig::resolve_self_contact`] gives
//! those of [`crate::selfcontact::pass::SelfContactPass::new`]. Every error is a
//! [`ConfigError`] naming the file and the field (`object[1].stiffness`,
//! `pair[0].direction_keys[2]`, `self_contact.pair[0].name`, ...).

use crate::mesh::{surface_size, WeldedMesh};
use crate::pass::{DirectionTrack, ObjectParams, PairOverride, DEFAULT_PASSES};
use crate::rig::{Confinement, Rig};
use crate::selfcontact::fold::FoldParams;
use crate::selfcontact::pass::{DEFAULT_FOLD_PASSES, DEFAULT_MAX_FOLD_PASSES};
use crate::selfcontact::DirectionSource;
use crate::selfcontact::{derive_pairs, RegionOptions, SelfContactError};
use nalgebra::Vector3;
use serde::de::{self, Deserializer, Visitor};
use serde::Deserialize;
use std::fmt;
use std::path::{Path, PathBuf};

/// Suffix of a rig's own configuration: `<rig stem>.contact.toml`, next to the rig.
pub const CONFIG_SUFFIX: &str = ".contact.toml";

/// Prefix of a `bulge_map` that names a custom vertex attribute of the glTF file.
pub const ATTRIBUTE_PREFIX: &str = "attribute:";

/// Largest accepted `gamma` (the bulge's share of the lost volume, Sec. 5.3: 1 restores it).
/// A larger bulge dwarfs the contact it balances, and its guard's collision tests then grow
/// with it (a hundred times the volume took 2.6 s per frame on the bending capsule, `-100` did
/// not finish in two minutes, 2026-12-05): such values are refused rather than run.
pub const MAX_GAMMA: f64 = 10.0;

/// Largest accepted `passes`.
pub const MAX_PASSES: usize = 16;

/// Largest accepted `self_contact.grow_rings`.
pub const MAX_GROW_RINGS: usize = 64;

/// Largest configuration or bulge-map file read (64 MiB): a guard against absurd inputs.
pub const MAX_FILE_BYTES: u64 = 64 << 20;

/// Why a configuration could not be read or applied. Every variant names the configuration
/// file and the field at fault.
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    /// The file could not be read (missing, unreadable, too large).
    #[error("{file}: cannot read: {source}")]
    Io {
        /// The configuration file.
        file: PathBuf,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
    /// Not valid TOML, an unknown field, or a value of the wrong type.
    #[error("{file}: {field}: {message} (line {line}, column {column})")]
    Parse {
        /// The configuration file.
        file: PathBuf,
        /// The field at fault, as far as it can be located (`object[1].stiffness`).
        field: String,
        /// Line (1-based).
        line: usize,
        /// Column (1-based).
        column: usize,
        /// What the parser said.
        message: String,
    },
    /// A value out of its range, or two options that exclude each other.
    #[error("{file}: {field}: {message}")]
    Invalid {
        /// The configuration file.
        file: PathBuf,
        /// The field at fault.
        field: String,
        /// What is wrong.
        message: String,
    },
    /// A name or index that is no body of the rig.
    #[error("{file}: {field}: no body '{name}' in the rig (bodies: {available})")]
    UnknownBody {
        /// The configuration file.
        file: PathBuf,
        /// The field at fault.
        field: String,
        /// The name or index given.
        name: String,
        /// The bodies of the rig (`0 'ball', 1 'thumb'`).
        available: String,
    },
    /// An object or a pair configured twice.
    #[error("{file}: {field}: {what} is already configured by {first}")]
    Duplicate {
        /// The configuration file.
        file: PathBuf,
        /// The second occurrence.
        field: String,
        /// What is repeated (`body 'ball'`, `pair 'ball' / 'thumb'`).
        what: String,
        /// The first occurrence.
        first: String,
    },
    /// A bulge-map file that is refused (path leaving the folder), unreadable or malformed,
    /// or a value that is not finite.
    #[error("{file}: {field}: bulge map '{map}': {message}")]
    BulgeMap {
        /// The configuration file.
        file: PathBuf,
        /// The field at fault.
        field: String,
        /// The map as written in the configuration.
        map: String,
        /// What is wrong.
        message: String,
    },
    /// A bulge map whose value count differs from the body's file vertex count.
    #[error(
        "{file}: {field}: bulge map '{map}' has {got} values, body '{body}' has {expected} file vertices"
    )]
    BulgeCount {
        /// The configuration file.
        file: PathBuf,
        /// The field at fault.
        field: String,
        /// The map as written in the configuration.
        map: String,
        /// The body.
        body: String,
        /// File vertices of the body.
        expected: usize,
        /// Values found.
        got: usize,
    },
    /// A `[[self_contact.pair]]` naming no joint pair derived from the rig.
    #[error("{file}: {field}: no joint pair '{name}' in the rig (derived pairs: {available})")]
    UnknownPair {
        /// The configuration file.
        file: PathBuf,
        /// The field at fault.
        field: String,
        /// The name given.
        name: String,
        /// The pairs derived from the rig's skin weights (`lips/head-jaw`), or `none`.
        available: String,
    },
    /// The joint pairs could not be derived from the rig (needed to check the pair names of
    /// `[self_contact]` and to resolve its `extent_factor`).
    #[error("{file}: {field}: cannot derive the joint pairs of the rig: {source}")]
    SelfContact {
        /// The configuration file.
        file: PathBuf,
        /// The field that needed the pairs.
        field: String,
        /// The underlying error.
        #[source]
        source: Box<SelfContactError>,
    },
    /// `attribute:NAME` naming no custom attribute of the body.
    #[error(
        "{file}: {field}: body '{body}' has no custom vertex attribute '{attribute}' (available: {available})"
    )]
    UnknownAttribute {
        /// The configuration file.
        file: PathBuf,
        /// The field at fault.
        field: String,
        /// The body.
        body: String,
        /// The attribute asked for.
        attribute: String,
        /// The attributes the body has.
        available: String,
    },
}

impl ConfigError {
    /// The field at fault (empty for [`ConfigError::Io`]).
    pub fn field(&self) -> &str {
        match self {
            ConfigError::Io { .. } => "",
            ConfigError::Parse { field, .. }
            | ConfigError::Invalid { field, .. }
            | ConfigError::UnknownBody { field, .. }
            | ConfigError::Duplicate { field, .. }
            | ConfigError::BulgeMap { field, .. }
            | ConfigError::BulgeCount { field, .. }
            | ConfigError::UnknownPair { field, .. }
            | ConfigError::SelfContact { field, .. }
            | ConfigError::UnknownAttribute { field, .. } => field,
        }
    }
}

// ---------------------------------------------------------------------------------------------
// The file's structure

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
    /// `φ̄` as a fraction of the object's rest size ([`rest_sizes`]).
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
    /// `φ̄` as a fraction of the body's rest size ([`rest_sizes`]).
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

/// A rig's contact configuration (see the module documentation).
#[derive(Clone, Debug, Default, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ContactConfig {
    /// Passes per frame ([`crate::pass::ContactPass::with_passes`]).
    pub passes: Option<usize>,
    /// Parameters of every object.
    #[serde(default)]
    pub defaults: ParamSpec,
    /// Per-object parameters.
    #[serde(default, rename = "object")]
    pub objects: Vec<ObjectSpec>,
    /// Per-pair overrides.
    #[serde(default, rename = "pair")]
    pub pairs: Vec<PairSpec>,
    /// The `[self_contact]` table (`None` when the file has none: the pass defaults).
    #[serde(default)]
    pub self_contact: Option<SelfContactSpec>,
    /// The file it was read from (named in errors).
    #[serde(skip)]
    pub file: PathBuf,
    /// The folder bulge-map files are resolved in (and confined to).
    #[serde(skip)]
    pub base_dir: PathBuf,
}

/// What [`ContactConfig::resolve`] gives: per-body parameters, pair overrides, passes.
pub type Resolved = (Vec<ObjectParams>, Vec<PairOverride>, usize);

// ---------------------------------------------------------------------------------------------
// Reading

impl ContactConfig {
    /// Reads and checks a configuration file; bulge maps are resolved in its folder.
    pub fn load(path: &Path) -> Result<Self, ConfigError> {
        let io = |source| ConfigError::Io {
            file: path.to_path_buf(),
            source,
        };
        let text = read_text(path).map_err(io)?;
        let base = path.parent().map(Path::to_path_buf).unwrap_or_default();
        Self::parse(&text, path, &base)
    }

    /// Parses and checks configuration text; bulge maps are resolved in `base_dir`. Errors name
    /// the file `<base_dir>/<inline>`.
    pub fn from_str_with_base(text: &str, base_dir: &Path) -> Result<Self, ConfigError> {
        Self::parse(text, &base_dir.join("<inline>"), base_dir)
    }

    /// Parses `text`, naming `file` in errors, and checks every number.
    pub fn parse(text: &str, file: &Path, base_dir: &Path) -> Result<Self, ConfigError> {
        let mut config: ContactConfig =
            toml::from_str(text).map_err(|e| parse_error(file, text, &e))?;
        config.file = file.to_path_buf();
        config.base_dir = base_dir.to_path_buf();
        config.check()?;
        Ok(config)
    }

    /// The configuration of the rig at `rig`: `explicit` when given (it must exist), else
    /// `<rig stem>.contact.toml` next to the rig when that file exists, else `None`.
    pub fn for_rig(rig: &Path, explicit: Option<&Path>) -> Result<Option<Self>, ConfigError> {
        match explicit {
            Some(p) => Self::load(p).map(Some),
            None => match default_path(rig) {
                Some(p) if p.is_file() => Self::load(&p).map(Some),
                _ => Ok(None),
            },
        }
    }

    /// Passes per frame (the default when the file does not say).
    pub fn passes(&self) -> usize {
        self.passes.unwrap_or(DEFAULT_PASSES)
    }
}

/// `<rig stem>.contact.toml` next to `rig` (`None` when the path has no file name).
pub fn default_path(rig: &Path) -> Option<PathBuf> {
    let stem = rig.file_stem()?.to_string_lossy();
    Some(rig.with_file_name(format!("{stem}{CONFIG_SUFFIX}")))
}

fn parse_error(file: &Path, text: &str, e: &toml::de::Error) -> ConfigError {
    let offset = e.span().map_or(0, |s| s.start.min(text.len()));
    let (line, column) = line_column(text, offset);
    ConfigError::Parse {
        file: file.to_path_buf(),
        field: field_at(text, line),
        line,
        column,
        message: e.message().trim().to_string(),
    }
}

/// 1-based line and column of byte `offset`.
fn line_column(text: &str, offset: usize) -> (usize, usize) {
    let before = text.get(..offset).unwrap_or(text);
    let line = before.matches('\n').count() + 1;
    let column = before.len() - before.rfind('\n').map_or(0, |i| i + 1) + 1;
    (line, column)
}

/// The dotted path of the key on (or last written before) 1-based `line`: the enclosing table
/// (`object[1]`, `defaults`) and the key. A best effort for error messages.
fn field_at(text: &str, line: usize) -> String {
    let lines: Vec<&str> = text.lines().take(line.max(1)).collect();
    let (mut table, mut counts) = (String::new(), Vec::<(String, usize)>::new());
    let mut key = String::new();
    for l in &lines {
        let l = l.split('#').next().unwrap_or("").trim();
        if let Some(name) = l.strip_prefix("[[").and_then(|r| r.strip_suffix("]]")) {
            let name = name.trim().to_string();
            let n = match counts.iter_mut().find(|(k, _)| *k == name) {
                Some((_, c)) => {
                    *c += 1;
                    *c
                }
                None => {
                    counts.push((name.clone(), 0));
                    0
                }
            };
            (table, key) = (format!("{name}[{n}]"), String::new());
        } else if let Some(name) = l.strip_prefix('[').and_then(|r| r.strip_suffix(']')) {
            (table, key) = (name.trim().to_string(), String::new());
        } else if let Some((k, _)) = l.split_once('=') {
            key = k.trim().trim_matches('"').to_string();
        }
    }
    match (table.is_empty(), key.is_empty()) {
        (true, true) => "(top level)".into(),
        (true, false) => key,
        (false, true) => table,
        (false, false) => format!("{table}.{key}"),
    }
}

// ---------------------------------------------------------------------------------------------
// Checks that need no rig

impl ContactConfig {
    fn invalid(&self, field: impl Into<String>, message: impl Into<String>) -> ConfigError {
        ConfigError::Invalid {
            file: self.file.clone(),
            field: field.into(),
            message: message.into(),
        }
    }

    /// Checks every number and every exclusive choice.
    fn check(&self) -> Result<(), ConfigError> {
        if let Some(p) = self.passes {
            if !(1..=MAX_PASSES).contains(&p) {
                return Err(self.invalid("passes", format!("{p} is not in 1..={MAX_PASSES}")));
            }
        }
        self.check_params(&self.defaults, "defaults")?;
        for (i, o) in self.objects.iter().enumerate() {
            self.check_params(&o.params(), &format!("object[{i}]"))?;
            self.check_map_syntax(o.bulge_map.as_deref(), &format!("object[{i}].bulge_map"))?;
        }
        for (j, p) in self.pairs.iter().enumerate() {
            self.check_pair(p, &format!("pair[{j}]"))?;
        }
        if let Some(sc) = &self.self_contact {
            self.check_self_contact(sc)?;
        }
        Ok(())
    }

    fn check_self_contact(&self, sc: &SelfContactSpec) -> Result<(), ConfigError> {
        let at = "self_contact";
        for (field, value) in [("passes", sc.passes), ("max_passes", sc.max_passes)] {
            if let Some(p) = value {
                if !(1..=MAX_PASSES).contains(&p) {
                    return Err(self.invalid(
                        format!("{at}.{field}"),
                        format!("{p} is not in 1..={MAX_PASSES}"),
                    ));
                }
            }
        }
        if let (Some(p), Some(m)) = (sc.passes, sc.max_passes) {
            if m < p {
                return Err(self.invalid(
                    format!("{at}.max_passes"),
                    format!("{m} is below passes = {p}"),
                ));
            }
        }
        if let Some(t) = sc.threshold {
            if !(t.is_finite() && (0.0..1.0).contains(&t)) {
                return Err(self.invalid(
                    format!("{at}.threshold"),
                    format!("{t} is not in [0, 1) (a skin weight)"),
                ));
            }
        }
        if let Some(r) = sc.grow_rings {
            if r > MAX_GROW_RINGS {
                return Err(self.invalid(
                    format!("{at}.grow_rings"),
                    format!("{r} is not in 0..={MAX_GROW_RINGS}"),
                ));
            }
        }
        if let Some(k) = sc.stiffness {
            if !(k.is_finite() && (0.0..=1.0).contains(&k)) {
                return Err(self.invalid(
                    format!("{at}.stiffness"),
                    format!("{k} is not in [0, 1] (k̄, the share of the parent side)"),
                ));
            }
        }
        self.check_safeguard(sc.safeguard_angle, at)?;
        let params = ParamSpec {
            stiffness: None,
            tau: sc.tau,
            extent: sc.extent,
            extent_factor: sc.extent_factor,
            gamma: sc.gamma,
            omega: sc.omega,
        };
        self.check_params(&params, at)?;
        if let Some(k) = sc.joint_extent {
            if !(k.is_finite() && k > 0.0) {
                return Err(
                    self.invalid(format!("{at}.joint_extent"), "must be finite and positive")
                );
            }
            if sc.extent.is_some() || sc.extent_factor.is_some() {
                return Err(self.invalid(
                    format!("{at}.joint_extent"),
                    "give one of extent, extent_factor and joint_extent",
                ));
            }
        }
        for j in 0..sc.pairs.len() {
            self.check_self_pair(&sc.pairs, j)?;
        }
        if matches!(sc.direction, Some(SelfDirection(DirectionSource::Fixed(_)))) {
            return Err(self.invalid(
                format!("{at}.direction"),
                "must be \"skeleton\" or \"motion\" (a fixed direction is set per pair)",
            ));
        }
        Ok(())
    }

    /// `[[self_contact.pair]]` number `j` of `pairs`: a name given once, something set, a
    /// usable direction and numbers.
    fn check_self_pair(&self, pairs: &[SelfPairSpec], j: usize) -> Result<(), ConfigError> {
        let (p, field) = (&pairs[j], format!("self_contact.pair[{j}]"));
        if p.name.trim().is_empty() {
            return Err(self.invalid(format!("{field}.name"), "is empty"));
        }
        if let Some(first) = pairs[..j].iter().position(|o| o.name == p.name) {
            return Err(ConfigError::Duplicate {
                file: self.file.clone(),
                field: format!("{field}.name"),
                what: format!("joint pair '{}'", p.name),
                first: format!("self_contact.pair[{first}]"),
            });
        }
        if p.direction.is_none() && p.enabled.is_none() && !p.sets_params() {
            return Err(self.invalid(
                field,
                format!(
                    "sets nothing for '{}' (give direction, tau, gamma, omega, \
                     free_isolated_crease or enabled)",
                    p.name
                ),
            ));
        }
        if let Some(SelfDirection(DirectionSource::Fixed(d))) = p.direction {
            if unit(&[d.x, d.y, d.z]).is_none() {
                return Err(self.invalid(format!("{field}.direction"), "is zero or not finite"));
            }
        }
        let own = ParamSpec {
            tau: p.tau,
            gamma: p.gamma,
            omega: p.omega,
            ..ParamSpec::default()
        };
        self.check_params(&own, &field)
    }

    fn check_params(&self, p: &ParamSpec, at: &str) -> Result<(), ConfigError> {
        if let Some(Stiffness(k)) = p.stiffness {
            if k.is_nan() || k <= 0.0 {
                return Err(self.invalid(
                    format!("{at}.stiffness"),
                    format!("{k} is not a positive number or \"rigid\""),
                ));
            }
        }
        let finite = |v: Option<f64>| v.is_none_or(f64::is_finite);
        let positive = |v: Option<f64>| v.is_none_or(|x| x.is_finite() && x > 0.0);
        let checks = [
            ("tau", finite(p.tau), "must be finite"),
            ("extent", positive(p.extent), "must be finite and positive"),
            (
                "extent_factor",
                positive(p.extent_factor),
                "must be finite and positive",
            ),
            (
                "gamma",
                p.gamma.is_none_or(|g| (0.0..=MAX_GAMMA).contains(&g)),
                "must be between 0 (no bulge) and 10 (ten times the lost volume)",
            ),
            (
                "omega",
                p.omega.is_none_or(|w| w.is_finite() && w >= 0.0),
                "must be finite and non-negative",
            ),
        ];
        if let Some((name, _, why)) = checks.iter().find(|c| !c.1) {
            return Err(self.invalid(format!("{at}.{name}"), *why));
        }
        if p.extent.is_some() && p.extent_factor.is_some() {
            return Err(self.invalid(
                format!("{at}.extent_factor"),
                "give extent or extent_factor, not both",
            ));
        }
        Ok(())
    }

    fn check_map_syntax(&self, map: Option<&str>, field: &str) -> Result<(), ConfigError> {
        match map {
            Some(m) if m.trim().is_empty() => Err(self.invalid(field, "is empty")),
            Some(m) if m.strip_prefix(ATTRIBUTE_PREFIX).is_some_and(str::is_empty) => {
                Err(self.invalid(field, "names no attribute (attribute:NAME)"))
            }
            _ => Ok(()),
        }
    }

    /// A safeguard angle must be a number of degrees in `(0, 90]`.
    fn check_safeguard(&self, angle: Option<f64>, at: &str) -> Result<(), ConfigError> {
        match angle {
            Some(a) if !(a > 0.0 && a <= 90.0) => Err(self.invalid(
                format!("{at}.safeguard_angle"),
                format!("{a} is not in (0, 90] (degrees)"),
            )),
            _ => Ok(()),
        }
    }

    fn check_pair(&self, p: &PairSpec, at: &str) -> Result<(), ConfigError> {
        if p.tau.is_some_and(|t| !t.is_finite()) {
            return Err(self.invalid(format!("{at}.tau"), "must be finite"));
        }
        self.check_safeguard(p.safeguard_angle, at)?;
        if p.direction.is_some() && p.direction_keys.is_some() {
            return Err(self.invalid(
                format!("{at}.direction_keys"),
                "give direction or direction_keys, not both",
            ));
        }
        if let Some(d) = p.direction {
            if !usable_direction(&d) {
                return Err(self.invalid(
                    format!("{at}.direction"),
                    "is zero, not finite or too long to normalize",
                ));
            }
        }
        if let Some(keys) = &p.direction_keys {
            self.check_keys(keys, &format!("{at}.direction_keys"))?;
        }
        Ok(())
    }

    fn check_keys(&self, keys: &[[f64; 4]], field: &str) -> Result<(), ConfigError> {
        if keys.is_empty() {
            return Err(self.invalid(field, "has no key"));
        }
        for (k, key) in keys.iter().enumerate() {
            if !key[0].is_finite() {
                return Err(self.invalid(format!("{field}[{k}]"), "time is not finite"));
            }
            if !usable_direction(&[key[1], key[2], key[3]]) {
                return Err(
                    self.invalid(format!("{field}[{k}]"), "direction is zero or not finite")
                );
            }
            if let Some(j) = keys[..k].iter().position(|o| o[0] == key[0]) {
                return Err(self.invalid(
                    format!("{field}[{k}]"),
                    format!("time {} is already keyed by [{j}]", key[0]),
                ));
            }
        }
        Ok(())
    }
}

/// A direction that normalizes to a unit vector: finite, non-zero, and a finite non-zero
/// length (`[1e308, 1e308, 1e308]` overflows it and normalized to zero, failing only mid-run;
/// found by fuzzing).
fn usable_direction(d: &[f64; 3]) -> bool {
    let length = d.iter().map(|x| x * x).sum::<f64>().sqrt();
    d.iter().all(|x| x.is_finite()) && length.is_finite() && length > 0.0
}

// ---------------------------------------------------------------------------------------------
// Resolution against a rig

/// Size of each body at the rest pose (linear blend skinning, no animation;
/// [`crate::mesh::surface_size`]): the reference of `extent_factor`.
pub fn rest_sizes(rig: &Rig) -> Vec<f64> {
    let pose = rig.pose_at(None, 0.0);
    rig.bodies
        .iter()
        .map(|b| {
            let mats = pose.skin_matrices(&rig.skins[b.skin]);
            surface_size(
                &crate::skinning::lbs::skin(b, &mats).positions,
                &b.triangles,
            )
        })
        .collect()
}

/// `0 'ball', 1 'thumb', ...` (at most 20 bodies listed).
fn list_bodies(rig: &Rig) -> String {
    let mut s: Vec<String> = rig
        .bodies
        .iter()
        .take(20)
        .enumerate()
        .map(|(i, b)| format!("{i} '{}'", b.name))
        .collect();
    if rig.bodies.len() > 20 {
        s.push(format!("... ({} in all)", rig.bodies.len()));
    }
    if s.is_empty() {
        "none".into()
    } else {
        s.join(", ")
    }
}

impl ContactConfig {
    /// Maps the configuration onto `rig` (`welded`: its welded bodies, in body order): one
    /// [`ObjectParams`] per body (defaults, then the object's own values), the pair overrides
    /// and the number of passes. Painted maps are read per file vertex and gathered to welded
    /// vertices (the first file copy of a welded vertex gives its value).
    pub fn resolve(&self, rig: &Rig, welded: &[WeldedMesh]) -> Result<Resolved, ConfigError> {
        if welded.len() != rig.bodies.len() {
            return Err(self.invalid(
                "(rig)",
                format!(
                    "{} welded meshes for {} bodies",
                    welded.len(),
                    rig.bodies.len()
                ),
            ));
        }
        let sizes = rest_sizes(rig);
        let mut params: Vec<ObjectParams> = sizes
            .iter()
            .map(|&d| object_params(&self.defaults, d))
            .collect();
        let mut seen: Vec<Option<usize>> = vec![None; rig.bodies.len()];
        for (i, o) in self.objects.iter().enumerate() {
            let at = format!("object[{i}]");
            let b = self.body_index(rig, &o.name, &format!("{at}.name"))?;
            if let Some(first) = seen[b] {
                return Err(ConfigError::Duplicate {
                    file: self.file.clone(),
                    field: format!("{at}.name"),
                    what: format!("body {b} '{}'", rig.bodies[b].name),
                    first: format!("object[{first}]"),
                });
            }
            seen[b] = Some(i);
            params[b] = object_params(&self.defaults.overlay(&o.params()), sizes[b]);
            params[b].contact = o.contact.unwrap_or(true);
            if let Some(map) = &o.bulge_map {
                let field = format!("{at}.bulge_map");
                params[b].painted = Some(self.painted(rig, &welded[b], b, map, &field)?);
            }
        }
        let overrides = self.pair_overrides(rig)?;
        Ok((params, overrides, self.passes()))
    }

    /// The body `r` names: a body name first, else an index (integer, or a string holding
    /// one).
    pub fn body_index(&self, rig: &Rig, r: &BodyRef, field: &str) -> Result<usize, ConfigError> {
        let n = rig.bodies.len();
        let found = match r {
            BodyRef::Index(i) => (*i < n).then_some(*i),
            BodyRef::Name(s) => {
                let hits: Vec<usize> = (0..n).filter(|&b| rig.bodies[b].name == *s).collect();
                if hits.len() > 1 {
                    return Err(self.invalid(
                        field,
                        format!("bodies {hits:?} are all named '{s}': use an index"),
                    ));
                }
                hits.first()
                    .copied()
                    .or_else(|| s.trim().parse::<usize>().ok().filter(|&i| i < n))
            }
        };
        found.ok_or_else(|| ConfigError::UnknownBody {
            file: self.file.clone(),
            field: field.to_string(),
            name: r.to_string(),
            available: list_bodies(rig),
        })
    }

    fn pair_overrides(&self, rig: &Rig) -> Result<Vec<PairOverride>, ConfigError> {
        let mut out: Vec<PairOverride> = Vec::new();
        for (j, p) in self.pairs.iter().enumerate() {
            let at = format!("pair[{j}]");
            let a = self.body_index(rig, &p.objects[0], &format!("{at}.objects[0]"))?;
            let b = self.body_index(rig, &p.objects[1], &format!("{at}.objects[1]"))?;
            if a == b {
                return Err(self.invalid(
                    format!("{at}.objects"),
                    format!("names body {a} '{}' twice", rig.bodies[a].name),
                ));
            }
            if let Some(first) = out
                .iter()
                .position(|o| o.bodies == [a, b] || o.bodies == [b, a])
            {
                return Err(ConfigError::Duplicate {
                    file: self.file.clone(),
                    field: format!("{at}.objects"),
                    what: format!("pair '{}' / '{}'", rig.bodies[a].name, rig.bodies[b].name),
                    first: format!("pair[{first}]"),
                });
            }
            out.push(PairOverride {
                bodies: [a, b],
                tau: p.tau,
                safeguard_angle: p.safeguard_angle,
                direction: self.direction_track(p, &at)?,
                enabled: p.enabled,
            });
        }
        Ok(out)
    }

    fn direction_track(
        &self,
        p: &PairSpec,
        at: &str,
    ) -> Result<Option<DirectionTrack>, ConfigError> {
        if let Some(d) = p.direction {
            return Ok(Some(DirectionTrack::constant(Vector3::from(d))));
        }
        let Some(keys) = &p.direction_keys else {
            return Ok(None);
        };
        let keys = keys
            .iter()
            .map(|k| (k[0], Vector3::new(k[1], k[2], k[3])))
            .collect();
        DirectionTrack::keyed(keys)
            .map(Some)
            .ok_or_else(|| self.invalid(format!("{at}.direction_keys"), "invalid keys"))
    }
}

/// The pass parameters of a (merged) spec; unset values keep [`ObjectParams::default`].
fn object_params(p: &ParamSpec, rest_size: f64) -> ObjectParams {
    let d = ObjectParams::default();
    ObjectParams {
        stiffness: p.stiffness.map_or(d.stiffness, |s| s.0),
        tau: p.tau.unwrap_or(d.tau),
        extent: p
            .extent
            .or(p.extent_factor.map(|f| f * rest_size))
            .or(d.extent),
        gamma: p.gamma.unwrap_or(d.gamma),
        omega: p.omega.unwrap_or(d.omega),
        painted: None,
        contact: d.contact,
    }
}

// ---------------------------------------------------------------------------------------------
// Self-contact

impl ContactConfig {
    /// Whether the self-contact pass runs: with a `[self_contact]` table, its `enabled`
    /// (default `true`); without one, `false` (the pass is opt-in while it is experimental).
    pub fn self_contact_enabled(&self) -> bool {
        self.self_contact
            .as_ref()
            .is_some_and(|s| s.enabled.unwrap_or(true))
    }

    /// How working regions are derived: `threshold` and `grow_rings` of `[self_contact]`, else
    /// [`RegionOptions::default`].
    pub fn self_contact_regions(&self) -> RegionOptions {
        let d = RegionOptions::default();
        let s = self.self_contact.as_ref();
        RegionOptions {
            threshold: s.and_then(|s| s.threshold).unwrap_or(d.threshold),
            grow_rings: s.and_then(|s| s.grow_rings).unwrap_or(d.grow_rings),
        }
    }

    /// Whether resolving `[self_contact]` needs the rig's derived joint pairs: pair names to
    /// check, an `extent_factor` (relative to the bodies that have pairs), or a `direction`
    /// for every pair not named (given to each derived pair).
    pub fn self_contact_needs_pairs(&self) -> bool {
        self.self_contact.as_ref().is_some_and(|s| {
            !s.pairs.is_empty() || s.extent_factor.is_some() || s.direction.is_some()
        })
    }

    /// Resolves `[self_contact]` against `rig` (`welded`: its welded bodies, in body order),
    /// deriving the joint pairs ([`derive_pairs`] with [`Self::self_contact_regions`]) only
    /// when [`Self::self_contact_needs_pairs`]. See [`Self::resolve_self_contact_with`].
    pub fn resolve_self_contact(
        &self,
        rig: &Rig,
        welded: &[WeldedMesh],
    ) -> Result<SelfContactSettings, ConfigError> {
        let derived: Vec<(usize, String)> = if self.self_contact_needs_pairs() {
            let field = match self.self_contact.as_ref() {
                Some(s) if !s.pairs.is_empty() => "self_contact.pair[0].name",
                Some(s) if s.extent_factor.is_some() => "self_contact.extent_factor",
                _ => "self_contact.direction",
            };
            derive_pairs(rig, welded, &self.self_contact_regions())
                .map_err(|source| ConfigError::SelfContact {
                    file: self.file.clone(),
                    field: field.into(),
                    source: Box::new(source),
                })?
                .into_iter()
                .map(|r| (r.pair.body, r.pair.name))
                .collect()
        } else {
            Vec::new()
        };
        self.resolve_self_contact_with(rig, &derived)
    }

    /// Resolves `[self_contact]` given the joint pairs derived from the rig, `(body, name)` as
    /// [`derive_pairs`] or [`crate::selfcontact::pass::SelfContactPass::pairs`] give them:
    /// every value the file does not set keeps [`FoldParams::default`] (and
    /// [`RegionOptions::default`]); `extent_factor` multiplies the rest size
    /// ([`rest_sizes`]) of the body of the pairs (the largest when several bodies have
    /// pairs, since one [`FoldParams`] serves every pair); a `[[self_contact.pair]]` naming no
    /// derived pair is a [`ConfigError::UnknownPair`] listing the derived names. Directions
    /// are normalized.
    pub fn resolve_self_contact_with(
        &self,
        rig: &Rig,
        derived: &[(usize, String)],
    ) -> Result<SelfContactSettings, ConfigError> {
        let spec = self.self_contact.clone().unwrap_or_default();
        let params = self.fold_params(&spec, rig, derived)?;
        let (passes, max_passes) = sweeps(&spec);
        let (directions, pair_params) = self.pair_settings(&spec, &params, derived)?;
        for (j, sep) in spec.separated.iter().enumerate() {
            for (k, side) in sep.sides.iter().enumerate() {
                if side.is_empty() {
                    return Err(self.invalid(
                        format!("self_contact.separated[{j}].sides[{k}]"),
                        "is empty",
                    ));
                }
            }
        }
        Ok(SelfContactSettings {
            enabled: self.self_contact_enabled(),
            regions: self.self_contact_regions(),
            params,
            directions,
            pair_params,
            pair_enabled: (spec.pairs.iter())
                .filter_map(|p| p.enabled.map(|on| (p.name.clone(), on)))
                .collect(),
            passes,
            max_passes,
            separated: spec.separated.iter().map(|s| s.sides.clone()).collect(),
            separated_from_skeleton: spec.separated_from_skeleton.unwrap_or(true),
        })
    }

    /// Every fold's parameters: the defaults with `[self_contact]`'s values; the extent from
    /// `extent`, else `extent_factor` times the largest rest size of a body with a `derived`
    /// pair (of any body when none has one), else per joint (`joint_extent`).
    fn fold_params(
        &self,
        spec: &SelfContactSpec,
        rig: &Rig,
        derived: &[(usize, String)],
    ) -> Result<FoldParams, ConfigError> {
        let mut params = FoldParams::default();
        set(&mut params.stiffness_1, spec.stiffness);
        set(&mut params.tau, spec.tau);
        set(&mut params.safeguard_angle, spec.safeguard_angle);
        set(&mut params.deform.gamma, spec.gamma);
        set(&mut params.deform.omega, spec.omega);
        set(&mut params.turn_guard, spec.turn_guard);
        set(&mut params.bulge_guard, spec.bulge_guard);
        set(&mut params.free_isolated_crease, spec.free_isolated_crease);
        if let Some(k) = spec.joint_extent {
            params.joint_extent = Some(k);
        }
        if let Some(e) = spec.extent {
            params.deform.extent = e;
            params.joint_extent = None;
        } else if let Some(f) = spec.extent_factor {
            let sizes = rest_sizes(rig);
            let with_pairs = derived
                .iter()
                .filter_map(|(b, _)| sizes.get(*b).copied())
                .fold(f64::NAN, f64::max);
            let all = sizes.iter().copied().fold(f64::NAN, f64::max);
            let size = if with_pairs.is_nan() { all } else { with_pairs };
            let extent = f * size;
            if !(extent.is_finite() && extent > 0.0) {
                return Err(self.invalid(
                    "self_contact.extent_factor",
                    format!("gives the extent {extent} (rest size {size})"),
                ));
            }
            params.deform.extent = extent;
            params.joint_extent = None;
        }
        Ok(params)
    }

    /// The `[[self_contact.pair]]` tables checked against the `derived` pair names: each
    /// pair's direction source (fixed directions normalized; the section's `direction` for the
    /// pairs that set none) and the parameters of those that set their own.
    fn pair_settings(
        &self,
        spec: &SelfContactSpec,
        params: &FoldParams,
        derived: &[(usize, String)],
    ) -> Result<PairSettings, ConfigError> {
        let mut directions = Vec::with_capacity(derived.len());
        let mut pair_params = Vec::new();
        for (j, p) in spec.pairs.iter().enumerate() {
            let at = format!("self_contact.pair[{j}]");
            if !derived.iter().any(|(_, n)| *n == p.name) {
                return Err(ConfigError::UnknownPair {
                    file: self.file.clone(),
                    field: format!("{at}.name"),
                    name: p.name.clone(),
                    available: list_pairs(derived),
                });
            }
            if let Some(own) = p.params(params) {
                pair_params.push((p.name.clone(), own));
            }
            let Some(SelfDirection(source)) = p.direction else {
                continue;
            };
            let source = match source {
                DirectionSource::Fixed(d) => {
                    let d = unit(&[d.x, d.y, d.z]).ok_or_else(|| {
                        self.invalid(format!("{at}.direction"), "is zero or not finite")
                    })?;
                    DirectionSource::Fixed(d)
                }
                other => other,
            };
            directions.push((p.name.clone(), source));
        }
        // The section's mode for every other derived pair.
        if let Some(SelfDirection(mode)) = spec.direction {
            for (_, name) in derived {
                if !directions.iter().any(|(n, _)| n == name) {
                    directions.push((name.clone(), mode));
                }
            }
        }
        Ok((directions, pair_params))
    }
}

/// Per pair name, its direction source and (for those that set their own) its parameters.
type PairSettings = (Vec<(String, DirectionSource)>, Vec<(String, FoldParams)>);

/// `*slot = value` when the configuration sets it.
fn set<T: Copy>(slot: &mut T, value: Option<T>) {
    if let Some(v) = value {
        *slot = v;
    }
}

/// Sweeps per frame and their most: `max_passes` alone bounds the default count too;
/// `passes` alone is exact.
fn sweeps(spec: &SelfContactSpec) -> (usize, usize) {
    let passes = spec
        .passes
        .unwrap_or(DEFAULT_FOLD_PASSES.min(spec.max_passes.unwrap_or(usize::MAX)));
    let max_passes = match (spec.passes, spec.max_passes) {
        (_, Some(max)) => max,
        (Some(_), None) => passes,
        (None, None) => DEFAULT_MAX_FOLD_PASSES,
    };
    (passes, max_passes)
}

/// `lips/head-jaw, ...` (at most 40 listed), or `none`.
fn list_pairs(derived: &[(usize, String)]) -> String {
    let mut s: Vec<String> = derived.iter().take(40).map(|(_, n)| n.clone()).collect();
    if derived.len() > 40 {
        s.push(format!("... ({} in all)", derived.len()));
    }
    if s.is_empty() {
        "none".into()
    } else {
        s.join(", ")
    }
}

/// `d` normalized (scaled first, so that huge or tiny finite components work); `None` when
/// zero or not finite.
fn unit(d: &[f64; 3]) -> Option<Vector3<f64>> {
    if !usable_direction(d) {
        return None;
    }
    let v = Vector3::from(*d);
    let m = v.amax();
    (v / m)
        .try_normalize(0.0)
        .filter(|u| u.iter().all(|x| x.is_finite()))
}

// ---------------------------------------------------------------------------------------------
// Painted bulge maps

impl ContactConfig {
    fn map_error(&self, field: &str, map: &str, message: impl Into<String>) -> ConfigError {
        ConfigError::BulgeMap {
            file: self.file.clone(),
            field: field.to_string(),
            map: map.to_string(),
            message: message.into(),
        }
    }

    /// The painted map of body `b` per welded vertex.
    fn painted(
        &self,
        rig: &Rig,
        welded: &WeldedMesh,
        b: usize,
        map: &str,
        field: &str,
    ) -> Result<Vec<f64>, ConfigError> {
        let body = &rig.bodies[b];
        let values = match map.strip_prefix(ATTRIBUTE_PREFIX) {
            Some(name) => self.attribute_map(rig, b, name, field)?,
            None => self.file_map(map, field)?,
        };
        if values.len() != body.vertex_count() {
            return Err(ConfigError::BulgeCount {
                file: self.file.clone(),
                field: field.to_string(),
                map: map.to_string(),
                body: body.name.clone(),
                expected: body.vertex_count(),
                got: values.len(),
            });
        }
        if let Some(v) = values.iter().position(|x| !x.is_finite()) {
            let message = format!("value of vertex {v} is {}, not finite", values[v]);
            return Err(self.map_error(field, map, message));
        }
        if welded.to_welded.len() != values.len() {
            let message = "the welded mesh does not match the body";
            return Err(self.map_error(field, map, message));
        }
        Ok(welded.gather(&values))
    }

    fn attribute_map(
        &self,
        rig: &Rig,
        b: usize,
        name: &str,
        field: &str,
    ) -> Result<Vec<f64>, ConfigError> {
        rig.extra_attribute(b, name)
            .map(<[f64]>::to_vec)
            .ok_or_else(|| {
                let names: Vec<&str> = rig
                    .extra_attributes
                    .get(b)
                    .map(|l| l.iter().map(|(n, _)| n.as_str()).collect())
                    .unwrap_or_default();
                ConfigError::UnknownAttribute {
                    file: self.file.clone(),
                    field: field.to_string(),
                    body: rig.bodies[b].name.clone(),
                    attribute: name.to_string(),
                    available: if names.is_empty() {
                        "none".into()
                    } else {
                        names.join(", ")
                    },
                }
            })
    }

    /// Reads a map file confined to the configuration's folder.
    fn file_map(&self, map: &str, field: &str) -> Result<Vec<f64>, ConfigError> {
        let path = crate::rig::confined_path(&self.base_dir, map).map_err(|e| match e {
            Confinement::Refused(why) => self.map_error(
                field,
                map,
                format!("the path {why}: a bulge map must lie inside the configuration's folder"),
            ),
            Confinement::Unreadable(message) => self.map_error(field, map, message),
        })?;
        let text = read_text(&path)
            .map_err(|e| self.map_error(field, map, format!("cannot read: {e}")))?;
        parse_map(&text).map_err(|message| self.map_error(field, map, message))
    }
}

/// The text of a configuration or bulge-map file ([`crate::rig::read_whole`]: a regular file of
/// at most [`MAX_FILE_BYTES`]).
fn read_text(path: &Path) -> std::io::Result<String> {
    let bytes = crate::rig::read_whole(path, MAX_FILE_BYTES).map_err(|e| match e {
        crate::rig::Unreadable::Io(e) => e,
        refused => std::io::Error::other(refused.to_string()),
    })?;
    String::from_utf8(bytes).map_err(|e| std::io::Error::new(std::io::ErrorKind::InvalidData, e))
}

/// The numbers of a bulge-map text: whitespace separated, `#` starts a comment. Non-finite
/// values are an error.
pub fn parse_map(text: &str) -> Result<Vec<f64>, String> {
    let mut out = Vec::new();
    for (l, line) in text.lines().enumerate() {
        let content = line.split('#').next().unwrap_or("");
        for token in content.split_whitespace() {
            let v: f64 = token
                .parse()
                .map_err(|_| format!("line {}: '{token}' is not a number", l + 1))?;
            if !v.is_finite() {
                return Err(format!("line {}: value '{token}' is not finite", l + 1));
            }
            out.push(v);
        }
    }
    Ok(out)
}
