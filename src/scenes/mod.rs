//! The procedural test scenes of `rigs/` (see `MEASURING.md`, "Scenes"): skinned, animated
//! glTF 2.0 binaries reproducing the set-ups of Brunel et al. 2021 (Figs. 1d, 5, 6, 13, 14,
//! 15, 17).
//!
//! Every body is a closed, outward-oriented 2-manifold (after welding coincident positions)
//! on its own skinned mesh node, with POSITION, NORMAL, JOINTS_0, WEIGHTS_0 and `u32` indices;
//! rigid bodies are skinned to a single joint. Every scene has one LINEAR animation that starts
//! at the rest pose and drives its parts well into interpenetration (plain skinning does not
//! resolve contacts: that is what the scenes are for); the bending capsule also has "twist".
//!
//! # Resolution
//! All bodies of a scene are meshed with one target edge length `h = L / resolution`, `L` the
//! scene's [`Scene::reference_length`]. A capsule, sphere or tube of radius `r` gets
//! `q = max(2, round(π r / 2h))` latitude steps per quarter circle and `4q` segments around,
//! with rings spaced like the latitude arcs (about `h`); the lips take `4·round(P / 4h)`
//! segments around their cross-section of perimeter `P` and rings about `h` apart along the
//! ring's centerline;
//! the slab is a grid of cells of about `h`. Vertex counts grow like `resolution²`. Output is
//! deterministic: the same scene and resolution give the same bytes.

mod catalog;
mod shapes;
mod write;

use std::path::{Path, PathBuf};

/// Resolution of the committed `rigs/*.glb` files.
pub const DEFAULT_RESOLUTION: u32 = 8;

/// Smallest accepted resolution.
pub const MIN_RESOLUTION: u32 = 1;

/// Largest accepted resolution (the finger then has about 250,000 vertices, a 19 MB file).
pub const MAX_RESOLUTION: u32 = 64;

/// One of the procedural test scenes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Scene {
    /// One capsule bent at a middle joint, 0 to 150° ("bend"), or twisted ("twist") (Fig. 13).
    BendingCapsule,
    /// A tapered three-phalanx finger flexing past contact (Fig. 15).
    Finger,
    /// [`Scene::Finger`] with a longer metacarpal stub: the metacarpal-proximal fold at the
    /// size of the paper's skinned finger (Table 1), for the benchmark.
    FingerLong,
    /// Upper and lower lip on one mesh, a jaw closing past contact (Fig. 1d).
    Mouth,
    /// Two separate capsules crossing, one pressed into the other (Figs. 5, 6).
    CapsulePair,
    /// Three fingertips pressing one ball: several contact zones on one body (Fig. 14).
    FingertipsOnBall,
    /// Two fingers of one mesh pressed against each other: sibling joints, separated working
    /// regions (Fig. 14).
    TwoFingers,
    /// A sphere pressed into a thick slab: the rigid-limit case (Fig. 17).
    SphereOnPlane,
}

impl Scene {
    /// Every scene, in a fixed order.
    pub const ALL: [Scene; 8] = [
        Scene::BendingCapsule,
        Scene::Finger,
        Scene::FingerLong,
        Scene::Mouth,
        Scene::CapsulePair,
        Scene::FingertipsOnBall,
        Scene::SphereOnPlane,
        Scene::TwoFingers,
    ];

    /// File stem and command-line name.
    pub fn name(self) -> &'static str {
        match self {
            Scene::BendingCapsule => "bending_capsule",
            Scene::Finger => "finger",
            Scene::FingerLong => "finger_long",
            Scene::Mouth => "mouth",
            Scene::CapsulePair => "capsule_pair",
            Scene::FingertipsOnBall => "fingertips_ball",
            Scene::SphereOnPlane => "sphere_plane",
            Scene::TwoFingers => "two_fingers",
        }
    }

    /// The scene called `name` (as returned by [`Scene::name`]).
    pub fn from_name(name: &str) -> Option<Scene> {
        Scene::ALL.into_iter().find(|s| s.name() == name)
    }

    /// One-line description: bodies, skeleton and animation.
    pub fn description(self) -> &'static str {
        match self {
            Scene::BendingCapsule => {
                "one capsule (r 0.2, length 2.4) on two bones; 'bend' folds the middle joint 0-150 deg \
                 about +Z, 'twist' turns the upper bone 0-150 deg about its axis (Fig. 13)"
            }
            Scene::Finger => {
                "a tapered finger on one mesh: metacarpal stub and three phalanges, 4 bones; 'flex' \
                 bends MCP/PIP/DIP to 100/110/100 deg toward +Z, past contact (Fig. 15)"
            }
            Scene::FingerLong => {
                "the finger with a metacarpal stub 0.22 longer: its MCP working regions have the size \
                 of the paper's skinned finger (Table 1, 1967 + 2951 vertices), for the benchmark"
            }
            Scene::Mouth => {
                "upper and lower lip as one ring mesh (slit 0.1 high), head and jaw bones, the corners \
                 half on each; 'close' turns the jaw 11 deg: the lower lip sinks 0.12 into the upper one \
                 and the corners fold; contact direction vertical (Fig. 1d)"
            }
            Scene::CapsulePair => {
                "two separate capsules (r 0.25) crossing at right angles; 'press' sinks the upper one \
                 0.75 r into the lower one while turning it 30 deg (Figs. 5, 6)"
            }
            Scene::FingertipsOnBall => {
                "a ball (r 0.5) and three separate fingertip capsules; 'squeeze' presses them 0.1 \
                 into the ball one after another: three contact zones on one body (Fig. 14)"
            }
            Scene::TwoFingers => {
                "two fingers (r 0.1 to 0.075, length 1) side by side on one mesh and one palm joint; \
                 'press' turns each 5 deg toward the other: they cross by 0.1 at the tips, a contact \
                 between sibling joints (separated working regions, Fig. 14)"
            }
            Scene::SphereOnPlane => {
                "a sphere (r 0.5) and a 3 x 0.4 x 3 slab; 'press' sinks the sphere half a radius \
                 into the slab: rigid-limit case and bulge map (Fig. 17)"
            }
        }
    }

    /// Reference length `L`: the scene is meshed with target edge length `L / resolution`.
    pub fn reference_length(self) -> f64 {
        match self {
            Scene::BendingCapsule => catalog::BENDING_CAPSULE_REF,
            Scene::Finger | Scene::FingerLong | Scene::TwoFingers => catalog::FINGER_REF,
            Scene::Mouth => catalog::MOUTH_REF,
            Scene::CapsulePair => catalog::CAPSULE_PAIR_REF,
            Scene::FingertipsOnBall => catalog::FINGERTIPS_BALL_REF,
            Scene::SphereOnPlane => catalog::SPHERE_PLANE_REF,
        }
    }

    /// Target edge length at `resolution`.
    pub fn edge_length(self, resolution: u32) -> f64 {
        self.reference_length() / f64::from(resolution.max(1))
    }

    fn spec(self, resolution: u32) -> Result<write::SceneSpec, SceneError> {
        check_resolution(resolution)?;
        Ok(match self {
            Scene::BendingCapsule => catalog::bending_capsule(resolution),
            Scene::Finger => catalog::finger(resolution),
            Scene::FingerLong => catalog::finger_long(resolution),
            Scene::Mouth => catalog::mouth(resolution),
            Scene::CapsulePair => catalog::capsule_pair(resolution),
            Scene::FingertipsOnBall => catalog::fingertips_ball(resolution),
            Scene::SphereOnPlane => catalog::sphere_plane(resolution),
            Scene::TwoFingers => catalog::two_fingers(resolution),
        })
    }
}

impl std::fmt::Display for Scene {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// Why a scene could not be built or written.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// The resolution is outside [`MIN_RESOLUTION`]`..=`[`MAX_RESOLUTION`].
    #[error("resolution {0} is outside {MIN_RESOLUTION}..={MAX_RESOLUTION}")]
    Resolution(u32),
    /// Writing a file failed.
    #[error("cannot write {path}: {source}")]
    Io {
        /// The file (or folder) being written.
        path: PathBuf,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
    /// Serializing the glTF JSON failed, or the file would not fit a GLB.
    #[error("cannot build the glb: {0}")]
    Glb(#[from] crate::output::glb_builder::GlbError),
}

fn check_resolution(resolution: u32) -> Result<(), SceneError> {
    if (MIN_RESOLUTION..=MAX_RESOLUTION).contains(&resolution) {
        Ok(())
    } else {
        Err(SceneError::Resolution(resolution))
    }
}

/// Size and reference volume of one body of a scene.
#[derive(Clone, Debug, PartialEq)]
pub struct BodySummary {
    /// Node name of the body.
    pub name: String,
    /// Number of file vertices.
    pub vertices: usize,
    /// Number of triangles.
    pub triangles: usize,
    /// Volume of the smooth primitive the mesh approximates (capsule `πr²ℓ + 4/3 πr³`, sphere,
    /// tapered tube, flattened torus, box); the mesh is inscribed, so slightly smaller.
    pub analytic_volume: f64,
}

/// The bodies of `scene` at `resolution`, in file order.
pub fn summarize(scene: Scene, resolution: u32) -> Result<Vec<BodySummary>, SceneError> {
    let spec = scene.spec(resolution)?;
    Ok(spec
        .bodies
        .iter()
        .map(|b| BodySummary {
            name: b.name.to_string(),
            vertices: b.mesh.positions.len(),
            triangles: b.mesh.triangles.len(),
            analytic_volume: b.analytic_volume,
        })
        .collect())
}

/// The GLB bytes of `scene` at `resolution` (deterministic).
pub fn build_glb(scene: Scene, resolution: u32) -> Result<Vec<u8>, SceneError> {
    let spec = scene.spec(resolution)?;
    Ok(write::assemble(&spec)?)
}

/// Writes `dir/<name>.glb` atomically (creating `dir` if needed) and returns its path.
pub fn write(scene: Scene, resolution: u32, dir: &Path) -> Result<PathBuf, SceneError> {
    let bytes = build_glb(scene, resolution)?;
    std::fs::create_dir_all(dir).map_err(|source| SceneError::Io {
        path: dir.to_path_buf(),
        source,
    })?;
    let path = dir.join(format!("{}.glb", scene.name()));
    crate::output::write_atomic(&path, &bytes).map_err(|source| SceneError::Io {
        path: path.clone(),
        source,
    })?;
    Ok(path)
}

/// Writes every scene of [`Scene::ALL`] into `dir`; returns the paths in that order.
pub fn write_all(resolution: u32, dir: &Path) -> Result<Vec<PathBuf>, SceneError> {
    check_resolution(resolution)?;
    Scene::ALL
        .into_iter()
        .map(|s| write(s, resolution, dir))
        .collect()
}

/// Most subdivision levels [`icosphere`] takes (655 362 vertices).
pub const MAX_ICOSPHERE_LEVELS: u32 = 8;

/// The unit icosphere subdivided `levels` times (at most [`MAX_ICOSPHERE_LEVELS`]; more is
/// taken as that): `10·4^levels + 2` vertices and counter-clockwise triangles seen from
/// outside, mirror-symmetric about the coordinate planes (a symmetric test body).
pub fn icosphere(levels: u32) -> (Vec<nalgebra::Point3<f64>>, Vec<[u32; 3]>) {
    let mesh = shapes::icosphere(levels.min(MAX_ICOSPHERE_LEVELS));
    (mesh.positions, mesh.triangles)
}

/// A test rig (not in `rigs/`): two ellipsoids crossing at right angles, the second shifted by
/// `offset` along y, in one mesh, each rigid on one of two sibling joints under a `hub` joint
/// (which carries a third ellipsoid, far from the others, so that it is a weighted parent). At
/// `offset = 0` the mesh's mirror symmetries make the normals over both intersection regions
/// cancel out (Eq. 2 gives no direction).
#[cfg(test)]
pub(crate) fn crossing_ellipsoids_glb(offset: f64) -> Vec<u8> {
    use nalgebra::{Point3, Vector3};
    use shapes::MeshData;
    use write::{Influence, Joint, SceneSpec, SkinnedBody};
    let part = |scale: Vector3<f64>, shift: Vector3<f64>| {
        let mut m = shapes::icosphere(3);
        for (p, n) in m.positions.iter_mut().zip(&mut m.normals) {
            *p = Point3::from(p.coords.component_mul(&scale) + shift);
            *n = n.component_div(&scale).normalize();
        }
        m
    };
    let thin = Vector3::new(1.0, 0.3, 0.3);
    let parts = [
        part(thin, Vector3::zeros()),
        part(Vector3::new(0.3, 0.3, 1.0), Vector3::y() * offset),
        part(thin, Vector3::y() * 3.0),
    ];
    let mut mesh = MeshData::default();
    let mut influences = Vec::new();
    for (joint, part) in [1u16, 2, 0].into_iter().zip(parts) {
        let first = mesh.positions.len() as u32;
        influences.extend(part.positions.iter().map(|_| Influence::rigid(joint)));
        mesh.positions.extend(part.positions);
        mesh.normals.extend(part.normals);
        mesh.triangles
            .extend(part.triangles.iter().map(|t| t.map(|i| i + first)));
    }
    let spec = SceneSpec {
        name: "crossing_ellipsoids",
        joints: vec![
            Joint::at("hub", None, Vector3::zeros()),
            Joint::at("long_x", Some(0), Vector3::zeros()),
            Joint::at("long_z", Some(0), Vector3::zeros()),
        ],
        bodies: vec![SkinnedBody {
            name: "ellipsoids",
            mesh,
            skin: vec![0, 1, 2],
            influences,
            analytic_volume: 0.0,
        }],
        clips: Vec::new(),
    };
    write::assemble(&spec).expect("the test rig assembles")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip() {
        for s in Scene::ALL {
            assert_eq!(Scene::from_name(s.name()), Some(s));
        }
        assert_eq!(Scene::from_name("nope"), None);
    }

    #[test]
    fn smoothstep_ends() {
        assert_eq!(catalog::smoothstep(-1.0), 0.0);
        assert_eq!(catalog::smoothstep(2.0), 1.0);
        assert!((catalog::smoothstep(0.5) - 0.5).abs() < 1e-15);
    }
}
