//! A small builder of binary glTF (`.glb`) files on top of `gltf-json`: typed accessors are
//! appended to one binary buffer (4-byte aligned, with the `min` / `max` the validator requires
//! on POSITION), and [`GlbBuilder::finish`] packs JSON and binary chunks.

use gltf_json as json;
use json::validation::{Checked::Valid, USize64};

/// Why [`GlbBuilder::finish`] failed.
#[derive(Debug, thiserror::Error)]
pub enum GlbError {
    /// The document could not be serialized.
    #[error("glTF serialization: {0}")]
    Json(#[from] json::Error),
    /// The file would not fit the GLB's 32-bit lengths.
    #[error("{bytes} bytes: a GLB holds less than 4 GiB (its lengths are 32-bit)")]
    TooLarge {
        /// The size the file would have.
        bytes: usize,
    },
}

/// Accumulates a glTF document and its single binary buffer.
pub struct GlbBuilder {
    /// The document being built; push nodes, meshes, skins, animations into it directly.
    pub root: json::Root,
    bin: Vec<u8>,
}

impl Default for GlbBuilder {
    fn default() -> Self {
        Self::new()
    }
}

/// Buffer-view target hint.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Target {
    /// Vertex attributes.
    Vertex,
    /// Triangle indices.
    Index,
    /// Anything else (inverse bind matrices, animation data).
    None,
}

impl GlbBuilder {
    /// An empty document with `asset.generator` set.
    pub fn new() -> Self {
        let root = json::Root {
            asset: json::Asset {
                generator: Some(format!("contact-skin {}", env!("CARGO_PKG_VERSION"))),
                ..Default::default()
            },
            ..Default::default()
        };
        Self {
            root,
            bin: Vec::new(),
        }
    }

    fn view(
        &mut self,
        bytes: &[u8],
        target: Target,
        stride: Option<usize>,
    ) -> json::Index<json::buffer::View> {
        while self.bin.len() % 4 != 0 {
            self.bin.push(0);
        }
        let offset = self.bin.len();
        self.bin.extend_from_slice(bytes);
        self.root.push(json::buffer::View {
            buffer: json::Index::new(0),
            byte_length: USize64::from(bytes.len()),
            byte_offset: Some(USize64::from(offset)),
            byte_stride: stride.map(json::buffer::Stride),
            name: None,
            target: match target {
                Target::Vertex => Some(Valid(json::buffer::Target::ArrayBuffer)),
                Target::Index => Some(Valid(json::buffer::Target::ElementArrayBuffer)),
                Target::None => None,
            },
            extensions: None,
            extras: Default::default(),
        })
    }

    #[allow(clippy::too_many_arguments)]
    fn accessor(
        &mut self,
        bytes: &[u8],
        count: usize,
        component: json::accessor::ComponentType,
        type_: json::accessor::Type,
        normalized: bool,
        target: Target,
        min_max: Option<(Vec<f32>, Vec<f32>)>,
    ) -> json::Index<json::Accessor> {
        let stride = (target == Target::Vertex
            && type_ == json::accessor::Type::Vec4
            && component != json::accessor::ComponentType::F32)
            .then_some(bytes.len() / count.max(1))
            .filter(|s| s % 4 == 0 && *s > 0);
        let view = self.view(bytes, target, stride);
        let (min, max) = match min_max {
            Some((lo, hi)) => (Some(json::Value::from(lo)), Some(json::Value::from(hi))),
            None => (None, None),
        };
        self.root.push(json::Accessor {
            buffer_view: Some(view),
            byte_offset: None,
            count: USize64::from(count),
            component_type: Valid(json::accessor::GenericComponentType(component)),
            extensions: None,
            extras: Default::default(),
            type_: Valid(type_),
            min,
            max,
            name: None,
            normalized,
            sparse: None,
        })
    }

    /// Appends `f32` elements of `N` components; `with_bounds` records `min` / `max`
    /// (required for POSITION and animation inputs).
    pub fn push_f32<const N: usize>(
        &mut self,
        data: &[[f32; N]],
        target: Target,
        with_bounds: bool,
    ) -> json::Index<json::Accessor> {
        let type_ = match N {
            1 => json::accessor::Type::Scalar,
            2 => json::accessor::Type::Vec2,
            3 => json::accessor::Type::Vec3,
            4 => json::accessor::Type::Vec4,
            16 => json::accessor::Type::Mat4,
            _ => panic!("unsupported element size {N}"),
        };
        let bounds = with_bounds.then(|| {
            let mut lo = [f32::INFINITY; N];
            let mut hi = [f32::NEG_INFINITY; N];
            for e in data {
                for c in 0..N {
                    lo[c] = lo[c].min(e[c]);
                    hi[c] = hi[c].max(e[c]);
                }
            }
            (lo.to_vec(), hi.to_vec())
        });
        let bytes: Vec<u8> = data
            .iter()
            .flatten()
            .flat_map(|x| x.to_le_bytes())
            .collect();
        self.accessor(
            &bytes,
            data.len(),
            json::accessor::ComponentType::F32,
            type_,
            false,
            target,
            bounds,
        )
    }

    /// Appends a SCALAR `f32` accessor of `count` elements, zero but for `values`
    /// (`(element, value)`, by increasing element): a sparse accessor without a buffer view
    /// (glTF 2.0 §3.6.2.3), whose bytes grow with `values` only; a dense one when `values` is
    /// empty (a sparse accessor holds at least one value).
    pub fn push_sparse_scalar(
        &mut self,
        count: usize,
        values: &[(u32, f32)],
    ) -> json::Index<json::Accessor> {
        if values.is_empty() {
            return self.push_f32(&vec![[0.0f32]; count], Target::None, false);
        }
        let indices: Vec<u8> = values.iter().flat_map(|(i, _)| i.to_le_bytes()).collect();
        let data: Vec<u8> = values.iter().flat_map(|(_, v)| v.to_le_bytes()).collect();
        let indices = self.view(&indices, Target::None, None);
        let data = self.view(&data, Target::None, None);
        let sparse = json::accessor::sparse::Sparse {
            count: USize64::from(values.len()),
            indices: json::accessor::sparse::Indices {
                buffer_view: indices,
                byte_offset: USize64(0),
                component_type: Valid(json::accessor::IndexComponentType(
                    json::accessor::ComponentType::U32,
                )),
                extensions: None,
                extras: Default::default(),
            },
            values: json::accessor::sparse::Values {
                buffer_view: data,
                byte_offset: USize64(0),
                extensions: None,
                extras: Default::default(),
            },
            extensions: None,
            extras: Default::default(),
        };
        self.root.push(json::Accessor {
            buffer_view: None,
            byte_offset: None,
            count: USize64::from(count),
            component_type: Valid(json::accessor::GenericComponentType(
                json::accessor::ComponentType::F32,
            )),
            extensions: None,
            extras: Default::default(),
            type_: Valid(json::accessor::Type::Scalar),
            min: None,
            max: None,
            name: None,
            normalized: false,
            sparse: Some(sparse),
        })
    }

    /// Appends triangle indices as `u32`.
    pub fn push_indices(&mut self, triangles: &[[u32; 3]]) -> json::Index<json::Accessor> {
        let bytes: Vec<u8> = triangles
            .iter()
            .flatten()
            .flat_map(|x| x.to_le_bytes())
            .collect();
        self.accessor(
            &bytes,
            triangles.len() * 3,
            json::accessor::ComponentType::U32,
            json::accessor::Type::Scalar,
            false,
            Target::Index,
            None,
        )
    }

    /// Appends JOINTS_n data as `u16` VEC4.
    pub fn push_joints(&mut self, joints: &[[u16; 4]]) -> json::Index<json::Accessor> {
        let bytes: Vec<u8> = joints
            .iter()
            .flatten()
            .flat_map(|x| x.to_le_bytes())
            .collect();
        self.accessor(
            &bytes,
            joints.len(),
            json::accessor::ComponentType::U16,
            json::accessor::Type::Vec4,
            false,
            Target::Vertex,
            None,
        )
    }

    /// Packs the document and the binary buffer into GLB bytes; a file the GLB's 32-bit
    /// lengths cannot describe (4 GiB and more, glTF 2.0 §4.4) is [`GlbError::TooLarge`]
    /// rather than a header whose lengths wrapped.
    pub fn finish(mut self) -> Result<Vec<u8>, GlbError> {
        while self.bin.len() % 4 != 0 {
            self.bin.push(0);
        }
        if !self.bin.is_empty() {
            self.root.buffers = vec![json::Buffer {
                byte_length: USize64::from(self.bin.len()),
                name: None,
                uri: None,
                extensions: None,
                extras: Default::default(),
            }];
        }
        let mut json_bytes = self.root.to_vec()?;
        while json_bytes.len() % 4 != 0 {
            json_bytes.push(b' ');
        }
        let has_bin = !self.bin.is_empty();
        let total = 12 + 8 + json_bytes.len() + if has_bin { 8 + self.bin.len() } else { 0 };
        if u32::try_from(total).is_err() {
            return Err(GlbError::TooLarge { bytes: total });
        }
        let mut out = Vec::with_capacity(total);
        out.extend_from_slice(b"glTF");
        out.extend_from_slice(&2u32.to_le_bytes());
        out.extend_from_slice(&(total as u32).to_le_bytes());
        out.extend_from_slice(&(json_bytes.len() as u32).to_le_bytes());
        out.extend_from_slice(b"JSON");
        out.extend_from_slice(&json_bytes);
        if has_bin {
            out.extend_from_slice(&(self.bin.len() as u32).to_le_bytes());
            out.extend_from_slice(b"BIN\0");
            out.extend_from_slice(&self.bin);
        }
        Ok(out)
    }
}
