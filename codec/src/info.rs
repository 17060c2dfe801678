//! What a container holds, read without decoding any geometry (`subwave info`).

use crate::decoder::layout;
use crate::error::Result;
use crate::sections::head::{Header, Transform};
use crate::sections::levl;
use crate::Limits;
use subwave_container::{Container, SectionKind};

/// One section's place in a container.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SectionInfo {
    /// Its kind code, as text (`HEAD`, `BASE`, ...).
    pub kind: String,
    /// Bytes it occupies, overhead included.
    pub bytes: usize,
    /// A level section's coding mode (SPEC.md 10.1, 10.2: 0 plain, 1 normal frame, 2
    /// tangent, ..., 9 phased corrected; without the unbinned and zero-slot flags);
    /// `None` for other sections and for a subdivision fit's levels (10.4), which have no
    /// mode.
    pub mode: Option<u8>,
    /// Whether a level section is unbinned (SPEC.md 10.1).
    pub unbinned: bool,
    /// Whether a mode 9 level rounds its corrections jointly (SPEC.md 10.9).
    pub joint: bool,
    /// A level section's slots whose values are all 0 and left out of its stream
    /// (SPEC.md 10.1), in increasing order.
    pub zero_slots: Vec<u8>,
    /// An ATTR section's attribute (SPEC.md 11.3): its values per entry and how its
    /// nested container codes them; `None` for other sections.
    pub attribute: Option<AttributeInfo>,
    /// An ORDR section's method (SPEC.md 7): `lists`, `walks`, `base elements` or
    /// `face blocks and first use`; empty for other sections.
    pub order_method: String,
}

/// How an ATTR or CHAN section codes its attribute.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct AttributeInfo {
    /// The attribute's name (an ATTR section's, SPEC.md 11.3, may be empty; a CHAN
    /// section's channel name, 11.4).
    pub name: String,
    /// A CHAN section's domain: `vertex`, `face` or `corner`; empty for ATTR.
    pub domain: String,
    /// Values per entry (2 for UVs, 3 for colours or normals).
    pub width: u8,
    /// Entries (the nested mesh's vertices).
    pub entries: u64,
    /// The nested container's transform, as `info` names it (`fit`, `interp6`, ...).
    pub transform: String,
    /// A fit's rules in words (`linear boundaries, limit surface`); empty otherwise.
    pub rules: String,
}

/// A parsed header and section table, without decoding any geometry.
#[derive(Debug, Clone)]
pub struct Info {
    /// Format version of the container.
    pub version: u16,
    /// The header.
    pub header: Header,
    /// Sections, in order.
    pub sections: Vec<SectionInfo>,
    /// Total bytes.
    pub bytes: usize,
}

/// A section's entry in the section table: a level section's mode, unbinned flag, mode
/// 9's joint flag and zero slots read from its payload (SPEC.md 10.1, 10.9); none of them
/// under `transform` 9, whose level sections have no mode byte (10.4).
pub(crate) fn section_info(
    kind: SectionKind,
    bytes: usize,
    transform: Transform,
    payload: &[u8],
) -> SectionInfo {
    let fit = matches!(transform, Transform::Fit { .. });
    let level = kind == SectionKind::LEVEL && !fit;
    SectionInfo {
        kind: kind.to_string(),
        bytes,
        mode: level.then(|| levl::mode_of(payload)).flatten(),
        unbinned: level && levl::unbinned(payload),
        joint: level && levl::joint(payload),
        zero_slots: match level {
            true => {
                let z = levl::zero_slots(payload);
                (0..3).filter(|s| z >> s & 1 == 1).collect()
            }
            false => Vec::new(),
        },
        attribute: None,
        order_method: match kind {
            SectionKind::ORDER => crate::sections::ordr::method_name(payload).to_string(),
            _ => String::new(),
        },
    }
}

/// An ATTR payload's [`AttributeInfo`] (`order`: the main container's ORDR payload, for
/// a nested container that shares it); `None` when it does not parse.
fn attribute_info(payload: &[u8], limits: &Limits, order: Option<&[u8]>) -> Option<AttributeInfo> {
    let (width, name, nested) = crate::sections::attr::decode(payload, limits, order).ok()?;
    let c = Container::parse(&nested, limits).ok()?;
    let h = layout(&c, limits, true).ok()?;
    Some(AttributeInfo {
        name,
        domain: String::new(),
        width,
        entries: h.vertices,
        transform: h.transform.name().to_string(),
        rules: fit_rules(&h),
    })
}

/// A CHAN payload's [`AttributeInfo`] (its entries without padding); `None` when it does
/// not parse.
fn channel_info(payload: &[u8], limits: &Limits) -> Option<AttributeInfo> {
    use crate::sections::chan;
    let (head, rest) = chan::decode(payload).ok()?;
    let domain = head.domain.name().to_string();
    let (entries, transform, rules) = match head.coding {
        chan::NORMALS => {
            let n = chan::decode_normals(rest).ok()?;
            (n.entries, "predicted normals".to_string(), String::new())
        }
        chan::LISTS => {
            let (_, total, body) = chan::decode_lists(rest).ok()?;
            let c = Container::parse(body, limits).ok()?;
            let h = layout(&c, limits, true).ok()?;
            (
                total,
                format!("lists, {}", h.transform.name()),
                fit_rules(&h),
            )
        }
        chan::LISTED => {
            let n = chan::decode_listed(rest, head.labels.len()).ok()?.len();
            (n as u64, "listed".to_string(), String::new())
        }
        _ => {
            let c = Container::parse(rest, limits).ok()?;
            let h = layout(&c, limits, true).ok()?;
            let e = h.vertices.saturating_sub(head.pad as u64);
            (e, h.transform.name().to_string(), fit_rules(&h))
        }
    };
    Some(AttributeInfo {
        name: head.name,
        domain,
        width: head.width,
        entries,
        transform,
        rules,
    })
}

/// A fit's rules in words, as `info` prints them (empty for another transform).
pub fn fit_rules(h: &Header) -> String {
    let Transform::Fit {
        limit,
        corners,
        linear,
        bilinear,
        limit_corners,
        extra_levels,
        end_caps,
        ..
    } = h.transform
    else {
        return String::new();
    };
    let mut rules = Vec::new();
    // "N creased base edges (sharpness ...)": the sharpnesses (in levels, the first
    // three distinct) where listed, else every one is infinitely sharp.
    let listed = |n: usize, what: &str, sharpness: &[u32]| -> Option<String> {
        if n == 0 {
            return None;
        }
        if sharpness.is_empty() {
            return Some(format!("{n} creased base {what}"));
        }
        let mut v: Vec<String> = sharpness
            .iter()
            .map(|&s| format!("{:.4}", s as f64 / crate::transform::fit::SHARP_ONE as f64))
            .collect();
        v.dedup();
        if v.len() > 3 {
            v.truncate(3);
            v.push("...".into());
        }
        Some(format!(
            "{n} creased base {what} (sharpness {})",
            v.join(", ")
        ))
    };
    let n = h.creases.len();
    let edges = if n == 1 { "edge" } else { "edges" };
    rules.extend(listed(n, edges, &h.crease_sharpness));
    let n = h.vertex_creases.len();
    let vertices = if n == 1 { "vertex" } else { "vertices" };
    rules.extend(listed(n, vertices, &h.vertex_sharpness));
    let n = h.seams.len();
    if n > 0 {
        rules.push(format!(
            "glued at {n} seam cop{}",
            if n == 1 { "y" } else { "ies" }
        ));
    }
    if corners {
        rules.push("boundary corners kept".to_string());
    }
    if linear {
        rules.push("linear boundaries".to_string());
    }
    if bilinear {
        rules.push("linear everywhere".to_string());
    }
    if limit {
        rules.push("limit surface".to_string());
    }
    if limit_corners {
        rules.push("corners kept at the limit".to_string());
    }
    if let Some(e) = extra_levels {
        rules.push(format!(
            "the limit {e} level{} further, finite sharpness smooth there",
            if e == 1 { "" } else { "s" }
        ));
    }
    if let Some(q) = end_caps {
        rules.push(format!("end-cap patches from level {q}"));
    }
    rules.join(", ")
}

/// Reads the header and section table (SPEC.md 2, 5), checking every checksum.
pub fn inspect(bytes: &[u8], limits: &Limits) -> Result<Info> {
    let c = Container::parse(bytes, limits)?;
    let header = layout(&c, limits, true)?;
    let t = header.transform;
    let order = c
        .sections
        .iter()
        .find(|s| s.kind == SectionKind::ORDER)
        .map(|s| s.payload);
    Ok(Info {
        version: c.version,
        header,
        sections: c
            .sections
            .iter()
            .map(|s| {
                let mut i = section_info(s.kind, s.total_len(), t, s.payload);
                if s.kind == SectionKind::ATTRIBUTE {
                    i.attribute = attribute_info(s.payload, limits, order);
                }
                if s.kind == SectionKind::CHANNEL {
                    i.attribute = channel_info(s.payload, limits);
                }
                i
            })
            .collect(),
        bytes: bytes.len(),
    })
}
