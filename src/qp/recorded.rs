//! ECBF QPs as a filter posed them, kept to replay against any solver.
//!
//! A [`RecordedQp`] is one cycle's problem in input space (see
//! [`crate::qp::lexicographic`]): weights, nominal input, box, and the active rows with
//! their ECBF bounds and priority tiers. [`EcbfFilter::recorded_qp`](crate::filter::EcbfFilter::recorded_qp) takes it
//! after an update; [`write()`] and [`read()`] keep many in a compact binary file (rows
//! stored sparse: Tachyon 3's touch 1–6 of 17 inputs), so that a hard stretch of a run
//! can be committed as a test fixture and benchmarked solver against solver.
//!
//! Each row keeps its index in the filter's row layout, so a recording replays through a
//! QP laid out as the filter's was (same rows, same sparsity, warm start from cycle to
//! cycle), not only through a solver that takes the rows as they come.
//!
//! Format (little-endian): the magic `CBFQP\0v3`, `nu: u32`, `count: u32`, then per
//! problem `t: f64`, `layout_rows: u32`, `nu` × (`weight`, `u_ref`, `min`, `max`: f64),
//! `rows: u32`, and per row `index: u32`, `b: f64`, `tier: u8`, `nnz: u8`, `nnz` ×
//! (`column: u8`, `value: f64`).

use std::io::{self, Read, Write};

use super::lexicographic::TieredRow;

const MAGIC: &[u8; 8] = b"CBFQP\0v3";

/// One recorded problem.
#[derive(Debug, Clone, PartialEq)]
pub struct RecordedQp {
    /// When it was posed (simulation time) \[s\].
    pub t: f64,
    /// Rows in the filter's layout (active or not).
    pub layout_rows: usize,
    /// Input weights `w_j`.
    pub weights: Vec<f64>,
    /// The nominal input — with a cost matrix, the cost's centre (see
    /// [`crate::qp::metric`]).
    pub u_ref: Vec<f64>,
    /// A spec objective's cost matrix `P` (row-major, scaled to a largest diagonal entry of
    /// 1), which then replaces `weights` (all 1); `None` for input weights. Not in the
    /// binary format: [`write()`] refuses it.
    pub cost_matrix: Option<Vec<f64>>,
    /// Lower input limits.
    pub input_min: Vec<f64>,
    /// Upper input limits.
    pub input_max: Vec<f64>,
    /// The rows that took part.
    pub rows: Vec<RecordedRow>,
}

/// One active row: `a·u + b ≥ 0`, of priority tier `tier`.
#[derive(Debug, Clone, PartialEq)]
pub struct RecordedRow {
    /// The row's index in the filter's layout.
    pub index: usize,
    /// Input coefficients, dense (`nu` entries).
    pub a: Vec<f64>,
    /// The ECBF bound `L_f^r h + Σ k_i L_f^i h`.
    pub b: f64,
    /// Its priority tier (0 is met first).
    pub tier: u8,
}

impl RecordedQp {
    /// Inputs of the problem.
    pub fn nu(&self) -> usize {
        self.weights.len()
    }

    /// The rows as the lexicographic solver takes them, or `None` when `NU` is not
    /// [`RecordedQp::nu`].
    pub fn tiered_rows<const NU: usize>(&self) -> Option<Vec<TieredRow<NU>>> {
        (self.nu() == NU).then(|| {
            self.rows.iter().map(|r| TieredRow { a: std::array::from_fn(|j| r.a[j]), b: r.b, tier: r.tier }).collect()
        })
    }

    /// Input-sized vectors as arrays, or `None` when `NU` is not [`RecordedQp::nu`]:
    /// `(weights, u_ref, input_min, input_max)`.
    #[allow(clippy::type_complexity)]
    pub fn inputs<const NU: usize>(&self) -> Option<([f64; NU], [f64; NU], [f64; NU], [f64; NU])> {
        let array = |v: &[f64]| <[f64; NU]>::try_from(v).ok();
        Some((array(&self.weights)?, array(&self.u_ref)?, array(&self.input_min)?, array(&self.input_max)?))
    }
}

/// Write `problems` (all of the same `nu`, each row with at most 255 non-zeros).
///
/// # Errors
/// The writer's, or problems that break the format's limits (`InvalidInput`).
pub fn write(w: &mut impl Write, problems: &[RecordedQp]) -> io::Result<()> {
    let invalid = |what: &str| io::Error::new(io::ErrorKind::InvalidInput, what.to_string());
    let nu = problems.first().map_or(0, RecordedQp::nu);
    if nu > 255 || problems.iter().any(|p| p.nu() != nu) {
        return Err(invalid("every problem must have the same number of inputs, at most 255"));
    }
    if problems.iter().any(|p| p.cost_matrix.is_some()) {
        return Err(invalid("a problem with a cost matrix (a spec's objective) cannot be written in this format"));
    }
    w.write_all(MAGIC)?;
    w.write_all(&(nu as u32).to_le_bytes())?;
    w.write_all(&u32::try_from(problems.len()).map_err(|_| invalid("too many problems"))?.to_le_bytes())?;
    for p in problems {
        w.write_all(&p.t.to_le_bytes())?;
        w.write_all(&u32::try_from(p.layout_rows).map_err(|_| invalid("too many rows"))?.to_le_bytes())?;
        for j in 0..nu {
            for v in [p.weights[j], p.u_ref[j], p.input_min[j], p.input_max[j]] {
                w.write_all(&v.to_le_bytes())?;
            }
        }
        w.write_all(&u32::try_from(p.rows.len()).map_err(|_| invalid("too many rows"))?.to_le_bytes())?;
        for r in &p.rows {
            if r.a.len() != nu {
                return Err(invalid("a row of another length"));
            }
            w.write_all(&u32::try_from(r.index).map_err(|_| invalid("row index too large"))?.to_le_bytes())?;
            w.write_all(&r.b.to_le_bytes())?;
            w.write_all(&[r.tier])?;
            let nnz = r.a.iter().filter(|v| **v != 0.0).count();
            w.write_all(&[nnz as u8])?;
            for (j, v) in r.a.iter().enumerate().filter(|(_, v)| **v != 0.0) {
                w.write_all(&[j as u8])?;
                w.write_all(&v.to_le_bytes())?;
            }
        }
    }
    Ok(())
}

/// Read problems written by [`write()`].
///
/// # Errors
/// The reader's, or data that is not this format (`InvalidData`).
pub fn read(r: &mut impl Read) -> io::Result<Vec<RecordedQp>> {
    let invalid = |what: &str| io::Error::new(io::ErrorKind::InvalidData, what.to_string());
    let mut magic = [0u8; 8];
    r.read_exact(&mut magic)?;
    if &magic != MAGIC {
        return Err(invalid("not a recorded-QP file (bad magic)"));
    }
    let nu = read_u32(r)? as usize;
    let count = read_u32(r)? as usize;
    // Grown as read: a corrupt count cannot ask for gigabytes up front.
    let mut problems = Vec::new();
    for _ in 0..count {
        let t = read_f64(r)?;
        let layout_rows = read_u32(r)? as usize;
        let (mut weights, mut u_ref, mut input_min, mut input_max) = (vec![], vec![], vec![], vec![]);
        for _ in 0..nu {
            weights.push(read_f64(r)?);
            u_ref.push(read_f64(r)?);
            input_min.push(read_f64(r)?);
            input_max.push(read_f64(r)?);
        }
        let rows = read_u32(r)? as usize;
        let mut recorded_rows = Vec::new();
        for _ in 0..rows {
            let index = read_u32(r)? as usize;
            let b = read_f64(r)?;
            let mut tier = [0u8];
            r.read_exact(&mut tier)?;
            let tier = tier[0];
            let mut a = vec![0.0; nu];
            for _ in 0..read_u8(r)? {
                let column = read_u8(r)? as usize;
                *a.get_mut(column).ok_or_else(|| invalid("column beyond nu"))? = read_f64(r)?;
            }
            if index >= layout_rows {
                return Err(invalid("row index beyond the layout"));
            }
            recorded_rows.push(RecordedRow { index, a, b, tier });
        }
        problems.push(RecordedQp {
            t,
            layout_rows,
            weights,
            u_ref,
            cost_matrix: None,
            input_min,
            input_max,
            rows: recorded_rows,
        });
    }
    Ok(problems)
}

fn read_u8(r: &mut impl Read) -> io::Result<u8> {
    let mut b = [0u8; 1];
    r.read_exact(&mut b)?;
    Ok(b[0])
}

fn read_u32(r: &mut impl Read) -> io::Result<u32> {
    let mut b = [0u8; 4];
    r.read_exact(&mut b)?;
    Ok(u32::from_le_bytes(b))
}

fn read_f64(r: &mut impl Read) -> io::Result<f64> {
    let mut b = [0u8; 8];
    r.read_exact(&mut b)?;
    Ok(f64::from_le_bytes(b))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_written_file_reads_back_bit_for_bit_and_a_foreign_one_is_refused() {
        let problem = RecordedQp {
            t: 25.1,
            layout_rows: 269,
            weights: vec![1.0, 2.0, 0.5],
            u_ref: vec![0.1, -3.0, f64::MIN_POSITIVE],
            cost_matrix: None,
            input_min: vec![-1.0, -2.0, -3.0],
            input_max: vec![1.0, 2.0, 3.0],
            rows: vec![
                RecordedRow { index: 3, a: vec![0.0, -1.5, 1e-300], b: 1300.25, tier: 0 },
                RecordedRow { index: 268, a: vec![0.0; 3], b: -1.0, tier: 3 },
            ],
        };
        let mut bytes = Vec::new();
        write(&mut bytes, &[problem.clone(), problem.clone()]).unwrap();
        assert_eq!(read(&mut bytes.as_slice()).unwrap(), vec![problem.clone(), problem]);
        bytes[0] = b'X';
        assert_eq!(read(&mut bytes.as_slice()).unwrap_err().kind(), io::ErrorKind::InvalidData);
        assert!(read(&mut &bytes[..20]).is_err(), "a truncated file is an error");
    }
}
