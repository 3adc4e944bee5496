//! Validated reading of glTF accessors.
//!
//! The `gltf` crate's accessor iterators underflow on `count = 0`, trust the declared component
//! type in release builds and can overflow on absurd counts, so reading goes through here: every
//! offset is computed with checked arithmetic and checked against the buffer view and the buffer
//! before a byte is read, and the result size is bounded by the data actually present
//! (accessors without a buffer view are capped at [`MAX_VIEWLESS_ELEMENTS`]). All component
//! types are read (normalized integers are mapped to `[0, 1]` or `[-1, 1]` per the glTF rules),
//! byteStride is honoured and sparse substitution is applied.

use super::RigError;
use gltf::accessor::{DataType, Dimensions};
use std::path::Path;

/// Upper bound on the element count of an accessor that has no buffer view (all zeros plus
/// sparse values): such a count costs memory without costing file bytes.
pub const MAX_VIEWLESS_ELEMENTS: usize = 1 << 22;

/// Most components (values) the accessor reads of one file may decode in all, morph target
/// displacements aside (bounded on their own: [`crate::rig::MAX_MORPH_READS`]): 2 GB as `f64`.
/// Accessors are read per use, and a file may use one accessor many times (a skin per
/// character sharing one inverse-bind-matrix accessor, channels sharing one key accessor), so
/// the file's size does not bound the reading (found by review: 500 skins naming one view-less
/// accessor of 4M matrices took 55 s from 23 kB).
pub const MAX_READ_COMPONENTS: usize = 1 << 28;

/// Where accessor data comes from: the file name (for errors) and the resolved buffers, and
/// the components read from them so far ([`MAX_READ_COMPONENTS`]).
pub struct Source<'a> {
    /// The file, named in errors.
    pub file: &'a Path,
    /// The bytes of every buffer, in buffer order.
    pub buffers: &'a [&'a [u8]],
    /// Components decoded so far by [`read`] (not [`read_unbounded`]).
    read: std::cell::Cell<usize>,
}

impl<'a> Source<'a> {
    /// The buffers of `file`, nothing read from them yet.
    pub fn new(file: &'a Path, buffers: &'a [&'a [u8]]) -> Self {
        Self {
            file,
            buffers,
            read: std::cell::Cell::new(0),
        }
    }
}

/// An accessor's values as `f64`, `dims` per element.
#[derive(Clone, Debug, PartialEq)]
pub struct Values {
    /// Components per element (1 for SCALAR, 3 for VEC3, 16 for MAT4, ...).
    pub dims: usize,
    /// `count * dims` values, element-major.
    pub data: Vec<f64>,
}

impl Values {
    /// Number of elements.
    pub fn count(&self) -> usize {
        self.data.len().checked_div(self.dims).unwrap_or(0)
    }

    /// Element `i`.
    pub fn element(&self, i: usize) -> &[f64] {
        &self.data[i * self.dims..(i + 1) * self.dims]
    }
}

fn dims_of(d: Dimensions) -> usize {
    match d {
        Dimensions::Scalar => 1,
        Dimensions::Vec2 => 2,
        Dimensions::Vec3 => 3,
        Dimensions::Vec4 => 4,
        Dimensions::Mat2 => 4,
        Dimensions::Mat3 => 9,
        Dimensions::Mat4 => 16,
    }
}

fn size_of(t: DataType) -> usize {
    match t {
        DataType::I8 | DataType::U8 => 1,
        DataType::I16 | DataType::U16 => 2,
        DataType::U32 | DataType::F32 => 4,
    }
}

/// Reads one component at `bytes[0..size_of(t)]`.
fn component(bytes: &[u8], t: DataType, normalized: bool) -> f64 {
    match t {
        DataType::I8 => {
            let v = bytes[0] as i8 as f64;
            if normalized {
                (v / 127.0).max(-1.0)
            } else {
                v
            }
        }
        DataType::U8 => {
            let v = bytes[0] as f64;
            if normalized {
                v / 255.0
            } else {
                v
            }
        }
        DataType::I16 => {
            let v = i16::from_le_bytes([bytes[0], bytes[1]]) as f64;
            if normalized {
                (v / 32767.0).max(-1.0)
            } else {
                v
            }
        }
        DataType::U16 => {
            let v = u16::from_le_bytes([bytes[0], bytes[1]]) as f64;
            if normalized {
                v / 65535.0
            } else {
                v
            }
        }
        DataType::U32 => u32::from_le_bytes([bytes[0], bytes[1], bytes[2], bytes[3]]) as f64,
        DataType::F32 => f32::from_le_bytes([bytes[0], bytes[1], bytes[2], bytes[3]]) as f64,
    }
}

struct Ctx<'s, 'a> {
    src: &'s Source<'a>,
    accessor: usize,
    role: &'s str,
}

impl Ctx<'_, '_> {
    fn err(&self, message: impl Into<String>) -> RigError {
        RigError::Accessor {
            file: self.src.file.to_path_buf(),
            accessor: self.accessor,
            role: self.role.to_string(),
            message: message.into(),
        }
    }

    /// The bytes of a buffer view, checked against its buffer.
    fn view_bytes(&self, view: &gltf::buffer::View) -> Result<&[u8], RigError> {
        let buffer = view.buffer().index();
        let data = self.src.buffers.get(buffer).ok_or_else(|| {
            self.err(format!(
                "bufferViews[{}] names a missing buffer",
                view.index()
            ))
        })?;
        let end = view.offset().checked_add(view.length());
        match end {
            Some(end) if end <= data.len() => Ok(&data[view.offset()..end]),
            _ => Err(self.err(format!(
                "bufferViews[{}] (offset {}, length {}) runs past the end of buffers[{}] ({} bytes)",
                view.index(),
                view.offset(),
                view.length(),
                buffer,
                data.len()
            ))),
        }
    }

    /// Reads `count` elements of `dims` components of type `t` from a view, starting at
    /// `offset`, `stride` bytes apart (0: tightly packed), appending to `out`.
    #[allow(clippy::too_many_arguments)]
    fn read_strided(
        &self,
        view: &gltf::buffer::View,
        offset: usize,
        count: usize,
        dims: usize,
        t: DataType,
        normalized: bool,
        out: &mut Vec<f64>,
    ) -> Result<(), RigError> {
        let bytes = self.view_bytes(view)?;
        let csize = size_of(t);
        let elem = csize * dims;
        let stride = view.stride().unwrap_or(elem);
        if stride < elem {
            return Err(self.err(format!(
                "bufferViews[{}].byteStride {} is smaller than the element size {}",
                view.index(),
                stride,
                elem
            )));
        }
        if count == 0 {
            return Ok(());
        }
        let needed = (count - 1)
            .checked_mul(stride)
            .and_then(|x| x.checked_add(elem))
            .and_then(|x| x.checked_add(offset));
        match needed {
            Some(n) if n <= bytes.len() => {}
            _ => {
                return Err(self.err(format!(
                    "{} elements of {} bytes (stride {}, offset {}) do not fit in bufferViews[{}] ({} bytes)",
                    count,
                    elem,
                    stride,
                    offset,
                    view.index(),
                    bytes.len()
                )))
            }
        }
        out.reserve(count * dims);
        for i in 0..count {
            let base = offset + i * stride;
            for c in 0..dims {
                let at = base + c * csize;
                out.push(component(&bytes[at..at + csize], t, normalized));
            }
        }
        Ok(())
    }
}

/// Reads accessor `index` into `f64` values. `role` names its use in errors; `dims_allowed`
/// lists the accepted element sizes (empty: any); `force_normalized` maps integer components to
/// `[0, 1]` even when the file forgot the `normalized` flag (used for WEIGHTS_n).
pub fn read(
    src: &Source,
    doc: &gltf::Document,
    index: usize,
    role: &str,
    dims_allowed: &[usize],
    force_normalized: bool,
) -> Result<Values, RigError> {
    read_counted(
        src,
        doc,
        (index, role),
        dims_allowed,
        force_normalized,
        true,
    )
}

/// [`read`] without counting against [`MAX_READ_COMPONENTS`], for reads bounded otherwise (the
/// morph targets').
pub fn read_unbounded(
    src: &Source,
    doc: &gltf::Document,
    index: usize,
    role: &str,
    dims_allowed: &[usize],
) -> Result<Values, RigError> {
    read_counted(src, doc, (index, role), dims_allowed, false, false)
}

fn read_counted(
    src: &Source,
    doc: &gltf::Document,
    (index, role): (usize, &str),
    dims_allowed: &[usize],
    force_normalized: bool,
    counted: bool,
) -> Result<Values, RigError> {
    let ctx = Ctx {
        src,
        accessor: index,
        role,
    };
    let accessor = doc
        .accessors()
        .nth(index)
        .ok_or_else(|| ctx.err("no such accessor"))?;
    let dims = dims_of(accessor.dimensions());
    if !dims_allowed.is_empty() && !dims_allowed.contains(&dims) {
        return Err(ctx.err(format!(
            "has {dims} components per element, expected one of {dims_allowed:?}"
        )));
    }
    let t = accessor.data_type();
    let normalized = t != DataType::F32 && (accessor.normalized() || force_normalized);
    let count = accessor.count();
    if accessor.view().is_none() && count > MAX_VIEWLESS_ELEMENTS {
        return Err(ctx.err(format!(
            "count {count} without a bufferView exceeds the limit of {MAX_VIEWLESS_ELEMENTS}"
        )));
    }
    if counted {
        let read = src.read.get().saturating_add(count.saturating_mul(dims));
        if read > MAX_READ_COMPONENTS {
            return Err(ctx.err(format!(
                "the file's accessor reads exceed {MAX_READ_COMPONENTS} values"
            )));
        }
        src.read.set(read);
    }
    let mut data = Vec::new();
    match accessor.view() {
        Some(view) => ctx.read_strided(
            &view,
            accessor.offset(),
            count,
            dims,
            t,
            normalized,
            &mut data,
        )?,
        None => data = vec![0.0; count * dims],
    }
    if let Some(sparse) = accessor.sparse() {
        apply_sparse(&ctx, &sparse, count, dims, t, normalized, &mut data)?;
    }
    Ok(Values { dims, data })
}

fn apply_sparse(
    ctx: &Ctx,
    sparse: &gltf::accessor::sparse::Sparse,
    count: usize,
    dims: usize,
    t: DataType,
    normalized: bool,
    data: &mut [f64],
) -> Result<(), RigError> {
    use gltf::accessor::sparse::IndexType;
    let n = sparse.count();
    if n > count {
        return Err(ctx.err(format!(
            "sparse.count {n} exceeds the accessor count {count}"
        )));
    }
    let indices = sparse.indices();
    let itype = match indices.index_type() {
        IndexType::U8 => DataType::U8,
        IndexType::U16 => DataType::U16,
        IndexType::U32 => DataType::U32,
    };
    let mut idx = Vec::new();
    ctx.read_strided(
        &indices.view(),
        indices.offset(),
        n,
        1,
        itype,
        false,
        &mut idx,
    )?;
    let values = sparse.values();
    let mut vals = Vec::new();
    ctx.read_strided(
        &values.view(),
        values.offset(),
        n,
        dims,
        t,
        normalized,
        &mut vals,
    )?;
    let mut previous: Option<usize> = None;
    for (k, &i) in idx.iter().enumerate() {
        let i = i as usize;
        if i >= count || previous.is_some_and(|p| i <= p) {
            return Err(ctx.err(format!(
                "sparse.indices[{k}] = {i} is out of range or not strictly increasing"
            )));
        }
        previous = Some(i);
        data[i * dims..(i + 1) * dims].copy_from_slice(&vals[k * dims..(k + 1) * dims]);
    }
    Ok(())
}

/// Reads an accessor of non-negative integers (indices, JOINTS_n), checking that every value
/// is below `bound`.
pub fn read_indices(
    src: &Source,
    doc: &gltf::Document,
    index: usize,
    role: &str,
    dims_allowed: &[usize],
    bound: u64,
) -> Result<(usize, Vec<u32>), RigError> {
    let refused = match doc.accessors().nth(index) {
        Some(a) if a.data_type() == DataType::F32 => Some("holds floats"),
        // glTF 2.0 (Meshes): indices and joints are never normalized; read as
        // fractions, every joint index of a u16 accessor below 65535 became joint 0.
        Some(a) if a.normalized() => Some("is normalized"),
        _ => None,
    };
    if let Some(what) = refused {
        return Err(RigError::Accessor {
            file: src.file.to_path_buf(),
            accessor: index,
            role: role.to_string(),
            message: format!("{what} where integers are required"),
        });
    }
    let values = read(src, doc, index, role, dims_allowed, false)?;
    let mut out = Vec::with_capacity(values.data.len());
    for (k, &v) in values.data.iter().enumerate() {
        if v < 0.0 || v as u64 >= bound {
            return Err(RigError::Accessor {
                file: src.file.to_path_buf(),
                accessor: index,
                role: role.to_string(),
                message: format!(
                    "element {} has value {} (must be below {})",
                    k / values.dims,
                    v,
                    bound
                ),
            });
        }
        out.push(v as u32);
    }
    Ok((values.dims, out))
}
