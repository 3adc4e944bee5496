//! Reading the skinned (and rigid) meshes into bodies: positions, normals, weights,
//! triangles, custom attributes.

use super::invalid;
use super::morphs::{merge_targets, MorphReader};
use crate::rig::accessor::{self, Source};
use crate::rig::weights::{normalize_row, SkinWeights};
use crate::rig::{Body, MorphTarget, Morphs, PrimitiveRange, RigError, Skin};
use nalgebra::{Matrix4, Point3, Vector3};

/// Custom attributes of one body or primitive: `(name with its underscore, values)`.
type Extras = Vec<(String, Vec<f64>)>;

/// The bodies: every skinned mesh instance in node order, then every unskinned one in node
/// order (a prop, often parented to a joint), which glTF poses by its node's world
/// transform: a rigid body, given a skin of its own appended to `skins` (its node as the one
/// joint, an identity inverse bind matrix, weight 1 on every vertex). Placed after the
/// skinned bodies, so that a configuration naming bodies by index keeps its meaning.
pub(super) fn read_bodies(
    src: &Source,
    doc: &gltf::Document,
    skins: &mut Vec<Skin>,
    warnings: &mut Vec<String>,
) -> Result<(Vec<Body>, Vec<Extras>), RigError> {
    let mut bodies = Vec::new();
    let mut extras = Vec::new();
    let mut morphs = MorphReader::default();
    let mut vertices = 0;
    for rigid in [false, true] {
        for node in doc.nodes() {
            let Some(mesh) = node.mesh() else { continue };
            let (index, own) = match (node.skin(), rigid) {
                (Some(skin), false) => (skin.index(), None),
                (None, true) => (skins.len(), Some(rigid_skin(&node))),
                _ => continue,
            };
            let skin = own.as_ref().unwrap_or_else(|| &skins[index]);
            let at = BodyAt {
                node: &node,
                mesh: &mesh,
                skin: (index, skin),
                rigid,
                vertices_before: vertices,
            };
            let read = read_body(src, doc, &at, &mut morphs, warnings)?;
            let Some((mut body, extra)) = read else {
                continue;
            };
            if let Some(own) = own {
                skins.push(own);
                warnings.push(format!(
                    "nodes[{}] carries meshes[{}] without a skin: posed rigidly by its node",
                    node.index(),
                    mesh.index()
                ));
            }
            if body.name.is_empty() {
                body.name = format!("body{}", bodies.len());
            }
            vertices += body.vertex_count();
            bodies.push(body);
            extras.push(extra);
        }
    }
    Ok((bodies, extras))
}

/// The skin of a rigid body: `node` as its one joint, an identity inverse bind matrix (so
/// that its skinning matrix is the node's world transform).
fn rigid_skin(node: &gltf::Node) -> Skin {
    Skin {
        name: Some(format!("nodes[{}] (rigid)", node.index())),
        joints: vec![node.index()],
        inverse_bind: vec![Matrix4::identity()],
    }
}

/// A mesh instance to read as a body: `mesh` instanced by `node`, skinned by `skin` (its index
/// and itself; `rigid`: every vertex on its one joint).
struct BodyAt<'a> {
    node: &'a gltf::Node<'a>,
    mesh: &'a gltf::Mesh<'a>,
    skin: (usize, &'a Skin),
    rigid: bool,
    /// Vertices of the file's bodies read before this one ([`MAX_FILE_VERTICES`]).
    vertices_before: usize,
}

/// Most vertices the bodies of one file may hold in all (about 1.5 GB of positions, normals
/// and weights). Every node instancing a mesh and every primitive naming an accessor reads it
/// again, so the file's size does not bound them (found by review: a 758-byte file of six
/// primitives naming one view-less accessor of 4M positions took 3 GB and 31 s).
pub const MAX_FILE_VERTICES: usize = 1 << 23;

/// One body: the triangle primitives of `at`'s mesh, with its custom attributes and its morph
/// targets (read by the file's `morphs`). `None` (with a warning) when the mesh has no
/// triangle primitive.
fn read_body(
    src: &Source,
    doc: &gltf::Document,
    at: &BodyAt,
    morphs: &mut MorphReader,
    warnings: &mut Vec<String>,
) -> Result<Option<(Body, Extras)>, RigError> {
    let BodyAt {
        node,
        mesh,
        skin: (skin_index, skin),
        rigid,
        vertices_before,
    } = *at;
    let name = node.name().or(mesh.name()).unwrap_or_default().to_string();
    let mut body = Body {
        name,
        node: node.index(),
        mesh: mesh.index(),
        skin: skin_index,
        rigid,
        positions: Vec::new(),
        normals: Vec::new(),
        weights: SkinWeights::with_capacity(0),
        triangles: Vec::new(),
        primitives: Vec::new(),
        morphs: Morphs::default(),
    };
    let mut has_normals = true;
    let mut primitive_extras = Vec::new();
    let mut targets: Vec<Vec<MorphTarget>> = Vec::new();
    for prim in mesh.primitives() {
        let incoming = prim
            .get(&gltf::Semantic::Positions)
            .map_or(0, |a| a.count());
        let total = (vertices_before + body.positions.len()).saturating_add(incoming);
        if is_triangles(&prim) && total > MAX_FILE_VERTICES {
            let message = format!(
                "the file's bodies would hold {total} vertices, more than {MAX_FILE_VERTICES}"
            );
            let at = format!("meshes[{}].primitives[{}]", mesh.index(), prim.index());
            return Err(invalid(src.file, at, message));
        }
        let at = PrimitiveAt {
            mesh: mesh.index(),
            skin,
            rigid,
        };
        let read = read_primitive(src, doc, &prim, &at, (&mut body, &mut *morphs), warnings)?;
        has_normals &= read.has_normals;
        primitive_extras.extend(read.extras);
        targets.extend(read.targets);
    }
    if body.positions.is_empty() {
        warnings.push(format!(
            "meshes[{}] has no triangle primitive: skipped",
            mesh.index()
        ));
        return Ok(None);
    }
    if !has_normals {
        body.normals = area_weighted_normals(&body.positions, &body.triangles);
    }
    body.morphs = merge_targets(src, targets, node, mesh, !has_normals)?;
    let extras = merge_extras(primitive_extras, mesh.index(), warnings);
    Ok(Some((body, extras)))
}

/// Concatenates the custom attributes of a body's triangle primitives (one list per
/// primitive, in order); an attribute missing from one of them is dropped with a warning.
fn merge_extras(per_primitive: Vec<Extras>, mesh: usize, warnings: &mut Vec<String>) -> Extras {
    let mut names: Vec<String> = Vec::new();
    for (name, _) in per_primitive.iter().flatten() {
        if !names.contains(name) {
            names.push(name.clone());
        }
    }
    let mut out = Vec::new();
    for name in names {
        let parts: Vec<&Vec<f64>> = per_primitive
            .iter()
            .filter_map(|p| p.iter().find(|(n, _)| *n == name).map(|(_, v)| v))
            .collect();
        if parts.len() == per_primitive.len() {
            out.push((name, parts.into_iter().flatten().copied().collect()));
        } else {
            warnings.push(format!(
                "meshes[{mesh}]: attribute {name} is missing on some triangle primitives: ignored"
            ));
        }
    }
    out
}

/// The custom `_NAME` attributes of a primitive with `n` vertices: SCALAR float or normalized
/// integer accessors of `n` elements; anything else is skipped with a warning.
fn read_extras(
    src: &Source,
    doc: &gltf::Document,
    prim: &gltf::Primitive,
    at: &str,
    n: usize,
    warnings: &mut Vec<String>,
) -> Result<Extras, RigError> {
    use gltf::accessor::{DataType, Dimensions};
    let mut out = Vec::new();
    for (semantic, acc) in prim.attributes() {
        let gltf::Semantic::Extras(name) = semantic else {
            continue;
        };
        let name = format!("_{name}");
        let mut skip =
            |why: String| warnings.push(format!("{at}: attribute {name} {why}: ignored"));
        if acc.dimensions() != Dimensions::Scalar {
            skip(format!("is {:?}, not SCALAR", acc.dimensions()));
            continue;
        }
        if acc.data_type() != DataType::F32 && !acc.normalized() {
            skip("holds integers that are not normalized".into());
            continue;
        }
        let role = format!("{name} of {at}");
        let values = accessor::read(src, doc, acc.index(), &role, &[1], false)?;
        if values.count() != n {
            skip(format!("has {} values for {n} vertices", values.count()));
            continue;
        }
        out.push((name, values.data));
    }
    Ok(out)
}

/// What [`read_primitive`] found besides the arrays it appended.
struct PrimitiveRead {
    /// The primitive carried NORMAL (or was ignored).
    has_normals: bool,
    /// Its custom attributes (`None` for an ignored, non-triangle primitive).
    extras: Option<Extras>,
    /// Its morph targets (`None` for an ignored, non-triangle primitive).
    targets: Option<Vec<MorphTarget>>,
}

/// Where a primitive is read: its mesh, the skin of the body it joins and whether that body
/// is rigid (an unskinned mesh: every vertex on the skin's one joint).
struct PrimitiveAt<'a> {
    mesh: usize,
    skin: &'a Skin,
    rigid: bool,
}

/// Appends one primitive to `body` (its morph targets read by the file's `morphs`).
fn read_primitive(
    src: &Source,
    doc: &gltf::Document,
    prim: &gltf::Primitive,
    place: &PrimitiveAt,
    (body, morphs): (&mut Body, &mut MorphReader),
    warnings: &mut Vec<String>,
) -> Result<PrimitiveRead, RigError> {
    let mesh = place.mesh;
    let at = format!("meshes[{mesh}].primitives[{}]", prim.index());
    let mode = prim.mode();
    if !is_triangles(prim) {
        warnings.push(format!("{at}: mode {mode:?} is not triangles: ignored"));
        return Ok(PrimitiveRead {
            has_normals: true,
            extras: None,
            targets: None,
        });
    }
    let pos = read_positions(src, doc, prim, &at, body.positions.len())?;
    let n = pos.count();
    let normals = read_normals(src, doc, prim, &at, n)?;
    let weights = if place.rigid {
        SkinWeights::rigid(n)
    } else {
        read_weights(src, doc, prim, &at, n, place.skin, warnings)?
    };
    let extras = read_extras(src, doc, prim, &at, n, warnings)?;
    let first = body.positions.len();
    let targets = morphs.primitive_targets(src, doc, prim, &at, (n, first))?;
    let indices = match prim.indices() {
        Some(acc) => {
            accessor::read_indices(
                src,
                doc,
                acc.index(),
                &format!("indices of {at}"),
                &[1],
                n as u64,
            )?
            .1
        }
        None => (0..n as u32).collect(),
    };
    let first_vertex = body.positions.len();
    body.positions
        .extend((0..n).map(|i| Point3::from_slice(pos.element(i))));
    append_normals(body, normals.as_ref(), n);
    for r in 0..n {
        let (j, w) = weights.row_slices(r);
        let row: Vec<(u16, f64)> = j.iter().copied().zip(w.iter().copied()).collect();
        body.weights.push_row(&row);
    }
    let local_tris = triangulate(mode, &indices);
    let first_triangle = body.triangles.len();
    let off = first_vertex as u32;
    body.triangles.extend(
        local_tris
            .iter()
            .map(|t| [t[0] + off, t[1] + off, t[2] + off]),
    );
    body.primitives.push(PrimitiveRange {
        mesh,
        primitive: prim.index(),
        first_vertex,
        vertex_count: n,
        first_triangle,
        triangle_count: local_tris.len(),
    });
    Ok(PrimitiveRead {
        has_normals: normals_present(prim),
        extras: Some(extras),
        targets: Some(targets),
    })
}

/// Whether `prim` draws triangles (a list, strip or fan): the primitives a body is made of,
/// the others (points, lines) ignored with a warning.
pub(super) fn is_triangles(prim: &gltf::Primitive) -> bool {
    use gltf::mesh::Mode;
    matches!(
        prim.mode(),
        Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
    )
}

/// POSITION of a primitive: finite, and the body (holding `before` vertices) stays within
/// 32-bit indices.
fn read_positions(
    src: &Source,
    doc: &gltf::Document,
    prim: &gltf::Primitive,
    at: &str,
    before: usize,
) -> Result<accessor::Values, RigError> {
    let acc = prim
        .get(&gltf::Semantic::Positions)
        .ok_or_else(|| invalid(src.file, at, "has no POSITION"))?;
    let pos = accessor::read(
        src,
        doc,
        acc.index(),
        &format!("POSITION of {at}"),
        &[3],
        false,
    )?;
    if pos.data.iter().any(|x| !x.is_finite()) {
        return Err(invalid(src.file, at, "POSITION holds a non-finite value"));
    }
    if (before + pos.count()) as u64 > u32::MAX as u64 {
        return Err(invalid(src.file, at, "more than 2^32 vertices in one mesh"));
    }
    Ok(pos)
}

/// NORMAL of a primitive of `n` vertices, if it has one.
fn read_normals(
    src: &Source,
    doc: &gltf::Document,
    prim: &gltf::Primitive,
    at: &str,
    n: usize,
) -> Result<Option<accessor::Values>, RigError> {
    let Some(acc) = prim.get(&gltf::Semantic::Normals) else {
        return Ok(None);
    };
    let v = accessor::read(
        src,
        doc,
        acc.index(),
        &format!("NORMAL of {at}"),
        &[3],
        false,
    )?;
    if v.count() != n {
        return Err(invalid(
            src.file,
            at,
            format!("NORMAL has {} elements, POSITION {}", v.count(), n),
        ));
    }
    Ok(Some(v))
}

/// Appends `n` unit normals (zero where the file has none, or a zero or non-finite one).
fn append_normals(body: &mut Body, normals: Option<&accessor::Values>, n: usize) {
    match normals {
        Some(v) => body.normals.extend((0..n).map(|i| {
            let nv = Vector3::from_column_slice(v.element(i));
            let len = nv.norm();
            if len.is_finite() && len > 1e-12 {
                nv / len
            } else {
                Vector3::zeros()
            }
        })),
        None => body
            .normals
            .extend(std::iter::repeat_n(Vector3::zeros(), n)),
    }
}

fn normals_present(prim: &gltf::Primitive) -> bool {
    prim.get(&gltf::Semantic::Normals).is_some()
}

/// Most JOINTS_n / WEIGHTS_n sets read (16 influences per vertex); later ones are ignored
/// with a warning. Until 2026-12-06 only sets 0 and 1 were read, and later ones dropped with
/// no word but the renormalization's (found by review).
const MAX_WEIGHT_SETS: u32 = 4;

/// Reads the JOINTS_n and WEIGHTS_n sets (up to [`MAX_WEIGHT_SETS`]) into normalized rows, with
/// the fallbacks documented on [`crate::rig`]: invalid (NaN, negative) weights are dropped,
/// rows are renormalized, a vertex with no usable weight follows the skin's first joint; each
/// fallback is counted in `warnings`.
fn read_weights(
    src: &Source,
    doc: &gltf::Document,
    prim: &gltf::Primitive,
    at: &str,
    n: usize,
    skin: &Skin,
    warnings: &mut Vec<String>,
) -> Result<SkinWeights, RigError> {
    let mut raw: Vec<Vec<(u16, f64)>> = vec![Vec::with_capacity(4); n];
    let later = |set: u32| {
        prim.get(&gltf::Semantic::Joints(set)).is_some()
            || prim.get(&gltf::Semantic::Weights(set)).is_some()
    };
    if later(MAX_WEIGHT_SETS) {
        warnings.push(format!(
            "{at}: JOINTS_{MAX_WEIGHT_SETS} / WEIGHTS_{MAX_WEIGHT_SETS} and later sets ignored \
             (at most {} influences per vertex are read)",
            4 * MAX_WEIGHT_SETS
        ));
    }
    for set in 0..MAX_WEIGHT_SETS {
        let (ja, wa) = (
            prim.get(&gltf::Semantic::Joints(set)),
            prim.get(&gltf::Semantic::Weights(set)),
        );
        match (ja, wa) {
            (Some(j), Some(w)) => {
                let set = WeightSet {
                    set,
                    joints: j.index(),
                    weights: w.index(),
                };
                read_weight_set(src, doc, at, &set, skin, &mut raw)?;
            }
            (None, None) if set > 0 => break,
            (None, None) => {
                return Err(invalid(
                    src.file,
                    at,
                    "skinned primitive without JOINTS_0 / WEIGHTS_0",
                ))
            }
            _ => {
                return Err(invalid(
                    src.file,
                    at,
                    format!("JOINTS_{set} and WEIGHTS_{set} must come together"),
                ))
            }
        }
    }
    Ok(normalized_weights(&raw, at, warnings))
}

/// One JOINTS_i / WEIGHTS_i pair of accessors.
struct WeightSet {
    set: u32,
    joints: usize,
    weights: usize,
}

/// Appends a set's four (joint, weight) entries to each vertex's `raw` row; a joint index
/// outside the skin with a non-zero weight is an error.
fn read_weight_set(
    src: &Source,
    doc: &gltf::Document,
    at: &str,
    ws: &WeightSet,
    skin: &Skin,
    raw: &mut [Vec<(u16, f64)>],
) -> Result<(), RigError> {
    let (set, n) = (ws.set, raw.len());
    let (_, joints) = accessor::read_indices(
        src,
        doc,
        ws.joints,
        &format!("JOINTS_{set} of {at}"),
        &[4],
        1 << 16,
    )?;
    let weights = accessor::read(
        src,
        doc,
        ws.weights,
        &format!("WEIGHTS_{set} of {at}"),
        &[4],
        true,
    )?;
    if joints.len() != 4 * n || weights.data.len() != 4 * n {
        return Err(invalid(
            src.file,
            at,
            format!("JOINTS_{set} / WEIGHTS_{set} counts differ from POSITION ({n})"),
        ));
    }
    for (v, row) in raw.iter_mut().enumerate() {
        for k in 0..4 {
            let (j, w) = (joints[4 * v + k], weights.data[4 * v + k]);
            if w != 0.0 && j as usize >= skin.joints.len() {
                return Err(invalid(
                    src.file,
                    format!("JOINTS_{set} of {at}"),
                    format!(
                        "vertex {v} uses joint {j} with weight {w}, but the skin has {} joints",
                        skin.joints.len()
                    ),
                ));
            }
            row.push((j as u16, w));
        }
    }
    Ok(())
}

/// The rows normalized ([`normalize_row`]), each fallback counted in `warnings`.
fn normalized_weights(
    raw: &[Vec<(u16, f64)>],
    at: &str,
    warnings: &mut Vec<String>,
) -> SkinWeights {
    let mut out = SkinWeights::with_capacity(raw.len());
    let (mut invalid_rows, mut renormalized, mut empty) = (0, 0, 0);
    let mut row = Vec::with_capacity(8);
    for r in raw {
        let fixes = normalize_row(r, &mut row);
        invalid_rows += fixes.dropped_invalid as usize;
        renormalized += fixes.renormalized as usize;
        if fixes.empty {
            empty += 1;
            row.push((0, 1.0));
        }
        out.push_row(&row);
    }
    if invalid_rows > 0 {
        warnings.push(format!(
            "{at}: {invalid_rows} vertices had NaN, infinite or negative weights (dropped)"
        ));
    }
    if renormalized > 0 {
        warnings.push(format!(
            "{at}: {renormalized} vertices had weights not summing to 1 (renormalized)"
        ));
    }
    if empty > 0 {
        warnings.push(format!(
            "{at}: {empty} vertices had no usable weight (bound to the skin's first joint)"
        ));
    }
    out
}

fn triangulate(mode: gltf::mesh::Mode, idx: &[u32]) -> Vec<[u32; 3]> {
    use gltf::mesh::Mode;
    match mode {
        Mode::TriangleStrip => (2..idx.len())
            .map(|i| {
                if i % 2 == 0 {
                    [idx[i - 2], idx[i - 1], idx[i]]
                } else {
                    [idx[i - 1], idx[i - 2], idx[i]]
                }
            })
            .collect(),
        Mode::TriangleFan => (2..idx.len())
            .map(|i| [idx[0], idx[i - 1], idx[i]])
            .collect(),
        _ => idx.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect(),
    }
}

/// Area-weighted vertex normals of a triangle soup (zero for isolated vertices).
pub fn area_weighted_normals(
    positions: &[Point3<f64>],
    triangles: &[[u32; 3]],
) -> Vec<Vector3<f64>> {
    let mut normals = vec![Vector3::zeros(); positions.len()];
    for t in triangles {
        let [a, b, c] = t.map(|i| positions[i as usize]);
        let n = (b - a).cross(&(c - a));
        for &i in t {
            normals[i as usize] += n;
        }
    }
    for n in &mut normals {
        let len = n.norm();
        *n = if len > 1e-300 {
            *n / len
        } else {
            Vector3::zeros()
        };
    }
    normals
}
