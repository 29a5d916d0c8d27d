//! Property tests of the JeVois line parser and reader: no input crashes them, valid lines
//! survive any chunking and any garbage around them.

use proptest::prelude::*;
use tmo_hal::wire::jevois::{format_fine2, parse_line, LineReader, Message};

fn points() -> impl Strategy<Value = Vec<[f32; 2]>> {
    prop::collection::vec([-1000.0f32..1000.0, -1000.0f32..1000.0], 0..40)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 512, failure_persistence: None, ..ProptestConfig::default() })]

    #[test]
    fn any_text_parses_or_is_refused_without_panicking(s in ".{0,300}") {
        let _ = parse_line(&s);
    }

    #[test]
    fn any_bytes_in_any_chunks_are_survived(
        bytes in prop::collection::vec(any::<u8>(), 0..2000),
        cut in 1usize..64,
    ) {
        let mut r = LineReader::default();
        for c in bytes.chunks(cut) {
            let _ = r.push(c);
        }
        let s = r.stats();
        prop_assert!(s.messages + s.dropped_total() <= s.lines);
    }

    #[test]
    fn formatted_frames_round_trip(p in points(), stamp in proptest::option::of(0u32..100000)) {
        let stamp = stamp.map(|s| s.to_string());
        let line = format_fine2(stamp.as_deref(), "pins", &p);
        let m = parse_line(line.trim_end()).unwrap();
        prop_assert_eq!(m.stamp, stamp);
        let Message::Fine2 { points, .. } = m.message else { panic!("not F2") };
        prop_assert_eq!(points.len(), p.len());
        for (a, b) in points.iter().zip(&p) {
            prop_assert!((a[0] - b[0]).abs() <= 6e-4 && (a[1] - b[1]).abs() <= 6e-4);
        }
    }

    #[test]
    fn valid_frames_survive_garbage_and_chunking(
        frames in prop::collection::vec(points(), 1..8),
        garbage in prop::collection::vec(prop::collection::vec(any::<u8>().prop_filter("no newline", |b| *b != b'\n'), 0..80), 1..8),
        cut in 1usize..50,
    ) {
        let mut stream = Vec::new();
        for (k, p) in frames.iter().enumerate() {
            // garbage on a line of its own, then a valid frame
            stream.extend_from_slice(&garbage[k % garbage.len()]);
            stream.extend_from_slice(b"\r\n");
            stream.extend_from_slice(format_fine2(None, "pins", p).as_bytes());
        }
        let mut r = LineReader::default();
        let mut got = Vec::new();
        for c in stream.chunks(cut) {
            got.extend(r.push(c));
        }
        // garbage that happens to be a valid message line is a message too
        let fine: Vec<_> = got.iter().filter(|m| matches!(&m.message, Message::Fine2 { id, .. } if id == "pins")).collect();
        prop_assert!(fine.len() >= frames.len());
    }
}
