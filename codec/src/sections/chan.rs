//! The CHAN section (SPEC.md 11.4): one named attribute channel of the mesh
//! ([`crate::mesh::Attribute`]), in the decoded mesh's vertex and face order, its values
//! coded as the positions of a mesh of their own (a nested container, as ATTR's): on the
//! mesh's faces for per-vertex values, on the corners' entries for a corner channel,
//! without faces for per-face values.

use subwave_container::{ByteReader, ByteWriter};

use crate::error::{Error, Result};
use crate::mesh::{Domain, ValueType};

const SECTION: &str = "CHAN";

/// What a CHAN payload says about its channel before the nested container.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct Head {
    pub name: String,
    pub domain: Domain,
    pub value_type: ValueType,
    pub width: u8,
    /// Entries past the channel's at the end of the nested mesh (0..=2): a corner
    /// channel of fewer than 3 entries is padded to 3, as a mesh with faces needs.
    pub pad: u8,
    /// How the rest codes the channel: [`NESTED`] or [`NORMALS`].
    pub coding: u8,
    /// The names a channel of names stands for.
    pub labels: Vec<String>,
}

/// Coding 0: the values as the positions of a nested container's mesh.
pub(crate) const NESTED: u8 = 0;
/// Coding 1: unit normals per corner, their entries' numbers in a CIDX stream and
/// their values predicted from the decoded geometry in an NRML stream.
pub(crate) const NORMALS: u8 = 1;

/// Coding 2: a per-file channel of names, its values listed (SPEC.md 11.4).
pub(crate) const LISTED: u8 = 2;

/// Coding 2's body: the entries' values (-1 for none), each a varint of the value
/// plus one after their count.
pub(crate) fn encode_listed(values: &[[i64; 3]]) -> Vec<u8> {
    let mut w = ByteWriter::new();
    w.varint(values.len() as u64);
    for v in values {
        w.varint((v[0] + 1) as u64);
    }
    w.out
}

/// Coding 2's values from its body, for a channel of `names` names.
pub(crate) fn decode_listed(body: &[u8], names: usize) -> Result<Vec<[i64; 3]>> {
    let mut r = ByteReader::new(body, 0);
    // Each entry takes at least a byte.
    let n = r.varint_max("entries", r.remaining() as u64)?;
    let mut out = Vec::with_capacity(n as usize);
    for _ in 0..n {
        let v = r.varint_max("value", names as u64)?;
        out.push([v as i64 - 1, 0, 0]);
    }
    if r.remaining() != 0 {
        return Err(Error::corrupt(SECTION, "bytes after the listed values"));
    }
    Ok(out)
}

/// Coding 3: a list channel, its lengths and its values (SPEC.md 11.4).
pub(crate) const LISTS: u8 = 3;

/// Coding 3's body: the records' list lengths, then the nested container of the values.
pub(crate) fn encode_lists(counts: &[u32], nested: &[u8]) -> Vec<u8> {
    let mut w = ByteWriter::new();
    w.varint(counts.len() as u64);
    for &n in counts {
        w.varint(n as u64);
    }
    w.out.extend_from_slice(nested);
    w.out
}

/// Coding 3's lengths and nested container from its body; the lengths' sum too.
pub(crate) fn decode_lists(body: &[u8]) -> Result<(Vec<u32>, u64, &[u8])> {
    let mut r = ByteReader::new(body, 0);
    // Each length takes at least a byte.
    let n = r.varint_max("lists", r.remaining() as u64)?;
    let mut counts = Vec::with_capacity(n as usize);
    let mut total = 0u64;
    for _ in 0..n {
        let c = r.varint_max("list length", u32::MAX as u64)?;
        total += c;
        counts.push(c as u32);
    }
    Ok((counts, total, &body[body.len() - r.remaining()..]))
}

/// Coding 4: as [`NESTED`], a corner channel whose last padding entry stands for no
/// entry (SPEC.md 11.4).
pub(crate) const NESTED_NONE: u8 = 4;

/// Coding 1's body: the values' decimals, the entries, and the two streams.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct Normals<'a> {
    pub decimals: u8,
    pub entries: u64,
    pub cidx: &'a [u8],
    pub nrml: &'a [u8],
}

/// Coding 1's body bytes.
pub(crate) fn encode_normals(n: &Normals<'_>) -> Vec<u8> {
    let mut w = ByteWriter::new();
    w.u8(n.decimals);
    w.varint(n.entries);
    w.varint(n.cidx.len() as u64);
    w.out.extend_from_slice(n.cidx);
    w.out.extend_from_slice(n.nrml);
    w.out
}

/// Coding 1's body from its bytes.
pub(crate) fn decode_normals(body: &[u8]) -> Result<Normals<'_>> {
    let mut r = ByteReader::new(body, 0);
    let decimals = r.u8("decimals")?;
    let entries = r.varint("entries")?;
    let n = r.varint_max("index stream length", r.remaining() as u64)? as usize;
    let cidx = r.bytes(n, "index stream")?;
    let nrml = &body[body.len() - r.remaining()..];
    if decimals as u32 > crate::sections::nrml::MAX_DECIMALS {
        return Err(Error::corrupt(SECTION, format!("{decimals} decimals")));
    }
    Ok(Normals {
        decimals,
        entries,
        cidx,
        nrml,
    })
}

fn domain_code(d: Domain) -> u8 {
    match d {
        Domain::Vertex => 0,
        Domain::Face => 1,
        Domain::Corner => 2,
        Domain::File => 3,
    }
}

/// The CHAN payload of channel `head` whose values the encoder coded as the container
/// `nested`.
pub(crate) fn encode(head: &Head, nested: &[u8]) -> Vec<u8> {
    let name = head.name.as_bytes();
    let mut out = Vec::with_capacity(4 + name.len() + nested.len());
    out.push(name.len() as u8);
    out.extend_from_slice(name);
    out.extend_from_slice(&[
        domain_code(head.domain),
        head.value_type.code(),
        head.width,
        head.pad,
        head.coding,
    ]);
    let mut w = ByteWriter::new();
    w.varint(head.labels.len() as u64);
    for l in &head.labels {
        w.varint(l.len() as u64);
        w.out.extend_from_slice(l.as_bytes());
    }
    out.extend_from_slice(&w.out);
    out.extend_from_slice(nested);
    out
}

/// A CHAN payload's head and nested container.
pub(crate) fn decode(payload: &[u8]) -> Result<(Head, &[u8])> {
    let bad = |what: String| Error::corrupt(SECTION, what);
    let (&n, rest) = payload
        .split_first()
        .ok_or_else(|| bad("empty payload".into()))?;
    let n = n as usize;
    if rest.len() < n + 5 {
        return Err(bad("payload shorter than its name and fields".into()));
    }
    let name = std::str::from_utf8(&rest[..n])
        .map_err(|_| bad("a name that is not UTF-8".into()))?
        .to_string();
    let [d, t, width, pad, coding] = [rest[n], rest[n + 1], rest[n + 2], rest[n + 3], rest[n + 4]];
    let domain = match d {
        0 => Domain::Vertex,
        1 => Domain::Face,
        2 => Domain::Corner,
        3 => Domain::File,
        _ => return Err(bad(format!("domain {d}"))),
    };
    let value_type = ValueType::from_code(t).ok_or_else(|| bad(format!("value type {t}")))?;
    if !(1..=3).contains(&width) {
        return Err(bad(format!("width {width}")));
    }
    // Up to 2 to make 3 entries, and one more for none (coding 4).
    if pad > 2 + (coding == NESTED_NONE) as u8 {
        return Err(bad(format!("{pad} padding entries")));
    }
    let fits = match coding {
        NESTED => true,
        NORMALS => pad == 0 && width == 3 && domain == Domain::Corner,
        // Names per file (checked below: the channel has names).
        LISTED => pad == 0 && width == 1 && domain == Domain::File,
        LISTS => pad == 0 && width == 1 && domain != Domain::Corner,
        NESTED_NONE => pad >= 1 && domain == Domain::Corner,
        _ => false,
    };
    if !fits {
        return Err(bad(format!("coding {coding} of a {domain:?} channel")));
    }
    let body = &rest[n + 5..];
    let mut r = ByteReader::new(body, 0);
    // Each name takes at least its length byte.
    let count = r.varint_max("names", r.remaining() as u64)?;
    let mut labels = Vec::with_capacity(count as usize);
    for _ in 0..count {
        let len = r.varint_max("name length", r.remaining() as u64)? as usize;
        let l = std::str::from_utf8(r.bytes(len, "name")?)
            .map_err(|_| bad("a name that is not UTF-8".into()))?;
        labels.push(l.to_string());
    }
    Ok((
        Head {
            name,
            domain,
            value_type,
            width,
            pad,
            coding,
            labels,
        },
        &body[body.len() - r.remaining()..],
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn heads_round_trip_and_bad_fields_are_refused() {
        let h = Head {
            name: "red green blue".into(),
            domain: Domain::Corner,
            value_type: ValueType::U8,
            width: 3,
            pad: 1,
            coding: 0,
            labels: vec!["a".into(), "bc".into()],
        };
        let p = encode(&h, b"nested");
        let (back, nested) = decode(&p).unwrap();
        assert_eq!((back, nested), (h, &b"nested"[..]));
        for (i, v) in [(15, 4), (16, 9), (17, 0), (17, 4), (18, 3), (19, 2), (19, 1)] {
            let mut q = p.clone();
            q[i] = v;
            assert!(decode(&q).is_err(), "byte {i} = {v}");
        }
        assert!(decode(&p[..10]).is_err());
        assert!(decode(&p[..p.len() - 7]).is_err(), "a name cut");
        let n = Normals {
            decimals: 4,
            entries: 300,
            cidx: b"abc",
            nrml: b"defg",
        };
        assert_eq!(decode_normals(&encode_normals(&n)).unwrap(), n);
        assert!(decode_normals(&encode_normals(&n)[..4]).is_err());
        assert!(decode(&[]).is_err());
    }

    #[test]
    fn listed_names_round_trip_within_their_names() {
        let values = [[1, 0, 0], [-1, 0, 0], [0, 0, 0], [1, 0, 0]];
        let body = encode_listed(&values);
        assert_eq!(body, [4, 2, 0, 1, 2]);
        assert_eq!(decode_listed(&body, 2).unwrap(), values);
        // A value past the names, a cut, bytes after the values, a count past the body.
        assert!(decode_listed(&body, 1).is_err());
        assert!(decode_listed(&body[..4], 2).is_err());
        assert!(decode_listed(&[body.clone(), vec![0]].concat(), 2).is_err());
        assert!(decode_listed(&[200, 1], 2).is_err());
        // Only a per-file channel of one value per entry is listed.
        let h = |domain, width| Head {
            name: "lines".into(),
            domain,
            value_type: ValueType::Text,
            width,
            pad: 0,
            coding: LISTED,
            labels: vec!["# a".into()],
        };
        assert!(decode(&encode(&h(Domain::File, 1), &body)).is_ok());
        assert!(decode(&encode(&h(Domain::Face, 1), &body)).is_err());
        assert!(decode(&encode(&h(Domain::File, 2), &body)).is_err());
    }

    #[test]
    fn list_lengths_round_trip_and_list_channels_are_not_per_corner() {
        let body = encode_lists(&[3, 0, 300], b"nested");
        let (counts, total, nested) = decode_lists(&body).unwrap();
        assert_eq!((counts, total, nested), (vec![3, 0, 300], 303, &b"nested"[..]));
        // A count past the body, a length past 2^32 - 1.
        assert!(decode_lists(&[9, 1]).is_err());
        assert!(decode_lists(&[1, 0x80, 0x80, 0x80, 0x80, 0x10]).is_err());
        let h = |domain| Head {
            name: "weights".into(),
            domain,
            value_type: ValueType::F32,
            width: 1,
            pad: 0,
            coding: LISTS,
            labels: Vec::new(),
        };
        for d in [Domain::Vertex, Domain::Face, Domain::File] {
            assert!(decode(&encode(&h(d), &body)).is_ok(), "{d:?}");
        }
        assert!(decode(&encode(&h(Domain::Corner), &body)).is_err());
    }
}
