//! Reading the skins: joints and inverse bind matrices.

use super::invalid;
use super::nodes::NotAffine;
use crate::rig::accessor::{self, Source};
use crate::rig::{RigError, Skin};
use nalgebra::Matrix4;

/// Every skin: its joints (at least one, at most 65535) and their inverse bind matrices
/// (the identity when the file gives none; made affine where they are not).
pub(super) fn read_skins(
    src: &Source,
    doc: &gltf::Document,
    warnings: &mut Vec<String>,
) -> Result<Vec<Skin>, RigError> {
    let mut skins = Vec::new();
    let mut not_affine = NotAffine::default();
    for skin in doc.skins() {
        let joints: Vec<usize> = skin.joints().map(|n| n.index()).collect();
        if joints.is_empty() {
            return Err(invalid(
                src.file,
                format!("skins[{}]", skin.index()),
                "has no joints",
            ));
        }
        if joints.len() > u16::MAX as usize {
            return Err(invalid(
                src.file,
                format!("skins[{}]", skin.index()),
                "has more than 65535 joints",
            ));
        }
        let inverse_bind = match skin.inverse_bind_matrices() {
            None => vec![Matrix4::identity(); joints.len()],
            Some(acc) => {
                let role = format!("inverseBindMatrices of skins[{}]", skin.index());
                let v = accessor::read(src, doc, acc.index(), &role, &[16], false)?;
                if v.count() < joints.len() {
                    return Err(invalid(
                        src.file,
                        format!("skins[{}]", skin.index()),
                        format!(
                            "{} inverse bind matrices for {} joints",
                            v.count(),
                            joints.len()
                        ),
                    ));
                }
                if v.data.iter().any(|x| !x.is_finite()) {
                    return Err(invalid(src.file, role, "non-finite matrix entry"));
                }
                (0..joints.len())
                    .map(|j| {
                        let m = Matrix4::from_column_slice(v.element(j));
                        not_affine.fix(m, || format!("{role}[{j}]"))
                    })
                    .collect()
            }
        };
        skins.push(Skin {
            name: skin.name().map(str::to_string),
            joints,
            inverse_bind,
        });
    }
    not_affine.warn(warnings);
    Ok(skins)
}
