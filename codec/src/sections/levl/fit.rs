//! A subdivision fit's residual section (SPEC.md 10.4): the finest level's LEVL payload
//! of transform 9, the finest values against the control mesh's integer refinement
//! (`transform::fit`).

use crate::entropy::{Decoder, Encoder, IntModel};
use crate::error::{Error, Result};

/// The mode byte that opens the finest level's section of a fit (SPEC.md 10.4).
pub const RESIDUAL_MODE: u8 = 3;

/// Distance classes of a prediction from the nearest rounding boundary (SPEC.md 10.4).
const BUCKETS: usize = 8;

/// A predicted value `p` at `bits` extra bits: the rounded prediction, the sign that
/// points from it towards the nearer rounding boundary, and the class of the distance
/// to that boundary, in 256ths of a unit (SPEC.md 10.4).
#[inline]
fn predict(p: i64, bits: u8) -> (i64, i64, usize) {
    if bits == 0 {
        return (p, 1, 0);
    }
    let one = 1i64 << bits;
    let t = p + (one >> 1);
    let q = t >> bits;
    let u = t - (q << bits);
    let (sign, d) = if u < one >> 1 {
        (-1, u)
    } else {
        (1, one - 1 - u)
    };
    let d256 = if bits >= 8 {
        d >> (bits - 8)
    } else {
        d << (8 - bits)
    };
    let class = (64 - d256.leading_zeros()) as usize;
    (q, sign, class.min(BUCKETS - 1))
}

/// Codes the finest values `fine` against the integer subdivision `pred` (both per
/// axis, `bits` extra bits in `pred`): the section of SPEC.md 10.4.
pub fn encode_residuals(pred: &[Vec<i64>; 3], fine: &[Vec<i64>; 3], bits: u8) -> Vec<u8> {
    let mut enc = Encoder::new();
    let mut models: Vec<IntModel> = (0..3 * BUCKETS).map(|_| IntModel::new()).collect();
    for i in 0..fine[0].len() {
        for k in 0..3 {
            let (q, sign, class) = predict(pred[k][i], bits);
            enc.int(&mut models[k * BUCKETS + class], sign * (fine[k][i] - q));
        }
    }
    let mut out = vec![RESIDUAL_MODE];
    out.extend(enc.finish());
    out
}

/// Decodes what [`encode_residuals`] wrote: `x` holds the subdivision at `bits` extra
/// bits and gets the finest values, each checked against `bound`.
pub fn decode_residuals(payload: &[u8], x: &mut [Vec<i64>; 3], bits: u8, bound: i64) -> Result<()> {
    let n = x[0].len();
    // Density bound (SPEC.md 10.4): a vertex's three residuals cost over 1/2053 byte.
    if n as u64 > 2560 * (payload.len() as u64 + 8) {
        return Err(Error::corrupt(
            "LEVL",
            format!(
                "{} bytes cannot hold {} vertices' residuals",
                payload.len(),
                n
            ),
        ));
    }
    let payload = match payload.split_first() {
        Some((&RESIDUAL_MODE, rest)) => rest,
        Some((m, _)) => {
            return Err(Error::corrupt(
                "LEVL",
                format!("level mode {m} in a fit's residual section"),
            ))
        }
        None => return Err(Error::corrupt("LEVL", "empty residual section")),
    };
    let mut dec = Decoder::new(payload, "LEVL")?;
    let mut models: Vec<IntModel> = (0..3 * BUCKETS).map(|_| IntModel::new()).collect();
    for i in 0..n {
        for k in 0..3 {
            let (q, sign, class) = predict(x[k][i], bits);
            let r = dec.int(&mut models[k * BUCKETS + class])?;
            x[k][i] = q
                .checked_add(sign * r)
                .filter(|v| v.abs() <= bound)
                .ok_or_else(|| Error::corrupt("LEVL", "reconstructed coordinate out of range"))?;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn values(n: usize, seed: u64) -> Vec<i64> {
        crate::topology::fixtures::pseudo(seed, n, 21)
    }

    #[test]
    fn predictions_point_towards_the_nearer_rounding_boundary() {
        // B = 8: 1.0 is far from a boundary, 1.49 and 1.51 near 1.5 on either side.
        assert_eq!(predict(256, 8), (1, 1, 7));
        assert_eq!(predict(381, 8), (1, 1, 2));
        assert_eq!(predict(386, 8), (2, -1, 2));
        assert_eq!(predict(384, 8), (2, -1, 0));
        assert_eq!(predict(-386, 8), (-2, 1, 1));
        // Other precisions measure the distance in 256ths too.
        assert_eq!(predict(94, 6), (1, 1, 3));
        assert_eq!(predict(376, 8), (1, 1, 3));
        assert_eq!(predict(7, 0), (7, 1, 0));
    }

    #[test]
    fn residuals_round_trip() {
        let pred: [Vec<i64>; 3] = std::array::from_fn(|k| values(500, 7 + k as u64));
        let fine: [Vec<i64>; 3] = std::array::from_fn(|k| {
            pred[k]
                .iter()
                .zip(values(500, 20 + k as u64))
                .map(|(&p, n)| ((p + 128) >> 8) + n % 5)
                .collect()
        });
        let bytes = encode_residuals(&pred, &fine, 8);
        let mut x = pred.clone();
        decode_residuals(&bytes, &mut x, 8, 1 << 44).unwrap();
        assert_eq!(x, fine);
    }
}
