//! The one compressed-sparse-column matrix handed to OSQP (by the filter and by the
//! systems' MPCs): its pattern laid out
//! once, its values rewritten in place every cycle, lent to OSQP without a copy.

use std::borrow::Cow;

use osqp::CscMatrix;

/// A `rows × cols` matrix in column-major sparse storage. The pattern (`indptr`,
/// `indices`) is fixed when it is built; `data` is the caller's to rewrite.
#[derive(Debug, Clone, PartialEq)]
pub struct Csc {
    /// Number of rows.
    pub rows: usize,
    /// Number of columns.
    pub cols: usize,
    /// Where each column's entries start in `indices` and `data` (`cols + 1` offsets).
    pub indptr: Vec<usize>,
    /// Each entry's row, column by column.
    pub indices: Vec<usize>,
    /// Each entry's value, in the order of `indices`.
    pub data: Vec<f64>,
}

impl Csc {
    /// The entries of `value(r, c)` where `keep(r, c)` holds (the structural pattern, even
    /// where the value is 0 now).
    pub fn new(
        rows: usize,
        cols: usize,
        keep: impl Fn(usize, usize) -> bool,
        value: impl Fn(usize, usize) -> f64,
    ) -> Self {
        let (mut indptr, mut indices, mut data) = (vec![0], Vec::new(), Vec::new());
        for c in 0..cols {
            for r in (0..rows).filter(|&r| keep(r, c)) {
                indices.push(r);
                data.push(value(r, c));
            }
            indptr.push(indices.len());
        }
        Self { rows, cols, indptr, indices, data }
    }

    /// The pattern of `entries` (`(row, col)`, any order, each once), values 0, and where
    /// each entry went: `slots[t]` is the place in `data` of `entries[t]`.
    pub fn from_entries(rows: usize, cols: usize, entries: &[(usize, usize)]) -> (Self, Vec<usize>) {
        let mut order: Vec<usize> = (0..entries.len()).collect();
        order.sort_unstable_by_key(|&t| (entries[t].1, entries[t].0));
        let mut slots = vec![0; entries.len()];
        let mut indptr = vec![0; cols + 1];
        let mut indices = Vec::with_capacity(entries.len());
        for (slot, &t) in order.iter().enumerate() {
            let (row, col) = entries[t];
            slots[t] = slot;
            indices.push(row);
            indptr[col + 1] = slot + 1;
        }
        for col in 0..cols {
            indptr[col + 1] = indptr[col + 1].max(indptr[col]);
        }
        let data = vec![0.0; indices.len()];
        (Self { rows, cols, indptr, indices, data }, slots)
    }

    /// The `n × n` identity.
    pub fn identity(n: usize) -> Self {
        Self { rows: n, cols: n, indptr: (0..=n).collect(), indices: (0..n).collect(), data: vec![1.0; n] }
    }

    /// A borrowed view for OSQP (no copy, no allocation).
    pub fn view(&self) -> CscMatrix<'_> {
        CscMatrix {
            nrows: self.rows,
            ncols: self.cols,
            indptr: Cow::Borrowed(&self.indptr),
            indices: Cow::Borrowed(&self.indices),
            data: Cow::Borrowed(&self.data),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::Csc;

    #[test]
    fn entries_given_in_any_order_land_column_major_and_say_where() {
        // [[1, 0, 2], [0, 0, 3]] given row by row; column 1 is empty.
        let entries = [(0, 0), (0, 2), (1, 2)];
        let (mut m, slots) = Csc::from_entries(2, 3, &entries);
        for (t, v) in [1.0, 2.0, 3.0].into_iter().enumerate() {
            m.data[slots[t]] = v;
        }
        let dense = Csc::new(
            2,
            3,
            |r, c| [[1.0, 0.0, 2.0], [0.0, 0.0, 3.0]][r][c] != 0.0,
            |r, c| [[1.0, 0.0, 2.0], [0.0, 0.0, 3.0]][r][c],
        );
        assert_eq!(m, dense);
        assert_eq!(m.indptr, vec![0, 1, 1, 3]);
    }
}
