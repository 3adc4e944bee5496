//! The bodies of one frame as the self-contact pass poses them: their positions, updated
//! fold after fold, with each body's detection tree and inside-twice trees refit at them.

use crate::intersect::{IntersectError, MeshIndex, PosedMesh, TriangleBvh};
use crate::mesh::operators::{vertex_normals, NormalWeighting};
use crate::report::metrics::WindingNumber;
use nalgebra::{Point3, Vector3};
use std::borrow::Cow;

/// Every body's positions in one frame, updated fold after fold, and each body's detection
/// tree refit at them: one refit per body shared by the detections of its folds until a fold
/// moves it. The positions change only through [`PosedBodies::replace`], which marks the
/// body's tree for a refit and drops its normals, so neither is read at positions it was not
/// made at.
///
/// Also each body's winding-number tree for the folds' inside-twice tests, copied from the
/// rest tree at the body's first fold of the frame and refit by every fold where it moved
/// ([`resolve_detected_in`](crate::selfcontact::fold::resolve_detected_in)).
pub(super) struct PosedBodies<'p> {
    positions: &'p mut [Vec<Point3<f64>>],
    trees: Vec<Option<TriangleBvh>>,
    /// Per body, whether its tree was refit at its positions.
    fitted: Vec<bool>,
    /// Per body, whether its positions are known finite: the frame's input once checked
    /// ([`PosedBodies::checked_finite`]), not after a fold moved them.
    finite: Vec<bool>,
    windings: Vec<Option<WindingNumber>>,
    /// Per body, the area-weighted vertex normals of its positions (dropped with them).
    normals: Vec<Option<Vec<Vector3<f64>>>>,
}

impl<'p> PosedBodies<'p> {
    /// `trees`: a frame's detection trees to refit in place (one per body, `None` where there
    /// is none yet), or `None` (each tree copied from its index at its first detection).
    /// `slots`: the inside-twice trees the frame keeps (at least one per body; see
    /// [`Fold::winding_slot`](super::Fold::winding_slot)).
    pub(super) fn new(
        positions: &'p mut [Vec<Point3<f64>>],
        trees: Option<Vec<Option<TriangleBvh>>>,
        slots: usize,
    ) -> Self {
        let trees = trees
            .filter(|t| t.len() == positions.len())
            .unwrap_or_else(|| vec![None; positions.len()]);
        let fitted = vec![false; positions.len()];
        let finite = vec![false; positions.len()];
        let windings = vec![None; slots.max(positions.len())];
        let normals = vec![None; positions.len()];
        Self {
            positions,
            trees,
            fitted,
            finite,
            windings,
            normals,
        }
    }

    /// The bodies, their positions checked finite by the caller: their trees' refits do not
    /// check them again (1.2 µs of the finger's 13 µs refit) until a fold moves them.
    pub(super) fn checked_finite(mut self) -> Self {
        self.finite.fill(true);
        self
    }

    /// Positions of `body`, their vertex normals (computed once per positions: most folds detected
    /// in a frame leave the body as they found it) and the winding-number tree of `slot`
    /// ([`Fold::winding_slot`](super::Fold::winding_slot); `rest_tree` the first time in the
    /// frame).
    pub(super) fn for_fold(
        &mut self,
        slot: usize,
        body: usize,
        triangles: &[[u32; 3]],
        rest_tree: impl FnOnce() -> WindingNumber,
    ) -> (&[Point3<f64>], &[Vector3<f64>], &mut WindingNumber) {
        let tree = self.windings[slot].get_or_insert_with(rest_tree);
        let positions = &self.positions[body];
        let normals = normals_of(&mut self.normals[body], positions, triangles);
        (positions, normals, tree)
    }

    /// Positions of `body`, their normals (the folds', [`PosedBodies::for_fold`]) and the
    /// winding-number tree of `slot` refit to them: the folds' (β = 1.5, see
    /// [`PosedBodies::for_fold`]), else (no fold resolved with it, or a non-finite position
    /// that the refit refuses) one of the whole body built on them with the metric's β.
    pub(super) fn refit_winding(
        &mut self,
        slot: usize,
        body: usize,
        triangles: &[[u32; 3]],
    ) -> (&[Point3<f64>], &[Vector3<f64>], Cow<'_, WindingNumber>) {
        let positions = &self.positions[body];
        let slot = &mut self.windings[slot];
        let refit = slot
            .as_mut()
            .is_some_and(|tree| tree.refit_changed(positions, triangles));
        let tree = match slot {
            Some(tree) if refit => Cow::Borrowed(&*tree),
            _ => Cow::Owned(WindingNumber::new(positions, triangles)),
        };
        let normals = normals_of(&mut self.normals[body], positions, triangles);
        (positions, normals, tree)
    }

    /// Every body's positions.
    pub(super) fn all(&self) -> &[Vec<Point3<f64>>] {
        self.positions
    }

    /// Positions of `body`.
    pub(super) fn positions(&self, body: usize) -> &[Point3<f64>] {
        &self.positions[body]
    }

    /// `body` posed for detection on `index` (its index: one per body), refitting the tree
    /// unless it was refit at these positions: at its nodes only
    /// ([`MeshIndex::refit_nodes_in`]), for the detection's queries alone.
    pub(super) fn posed<'s>(
        &'s mut self,
        body: usize,
        index: &'s MeshIndex,
    ) -> Result<PosedMesh<'s>, IntersectError> {
        let positions = &self.positions[body];
        // A tree whose refit fails (a non-finite position) is dropped.
        let tree = match self.trees[body].take() {
            Some(tree) if self.fitted[body] => tree,
            Some(mut tree) => {
                index.refit_nodes_in(positions, &mut tree, self.finite[body])?;
                tree
            }
            None => index.refit_tree(positions)?,
        };
        self.fitted[body] = true;
        Ok(index.posed_with(positions, self.trees[body].insert(tree)))
    }

    /// The detection trees, to refit in place in a later frame.
    pub(super) fn into_trees(self) -> Vec<Option<TriangleBvh>> {
        self.trees
    }

    /// New positions for `body`; its tree is to refit, its normals are dropped.
    pub(super) fn replace(&mut self, body: usize, positions: &[Point3<f64>]) {
        let own = &mut self.positions[body];
        own.clear();
        own.extend_from_slice(positions);
        self.fitted[body] = false;
        self.finite[body] = false;
        self.normals[body] = None;
    }
}

/// A body's area-weighted vertex normals at `positions`, made in `slot` unless already there
/// (the slot is emptied whenever the positions change, [`PosedBodies::replace`]).
pub(super) fn normals_of<'s>(
    slot: &'s mut Option<Vec<Vector3<f64>>>,
    positions: &[Point3<f64>],
    triangles: &[[u32; 3]],
) -> &'s [Vector3<f64>] {
    slot.get_or_insert_with(|| vertex_normals(positions, triangles, NormalWeighting::Area))
}
