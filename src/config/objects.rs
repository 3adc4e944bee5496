//! Resolution against a rig: the contact pass's per-body parameters and pair overrides
//! ([`ContactConfig::resolve`]).

use super::{BodyRef, ConfigError, ContactConfig, PairSpec, ParamSpec, Resolved};
use crate::mesh::{surface_size, WeldedMesh};
use crate::pass::{DirectionTrack, ObjectParams, PairOverride};
use crate::rig::Rig;
use nalgebra::Vector3;

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
        let mut params: Vec<ObjectParams> = Vec::with_capacity(sizes.len());
        for &size in &sizes {
            params.push(self.object_params(&self.defaults, size, "defaults")?);
        }
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
            params[b] = self.object_params(&self.defaults.overlay(&o.params()), sizes[b], &at)?;
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

    /// [`object_params`], its extent from `extent_factor` times a body's `rest_size` checked
    /// finite and positive (1e308 times a body's size was an infinite extent, `null` in `info
    /// --json`, where `[self_contact]` refuses it); `at`: the table, for the error.
    fn object_params(
        &self,
        p: &ParamSpec,
        rest_size: f64,
        at: &str,
    ) -> Result<ObjectParams, ConfigError> {
        let params = object_params(p, rest_size);
        match (p.extent, p.extent_factor, params.extent) {
            (None, Some(_), Some(extent)) if !(extent.is_finite() && extent > 0.0) => Err(self
                .invalid(
                    format!("{at}.extent_factor"),
                    format!("gives the extent {extent} (rest size {rest_size})"),
                )),
            _ => Ok(params),
        }
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
