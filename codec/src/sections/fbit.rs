//! The FBIT section (SPEC.md 3.2): binary float positions finer than their grid. The
//! levels reconstruct each value's integer on the grid 2^e; this section holds what the
//! integer does not determine, per value: the mantissa bits below the grid, and for the
//! values whose integer is 0, whether they are +0 or else their bits whole.

use crate::error::{Error, Result};
use crate::quant::{grid_integer, normal_parts, FloatWidth};

/// Writes bits most significant first.
#[derive(Default)]
struct BitWriter {
    out: Vec<u8>,
    acc: u64,
    n: u32,
}

impl BitWriter {
    /// Appends the low `k` bits of `v` (`k <= 56`).
    fn put(&mut self, v: u64, k: u32) {
        debug_assert!(k <= 56);
        if k == 0 {
            return;
        }
        self.acc = self.acc << k | (v & ((1u64 << k) - 1));
        self.n += k;
        while self.n >= 8 {
            self.n -= 8;
            self.out.push((self.acc >> self.n) as u8);
        }
        self.acc &= (1u64 << self.n) - 1;
    }

    /// `k` bits of `v`, `k <= 64`.
    fn put_wide(&mut self, v: u64, k: u32) {
        if k > 32 {
            self.put(v >> 32, k - 32);
            self.put(v & 0xffff_ffff, 32);
        } else {
            self.put(v, k);
        }
    }

    /// The bytes, the last padded with zero bits.
    fn finish(mut self) -> Vec<u8> {
        if self.n > 0 {
            self.out.push((self.acc << (8 - self.n)) as u8);
        }
        self.out
    }
}

/// Reads what [`BitWriter`] wrote.
struct BitReader<'a> {
    data: &'a [u8],
    /// Bits read so far.
    pos: usize,
}

impl BitReader<'_> {
    /// The next `k` bits (`k <= 64`), or an error past the end.
    fn get(&mut self, k: u32) -> Result<u64> {
        let end = self.pos + k as usize;
        if end > self.data.len() * 8 {
            return Err(Error::corrupt("FBIT", "the section ends inside a value"));
        }
        let mut v = 0u64;
        for i in self.pos..end {
            v = v << 1 | (self.data[i / 8] >> (7 - i % 8) & 1) as u64;
        }
        self.pos = end;
        Ok(v)
    }
}

/// The FBIT payload of `floats` (each value's bits, in the decoder's vertex order) on
/// the grid 2^`e`.
pub(crate) fn encode(floats: impl Iterator<Item = [u64; 3]>, width: FloatWidth, e: i32) -> Vec<u8> {
    let p = width.precision();
    let mut w = BitWriter::default();
    for v in floats {
        for b in v {
            let n = grid_integer(b, width, e);
            if n == 0 {
                // +0, else the value whole.
                w.put((b != 0) as u64, 1);
                if b != 0 {
                    w.put_wide(b, width.bits());
                }
                continue;
            }
            let len = 64 - n.unsigned_abs().leading_zeros();
            if len < p {
                let k = p - len;
                let (_, m, _) = normal_parts(b, width).unwrap_or_default();
                w.put(m, k);
            }
        }
    }
    w.finish()
}

/// The values of the integers `positions` (the finest level's, in the decoder's order)
/// on the grid 2^`e`, with the bits of the FBIT `payload`.
pub(crate) fn decode(
    payload: &[u8],
    positions: &[[i64; 3]],
    width: FloatWidth,
    e: i32,
) -> Result<Vec<[u64; 3]>> {
    let mut r = BitReader {
        data: payload,
        pos: 0,
    };
    let mut out = Vec::with_capacity(positions.len());
    for p in positions {
        let mut v = [0u64; 3];
        for k in 0..3 {
            v[k] = value(&mut r, p[k], width, e)?;
        }
        out.push(v);
    }
    // Only the last byte's padding may follow, and it is zero.
    let used = r.pos.div_ceil(8);
    if used != payload.len() || r.get((used * 8 - r.pos) as u32)? != 0 {
        return Err(Error::corrupt(
            "FBIT",
            "bytes after the last value's bits, or padding bits set",
        ));
    }
    Ok(out)
}

/// One value from its integer `n` (SPEC.md 3.2).
fn value(r: &mut BitReader<'_>, n: i64, width: FloatWidth, e: i32) -> Result<u64> {
    let p = width.precision();
    let bad = |what: &str| Error::corrupt("FBIT", what.to_string());
    if n == 0 {
        if r.get(1)? == 0 {
            return Ok(0);
        }
        let b = r.get(width.bits())?;
        let w = width.bits();
        let all_ones = (1u64 << (w - p)) - 1;
        let finite = (b >> (p - 1)) & all_ones != all_ones;
        if !finite || b == 0 || grid_integer(b, width, e) != 0 {
            return Err(bad("a value written whole that is not one of the grid's zeros"));
        }
        return Ok(b);
    }
    let a = n.unsigned_abs();
    let len = 64 - a.leading_zeros();
    let (m, x) = if len >= p {
        let s = len - p;
        if a & ((1u64 << s) - 1) != 0 {
            return Err(bad("an integer that is no float on the grid"));
        }
        (a >> s, e as i64 + s as i64)
    } else {
        let k = p - len;
        (a << k | r.get(k)?, e as i64 - k as i64)
    };
    let field = x + width.bias() as i64;
    let max = (1i64 << (width.bits() - p)) - 2;
    if !(1..=max).contains(&field) {
        return Err(bad("a value outside the float's exponent range"));
    }
    let sign = ((n < 0) as u64) << (width.bits() - 1);
    Ok(sign | (field as u64) << (p - 1) | (m & ((1u64 << (p - 1)) - 1)))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn round_trip(values: &[f32]) {
        let bits: Vec<[u64; 3]> = values
            .chunks(3)
            .map(|c| std::array::from_fn(|k| c.get(k).copied().unwrap_or(0.0).to_bits() as u64))
            .collect();
        let e = bits
            .iter()
            .flatten()
            .filter_map(|&b| normal_parts(b, FloatWidth::F32))
            .map(|p| p.2)
            .max()
            .unwrap_or(0);
        let pos: Vec<[i64; 3]> = bits
            .iter()
            .map(|p| p.map(|b| grid_integer(b, FloatWidth::F32, e)))
            .collect();
        let payload = encode(bits.iter().copied(), FloatWidth::F32, e);
        let back = decode(&payload, &pos, FloatWidth::F32, e).unwrap();
        assert_eq!(back, bits);
        // One byte more, or a cut, is refused.
        let mut longer = payload.clone();
        longer.push(0);
        assert!(decode(&longer, &pos, FloatWidth::F32, e).is_err());
        if !payload.is_empty() {
            assert!(decode(&payload[..payload.len() - 1], &pos, FloatWidth::F32, e).is_err());
        }
    }

    #[test]
    fn floats_below_the_grid_come_back_bit_for_bit() {
        round_trip(&[
            1.5,
            -0.0,
            0.0,
            0.020000003,
            -2.3283064e-10,
            f32::MIN_POSITIVE,
            1e-45,
            -3.0e38,
            123.456,
            -0.1,
        ]);
        round_trip(&[0.0, -0.0, 0.0]);
    }
}
