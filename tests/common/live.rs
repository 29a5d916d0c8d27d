//! A plain client of the Foxglove WebSocket protocol, for tests of `--live`.

use std::io::{BufRead, BufReader};
use std::process::Child;

use tungstenite::client::IntoClientRequest;
use tungstenite::Message;

/// Reads the live view's address from the first line `child` (a `tmo ... --live
/// 127.0.0.1:0`, its stderr piped) says, connects, subscribes to the thumb's pin channel
/// `/tactile/0` and returns the sequence numbers of the first `n` frames it receives (the
/// pin scene `/tactile/scene` must be advertised beside it). Each
/// frame is checked: wall-clock log time, schema `tmo.PinFrame`, sensor 0, 30 pins. A
/// stream that stalls fails the test with what tmo said instead of hanging it.
pub fn pin_frames(child: &mut Child, n: usize) -> Vec<u64> {
    let mut said = String::new();
    BufReader::new(child.stderr.as_mut().unwrap())
        .read_line(&mut said)
        .unwrap();
    let url = said
        .split_whitespace()
        .find(|w| w.starts_with("ws://"))
        .unwrap_or_else(|| panic!("no address in {said:?}"))
        .trim_end_matches(':')
        .to_string();
    let mut request = url.as_str().into_client_request().unwrap();
    request
        .headers_mut()
        .insert("Sec-WebSocket-Protocol", "foxglove.sdk.v1".parse().unwrap());
    let (mut ws, _) = tungstenite::connect(request).unwrap();
    if let tungstenite::stream::MaybeTlsStream::Plain(s) = ws.get_ref() {
        s.set_read_timeout(Some(std::time::Duration::from_secs(30)))
            .unwrap();
    }
    let mut channel = None;
    let mut frames = Vec::new();
    let started = std::time::Instant::now();
    while frames.len() < n {
        assert!(
            started.elapsed().as_secs() < 60,
            "no frames within a minute"
        );
        let message = match ws.read() {
            Ok(m) => m,
            Err(e) => {
                let _ = child.kill();
                let mut rest = String::new();
                let _ = std::io::Read::read_to_string(child.stderr.as_mut().unwrap(), &mut rest);
                panic!("{e} after {} frames; tmo said: {said}{rest}", frames.len());
            }
        };
        match message {
            Message::Text(text) => {
                let v: serde_json::Value = serde_json::from_str(&text).unwrap();
                if v["op"] != "advertise" || channel.is_some() {
                    continue;
                }
                let channels = v["channels"].as_array().unwrap();
                // the pin fields as a well-known scene, for Foxglove's 3D panel
                let scene = channels.iter().find(|c| c["topic"] == "/tactile/scene");
                assert_eq!(
                    scene.map(|c| c["schemaName"].clone()),
                    Some(serde_json::json!("foxglove.SceneUpdate")),
                    "{channels:?}"
                );
                if let Some(c) = channels.iter().find(|c| c["topic"] == "/tactile/0") {
                    assert_eq!(c["schemaName"], "tmo.PinFrame");
                    channel = c["id"].as_u64();
                    let subscribe = serde_json::json!({"op": "subscribe",
                        "subscriptions": [{"id": 7, "channelId": channel}]});
                    ws.send(Message::text(subscribe.to_string())).unwrap();
                }
            }
            // opcode 1 (message data), subscription id, log time (ns), the message
            Message::Binary(b) if b.first() == Some(&1) => {
                assert_eq!(u32::from_le_bytes(b[1..5].try_into().unwrap()), 7);
                let log_time = u64::from_le_bytes(b[5..13].try_into().unwrap());
                assert!(
                    log_time > 1_700_000_000_000_000_000,
                    "wall-clock time: {log_time}"
                );
                let v: serde_json::Value = serde_json::from_slice(&b[13..]).unwrap();
                assert_eq!(v["sensor"], 0);
                assert_eq!(v["x"].as_array().unwrap().len(), 30);
                frames.push(v["seq"].as_u64().unwrap());
            }
            _ => {}
        }
    }
    frames
}
