//! Prediction phases (SPEC.md 10.6, 10.9): where a rounded prediction's unrounded value
//! lay. The predict-only transforms make them (`transform::cc`'s `Phaser`, the sqrt(2)
//! predictions); the LEVL modes 6, 7 and 9 model their values by them.

/// Per axis and detail, the phase of the detail's prediction (SPEC.md 10.6), and for a
/// Catmull-Clark level its fraction (10.9).
#[derive(Clone, Default)]
pub struct Phases {
    /// Bit 2 set when the remainder is negative, bits 0 and 1 its bin.
    pub codes: [Vec<u8>; 3],
    /// Where the unrounded prediction lies from the rounded one, in [`FRAC_DIV`]ths
    /// (rounded); empty where no level mode reads it (sqrt(2) levels).
    pub fracs: [Vec<i16>; 3],
}

/// A prediction's fraction (SPEC.md 10.9) is in 512ths.
pub const FRAC_DIV: i128 = 512;

/// The phase of a prediction `[n / d]` (9.1 rounding, `d > 0`) from its remainder
/// `r = n - d [n / d]` (so `-d / 2 <= r < d / 2`): the sign of `r`, and how many of
/// `d, 2d` are at most `6 |r|`.
#[inline]
pub fn phase(r: i128, d: i128) -> u8 {
    let (a, d) = (6 * r.unsigned_abs(), d.unsigned_abs());
    let bin = (a >= d) as u8 + (a >= 2 * d) as u8;
    ((r < 0) as u8) << 2 | bin
}

/// Test helper: the phase (SPEC.md 10.6) of an integer detail `d` whose unrounded
/// counterpart (the same analysis on floating point values) is `exact`: the sign of
/// `g = d - exact` and how many of 1/6, 2/6 are at most `|g|`; `None` too near a bin's
/// edge for floating point to tell.
#[cfg(test)]
pub(crate) fn expected_phase(d: i64, exact: f64) -> Option<u8> {
    let g = d as f64 - exact;
    let a = 6.0 * g.abs();
    if (a - 1.0).abs() < 1e-6 || (a - 2.0).abs() < 1e-6 {
        return None;
    }
    Some(((g < 0.0) as u8) << 2 | ((a >= 1.0) as u8 + (a >= 2.0) as u8))
}
