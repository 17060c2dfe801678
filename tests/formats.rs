//! PLY (ASCII, binary LE/BE) and OFF read and write, attributes reported, unreferenced
//! vertices kept.

use subwave::{EncodeOptions, Format};

fn round_trip(bytes: &[u8], out_format: Format) -> (subwave::Loaded, Vec<u8>) {
    let input = subwave::load(bytes, None).unwrap();
    let enc = subwave::encode_to_vec(
        &input.mesh,
        &input.quantization,
        &EncodeOptions {
            keep_order: true,
            source: input.source(),
            ..Default::default()
        },
    )
    .unwrap();
    let dec = subwave::decode_slice(&enc.bytes).unwrap();
    assert_eq!(dec.mesh, input.mesh);
    let mut out = Vec::new();
    subwave::write_mesh(&mut out, &dec.mesh, &dec.quantization, out_format).unwrap();
    let again = subwave::load(&out, None).unwrap();
    if out_format == Format::PlyBinary && !input.quantization.prefers_f32() {
        // Decimals go out as the nearest doubles: the same values on another grid.
        assert_eq!(again.mesh.faces, input.mesh.faces);
        for (a, b) in again.mesh.positions.iter().zip(&input.mesh.positions) {
            for k in 0..3 {
                assert_eq!(
                    again.quantization.value_f64(a[k], k),
                    input.quantization.value_f64(b[k], k)
                );
            }
        }
    } else {
        // What the output format holds of the channels (an OBJ's lines only an OBJ).
        let mut want = input.mesh.clone();
        want.attributes
            .retain(|a| subwave::writes_attribute(out_format, a));
        assert_eq!(
            again.mesh, want,
            "{out_format:?} output reads back differently"
        );
    }
    (input, out)
}

const OBJ: &[u8] = b"# test\nv 0.5 0.25 -1.125\nv 1 0 0\nv 1.5 1 0\nv 0 1 0.5\nv 9 9 9\nv 2 0 0\nvn 0 0 1\nvt 0 0\nf 1/1/1 2/1/1 3/1/1 4/1/1\nf -5 -1 -4\n";

#[test]
fn obj_keeps_unreferenced_vertices_and_reports_attributes() {
    let (input, out) = round_trip(OBJ, Format::Obj);
    assert_eq!(input.mesh.vertex_count(), 6);
    assert_eq!(input.mesh.face(1), &[1, 5, 2]);
    assert!(input.dropped.is_empty(), "{:?}", input.dropped);
    // Its comment is a line of the file's; the second face has neither a texture
    // coordinate nor a normal: its corners have no entry.
    let a = &input.mesh.attributes;
    let names: Vec<&str> = a.iter().map(|a| a.name.as_str()).collect();
    assert_eq!(names, ["lines", "uv", "normal"]);
    let none = subwave::NO_ENTRY;
    assert_eq!(a[1].indices, [0, 0, 0, 0, none, none, none]);
    let text = String::from_utf8(out).unwrap();
    assert!(
        text.contains("f 1/1/1 2/1/1 3/1/1 4/1/1\nf 2 6 3\n"),
        "{text}"
    );
    assert!(
        text.starts_with("# test\nv 0.500 0.250 -1.125\nv 1.000 0.000 0.000\n"),
        "{text}"
    );
    assert!(text.contains("v 9.000 9.000 9.000\n"));
}

#[test]
fn every_output_format_reads_back() {
    for f in [
        Format::Obj,
        Format::PlyAscii,
        Format::PlyBinary,
        Format::Off,
    ] {
        round_trip(OBJ, f);
    }
}

#[test]
fn binary_ply_floats_are_exact() {
    let pts: [[f32; 3]; 4] = [
        [0.1, -2.5, 3.0e-3],
        [1.0e3, 0.7, 0.0],
        [0.33, 0.66, 0.99],
        [-0.0, 5.0, 6.0],
    ];
    for be in [false, true] {
        let mut ply = format!(
            "ply\nformat {} 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\nproperty uchar red\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n",
            if be { "binary_big_endian" } else { "binary_little_endian" }
        )
        .into_bytes();
        for p in pts {
            for c in p {
                ply.extend_from_slice(&if be { c.to_be_bytes() } else { c.to_le_bytes() });
            }
            ply.push(200);
        }
        ply.push(4);
        for i in [0i32, 1, 2, 3] {
            ply.extend_from_slice(&if be { i.to_be_bytes() } else { i.to_le_bytes() });
        }
        let (input, out) = round_trip(&ply, Format::PlyBinary);
        assert!(input.dropped.is_empty(), "{:?}", input.dropped);
        let red = input.mesh.attribute("red").expect("a red channel");
        assert_eq!(red.value_type, subwave::ValueType::U8);
        assert!(red.values.iter().all(|v| *v == [200, 0, 0]));
        let back = subwave::read_mesh(&out).unwrap();
        let subwave::RawCoords::F32(v) = back.coords else {
            panic!("float PLY out")
        };
        for (a, b) in v.iter().zip(&pts) {
            for k in 0..3 {
                assert_eq!(a[k], b[k], "binary float changed");
            }
        }
    }
}

#[test]
fn ascii_ply_and_off_keep_decimals() {
    let ply = b"ply\nformat ascii 1.0\ncomment x\nelement vertex 3\nproperty double x\nproperty double y\nproperty double z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0.123456 1 2\n3 4.5 6\n7 8 9.25\n3 0 1 2\n";
    let (_, out) = round_trip(ply, Format::PlyAscii);
    let text = String::from_utf8(out).unwrap();
    assert!(text.contains("0.123456 1.000000 2.000000\n"), "{text}");
    let off = b"OFF\n# comment\n4 1 0\n0 0 0\n1 0 0.5\n1 1 0\n0 1 0\n4 0 1 2 3 255 0 0\n";
    let (input, out) = round_trip(off, Format::Off);
    assert!(input.dropped.contains("face colors"));
    assert!(String::from_utf8(out)
        .unwrap()
        .starts_with("OFF\n4 1 0\n0.0 0.0 0.0\n1.0 0.0 0.5\n"));
}

#[test]
fn grid_mode_matches_dracos_dequantisation() {
    let input = subwave::load(OBJ, Some(8)).unwrap();
    let subwave::Quantization::Grid { origin, step, .. } = input.quantization else {
        panic!()
    };
    assert_eq!(origin, [0.0, 0.0, -1.125]);
    assert_eq!(step, 10.125f32 / 255.0);
    // Every value is within half a step of the input.
    let raw = subwave::read_mesh(OBJ).unwrap();
    let subwave::RawCoords::Decimal(d) = raw.coords else {
        panic!()
    };
    for (p, q) in d.iter().zip(&input.mesh.positions) {
        for k in 0..3 {
            let back = input.quantization.value_f32(q[k], k) as f64;
            assert!((back - p[k].to_f64()).abs() <= step as f64 * 0.5 + 1e-6);
        }
    }
}

/// A binary STL of `tris` (three corners each), facet normals zero.
fn binary_stl(tris: &[[[f32; 3]; 3]]) -> Vec<u8> {
    let mut b = b"made by the test".to_vec();
    b.resize(80, b' ');
    b.extend_from_slice(&(tris.len() as u32).to_le_bytes());
    for t in tris {
        b.extend_from_slice(&[0u8; 12]);
        for x in t.iter().flatten() {
            b.extend_from_slice(&x.to_le_bytes());
        }
        b.extend_from_slice(&[0, 0]);
    }
    b
}

#[test]
fn stl_corners_become_shared_vertices_and_come_back() {
    let (a, b, c, d) = (
        [0f32, 0., 0.],
        [1., 0., 0.],
        [1., 1., -0.0],
        [0., 1., 1e-30],
    );
    let bin = binary_stl(&[[a, b, c], [a, c, d]]);
    let m = subwave::load(&bin, None).unwrap();
    assert_eq!(m.format, Format::StlBinary);
    assert_eq!(m.mesh.vertex_count(), 4);
    assert_eq!(m.mesh.faces, [0, 1, 2, 0, 2, 3]);
    // Every value bit for bit (-0 and the tiny one too), through the codec and back to a
    // binary STL, and to the same bytes with the file's order.
    let enc = subwave::encode_to_vec(&m.mesh, &m.quantization, &EncodeOptions::default()).unwrap();
    let dec = subwave::decode_slice(&enc.bytes).unwrap();
    let mut out = Vec::new();
    subwave::write_mesh(&mut out, &dec.mesh, &dec.quantization, Format::StlBinary).unwrap();
    let again = subwave::load(&out, None).unwrap();
    let corners = |l: &subwave::Loaded| -> Vec<[u32; 3]> {
        let mut v: Vec<[u32; 3]> = (0..l.mesh.faces.len())
            .map(|i| {
                let p = l.mesh.faces[i] as usize;
                std::array::from_fn(|k| {
                    let n = l.mesh.floats.get(p).map_or(0, |f| f[k]);
                    if l.mesh.floats.is_empty() {
                        l.quantization
                            .value_f32(l.mesh.positions[p][k], k)
                            .to_bits()
                    } else {
                        n as u32
                    }
                })
            })
            .collect();
        v.sort();
        v
    };
    assert_eq!(corners(&again), corners(&m));
    let opts = EncodeOptions {
        keep_order: true,
        source: m.source(),
        ..Default::default()
    };
    let enc = subwave::encode_file(&m.mesh, &m.quantization, &opts, &bin, m.format).unwrap();
    let dec = subwave::decode_slice(&enc.bytes).unwrap();
    assert_eq!(dec.file().unwrap().unwrap(), bin);

    // ASCII: corners welded by their text, polygons kept, the same values back as text.
    let ascii = b"solid sq\nfacet normal 0 0 1\n outer loop\n  vertex 0 0 0\n  vertex 1.5 0 0\n  vertex 1.5 1 0\n  vertex 0 1 0\n endloop\nendfacet\nfacet normal 0 0 1\n outer loop\n  vertex 0 0 0\n  vertex 0 1 0\n  vertex -1 0.5 0\n endloop\nendfacet\nendsolid sq\n";
    let m = subwave::load(ascii, None).unwrap();
    assert_eq!(m.format, Format::StlAscii);
    assert_eq!((m.mesh.vertex_count(), m.mesh.face_count()), (5, 2));
    assert_eq!(m.mesh.face(0), &[0, 1, 2, 3]);
    let mut out = Vec::new();
    subwave::write_mesh(&mut out, &m.mesh, &m.quantization, Format::StlAscii).unwrap();
    let again = subwave::load(&out, None).unwrap();
    assert_eq!(again.mesh, m.mesh);
    let enc = subwave::encode_file(&m.mesh, &m.quantization, &opts, ascii, m.format).unwrap();
    let dec = subwave::decode_slice(&enc.bytes).unwrap();
    assert_eq!(dec.file().unwrap().unwrap(), ascii);
    // An empty solid is an empty mesh; so is a binary STL of no facets.
    assert_eq!(
        subwave::load(b"solid e\nendsolid e\n", None)
            .unwrap()
            .mesh
            .vertex_count(),
        0
    );
    assert_eq!(
        subwave::load(&binary_stl(&[]), None)
            .unwrap()
            .mesh
            .vertex_count(),
        0
    );
}

#[test]
fn records_as_real_writers_lay_them_out() {
    // OFF faces spread over several lines (libigl), the counts glued to the keyword.
    let off = subwave::load(
        b"OFF\n4 1 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 \n1\n2 \n3\n",
        None,
    )
    .unwrap();
    assert_eq!(off.mesh.face(0), &[0, 1, 2, 3]);
    let glued = subwave::load(b"  OFF3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n", None).unwrap();
    assert_eq!((glued.mesh.vertex_count(), glued.mesh.face_count()), (3, 1));
    // A PLY face with a list of floats besides its vertex indices (texture coordinates
    // per corner), and ASCII records with more values than the header names (VCG).
    let ply = b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nproperty list uchar float texcoord\nproperty uchar red\nend_header\n0 0 0\n1 0 0\n0 1 0 7 7\n3 0 1 2 6 0.5 0.25 0 0 1 1 9 1 1 1\n";
    let m = subwave::load(ply, None).unwrap();
    assert_eq!(m.mesh.face(0), &[0, 1, 2]);
    // Two values for each corner: a corner channel (in canonical order too).
    let tex = m.mesh.attribute("texcoord").expect("texcoord read");
    let values: Vec<f64> = (0..3)
        .flat_map(|c| (0..2).map(move |k| (c, k)))
        .map(|(c, k)| tex.value_f64(tex.indices[c] as usize, k))
        .collect();
    assert_eq!(values, [0.5, 0.25, 0.0, 0.0, 1.0, 1.0]);
    assert!(m.dropped.iter().any(|d| d.contains("values past the end")));
    let opts = EncodeOptions {
        keep_order: true,
        source: m.source(),
        ..Default::default()
    };
    for file in [
        &ply[..],
        b"OFF\n4 1 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 \n1\n2 \n3\n",
    ] {
        let m = subwave::load(file, None).unwrap();
        let enc = subwave::encode_file(&m.mesh, &m.quantization, &opts, file, m.format).unwrap();
        let dec = subwave::decode_slice(&enc.bytes).unwrap();
        assert_eq!(dec.file().unwrap().unwrap(), file);
    }
    // A PLY header without a vertex element is an empty mesh.
    let empty = subwave::load(b"ply\nformat ascii 1.0\nend_header\n", None).unwrap();
    assert_eq!(empty.mesh.vertex_count(), 0);
}

#[test]
fn corner_numbers_past_their_tables_drop_the_channel_not_the_file() {
    // A `vt` or `vn` number past the file's lines (counted from 1, or back from the
    // lines so far), a corner number that is no number, colours that are no numbers:
    // real files have them (trimesh's cubevt.obj, nancolor.obj). The file is read (its
    // own bytes keep them with --keep-order); that table is no channel, and what was
    // dropped names the line.
    let cases: [(&[u8], &str); 5] = [
        (
            b"v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/1 2/2 3/1\n",
            "line 5: vt reference 2",
        ),
        (
            b"v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//7\n",
            "line 5: vn reference 7",
        ),
        (
            b"v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/-2 2/1 3/1\n",
            "vt reference -2",
        ),
        (
            b"v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/x 2/1 3/1\n",
            "vt reference 0",
        ),
        (
            b"v 0 0 0 1 0 nan\nv 1 0 0 1 1 1\nv 0 1 0 1 1 1\nf 1 2 3\n",
            "line 1: 'nan'",
        ),
    ];
    for (obj, want) in cases {
        let m = subwave::load(obj, None).unwrap();
        assert!(m.mesh.attributes.is_empty(), "{:?}", m.mesh.attributes);
        assert!(
            m.dropped.iter().any(|d| d.contains(want)),
            "{:?}",
            m.dropped
        );
        // And the file comes back byte for byte with its order.
        let opts = subwave::EncodeOptions {
            keep_order: true,
            ..Default::default()
        };
        let enc = subwave::encode_file(&m.mesh, &m.quantization, &opts, obj, m.format).unwrap();
        let dec = subwave::decode_slice(&enc.bytes).unwrap();
        assert_eq!(dec.file().unwrap().unwrap(), obj);
    }
    // A number that points forward, to a line further down, is fine.
    let ahead = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/1 2/2 3/1\nvt 0 0\nvt 1 0\n";
    let m = subwave::load(ahead, None).unwrap();
    assert_eq!(m.mesh.attribute("uv").unwrap().indices, [0, 1, 0]);
}
