//! The decoder: one straight pipeline from the container to the mesh (SPEC.md 2-10).

use crate::error::{Error, Result};
use crate::io::template::{Attribute, Channels};
use crate::mesh::{Mesh, MAX_COORD};
use crate::quant::Quantization;
use crate::sections::head::{Header, Transform};
use crate::sections::vmap::ValueMap;
use crate::sections::{attr, chan, cidx, nrml};
use crate::sections::{base, fbit, levl, ordr, tmpl};
use crate::topology::Family;
use crate::topology::{self, Level, Topo};
use crate::transform::fit;
use crate::transform::level::{LevelTransform, Scheme};
use crate::transform::{Stencils, Wavelet};
use crate::Limits;
use subwave_container::{Container, SectionKind};

/// How to decode.
#[derive(Debug, Clone, Default)]
pub struct DecodeOptions {
    /// Bounds on what the container may ask for.
    pub limits: Limits,
    /// Decode only up to this level (0 = the base mesh). The container may then be cut
    /// off anywhere after that level's section.
    pub max_level: Option<u8>,
    /// Threads the decoder may use (0 and 1: the calling thread only). The mesh is the
    /// same for every count.
    pub threads: usize,
}

/// The result of [`decode`].
#[derive(Debug, Clone)]
pub struct Decoded {
    /// The mesh, in the input's vertex and face order when the container has an ORDR
    /// section and the finest level was decoded, in canonical order otherwise; with its
    /// attribute channels (CHAN sections, SPEC.md 11.4) when the finest level was
    /// decoded. A container that keeps a file's own bytes has its attributes in them:
    /// [`Decoded::file`], read again, gives them as channels.
    pub mesh: Mesh,
    /// How integers map to values.
    pub quantization: Quantization,
    /// The container's header.
    pub header: Header,
    /// The level decoded (0 = base mesh).
    pub level: u8,
    /// Whether the vertices are in the input's order.
    pub input_order: bool,
    /// The input file's template (SPEC.md 11), when the container keeps the file's own
    /// bytes and the mesh is in its order: [`Decoded::file`] gives the file back.
    pub template: Option<Vec<u8>>,
    /// The template's channels (SPEC.md 11.1, 11.2).
    pub(crate) channels: Channels,
}

impl Decoded {
    /// The input file, byte for byte, when the container keeps its own bytes (a
    /// container written by [`crate::encode_file`], decoded whole).
    pub fn file(&self) -> Option<Result<Vec<u8>>> {
        let mut out = Vec::new();
        Some(self.write_file(&mut out)?.map(|_| out))
    }

    /// Writes the input file, byte for byte, to `out` as [`Decoded::file`] makes it,
    /// without holding it whole (a large file's memory); the bytes written. `None`
    /// when the container does not keep the file. On an error (a template that does
    /// not match its channels) part of the file may have been written.
    pub fn write_file<W: std::io::Write>(&self, out: W) -> Option<Result<u64>> {
        let t = self.template.as_ref()?;
        Some(crate::io::template::expand_into(
            t,
            &self.mesh,
            &self.quantization,
            &self.channels,
            out,
        ))
    }
}

pub(crate) fn expect_kind(
    c: &Container<'_>,
    i: usize,
    kind: SectionKind,
    what: &str,
) -> Result<()> {
    match c.sections.get(i) {
        Some(s) if s.kind == kind => Ok(()),
        Some(s) => Err(subwave_container::Error::malformed(
            s.offset,
            format!("expected the {what} section ({kind}), found {}", s.kind),
        )
        .into()),
        None => Err(subwave_container::Error::Truncated {
            what: format!("the {what} section ({kind}) is missing"),
        }
        .into()),
    }
}

/// Checks the section sequence (SPEC.md 2.4) and returns the header. With `whole`, the
/// container must hold every section; otherwise a prefix is fine.
pub(crate) fn layout(c: &Container<'_>, limits: &Limits, whole: bool) -> Result<Header> {
    expect_kind(c, 0, SectionKind::HEADER, "header")?;
    let h = Header::read(c.sections[0].payload, c.sections[0].offset + 8, limits)?;
    let mut expected = Vec::new();
    if h.has_value_map {
        expected.push((SectionKind::VALUE_MAP, "value map"));
    }
    expected.push((SectionKind::BASE, "base mesh"));
    expected.extend((0..h.levels).map(|_| (SectionKind::LEVEL, "level")));
    if h.has_float_bits {
        expected.push((SectionKind::FLOAT_BITS, "float bits"));
    }
    if h.has_order {
        expected.push((SectionKind::ORDER, "vertex order"));
    }
    if h.has_template {
        expected.push((SectionKind::TEMPLATE, "file template"));
    }
    if h.has_corner_indices {
        expected.push((SectionKind::CORNER_INDICES, "corner index channels"));
    }
    if h.has_normals {
        expected.push((SectionKind::NORMALS, "normal components"));
    }
    // As many sections of `kind` as stand next.
    let run = |expected: &mut Vec<(SectionKind, &'static str)>, kind, what| {
        let at = expected.len() + 1;
        let n = c
            .sections
            .iter()
            .skip(at)
            .take_while(|s| s.kind == kind)
            .count();
        expected.extend((0..n).map(|_| (kind, what)));
    };
    // Attribute sections (SPEC.md 11.3) after a template, then named attribute channels
    // (11.4).
    if h.has_template {
        run(&mut expected, SectionKind::ATTRIBUTE, "attribute");
    }
    run(&mut expected, SectionKind::CHANNEL, "attribute channel");
    expected.push((SectionKind::END, "end marker"));
    for (i, &(kind, what)) in expected.iter().enumerate() {
        if !whole && i + 1 >= c.sections.len() {
            break;
        }
        expect_kind(c, i + 1, kind, what)?;
    }
    if c.sections.len() > expected.len() + 1 {
        let s = &c.sections[expected.len() + 1];
        return Err(
            subwave_container::Error::malformed(s.offset, "section after the end marker").into(),
        );
    }
    Ok(h)
}

/// Decodes a container (SPEC.md 2-10).
pub fn decode(bytes: &[u8], opts: &DecodeOptions) -> Result<Decoded> {
    decode_inner(bytes, opts, false)
}

/// Decodes an attribute's nested container (SPEC.md 11.3): one that keeps no file of
/// its own, so nesting stops there.
fn decode_nested(bytes: &[u8], opts: &DecodeOptions) -> Result<Decoded> {
    decode_inner(bytes, opts, true)
}

fn decode_inner(bytes: &[u8], opts: &DecodeOptions, nested: bool) -> Result<Decoded> {
    let limits = &opts.limits;
    let c = if opts.max_level.is_some() {
        Container::parse_prefix(bytes, limits)?
    } else {
        Container::parse(bytes, limits)?
    };
    let h = layout(&c, limits, opts.max_level.is_none())?;
    if nested && h.has_template {
        return Err(Error::corrupt("ATTR", "a nested container keeps a file"));
    }
    // Decompression-bomb guard (SPEC.md 2.5): what the header asks for, per byte given.
    let allowance = (bytes.len() as u64)
        .max(64)
        .saturating_mul(limits.max_expansion);
    if h.memory_estimate() > allowance {
        return Err(subwave_container::Error::Limit {
            what: "decoder memory for a container this size (bytes; see Limits::max_expansion)",
            requested: h.memory_estimate(),
            limit: allowance,
        }
        .into());
    }
    // The value map (SPEC.md 3.1); the other sections then sit where they do without one.
    let mut c = c;
    let vmap = if h.has_value_map {
        if c.sections.len() < 2 {
            return Err(subwave_container::Error::Truncated {
                what: "the value map section (VMAP) is missing".into(),
            }
            .into());
        }
        let s = c.sections.remove(1);
        Some(ValueMap::decode(s.payload, h.vertices)?)
    } else {
        None
    };
    let level = opts.max_level.map_or(h.levels, |k| k.min(h.levels));
    // Sections needed: header, base, `level` levels.
    let needed = 2 + level as usize;
    if c.sections.len() < needed {
        return Err(subwave_container::Error::Truncated {
            what: format!(
                "level {level} needs {needed} sections, the file holds {} whole ones",
                c.sections.len()
            ),
        }
        .into());
    }
    let bound = if h.levels == 0 {
        MAX_COORD
    } else {
        levl::MAX_LIFTED
    };
    let base = base::decode(
        c.sections[1].payload,
        h.base_vertices,
        h.base_faces,
        h.base_corners,
        bound,
    )?;
    // The base faces, for an order coded by the hierarchy's base elements or levels
    // (SPEC.md 7.3 to 7.5).
    let by_elements = (h.has_order
        && level == h.levels
        && level > 0
        && matches!(h.family, Family::Cc | Family::Sqrt2 | Family::Polar))
    .then(|| {
        (
            base.vertex_count(),
            base.face_starts.clone(),
            base.faces.clone(),
        )
    });
    let mut mesh = match h.transform {
        _ if h.levels == 0 => base,
        Transform::Wavelet(w) => synthesise_levels(&c, &h, base, w, level, opts.threads)?,
        Transform::Fit {
            bits,
            limit,
            corners,
            linear,
            bilinear,
            limit_corners,
            extra_levels,
            end_caps,
        } => {
            let rules = fit::Rules {
                limit,
                corners,
                linear,
                bilinear,
                limit_corners,
                extra_levels,
                end_caps,
                ..fit::Rules::default()
            };
            synthesise_fit(&c, &h, base, bits, &rules, level)?
        }
        Transform::None => return Err(Error::Unsupported("levels without a transform".into())),
    };
    if let Some(m) = &vmap {
        m.values(&mut mesh.positions, level == h.levels)?;
    }
    // Binary floats below their grid (SPEC.md 3.2), at the finest level.
    let after_levels = 2 + h.levels as usize;
    if let (true, true, Quantization::Float { width, exponent }) =
        (h.has_float_bits, level == h.levels, h.quantization)
    {
        let s = c.sections.get(after_levels).ok_or_else(|| {
            Error::from(subwave_container::Error::Truncated {
                what: "the float bits section (FBIT) is missing".into(),
            })
        })?;
        mesh.floats = fbit::decode(s.payload, &mesh.positions, width, exponent)?;
    }
    let mut input_order = false;
    let ordr_at = after_levels + h.has_float_bits as usize;
    let mut order_payload = None;
    if h.has_order && level == h.levels {
        if let Some(s) = c.sections.get(ordr_at) {
            let faces = ordr::Faces {
                nv: mesh.vertex_count(),
                starts: &mesh.face_starts,
                idx: &mesh.faces,
                hierarchy: by_elements
                    .as_ref()
                    .map(|(nv, starts, idx)| ordr::Hierarchy {
                        nv: *nv,
                        starts,
                        idx,
                        levels: h.levels as u32,
                        family: h.family,
                        poles: &h.poles,
                    }),
            };
            let o = ordr::decode(s.payload, faces)?;
            order_payload = Some(s.payload);
            mesh = restore_order(&mesh, &o);
            input_order = true;
        }
    }
    let (template, channels) = match input_order && h.has_template {
        true => {
            let own = FileSections {
                at: ordr_at + 1,
                allowance,
                limits,
                order: order_payload,
            };
            file_sections(&c, own, &h, &mesh)?
        }
        false => (None, Channels::default()),
    };
    let chans = c.sections.iter().filter(|s| s.kind == SectionKind::CHANNEL);
    if nested && chans.clone().next().is_some() {
        return Err(Error::corrupt("CHAN", "a nested container has channels"));
    }
    if level == h.levels {
        for s in chans {
            let a = channel(s.payload, limits, &mesh)?;
            mesh.attributes.push(a);
        }
    }
    Ok(Decoded {
        mesh,
        quantization: h.quantization,
        header: h,
        level,
        input_order,
        template,
        channels,
    })
}

/// Where the sections that keep a file's own bytes start, and what decoding them
/// needs: the decompression-bomb allowance, the limits, the main ORDR payload.
struct FileSections<'a> {
    at: usize,
    allowance: u64,
    limits: &'a Limits,
    order: Option<&'a [u8]>,
}

/// The sections that keep the file's own bytes, from section `at` on (SPEC.md 11): the
/// template, within the decompression-bomb allowance, and its channels (CIDX, NRML,
/// ATTR), for `mesh` in the input's order.
fn file_sections(
    c: &Container<'_>,
    own: FileSections<'_>,
    h: &Header,
    mesh: &Mesh,
) -> Result<(Option<Vec<u8>>, Channels)> {
    let FileSections {
        mut at,
        allowance,
        limits,
        order,
    } = own;
    let mut channels = Channels::default();
    let Some(s) = c.sections.get(at) else {
        return Ok((None, channels));
    };
    let template = tmpl::decode(s.payload, s.offset, allowance)?;
    at += 1;
    if let (Some(s), true) = (c.sections.get(at), h.has_corner_indices) {
        channels.indices = cidx::decode(s.payload, mesh)?;
        at += 1;
    }
    if let (Some(s), true) = (c.sections.get(at), h.has_normals) {
        let count = crate::io::template::normal_markers(&template);
        channels.normals = nrml::decode(s.payload, mesh, &channels.indices, count)?;
        at += 1;
    }
    while let Some(s) = c
        .sections
        .get(at)
        .filter(|s| s.kind == SectionKind::ATTRIBUTE)
    {
        channels
            .attributes
            .push(attribute(s.payload, limits, order)?);
        at += 1;
    }
    Ok((Some(template), channels))
}

/// An attribute from its ATTR payload (SPEC.md 11.3), `order` being the main
/// container's ORDR payload: the nested container must keep its order and nothing of a
/// file of its own.
fn attribute(payload: &[u8], limits: &Limits, order: Option<&[u8]>) -> Result<Attribute> {
    let (width, name, nested) = attr::decode(payload, limits, order)?;
    let opts = DecodeOptions {
        limits: limits.clone(),
        ..DecodeOptions::default()
    };
    let d = decode_nested(&nested, &opts)
        .map_err(|e| Error::corrupt("ATTR", format!("nested container: {e}")))?;
    if !d.input_order && d.mesh.vertex_count() > 0 {
        return Err(Error::corrupt("ATTR", "the nested container has no order"));
    }
    Ok(Attribute {
        name,
        width,
        mesh: d.mesh,
        q: d.quantization,
    })
}

/// A named attribute channel from its CHAN payload (SPEC.md 11.4), for `mesh` (the
/// decoded mesh, in the order the channel was coded in): the nested container must keep
/// its order and its mesh fit the channel's domain.
fn channel(payload: &[u8], limits: &Limits, mesh: &Mesh) -> Result<crate::mesh::Attribute> {
    use crate::mesh::Domain;
    let (head, nested) = chan::decode(payload)?;
    let bad = |what: &str| Error::corrupt("CHAN", format!("'{}': {what}", head.name));
    if head.coding == chan::NORMALS {
        return predicted_normals(head, nested, mesh);
    }
    // A nested container, decoded whole in its input order.
    let ordered = |body: &[u8]| -> Result<Decoded> {
        let opts = DecodeOptions {
            limits: limits.clone(),
            ..DecodeOptions::default()
        };
        let d = decode_nested(body, &opts).map_err(|e| bad(&format!("nested container: {e}")))?;
        if !d.input_order && d.mesh.vertex_count() > 1 {
            return Err(bad("the nested container has no order"));
        }
        Ok(d)
    };
    if head.coding == chan::LISTS {
        if !head.labels.is_empty() {
            return Err(bad("lists of names"));
        }
        let (counts, total, body) = chan::decode_lists(nested)?;
        let d = ordered(body)?;
        let m = d.mesh;
        if total != m.vertex_count() as u64 || !m.faces.is_empty() || counts.is_empty() {
            return Err(bad("its lists do not fit their values"));
        }
        if m.positions.iter().any(|p| p[1] != 0 || p[2] != 0) {
            return Err(bad("values past the channel's width"));
        }
        return channel_of(head, (m.positions, m.floats, d.quantization), counts, mesh);
    }
    if head.coding == chan::LISTED {
        if head.labels.is_empty() {
            return Err(bad("listed values of a channel without names"));
        }
        let values = chan::decode_listed(nested, head.labels.len())?;
        let q = Quantization::Decimal { decimals: 0 };
        return channel_of(head, (values, Vec::new(), q), Vec::new(), mesh);
    }
    let d = ordered(nested)?;
    let mut m = d.mesh;
    // A corner channel's padding entries (zeros) go.
    let keep = m.positions.len().saturating_sub(head.pad as usize);
    let padding = &m.positions[keep..];
    // With coding 4 the last padding entry stands for none: corners that use it have
    // no entry.
    let none = (head.coding == chan::NESTED_NONE)
        .then(|| m.positions.len().checked_sub(1))
        .flatten();
    if head.pad > 0
        && (head.domain != Domain::Corner
            || padding.len() != head.pad as usize
            || padding.iter().any(|p| *p != [0; 3])
            || m.faces
                .iter()
                .any(|&i| i as usize >= keep && Some(i as usize) != none))
    {
        return Err(bad("padding entries that are no padding"));
    }
    if let Some(n) = none {
        m.faces
            .iter_mut()
            .filter(|i| **i as usize == n)
            .for_each(|i| *i = crate::mesh::NO_ENTRY);
    }
    m.positions.truncate(keep);
    m.floats.truncate(keep);
    let fits = match head.domain {
        Domain::Vertex => m.positions.len() == mesh.vertex_count() && m.faces == mesh.faces,
        Domain::Face => m.positions.len() == mesh.face_count() && m.faces.is_empty(),
        Domain::File => m.faces.is_empty(),
        Domain::Corner => m.face_starts == mesh.face_starts,
    } && (m.face_starts == mesh.face_starts || m.faces.is_empty());
    if !fits {
        return Err(bad("its entries or faces do not fit the mesh"));
    }
    if m.positions
        .iter()
        .any(|p| p[head.width as usize..].iter().any(|&c| c != 0))
    {
        return Err(bad("values past the channel's width"));
    }
    let indices = match head.domain {
        Domain::Corner => m.faces,
        _ => Vec::new(),
    };
    let values = (m.positions, m.floats, d.quantization);
    channel_of(head, values, indices, mesh)
}

/// The channel of CHAN head `head` with `values` (integers, float bits, quantisation)
/// and corner `indices`, checked against `mesh`: an integer type's values in its range,
/// on an integer grid; names, entries and indices that fit.
fn channel_of(
    head: chan::Head,
    (values, floats, quantization): (Vec<[i64; 3]>, Vec<[u64; 3]>, Quantization),
    indices: Vec<u32>,
    mesh: &Mesh,
) -> Result<crate::mesh::Attribute> {
    let a = crate::mesh::Attribute {
        labels: head.labels,
        name: head.name,
        domain: head.domain,
        value_type: head.value_type,
        width: head.width,
        values,
        floats,
        quantization,
        indices,
    };
    a.validate(mesh)
        .map_err(|e| Error::corrupt("CHAN", e.to_string()))?;
    Ok(a)
}

/// A CHAN section's channel in coding 1 (SPEC.md 11.4): unit normals per corner, their
/// entries' numbers from a CIDX stream, their values predicted from `mesh`'s geometry in
/// an NRML stream.
fn predicted_normals(head: chan::Head, body: &[u8], mesh: &Mesh) -> Result<crate::mesh::Attribute> {
    let bad = |what: &str| Error::corrupt("CHAN", format!("'{}': {what}", head.name));
    let n = chan::decode_normals(body)?;
    let corners = mesh.corner_count();
    if n.entries > corners as u64 {
        return Err(bad("more entries than corners"));
    }
    let idx = cidx::decode(n.cidx, mesh)?;
    let every = |c: &cidx::IndexChannel| c.corners.len() == corners;
    if idx.channels.len() != 2 || !idx.channels[0].corners.is_empty() || !every(&idx.channels[1]) {
        return Err(bad("the index stream is not one number per corner"));
    }
    let numbers = &idx.channels[1].values;
    if numbers.iter().any(|&e| e == 0 || e as u64 > n.entries) {
        return Err(bad("a corner's entry past the entries"));
    }
    let comps = nrml::decode(n.nrml, mesh, &idx, n.entries as usize * 3)?;
    if comps
        .iter()
        .any(|c| c.decimals != n.decimals as u32 || c.negative_zero)
    {
        return Err(bad("a component of other decimals"));
    }
    let values = comps.chunks(3).map(|c| [c[0].m, c[1].m, c[2].m]).collect();
    let q = Quantization::Decimal {
        decimals: n.decimals,
    };
    let indices = numbers.iter().map(|&e| e - 1).collect();
    channel_of(head, (values, Vec::new(), q), indices, mesh)
}

/// Refuses a refinement larger than the header's finest mesh, before it is built.
fn check_refinement_size(h: &Header, fine_nv: usize, fine_faces: usize) -> Result<()> {
    if fine_nv as u64 > h.vertices || fine_faces as u64 > h.faces {
        return Err(Error::corrupt(
            "HEAD",
            "the base mesh refines to more than the header's counts",
        ));
    }
    Ok(())
}

/// The finest refined topology must have the header's counts.
fn check_finest_counts(h: &Header, topo: &Topo) -> Result<()> {
    if topo.nv as u64 != h.vertices
        || topo.nf() as u64 != h.faces
        || topo.idx.len() as u64 != h.corners
    {
        return Err(Error::corrupt(
            "HEAD",
            "the refined mesh does not have the header's counts",
        ));
    }
    Ok(())
}

/// Which base vertices are a polar hierarchy's poles (the same at every level, SPEC.md
/// 8.6; empty for the other families); every face at a pole must be a triangle.
fn pole_flags(h: &Header, base: &Topo) -> Result<Vec<bool>> {
    let mut pole = vec![
        false;
        if h.family == Family::Polar {
            base.nv
        } else {
            0
        }
    ];
    for &p in &h.poles {
        *pole
            .get_mut(p as usize)
            .ok_or_else(|| Error::corrupt("HEAD", "a pole is not a base vertex"))? = true;
    }
    if !pole.is_empty() {
        for f in 0..base.nf() {
            let face = base.face(f);
            if face.len() != 3 && face.iter().any(|&v| pole[v as usize]) {
                return Err(Error::corrupt("BASE", "a face at a pole is not a triangle"));
            }
        }
    }
    Ok(pole)
}

/// Rebuilds levels 1..=`upto` from the base mesh (SPEC.md 8-10).
fn synthesise_levels(
    c: &Container<'_>,
    h: &Header,
    base: Mesh,
    w: Wavelet,
    upto: u8,
    threads: usize,
) -> Result<Mesh> {
    let mut topo = Topo::new(base.vertex_count());
    topo.idx = base.faces;
    topo.starts = base.face_starts;
    // The values of every level in buffers sized once for the finest mesh, when its
    // count is within what the levels' bytes can hold (SPEC.md 2.6's density bound; a
    // header beyond it fails at a level and gets no room made for it).
    let levl_bytes: u64 = c.sections[2..]
        .iter()
        .take(upto as usize)
        .map(|s| s.payload.len() as u64 + 8)
        .sum();
    let finest = if upto == h.levels && h.vertices <= topo.nv as u64 + 2048 * levl_bytes {
        h.vertices as usize
    } else {
        topo.nv
    };
    let values = |k: usize| {
        let mut v = Vec::with_capacity(finest.max(topo.nv));
        v.extend(base.positions.iter().map(|p| p[k]));
        v
    };
    let mut models = levl::LevelModels::new();
    models.reserve(finest);
    let mut s = Synthesis {
        h,
        scheme: Scheme {
            family: h.family,
            wavelet: w,
            poles: &h.poles,
            disc: h.disc,
            stencils: None,
        },
        x: std::array::from_fn(values),
        models,
        pole: pole_flags(h, &topo)?,
        threads,
    };
    // A level's successor, derived from it (cheaper than from its fine faces), and the
    // successor's stencils, derived from the level's where they can be.
    let mut next: Option<Level> = None;
    let mut stencils: Option<Stencils> = None;
    let family = s.scheme.family;
    // sqrt2-sym reads the per-vertex lists; the other sqrt(2) transforms walk the
    // rings, which each level derives from the one before (sqrt2-sym makes them only
    // for a level in tangent mode, for its memory).
    let lists = w == Wavelet::Sqrt2Sym;
    for l in 0..upto as usize {
        let mut level = match next.take() {
            Some(n) => n,
            None => Level::new(&topo)?,
        };
        let section = &c.sections[2 + l];
        let last = l + 1 == upto as usize;
        let at = |e: Error| e.in_level(l + 1, section.offset);
        s.prepare(&mut level).map_err(at)?;
        // On more than one thread the successor's topology is made beside the level's
        // reading (it needs only the level's); small levels are not worth a thread. A
        // large sqrt(2) successor is made after, from the level given up, as on one
        // thread: made beside, both levels' topologies and rings would be held at once,
        // past the decoder's memory bound (2 x the mesh + 32 MiB) on large meshes.
        if threads > 1
            && !last
            && (family == Family::Sqrt2 || s.pole.is_empty())
            && family.details(&level) >= levl::BESIDE_MIN
            && (family != Family::Sqrt2 || family.fine_nv(&level) <= SQRT2_BESIDE_MAX)
        {
            let given = stencils.take();
            let (read, made) = std::thread::scope(|sc| {
                let made = sc.spawn(|| match family {
                    Family::Sqrt2 => {
                        topology::sqrt2::next_level_of(&level, lists, !lists).map(|n| (n, None))
                    }
                    _ => Ok(level.next_mapped()).map(|(n, m)| (n, Some(m))),
                });
                let read = s.read(&level, l, section.payload, last, given);
                (
                    read,
                    made.join().unwrap_or_else(|e| std::panic::resume_unwind(e)),
                )
            });
            let st = read.map_err(at)?;
            let (made, map) = made?;
            stencils = st
                .zip(map)
                .and_then(|(st, map)| st.next(&level, &made, &map, w));
            next = Some(made);
            continue;
        }
        let st = s
            .read(&level, l, section.payload, last, stencils.take())
            .map_err(at)?;
        match family {
            // Only sqrt2-sym reads the per-vertex lists: the others' levels are made
            // without them.
            Family::Sqrt2 if !last => {
                next = Some(topology::sqrt2::next_level(level, lists, !lists)?);
            }
            // The finest topology needs only the level's edges: its other arrays go first.
            Family::Sqrt2 => topo = topology::sqrt2::fine_owned(level),
            // A Catmull-Clark level's successor, derived from it (no edge lookups).
            _ if s.pole.is_empty() && !last => {
                let (made, map) = level.next_mapped();
                stencils = st.and_then(|st| st.next(&level, &made, &map, w));
                next = Some(made);
            }
            _ => {
                topo = level.fine_with(&s.pole);
                if !s.pole.is_empty() {
                    s.pole.resize(topo.nv, false);
                }
            }
        }
    }
    if upto == h.levels {
        check_finest_counts(h, &topo)?;
    }
    coarse_mesh(h, w, upto, &s.x, topo)
}

/// Most vertices of a sqrt(2) level whose topology is made beside the reading of the
/// level before (see [`synthesise_levels`]), and most coarse vertices of a sqrt(2) level
/// whose transform is made beside its reading (see [`Synthesis::read`]): above them the
/// decoder works as on one thread, within its memory bound (2 x the mesh + 32 MiB; 2^19
/// left a 1.57 M-vertex mesh at 184 MB on two threads against 165 MB on one, bound 168).
const SQRT2_BESIDE_MAX: usize = 1 << 18;

/// The decoder's state between levels.
struct Synthesis<'h> {
    h: &'h Header,
    scheme: Scheme<'h>,
    /// Per axis, the values decoded so far (the coarse values of the next level).
    x: [Vec<i64>; 3],
    models: levl::LevelModels,
    /// Polar hierarchies: which vertices are poles.
    pole: Vec<bool>,
    /// Threads the level decoder may use.
    threads: usize,
}

impl Synthesis<'_> {
    /// Checks `level` before its reading: its refinement within the header's counts (a
    /// sqrt(2) level closed); drops the per-vertex lists that only sqrt2-sym reads.
    fn prepare(&self, level: &mut Level) -> Result<()> {
        let family = self.scheme.family;
        // Refuse a refinement larger than the header's finest mesh before building it.
        let (nv, nf) = (family.fine_nv(level), family.fine_faces(level, &self.pole));
        check_refinement_size(self.h, nv, nf)?;
        if family == Family::Sqrt2 && !topology::sqrt2::closed(level) {
            return Err(Error::corrupt("BASE", "a sqrt(2) level with a boundary"));
        }
        // Only sqrt2-sym (SPEC.md 9.8) reads the per-vertex lists.
        if family == Family::Sqrt2 && self.scheme.wavelet != Wavelet::Sqrt2Sym {
            level.free_vertex_adjacency();
        }
        Ok(())
    }

    /// Reads level `l`'s details from `payload` and synthesises the level's fine
    /// values (SPEC.md 9, 10); `level` went through [`Synthesis::prepare`]. A
    /// Catmull-Clark level's transform takes `given` stencils if there are any; the
    /// level's stencils come back unless it is the `last` read.
    fn read(
        &mut self,
        level: &Level,
        l: usize,
        payload: &[u8],
        last: bool,
        given: Option<Stencils>,
    ) -> Result<Option<Stencils>> {
        let family = self.scheme.family;
        let x = &mut self.x;
        // Made before the details are decoded: while the coarse values alone are in
        // memory, which is smaller than making them after. Modes 6 and 9 read the
        // predictions' phases (SPEC.md 10.6, 10.9).
        let phased = levl::reads_phases(payload);
        let models = &mut self.models;
        let threads = self.threads;
        // On more than one thread, a level whose reading needs nothing of its transform
        // (no phases, no tangent targets) has the transform made beside the reading,
        // from a copy of the coarse values; not a sqrt(2) level of more than
        // SQRT2_BESIDE_MAX coarse vertices, whose copy would take the decoder past its
        // memory bound beside the level's rings and predictions.
        let beside = threads > 1
            && !phased
            && !levl::reads_targets(payload)
            && family.details(level) >= levl::BESIDE_MIN
            && (family != Family::Sqrt2 || level.nv <= SQRT2_BESIDE_MAX);
        let t = if beside {
            let coarse = x.clone();
            let scheme = &self.scheme;
            let t = std::thread::scope(|s| -> Result<LevelTransform<'_>> {
                let made = s.spawn(|| {
                    LevelTransform::with_stencils(scheme, level, l, &coarse, false, given)
                });
                let read = levl::decode(payload, level, family, x, models, None, None, threads);
                let t = made.join().unwrap_or_else(|e| std::panic::resume_unwind(e));
                read.map(|()| t)
            })?;
            t.synthesise(level, x);
            t
        } else {
            let t = LevelTransform::with_stencils(&self.scheme, level, l, x, phased, given);
            // Tangent targets only for a level coded in tangent mode (SPEC.md 10.3).
            let targets = levl::reads_targets(payload)
                .then(|| t.tangent_targets(level, x))
                .flatten();
            let phaser = phased.then(|| t.phaser(level)).flatten();
            let phasing = match (t.phases(), &phaser) {
                (Some(p), _) => Some(levl::Phasing::Ready(p)),
                (None, Some(p)) => Some(levl::Phasing::Cc(p)),
                (None, None) => None,
            };
            levl::decode(
                payload,
                level,
                family,
                x,
                models,
                targets.as_deref(),
                phasing,
                threads,
            )?;
            // A Catmull-Clark level in mode 6 or 9 is synthesised as it is read.
            if phaser.is_none() {
                t.synthesise(level, x);
            }
            t
        };
        if last {
            // The last level read: its magnitudes serve no later level.
            *models = levl::LevelModels::new();
        }
        if x.iter().flatten().any(|v| v.abs() > levl::MAX_LIFTED) {
            return Err(Error::corrupt("LEVL", "reconstructed value out of range"));
        }
        Ok(if last { None } else { t.into_stencils() })
    }
}

/// The mesh of level `upto` from its values `x` and topology. The finest level's values
/// must lie in the coordinates' range, else corrupt; a coarser level's carry 1/gain of
/// the geometry per level still above it and are clamped into the range (SPEC.md 9.4:
/// an update step's approximations may pass a mesh that reaches the range's edge).
fn coarse_mesh(h: &Header, w: Wavelet, upto: u8, x: &[Vec<i64>; 3], topo: Topo) -> Result<Mesh> {
    let finest = upto == h.levels;
    let gain: i64 = match w {
        Wavelet::Bicubic => 4,
        Wavelet::Biquintic => 16,
        _ => 1,
    };
    let mut scale: i64 = 1;
    for _ in upto..h.levels {
        scale = scale.saturating_mul(gain);
    }
    let mut mesh = Mesh::new();
    mesh.positions = Vec::with_capacity(topo.nv);
    for i in 0..topo.nv {
        let mut p = [0i64; 3];
        for k in 0..3 {
            let v = x[k][i].saturating_mul(scale);
            if finest && v.abs() > MAX_COORD {
                return Err(Error::corrupt(
                    "LEVL",
                    "reconstructed coordinate out of range",
                ));
            }
            p[k] = v.clamp(-MAX_COORD, MAX_COORD);
        }
        mesh.positions.push(p);
    }
    mesh.faces = topo.idx;
    mesh.face_starts = topo.starts;
    Ok(mesh)
}

/// Rebuilds levels 1..=`upto` of a subdivision fit (SPEC.md 9.10, 10.4): the control
/// values (`bits` extra bits) refined in integers by the header's `rules` (its creases
/// from the header, per level; `rules`' sharpnesses are not read), rounded to the grid,
/// and at the
/// finest level the residuals added.
fn synthesise_fit(
    c: &Container<'_>,
    h: &Header,
    base: Mesh,
    bits: u8,
    rules: &fit::Rules,
    upto: u8,
) -> Result<Mesh> {
    let mut topo = Topo::new(base.vertex_count());
    topo.idx = base.faces;
    topo.starts = base.face_starts;
    let mut x: [Vec<i64>; 3] =
        std::array::from_fn(|k| base.positions.iter().map(|p| p[k]).collect());
    let mut level = Level::new(&topo)?;
    // With seams, the rules refine the base mesh glued at them (SPEC.md 9.10), and
    // `map` follows each vertex of the cut mesh to its glued vertex, level by level.
    let mut glued = match h.seams.is_empty() {
        true => None,
        false => {
            let g = fit::Glued::new(&level.coarse, &h.seams)
                .map_err(|e| Error::corrupt("HEAD", e.to_string()))?;
            for xs in x.iter_mut() {
                *xs = g.gather(xs);
            }
            Some((g.level, g.map))
        }
    };
    // The level the rules refine: the glued one, or the base mesh's.
    let rl = glued.as_ref().map_or(&level, |g| &g.0);
    let mut sharp = fit::Sharpness::default();
    if !h.creases.is_empty() {
        sharp.edges = vec![0; rl.ne()];
    }
    for (i, &e) in h.creases.iter().enumerate() {
        *sharp
            .edges
            .get_mut(e as usize)
            .ok_or_else(|| Error::corrupt("HEAD", format!("crease {e} is not a base edge")))? = h
            .crease_sharpness
            .get(i)
            .copied()
            .unwrap_or(fit::SHARP_INFINITE);
    }
    if !h.vertex_creases.is_empty() {
        sharp.vertices = vec![0; rl.nv];
        for (i, &v) in h.vertex_creases.iter().enumerate() {
            *sharp.vertices.get_mut(v as usize).ok_or_else(|| {
                Error::corrupt("HEAD", format!("vertex crease {v} is not a base vertex"))
            })? = h
                .vertex_sharpness
                .get(i)
                .copied()
                .unwrap_or(fit::SHARP_INFINITE);
        }
    }
    // With seams, the cut mesh's finest faces (made without a level).
    let mut finest = None;
    // The end caps, from their isolation level on (SPEC.md 9.10).
    let mut caps = None;
    for l in 0..upto as usize {
        check_refinement_size(h, level.fine_nv(), level.fine_faces_with(&[]))?;
        if l + 1 < h.levels as usize && !c.sections[2 + l].payload.is_empty() {
            return Err(
                Error::corrupt("LEVL", "a fit's level other than the finest holds data")
                    .in_level(l + 1, c.sections[2 + l].offset),
            );
        }
        let rl = glued.as_ref().map_or(&level, |g| &g.0);
        if caps.is_none() {
            caps = fit::end_caps_at(rules, l, rl, &mut sharp, &x);
        }
        for xs in x.iter_mut() {
            fit::subdivide(rl, rules.hard(&sharp), xs);
        }
        if let Some(c) = &mut caps {
            c.below(rl);
        }
        glued = match glued {
            None => {
                let fine = level.next();
                sharp = sharp.below(&level, &fine);
                level = fine;
                None
            }
            Some((g, map)) => {
                let gf = g.next();
                sharp = sharp.below(&g, &gf);
                let map = fit::glued_below(&level, &g, &map);
                // The rules refine the glued levels: of the cut mesh's finest, only
                // its faces are needed.
                if l + 1 == upto as usize {
                    finest = Some(level.fine());
                } else {
                    level = level.next();
                }
                Some((gf, map))
            }
        };
    }
    let rl = glued.as_ref().map_or(&level, |g| &g.0);
    fit::place_finest(rl, rules, sharp, &mut x)
        .map_err(|e| Error::corrupt("HEAD", e.to_string()))?;
    if let Some(c) = caps {
        c.place(&rl.coarse, &mut x);
    }
    if let Some((_, map)) = &glued {
        for xs in x.iter_mut() {
            *xs = fit::spread(map, xs);
        }
    }
    let topo = finest.unwrap_or(level.coarse);
    if upto == h.levels {
        check_finest_counts(h, &topo)?;
        let s = &c.sections[1 + upto as usize];
        levl::fit::decode_residuals(s.payload, &mut x, bits, MAX_COORD)
            .map_err(|e| e.in_level(upto as usize, s.offset))?;
    } else {
        // A coarser level: the control mesh's refinement, rounded to the grid and
        // clamped into the coordinates' range (SPEC.md 9.10).
        let half = (1i64 << bits) >> 1;
        for v in x.iter_mut().flatten() {
            *v = ((*v + half) >> bits).clamp(-MAX_COORD, MAX_COORD);
        }
    }
    let mut mesh = Mesh::new();
    mesh.positions = (0..topo.nv).map(|i| [x[0][i], x[1][i], x[2][i]]).collect();
    mesh.faces = topo.idx;
    mesh.face_starts = topo.starts;
    Ok(mesh)
}

/// Undoes [`base::permute`]: `order[new] = old`.
fn unpermute(mesh: &Mesh, order: &[u32]) -> Mesh {
    let mut positions = vec![[0i64; 3]; order.len()];
    for (new, &old) in order.iter().enumerate() {
        positions[old as usize] = mesh.positions[new];
    }
    let mut floats = vec![
        [0u64; 3];
        if mesh.floats.is_empty() {
            0
        } else {
            order.len()
        }
    ];
    for (new, &old) in order.iter().enumerate().take(mesh.floats.len()) {
        floats[old as usize] = mesh.floats[new];
    }
    Mesh {
        positions,
        face_starts: mesh.face_starts.clone(),
        faces: mesh.faces.iter().map(|&v| order[v as usize]).collect(),
        floats,
        attributes: Vec::new(),
    }
}

/// Puts vertices and faces back in the input's order (SPEC.md 7).
fn restore_order(mesh: &Mesh, o: &ordr::InputOrder) -> Mesh {
    let mut out = unpermute(mesh, &o.vertices);
    let nf = mesh.face_count();
    let mut degree = vec![0u32; nf];
    for c in 0..nf {
        degree[o.faces[c] as usize] = mesh.face_starts[c + 1] - mesh.face_starts[c];
    }
    let mut starts = Vec::with_capacity(nf + 1);
    starts.push(0u32);
    for d in &degree {
        starts.push(starts.last().copied().unwrap_or(0) + d);
    }
    let mut faces = vec![0u32; mesh.faces.len()];
    for c in 0..nf {
        let src = &out.faces[mesh.face_starts[c] as usize..mesh.face_starts[c + 1] as usize];
        let k = src.len();
        let r = o.rotations[c] as usize;
        let dst = starts[o.faces[c] as usize] as usize;
        for i in 0..k {
            faces[dst + i] = src[(i + k - r) % k];
        }
    }
    out.faces = faces;
    out.face_starts = starts;
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A value past the coordinates' range is corrupt at the finest level and clamped
    /// at a coarser one (SPEC.md 9.4).
    #[test]
    fn only_coarser_levels_clamp_into_the_range() {
        let opts = crate::EncodeOptions::default();
        let q = crate::Quantization::Decimal { decimals: 0 };
        let mut h = crate::encoder::flat_header(&Mesh::new(), &q, &opts);
        h.levels = 2;
        let past = MAX_COORD + 1;
        let x = [vec![past, -past], vec![1, 2], vec![3, 4]];
        let w = Wavelet::Bicubic;
        assert!(coarse_mesh(&h, w, 2, &x, Topo::new(2)).is_err());
        let inside = [vec![MAX_COORD, -MAX_COORD], vec![1, 2], vec![3, 4]];
        let m = coarse_mesh(&h, w, 2, &inside, Topo::new(2)).unwrap();
        assert_eq!(m.positions, vec![[MAX_COORD, 1, 3], [-MAX_COORD, 2, 4]]);
        // One level down the values carry a quarter of the geometry: 4 x past.
        let m = coarse_mesh(&h, w, 1, &x, Topo::new(2)).unwrap();
        assert_eq!(m.positions, vec![[MAX_COORD, 4, 12], [-MAX_COORD, 8, 16]]);
    }
}
