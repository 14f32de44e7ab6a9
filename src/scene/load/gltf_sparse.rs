//! Sparse accessors checked before the `gltf` crate reads them: an accessor whose elements are
//! its buffer view's (or zeros, without one) with `sparse.count` of them replaced, element
//! `indices[k]` by `values[k]`.
//!
//! The crate's reader slices `count − 1` strides past the start of each array and skips a
//! replacement whose index is out of order, so here: `1 ≤ sparse.count ≤ count`, the indices'
//! and the values' bytes inside their buffer views, and the indices strictly increasing and
//! below `count` (as the specification asks).

use gltf::accessor::sparse::IndexType;

/// Checks `a`'s sparse part; `view_bytes` gives a buffer view's bytes (or why it has none).
pub fn check_sparse<'b>(
    a: &gltf::Accessor,
    sparse: &gltf::accessor::sparse::Sparse,
    view_bytes: impl Fn(&gltf::buffer::View) -> Result<&'b [u8], String>,
    name: &str,
) -> Result<(), String> {
    let n = sparse.count();
    if n == 0 || n > a.count() {
        return Err(format!("{name}: sparse.count {n} is not in 1..={}", a.count()));
    }
    let (indices, values) = (sparse.indices(), sparse.values());
    let index_size = indices.index_type().size();
    let index_view = indices.view();
    let index_bytes =
        span(view_bytes(&index_view)?, indices.offset(), index_view.stride().unwrap_or(index_size), index_size, n)
            .ok_or_else(|| {
                format!("{name}: sparse.indices: {n} indices do not fit in buffer view {}", index_view.index())
            })?;
    let value_view = values.view();
    span(view_bytes(&value_view)?, values.offset(), value_view.stride().unwrap_or(a.size()), a.size(), n)
        .ok_or_else(|| format!("{name}: sparse.values: {n} values do not fit in buffer view {}", value_view.index()))?;
    let stride = index_view.stride().unwrap_or(index_size);
    let mut previous: Option<u64> = None;
    for k in 0..n {
        let b = &index_bytes[k * stride..];
        let i = match indices.index_type() {
            IndexType::U8 => u64::from(b[0]),
            IndexType::U16 => u64::from(u16::from_le_bytes([b[0], b[1]])),
            IndexType::U32 => u64::from(u32::from_le_bytes([b[0], b[1], b[2], b[3]])),
        };
        if i >= a.count() as u64 || previous.is_some_and(|p| i <= p) {
            return Err(format!(
                "{name}: sparse index {k} is {i}: the indices must increase strictly and stay below {}",
                a.count()
            ));
        }
        previous = Some(i);
    }
    Ok(())
}

/// The bytes of `n` elements of `size` bytes, `stride` apart from `offset`, if they fit.
fn span(bytes: &[u8], offset: usize, stride: usize, size: usize, n: usize) -> Option<&[u8]> {
    if stride < size {
        return None;
    }
    let end = (n - 1).checked_mul(stride)?.checked_add(size)?.checked_add(offset)?;
    bytes.get(offset..end)
}
