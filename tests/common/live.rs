//! A plain client of the Foxglove WebSocket protocol, for tests of `--live`.

use std::collections::BTreeMap;
use std::io::{BufRead, BufReader};
use std::process::Child;

use tungstenite::client::IntoClientRequest;
use tungstenite::Message;

/// Reads the live view's address from the first line `child` (a `tmo ... --live
/// 127.0.0.1:0`, its stderr piped) says, connects, subscribes to the thumb's pin channel
/// `/tactile/0` and returns the sequence numbers of the first `n` frames it receives (the
/// pin scene `/tactile/scene` must be advertised beside it). Each frame is checked:
/// wall-clock log time, schema `tmo.PinFrame`, sensor 0, 30 pins.
pub fn pin_frames(child: &mut Child, n: usize) -> Vec<u64> {
    let received = receive(child, &[("/tactile/0", "tmo.PinFrame")], n);
    received["/tactile/0"]
        .iter()
        .map(|v| {
            assert_eq!(v["sensor"], 0);
            assert_eq!(v["x"].as_array().unwrap().len(), 30);
            v["seq"].as_u64().unwrap()
        })
        .collect()
}

/// Like [`pin_frames`], for any channels: subscribes to each `(topic, schema name)` as it is
/// advertised and returns the first `n` messages of each, in order. A stream that stalls
/// fails the test with what tmo said instead of hanging it.
pub fn receive(
    child: &mut Child,
    topics: &[(&str, &str)],
    n: usize,
) -> BTreeMap<String, Vec<serde_json::Value>> {
    let url = address(child);
    let mut request = url.as_str().into_client_request().unwrap();
    request
        .headers_mut()
        .insert("Sec-WebSocket-Protocol", "foxglove.sdk.v1".parse().unwrap());
    let (mut ws, _) = tungstenite::connect(request).unwrap();
    if let tungstenite::stream::MaybeTlsStream::Plain(s) = ws.get_ref() {
        s.set_read_timeout(Some(std::time::Duration::from_secs(30)))
            .unwrap();
    }
    let mut received: BTreeMap<String, Vec<serde_json::Value>> = BTreeMap::new();
    let mut subscribed = false;
    let started = std::time::Instant::now();
    while topics
        .iter()
        .any(|(t, _)| received.get(*t).map_or(0, |m| m.len()) < n)
    {
        assert!(
            started.elapsed().as_secs() < 60,
            "not every channel sent within a minute: {:?}",
            received
                .iter()
                .map(|(t, m)| (t, m.len()))
                .collect::<Vec<_>>()
        );
        let message = match ws.read() {
            Ok(m) => m,
            Err(e) => {
                let _ = child.kill();
                let mut rest = String::new();
                let _ = std::io::Read::read_to_string(child.stderr.as_mut().unwrap(), &mut rest);
                panic!("{e} after {received:?}; tmo said, after its address: {rest}");
            }
        };
        match message {
            Message::Text(text) => {
                let v: serde_json::Value = serde_json::from_str(&text).unwrap();
                if v["op"] != "advertise" || subscribed {
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
                // phases, commands, detections and faults as Foxglove's own log lines
                let log = channels.iter().find(|c| c["topic"] == "/log");
                assert_eq!(
                    log.map(|c| c["schemaName"].clone()),
                    Some(serde_json::json!("foxglove.Log")),
                    "{channels:?}"
                );
                let mut subscriptions = Vec::new();
                for (k, (topic, schema)) in topics.iter().enumerate() {
                    let c = channels
                        .iter()
                        .find(|c| c["topic"] == *topic)
                        .unwrap_or_else(|| panic!("{topic} is not advertised: {channels:?}"));
                    assert_eq!(c["schemaName"], *schema, "{topic}");
                    subscriptions.push(serde_json::json!({"id": k + 1, "channelId": c["id"]}));
                }
                let subscribe =
                    serde_json::json!({"op": "subscribe", "subscriptions": subscriptions});
                ws.send(Message::text(subscribe.to_string())).unwrap();
                subscribed = true;
            }
            // opcode 1 (message data), subscription id, log time (ns), the message
            Message::Binary(b) if b.first() == Some(&1) => {
                let id = u32::from_le_bytes(b[1..5].try_into().unwrap()) as usize;
                let (topic, _) = topics[id - 1];
                let log_time = u64::from_le_bytes(b[5..13].try_into().unwrap());
                assert!(
                    log_time > 1_700_000_000_000_000_000,
                    "wall-clock time: {log_time}"
                );
                let v: serde_json::Value = serde_json::from_slice(&b[13..]).unwrap();
                received.entry(topic.to_string()).or_default().push(v);
            }
            _ => {}
        }
    }
    received
}

/// The live view's address from the first line `child` (its stderr piped) says that has
/// one (warnings may come before it).
pub fn address(child: &mut Child) -> String {
    let mut said = String::new();
    let mut stderr = BufReader::new(child.stderr.as_mut().unwrap());
    loop {
        let mut line = String::new();
        if stderr.read_line(&mut line).unwrap() == 0 {
            panic!("no address in {said:?}");
        }
        said.push_str(&line);
        if let Some(w) = line.split_whitespace().find(|w| w.starts_with("ws://")) {
            return w.trim_end_matches(':').to_string();
        }
    }
}

/// Connects to `url` asking for `subprotocol` only.
pub fn connect(
    url: &str,
    subprotocol: &str,
) -> tungstenite::Result<
    tungstenite::WebSocket<tungstenite::stream::MaybeTlsStream<std::net::TcpStream>>,
> {
    let mut request = url.into_client_request().unwrap();
    request
        .headers_mut()
        .insert("Sec-WebSocket-Protocol", subprotocol.parse().unwrap());
    let (ws, _) = tungstenite::connect(request)?;
    if let tungstenite::stream::MaybeTlsStream::Plain(s) = ws.get_ref() {
        s.set_read_timeout(Some(std::time::Duration::from_secs(30)))
            .unwrap();
    }
    Ok(ws)
}

/// Subscribes to `topic` once advertised and collects `(log time ns, message)` until the
/// server closes the connection; whether it sent a close frame.
pub fn until_closed(
    ws: &mut tungstenite::WebSocket<tungstenite::stream::MaybeTlsStream<std::net::TcpStream>>,
    topic: &str,
) -> (Vec<(u64, serde_json::Value)>, bool) {
    let mut got = Vec::new();
    let mut subscribed = false;
    loop {
        match ws.read() {
            Ok(Message::Text(text)) => {
                let v: serde_json::Value = serde_json::from_str(&text).unwrap();
                if v["op"] != "advertise" || subscribed {
                    continue;
                }
                let c = v["channels"]
                    .as_array()
                    .unwrap()
                    .iter()
                    .find(|c| c["topic"] == topic)
                    .unwrap_or_else(|| panic!("{topic} is not advertised: {v}"))
                    .clone();
                let subscribe = serde_json::json!({"op": "subscribe", "subscriptions": [{"id": 1, "channelId": c["id"]}]});
                ws.send(Message::text(subscribe.to_string())).unwrap();
                subscribed = true;
            }
            Ok(Message::Binary(b)) if b.first() == Some(&1) => {
                let log_time = u64::from_le_bytes(b[5..13].try_into().unwrap());
                got.push((log_time, serde_json::from_slice(&b[13..]).unwrap()));
            }
            Ok(Message::Close(_)) => {
                // the closing handshake: read on until the server ends it
                while ws.read().is_ok() {}
                return (got, true);
            }
            Ok(_) => {}
            Err(tungstenite::Error::ConnectionClosed) => return (got, true),
            Err(_) => return (got, false),
        }
    }
}
