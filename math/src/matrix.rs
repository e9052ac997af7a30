//! Reading and writing the pushed matrix: 16 float32 values in the application's storage order
//! on one side, the clip-space transform `M` in f64 on the other.
//!
//! `M` is what the vertex shader multiplies the position with (`clip = M * v`), written by rows
//! r0..r3 as in `DESIGN.md` section 1: r2 is the depth row, r3 the w row. Which storage order a
//! push-constant member has (column-major, the GLSL default, or row-major, HLSL's and
//! `layout(row_major)`'s) is decided by the shader analysis; this module only applies it.
//!
//! Reading is exact (every f32 is an f64). Writing rounds every entry once, to nearest, which
//! is the single rounding `DESIGN.md` section 1 asks of the rewrite ("computed in f64 and
//! rounded once to f32").

use glam::{DMat4, DVec4};

/// How 16 consecutive float32 values hold the matrix `M` of `clip = M * v`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Storage {
    /// `values[4 * column + row]` is `M[row][column]` (GLSL's default, glam's `to_cols_array`).
    ColumnMajor,
    /// `values[4 * row + column]` is `M[row][column]` (HLSL `row_major`, GLSL
    /// `layout(row_major)`).
    RowMajor,
}

/// Reads 16 float32 values stored in `storage` order as the clip-space transform `M`, exactly.
#[must_use]
pub fn read_clip_transform(values: &[f32; 16], storage: Storage) -> DMat4 {
    let widened = values.map(f64::from);
    let as_columns = DMat4::from_cols_array(&widened);
    match storage {
        Storage::ColumnMajor => as_columns,
        // The same 16 numbers read as columns are the rows of M.
        Storage::RowMajor => as_columns.transpose(),
    }
}

/// Writes `m` as 16 float32 values in `storage` order, each entry rounded once to nearest.
///
/// An entry beyond the float32 range becomes an infinity and NaN stays NaN: callers that write
/// back a rewritten matrix get one from [`crate::rewrite`](fn@crate::rewrite), which only returns matrices whose
/// entries fit.
#[must_use]
pub fn write_clip_transform(m: &DMat4, storage: Storage) -> [f32; 16] {
    let stored = match storage {
        Storage::ColumnMajor => *m,
        Storage::RowMajor => m.transpose(),
    };
    // `as` rounds an f64 to the nearest f32 (ties to even).
    stored.to_cols_array().map(|entry| entry as f32)
}

/// Builds `M` from its rows r0..r3.
#[must_use]
pub fn from_rows(rows: [DVec4; 4]) -> DMat4 {
    DMat4::from_cols(rows[0], rows[1], rows[2], rows[3]).transpose()
}

/// `e3 = (0, 0, 0, 1)`: the w row of an affine transform, and the constant term of a depth row.
pub const E3: DVec4 = DVec4::W;

#[cfg(test)]
mod tests {
    use super::*;

    fn counting() -> [f32; 16] {
        std::array::from_fn(|i| i as f32)
    }

    #[test]
    fn column_major_index_is_column_times_four_plus_row() {
        let m = read_clip_transform(&counting(), Storage::ColumnMajor);
        assert_eq!(m.row(2), DVec4::new(2.0, 6.0, 10.0, 14.0));
        assert_eq!(m.row(3), DVec4::new(3.0, 7.0, 11.0, 15.0));
    }

    #[test]
    fn row_major_index_is_row_times_four_plus_column() {
        let m = read_clip_transform(&counting(), Storage::RowMajor);
        assert_eq!(m.row(2), DVec4::new(8.0, 9.0, 10.0, 11.0));
        assert_eq!(m.row(3), DVec4::new(12.0, 13.0, 14.0, 15.0));
    }

    #[test]
    fn write_inverts_read_in_both_orders() {
        let values: [f32; 16] = std::array::from_fn(|i| (i as f32 + 0.1) * 1.37e-3);
        for storage in [Storage::ColumnMajor, Storage::RowMajor] {
            let m = read_clip_transform(&values, storage);
            assert_eq!(write_clip_transform(&m, storage), values);
        }
    }

    #[test]
    fn write_rounds_once_to_nearest() {
        let third = 1.0 / 3.0;
        let m = from_rows([DVec4::splat(third); 4]);
        let written = write_clip_transform(&m, Storage::ColumnMajor);
        assert!(written.iter().all(|&x| x == (1.0f32 / 3.0)));
    }

    #[test]
    fn from_rows_puts_rows_in_place() {
        let rows = [DVec4::X, DVec4::Y * 2.0, DVec4::new(0.0, 0.0, 3.0, 4.0), E3];
        let m = from_rows(rows);
        for (index, row) in rows.iter().enumerate() {
            assert_eq!(m.row(index), *row);
        }
    }
}
