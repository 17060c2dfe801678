//! JSON descriptions of containers, as `subwave info --json` prints them and the Python
//! package's `info` returns them.

use serde_json::{json, Value};
use subwave_codec::{FloatWidth, Info, Quantization, Transform};

/// Bits per vertex of `bytes` for `vertices` (0 for an empty mesh).
pub fn bits_per_vertex(bytes: usize, vertices: u64) -> f64 {
    if vertices == 0 {
        0.0
    } else {
        bytes as f64 * 8.0 / vertices as f64
    }
}

/// A quantisation: `{"kind": "decimal", "decimals": d}`, `{"kind": "float", "width": 32
/// or 64, "exponent": e}` or `{"kind": "grid", "bits", "origin", "step"}`.
pub fn quantization(q: &Quantization) -> Value {
    match *q {
        Quantization::Decimal { decimals } => json!({"kind": "decimal", "decimals": decimals}),
        Quantization::Float { width, exponent } => json!({
            "kind": "float",
            "width": match width { FloatWidth::F32 => 32, FloatWidth::F64 => 64 },
            "exponent": exponent,
        }),
        Quantization::Grid { bits, origin, step } => json!({
            "kind": "grid", "bits": bits, "origin": origin, "step": step,
        }),
    }
}

/// Everything [`crate::inspect`] tells of a container: counts, family, transform,
/// quantisation, flags and each section's kind and size (a level section's mode too).
pub fn info(info: &Info) -> Value {
    let h = &info.header;
    json!({
        "format_version": info.version,
        "vertices": h.vertices,
        "faces": h.faces,
        "corners": h.corners,
        "base_vertices": h.base_vertices,
        "base_faces": h.base_faces,
        "levels": h.levels,
        "family": h.family.name(),
        "poles": h.poles,
        "disc_transform": h.disc.name(),
        "transform": h.transform.name(),
        "fit_bits": match h.transform {
            Transform::Fit { bits, .. } => Some(bits),
            _ => None,
        },
        "fit_limit": match h.transform {
            Transform::Fit { limit, .. } => Some(limit),
            _ => None,
        },
        "fit_corners": match h.transform {
            Transform::Fit { corners, .. } => Some(corners),
            _ => None,
        },
        "fit_linear_boundaries": match h.transform {
            Transform::Fit { linear, .. } => Some(linear),
            _ => None,
        },
        "fit_linear_everywhere": match h.transform {
            Transform::Fit { bilinear, .. } => Some(bilinear),
            _ => None,
        },
        "fit_limit_corners": match h.transform {
            Transform::Fit { limit_corners, .. } => Some(limit_corners),
            _ => None,
        },
        "fit_extra_levels": match h.transform {
            Transform::Fit { extra_levels, .. } => extra_levels,
            _ => None,
        },
        "fit_end_caps": match h.transform {
            Transform::Fit { end_caps, .. } => end_caps,
            _ => None,
        },
        "creases": h.creases,
        "crease_sharpness": h.crease_sharpness,
        "vertex_creases": h.vertex_creases,
        "vertex_sharpness": h.vertex_sharpness,
        "seams": h.seams.iter().map(|&(c, p)| [c, p]).collect::<Vec<_>>(),
        "quantization": quantization(&h.quantization),
        "keep_order": h.has_order,
        "value_map": h.has_value_map,
        "sections": info.sections.iter().map(|s| match s.mode {
            Some(m) => json!({"kind": s.kind, "bytes": s.bytes, "mode": m, "unbinned": s.unbinned, "joint": s.joint, "zero_slots": s.zero_slots}),
            None => match &s.attribute {
                Some(a) => json!({"kind": s.kind, "bytes": s.bytes, "attribute": {"name": a.name, "domain": a.domain, "width": a.width, "entries": a.entries, "transform": a.transform, "fit_rules": a.rules}}),
                None if !s.order_method.is_empty() => json!({"kind": s.kind, "bytes": s.bytes, "order_method": s.order_method}),
                None => json!({"kind": s.kind, "bytes": s.bytes}),
            },
        }).collect::<Vec<_>>(),
        "bytes": info.bytes,
        "bits_per_vertex": bits_per_vertex(info.bytes, h.vertices),
    })
}
