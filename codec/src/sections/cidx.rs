//! The CIDX section (SPEC.md 11.1): a file's per-corner index channels, such as an OBJ
//! face corner's `vt` and `vn` numbers, which the template (SPEC.md 11) writes with
//! marker 0x0F. Each value is predicted from the corner's vertex and face (the number the
//! vertex had at its last corner, the face's previous corner's, the next new number of
//! a deduplicated table, the vertex's number shifted as the last new vertex's was) and
//! coded as which prediction holds, with adaptive models, or as its difference from the
//! last prediction.

use crate::entropy::{AdaptiveModel, Decoder, Encoder, IntModel};
use crate::error::{Error, Result};
use crate::mesh::Mesh;

const SECTION: &str = "CIDX";

/// Most channels a container carries.
pub const MAX_CHANNELS: usize = 4;

/// One channel: the corners (of the mesh in the file's order, ascending) that carry a
/// value, and their values.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct IndexChannel {
    /// Corner numbers, ascending.
    pub corners: Vec<u32>,
    /// `values[i]` belongs to corner `corners[i]`.
    pub values: Vec<u32>,
}

/// A file's per-corner index channels (channel 0 an OBJ's `vt` numbers, 1 its `vn`).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct CornerIndices {
    /// The channels, at most [`MAX_CHANNELS`].
    pub channels: Vec<IndexChannel>,
}

impl CornerIndices {
    /// Whether no channel carries a value.
    pub fn is_empty(&self) -> bool {
        self.channels.iter().all(|c| c.values.is_empty())
    }
}

/// The symbol of a value no prediction gives (SPEC.md 11.1); symbols 0 to 3 are the
/// predictions of [`Predictor::candidates`].
const ESCAPE: usize = 4;
/// Symbols per model.
const SYMBOLS: usize = 5;

/// A channel's state while coding, the same both ways.
struct Predictor {
    /// Per vertex: its value at its last corner, or `None`.
    last: Vec<Option<u32>>,
    /// The largest value so far.
    max: Option<u32>,
    /// Value minus vertex at the last corner whose vertex was new to the channel.
    shift: i64,
    /// The value of the previous corner of this face that carries one.
    face_prev: Option<u32>,
    /// The previous symbol.
    prev_symbol: usize,
    models: Vec<AdaptiveModel>,
    escape: IntModel,
}

impl Predictor {
    fn new(nv: usize) -> Self {
        Predictor {
            last: vec![None; nv],
            max: None,
            shift: 1,
            face_prev: None,
            prev_symbol: 0,
            models: (0..2 * 2 * SYMBOLS)
                .map(|_| AdaptiveModel::new(SYMBOLS))
                .collect(),
            escape: IntModel::new(),
        }
    }

    /// The predictions for a corner of vertex `v`, symbols 0 to 3: the vertex's value at
    /// its last corner, the face's previous value, one more than the largest value so
    /// far (1 at first), the vertex plus the shift.
    fn candidates(&self, v: usize) -> [Option<i64>; 4] {
        [
            self.last[v].map(i64::from),
            self.face_prev.map(i64::from),
            Some(self.max.map_or(1, |m| m as i64 + 1)),
            Some(v as i64 + self.shift),
        ]
    }

    /// The context of a corner of vertex `v`: whether the vertex had a value, whether
    /// the face had one, and the previous symbol.
    fn context(&self, v: usize) -> usize {
        (self.last[v].is_some() as usize * 2 + self.face_prev.is_some() as usize) * SYMBOLS
            + self.prev_symbol
    }

    /// Takes value `a` at a corner of vertex `v` coded as `symbol`.
    fn take(&mut self, v: usize, a: u32, symbol: usize) {
        if self.last[v].is_none() {
            self.shift = a as i64 - v as i64;
        }
        self.last[v] = Some(a);
        self.max = Some(self.max.map_or(a, |m| m.max(a)));
        self.face_prev = Some(a);
        self.prev_symbol = symbol;
    }
}

/// The faces' corners with each corner's face start flag, in order.
fn corner_walk(mesh: &Mesh) -> impl Iterator<Item = (usize, u32, bool)> + '_ {
    mesh.face_starts.windows(2).flat_map(move |w| {
        (w[0]..w[1]).map(move |c| (c as usize, mesh.faces[c as usize], c == w[0]))
    })
}

/// The CIDX payload of `indices` for `mesh` (in the file's order): the channel count,
/// then one entropy-coded stream.
pub fn encode(mesh: &Mesh, indices: &CornerIndices) -> Result<Vec<u8>> {
    let nc = indices.channels.len();
    if nc > MAX_CHANNELS {
        return Err(Error::InvalidArgument(format!(
            "{nc} corner index channels, at most {MAX_CHANNELS}"
        )));
    }
    let mut e = Encoder::new();
    for ch in &indices.channels {
        let mut p = Predictor::new(mesh.vertex_count());
        let mut present = [AdaptiveModel::new(2), AdaptiveModel::new(2)];
        let mut prev_present = 0;
        let mut next = 0;
        for (c, v, first) in corner_walk(mesh) {
            if first {
                p.face_prev = None;
            }
            let here = ch.corners.get(next) == Some(&(c as u32));
            e.symbol(&mut present[prev_present], here as usize);
            prev_present = here as usize;
            if !here {
                continue;
            }
            let a = ch.values[next];
            next += 1;
            let v = v as usize;
            let cands = p.candidates(v);
            let s = cands
                .iter()
                .position(|&x| x == Some(a as i64))
                .unwrap_or(ESCAPE);
            let ctx = p.context(v);
            e.symbol(&mut p.models[ctx], s);
            if s == ESCAPE {
                e.int(&mut p.escape, a as i64 - (v as i64 + p.shift));
            }
            p.take(v, a, s);
        }
        if next != ch.values.len() || ch.corners.len() != ch.values.len() {
            return Err(Error::InvalidArgument(
                "corner index channel with corners past the mesh or out of order".into(),
            ));
        }
    }
    let mut out = vec![nc as u8];
    out.extend_from_slice(&e.finish());
    Ok(out)
}

/// Decodes a CIDX payload for `mesh` (in the file's order).
pub fn decode(payload: &[u8], mesh: &Mesh) -> Result<CornerIndices> {
    let bad = |what: &str| Error::corrupt(SECTION, what.to_string());
    let (&nc, stream) = payload
        .split_first()
        .ok_or_else(|| bad("empty payload"))?;
    if nc as usize > MAX_CHANNELS || nc == 0 {
        return Err(bad("channel count not in 1..=4"));
    }
    let mut d = Decoder::new(stream, SECTION)?;
    let mut channels = Vec::with_capacity(nc as usize);
    for _ in 0..nc {
        let mut p = Predictor::new(mesh.vertex_count());
        let mut present = [AdaptiveModel::new(2), AdaptiveModel::new(2)];
        let mut prev_present = 0;
        let mut ch = IndexChannel::default();
        for (c, v, first) in corner_walk(mesh) {
            if first {
                p.face_prev = None;
            }
            let here = d.symbol(&mut present[prev_present])?;
            prev_present = here;
            if here == 0 {
                continue;
            }
            let v = v as usize;
            let ctx = p.context(v);
            let s = d.symbol(&mut p.models[ctx])?;
            let a = if s == ESCAPE {
                let delta = d.int(&mut p.escape)?;
                (v as i64 + p.shift).checked_add(delta)
            } else {
                p.candidates(v)[s]
            };
            let a = a
                .and_then(|a| u32::try_from(a).ok())
                .ok_or_else(|| bad("an index value out of range or not predicted"))?;
            p.take(v, a, s);
            ch.corners.push(c as u32);
            ch.values.push(a);
        }
        channels.push(ch);
    }
    Ok(CornerIndices { channels })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid_mesh(n: u32) -> Mesh {
        let t = crate::topology::fixtures::quad_grid(n);
        Mesh {
            positions: vec![[0; 3]; t.nv],
            faces: t.idx,
            face_starts: t.starts,
            ..Mesh::default()
        }
    }

    /// A channel of every prediction kind and escapes (a seam, a flat face's one
    /// value, a table out of first-use order, corners without a value) round-trips; a
    /// per-vertex channel costs well under a bit per corner.
    #[test]
    fn channels_round_trip_and_per_vertex_ones_are_cheap() {
        let mesh = grid_mesh(40);
        let corners = mesh.faces.len() as u32;
        let per_vertex = IndexChannel {
            corners: (0..corners).collect(),
            values: mesh.faces.iter().map(|&v| v + 1).collect(),
        };
        let mut s = 12345u64;
        let mut rnd = || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            s
        };
        let mut mixed = IndexChannel::default();
        for (c, &v) in mesh.faces.iter().enumerate() {
            let r = rnd() % 10;
            if r == 0 {
                continue;
            }
            mixed.corners.push(c as u32);
            mixed.values.push(match r {
                1 => (rnd() % 5000) as u32,
                2 => c as u32 / 4 + 1,
                _ => v * 2 + 7,
            });
        }
        let idx = CornerIndices {
            channels: vec![per_vertex.clone(), mixed],
        };
        let bytes = encode(&mesh, &idx).unwrap();
        assert_eq!(decode(&bytes, &mesh).unwrap(), idx);
        let one = CornerIndices {
            channels: vec![per_vertex],
        };
        let small = encode(&mesh, &one).unwrap();
        assert!(small.len() * 8 < corners as usize / 4, "{} bytes", small.len());
        assert_eq!(decode(&small, &mesh).unwrap(), one);
    }

    /// Truncations and flipped bits give an error or other values, never a panic; a
    /// channel count out of range is refused.
    #[test]
    fn damaged_payloads_are_errors_not_panics() {
        let mesh = grid_mesh(12);
        let idx = CornerIndices {
            channels: vec![IndexChannel {
                corners: (0..mesh.faces.len() as u32).collect(),
                values: mesh.faces.iter().map(|&v| v * 3 % 17).collect(),
            }],
        };
        let bytes = encode(&mesh, &idx).unwrap();
        for cut in 0..bytes.len() {
            let _ = decode(&bytes[..cut], &mesh);
        }
        for i in 0..bytes.len() * 8 {
            let mut b = bytes.clone();
            b[i / 8] ^= 1 << (i % 8);
            let _ = decode(&b, &mesh);
        }
        assert!(decode(&[0], &mesh).is_err());
        assert!(decode(&[5, 0, 0], &mesh).is_err());
        assert!(decode(&[], &mesh).is_err());
    }
}
