//! The contact part of `contact-skin info`: each object's parameters, the pairs' overrides and
//! directions, and the pairs whose surfaces already cross at rest.

use super::length;
use contact_skin::config::{self, ContactConfig};
use contact_skin::contact::zones::DEFAULT_SAFEGUARD_ANGLE;
use contact_skin::mesh::WeldedMesh;
use contact_skin::pass::{rest_bodies, ContactPass, RestOverlaps, DEFAULT_EXTENT_FACTOR};
use contact_skin::rig::Rig;
use serde::Serialize;
use std::path::Path;

/// The resolved contact parameters of one body.
#[derive(Serialize)]
struct ObjectInfo {
    body: usize,
    name: String,
    /// Named by an `[[object]]` table (else: the defaults).
    configured: bool,
    /// `null` for a rigid body.
    stiffness: Option<f64>,
    tau: f64,
    /// `φ̄` in scene units (the pass default resolved when the file does not set it).
    extent: f64,
    gamma: f64,
    omega: f64,
    /// The painted map as written (`null`: none).
    bulge_map: Option<String>,
    /// Smallest and largest painted value (welded vertices).
    painted_range: Option<[f64; 2]>,
    /// Takes part in contacts between bodies (`[[object]] contact = false`: not).
    contact: bool,
}

/// One configured pair.
#[derive(Serialize)]
struct PairInfo {
    bodies: [usize; 2],
    names: [String; 2],
    tau: Option<f64>,
    /// Degrees (the default, 80°, unless the pair sets it).
    safeguard_angle: f64,
    /// `automatic`, `constant [x, y, z]` or `N keys from t0 to t1`.
    direction: String,
    /// `[[pair]] enabled` as configured (`false`: not resolved; `true`: resolved even when
    /// the bodies cross at rest; `null`: the default, resolved unless they do).
    enabled: Option<bool>,
}

/// A pair of bodies whose surfaces cross at rest
/// ([`contact_skin::pass::ContactPass::crossing_at_rest`]).
#[derive(Serialize)]
pub(super) struct RestCrossingInfo {
    bodies: [usize; 2],
    names: [String; 2],
    /// Resolved anyway (`[[pair]] enabled = true`); by default such a pair is left out.
    resolved: bool,
}

/// The contact configuration of the rig, resolved.
#[derive(Serialize)]
pub(super) struct ContactInfo {
    file: String,
    passes: usize,
    objects: Vec<ObjectInfo>,
    pairs: Vec<PairInfo>,
}

/// Resolves the rig's configuration, if there is one.
pub(super) fn describe_contact(
    path: &Path,
    explicit: Option<&Path>,
    rig: &Rig,
    welded: &[WeldedMesh],
) -> Result<Option<ContactInfo>, config::ConfigError> {
    let Some(cfg) = ContactConfig::for_rig(path, explicit)? else {
        return Ok(None);
    };
    let (params, overrides, passes) = cfg.resolve(rig, welded)?;
    let sizes = config::rest_sizes(rig);
    let mut configured: Vec<Option<&config::ObjectSpec>> = vec![None; rig.bodies.len()];
    for (i, o) in cfg.objects.iter().enumerate() {
        let b = cfg.body_index(rig, &o.name, &format!("object[{i}].name"))?;
        configured[b] = Some(o);
    }
    let objects = params
        .iter()
        .enumerate()
        .map(|(b, p)| ObjectInfo {
            body: b,
            name: rig.bodies[b].name.clone(),
            configured: configured[b].is_some(),
            stiffness: p.stiffness.is_finite().then_some(p.stiffness),
            tau: p.tau,
            extent: p.extent.unwrap_or(DEFAULT_EXTENT_FACTOR * sizes[b]),
            gamma: p.gamma,
            omega: p.omega,
            bulge_map: configured[b].and_then(|o| o.bulge_map.clone()),
            painted_range: p.painted.as_ref().map(|v| {
                let lo = v.iter().copied().fold(f64::INFINITY, f64::min);
                let hi = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
                [lo, hi]
            }),
            contact: p.contact,
        })
        .collect();
    let pairs = overrides
        .iter()
        .zip(&cfg.pairs)
        .map(|(o, spec)| PairInfo {
            bodies: o.bodies,
            names: o.bodies.map(|b| rig.bodies[b].name.clone()),
            tau: o.tau,
            safeguard_angle: o.safeguard_angle.unwrap_or(DEFAULT_SAFEGUARD_ANGLE),
            direction: describe_direction(spec),
            enabled: o.enabled,
        })
        .collect();
    Ok(Some(ContactInfo {
        file: cfg.file.display().to_string(),
        passes,
        objects,
        pairs,
    }))
}

fn describe_direction(p: &config::PairSpec) -> String {
    match (&p.direction, &p.direction_keys) {
        (Some(d), _) => format!("constant {d:?}"),
        (None, Some(keys)) => {
            let t = keys.iter().map(|k| k[0]);
            let lo = t.clone().fold(f64::INFINITY, f64::min);
            let hi = t.fold(f64::NEG_INFINITY, f64::max);
            format!("{} keys from t = {lo} to t = {hi}", keys.len())
        }
        (None, None) => "automatic".into(),
    }
}

/// The resolved configuration as text: objects, pairs, and their directions.
pub(super) fn print_contact(c: &ContactInfo) {
    println!(
        "  contact configuration {} ({} passes per frame):",
        c.file, c.passes
    );
    for o in &c.objects {
        let k = o.stiffness.map_or("rigid".into(), |k| k.to_string());
        let map = match (&o.bulge_map, o.painted_range) {
            (Some(m), Some([lo, hi])) => format!(", bulge map {m} (values {lo} to {hi})"),
            _ => String::new(),
        };
        if !o.contact {
            println!(
                "    object {} '{}': no contact between bodies (contact = false)",
                o.body, o.name
            );
            continue;
        }
        println!(
            "    object {} '{}'{}: stiffness {k}, tau {}, extent {}, gamma {}, omega {}{map}",
            o.body,
            o.name,
            if o.configured { "" } else { " (defaults)" },
            o.tau,
            length(o.extent),
            o.gamma,
            o.omega
        );
    }
    for p in &c.pairs {
        if p.enabled == Some(false) {
            println!(
                "    pair '{}' / '{}': not resolved (enabled = false)",
                p.names[0], p.names[1]
            );
            continue;
        }
        let tau = p.tau.map_or("from the objects".into(), |t| t.to_string());
        println!(
            "    pair '{}' / '{}': tau {tau}, safeguard {} deg, direction {}",
            p.names[0], p.names[1], p.safeguard_angle, p.direction
        );
    }
}

/// The pairs of bodies crossing at rest, as `pose`'s contact pass finds them (its pass, built
/// on the rest pose skinned with LBS, the configuration's objects left out of contacts
/// excluded).
pub(super) fn describe_crossing_at_rest(
    path: &Path,
    explicit: Option<&Path>,
    rig: &Rig,
) -> Result<Vec<RestCrossingInfo>, Box<dyn std::error::Error + Send + Sync>> {
    if rig.bodies.len() < 2 {
        return Ok(Vec::new());
    }
    let cfg = ContactConfig::for_rig(path, explicit)?.unwrap_or_default();
    let pre = contact_skin::frames::Precomputed::new(rig, contact_skin::skinning::Method::Lbs);
    let (params, overrides, _) = cfg.resolve(rig, &pre.welded)?;
    let rest = contact_skin::frames::welded_positions(rig, &pre, None, 0.0);
    let pass = ContactPass::new(&rest_bodies(&rest, &pre.welded), params, overrides)?
        .with_rest_overlaps(RestOverlaps::LeftOut);
    let left_out = pass.left_out_at_rest();
    Ok((pass.crossing_at_rest().iter())
        .map(|&bodies| RestCrossingInfo {
            bodies,
            names: bodies.map(|b| rig.bodies[b].name.clone()),
            resolved: !left_out.contains(&bodies),
        })
        .collect())
}

/// The pairs of bodies crossing at rest as text, and what the pass does with them.
pub(super) fn print_crossing_at_rest(pairs: &[RestCrossingInfo]) {
    if pairs.is_empty() {
        return;
    }
    let left_out = pairs.iter().filter(|p| !p.resolved).count();
    println!(
        "  {} pair(s) of bodies cross at rest (modeled overlaps), {left_out} left out of contacts ([[pair]] enabled = true resolves one):",
        pairs.len()
    );
    for p in pairs {
        println!(
            "    '{}' / '{}'{}",
            p.names[0],
            p.names[1],
            if p.resolved {
                ": resolved (enabled = true)"
            } else {
                ""
            }
        );
    }
}
