//! Property tests of the RTDE codec: messages and values round-trip through any chunking of
//! the TCP stream; no byte stream or payload crashes the decoders.

use proptest::prelude::*;
use tmo_hal::wire::rtde::{
    decode_values, encode_values, ClientMessage, Framer, ServerMessage, Value, VarType,
};

fn value() -> impl Strategy<Value = Value> {
    let f = -1e6f64..1e6;
    prop_oneof![
        any::<bool>().prop_map(Value::Bool),
        any::<u8>().prop_map(Value::Uint8),
        any::<u32>().prop_map(Value::Uint32),
        any::<u64>().prop_map(Value::Uint64),
        any::<i32>().prop_map(Value::Int32),
        f.clone().prop_map(Value::Double),
        prop::array::uniform3(f.clone()).prop_map(Value::Vector3d),
        prop::array::uniform6(f).prop_map(Value::Vector6d),
        prop::array::uniform6(any::<i32>()).prop_map(Value::Vector6Int32),
        prop::array::uniform6(any::<u32>()).prop_map(Value::Vector6Uint32),
    ]
}

fn name() -> impl Strategy<Value = String> {
    "[a-zA-Z_][a-zA-Z0-9_]{0,30}"
}

fn client() -> impl Strategy<Value = ClientMessage> {
    prop_oneof![
        any::<u16>().prop_map(ClientMessage::RequestProtocolVersion),
        Just(ClientMessage::GetUrcontrolVersion),
        (1.0f64..500.0, prop::collection::vec(name(), 1..10)).prop_map(
            |(frequency_hz, variables)| {
                ClientMessage::SetupOutputs {
                    frequency_hz,
                    variables,
                }
            }
        ),
        prop::collection::vec(name(), 1..10)
            .prop_map(|variables| ClientMessage::SetupInputs { variables }),
        Just(ClientMessage::Start),
        Just(ClientMessage::Pause),
        (any::<u8>(), prop::collection::vec(value(), 0..6))
            .prop_map(|(recipe, values)| ClientMessage::data(recipe, &values)),
    ]
}

fn server() -> impl Strategy<Value = ServerMessage> {
    prop_oneof![
        any::<bool>().prop_map(ServerMessage::ProtocolVersionAccepted),
        (any::<u32>(), any::<u32>(), any::<u32>(), any::<u32>()).prop_map(
            |(major, minor, bugfix, build)| {
                ServerMessage::UrcontrolVersion {
                    major,
                    minor,
                    bugfix,
                    build,
                }
            }
        ),
        (any::<u8>(), prop::collection::vec("[A-Z0-9_]{1,13}", 1..8))
            .prop_map(|(id, types)| ServerMessage::Recipe { id, types }),
        any::<bool>().prop_map(ServerMessage::Started),
        any::<bool>().prop_map(ServerMessage::Paused),
        (".{0,60}", "[a-zA-Z]{0,20}", 0u8..4).prop_map(|(message, source, level)| {
            ServerMessage::Text {
                message,
                source,
                level,
            }
        }),
        (any::<u8>(), prop::collection::vec(value(), 0..6)).prop_map(|(recipe, values)| {
            ServerMessage::Data {
                recipe,
                payload: encode_values(&values),
            }
        }),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 512, failure_persistence: None, ..ProptestConfig::default() })]

    #[test]
    fn client_messages_round_trip(ms in prop::collection::vec(client(), 1..6), cut in 1usize..40) {
        let bytes: Vec<u8> = ms.iter().flat_map(|m| m.encode().unwrap()).collect();
        let mut f = Framer::default();
        let mut got = Vec::new();
        for c in bytes.chunks(cut) {
            for (code, p) in f.push(c).unwrap() {
                got.push(ClientMessage::decode(code, &p).unwrap());
            }
        }
        prop_assert_eq!(got, ms);
    }

    #[test]
    fn server_messages_round_trip(ms in prop::collection::vec(server(), 1..6), cut in 1usize..40) {
        let bytes: Vec<u8> = ms.iter().flat_map(|m| m.encode().unwrap()).collect();
        let mut f = Framer::default();
        let mut got = Vec::new();
        for c in bytes.chunks(cut) {
            for (code, p) in f.push(c).unwrap() {
                got.push(ServerMessage::decode(code, &p).unwrap());
            }
        }
        prop_assert_eq!(got, ms);
    }

    #[test]
    fn values_round_trip(vs in prop::collection::vec(value(), 0..12)) {
        let types: Vec<VarType> = vs.iter().map(|v| v.var_type()).collect();
        prop_assert_eq!(decode_values(&encode_values(&vs), &types).unwrap(), vs);
    }

    #[test]
    fn arbitrary_bytes_never_panic(bytes in prop::collection::vec(any::<u8>(), 0..2000), cut in 1usize..64) {
        let mut f = Framer::default();
        for c in bytes.chunks(cut) {
            if let Ok(packages) = f.push(c) {
                for (code, p) in packages {
                    let _ = ServerMessage::decode(code, &p);
                    let _ = ClientMessage::decode(code, &p);
                    let _ = decode_values(&p, &[VarType::Double, VarType::Vector6d]);
                }
            }
        }
    }
}
