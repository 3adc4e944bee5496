//! Writing results: per-frame OBJ files (the output contract of `MEASURING.md`) and a baked
//! glb that plays the result in any glTF viewer. Every file is written atomically.

mod atomic;
pub mod glb;
pub mod glb_builder;
pub mod obj;

pub use atomic::write_atomic;
