//! Bodies their skin mirrors: a skinned mesh's orientation at rest.
//!
//! Every stage after loading assumes that a posed body's triangles wind counter-clockwise seen
//! from outside (outward normals, inside where the winding number is 1). A skin whose
//! matrices have a negative determinant (a left hand made from a right one by a scale of -1
//! on its armature) poses the file's outward winding inside out: the passes then saw no
//! interpenetration at all, or deformed the wrong way (found on the committed scenes under a
//! root scaled by `[-1, 1, 1]`: the capsule's 23 frames with a fold became none). Such a body's
//! triangles are reversed and its bind normals (and its morph targets' normal displacements)
//! negated once, at load, so that it faces out
//! when posed (the cofactor that carries normals to the pose turns them with the winding).
//! The glTF rule that the determinant of the *node's* transform decides the winding does not
//! apply to a skinned mesh, whose node transform is ignored: the skin's matrices decide here.
//!
//! Then a closed body whose surface, posed at rest, still encloses a negative volume is wound
//! inward in the file ([`wind_outward`]): its winding is reversed too (found with the capsule
//! pair and the bending capsule so written: the passes resolved nothing, as for a mirror).

use super::{Body, Pose, Rig};
use crate::mesh::operators::{vertex_normals, NormalWeighting};
use crate::mesh::{signed_volume, WeldedMesh};
use crate::skinning::lbs::{self, blended_matrix};
use nalgebra::Matrix4;

/// Reverses the winding and normals of every body that its skin mirrors at `rest` (the rig's
/// rest pose), with a warning naming it; a warning too for a skin that mirrors only some of a
/// body's vertices (left as the majority has it).
pub(super) fn face_outward(rig: &mut Rig, rest: &Pose) {
    for body in &mut rig.bodies {
        let mats = rest.skin_matrices(&rig.skins[body.skin]);
        let [mirrored, kept] = orientations(body, &mats);
        let mixed = if mirrored > 0 && kept > 0 {
            format!(" ({mirrored} of its {} vertices mirrored)", mirrored + kept)
        } else {
            String::new()
        };
        if mirrored <= kept {
            if mirrored > 0 {
                rig.warnings.push(format!(
                    "body '{}' (meshes[{}]): its skin mirrors some of it at rest{mixed}: \
                     left as most of it faces",
                    body.name, body.mesh
                ));
            }
            continue;
        }
        for t in &mut body.triangles {
            t.swap(1, 2);
        }
        body.negate_normals();
        rig.warnings.push(format!(
            "body '{}' (meshes[{}]): its skin mirrors it at rest (negative determinant){mixed}: \
             its triangles' winding and normals reversed, so that it faces out",
            body.name, body.mesh
        ));
    }
}

/// Reverses the winding of every closed body whose surface, posed at `rest` (after
/// [`face_outward`]), encloses a negative volume: its faces are wound inward in the file (or,
/// made double-sided, its inward copy comes first and is the one welding keeps:
/// [`WeldedMesh::triangles`]). Its normals are negated too where they agreed with the inward
/// winding, and kept where they already pointed out. A warning names each body. An open
/// body is not judged (its signed volume depends on the origin).
pub(super) fn wind_outward(rig: &mut Rig, rest: &Pose) {
    for body in &mut rig.bodies {
        let mats = rest.skin_matrices(&rig.skins[body.skin]);
        let posed = lbs::skin(body, &mats);
        let welded = WeldedMesh::weld(&body.positions, &body.triangles);
        let positions = welded.gather(&posed.positions);
        let volume = signed_volume(&positions, &welded.triangles);
        if !welded.closed || volume >= 0.0 || volume.is_nan() {
            continue;
        }
        for t in &mut body.triangles {
            t.swap(1, 2);
        }
        // Judged on the welded faces (one copy of a double-sided surface), still inward: the
        // normals point inward where they agree with those faces' own.
        let faces = vertex_normals(&positions, &welded.triangles, NormalWeighting::Area);
        let agreement: f64 = (faces.iter().zip(welded.gather(&posed.normals)))
            .map(|(f, n)| f.dot(&n))
            .sum();
        let inward_normals = agreement > 0.0;
        if inward_normals {
            body.negate_normals();
        }
        let normals = if inward_normals {
            "its triangles' winding and normals reversed"
        } else {
            "its triangles' winding reversed (its normals already point out)"
        };
        rig.warnings.push(format!(
            "body '{}' (meshes[{}]): its closed surface is wound inward (negative volume at \
             rest): {normals}, so that it faces out",
            body.name, body.mesh
        ));
    }
}

/// How many of `body`'s vertices are posed at rest by a blended linear map (`Σ w_j A_j`,
/// LBS's) of negative determinant, and how many of positive (a zero or NaN determinant counts
/// in neither).
fn orientations(body: &Body, mats: &[Matrix4<f64>]) -> [usize; 2] {
    let mut counts = [0, 0];
    for v in 0..body.weights.len() {
        let d = blended_matrix(&body.weights, v, mats)
            .fixed_view::<3, 3>(0, 0)
            .determinant();
        if d < 0.0 {
            counts[0] += 1;
        } else if d > 0.0 {
            counts[1] += 1;
        }
    }
    counts
}
