//! Per-frame Wavefront OBJ, the output contract of `MEASURING.md`: world-space positions of
//! every skinned primitive, in file order, with exactly the glTF vertex order (split seam
//! vertices included) and faces, so two runs compare vertex by vertex.
//!
//! Coordinates are written as the shortest decimal that round-trips the `f32` value (what a glb
//! stores), so the text is a deterministic function of the frame.

use crate::frames::Frame;
use crate::rig::Rig;
use std::fmt::Write as _;

/// The OBJ text of one frame.
pub fn frame_to_obj(rig: &Rig, frame: &Frame, header: &str) -> String {
    frame_to_obj_with(&ObjFaces::of(rig), frame, header)
}

/// The part of a rig's OBJ text that no pose changes: its objects and faces, written once per
/// run rather than once per frame (on `finger_long`, 9120 faces, they were about two fifths
/// of the writer's time).
#[derive(Clone, Debug)]
pub struct ObjFaces {
    text: String,
    vertices: usize,
}

impl ObjFaces {
    /// The objects and faces of `rig`.
    pub fn of(rig: &Rig) -> Self {
        let mut text = String::new();
        let mut base = 1usize;
        for (b, body) in rig.bodies.iter().enumerate() {
            for prim in &body.primitives {
                let _ = writeln!(
                    text,
                    "o {}.mesh{}.prim{} body{}",
                    body.name.replace(char::is_whitespace, "_"),
                    prim.mesh,
                    prim.primitive,
                    b
                );
                let tris =
                    &body.triangles[prim.first_triangle..prim.first_triangle + prim.triangle_count];
                for t in tris {
                    let _ = writeln!(
                        text,
                        "f {} {} {}",
                        t[0] as usize + base,
                        t[1] as usize + base,
                        t[2] as usize + base
                    );
                }
            }
            base += body.vertex_count();
        }
        Self {
            text,
            vertices: rig.vertex_count(),
        }
    }
}

/// [`frame_to_obj`] with the rig's objects and faces written beforehand ([`ObjFaces::of`] the
/// frame's rig): the same text.
pub fn frame_to_obj_with(faces: &ObjFaces, frame: &Frame, header: &str) -> String {
    let mut s = String::with_capacity(faces.vertices * 40 + faces.text.len());
    let _ = writeln!(
        s,
        "# contact-skin {} frame {} t={}",
        env!("CARGO_PKG_VERSION"),
        frame.index,
        frame.time
    );
    for line in header.lines() {
        let _ = writeln!(s, "# {line}");
    }
    for posed in &frame.bodies {
        for p in &posed.positions {
            let _ = writeln!(s, "v {} {} {}", p.x as f32, p.y as f32, p.z as f32);
        }
    }
    s.push_str(&faces.text);
    s
}

/// The file name of frame `index`: `frame_NNNN.obj`.
pub fn frame_file_name(index: usize) -> String {
    format!("frame_{index:04}.obj")
}
