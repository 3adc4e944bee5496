//! The self-contact part of `contact-skin info`: the joint pairs derived (or configured), each
//! with its regions, direction and parameters, and the ones the pass leaves out, and why.

use super::length;
use contact_skin::config::{self, ContactConfig};
use contact_skin::mesh::WeldedMesh;
use contact_skin::pass::RestOverlaps;
use contact_skin::rig::Rig;
use contact_skin::selfcontact::layers::Layer;
use contact_skin::selfcontact::pass::SelfContactPass;
use contact_skin::selfcontact::{
    derive_pairs_reporting, extend_distinct, separated_from_skeleton, separated_regions, BoneAxes,
    DirectionSource, PairRegions,
};
use serde::Serialize;
use std::path::Path;

/// One joint pair derived from the skin weights (a possible fold), or a pair of separated
/// regions the configuration names (`[[self_contact.separated]]`).
#[derive(Serialize)]
struct SelfPairInfo {
    body: usize,
    body_name: String,
    /// `body/parent-child`: the name `[[self_contact.pair]]` uses.
    name: String,
    parent: String,
    child: String,
    /// Welded vertices of the shared region `R`.
    shared: usize,
    /// Rings the regions were grown by (fewer than the configured `grow_rings` where that
    /// growth left `R` without a partition of unity).
    grow_rings: usize,
    /// How the regions were derived (thresholds, counts, the partition of unity).
    reason: String,
    /// The user direction of `[[self_contact.pair]]`, normalized (`null`: not fixed).
    direction: Option<[f64; 3]>,
    /// Where the direction comes from: `"skeleton"`, `"fixed"` or `"motion"`; `"normals"`
    /// (Eq. 2) for separated regions.
    direction_source: &'static str,
    /// Separated regions (no shared region: Sec. 4-5 alone, `parent` and `child` the first
    /// joint of each side).
    separated: bool,
    /// A leaf joint pair's fold angle at rest in degrees when it exceeds 90° (the skeleton's
    /// direction keeps that fold's sense past a full fold:
    /// `contact_skin::selfcontact::RestFold`); `null` otherwise. Given whatever the pair's
    /// direction source (the text report shows it for the skeleton's only).
    rest_fold_degrees: Option<f64>,
    /// The same, for the text report.
    #[serde(skip)]
    source: DirectionSource,
    /// The joint's size (`PairRegions::joint_size`: a second moment of `R` at rest).
    joint_size: f64,
    /// `φ̄` of this pair in scene units.
    extent: f64,
    /// This pair's `τ`, `γ` and `ω`: its `[[self_contact.pair]]` values, else the section's.
    tau: f64,
    gamma: f64,
    omega: f64,
    /// `FoldParams::free_isolated_crease` of this pair.
    free_isolated_crease: bool,
    /// Whether `[[self_contact.pair]]` sets any of `τ`, `γ`, `ω`, `free_isolated_crease` for
    /// this pair.
    own_params: bool,
    /// Face pairs of its two sides crossing at rest, when they do (`SelfContactPass::
    /// crossing_at_rest`).
    crossing_at_rest: Option<usize>,
    /// Why its detection failed at rest, when it did.
    failure_at_rest: Option<String>,
    /// `pose` leaves it as it comes in every frame: its sides cross at rest (and
    /// `[[self_contact.pair]] enabled = true` does not resolve it), or `enabled = false`.
    left_out: bool,
    /// The separate pieces of the mesh sunk into it or lying inside others at rest that it
    /// runs without (they follow the skinning; `SelfContactPass::layers`).
    layers: Vec<Layer>,
}

/// The self-contact pass as it would run: its parameters, resolved, and the joint pairs.
#[derive(Serialize)]
pub(super) struct SelfContactInfo {
    /// `[self_contact] enabled` (default true).
    enabled: bool,
    /// Sweeps over the folds per frame.
    passes: usize,
    /// Largest number of sweeps, those past `passes` while a fold's shared region still
    /// penetrates.
    max_passes: usize,
    /// The configuration has a `[self_contact]` table (else: the pass defaults).
    configured: bool,
    threshold: f64,
    grow_rings: usize,
    /// `k̄` of the parent side.
    stiffness: f64,
    tau: f64,
    /// The safeguard angle of Sec. 4.4, degrees.
    safeguard_angle: f64,
    /// `φ̄` as a multiple of each joint's size (`null`: `extent` in scene units for all).
    joint_extent: Option<f64>,
    /// `φ̄` in scene units when `joint_extent` is `null`.
    extent: f64,
    gamma: f64,
    omega: f64,
    /// Separated regions are also derived from the skeleton (`[self_contact]
    /// separated_from_skeleton`, default true).
    separated_from_skeleton: bool,
    /// Joint pairs per body, in the order the pass resolves them.
    pairs: Vec<SelfPairInfo>,
    /// Why the pairs could not be derived (`null` when they could).
    error: Option<String>,
    /// Parent/child joint pairs left out, one reason each (e.g. a shared region without a
    /// border toward one side, where no partition of unity exists).
    skipped: Vec<String>,
}

/// The self-contact pass of the rig under its configuration (or the defaults): derived joint
/// pairs with their reasons and the user directions that apply. A configuration error
/// (numbers, unknown pair) is an error; pairs that cannot be derived are reported in `error`.
pub(super) fn describe_self_contact(
    path: &Path,
    explicit: Option<&Path>,
    rig: &Rig,
    welded: &[WeldedMesh],
) -> Result<SelfContactInfo, config::ConfigError> {
    let cfg = ContactConfig::for_rig(path, explicit)?.unwrap_or_default();
    let found = pairs_as_the_pass_finds_them(&cfg, rig, welded)?;
    let settings = &found.settings;
    let f = &settings.params;
    // The rest pose as the pass sees it (skinned at rest: node transforms included).
    let pre = contact_skin::frames::Precomputed::new(rig, contact_skin::skinning::Method::Lbs);
    let rest = contact_skin::frames::welded_positions(rig, &pre, None, 0.0);
    let mut pairs: Vec<SelfPairInfo> = found
        .regions
        .iter()
        .map(|r| pair_info(r, settings, rig, (&pre, &rest)))
        .collect();
    if found.error.is_none() {
        mark_left_out(&mut pairs, &found, (&pre, &rest), rig);
    }
    Ok(SelfContactInfo {
        joint_extent: f.joint_extent,
        enabled: settings.enabled,
        passes: settings.passes,
        max_passes: settings.max_passes,
        configured: cfg.self_contact.is_some(),
        threshold: settings.regions.threshold,
        grow_rings: settings.regions.grow_rings,
        stiffness: f.stiffness_1,
        tau: f.tau,
        safeguard_angle: f.safeguard_angle,
        extent: f.deform.extent,
        gamma: f.deform.gamma,
        omega: f.deform.omega,
        separated_from_skeleton: settings.separated_from_skeleton,
        pairs,
        error: found.error,
        skipped: found.skipped,
    })
}

/// Marks the `pairs` (listed from `found`) whose sides cross at rest, and those `pose`
/// leaves out, from the pass as `pose` builds it on `rest` (none marked if it cannot be
/// built: `pose` then runs without it).
fn mark_left_out(
    pairs: &mut [SelfPairInfo],
    found: &FoundPairs,
    (pre, rest): (
        &contact_skin::frames::Precomputed,
        &[Vec<nalgebra::Point3<f64>>],
    ),
    rig: &Rig,
) {
    let s = &found.settings;
    let separated = found.regions.iter().filter(|r| r.separated()).cloned();
    let pass = SelfContactPass::with_separated(
        rig,
        &pre.welded,
        rest,
        &s.regions,
        s.params,
        &s.directions,
        separated.collect(),
    );
    let Ok(pass) = pass.and_then(|p| {
        (p.with_rest_overlaps(RestOverlaps::LeftOut)).with_pair_enabled(&s.pair_enabled)
    }) else {
        return;
    };
    let left_out = pass.left_out();
    let crossing = pass.crossing_at_rest();
    let layered = pass.layers();
    for p in pairs {
        p.layers = (layered.iter())
            .find(|f| f.body == p.body && f.name == p.name)
            .map_or(Vec::new(), |f| f.layers.clone());
        let at_rest = crossing
            .iter()
            .find(|c| c.body == p.body && c.name == p.name);
        p.crossing_at_rest = at_rest.and_then(|c| c.crossing_face_pairs());
        p.failure_at_rest = at_rest.and_then(|c| c.failure.clone());
        p.left_out = left_out
            .iter()
            .any(|f| f.body == p.body && f.name == p.name);
    }
}

/// The self-contact pass's working regions as `pose` would build them, with the resolved
/// settings, the pairs left out and why, and the first error met (the listing goes on
/// without the pairs it concerns).
struct FoundPairs {
    regions: Vec<PairRegions>,
    settings: config::SelfContactSettings,
    skipped: Vec<String>,
    error: Option<String>,
}

/// The parent/child pairs from the skin weights, then the configured and the skeleton's
/// separated regions, as [`contact_skin::selfcontact::pass::SelfContactPass`] is built.
fn pairs_as_the_pass_finds_them(
    cfg: &ContactConfig,
    rig: &Rig,
    welded: &[WeldedMesh],
) -> Result<FoundPairs, config::ConfigError> {
    let (mut regions, skipped, mut error): (Vec<PairRegions>, Vec<String>, Option<String>) =
        match derive_pairs_reporting(rig, welded, &cfg.self_contact_regions()) {
            Ok((r, skipped)) => (r, skipped, None),
            Err(e) => (Vec::new(), Vec::new(), Some(e.to_string())),
        };
    let derived: Vec<(usize, String)> = regions
        .iter()
        .map(|r| (r.pair.body, r.pair.name.clone()))
        .collect();
    let settings = if error.is_some() {
        // Without the pairs the names cannot be checked: resolve the numbers only.
        let mut numbers_only = cfg.clone();
        if let Some(sc) = numbers_only.self_contact.as_mut() {
            sc.pairs.clear();
        }
        numbers_only.resolve_self_contact_with(rig, &derived)?
    } else {
        cfg.resolve_self_contact_with(rig, &derived)?
    };
    for [a, b] in &settings.separated {
        match separated_regions(rig, welded, [a, b], &settings.regions) {
            Ok(found) => regions.extend(found),
            Err(e) => {
                error.get_or_insert_with(|| e.to_string());
            }
        }
    }
    if settings.separated_from_skeleton {
        match separated_from_skeleton(rig, welded, &settings.regions) {
            // As the pass does: a configured pair the skeleton also derives is listed once.
            Ok(found) => extend_distinct(&mut regions, found),
            Err(e) => {
                error.get_or_insert_with(|| e.to_string());
            }
        }
    }
    Ok(FoundPairs {
        regions,
        settings,
        skipped,
        error,
    })
}

/// One pair's listing: its regions `r`, its resolved parameters (its own or the pass's) and
/// its sizes on the rest pose (`rest`: the welded positions `pre` skins at rest).
fn pair_info(
    r: &PairRegions,
    settings: &config::SelfContactSettings,
    rig: &Rig,
    (pre, rest): (
        &contact_skin::frames::Precomputed,
        &[Vec<nalgebra::Point3<f64>>],
    ),
) -> SelfPairInfo {
    let p = &r.pair;
    let f = &settings.params;
    let node = |n: usize| {
        rig.nodes
            .get(n)
            .and_then(|x| x.name.clone())
            .unwrap_or_else(|| format!("node{n}"))
    };
    let joint_size = rest
        .get(p.body)
        .zip(pre.welded.get(p.body))
        .map_or(f64::NAN, |(x, w)| r.joint_size(x, &w.triangles));
    let source = settings
        .directions
        .iter()
        .find(|(n, _)| *n == p.name)
        .map_or(DirectionSource::Skeleton, |(_, d)| *d);
    let own = settings
        .pair_params
        .iter()
        .find(|(n, _)| *n == p.name)
        .map(|(_, q)| q);
    let q = own.unwrap_or(f);
    SelfPairInfo {
        tau: q.tau,
        gamma: q.deform.gamma,
        omega: q.deform.omega,
        free_isolated_crease: q.free_isolated_crease,
        own_params: own.is_some(),
        crossing_at_rest: None,
        failure_at_rest: None,
        left_out: false,
        layers: Vec::new(),
        joint_size,
        extent: f.joint_extent.map_or(f.deform.extent, |k| k * joint_size),
        body: p.body,
        body_name: rig.bodies[p.body].name.clone(),
        name: p.name.clone(),
        parent: node(p.parent_joint),
        child: node(p.child_joint),
        shared: r.shared.len(),
        grow_rings: r.grow_rings,
        reason: r.reason.clone(),
        direction: source.fixed(),
        direction_source: if r.separated() {
            "normals"
        } else {
            source.label()
        },
        separated: r.separated(),
        rest_fold_degrees: pre
            .welded
            .get(p.body)
            .and_then(|w| BoneAxes::new(rig, w, r).rest_fold)
            .map(|f| f.angle.to_degrees()),
        source,
    }
}

/// The self-contact pass as text: its parameters, then each joint pair.
pub(super) fn print_self_contact(s: &SelfContactInfo) {
    println!(
        "  self-contact ({}{}): {} sweep(s) per frame{}, threshold {}, grow rings {}, stiffness {}, tau {}, safeguard {} deg, extent {}, gamma {}, omega {}, separated regions from the skeleton {}",
        if s.enabled { "on" } else { "off" },
        if s.configured {
            ", [self_contact] of the configuration"
        } else {
            ", defaults"
        },
        s.passes,
        if s.max_passes > s.passes {
            format!(" (up to {} while a fold still penetrates)", s.max_passes)
        } else {
            String::new()
        },
        s.threshold,
        s.grow_rings,
        s.stiffness,
        s.tau,
        s.safeguard_angle,
        match s.joint_extent {
            Some(k) => format!("{k} x joint size"),
            None => length(s.extent),
        },
        s.gamma,
        s.omega,
        if s.separated_from_skeleton { "on" } else { "off" }
    );
    if let Some(e) = &s.error {
        println!("    joint pairs cannot be derived: {e}");
    } else if s.pairs.is_empty() && s.skipped.is_empty() {
        println!(
            "    no joint pair (no body is deformed by a parent and a child joint; joints whose \
             nodes are not nested are paired only when named as a tracked hand's)"
        );
    } else if s.pairs.is_empty() {
        println!("    no usable joint pair");
    }
    for reason in &s.skipped {
        println!("    skipped {reason}");
    }
    if !s.pairs.is_empty() {
        let separated = s.pairs.iter().filter(|p| p.separated).count();
        println!(
            "    {} joint pair(s) (parent/child), {separated} pair(s) of separated regions",
            s.pairs.len() - separated
        );
    }
    for p in &s.pairs {
        print_pair(p);
    }
}

/// One joint pair of [`print_self_contact`]: what it is, why it was derived, what it runs
/// without.
fn print_pair(p: &SelfPairInfo) {
    let own = if p.own_params {
        format!(
            ", tau {}, gamma {}, omega {} (this pair's)",
            p.tau, p.gamma, p.omega
        )
    } else {
        String::new()
    };
    let own = if p.free_isolated_crease {
        format!("{own}, isolated crease vertices out of the zones")
    } else {
        own
    };
    println!(
        "    pair '{}' (body {} '{}', joints '{}' {} '{}'): shared region {} vertices, joint size {}, extent {}, {}{own}",
        p.name,
        p.body,
        p.body_name,
        p.parent,
        if p.separated { "vs" } else { "->" },
        p.child,
        p.shared,
        length(p.joint_size),
        length(p.extent),
        direction_text(p)
    );
    println!("      {}", p.reason);
    if let Some(line) = left_out_line(p) {
        println!("      {line}");
    }
    if !p.layers.is_empty() {
        let faces: Vec<String> = p.layers.iter().map(|l| l.faces.to_string()).collect();
        println!(
            "      runs without {} separate piece(s) of the mesh sunk into it or lying inside others at rest ({} faces), which follow the skinning",
            p.layers.len(),
            faces.join(", ")
        );
    }
}

/// Where a pair's mapping direction comes from, as [`print_pair`] says it.
fn direction_text(p: &SelfPairInfo) -> String {
    match p.source {
        _ if p.separated => "separated regions, direction from the normals (Eq. 2)".into(),
        DirectionSource::Fixed(d) => format!("direction {:?} (configured)", [d.x, d.y, d.z]),
        DirectionSource::Motion => "direction from the relative motion of the parts".into(),
        DirectionSource::Skeleton => match p.rest_fold_degrees {
            Some(a) => format!(
                "direction from the skeleton (folded {a:.1} deg at rest: that fold's sense \
                 is kept past a full fold)"
            ),
            None => "direction from the skeleton".into(),
        },
    }
}

/// What `pose` does with a pair whose sides cross at rest, or that it leaves out.
fn left_out_line(p: &SelfPairInfo) -> Option<String> {
    let at_rest = match (p.crossing_at_rest, &p.failure_at_rest) {
        (Some(n), _) => Some(format!("its two sides cross at rest ({n} face pairs)")),
        (None, Some(e)) => Some(format!("its detection fails at rest ({e})")),
        (None, None) => None,
    };
    match (at_rest, p.left_out) {
        (Some(why), true) => Some(format!(
            "{why}: left as it comes in every frame (modeled overlap; [[self_contact.pair]] enabled = true resolves it)"
        )),
        (Some(why), false) => Some(format!("{why}: resolved (enabled = true)")),
        (None, true) => Some("left as it comes in every frame (enabled = false)".into()),
        (None, false) => None,
    }
}
