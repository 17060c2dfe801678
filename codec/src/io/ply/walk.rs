//! A PLY file's template (SPEC.md 11): the walk over its header and body that marks
//! the coded values, and the vertex element's attributes (11.3).

use super::{
    line_len, parse_header, read_list, run_name, runs, to_coords, Body, Element, Mode, Num, Prop,
    Scalar,
};
use crate::io::template::{Attribute, Builder, Form};
use crate::quant::integerize;

/// The vertex element's attributes (SPEC.md 11.3), made in `b`: its scalar properties
/// but x, y, z, in runs of up to three of one type, each on the file's faces. Per
/// property of the vertex element, its attribute and place in it.
fn attributes(
    bytes: &[u8],
    mode: Mode,
    elements: &[Element],
    body_start: usize,
    b: &mut Builder<'_>,
) -> Option<Vec<Option<(usize, usize)>>> {
    let vertex = elements.iter().position(|e| e.name == "vertex")?;
    let props = &elements[vertex].props;
    let runs = runs(props, true);
    if runs.is_empty() {
        return None;
    }
    let mut place = vec![None; props.len()];
    for (r, &(first, len, _)) in runs.iter().enumerate() {
        for k in 0..len {
            place[first + k] = Some((r, k));
        }
    }
    // The values, as tokens (ASCII) or numbers.
    let n = elements[vertex].count as usize;
    let mut tokens: Vec<Vec<[&str; 3]>> = vec![Vec::new(); runs.len()];
    let mut nums: Vec<Vec<[Num; 3]>> = vec![Vec::new(); runs.len()];
    let mut body = Body {
        data: bytes,
        pos: body_start,
        mode,
    };
    for (e, el) in elements.iter().enumerate() {
        if e == vertex {
            // Room for the values, the axes past a run's length 0 of its type.
            for (r, &(_, _, ty)) in runs.iter().enumerate() {
                match mode {
                    Mode::Ascii => tokens[r] = vec![["0"; 3]; n],
                    _ => {
                        nums[r] = vec![[ty.zero(); 3]; n];
                    }
                }
            }
        }
        for v in 0..el.count as usize {
            for (i, p) in el.props.iter().enumerate() {
                match (p, place.get(i).copied().flatten().filter(|_| e == vertex)) {
                    (Prop::Scalar(..), Some((r, k))) if mode == Mode::Ascii => {
                        tokens[r][v][k] = body.token().ok()?;
                    }
                    (Prop::Scalar(_, ty), Some((r, k))) => nums[r][v][k] = body.num(*ty).ok()?,
                    (Prop::Scalar(_, ty), None) => body.skip(*ty).ok()?,
                    (Prop::List(_, cty, ity), _) => read_list(&mut body, *cty, *ity, None).ok()?,
                }
            }
            if mode == Mode::Ascii {
                body.end_line();
            }
        }
        if e == vertex {
            break;
        }
    }
    let mesh = b.mesh();
    let mut numbers = Vec::with_capacity(runs.len());
    for (r, &(first, len, ty)) in runs.iter().enumerate() {
        let name = run_name(props, first, len);
        let raw = match (mode, ty) {
            (Mode::Ascii, _) => {
                let g = crate::io::text_values(&tokens[r])
                    .and_then(|v| b.attribute(Attribute::on_faces(len, v, mesh).named(&name)));
                numbers.push(g);
                continue;
            }
            _ => to_coords(&nums[r]).ok()?,
        };
        let g = integerize(&raw, None)
            .ok()
            .and_then(|v| b.attribute(Attribute::on_faces(len, v, mesh).named(&name)));
        numbers.push(g);
    }
    Some(
        place
            .into_iter()
            .map(|p| p.and_then(|(r, k)| Some((numbers[r]?, k))))
            .collect(),
    )
}

/// Per property of `el`, the axis it is (x, y, z of a `vertex` element), if the axes
/// stand in that order.
fn axes(el: &Element, is_vertex: bool) -> Option<Vec<Option<usize>>> {
    let axes: Vec<Option<usize>> = el
        .props
        .iter()
        .map(|p| match p {
            Prop::Scalar(n, _) if is_vertex => ["x", "y", "z"].iter().position(|a| a == n),
            _ => None,
        })
        .collect();
    let n = axes.iter().flatten().count();
    axes.iter()
        .flatten()
        .copied()
        .eq(0..3usize.min(n))
        .then_some(axes)
}

/// Walks a PLY file for its template (SPEC.md 11): the header and every property but the
/// vertices' x, y, z (in that order) and the faces' first vertex index list stay as they
/// are. `None` where the walk cannot follow the file (coordinates out of order, integer
/// coordinates in a binary file, index lists of other than 32-bit items).
pub(in crate::io) fn template(bytes: &[u8], b: &mut Builder<'_>) -> Option<()> {
    let (mode, elements, body_start, _) = parse_header(bytes).ok()?;
    let places = attributes(bytes, mode, &elements, body_start, b).unwrap_or_default();
    b.literal(&bytes[..body_start]);
    let mut pos = body_start;
    let big = mode == Mode::Be;
    // An ASCII token: the whitespace before it literal, its span returned.
    let token = |pos: &mut usize, b: &mut Builder<'_>| -> Option<(usize, usize)> {
        let s = *pos
            + bytes[*pos..]
                .iter()
                .position(|c| !c.is_ascii_whitespace())?;
        let e = s + bytes[s..]
            .iter()
            .position(|c| c.is_ascii_whitespace())
            .unwrap_or(bytes.len() - s);
        b.literal(&bytes[*pos..s]);
        *pos = e;
        Some((s, e))
    };
    for el in &elements {
        let is_vertex = el.name == "vertex";
        let is_face = el.name == "face";
        let axes = axes(el, is_vertex)?;
        let place = |i: usize| match is_vertex {
            true => places.get(i).copied().flatten(),
            false => None,
        };
        for _ in 0..el.count {
            let mut took_list = false;
            for (i, (p, axis)) in el.props.iter().zip(&axes).enumerate() {
                match (p, mode) {
                    (Prop::Scalar(..), Mode::Ascii) => {
                        let (s, e) = token(&mut pos, b)?;
                        match (axis, place(i)) {
                            (Some(_), _) => b.coord_text(&bytes[s..e]),
                            (None, Some((g, _))) => b.attr_value(g, Form::Text, &bytes[s..e]),
                            (None, None) => b.literal(&bytes[s..e]),
                        }
                    }
                    (Prop::Scalar(_, ty), _) => {
                        let raw = bytes.get(pos..pos + ty.size())?;
                        pos += ty.size();
                        let signed = matches!(ty, Scalar::I8 | Scalar::I16 | Scalar::I32);
                        let form = Form::binary(ty.size(), ty.is_float(), signed, big);
                        match (axis, place(i), form) {
                            (Some(_), ..) if ty.is_float() => b.coord_binary(raw, big),
                            (Some(_), ..) => return None,
                            (None, Some((g, _)), Some(f)) => b.attr_value(g, f, raw),
                            (None, ..) => b.literal(raw),
                        }
                    }
                    (Prop::List(name, cty, ity), _) => {
                        let want = is_face
                            && !took_list
                            && (name == "vertex_indices" || name == "vertex_index");
                        took_list |= want;
                        let n = if mode == Mode::Ascii {
                            let (s, e) = token(&mut pos, b)?;
                            b.literal(&bytes[s..e]);
                            std::str::from_utf8(&bytes[s..e])
                                .ok()?
                                .parse::<usize>()
                                .ok()?
                        } else {
                            let raw = bytes.get(pos..pos + cty.size())?;
                            pos += cty.size();
                            b.literal(raw);
                            let mut body = Body {
                                data: raw,
                                pos: 0,
                                mode,
                            };
                            usize::try_from(body.int(*cty, "list count").ok()?).ok()?
                        };
                        for _ in 0..n {
                            if mode == Mode::Ascii {
                                let (s, e) = token(&mut pos, b)?;
                                match want {
                                    true => b.index_text(&bytes[s..e], 0),
                                    false => b.literal(&bytes[s..e]),
                                }
                            } else {
                                let raw = bytes.get(pos..pos + ity.size())?;
                                pos += ity.size();
                                match (want, ity.size()) {
                                    (true, 4) => b.index_binary(raw, big),
                                    (true, _) => return None,
                                    (false, _) => b.literal(raw),
                                }
                            }
                        }
                    }
                }
            }
            if mode == Mode::Ascii {
                // The rest of the record's line, as the reader skips it.
                let rest = &bytes[pos..];
                let end = line_len(rest);
                b.literal(&rest[..end]);
                pos += end;
            }
        }
    }
    b.literal(&bytes[pos..]);
    Some(())
}
