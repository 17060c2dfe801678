//! The ATTR section (SPEC.md 11.3): one vertex attribute of a file (an OBJ's `vt`
//! table or vertex colours, a PLY vertex element's other properties) coded as the
//! positions of a mesh of its own, whose faces are the attribute's (the corners' `vt`
//! numbers; the file's faces for per-vertex values). The attribute mesh has the file's
//! subdivision connectivity, cut along the seams, so its values go through the same
//! hierarchy and wavelets as positions do: the payload is a nested container.

use std::borrow::Cow;

use crate::error::{Error, Result};
use crate::Limits;
use subwave_container::{Container, ContainerWriter, SectionKind};

const SECTION: &str = "ATTR";

/// Flag bit of the payload's second byte: the nested container's ORDR section is the
/// main container's, left out.
const SHARED_ORDER: u8 = 1;

/// The ATTR payload of an attribute `name` (at most 255 bytes are kept) of `width`
/// values per entry whose mesh the encoder coded, with its order kept, as the container
/// `nested`.
pub(crate) fn encode(width: u8, name: &str, nested: &[u8]) -> Vec<u8> {
    let mut n = name.len().min(255);
    while !name.is_char_boundary(n) {
        n -= 1;
    }
    let mut out = Vec::with_capacity(3 + n + nested.len());
    out.extend_from_slice(&[width, 0, n as u8]);
    out.extend_from_slice(&name.as_bytes()[..n]);
    out.extend_from_slice(nested);
    out
}

/// The bytes before the nested container: width, flags, the name's length and the
/// name; `None` when the payload is shorter.
fn head_len(payload: &[u8]) -> Option<usize> {
    let n = *payload.get(2)? as usize;
    (payload.len() >= 3 + n).then_some(3 + n)
}

/// `payload` (from [`encode`]) with its nested container's ORDR section left out when
/// that section's payload is `order`, the main container's: an attribute on the file's
/// own faces in the file's order has the same hierarchy and order as the positions.
pub(crate) fn share_order<'a>(payload: &'a [u8], order: Option<&[u8]>) -> Cow<'a, [u8]> {
    let Some(h) = head_len(payload) else {
        return Cow::Borrowed(payload);
    };
    let (Some(order), nested) = (order, &payload[h..]) else {
        return Cow::Borrowed(payload);
    };
    let Ok(c) = Container::parse(nested, &Limits::default()) else {
        return Cow::Borrowed(payload);
    };
    if !c
        .sections
        .iter()
        .any(|s| s.kind == SectionKind::ORDER && s.payload == order)
    {
        return Cow::Borrowed(payload);
    }
    let mut w = ContainerWriter::new();
    for s in &c.sections {
        if s.kind != SectionKind::ORDER && s.kind != SectionKind::END {
            w.section(s.kind, s.payload);
        }
    }
    let mut out = payload[..h].to_vec();
    out[1] |= SHARED_ORDER;
    out.extend_from_slice(&w.finish());
    Cow::Owned(out)
}

/// An ATTR payload's width, name and nested container (with the main container's
/// ORDR payload `order` back in it where it is shared), for the decoder to decode.
pub(crate) fn decode<'a>(
    payload: &'a [u8],
    limits: &Limits,
    order: Option<&[u8]>,
) -> Result<(u8, String, Cow<'a, [u8]>)> {
    let h = head_len(payload)
        .ok_or_else(|| Error::corrupt(SECTION, "payload shorter than its head"))?;
    let name = std::str::from_utf8(&payload[3..h])
        .map_err(|_| Error::corrupt(SECTION, "a name that is not UTF-8"))?
        .to_string();
    let (width, flags, nested) = (&payload[0], &payload[1], &payload[h..]);
    if !(1..=3).contains(width) || flags & !SHARED_ORDER != 0 {
        return Err(Error::corrupt(
            SECTION,
            format!("attribute width {width}, flags {flags}"),
        ));
    }
    if flags & SHARED_ORDER == 0 {
        return Ok((*width, name, Cow::Borrowed(nested)));
    }
    // The main container's ORDR section goes back in, before the end marker.
    let order = order.ok_or_else(|| Error::corrupt(SECTION, "a shared order without ORDR"))?;
    let c = Container::parse(nested, limits)
        .map_err(|e| Error::corrupt(SECTION, format!("nested container: {e}")))?;
    let mut w = ContainerWriter::new();
    for s in c.sections.iter().filter(|s| s.kind != SectionKind::END) {
        w.section(s.kind, s.payload);
    }
    w.section(SectionKind::ORDER, order);
    Ok((*width, name, Cow::Owned(w.finish())))
}
