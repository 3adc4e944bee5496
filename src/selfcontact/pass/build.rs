//! The self-contact pass's folds as built once per rig: each fold's detection index (one per
//! body), how its sides meet at rest, and the separate pieces of the mesh it runs without
//! ([`crate::selfcontact::layers`]).

use super::posed::PosedBodies;
use super::{Fold, RestCrossing, SelfPassError, WithoutLayers};
use crate::intersect::MeshIndex;
use crate::mesh::operators::mean_edge_length;
use crate::mesh::WeldedMesh;
use crate::report::metrics::WindingNumber;
use crate::rig::Rig;
use crate::selfcontact::direction::{BoneAxes, DirectionSource};
use crate::selfcontact::fold::FoldPre;
use crate::selfcontact::layers::{Components, InsideMemo};
use crate::selfcontact::regions::PairRegions;
use nalgebra::Point3;
use std::collections::HashMap;
use std::sync::Arc;
use std::time::Instant;

/// The folds with their detection: one index per body with a fold, over the faces of all its folds'
/// sides (the rest of the body is never queried), each fold's sides marked in it. On a body of
/// several pieces, each fold runs on the surface of its own pieces ([`crate::selfcontact::layers`],
/// [`FoldPre::on_surface`]): the extra inside-twice trees, each shared by the folds on the same
/// surface, come with their body and rest edge length.
pub(super) fn with_detection(
    rig: &Rig,
    built: Vec<(usize, FoldPre, BoneAxes, DirectionSource)>,
    rest: &[Vec<Point3<f64>>],
    welded: &[WeldedMesh],
) -> Result<(Vec<Fold>, SurfaceSlots), SelfPassError> {
    let mut sided: Vec<Vec<u32>> = vec![Vec::new(); welded.len()];
    for (body, pre, ..) in &built {
        sided[*body].extend(pre.sided_faces());
    }
    let mut indices: Vec<Option<Arc<MeshIndex>>> = vec![None; welded.len()];
    let mut folds = Vec::with_capacity(built.len());
    for (body, pre, axes, direction) in built {
        let detection = match &mut indices[body] {
            Some(index) => Arc::clone(index),
            slot => {
                let faces = &mut sided[body];
                faces.sort_unstable();
                faces.dedup();
                let index = MeshIndex::with_faces(&rest[body], &welded[body].triangles, faces)
                    .map_err(|source| SelfPassError::Detection { body, source })?;
                Arc::clone(slot.insert(Arc::new(index)))
            }
        };
        folds.push(Fold {
            body,
            sets: pre.face_sets(&detection),
            detection,
            pre,
            axes,
            direction,
            params: None,
            at_rest: None,
            enabled: None,
            without: None,
            winding_slot: body,
        });
    }
    let mut positions = rest.to_vec();
    let mut bodies = PosedBodies::new(&mut positions, None, welded.len());
    let mut pieces: Vec<Option<BodyPieces>> = (0..welded.len()).map(|_| None).collect();
    let mut surfaces = Surfaces::new(welded.len());
    for fold in &mut folds {
        let (at_rest, face_pairs) = crossing_at(fold, &mut bodies);
        fold.at_rest = at_rest;
        let (body, triangles) = (fold.body, &welded[fold.body].triangles);
        let p = pieces[body].get_or_insert_with(|| BodyPieces {
            components: Components::of(&rest[body], triangles),
            memo: InsideMemo::default(),
        });
        if p.components.len() < 2 {
            continue;
        }
        let surface = (&rest[body][..], &triangles[..]);
        let layers = layers_of(fold, surface, p, &face_pairs);
        if !layers.is_empty() {
            let without = without_layers(rig, fold, &rest[body], &welded[body], p, &layers);
            if let Some(without) = without {
                if crossing_at(&without, &mut bodies).0.is_none() {
                    *fold = without;
                }
            }
        }
        surfaces.put(fold, surface, &p.components);
    }
    Ok((folds, surfaces.extra))
}

/// A body's pieces ([`Components`]) and what [`Components::inside_larger`] keeps for it.
struct BodyPieces {
    components: Components,
    memo: InsideMemo,
}

/// Per inside-twice tree past the bodies' ([`Surfaces`]): its body and its surface's mean
/// rest edge length.
type SurfaceSlots = Vec<(usize, f64)>;

/// A surface folds run on: its inside-twice tree, its triangles and its slot.
type Surface = (Arc<WindingNumber>, Arc<Vec<[u32; 3]>>, usize);

/// The surfaces folds run on ([`FoldPre::on_surface`]), per body keyed by the pieces left
/// out of them, with their shared inside-twice trees and slots.
struct Surfaces {
    known: Vec<HashMap<Vec<u32>, Surface>>,
    /// Per extra slot (past the bodies'): its body and its surface's mean rest edge length.
    extra: SurfaceSlots,
}

impl Surfaces {
    fn new(bodies: usize) -> Self {
        Self {
            known: (0..bodies).map(|_| HashMap::new()).collect(),
            extra: Vec::new(),
        }
    }

    /// Puts `fold` on the surface of the pieces its regions hold (left as it is when they
    /// are all of its body's).
    fn put(
        &mut self,
        fold: &mut Fold,
        (rest, triangles): (&[Point3<f64>], &[[u32; 3]]),
        components: &Components,
    ) {
        let own = pieces_of(components, &fold.pre.regions);
        let others: Vec<u32> = (0..components.len() as u32)
            .filter(|c| own.binary_search(c).is_err())
            .collect();
        if others.is_empty() {
            return;
        }
        let next = self.known.len() + self.extra.len();
        let (tree, kept, slot) = self.known[fold.body]
            .entry(others)
            .or_insert_with_key(|others| {
                let left = components.faces_in(others);
                let kept = triangles_without(triangles, &left);
                let tree = Arc::new(FoldPre::surface_winding(rest, triangles, &left));
                (tree, Arc::new(kept), next)
            });
        if *slot == next {
            self.extra.push((fold.body, mean_edge_length(rest, kept)));
        }
        fold.pre.on_surface(Arc::clone(kept), Arc::clone(tree));
        fold.winding_slot = *slot;
    }
}

/// The pieces of its body `fold` runs without ([`crate::selfcontact::layers`]): the smaller of
/// every two pieces meeting in its `face_pairs` crossing at rest, the pieces of its working regions
/// lying inside a larger piece, and (a fold with a shared region) those holding no vertex of it (a
/// stud, an eyelash card on one side: their faces would open the fold's surface, and an open
/// surface keeps no volume); ascending.
fn layers_of(
    fold: &Fold,
    (rest, triangles): (&[Point3<f64>], &[[u32; 3]]),
    pieces: &mut BodyPieces,
    face_pairs: &[[u32; 2]],
) -> Vec<u32> {
    let components = &pieces.components;
    let regions = &fold.pre.regions;
    let own = pieces_of(components, regions);
    let mut layers = components.layers_of(face_pairs);
    layers.extend(components.inside_larger(rest, triangles, &own, &mut pieces.memo));
    if !regions.separated() {
        let in_r = |v: &u32| regions.w1[*v as usize] && regions.w2[*v as usize];
        let faces = regions.w1_faces.iter().chain(&regions.w2_faces).copied();
        let holding = faces.filter(|&f| triangles[f as usize].iter().any(in_r));
        let holding = components.of_faces(holding);
        layers.extend(own.iter().filter(|c| holding.binary_search(c).is_err()));
    }
    layers.sort_unstable();
    layers.dedup();
    layers
}

/// The pieces of the mesh ([`Components`]) holding faces of `regions`' `W1` or `W2`
/// (ascending).
fn pieces_of(components: &Components, regions: &PairRegions) -> Vec<u32> {
    components.of_faces(regions.w1_faces.iter().chain(&regions.w2_faces).copied())
}

/// The `triangles` whose flag in `left` is not set (a triangle past `left` is kept).
pub(super) fn triangles_without(triangles: &[[u32; 3]], left: &[bool]) -> Vec<[u32; 3]> {
    (triangles.iter().enumerate())
        .filter(|&(f, _)| !left.get(f).copied().unwrap_or(false))
        .map(|(_, t)| *t)
        .collect()
}

/// `fold` without the pieces `layers` of its body ([`crate::selfcontact::layers`]), when its
/// regions keep both sides and it can be precomputed without them (else it stays as it is). Its
/// surface is set afterwards ([`Surfaces::put`]).
fn without_layers(
    rig: &Rig,
    fold: &Fold,
    rest: &[Point3<f64>],
    welded: &WeldedMesh,
    pieces: &BodyPieces,
    layers: &[u32],
) -> Option<Fold> {
    let (triangles, components) = (&welded.triangles, &pieces.components);
    let removed = components.faces_in(layers);
    let regions = fold.pre.regions.without_faces(triangles, &removed)?;
    let winding = fold.pre.shared_winding();
    let pre = FoldPre::with_winding(rest, triangles, regions, winding).ok()?;
    let without = WithoutLayers {
        layers: layers.iter().map(|&c| components.part(c).clone()).collect(),
        faces: (0..removed.len() as u32)
            .filter(|&f| removed[f as usize])
            .collect(),
    };
    let axes = BoneAxes::new(rig, welded, &pre.regions);
    Some(Fold {
        body: fold.body,
        sets: pre.face_sets(&fold.detection),
        detection: Arc::clone(&fold.detection),
        pre,
        axes,
        direction: fold.direction,
        params: None,
        at_rest: None,
        enabled: None,
        without: Some(without),
        winding_slot: fold.body,
    })
}

/// How `fold`'s two sides meet at `bodies`' positions, when they cross there (the frames'
/// detection, [`FoldPre::detect_on`]; a detection that fails is a crossing with its reason),
/// and the crossing face pairs.
fn crossing_at(fold: &Fold, bodies: &mut PosedBodies) -> (Option<RestCrossing>, Vec<[u32; 2]>) {
    let crossing = |face_pairs, failure| RestCrossing {
        body: fold.body,
        name: fold.pre.regions.pair.name.clone(),
        face_pairs,
        failure,
    };
    let detected = match bodies.posed(fold.body, &fold.detection) {
        Ok(posed) => fold.pre.detect_on(&posed, &fold.sets, Instant::now()),
        Err(e) => return (Some(crossing(0, Some(e.to_string()))), Vec::new()),
    };
    match detected {
        Ok(None) => (None, Vec::new()),
        Ok(Some(d)) => (Some(crossing(d.face_pairs.len(), None)), d.face_pairs),
        Err(e) => (Some(crossing(0, Some(e.to_string()))), Vec::new()),
    }
}
