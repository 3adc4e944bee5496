//! The `[self_contact]` table resolved against a rig: the inputs of
//! [`crate::selfcontact::pass::SelfContactPass::new`]
//! ([`ContactConfig::resolve_self_contact`]), and the pass built from them as `pose` runs it
//! ([`SelfContactSettings::pass`]).

use super::check::usable_direction;
use super::{
    rest_sizes, ConfigError, ContactConfig, SelfContactSettings, SelfContactSpec, SelfDirection,
    SeparatedSpec,
};
use crate::mesh::WeldedMesh;
use crate::pass::RestOverlaps;
use crate::rig::Rig;
use crate::selfcontact::fold::FoldParams;
use crate::selfcontact::pass::{
    SelfContactPass, SelfPassError, DEFAULT_FOLD_PASSES, DEFAULT_MAX_FOLD_PASSES,
};
use crate::selfcontact::regions::node_name;
use crate::selfcontact::{
    derive_pairs, extend_distinct, separated_from_skeleton, separated_regions, DirectionSource,
    PairRegions, RegionOptions, SelfContactError,
};
use nalgebra::{Point3, Vector3};

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
        self.check_separated(&spec.separated, rig)?;
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

    /// `[[self_contact.separated]]`: each side names joints of the rig, none twice nor on both
    /// sides, and no pair of sides is given twice (in either order): a repeated pair was
    /// resolved twice per frame (found by review: the capsule's unbalanced folds 2 → 5), and a
    /// missing name was reported without the file and the field.
    fn check_separated(&self, separated: &[SeparatedSpec], rig: &Rig) -> Result<(), ConfigError> {
        let mut seen: Vec<[Vec<&str>; 2]> = Vec::new();
        for (j, sep) in separated.iter().enumerate() {
            let at = format!("self_contact.separated[{j}].sides");
            for (k, side) in sep.sides.iter().enumerate() {
                let field = format!("{at}[{k}]");
                if side.is_empty() {
                    return Err(self.invalid(field, "is empty"));
                }
                for (i, name) in side.iter().enumerate() {
                    if !(0..rig.nodes.len()).any(|n| node_name(rig, n) == *name) {
                        return Err(self.invalid(field, format!("no node is named \"{name}\"")));
                    }
                    if side[..i].contains(name) {
                        return Err(self.invalid(field, format!("names \"{name}\" twice")));
                    }
                }
            }
            let [a, b] = &sep.sides;
            if let Some(name) = a.iter().find(|n| b.contains(n)) {
                return Err(self.invalid(at, format!("\"{name}\" is on both sides")));
            }
            let key = sorted_sides(&sep.sides);
            if let Some(first) = seen.iter().position(|k| *k == key) {
                return Err(ConfigError::Duplicate {
                    file: self.file.clone(),
                    field: at,
                    what: format!("separated regions {:?} / {:?}", key[0], key[1]),
                    first: format!("self_contact.separated[{first}]"),
                });
            }
            seen.push(key);
        }
        Ok(())
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

impl SelfContactSettings {
    /// The separated regions these settings name (`[[self_contact.separated]]`, in the file's
    /// order), then those the skeleton derives when `separated_from_skeleton` is on, a pair
    /// already named listed once ([`crate::selfcontact::extend_distinct`]).
    pub fn separated_regions(
        &self,
        rig: &Rig,
        welded: &[WeldedMesh],
    ) -> Result<Vec<PairRegions>, SelfContactError> {
        let mut separated = Vec::new();
        for [a, b] in &self.separated {
            separated.extend(separated_regions(rig, welded, [a, b], &self.regions)?);
        }
        if self.separated_from_skeleton {
            let derived = separated_from_skeleton(rig, welded, &self.regions)?;
            extend_distinct(&mut separated, derived);
        }
        Ok(separated)
    }

    /// The self-contact pass as `pose --self-contact` runs it, precomputed on `rest` (the
    /// welded rest positions per body): the joint pairs from the skin weights and the
    /// separated regions ([`SelfContactSettings::separated_regions`]), with these settings'
    /// sweeps, per-pair parameters and enabled pairs; pairs crossing at rest left out
    /// ([`RestOverlaps::LeftOut`]: modeled overlaps, not contacts).
    pub fn pass(
        &self,
        rig: &Rig,
        welded: &[WeldedMesh],
        rest: &[Vec<Point3<f64>>],
    ) -> Result<SelfContactPass, SelfPassError> {
        let separated = self.separated_regions(rig, welded)?;
        SelfContactPass::with_separated(
            rig,
            welded,
            rest,
            &self.regions,
            self.params,
            &self.directions,
            separated,
        )?
        .with_passes(self.passes)
        .with_max_passes(self.max_passes)
        .with_pair_params(&self.pair_params)?
        .with_rest_overlaps(RestOverlaps::LeftOut)
        .with_pair_enabled(&self.pair_enabled)
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

/// A pair of sides as a set of sets: each side's names sorted, the two sides in order.
fn sorted_sides(sides: &[Vec<String>; 2]) -> [Vec<&str>; 2] {
    let mut key = sides.each_ref().map(|side| {
        let mut names: Vec<&str> = side.iter().map(String::as_str).collect();
        names.sort_unstable();
        names
    });
    key.sort();
    key
}

/// `d` normalized; `None` when [`usable_direction`] refuses it (zero, not finite, or a length
/// whose square overflows or underflows: `[1e200, 1e200, 0]` and `[1e-200, 0, 0]` are refused
/// as for the contact pairs' directions, which are normalized without scaling later).
pub(super) fn unit(d: &[f64; 3]) -> Option<Vector3<f64>> {
    if !usable_direction(d) {
        return None;
    }
    let v = Vector3::from(*d);
    let m = v.amax();
    (v / m)
        .try_normalize(0.0)
        .filter(|u| u.iter().all(|x| x.is_finite()))
}
