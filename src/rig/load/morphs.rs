//! Reading a mesh's morph targets and default weights into its body's [`Morphs`]
//! (glTF 2.0 §3.7.2.2).

use super::invalid;
use crate::rig::accessor::{self, Source};
use crate::rig::{MorphTarget, Morphs, RigError};
use nalgebra::Vector3;
use std::collections::HashMap;
use std::sync::Arc;

/// Most non-zero displacements the morph targets of one file may hold, over all its bodies (32
/// bytes each: 512 MiB). A file can make many targets read one accessor, and many nodes
/// instance one mesh, so the targets' size is not bounded by the file's (a 200 kB JSON of 10k
/// targets sharing one dense 100k-vertex accessor would ask for 24 GB); real face rigs hold a
/// few million.
pub const MAX_MORPH_DISPLACEMENTS: usize = 1 << 24;

/// Most accessor elements the morph targets of one file may decode (each accessor once: the
/// targets sharing one reuse it), 1.4 s of reading on this machine (all-zero sparse accessors). Targets whose
/// accessors hold zeros store nothing, so [`MAX_MORPH_DISPLACEMENTS`] does not bound the
/// reading: 8 000 targets each on its own all-zero sparse accessor of 51k vertices took 10 s
/// from a 1 MB file before this bound (found by review). A face rig of 300 targets of 100k
/// vertices, POSITION and NORMAL each on its own accessor, reads 6 × 10⁷.
pub const MAX_MORPH_READS: usize = 1 << 27;

/// An accessor's non-zero displacements, `(vertex of the primitive, Δ)`, shared by the targets
/// that read it.
type Decoded = Arc<[(u32, Vector3<f64>)]>;

/// Reads the morph targets of a file's bodies: each target accessor decoded once (its
/// non-zero displacements kept by accessor, primitive-local), and the file's totals held under
/// [`MAX_MORPH_DISPLACEMENTS`] and [`MAX_MORPH_READS`].
#[derive(Default)]
pub(super) struct MorphReader {
    decoded: HashMap<usize, Decoded>,
    held: usize,
    read: usize,
}

impl MorphReader {
    /// The morph targets of one triangle primitive (at `at`) of `n` vertices whose first
    /// vertex is body vertex `first`: their non-zero displacements, indexed in the body. A
    /// target's accessor must hold one finite VEC3 per vertex.
    pub(super) fn primitive_targets(
        &mut self,
        src: &Source,
        doc: &gltf::Document,
        prim: &gltf::Primitive,
        at: &str,
        (n, first): (usize, usize),
    ) -> Result<Vec<MorphTarget>, RigError> {
        let mut targets = Vec::new();
        for (k, target) in prim.morph_targets().enumerate() {
            let mut read = |acc: Option<gltf::Accessor>, name: &str| {
                let role = format!("{name} of {at}.targets[{k}]");
                let local = self.displacements(src, doc, acc, &role, n)?;
                Ok::<_, RigError>(local.iter().map(|&(i, d)| (first as u32 + i, d)).collect())
            };
            let target = MorphTarget {
                positions: read(target.positions(), "POSITION")?,
                normals: read(target.normals(), "NORMAL")?,
            };
            self.held += target.len();
            if self.held > MAX_MORPH_DISPLACEMENTS {
                let message = format!(
                    "the file's morph targets hold more than {MAX_MORPH_DISPLACEMENTS} \
                     displacements"
                );
                return Err(invalid(src.file, at, message));
            }
            targets.push(target);
        }
        Ok(targets)
    }

    /// The non-zero displacements of a target attribute, primitive-local (none without an
    /// accessor), decoded at its first use.
    fn displacements(
        &mut self,
        src: &Source,
        doc: &gltf::Document,
        acc: Option<gltf::Accessor>,
        role: &str,
        n: usize,
    ) -> Result<Decoded, RigError> {
        let Some(acc) = acc else {
            return Ok(Arc::from([]));
        };
        if acc.count() != n {
            let message = format!("{} elements for {n} vertices", acc.count());
            return Err(invalid(src.file, role, message));
        }
        if let Some(known) = self.decoded.get(&acc.index()) {
            return Ok(Arc::clone(known));
        }
        self.read = self.read.saturating_add(n);
        if self.read > MAX_MORPH_READS {
            let message = format!(
                "the file's morph targets read more than {MAX_MORPH_READS} accessor elements"
            );
            return Err(invalid(src.file, role, message));
        }
        let values = accessor::read_unbounded(src, doc, acc.index(), role, &[3])?;
        if values.data.iter().any(|x| !x.is_finite()) {
            return Err(invalid(src.file, role, "holds a non-finite value"));
        }
        let local: Decoded = (0..n)
            .map(|i| (i as u32, Vector3::from_column_slice(values.element(i))))
            .filter(|(_, d)| *d != Vector3::zeros())
            .collect();
        self.decoded.insert(acc.index(), Arc::clone(&local));
        Ok(local)
    }
}

/// A body's morphs: target `k` of each of its triangle primitives (`per_primitive`, in order)
/// concatenated, and the default weights, `node`'s `weights`, else `mesh`'s, else zeros. Every
/// primitive must have as many targets, and the weights one per target (glTF 2.0 §3.7.2.2).
pub(super) fn merge_targets(
    src: &Source,
    per_primitive: Vec<Vec<MorphTarget>>,
    node: &gltf::Node,
    mesh: &gltf::Mesh,
    normals_from_triangles: bool,
) -> Result<Morphs, RigError> {
    let at = format!("meshes[{}]", mesh.index());
    let count = per_primitive.first().map_or(0, Vec::len);
    if let Some(other) = per_primitive.iter().find(|t| t.len() != count) {
        let message = format!(
            "its triangle primitives have {count} and {} morph targets (glTF requires as many \
             on every primitive)",
            other.len()
        );
        return Err(invalid(src.file, at, message));
    }
    let mut targets = vec![MorphTarget::default(); count];
    for primitive in per_primitive {
        for (target, part) in targets.iter_mut().zip(primitive) {
            target.positions.extend(part.positions);
            target.normals.extend(part.normals);
        }
    }
    let (weights, whose) = match (node.weights(), mesh.weights()) {
        (Some(w), _) => (Some(w), format!("nodes[{}].weights", node.index())),
        (None, w) => (w, format!("{at}.weights")),
    };
    let default_weights = match weights {
        Some(w) if w.len() != count => {
            let message = format!("{} weights for {count} morph targets", w.len());
            return Err(invalid(src.file, whose, message));
        }
        Some(w) if w.iter().any(|x| !x.is_finite()) => {
            return Err(invalid(src.file, whose, "holds a non-finite weight"));
        }
        Some(w) => w.iter().map(|&x| f64::from(x)).collect(),
        None => vec![0.0; count],
    };
    Ok(Morphs {
        targets,
        default_weights,
        normals_from_triangles,
    })
}
