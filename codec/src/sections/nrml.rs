//! The NRML section (SPEC.md 11.2): an OBJ's `vn` values, predicted from the decoded
//! geometry as the exporters compute them (a vertex's normal: its faces' unit normals
//! weighted by the corner angles; a face's normal) in integer arithmetic only, and
//! coded as the differences from the prediction at the printed precision. The template
//! writes each component with marker 0x0F 4.

use crate::entropy::{AdaptiveModel, Decoder, Encoder, IntModel};
use crate::error::{Error, Result};
use crate::mesh::Mesh;
use crate::sections::cidx::CornerIndices;
use crate::transform::isqrt;

const SECTION: &str = "NRML";

/// The channel of the corners' `vn` numbers (SPEC.md 11.1).
pub const NORMAL_CHANNEL: usize = 1;
/// Most decimals of a component.
pub const MAX_DECIMALS: u32 = 18;

/// One `vn` component as written: `m / 10^decimals`, and whether a zero was written
/// `-0`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Component {
    /// The number times 10^decimals.
    pub m: i64,
    /// Digits after the point (0: no point).
    pub decimals: u32,
    /// A zero written with a minus sign.
    pub negative_zero: bool,
}

impl Component {
    /// The component a token writes, if it is a plain decimal (`-?D+(.D+)?`, no
    /// leading zeros, at most [`MAX_DECIMALS`] decimals).
    pub fn parse(token: &[u8]) -> Option<Component> {
        let (neg, digits) = match token.split_first()? {
            (b'-', rest) => (true, rest),
            _ => (false, token),
        };
        let (int, frac) = match digits.iter().position(|&c| c == b'.') {
            Some(p) => (&digits[..p], Some(&digits[p + 1..])),
            None => (digits, None),
        };
        let plain = |d: &[u8]| !d.is_empty() && d.iter().all(u8::is_ascii_digit);
        if !plain(int) || (int.len() > 1 && int[0] == b'0') || frac.is_some_and(|f| !plain(f)) {
            return None;
        }
        let decimals = frac.map_or(0, |f| f.len()) as u32;
        if decimals > MAX_DECIMALS {
            return None;
        }
        let mut m: i64 = 0;
        for &c in int.iter().chain(frac.unwrap_or(&[])) {
            m = m.checked_mul(10)?.checked_add((c - b'0') as i64)?;
        }
        let c = Component {
            m: if neg { -m } else { m },
            decimals,
            negative_zero: neg && m == 0,
        };
        (c.text().as_bytes() == token).then_some(c)
    }

    /// The component's text.
    pub fn text(&self) -> String {
        let a = self.m.unsigned_abs();
        let sign = if self.m < 0 || self.negative_zero { "-" } else { "" };
        match self.decimals {
            0 => format!("{sign}{a}"),
            d => {
                let p = 10u64.pow(d);
                format!("{sign}{}.{:0w$}", a / p, a % p, w = d as usize)
            }
        }
    }
}

/// Fixed-point scale of unit vectors and angles: 2^30.
const ONE: u32 = 30;

/// `v` shifted right (arithmetic) until every component is below 2^bits in magnitude.
fn shrink<const N: usize>(v: [i128; N], bits: u32) -> [i128; N] {
    let top = v.iter().map(|x| 128 - x.unsigned_abs().leading_zeros()).max().unwrap_or(0);
    let s = top.saturating_sub(bits);
    v.map(|x| x >> s)
}

/// `n / |n|` times 2^30 (floor), after `n` is shrunk below 2^62; zero for zero.
fn unit(n: [i128; 3]) -> [i64; 3] {
    let n = shrink(n, 62);
    let len = isqrt(n.iter().map(|&x| (x * x) as u128).sum());
    if len == 0 {
        return [0; 3];
    }
    n.map(|x| (x << ONE).div_euclid(len as i128) as i64)
}

/// atan(2^-i) times 2^30, rounded, i = 0..=30.
const ATAN: [i64; 31] = [
    843314857, 497837829, 263043837, 133525159, 67021687, 33543516, 16775851, 8388437,
    4194283, 2097149, 1048576, 524288, 262144, 131072, 65536, 32768, 16384, 8192, 4096,
    2048, 1024, 512, 256, 128, 64, 32, 16, 8, 4, 2, 1,
];

/// The angle between integer vectors a and b, in [0, pi], times 2^30 (CORDIC).
fn angle(a: [i128; 3], b: [i128; 3]) -> i64 {
    let (a, b) = (shrink(a, 31), shrink(b, 31));
    let c = [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ];
    let y = isqrt(c.iter().map(|&x| (x * x) as u128).sum()) as i128;
    let x: i128 = (0..3).map(|k| a[k] * b[k]).sum();
    // Scaled up or down to 60 bits, so that the iterations keep their precision.
    let top = 128 - x.unsigned_abs().max(y.unsigned_abs()).leading_zeros();
    let [mut x, mut y] = match top {
        0 => return 0,
        t if t < 60 => [x << (60 - t), y << (60 - t)],
        _ => shrink([x, y], 60),
    };
    let mut t: i64 = 0;
    if x < 0 {
        // Turn by 90 degrees first: y >= 0, so the angle is above pi / 2.
        (x, y) = (y, -x);
        t = ATAN[0] * 2;
    }
    for (i, &step) in ATAN.iter().enumerate() {
        let (dx, dy) = (y >> i, x >> i);
        if y > 0 {
            (x, y) = (x + dx, y - dy);
            t += step;
        } else if y < 0 {
            (x, y) = (x - dx, y + dy);
            t -= step;
        }
    }
    t
}

/// Face g's normal (Newell's, corners relative to its first): sums in 128 bits.
fn face_normal(mesh: &Mesh, g: usize) -> [i128; 3] {
    let face = &mesh.faces[mesh.face_starts[g] as usize..mesh.face_starts[g + 1] as usize];
    let p0 = mesh.positions[face[0] as usize];
    let rel = |v: u32| -> [i128; 3] {
        let p = mesh.positions[v as usize];
        std::array::from_fn(|k| p[k] as i128 - p0[k] as i128)
    };
    let mut n = [0i128; 3];
    for i in 1..face.len().saturating_sub(1) {
        let (a, b) = (rel(face[i]), rel(face[i + 1]));
        n[0] += a[1] * b[2] - a[2] * b[1];
        n[1] += a[2] * b[0] - a[0] * b[2];
        n[2] += a[0] * b[1] - a[1] * b[0];
    }
    n
}

/// Per vertex: its faces' unit normals weighted by the angle of their corner at it
/// (2^60-scaled sums).
fn vertex_normals(mesh: &Mesh) -> Vec<[i128; 3]> {
    let mut out = vec![[0i128; 3]; mesh.vertex_count()];
    for g in 0..mesh.face_count() {
        let face = &mesh.faces[mesh.face_starts[g] as usize..mesh.face_starts[g + 1] as usize];
        let u = unit(face_normal(mesh, g));
        let k = face.len();
        for i in 0..k {
            let p = |j: usize| mesh.positions[face[j % k] as usize];
            let (v, prev, next) = (p(i), p(i + k - 1), p(i + 1));
            let d = |q: [i64; 3]| -> [i128; 3] { std::array::from_fn(|c| q[c] as i128 - v[c] as i128) };
            let w = angle(d(prev), d(next)) as i128;
            let acc = &mut out[face[i] as usize];
            for c in 0..3 {
                acc[c] += w * u[c] as i128;
            }
        }
    }
    out
}

/// For each `vn` entry (numbers from 1): the vertex and face of the first corner whose
/// channel value is its number.
fn first_corners(mesh: &Mesh, idx: &CornerIndices, entries: usize) -> Vec<Option<(u32, u32)>> {
    let mut out = vec![None; entries];
    let Some(ch) = idx.channels.get(NORMAL_CHANNEL) else {
        return out;
    };
    let mut face = 0usize;
    for (&c, &a) in ch.corners.iter().zip(&ch.values) {
        while mesh.face_starts.get(face + 1).is_some_and(|&s| s <= c) {
            face += 1;
        }
        let j = (a as usize).wrapping_sub(1);
        if let (Some(slot @ None), Some(&v)) = (out.get_mut(j), mesh.faces.get(c as usize)) {
            *slot = Some((v, face as u32));
        }
    }
    out
}

/// Predictions of an entry: by its first corner's vertex normal, and by its face's.
struct Predictor {
    vertex: Vec<[i128; 3]>,
    firsts: Vec<Option<(u32, u32)>>,
}

impl Predictor {
    fn new(mesh: &Mesh, idx: &CornerIndices, entries: usize) -> Self {
        Predictor {
            vertex: vertex_normals(mesh),
            firsts: first_corners(mesh, idx, entries),
        }
    }

    /// Entry j's unit normals (2^30-scaled): by its vertex, by its face.
    fn units(&self, mesh: &Mesh, j: usize) -> Option<[[i64; 3]; 2]> {
        let (v, f) = self.firsts[j]?;
        Some([unit(self.vertex[v as usize]), unit(face_normal(mesh, f as usize))])
    }
}

/// A unit component (2^30-scaled) at `decimals` digits, rounded.
fn scaled(u: i64, decimals: u32) -> i64 {
    let p = 10i128.pow(decimals);
    ((u as i128 * p + (1 << (ONE - 1))) >> ONE) as i64
}

/// The models of the stream.
struct Models {
    choice: [AdaptiveModel; 2],
    decimals: Vec<AdaptiveModel>,
    zero: AdaptiveModel,
    residual: [IntModel; 3],
}

impl Models {
    fn new() -> Self {
        let n = MAX_DECIMALS as usize + 1;
        Models {
            choice: [AdaptiveModel::new(2), AdaptiveModel::new(2)],
            decimals: (0..n).map(|_| AdaptiveModel::new(n)).collect(),
            zero: AdaptiveModel::new(2),
            residual: [IntModel::new(), IntModel::new(), IntModel::new()],
        }
    }
}

/// The NRML payload of `values` (three components per `vn` entry) for `mesh` in the
/// file's order and its corner index channels.
pub fn encode(mesh: &Mesh, idx: &CornerIndices, values: &[Component]) -> Result<Vec<u8>> {
    if values.len() % 3 != 0 {
        return Err(Error::InvalidArgument("normal components not in threes".into()));
    }
    let entries = values.len() / 3;
    let pred = Predictor::new(mesh, idx, entries);
    let mut m = Models::new();
    let mut e = Encoder::new();
    let (mut prev_choice, mut prev_d) = (0usize, 4usize);
    for (j, comps) in values.chunks(3).enumerate() {
        let units = pred.units(mesh, j);
        let units = units.map(|u| {
            // The prediction whose components are nearer.
            let cost = |w: &[i64; 3]| -> u64 {
                (0..3)
                    .map(|k| (comps[k].m - scaled(w[k], comps[k].decimals)).unsigned_abs())
                    .sum()
            };
            let c = (cost(&u[1]) < cost(&u[0])) as usize;
            e.symbol(&mut m.choice[prev_choice], c);
            prev_choice = c;
            u[c]
        });
        for (k, comp) in comps.iter().enumerate() {
            let d = comp.decimals as usize;
            e.symbol(&mut m.decimals[prev_d], d);
            prev_d = d;
            let p = units.map_or(0, |u| scaled(u[k], comp.decimals));
            e.int(&mut m.residual[k], comp.m - p);
            if comp.m == 0 {
                e.symbol(&mut m.zero, comp.negative_zero as usize);
            }
        }
    }
    Ok(e.finish())
}

/// Decodes an NRML payload of `count` components for `mesh` in the file's order.
pub fn decode(payload: &[u8], mesh: &Mesh, idx: &CornerIndices, count: usize) -> Result<Vec<Component>> {
    if count % 3 != 0 {
        return Err(Error::corrupt(SECTION, "normal components not in threes"));
    }
    let entries = count / 3;
    let pred = Predictor::new(mesh, idx, entries);
    let mut m = Models::new();
    let mut d = Decoder::new(payload, SECTION)?;
    let (mut prev_choice, mut prev_d) = (0usize, 4usize);
    let mut out = Vec::with_capacity(count);
    for j in 0..entries {
        let units = match pred.units(mesh, j) {
            Some(u) => {
                let c = d.symbol(&mut m.choice[prev_choice])?;
                prev_choice = c;
                Some(u[c])
            }
            None => None,
        };
        for k in 0..3 {
            let dec = d.symbol(&mut m.decimals[prev_d])?;
            prev_d = dec;
            let p = units.map_or(0, |u| scaled(u[k], dec as u32));
            let r = d.int(&mut m.residual[k])?;
            let v = p
                .checked_add(r)
                .filter(|v| v.unsigned_abs() < 10u64.pow(18))
                .ok_or_else(|| Error::corrupt(SECTION, "a normal component out of range"))?;
            let negative_zero = v == 0 && d.symbol(&mut m.zero)? == 1;
            out.push(Component {
                m: v,
                decimals: dec as u32,
                negative_zero,
            });
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn components_read_back_as_written() {
        for t in ["0.1234", "-0.0000", "-1.0000", "1", "0", "-0", "12.5", "0.000001"] {
            let c = Component::parse(t.as_bytes()).unwrap();
            assert_eq!(c.text(), t);
        }
        for t in ["01.5", "1.", ".5", "+1.0", "1e-3", "", "-", "1.2.3"] {
            assert!(Component::parse(t.as_bytes()).is_none(), "{t}");
        }
    }

    #[test]
    fn isqrt_is_the_floor() {
        for v in [0u128, 1, 2, 3, 4, 15, 16, 17, 1 << 100, (1 << 126) + 12345, u128::MAX >> 2] {
            let r = isqrt(v);
            assert!(r * r <= v && (r + 1).checked_mul(r + 1).is_none_or(|s| s > v), "{v}");
        }
    }

    /// CORDIC's angles against known ones, to 2^-28 rad.
    #[test]
    fn angles_are_right() {
        let one = (1i64 << ONE) as f64;
        for (a, b, want) in [
            ([1, 0, 0], [0, 1, 0], std::f64::consts::FRAC_PI_2),
            ([1, 0, 0], [1, 1, 0], std::f64::consts::FRAC_PI_4),
            ([1, 0, 0], [-1, 1, 0], 3.0 * std::f64::consts::FRAC_PI_4),
            ([1, 0, 0], [-1, 0, 0], std::f64::consts::PI),
            ([3, 0, 0], [5, 0, 0], 0.0),
            ([1 << 40, 0, 0], [1 << 40, 1 << 39, 7], (0.5f64).atan()),
        ] {
            let t = angle(a.map(|x: i64| x as i128), b.map(|x: i64| x as i128)) as f64 / one;
            assert!((t - want).abs() < 4e-9, "{a:?} {b:?}: {t} vs {want}");
        }
    }
    /// A bumpy grid whose vertex normals are the channel's entries (one per vertex),
    /// some moved off the prediction, with other decimals, negative zeros and an entry
    /// no corner names: the round trip is exact; predicted entries cost little; damaged
    /// payloads are errors or other values, never a panic.
    #[test]
    fn normals_round_trip_and_predicted_ones_are_cheap() {
        use crate::sections::cidx::IndexChannel;
        let t = crate::topology::fixtures::quad_grid(30);
        let positions: Vec<[i64; 3]> = (0..t.nv as i64)
            .map(|i| [(i % 30) * 1000, (i / 30) * 1000, (i * 7919) % 613 * 3])
            .collect();
        let mesh = Mesh {
            positions,
            faces: t.idx.clone(),
            face_starts: t.starts.clone(),
            ..Mesh::default()
        };
        // Channel 1: vertex v's corners name entry v + 1; entry nv + 1 is named by none.
        let idx = CornerIndices {
            channels: vec![
                IndexChannel::default(),
                IndexChannel {
                    corners: (0..t.idx.len() as u32).collect(),
                    values: t.idx.iter().map(|&v| v + 1).collect(),
                },
            ],
        };
        let normals = vertex_normals(&mesh);
        let mut values = Vec::new();
        for (v, n) in normals.iter().enumerate() {
            let u = unit(*n);
            for k in 0..3 {
                let decimals = if v % 17 == 3 { 6 } else { 4 };
                let m = scaled(u[k], decimals) + if v % 11 == 0 { 3 } else { 0 };
                values.push(Component {
                    m,
                    decimals,
                    negative_zero: m == 0 && v % 2 == 0,
                });
            }
        }
        for m in [5, 0, -7] {
            values.push(Component { m, decimals: 2, negative_zero: false });
        }
        let bytes = encode(&mesh, &idx, &values).unwrap();
        assert_eq!(decode(&bytes, &mesh, &idx, values.len()).unwrap(), values);
        assert!(bytes.len() * 8 < values.len() * 2, "{} bytes", bytes.len());
        for cut in 0..bytes.len() {
            let _ = decode(&bytes[..cut], &mesh, &idx, values.len());
        }
        for i in 0..bytes.len() * 8 {
            let mut b = bytes.clone();
            b[i / 8] ^= 1 << (i % 8);
            let _ = decode(&b, &mesh, &idx, values.len());
        }
        assert!(decode(&bytes, &mesh, &idx, 4).is_err());
    }
}
