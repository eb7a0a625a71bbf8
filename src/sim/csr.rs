//! Compressed rows: a stable counting sort of `(row, value)` pairs into
//! rows, for keys that are small integers (particles, elements, tiles,
//! colours). O(pairs + rows), each row's values in the order given.

/// Compressed rows of `(row, value)` pairs over `rows` rows: the offsets
/// (row r is `values[offsets[r]..offsets[r + 1]]`) and the values, each
/// row's in the order given.
pub(crate) fn csr<T: Copy + Default>(rows: usize, pairs: impl Iterator<Item = (u32, T)> + Clone) -> (Vec<u32>, Vec<T>) {
    let mut offsets = vec![0u32; rows + 1];
    for (row, _) in pairs.clone() {
        offsets[row as usize + 1] += 1;
    }
    for r in 0..rows {
        offsets[r + 1] += offsets[r];
    }
    let mut fill = offsets.clone();
    let mut values = vec![T::default(); offsets[rows] as usize];
    for (row, value) in pairs {
        values[fill[row as usize] as usize] = value;
        fill[row as usize] += 1;
    }
    (offsets, values)
}
