//! From the numbers in a file to integer positions and back (SPEC.md 3).
//!
//! Two modes. *Exact* keeps the file's own values: decimal text on its decimal grid,
//! binary floats on the power-of-two grid that holds all of them. *Grid* (`--bits Q`)
//! quantises exactly as Draco does, in `f32`, so sizes compare 1:1 with Draco.

mod float;

pub(crate) use float::{grid_integer, normal_parts, token_f32};
use float::{decimals_as_floats, exact_floats, nearest_f64, shortest_f32};

use crate::error::{Error, Result};
use crate::mesh::{COORD_BITS, MAX_COORD};

/// A decimal number as written in a text file: `mantissa * 10^-decimals`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Decimal {
    /// The digits, as an integer, with the sign.
    pub mantissa: i64,
    /// How many digits stood after the decimal point (after applying any exponent).
    pub decimals: u8,
}

/// Most decimals a coordinate may have in exact mode (10^18 still fits `i64`).
pub const MAX_DECIMALS: u8 = 18;

const POW10: [i64; 19] = {
    let mut t = [1i64; 19];
    let mut i = 1;
    while i < 19 {
        t[i] = t[i - 1] * 10;
        i += 1;
    }
    t
};

impl Decimal {
    /// The integer `m` (no decimals).
    pub const fn integer(m: i64) -> Decimal {
        Decimal {
            mantissa: m,
            decimals: 0,
        }
    }

    /// Parses a decimal number the way text mesh formats write them: optional sign,
    /// digits with an optional point, optional exponent. NaN and infinities are refused.
    pub fn parse(token: &str) -> std::result::Result<Decimal, String> {
        Self::parse_kind(token).map_err(|(_, e)| e)
    }

    /// Like [`Decimal::parse`], also saying whether a failure is only that the number
    /// is too long or too large for exact mode (`true`): such a number still has a
    /// value as `f64`.
    pub fn parse_kind(token: &str) -> std::result::Result<Decimal, (bool, String)> {
        Self::parse_inner(token)
    }

    fn parse_inner(token: &str) -> std::result::Result<Decimal, (bool, String)> {
        let b = token.as_bytes();
        let mut i = 0;
        let neg = match b.first() {
            Some(b'-') => {
                i += 1;
                true
            }
            Some(b'+') => {
                i += 1;
                false
            }
            _ => false,
        };
        // (After every leading sign, without a lower-case copy: one allocation a
        // number was a fifth of reading a large OBJ.)
        let body = &b[b.iter().take_while(|&&c| c == b'+' || c == b'-').count()..];
        let named = |name: &[u8]| body.get(..3).is_some_and(|h| h.eq_ignore_ascii_case(name));
        if named(b"nan") || named(b"inf") {
            return Err((false, format!("'{token}' is not a finite number")));
        }
        let mut mant: i64 = 0;
        let mut digits = 0usize;
        let mut frac: i32 = 0;
        let mut seen_point = false;
        let mut overflow = false;
        while i < b.len() {
            match b[i] {
                c @ b'0'..=b'9' => {
                    digits += 1;
                    match mant
                        .checked_mul(10)
                        .and_then(|m| m.checked_add((c - b'0') as i64))
                    {
                        Some(m) if m <= POW10[18] => mant = m,
                        _ => overflow = true,
                    }
                    if seen_point {
                        frac += 1;
                    }
                }
                b'.' if !seen_point => seen_point = true,
                b'e' | b'E' => break,
                _ => return Err((false, format!("'{token}' is not a number"))),
            }
            i += 1;
        }
        if digits == 0 {
            return Err((false, format!("'{token}' is not a number")));
        }
        let mut exp: i32 = 0;
        if i < b.len() {
            let e = &token[i + 1..];
            exp = e
                .parse::<i32>()
                .ok()
                .filter(|e| e.abs() <= 400)
                .ok_or_else(|| (false, format!("'{token}' has a bad exponent")))?;
        }
        if overflow {
            return Err((
                true,
                format!("'{token}' has more than 18 significant digits, too many for exact mode"),
            ));
        }
        let mut dec = frac - exp;
        if dec < 0 {
            if mant != 0 {
                let scale = POW10.get((-dec) as usize).copied().unwrap_or(i64::MAX);
                mant = mant
                    .checked_mul(scale)
                    .filter(|m| *m <= POW10[18])
                    .ok_or_else(|| (true, format!("'{token}' is too large for exact mode")))?;
            }
            dec = 0;
        }
        if dec > MAX_DECIMALS as i32 {
            return Err((
                true,
                format!("'{token}' has {dec} decimals; exact mode supports at most {MAX_DECIMALS}"),
            ));
        }
        Ok(Decimal {
            mantissa: if neg { -mant } else { mant },
            decimals: dec as u8,
        })
    }

    /// The nearest `f64` (exact division of exactly representable values when the
    /// mantissa is below 2^53, so this equals a correctly rounded parse of the text).
    pub fn to_f64(self) -> f64 {
        self.mantissa as f64 / POW10[self.decimals as usize] as f64
    }
}

/// Coordinates as read from a file, before they become integers.
#[derive(Debug, Clone, PartialEq)]
pub enum RawCoords {
    /// Decimal text (also binary integer properties, with 0 decimals).
    Decimal(Vec<[Decimal; 3]>),
    /// Binary `f32`.
    F32(Vec<[f32; 3]>),
    /// Binary `f64`.
    F64(Vec<[f64; 3]>),
}

impl RawCoords {
    /// Number of vertices.
    pub fn len(&self) -> usize {
        match self {
            RawCoords::Decimal(v) => v.len(),
            RawCoords::F32(v) => v.len(),
            RawCoords::F64(v) => v.len(),
        }
    }

    /// Whether there are no vertices.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    fn to_f32(&self) -> Vec<[f32; 3]> {
        match self {
            RawCoords::Decimal(v) => v.iter().map(|p| p.map(|d| d.to_f64() as f32)).collect(),
            RawCoords::F32(v) => v.clone(),
            RawCoords::F64(v) => v.iter().map(|p| p.map(|x| x as f32)).collect(),
        }
    }
}

/// Collects text coordinates: exact decimals while every number allows it, else
/// (a number too long or too large for exact mode) the `f64` values, so that `--bits`
/// still works and exact mode fails with a message that suggests it.
#[derive(Debug, Default)]
pub struct TextCoords {
    exact: Vec<[Decimal; 3]>,
    inexact: Option<(Vec<[f64; 3]>, String)>,
    /// Once inexact: whether every number so far is the shortest text of a binary32
    /// (then the values are those binary32s).
    all_f32: bool,
}

impl TextCoords {
    /// Parses and appends one vertex.
    pub fn push(&mut self, t: [&str; 3]) -> std::result::Result<(), String> {
        if self.inexact.is_none() {
            let mut p = [Decimal {
                mantissa: 0,
                decimals: 0,
            }; 3];
            let mut bad = None;
            for k in 0..3 {
                match Decimal::parse_kind(t[k]) {
                    Ok(d) => p[k] = d,
                    Err((true, why)) => {
                        bad = Some(why);
                        break;
                    }
                    Err((false, why)) => return Err(why),
                }
            }
            match bad {
                None => {
                    self.exact.push(p);
                    return Ok(());
                }
                Some(why) => {
                    self.all_f32 = self
                        .exact
                        .iter()
                        .all(|p| p.iter().all(|&d| shortest_f32(d).is_some()));
                    let v = self
                        .exact
                        .drain(..)
                        .map(|p| p.map(nearest_f64))
                        .collect();
                    self.inexact = Some((v, why));
                }
            }
        }
        let mut p = [0f64; 3];
        for k in 0..3 {
            p[k] = t[k]
                .parse::<f64>()
                .ok()
                .filter(|x| x.is_finite())
                .ok_or_else(|| format!("'{}' is not a finite number", t[k]))?;
            self.all_f32 = self.all_f32 && token_f32(t[k]).is_some();
        }
        if let Some((v, _)) = &mut self.inexact {
            v.push(p);
        }
        Ok(())
    }

    /// Number of vertices so far.
    pub fn len(&self) -> usize {
        match &self.inexact {
            Some((v, _)) => v.len(),
            None => self.exact.len(),
        }
    }

    /// Whether no vertex was pushed.
    #[cfg(feature = "internals")]
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The coordinates, and why they are not exact decimals if they are not: then the
    /// binary32 values when every number is a binary32's shortest text, else the nearest
    /// binary64s.
    pub fn finish(self) -> (RawCoords, Option<String>) {
        match self.inexact {
            Some((v, why)) if self.all_f32 => (
                RawCoords::F32(v.iter().map(|p| p.map(|x| x as f32)).collect()),
                Some(why),
            ),
            Some((v, why)) => (RawCoords::F64(v), Some(why)),
            None => (RawCoords::Decimal(self.exact), None),
        }
    }
}

/// Width of a binary float.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FloatWidth {
    /// IEEE 754 binary32.
    F32,
    /// IEEE 754 binary64.
    F64,
}

impl FloatWidth {
    /// Bits of the format: 32 or 64.
    pub fn bits(self) -> u32 {
        match self {
            FloatWidth::F32 => 32,
            FloatWidth::F64 => 64,
        }
    }

    /// Mantissa bits with the leading one: 24 or 53.
    pub fn precision(self) -> u32 {
        match self {
            FloatWidth::F32 => 24,
            FloatWidth::F64 => 53,
        }
    }

    /// What a normal float's exponent field less gives the exponent of its last
    /// mantissa bit: 150 or 1075.
    pub(crate) fn bias(self) -> i32 {
        match self {
            FloatWidth::F32 => 150,
            FloatWidth::F64 => 1075,
        }
    }
}

/// How integer coordinates map to the values written to a file (SPEC.md 3).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Quantization {
    /// `value = n / 10^decimals`, written with exactly `decimals` decimals.
    Decimal {
        /// Decimals after the point.
        decimals: u8,
    },
    /// `value = n * 2^exponent`, exactly the binary float that was read.
    Float {
        /// The float type the values came from.
        width: FloatWidth,
        /// Binary exponent of the integer grid.
        exponent: i32,
    },
    /// Draco's grid: `value = f32(n) * step + origin`, in `f32`.
    Grid {
        /// Q, the number of bits.
        bits: u8,
        /// Per-axis minimum of the input.
        origin: [f32; 3],
        /// One step for all axes: largest extent / (2^Q - 1), in `f32`.
        step: f32,
    },
}

impl Quantization {
    /// Whether the mode reproduces the file's own values (not a lossy grid).
    pub fn is_exact(&self) -> bool {
        !matches!(self, Quantization::Grid { .. })
    }

    /// A short human description.
    pub fn describe(&self) -> String {
        match *self {
            Quantization::Decimal { decimals } => format!("exact decimal, 1e-{decimals} grid"),
            Quantization::Float { width, exponent } => format!(
                "exact binary {}, 2^{exponent} grid",
                match width {
                    FloatWidth::F32 => "float32",
                    FloatWidth::F64 => "float64",
                }
            ),
            Quantization::Grid { bits, step, .. } => format!("{bits}-bit grid, step {step}"),
        }
    }

    /// The value of integer `n` on `axis` as `f64` (exact for the exact modes where the
    /// value is representable; the `f32` value for grids).
    pub fn value_f64(&self, n: i64, axis: usize) -> f64 {
        match *self {
            Quantization::Decimal { decimals } => Decimal {
                mantissa: n,
                decimals,
            }
            .to_f64(),
            Quantization::Float { exponent, .. } => scale_pow2(n as f64, exponent),
            Quantization::Grid { .. } => self.value_f32(n, axis) as f64,
        }
    }

    /// The value as `f32` (exact for `Float { width: F32 }` and for grids).
    pub fn value_f32(&self, n: i64, axis: usize) -> f32 {
        match *self {
            Quantization::Grid { origin, step, .. } => (n as f32) * step + origin[axis],
            _ => self.value_f64(n, axis) as f32,
        }
    }

    /// Appends the value's text: exact decimals for the decimal mode, the shortest text
    /// that reads back as the same float otherwise.
    pub fn write_text(&self, n: i64, axis: usize, out: &mut String) {
        use std::fmt::Write;
        match *self {
            Quantization::Decimal { decimals } => write_decimal(n, decimals, out),
            Quantization::Float {
                width: FloatWidth::F64,
                ..
            } => {
                let _ = write!(out, "{}", self.value_f64(n, axis));
            }
            _ => {
                let _ = write!(out, "{}", self.value_f32(n, axis));
            }
        }
    }

    /// Whether binary output should use `f32` (values are exactly `f32`).
    pub fn prefers_f32(&self) -> bool {
        matches!(
            self,
            Quantization::Grid { .. }
                | Quantization::Float {
                    width: FloatWidth::F32,
                    ..
                }
        )
    }
}

fn scale_pow2(x: f64, e: i32) -> f64 {
    // Two steps so that intermediate powers stay normal for any exponent we accept.
    let h = e / 2;
    x * 2f64.powi(h) * 2f64.powi(e - h)
}

/// Writes `n / 10^decimals` with exactly `decimals` decimals (at most [`MAX_DECIMALS`]).
pub fn write_decimal(n: i64, decimals: u8, out: &mut String) {
    let a = n.unsigned_abs();
    if n < 0 {
        out.push('-');
    }
    // (itoa: the digits without a formatter.)
    let mut digits = itoa::Buffer::new();
    if decimals == 0 {
        out.push_str(digits.format(a));
        return;
    }
    let p = POW10[decimals as usize] as u64;
    out.push_str(digits.format(a / p));
    out.push('.');
    let fraction = digits.format(a % p);
    out.extend(std::iter::repeat_n('0', decimals as usize - fraction.len()));
    out.push_str(fraction);
}

fn range_error(what: String) -> Error {
    Error::Range(format!(
        "{what}; exact integers would not fit the codec's range of +-(2^{COORD_BITS} - 1): \
         quantise them (a grid of 1 to 30 bits)"
    ))
}

/// Integer positions, how they map to values, and the exact binary floats where the
/// integers alone do not give them (`Mesh::floats`; empty otherwise).
pub type Integers = (Vec<[i64; 3]>, Quantization, Vec<[u64; 3]>);

/// Turns the coordinates into integers: exactly when `bits` is `None` (decimal text on
/// its grid, or as the binary floats it denotes when that grid is beyond the codec's
/// range; binary floats bit for bit, SPEC.md 3.2), on Draco's Q-bit grid otherwise.
pub fn integerize(raw: &RawCoords, bits: Option<u8>) -> Result<Integers> {
    check_finite(raw)?;
    match (bits, raw) {
        (Some(q), _) => grid(raw, q).map(|(p, q)| (p, q, Vec::new())),
        (None, RawCoords::Decimal(v)) => match exact_decimal(v) {
            Ok((p, q)) => Ok((p, q, Vec::new())),
            Err(Error::Range(_)) => integerize(&decimals_as_floats(v), None),
            Err(e) => Err(e),
        },
        (None, RawCoords::F32(v)) => Ok(exact_floats(
            v.iter().map(|p| p.map(|x| x.to_bits() as u64)).collect(),
            FloatWidth::F32,
        )),
        (None, RawCoords::F64(v)) => Ok(exact_floats(
            v.iter().map(|p| p.map(f64::to_bits)).collect(),
            FloatWidth::F64,
        )),
    }
}

fn check_finite(raw: &RawCoords) -> Result<()> {
    let bad = match raw {
        RawCoords::Decimal(_) => None,
        RawCoords::F32(v) => v.iter().position(|p| p.iter().any(|x| !x.is_finite())),
        RawCoords::F64(v) => v.iter().position(|p| p.iter().any(|x| !x.is_finite())),
    };
    match bad {
        Some(i) => Err(Error::InvalidMesh(format!(
            "vertex {} has a NaN or infinite coordinate",
            i + 1
        ))),
        None => Ok(()),
    }
}

fn exact_decimal(v: &[[Decimal; 3]]) -> Result<(Vec<[i64; 3]>, Quantization)> {
    let d = v
        .iter()
        .flat_map(|p| p.iter().map(|x| x.decimals))
        .max()
        .unwrap_or(0);
    let mut out = Vec::with_capacity(v.len());
    for (i, p) in v.iter().enumerate() {
        let mut q = [0i64; 3];
        for k in 0..3 {
            let s = POW10[(d - p[k].decimals) as usize];
            q[k] = p[k]
                .mantissa
                .checked_mul(s)
                .filter(|x| x.abs() <= MAX_COORD)
                .ok_or_else(|| {
                    range_error(format!(
                        "vertex {} coordinate {} on the 1e-{d} grid",
                        i + 1,
                        k + 1
                    ))
                })?;
        }
        out.push(q);
    }
    Ok((out, Quantization::Decimal { decimals: d }))
}

/// Draco's quantiser (AttributeQuantizationTransform with a shared range), in `f32`.
fn grid(raw: &RawCoords, q: u8) -> Result<(Vec<[i64; 3]>, Quantization)> {
    if !(1..=30).contains(&q) {
        return Err(Error::InvalidArgument(format!(
            "--bits {q} is outside 1..=30"
        )));
    }
    let p = raw.to_f32();
    if let Some(i) = p.iter().position(|v| v.iter().any(|x| !x.is_finite())) {
        return Err(Error::Range(format!(
            "vertex {} overflows f32, which --bits quantises in",
            i + 1
        )));
    }
    let mut mn = [f32::INFINITY; 3];
    let mut mx = [f32::NEG_INFINITY; 3];
    for v in &p {
        for k in 0..3 {
            mn[k] = mn[k].min(v[k]);
            mx[k] = mx[k].max(v[k]);
        }
    }
    if p.is_empty() {
        mn = [0.0; 3];
        mx = [0.0; 3];
    }
    let mut range = (0..3).map(|k| mx[k] - mn[k]).fold(0f32, f32::max);
    if range == 0.0 || !range.is_finite() {
        if !range.is_finite() {
            return Err(Error::Range("bounding box extent overflows f32".into()));
        }
        range = 1.0;
    }
    let maxq = ((1u32 << q) - 1) as f32;
    let inv_delta = maxq / range;
    let delta = range / maxq;
    let out = p
        .iter()
        .map(|v| {
            let mut r = [0i64; 3];
            for k in 0..3 {
                r[k] = ((v[k] - mn[k]) * inv_delta + 0.5f32).floor() as i64;
            }
            r
        })
        .collect();
    Ok((
        out,
        Quantization::Grid {
            bits: q,
            origin: mn,
            step: delta,
        },
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_decimals_exactly() {
        let d = |s| Decimal::parse(s).unwrap();
        assert_eq!(
            d("1.500000"),
            Decimal {
                mantissa: 1500000,
                decimals: 6
            }
        );
        assert_eq!(
            d("-0.25"),
            Decimal {
                mantissa: -25,
                decimals: 2
            }
        );
        assert_eq!(
            d("12"),
            Decimal {
                mantissa: 12,
                decimals: 0
            }
        );
        assert_eq!(
            d("1.5e-3"),
            Decimal {
                mantissa: 15,
                decimals: 4
            }
        );
        assert_eq!(
            d("1.5E3"),
            Decimal {
                mantissa: 1500,
                decimals: 0
            }
        );
        assert_eq!(
            d(".5"),
            Decimal {
                mantissa: 5,
                decimals: 1
            }
        );
        for bad in [
            "nan", "-inf", "Infinity", "1.2.3", "", "-", "abc", "1e", "1e999",
        ] {
            assert!(Decimal::parse(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn decimal_text_is_the_formatters() {
        // What `{}.{:0width$}` writes, for mantissas near every power of ten and the
        // extremes, with every number of decimals.
        let mut ns = vec![0i64, 1, -1, 5, i64::MAX, i64::MIN, i64::MIN + 1];
        for p in POW10 {
            ns.extend([p - 1, p, p + 1, -p + 1, -p, -p - 1, p / 2 + 7]);
        }
        for decimals in 0..=18u8 {
            for &n in &ns {
                let a = n.unsigned_abs();
                let sign = if n < 0 { "-" } else { "" };
                let want = match decimals {
                    0 => format!("{sign}{a}"),
                    d => {
                        let p = POW10[d as usize] as u64;
                        format!("{sign}{}.{:0w$}", a / p, a % p, w = d as usize)
                    }
                };
                let mut out = String::new();
                write_decimal(n, decimals, &mut out);
                assert_eq!(out, want, "{n} with {decimals} decimals");
            }
        }
    }

    #[test]
    fn decimal_text_round_trips() {
        for s in ["0.000000", "-12.345678", "123456.000001", "7", "-0.5"] {
            let d = Decimal::parse(s).unwrap();
            let mut out = String::new();
            write_decimal(d.mantissa, d.decimals, &mut out);
            assert_eq!(out, s);
        }
    }

    #[test]
    fn exact_floats_are_exact() {
        // On a grid no finer than the largest value's last bit: one grid, no float bits.
        let v = vec![[1.5f32, -0.25, 1000.25], [0.0, 0.5, -7.0]];
        let (ints, q, floats) = integerize(&RawCoords::F32(v.clone()), None).unwrap();
        assert!(floats.is_empty(), "one grid holds them");
        // -0.001's last bit is finer than 1000.25's: the float bits keep it.
        let w = vec![[1.5f32, -0.001, 1000.25]];
        let (_, _, floats) = integerize(&RawCoords::F32(w.clone()), None).unwrap();
        assert_eq!(floats, vec![w[0].map(|x| x.to_bits() as u64)]);
        for (p, n) in v.iter().zip(&ints) {
            for k in 0..3 {
                assert_eq!(q.value_f32(n[k], k).to_bits(), p[k].to_bits());
            }
        }
    }

    #[test]
    fn floats_beyond_one_grid_keep_their_bits() {
        // Exponents 200 apart, and a negative zero: no one grid holds them in 44 bits.
        let v = vec![[1.0e30f64, 1.0e-30, -0.0], [3.0, -2.5e-300, 7.0e-310]];
        let (ints, q, floats) = integerize(&RawCoords::F64(v.clone()), None).unwrap();
        let Quantization::Float { exponent: e, .. } = q else {
            panic!("{q:?}")
        };
        assert_eq!(floats.len(), 2);
        for (p, (n, f)) in v.iter().zip(ints.iter().zip(&floats)) {
            for k in 0..3 {
                assert_eq!(f[k], p[k].to_bits());
                assert_eq!(n[k], grid_integer(f[k], FloatWidth::F64, e));
                assert!(n[k].abs() <= MAX_COORD);
            }
        }
        assert_eq!(ints[0][0] >> 43, 1, "the largest value's integer takes 44 bits");
        let nan = vec![[f32::NAN, 0.0, 0.0]];
        assert!(integerize(&RawCoords::F32(nan), None).is_err());
    }

    #[test]
    fn decimal_text_beyond_the_grid_is_read_as_floats() {
        let read = |lines: &[[&str; 3]]| {
            let mut t = TextCoords::default();
            for l in lines {
                t.push(*l).unwrap();
            }
            integerize(&t.finish().0, None).unwrap()
        };
        // binary32 shortest texts (a Blender ASCII PLY's): on a decimal grid too fine
        // for the codec's range, then with a number too long for any decimal grid.
        for tail in [["1e-17", "0.1", "7"], ["1e-20", "0.1", "7"]] {
            let (_, q, floats) = read(&[["0.020000003", "-2.3283064e-10", "-1"], tail]);
            assert!(matches!(q, Quantization::Float { width: FloatWidth::F32, .. }));
            let want = |l: [&str; 3]| l.map(|t| t.parse::<f32>().unwrap().to_bits() as u64);
            assert_eq!(
                floats,
                [want(["0.020000003", "-2.3283064e-10", "-1"]), want(tail)]
            );
        }
        // %.17g text: binary64.
        let (_, q, floats) = read(&[["0.0055160000000000001", "1e-12", "12345.5"]]);
        assert!(matches!(q, Quantization::Float { width: FloatWidth::F64, .. }));
        assert_eq!(floats[0], [0.005516f64, 1e-12, 12345.5].map(f64::to_bits));
        for (t, want) in [("0.5", true), ("5e-1", true), ("0.50", true), ("0.1", true)] {
            assert_eq!(token_f32(t).is_some(), want, "{t}");
        }
        assert!(token_f32("0.10000000149011612").is_none());
        assert!(token_f32("-0").is_some_and(|x| x.to_bits() == (-0.0f32).to_bits()));
    }

    #[test]
    fn grid_matches_drafts_formula() {
        let v = vec![[0.0f32, 0.0, 0.0], [2.0, 1.0, 0.5], [1.0, 0.3, 0.1]];
        let (ints, q, _) = integerize(&RawCoords::F32(v), Some(8)).unwrap();
        assert_eq!(ints[1], [255, 128, 64]);
        assert_eq!(ints[2][0], 128);
        assert_eq!(q.value_f32(255, 0), 2.0);
    }
}
