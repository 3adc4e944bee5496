//! Reading a rig's animations: channels per node and property, their keys checked.

use super::invalid;
use crate::rig::accessor::{self, Source};
use crate::rig::animation::{Animation, Channel, Interpolation, Property};
use crate::rig::skeleton::unit_quaternion;
use crate::rig::RigError;

/// Every animation: its channels, one per animated node and property, their keys read and
/// checked.
pub(super) fn read_animations(
    src: &Source,
    doc: &gltf::Document,
    warnings: &mut Vec<String>,
) -> Result<Vec<Animation>, RigError> {
    let mut out = Vec::new();
    let mut matrix_nodes: Vec<usize> = Vec::new();
    for anim in doc.animations() {
        let mut channels = Vec::new();
        for ch in anim.channels() {
            let at = format!("animations[{}].channels[{}]", anim.index(), ch.index());
            let node = ch.target().node();
            let is_matrix = matches!(node.transform(), gltf::scene::Transform::Matrix { .. });
            if is_matrix && !matrix_nodes.contains(&node.index()) {
                matrix_nodes.push(node.index());
                // glTF 2.0 §3.11: an animated node MUST be given by TRS (found by review: a
                // sheared or zero-scale matrix posed wrong without a word).
                warnings.push(format!(
                    "nodes[{}]: animated but given by a matrix (glTF requires TRS): its \
                     matrix is decomposed into translation, rotation and scale, shear dropped",
                    node.index()
                ));
            }
            let property = match ch.target().property() {
                gltf::animation::Property::Translation => Property::Translation,
                gltf::animation::Property::Rotation => Property::Rotation,
                gltf::animation::Property::Scale => Property::Scale,
                gltf::animation::Property::MorphTargetWeights => Property::Weights,
            };
            let targets = morph_target_count(&ch.target().node());
            if property == Property::Weights && targets == 0 {
                warnings.push(format!(
                    "{at}: morph target weights of a node without morph targets (ignored)"
                ));
                continue;
            }
            let width = property.components(targets);
            let mut channel = read_channel(src, doc, &ch, &at, (property, width))?;
            if property == Property::Rotation {
                let rest = ch.target().node().transform().decomposed().1;
                let zeros = replace_zero_rotations(&mut channel, rest.map(f64::from));
                if zeros > 0 {
                    warnings.push(format!(
                        "{at}: {zeros} rotation key(s) are zero quaternions (not a rotation): \
                         read as the node's rest rotation"
                    ));
                }
            }
            channels.push(channel);
        }
        out.push(Animation::new(anim.name().map(str::to_string), channels));
    }
    Ok(out)
}

/// Replaces the zero quaternions ([`unit_quaternion`]'s `None`) among a rotation channel's key
/// values (each key's value; a cubic spline's tangents left as they are) by `rest`
/// (`[x, y, z, w]`); their number.
/// Sampling would otherwise read them as the identity between keys and as the rest rotation at
/// a key (until 2026-12-05, without a word).
fn replace_zero_rotations(channel: &mut Channel, rest: [f64; 4]) -> usize {
    let cubic = channel.interpolation == Interpolation::CubicSpline;
    let (stride, value) = if cubic { (12, 4) } else { (4, 0) };
    let mut zeros = 0;
    for key in channel.values.chunks_exact_mut(stride) {
        let q = &mut key[value..value + 4];
        if unit_quaternion([q[0], q[1], q[2], q[3]]).is_none() {
            q.copy_from_slice(&rest);
            zeros += 1;
        }
    }
    zeros
}

/// The number of morph targets of `node`'s body: its mesh's first triangle primitive's (glTF
/// requires as many on every primitive; the body is made of its triangle primitives, which
/// [`super::morphs::merge_targets`] holds to one count), 0 without one. A first primitive of
/// points or lines, ignored, no longer sets the count (found by review: its count, differing
/// from the triangles', dropped the weights channel with a warning).
fn morph_target_count(node: &gltf::Node) -> usize {
    let mesh = node.mesh();
    let first = mesh.and_then(|m| m.primitives().find(super::bodies::is_triangles));
    first.map_or(0, |p| p.morph_targets().count())
}

/// A channel driving `property`, whose values have `width` components (a weights channel's
/// output is SCALAR, `width` values per key).
fn read_channel(
    src: &Source,
    doc: &gltf::Document,
    ch: &gltf::animation::Channel,
    at: &str,
    (property, width): (Property, usize),
) -> Result<Channel, RigError> {
    let sampler = ch.sampler();
    let interpolation = match sampler.interpolation() {
        gltf::animation::Interpolation::Linear => Interpolation::Linear,
        gltf::animation::Interpolation::Step => Interpolation::Step,
        gltf::animation::Interpolation::CubicSpline => Interpolation::CubicSpline,
    };
    let input = accessor::read(
        src,
        doc,
        sampler.input().index(),
        &format!("input of {at}"),
        &[1],
        false,
    )?;
    let times = input.data;
    if times.is_empty() {
        return Err(invalid(src.file, at, "sampler input has no key"));
    }
    if times.iter().any(|t| !t.is_finite()) || times.windows(2).any(|w| w[1] <= w[0]) {
        return Err(invalid(
            src.file,
            at,
            "key times are not finite and strictly increasing",
        ));
    }
    // A weights channel's output is SCALAR: `width` elements per value.
    let (dims, elements_per_value) = if property == Property::Weights {
        (1, width)
    } else {
        (width, 1)
    };
    let output = accessor::read(
        src,
        doc,
        sampler.output().index(),
        &format!("output of {at}"),
        &[dims],
        false,
    )?;
    let per_key = elements_per_value
        * if interpolation == Interpolation::CubicSpline {
            3
        } else {
            1
        };
    if output.count() != times.len() * per_key {
        return Err(invalid(
            src.file,
            at,
            format!(
                "{} output values for {} keys ({:?})",
                output.count(),
                times.len(),
                interpolation
            ),
        ));
    }
    if output.data.iter().any(|x| !x.is_finite()) {
        return Err(invalid(src.file, at, "output holds a non-finite value"));
    }
    Ok(Channel {
        node: ch.target().node().index(),
        property,
        width,
        interpolation,
        times,
        values: output.data,
    })
}
