//! Binary floats exactly (SPEC.md 3, kind 1, and 3.2): decimal text as the floats it
//! denotes, one grid where it holds every value, else the grid of the largest values'
//! last bit with the values' float bits.

use super::{range_error, Decimal, FloatWidth, Integers, Quantization, RawCoords};
use crate::mesh::{COORD_BITS, MAX_COORD};
use crate::error::Result;

/// A decimal number's digits without leading or trailing zeros and its power of ten:
/// value = (-1)^neg * digits * 10^exp; `None` with more than 19 significant digits or
/// text that is no number. Zero is (neg, 0, 0).
pub(super) fn decimal_key(text: &str) -> Option<(bool, u64, i32)> {
    let (neg, body) = match text.as_bytes().first()? {
        b'-' => (true, &text[1..]),
        b'+' => (false, &text[1..]),
        _ => (false, text),
    };
    let (mant, exp) = match body.find(['e', 'E']) {
        Some(i) => (&body[..i], body[i + 1..].parse::<i32>().ok()?),
        None => (body, 0),
    };
    let (int, frac) = mant.split_once('.').unwrap_or((mant, ""));
    let all = int.bytes().chain(frac.bytes());
    let (mut digits, mut n, mut exp) = (0u64, 0usize, exp.checked_sub(frac.len() as i32)?);
    let mut trailing = 0i32;
    for c in all {
        if !c.is_ascii_digit() {
            return None;
        }
        let d = (c - b'0') as u64;
        if digits == 0 && d == 0 {
            continue;
        }
        if d == 0 {
            trailing += 1;
            continue;
        }
        for _ in 0..trailing {
            digits = digits.checked_mul(10)?;
            n += 1;
        }
        trailing = 0;
        digits = digits.checked_mul(10)?.checked_add(d)?;
        n += 1;
        if n > 19 {
            return None;
        }
    }
    if int.is_empty() && frac.is_empty() {
        return None;
    }
    if digits == 0 {
        return Some((neg, 0, 0));
    }
    exp = exp.checked_add(trailing)?;
    Some((neg, digits, exp))
}

/// The binary32 whose shortest text is `token` (the same digits and power of ten, its
/// form aside: `0.5`, `5e-1` and `0.50` are all binary32 0.5's), if any.
pub(crate) fn token_f32(token: &str) -> Option<f32> {
    let x: f32 = token.parse().ok().filter(|x: &f32| x.is_finite())?;
    let key = decimal_key(token)?;
    (decimal_key(&format!("{x:e}")) == Some(key)).then_some(x)
}

/// The binary32 whose shortest text is the decimal `d`, if any.
pub(crate) fn shortest_f32(d: Decimal) -> Option<f32> {
    token_f32(&format!("{}e-{}", d.mantissa, d.decimals))
}

/// The binary64 nearest to the decimal `d` (a correctly rounded conversion).
pub(crate) fn nearest_f64(d: Decimal) -> f64 {
    format!("{}e-{}", d.mantissa, d.decimals)
        .parse()
        .unwrap_or_else(|_| d.to_f64())
}

/// Decimal text whose grid the codec cannot hold, as the binary floats it denotes:
/// binary32 when every number is a binary32's shortest text, else the nearest binary64.
pub(super) fn decimals_as_floats(v: &[[Decimal; 3]]) -> RawCoords {
    let f32s: Option<Vec<[f32; 3]>> = v
        .iter()
        .map(|p| {
            Some([
                shortest_f32(p[0])?,
                shortest_f32(p[1])?,
                shortest_f32(p[2])?,
            ])
        })
        .collect();
    match f32s {
        Some(f) => RawCoords::F32(f),
        None => RawCoords::F64(v.iter().map(|p| p.map(nearest_f64)).collect()),
    }
}


/// Exact binary floats: on the grid 2^e that holds every value (SPEC.md 3, kind 1) when
/// its integers fit the codec's range, no value is negative zero, and (binary32) it is
/// no finer than the grid of the largest values' last mantissa bit; else on that grid,
/// the values kept beside the integers for the bits below it (3.2).
pub(super) fn exact_floats(bits: Vec<[u64; 3]>, width: FloatWidth) -> Integers {
    let split = |b: u64| match width {
        FloatWidth::F32 => split_f32(f32::from_bits(b as u32)),
        FloatWidth::F64 => split_f64(f64::from_bits(b)),
    };
    let negative_zero = 1u64 << (width.bits() - 1);
    let e = fine_grid(&bits, width);
    // binary32: the grid of the largest values' last bit unless a coarser one holds
    // every value (the bits below it are the smaller values' own, coded raw rather than
    // through the levels, where the larger values' zero bits would cost as much);
    // binary64: one grid wherever it fits (the raw bits would be the 53-bit mantissas').
    let coarse = |emin: i32| width == FloatWidth::F64 || emin >= e;
    let emin = bits
        .iter()
        .flatten()
        .map(|&b| split(b))
        .filter(|p| p.1 != 0)
        .map(|p| p.2)
        .min()
        .unwrap_or(0);
    if coarse(emin) && !bits.iter().flatten().any(|&b| b == negative_zero) {
        if let Ok((p, q)) = exact_float(
            bits.iter().flat_map(|p| p.iter().map(move |&b| split(b))),
            bits.len(),
            width,
        ) {
            return (p, q, Vec::new());
        }
    }
    let positions = bits
        .iter()
        .map(|p| p.map(|b| grid_integer(b, width, e)))
        .collect();
    (positions, Quantization::Float { width, exponent: e }, bits)
}

/// A normal float's sign, mantissa with its leading one (`precision` bits) and the
/// exponent of its last bit: `value = (-1)^sign * m * 2^x`; `None` for zero, subnormals
/// and non-finite values.
pub(crate) fn normal_parts(bits: u64, width: FloatWidth) -> Option<(bool, u64, i32)> {
    let p = width.precision();
    let w = width.bits();
    let field = (bits >> (p - 1)) & ((1 << (w - p)) - 1);
    if field == 0 || field == (1 << (w - p)) - 1 {
        return None;
    }
    let m = bits & ((1 << (p - 1)) - 1) | 1 << (p - 1);
    Some((bits >> (w - 1) & 1 == 1, m, field as i32 - width.bias()))
}

/// The grid of 3.2: the exponent of the last mantissa bit of the largest values, raised
/// so that every integer fits the codec's range (binary64: by 9 bits).
pub(super) fn fine_grid(bits: &[[u64; 3]], width: FloatWidth) -> i32 {
    let top = bits
        .iter()
        .flatten()
        .filter_map(|&b| normal_parts(b, width))
        .map(|(_, _, x)| x)
        .max()
        .unwrap_or(0);
    top + (width.precision() as i32 - COORD_BITS as i32).max(0)
}

/// A float's integer on the grid 2^e (SPEC.md 3.2): its value over 2^e truncated toward
/// zero when its mantissa reaches the grid by fewer than its precision bits, else 0
/// (also for zero and subnormals).
pub(crate) fn grid_integer(bits: u64, width: FloatWidth, e: i32) -> i64 {
    let Some((neg, m, x)) = normal_parts(bits, width) else {
        return 0;
    };
    let p = width.precision() as i32;
    let n = if x >= e {
        // At most COORD_BITS bits when e is the grid of fine_grid.
        m.checked_shl((x - e) as u32).filter(|&v| v <= MAX_COORD as u64)
    } else if e - x < p {
        Some(m >> (e - x))
    } else {
        Some(0)
    };
    let n = n.unwrap_or(0) as i64;
    if neg {
        -n
    } else {
        n
    }
}


/// `(negative, odd mantissa, exponent)` with `|x| = mantissa * 2^exponent`; zero gives
/// mantissa 0.
pub(super) fn split_f32(x: f32) -> (bool, u64, i32) {
    let b = x.to_bits();
    let e = ((b >> 23) & 0xff) as i32;
    let m = (b & 0x7f_ffff) as u64;
    let (m, e) = if e == 0 {
        (m, -149)
    } else {
        (m | 0x80_0000, e - 150)
    };
    normalise(b >> 31 == 1, m, e)
}

pub(super) fn split_f64(x: f64) -> (bool, u64, i32) {
    let b = x.to_bits();
    let e = ((b >> 52) & 0x7ff) as i32;
    let m = b & 0xf_ffff_ffff_ffff;
    let (m, e) = if e == 0 {
        (m, -1074)
    } else {
        (m | 1 << 52, e - 1075)
    };
    normalise(b >> 63 == 1, m, e)
}

pub(super) fn normalise(neg: bool, m: u64, e: i32) -> (bool, u64, i32) {
    if m == 0 {
        return (false, 0, 0);
    }
    let tz = m.trailing_zeros();
    (neg, m >> tz, e + tz as i32)
}

pub(super) fn exact_float(
    parts: impl Iterator<Item = (bool, u64, i32)> + Clone,
    n: usize,
    width: FloatWidth,
) -> Result<(Vec<[i64; 3]>, Quantization)> {
    let emin = parts
        .clone()
        .filter(|p| p.1 != 0)
        .map(|p| p.2)
        .min()
        .unwrap_or(0);
    let mut out = vec![[0i64; 3]; n];
    for (idx, (neg, m, e)) in parts.enumerate() {
        if m == 0 {
            continue;
        }
        let shift = (e - emin) as u32;
        let bits = 64 - m.leading_zeros() + shift;
        if bits > COORD_BITS {
            return Err(range_error(format!(
                "vertex {} needs {bits} bits on the 2^{emin} grid that holds every value",
                idx / 3 + 1
            )));
        }
        let v = (m << shift) as i64;
        out[idx / 3][idx % 3] = if neg { -v } else { v };
    }
    Ok((
        out,
        Quantization::Float {
            width,
            exponent: emin,
        },
    ))
}

