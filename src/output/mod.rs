//! Writing results: per-frame OBJ files (the output contract of `MEASURING.md`) and a baked
//! glb that plays the result in any glTF viewer. Every file is written atomically.

mod atomic;
pub mod glb;
pub mod glb_builder;
pub mod obj;

pub use atomic::{clear_interrupted, clear_own, commit_all, write_atomic, Cleared, Staged};

/// Whether every position of `frame` can be written: finite, and within `f32`'s range (OBJ
/// and glb store `f32`). A rig whose transforms overflow (scales of 1e30 down a joint chain,
/// inverse bind matrices near `f64::MAX`) poses to NaN or to values that become infinite as
/// `f32`: refused here rather than written (found by fuzzing).
pub fn check_representable(frame: &crate::frames::Frame) -> Result<(), String> {
    for (b, body) in frame.bodies.iter().enumerate() {
        for (v, p) in body.positions.iter().enumerate() {
            if !p
                .iter()
                .all(|x| x.is_finite() && x.abs() <= f64::from(f32::MAX))
            {
                return Err(format!(
                    "body {b} vertex {v}: the posed position [{}, {}, {}] cannot be written as \
                     32-bit floats (the rig's transforms overflow)",
                    p.x, p.y, p.z
                ));
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frames::Frame;
    use crate::skinning::Skinned;
    use nalgebra::{Point3, Vector3};

    fn frame(index: usize, time: f64, p: Point3<f64>) -> Frame {
        Frame {
            index,
            time,
            bodies: vec![Skinned {
                positions: vec![Point3::origin(), p],
                normals: vec![Vector3::z(); 2],
            }],
        }
    }

    #[test]
    fn positions_beyond_f32_or_not_finite_are_refused() {
        assert!(check_representable(&frame(0, 0.0, Point3::new(1.0, -2.0, 3e38))).is_ok());
        for bad in [f64::NAN, f64::INFINITY, 4e38, -1e300] {
            let e = check_representable(&frame(0, 0.0, Point3::new(1.0, bad, 0.0)))
                .expect_err("refused");
            assert!(e.contains("vertex 1"), "{e}");
        }
    }

    #[test]
    fn deltas_and_key_times_beyond_f32_are_refused() {
        let base = frame(0, 0.0, Point3::new(-3e38, 0.0, 0.0));
        let near = frame(1, 1.0, Point3::new(-1e38, 0.0, 0.0));
        assert!(glb::check_bakeable(&[base.clone(), near]).is_ok());
        let across = frame(1, 1.0, Point3::new(3e38, 0.0, 0.0));
        assert!(glb::check_bakeable(&[base.clone(), across]).is_err());
        let late = frame(1, 1e39, Point3::new(-3e38, 0.0, 0.0));
        assert!(glb::check_bakeable(&[base, late]).is_err());
    }
}
