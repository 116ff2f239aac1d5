//! Checks of buffer views and accessors before the `gltf` crate reads them.
//!
//! The crate's readers trust the file: a count of 0, an offset near 2⁶⁴ or a
//! type they do not expect overflows, fails an assertion or reaches
//! `unreachable!`. Every view is checked against its buffer
//! ([`buffer_views`]) and every accessor the loader reads against its view and
//! its use ([`accessor`]), so that the readers only see what they handle;
//! [`read`] turns what they still refuse into an error.

use std::panic::{catch_unwind, AssertUnwindSafe};

use gltf::accessor::{DataType, Dimensions};

use super::GltfError;

/// The most elements an accessor may have: indices are `u32`.
pub const MAX_ACCESSOR_COUNT: usize = u32::MAX as usize;

/// The most elements an accessor without a buffer view (zeros, with sparse
/// values) may have: nothing in the file backs them, so nothing else bounds them.
pub const MAX_ZERO_FILLED_COUNT: usize = 1 << 24;

/// What an accessor is read as.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum Use {
    /// `POSITION`: `VEC3` of `FLOAT`.
    Position,
    /// `NORMAL`: `VEC3` of `FLOAT`.
    Normal,
    /// `TANGENT`: `VEC4` of `FLOAT`.
    Tangent,
    /// `TEXCOORD_0`: `VEC2` of `FLOAT`, `UNSIGNED_BYTE` or `UNSIGNED_SHORT`.
    TexCoord,
    /// Indices: `SCALAR` of `UNSIGNED_BYTE`, `UNSIGNED_SHORT` or `UNSIGNED_INT`.
    Index,
}

impl Use {
    /// The types and component types this use allows, and their description.
    fn allowed(self) -> (Dimensions, &'static [DataType], &'static str) {
        match self {
            Use::Position | Use::Normal => (Dimensions::Vec3, &[DataType::F32], "VEC3 of FLOAT"),
            Use::Tangent => (Dimensions::Vec4, &[DataType::F32], "VEC4 of FLOAT"),
            Use::TexCoord => (
                Dimensions::Vec2,
                &[DataType::F32, DataType::U8, DataType::U16],
                "VEC2 of FLOAT, UNSIGNED_BYTE or UNSIGNED_SHORT",
            ),
            Use::Index => (
                Dimensions::Scalar,
                &[DataType::U8, DataType::U16, DataType::U32],
                "SCALAR of UNSIGNED_BYTE, UNSIGNED_SHORT or UNSIGNED_INT",
            ),
        }
    }
}

/// glTF's name of a type.
fn type_name(dimensions: Dimensions) -> &'static str {
    match dimensions {
        Dimensions::Scalar => "SCALAR",
        Dimensions::Vec2 => "VEC2",
        Dimensions::Vec3 => "VEC3",
        Dimensions::Vec4 => "VEC4",
        Dimensions::Mat2 => "MAT2",
        Dimensions::Mat3 => "MAT3",
        Dimensions::Mat4 => "MAT4",
    }
}

/// glTF's name of a component type.
fn component_name(data_type: DataType) -> &'static str {
    match data_type {
        DataType::I8 => "BYTE",
        DataType::U8 => "UNSIGNED_BYTE",
        DataType::I16 => "SHORT",
        DataType::U16 => "UNSIGNED_SHORT",
        DataType::U32 => "UNSIGNED_INT",
        DataType::F32 => "FLOAT",
    }
}

/// Checks that every primitive's POSITION names an accessor of the file (the
/// `gltf` crate's validation indexes it unchecked, and panics).
pub fn position_indices(root: &gltf::json::Root) -> Result<(), GltfError> {
    use gltf::json::validation::Checked;
    let positions = Checked::Valid(gltf::json::mesh::Semantic::Positions);
    for (m, mesh) in root.meshes.iter().enumerate() {
        for (p, primitive) in mesh.primitives.iter().enumerate() {
            if let Some(index) = primitive.attributes.get(&positions) {
                if index.value() >= root.accessors.len() {
                    return Err(GltfError::DanglingIndex {
                        path: format!("meshes[{m}].primitives[{p}].attributes.POSITION"),
                        target: "accessors",
                        index: index.value(),
                        count: root.accessors.len(),
                    });
                }
            }
        }
    }
    Ok(())
}

/// Checks that every buffer view lies inside its buffer (the buffer's declared
/// `byteLength`; importing checks that the data is at least that long).
pub fn buffer_views(document: &gltf::Document) -> Result<(), GltfError> {
    for view in document.views() {
        let buffer = view.buffer();
        let start = view.offset() as u128;
        let end = start + view.length() as u128;
        if end > buffer.length() as u128 {
            return Err(GltfError::ViewOutOfBounds {
                path: format!("bufferViews[{}]", view.index()),
                buffer: buffer.index(),
                start,
                end,
                length: buffer.length(),
            });
        }
    }
    Ok(())
}

/// Checks an accessor used at `path` (`meshes[0].primitives[0].attributes.POSITION`)
/// as `usage`: its type and component type, its count, its elements (and sparse
/// indices and values) inside their views. Returns its count. Views are
/// checked against their buffers by [`buffer_views`].
pub fn accessor(
    accessor: &gltf::Accessor,
    path: &str,
    usage: Use,
    buffers: &[gltf::buffer::Data],
) -> Result<usize, GltfError> {
    let index = accessor.index();
    let (dimensions, data_types, expected) = usage.allowed();
    if accessor.dimensions() != dimensions || !data_types.contains(&accessor.data_type()) {
        let found = format!("{} of {}", type_name(accessor.dimensions()), component_name(accessor.data_type()));
        return Err(GltfError::AccessorType { path: path.to_owned(), accessor: index, found, expected });
    }
    let count = accessor.count();
    if count == 0 {
        return Err(GltfError::EmptyAccessor { path: path.to_owned(), accessor: index });
    }
    let limit = if accessor.view().is_some() { MAX_ACCESSOR_COUNT } else { MAX_ZERO_FILLED_COUNT };
    if count > limit {
        return Err(GltfError::AccessorTooLarge { path: path.to_owned(), accessor: index, count, limit });
    }
    let element = accessor.size();
    let sparse = accessor.sparse();
    match accessor.view() {
        Some(view) => elements_inside(path, index, "", &view, accessor.offset(), count, element)?,
        None if sparse.is_none() => {
            return Err(GltfError::AccessorWithoutData { path: path.to_owned(), accessor: index });
        }
        None => {}
    }
    if let Some(sparse) = sparse {
        let sparse_count = sparse.count();
        if sparse_count == 0 || sparse_count > count {
            return Err(GltfError::SparseCount { path: path.to_owned(), accessor: index, sparse: sparse_count, count });
        }
        let indices = sparse.indices();
        let index_size = indices.index_type().size();
        elements_inside(path, index, ".sparse.indices", &indices.view(), indices.offset(), sparse_count, index_size)?;
        let values = sparse.values();
        elements_inside(path, index, ".sparse.values", &values.view(), values.offset(), sparse_count, element)?;
        sparse_indices_increase(path, index, &indices, sparse_count, count, buffers)?;
    }
    Ok(count)
}

/// Checks that `count` elements of `element` bytes from `offset`, at the view's
/// stride (or packed), lie inside the view. `count` is at least 1.
fn elements_inside(
    path: &str,
    accessor: usize,
    part: &'static str,
    view: &gltf::buffer::View,
    offset: usize,
    count: usize,
    element: usize,
) -> Result<(), GltfError> {
    let stride = view.stride().unwrap_or(element);
    if stride < element {
        return Err(GltfError::AccessorStride {
            path: path.to_owned(),
            accessor,
            part,
            view: view.index(),
            stride,
            element,
        });
    }
    // In u128 nothing here overflows: each term is below 2⁶⁴.
    let start = offset as u128;
    let end = start + stride as u128 * (count as u128 - 1) + element as u128;
    if end > view.length() as u128 {
        return Err(GltfError::AccessorOutOfBounds {
            path: path.to_owned(),
            accessor,
            part,
            view: view.index(),
            start,
            end,
            length: view.length(),
        });
    }
    Ok(())
}

/// Checks that a sparse accessor's indices, inside their view (checked), increase
/// strictly and stay below the accessor's `count`.
fn sparse_indices_increase(
    path: &str,
    accessor: usize,
    indices: &gltf::accessor::sparse::Indices,
    sparse_count: usize,
    count: usize,
    buffers: &[gltf::buffer::Data],
) -> Result<(), GltfError> {
    let view = indices.view();
    let size = indices.index_type().size();
    let stride = view.stride().unwrap_or(size);
    let unreadable = || GltfError::UnreadableAccessor {
        path: path.to_owned(),
        accessor,
        reason: format!("bufferViews[{}] is not inside buffers[{}]'s data", view.index(), view.buffer().index()),
    };
    let data = buffers.get(view.buffer().index()).ok_or_else(unreadable)?;
    // The view lies inside the buffer and the indices inside the view: no sum here overflows.
    let first = view.offset() + indices.offset();
    let mut previous: Option<u64> = None;
    for at in 0..sparse_count {
        let start = first + at * stride;
        let bytes = data.0.get(start..start + size).ok_or_else(unreadable)?;
        let index = bytes.iter().rev().fold(0u64, |value, &byte| value << 8 | byte as u64);
        if index >= count as u64 || previous.is_some_and(|p| index <= p) {
            return Err(GltfError::SparseIndex { path: path.to_owned(), accessor, at, index, previous, count });
        }
        previous = Some(index);
    }
    Ok(())
}

/// Runs a reader of the accessor at `path` that [`accessor`] checked: a reader
/// that still finds no data, or panics, is an [`GltfError::UnreadableAccessor`].
/// The checks are the defence; this is the last line behind them.
pub fn read<T>(path: &str, accessor: usize, reader: impl FnOnce() -> Option<T>) -> Result<T, GltfError> {
    let unreadable = |reason: String| GltfError::UnreadableAccessor { path: path.to_owned(), accessor, reason };
    match catch_unwind(AssertUnwindSafe(reader)) {
        Ok(Some(value)) => Ok(value),
        Ok(None) => Err(unreadable("the reader found no data".to_owned())),
        Err(panic) => {
            let message = panic
                .downcast_ref::<&str>()
                .map(|s| (*s).to_owned())
                .or_else(|| panic.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "a panic".to_owned());
            Err(unreadable(format!("the reader panicked: {message}")))
        }
    }
}
