//! Harness functions shared by the fuzz targets (`fuzz/`) and the tests that replay
//! their regression inputs (`tests/fuzz_regressions.rs`). Each takes arbitrary bytes and
//! panics only when a property is violated: a hostile input that is merely refused is
//! fine, a panic inside the library is a bug.

use subwave_codec::entropy::{AdaptiveModel, Decoder, Encoder, IntModel};
use subwave_codec::topology::{Level, Topo};
use subwave_codec::transform::{analyse, synthesise};

use crate::{DecodeOptions, EncodeOptions, Limits, Mesh, Quantization, TransformChoice, Wavelet};

/// Reads bytes as a little stream of small numbers, zeros after the end.
struct Bytes<'a> {
    data: &'a [u8],
    pos: usize,
}

impl<'a> Bytes<'a> {
    fn new(data: &'a [u8]) -> Self {
        Bytes { data, pos: 0 }
    }

    fn u8(&mut self) -> u8 {
        let b = self.data.get(self.pos).copied().unwrap_or(0);
        self.pos += 1;
        b
    }

    fn u64(&mut self) -> u64 {
        (0..8).fold(0u64, |acc, _| (acc << 8) | self.u8() as u64)
    }

    fn below(&mut self, n: usize) -> usize {
        if n <= 1 {
            return 0;
        }
        ((self.u8() as usize) << 8 | self.u8() as usize) % n
    }

    fn exhausted(&self) -> bool {
        self.pos >= self.data.len()
    }
}

/// A small polygon base mesh (3..=24 vertices, 1..=12 faces of degree 3..=6), refined
/// `levels` times where the topology allows.
fn arbitrary_topology(b: &mut Bytes<'_>) -> (Topo, usize) {
    let n = 3 + b.below(22);
    let m = 1 + b.below(12);
    let mut t = Topo::new(n);
    for _ in 0..m {
        let k = 3 + b.below(4);
        let face: Vec<u32> = (0..k).map(|_| b.below(n) as u32).collect();
        t.push(&face);
    }
    let want = b.below(3);
    let mut levels = 0;
    for _ in 0..want {
        match Level::new(&t) {
            Ok(l) if l.coarse.idx.len() < 4096 => {
                t = l.fine();
                levels += 1;
            }
            _ => break,
        }
    }
    (t, levels)
}

fn arbitrary_coordinates(b: &mut Bytes<'_>, n: usize) -> Vec<[i64; 3]> {
    let bits = b.below(45) as u32;
    let span = if bits == 0 { 0 } else { (1i64 << bits) - 1 };
    (0..n)
        .map(|_| {
            std::array::from_fn(|_| {
                if span == 0 {
                    0
                } else {
                    (b.u64() % (2 * span as u64 + 1)) as i64 - span
                }
            })
        })
        .collect()
}

/// Decoding arbitrary bytes with tight limits never panics; what it returns is a valid
/// mesh.
pub fn decode_tight(data: &[u8]) {
    let opts = DecodeOptions {
        limits: Limits::tight(),
        ..DecodeOptions::default()
    };
    let one = crate::decode(data, &opts);
    if let Ok(d) = &one {
        d.mesh.validate().expect("decoded mesh is valid");
    }
    // Two threads decode the same mesh, or refuse the same container.
    let two = crate::decode(data, &DecodeOptions { threads: 2, ..opts });
    match (&one, &two) {
        (Ok(a), Ok(b)) => assert_eq!(a.mesh, b.mesh, "threads change the mesh"),
        (Err(_), Err(_)) => {}
        _ => panic!("one thread and two disagree on whether the container decodes"),
    }
    let prefix = DecodeOptions {
        limits: Limits::tight(),
        max_level: Some(data.first().copied().unwrap_or(0) % 4),
        ..DecodeOptions::default()
    };
    let _ = crate::decode(data, &prefix);
    let _ = crate::inspect(data, &Limits::tight());
}

/// Parsing arbitrary bytes as a container never panics, and a parsed prefix is
/// consistent with the bytes.
pub fn container_parse(data: &[u8]) {
    let limits = Limits::tight();
    if let Ok(c) = subwave_container::Container::parse(data, &limits) {
        assert!(c.complete);
    }
    if let Ok(c) = subwave_container::Container::parse_prefix(data, &limits) {
        for s in &c.sections {
            // The payload sits between the kind and length and the 4-byte CRC.
            let start = s.offset as usize + s.overhead - 4;
            assert_eq!(&data[start..start + s.payload.len()], s.payload);
            assert!(s.offset as usize + s.total_len() <= data.len());
        }
    }
}

/// Any mesh (any base, levels, coordinates in range, shuffled) round-trips exactly.
pub fn roundtrip_mesh(data: &[u8]) {
    let mut b = Bytes::new(data);
    let (topo, _) = arbitrary_topology(&mut b);
    let extra = b.below(3);
    let mut mesh = Mesh::new();
    mesh.positions = arbitrary_coordinates(&mut b, topo.nv + extra);
    // Shuffle vertex numbers and face order.
    let n = mesh.positions.len();
    let mut perm: Vec<u32> = (0..n as u32).collect();
    for i in (1..n).rev() {
        perm.swap(i, b.below(i + 1));
    }
    let mut faces: Vec<Vec<u32>> = (0..topo.nf())
        .map(|f| topo.face(f).iter().map(|&v| perm[v as usize]).collect())
        .collect();
    for i in (1..faces.len()).rev() {
        faces.swap(i, b.below(i + 1));
    }
    for f in &faces {
        mesh.push_face(f);
    }
    if b.u8() & 1 == 1 {
        arbitrary_channels(&mut b, &mut mesh);
    }
    let all: Vec<Wavelet> = Wavelet::ALL.into_iter().chain(Wavelet::SQRT2).collect();
    let w = b.below(all.len() + 2);
    let opts = EncodeOptions {
        keep_order: b.u8() & 1 == 1,
        transform: match w {
            0 => TransformChoice::Auto,
            1 => TransformChoice::Fit,
            _ => TransformChoice::Fixed(all[w - 2]),
        },
        max_levels: b.below(17) as u8,
        value_map: match b.below(3) {
            0 => None,
            1 => Some(true),
            _ => Some(false),
        },
        ..Default::default()
    };
    let q = Quantization::Decimal { decimals: 0 };
    let enc = crate::encode(&mesh, &q, &opts).expect("a valid mesh encodes");
    let dec = crate::decode_slice(&enc.bytes).expect("own output decodes");
    if opts.keep_order {
        assert_eq!(dec.mesh, mesh, "keep-order round trip differs");
    } else {
        crate::compare_up_to_order(&mesh, &dec.mesh, &enc.order).expect("round trip differs");
    }
}

/// Attribute channels of every domain on `mesh` (SPEC.md 11.4): per-vertex values,
/// a per-corner table of three-decimal triples (as normals are) with arbitrary corner
/// entries, per-face names with faces of none, per-file vertex numbers, lists per face.
fn arbitrary_channels(b: &mut Bytes<'_>, mesh: &mut Mesh) {
    use subwave_codec::{Attribute, Domain, ValueType};
    let small = |b: &mut Bytes<'_>| b.below(2001) as i64 - 1000;
    let width = 1 + b.below(3) as u8;
    let values = (0..mesh.vertex_count())
        .map(|_| {
            let mut v = [0i64; 3];
            v[..width as usize].iter_mut().for_each(|x| *x = small(b));
            v
        })
        .collect();
    let vertex = Attribute {
        name: "v".into(),
        domain: Domain::Vertex,
        value_type: ValueType::Text,
        width,
        values,
        floats: Vec::new(),
        quantization: Quantization::Decimal { decimals: 1 },
        indices: Vec::new(),
        labels: Vec::new(),
    };
    let entries = 1 + b.below(mesh.corner_count().max(1));
    let corner = Attribute {
        name: "normal".into(),
        domain: Domain::Corner,
        value_type: ValueType::Text,
        width: 3,
        values: (0..entries)
            .map(|_| [small(b), small(b), small(b)])
            .collect(),
        floats: Vec::new(),
        quantization: Quantization::Decimal { decimals: 4 },
        indices: (0..mesh.corner_count())
            .map(|_| b.below(entries) as u32)
            .collect(),
        labels: Vec::new(),
    };
    let face = Attribute {
        name: "material".into(),
        domain: Domain::Face,
        value_type: ValueType::Text,
        width: 1,
        values: (0..mesh.face_count())
            .map(|_| [b.below(3) as i64 - 1, 0, 0])
            .collect(),
        floats: Vec::new(),
        quantization: Quantization::Decimal { decimals: 0 },
        indices: Vec::new(),
        labels: vec!["a".into(), "b c".into()],
    };
    // Per file: an element's vertex numbers (some past the mesh), renumbered with the
    // vertices in canonical order.
    let n = mesh.vertex_count().max(1);
    let edge = Attribute {
        name: "edge/vertex1 vertex2".into(),
        domain: Domain::File,
        value_type: ValueType::I32,
        width: 2,
        values: (0..b.below(5))
            .map(|_| [b.below(n + 1) as i64, b.below(n) as i64, 0])
            .collect(),
        floats: Vec::new(),
        quantization: Quantization::Decimal { decimals: 0 },
        indices: Vec::new(),
        labels: Vec::new(),
    };
    // A list per face, of 0 to 3 values.
    let lengths: Vec<u32> = (0..mesh.face_count()).map(|_| b.below(4) as u32).collect();
    let lists = Attribute {
        name: "flags".into(),
        domain: Domain::Face,
        value_type: ValueType::I16,
        width: 1,
        values: (0..lengths.iter().sum::<u32>())
            .map(|_| [small(b), 0, 0])
            .collect(),
        floats: Vec::new(),
        quantization: Quantization::Decimal { decimals: 0 },
        indices: lengths,
        labels: Vec::new(),
    };
    mesh.attributes = vec![vertex, corner, face, edge, lists];
}

/// Every transform's synthesis undoes its analysis exactly on any refinable topology
/// and any values in range.
pub fn lifting_roundtrip(data: &[u8]) {
    let mut b = Bytes::new(data);
    let (topo, _) = arbitrary_topology(&mut b);
    let Ok(level) = Level::new(&topo) else { return };
    let coords = arbitrary_coordinates(&mut b, level.fine_nv());
    let orig: Vec<i64> = coords.iter().map(|c| c[0]).collect();
    for w in Wavelet::ALL {
        let mut x = orig.clone();
        analyse(&level, w, &mut x);
        synthesise(&level, w, &mut x);
        assert_eq!(x, orig, "{} does not invert", w.name());
    }
    // The sqrt(2) transforms on the same coarse mesh (face points only).
    let n = subwave_codec::topology::sqrt2::fine_nv(&level);
    for w in Wavelet::SQRT2 {
        let plan = subwave_codec::transform::sqrt2::Plan::new(&level, w);
        let mut x = orig[..n].to_vec();
        plan.analyse(&mut x);
        plan.synthesise(&mut x);
        assert_eq!(x, orig[..n], "{} does not invert", w.name());
    }
}

/// Any sequence of symbols, integers and uniform values decodes to itself.
pub fn coder_roundtrip(data: &[u8]) {
    #[derive(Debug, PartialEq)]
    enum Op {
        Sym(usize, usize),
        Int(i64),
        Uni(u64, u64),
    }
    let mut b = Bytes::new(data);
    let sizes = [2usize, 3, 17, 64, 300];
    let mut ops = Vec::new();
    while !b.exhausted() && ops.len() < 4096 {
        ops.push(match b.u8() % 3 {
            0 => {
                let m = b.below(sizes.len());
                Op::Sym(m, b.below(sizes[m]))
            }
            1 => {
                let v = b.u64() as i64 >> (b.u8() % 64);
                Op::Int(v.clamp(-(1 << 61), 1 << 61))
            }
            _ => {
                let n = 1 + b.u64() % (1 << 32);
                Op::Uni(b.u64() % n, n)
            }
        });
    }
    let mut e = Encoder::new();
    let mut models: Vec<AdaptiveModel> = sizes.iter().map(|&n| AdaptiveModel::new(n)).collect();
    let mut im = IntModel::new();
    for op in &ops {
        match *op {
            Op::Sym(m, s) => e.symbol(&mut models[m], s),
            Op::Int(v) => e.int(&mut im, v),
            Op::Uni(v, n) => e.uniform(v, n),
        }
    }
    // The encoder's size bound (its early stops) never passes the stream's size.
    let bound = e.written();
    let bytes = e.finish();
    assert!(
        bound <= bytes.len(),
        "bound {bound} > {} bytes",
        bytes.len()
    );
    let mut d = Decoder::new(&bytes, "fuzz").expect("own stream");
    let mut models: Vec<AdaptiveModel> = sizes.iter().map(|&n| AdaptiveModel::new(n)).collect();
    let mut im = IntModel::new();
    for op in &ops {
        let got = match *op {
            Op::Sym(m, _) => Op::Sym(m, d.symbol(&mut models[m]).expect("symbol")),
            Op::Int(_) => Op::Int(d.int(&mut im).expect("int")),
            Op::Uni(_, n) => Op::Uni(d.uniform(n).expect("uniform"), n),
        };
        assert_eq!(&got, op);
    }
}

/// Decoding the same bytes into two meshes pre-filled with different junk gives the same
/// result: nothing of a buffer's old contents leaks into the output.
pub fn decode_twice(data: &[u8]) {
    let opts = DecodeOptions {
        limits: Limits::tight(),
        ..DecodeOptions::default()
    };
    let mut a = Mesh::new();
    a.positions = vec![[7; 3]; 64];
    a.faces = vec![1; 100];
    a.face_starts = vec![0, 50, 100];
    let mut b = Mesh::new();
    b.positions = vec![[-3; 3]; 3];
    b.faces = vec![0xdead; 7];
    let ra = crate::decode_into(data, &opts, &mut a);
    let rb = crate::decode_into(data, &opts, &mut b);
    assert_eq!(ra.is_ok(), rb.is_ok());
    if ra.is_ok() {
        assert_eq!(a, b);
    }
}

/// Any bytes that read as a mesh file (OBJ, PLY, OFF, STL; small ones, so that the
/// fuzzer explores the readers rather than the coder) come back byte for byte from a
/// container made with the file's order and bytes (SPEC.md 11), and value for value
/// without them; bytes that do not read are refused with an error.
pub fn whole_file(data: &[u8]) {
    let Ok(m) = crate::load(data, None) else {
        return;
    };
    if m.mesh.vertex_count() > 4096 || m.mesh.faces.len() > 16384 {
        return;
    }
    let opts = EncodeOptions {
        keep_order: true,
        source: m.source(),
        max_levels: 3,
        ..Default::default()
    };
    let Ok(enc) = crate::encode_file(&m.mesh, &m.quantization, &opts, data, m.format) else {
        // A mesh the codec cannot take (values beyond its range) is refused, not lost.
        return;
    };
    let dec = crate::decode_slice(&enc.bytes).expect("own output decodes");
    // The channels are in the file's bytes.
    assert_eq!(
        dec.mesh,
        m.mesh.without_attributes(),
        "the mesh in the file's order"
    );
    let file = dec
        .file()
        .expect("a file template")
        .expect("the template expands");
    assert!(file == data, "the file's bytes come back");
    // In canonical order: every value of every channel (SPEC.md 11.4).
    let opts = EncodeOptions {
        keep_order: false,
        ..opts
    };
    let enc = crate::encode(&m.mesh, &m.quantization, &opts).expect("a mesh that coded once");
    let dec = crate::decode_slice(&enc.bytes).expect("own output decodes");
    crate::compare_up_to_order(&m.mesh, &dec.mesh, &enc.order).expect("channels back");
}
