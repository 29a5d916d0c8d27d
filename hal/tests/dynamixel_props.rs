//! Property tests of the Dynamixel Protocol 2.0 codec: any packet survives encoding,
//! stuffing and any chunking; no byte stream crashes the decoder.

use proptest::prelude::*;
use tmo_hal::wire::dynamixel::{Decoder, Packet};

fn packet() -> impl Strategy<Value = Packet> {
    (
        0u8..=0xFE,
        any::<u8>(),
        // runs of FF FF FD are likely enough to exercise the stuffing
        prop::collection::vec(prop_oneof![Just(0xFFu8), Just(0xFD), any::<u8>()], 0..120),
    )
        .prop_map(|(id, instruction, params)| Packet {
            id,
            instruction,
            params,
        })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 512, failure_persistence: None, ..ProptestConfig::default() })]

    #[test]
    fn packets_round_trip_in_any_chunks(ps in prop::collection::vec(packet(), 1..6), cut in 1usize..40) {
        let stream: Vec<u8> = ps.iter().flat_map(|p| p.encode()).collect();
        let mut d = Decoder::default();
        let mut got = Vec::new();
        for c in stream.chunks(cut) {
            got.extend(d.push(c));
        }
        prop_assert_eq!(got, ps);
        prop_assert_eq!(d.stats().skipped_bytes, 0);
    }

    #[test]
    fn any_bytes_are_survived(bytes in prop::collection::vec(any::<u8>(), 0..3000), cut in 1usize..64) {
        let mut d = Decoder::default();
        for c in bytes.chunks(cut) {
            let _ = d.push(c);
        }
    }

    #[test]
    fn packets_are_found_between_garbage(
        ps in prop::collection::vec(packet(), 1..5),
        // garbage without FD cannot fake a header
        junk in prop::collection::vec(prop::collection::vec(any::<u8>().prop_filter("no FD", |b| *b != 0xFD), 0..50), 1..5),
    ) {
        let mut stream = Vec::new();
        for (k, p) in ps.iter().enumerate() {
            stream.extend(&junk[k % junk.len()]);
            stream.extend(p.encode());
        }
        let mut d = Decoder::default();
        prop_assert_eq!(d.push(&stream), ps);
    }
}
