//! Reading the node hierarchy: local transforms (TRS or matrices made affine) and the
//! parents-first order.

use super::invalid;
use crate::rig::skeleton::{unit_quaternion, LocalTransform, Node, Trs};
use crate::rig::RigError;
use nalgebra::{Matrix4, Vector3};
use std::path::Path;

/// The rest transform of `node`: its matrix (finite; made affine by `not_affine`) or its
/// translation, rotation (a non-zero quaternion, normalized) and scale (all finite).
fn read_local(
    file: &Path,
    node: &gltf::Node,
    not_affine: &mut NotAffine,
) -> Result<LocalTransform, RigError> {
    let element = format!("nodes[{}]", node.index());
    match node.transform() {
        gltf::scene::Transform::Matrix { matrix } => {
            let m = Matrix4::from_fn(|r, c| matrix[c][r] as f64);
            if m.iter().any(|x| !x.is_finite()) {
                return Err(invalid(file, element, "matrix has a non-finite entry"));
            }
            Ok(LocalTransform::Matrix(not_affine.fix(m, || element)))
        }
        gltf::scene::Transform::Decomposed {
            translation,
            rotation,
            scale,
        } => {
            let all = translation.iter().chain(&rotation).chain(&scale);
            if all.clone().any(|x| !x.is_finite()) {
                return Err(invalid(
                    file,
                    element,
                    "translation, rotation or scale is not finite",
                ));
            }
            let rotation = unit_quaternion(rotation.map(|x| x as f64))
                .ok_or_else(|| invalid(file, element, "rotation quaternion is zero"))?;
            Ok(LocalTransform::Trs(Trs {
                translation: Vector3::from(translation.map(|x| x as f64)),
                rotation,
                scale: Vector3::from(scale.map(|x| x as f64)),
            }))
        }
    }
}

/// The matrices whose last row is not `[0, 0, 0, 1]`, as glTF requires of a node's matrix
/// and an inverse bind matrix (an affine transform): their affine part is used (with a
/// projective row the skinning divided each position by its homogeneous coordinate; the
/// fuzzing corpus sets `m[15] = 0`), and one warning names the first.
#[derive(Default)]
pub(super) struct NotAffine {
    count: usize,
    first: Option<(String, [f64; 4])>,
}

impl NotAffine {
    /// `m` with its last row `[0, 0, 0, 1]`, counted when it was not (`element` names it).
    pub(super) fn fix(
        &mut self,
        mut m: Matrix4<f64>,
        element: impl FnOnce() -> String,
    ) -> Matrix4<f64> {
        let row = [m[(3, 0)], m[(3, 1)], m[(3, 2)], m[(3, 3)]];
        if row != [0.0, 0.0, 0.0, 1.0] {
            self.count += 1;
            self.first.get_or_insert_with(|| (element(), row));
            m.set_row(3, &nalgebra::RowVector4::new(0.0, 0.0, 0.0, 1.0));
        }
        m
    }

    /// The warning, if any matrix was fixed.
    pub(super) fn warn(self, warnings: &mut Vec<String>) {
        if let Some((element, row)) = self.first {
            warnings.push(format!(
                "{} matrices whose last row is not [0, 0, 0, 1] (not affine; the first: \
                 {element}, {row:?}): their affine part is used",
                self.count
            ));
        }
    }
}

/// Reads the hierarchy and checks it is a forest (one parent per node, no cycle).
pub(super) fn read_nodes(
    file: &Path,
    doc: &gltf::Document,
    warnings: &mut Vec<String>,
) -> Result<(Vec<Node>, Vec<usize>), RigError> {
    let mut nodes = Vec::new();
    let mut not_affine = NotAffine::default();
    for node in doc.nodes() {
        nodes.push(Node {
            name: node.name().map(str::to_string),
            parent: None,
            children: node.children().map(|c| c.index()).collect(),
            rest: read_local(file, &node, &mut not_affine)?,
        });
    }
    not_affine.warn(warnings);
    for n in 0..nodes.len() {
        for k in 0..nodes[n].children.len() {
            let c = nodes[n].children[k];
            if let Some(p) = nodes[c].parent {
                return Err(invalid(
                    file,
                    format!("nodes[{c}]"),
                    format!("has two parents (nodes[{p}] and nodes[{n}])"),
                ));
            }
            nodes[c].parent = Some(n);
        }
    }
    let mut order = Vec::with_capacity(nodes.len());
    let mut stack: Vec<usize> = (0..nodes.len())
        .rev()
        .filter(|&n| nodes[n].parent.is_none())
        .collect();
    while let Some(n) = stack.pop() {
        order.push(n);
        stack.extend(nodes[n].children.iter().rev());
    }
    if order.len() != nodes.len() {
        // A mark per node, not a search of `order` per node (quadratic: 88 s for 800k nodes,
        // found by review).
        let mut ordered = vec![false; nodes.len()];
        for &n in &order {
            ordered[n] = true;
        }
        let stuck = ordered.iter().position(|&o| !o).unwrap_or(0);
        return Err(invalid(
            file,
            format!("nodes[{stuck}]"),
            "is part of a cycle in the node hierarchy",
        ));
    }
    Ok((nodes, order))
}
