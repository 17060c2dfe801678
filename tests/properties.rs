//! Property tests: random meshes (any polygon degrees, repeated and unreferenced
//! vertices, coordinates across the whole supported range) round-trip exactly.

use proptest::prelude::*;
use subwave::{EncodeOptions, Mesh, Quantization, MAX_COORD};

fn arb_mesh() -> impl Strategy<Value = Mesh> {
    (1usize..60, 0usize..40, 0u32..45).prop_flat_map(|(nv, nf, bits)| {
        let span = if bits == 0 {
            0
        } else {
            (1i64 << bits.min(44)) - 1
        }
        .min(MAX_COORD);
        let positions =
            proptest::collection::vec(proptest::array::uniform3(-span..=span), nv.max(3));
        let faces =
            proptest::collection::vec(proptest::collection::vec(0u32..nv.max(3) as u32, 3..9), nf);
        (positions, faces).prop_map(|(positions, faces)| {
            let mut m = Mesh::new();
            m.positions = positions;
            for f in &faces {
                m.push_face(f);
            }
            m
        })
    })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(10_000))]
    #[test]
    fn random_meshes_round_trip(mesh in arb_mesh(), keep in any::<bool>()) {
        let q = Quantization::Decimal { decimals: 3 };
        let enc = subwave::encode_to_vec(&mesh, &q, &EncodeOptions { keep_order: keep, ..Default::default() }).unwrap();
        let dec = subwave::decode_slice(&enc.bytes).unwrap();
        if keep {
            prop_assert_eq!(&dec.mesh, &mesh);
        } else {
            prop_assert!(subwave::compare_up_to_order(&mesh, &dec.mesh, &enc.order).is_ok());
        }
        // And the container lists what inspect says.
        let info = subwave::inspect(&enc.bytes, &subwave::Limits::default()).unwrap();
        prop_assert_eq!(info.header.vertices, mesh.vertex_count() as u64);
        prop_assert_eq!(info.sections.iter().map(|s| s.bytes).sum::<usize>() + 12, enc.bytes.len());
    }

    #[test]
    fn corrupted_containers_never_panic(mesh in arb_mesh(), pos in any::<usize>(), val in any::<u8>()) {
        let q = Quantization::Decimal { decimals: 0 };
        let enc = subwave::encode_to_vec(&mesh, &q, &EncodeOptions::default()).unwrap();
        let mut b = enc.bytes.clone();
        let i = pos % b.len();
        b[i] = val;
        let _ = subwave::decode_slice(&b);
        let _ = subwave::decode_slice(&b[..i]);
    }
}
