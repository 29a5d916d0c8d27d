//! A live view of the rig while a batch runs: the trial log's channels, with the same
//! schemas and messages, served over the Foxglove WebSocket protocol by the official
//! Foxglove SDK (`foxglove`), so Foxglove (or any client of that protocol) can watch.
//!
//! Publishing never waits for a viewer: the SDK queues each client's messages and drops
//! them for a client that cannot keep up, so the control loop's timing does not depend on
//! who watches.

use std::collections::HashMap;
use std::net::SocketAddr;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use foxglove::{RawChannel, Schema};
use tmo_hal::{MarkerSample, PinFrame};

use crate::slip::Class;
use crate::trial::schema;
use crate::trial::{Trial, TrialEvent};

pub mod scene;
pub mod served;

#[derive(Debug, thiserror::Error)]
pub enum LiveError {
    #[error("cannot serve the live view on {addr}: {message}")]
    Serve { addr: SocketAddr, message: String },
}

/// The channels the runners write beside one `/tactile/<k>` per fingertip.
const ANNOUNCED_TOPICS: [&str; 9] = [
    "/marker",
    "/phase",
    "/command/hand",
    "/command/arm",
    "/state/hand",
    "/state/arm",
    "/classifier",
    "/detector",
    "/fault",
];

/// The live view's server and its channels (made as topics first appear); clones share
/// them.
#[derive(Clone)]
pub struct LiveView {
    inner: Arc<Inner>,
}

struct Inner {
    ctx: Arc<foxglove::Context>,
    port: u16,
    host: String,
    channels: Mutex<HashMap<String, Arc<RawChannel>>>,
    /// Every fingertip's pin field as a well-known scene (live only: see `scene`).
    scene: foxglove::Channel<foxglove::messages::SceneUpdate>,
    /// Phases, commands, detections and faults as the well-known `foxglove.Log`, for
    /// Foxglove's Log panel; the plots read the same events on their own channels.
    log: foxglove::Channel<foxglove::messages::Log>,
    /// The latest log time sent, ns: a trial's messages start after it, so a viewer's
    /// clock never runs back at a trial boundary (trials of one batch share a start).
    last_sent_ns: AtomicU64,
    // kept for as long as the view; stopped gracefully when it goes (see Drop)
    server: Mutex<Option<foxglove::WebSocketServerHandle>>,
    /// When a viewer first subscribed to a channel.
    viewers: Arc<ViewerWatch>,
}

/// Notes when a viewer first subscribes to one of the view's channels (the SDK calls it
/// from a client's poll loop, so it only records).
#[derive(Default)]
struct ViewerWatch {
    first_subscribed: Mutex<Option<Instant>>,
}

impl foxglove::websocket::ServerListener for ViewerWatch {
    fn on_subscribe(
        &self,
        _client: foxglove::websocket::Client,
        _channel: foxglove::websocket::ChannelView,
    ) {
        let mut first = self
            .first_subscribed
            .lock()
            .unwrap_or_else(|e| e.into_inner());
        first.get_or_insert_with(Instant::now);
    }
}

/// How long after a viewer's first subscription [`LiveView::wait_for_viewer`] waits for its
/// others: a viewer subscribes to each of its panels' topics in turn, within a few
/// milliseconds.
const SUBSCRIPTIONS_SETTLE: Duration = Duration::from_millis(500);

/// How long a closing view waits for its clients to take the close frame.
const CLOSE_WAIT: Duration = Duration::from_secs(2);

impl Drop for Inner {
    fn drop(&mut self) {
        // A graceful stop sends each client a close frame; a client that never answers
        // does not hold tmo's exit for more than CLOSE_WAIT.
        let Some(server) = self.server.lock().ok().and_then(|mut s| s.take()) else {
            return;
        };
        let (done, waited) = std::sync::mpsc::channel();
        std::thread::spawn(move || {
            server.stop().wait_blocking();
            let _ = done.send(());
        });
        let _ = waited.recv_timeout(CLOSE_WAIT);
    }
}

impl LiveView {
    /// Serves on `addr` (port 0: any free port; [`LiveView::url`] says which) the channels
    /// of a rig with `sensors` fingertips. The server speaks the SDK's subprotocols
    /// `foxglove.sdk.v1` and `foxglove.sdk.v1.1` (Foxglove's app and its open-source
    /// WebSocket clients ask for them); a client asking only for the older name
    /// `foxglove.websocket.v1` is refused with HTTP 400, as the SDK does not let a server
    /// add a name (docs/commands.md, "Live view").
    pub fn start(addr: SocketAddr, sensors: u8) -> Result<Self, LiveError> {
        let ctx = foxglove::Context::new();
        let viewers = Arc::new(ViewerWatch::default());
        let server = foxglove::WebSocketServer::new()
            .name("tmo")
            .context(&ctx)
            .listener(viewers.clone())
            .bind(addr.ip().to_string(), addr.port())
            .start_blocking()
            .map_err(|e| LiveError::Serve {
                addr,
                message: e.to_string(),
            })?;
        let scene = ctx.channel_builder(scene::SCENE_TOPIC).build();
        let log = ctx.channel_builder(LOG_TOPIC).build();
        let view = Self {
            inner: Arc::new(Inner {
                ctx,
                scene,
                log,
                port: server.port(),
                host: addr.ip().to_string(),
                channels: Mutex::new(HashMap::new()),
                last_sent_ns: AtomicU64::new(0),
                server: Mutex::new(Some(server)),
                viewers,
            }),
        };
        // Every channel the rig writes exists before a viewer can connect: a viewer sees
        // the whole list at once, and no advertisement can cross its connecting (a channel
        // made while a client was connecting was never advertised to it). Only the rig's
        // own fingertips are announced.
        for k in 0..sensors {
            view.channel(&format!("/tactile/{k}"));
        }
        for topic in ANNOUNCED_TOPICS {
            view.channel(topic);
        }
        Ok(view)
    }

    /// Waits until a viewer has subscribed to the view's channels (and half a second more,
    /// for its other subscriptions), at most `timeout`; `false` if none came in time or
    /// `stop` was set. Before the first trial, so a viewer sees it from its start.
    pub fn wait_for_viewer(&self, timeout: Duration, stop: &AtomicBool) -> bool {
        let deadline = Instant::now() + timeout;
        loop {
            let first = *self
                .inner
                .viewers
                .first_subscribed
                .lock()
                .unwrap_or_else(|e| e.into_inner());
            if let Some(first) = first {
                let settled = first + SUBSCRIPTIONS_SETTLE;
                std::thread::sleep(settled.saturating_duration_since(Instant::now()));
                return true;
            }
            if stop.load(Ordering::Relaxed) || Instant::now() >= deadline {
                return false;
            }
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    /// The address a Foxglove WebSocket client connects to.
    pub fn url(&self) -> String {
        format!("ws://{}:{}", self.inner.host, self.inner.port)
    }

    /// A publisher for one trial whose clock starts at `started_unix_ns` (the log's time
    /// base). `pace`: hold the trial to wall-clock speed (the simulator's clock would
    /// otherwise run thousands of times faster than anyone can watch).
    pub fn trial(&self, started_unix_ns: u64, pace: bool) -> LivePublisher {
        // after everything sent so far (1 ms on), so times never run back between trials
        let last = self.inner.last_sent_ns.load(Ordering::Relaxed);
        let base_ns = if last == 0 {
            started_unix_ns
        } else {
            started_unix_ns.max(last.saturating_add(1_000_000))
        };
        LivePublisher {
            view: self.clone(),
            base_ns,
            pace: pace.then(|| (Instant::now(), None)),
            frames: 0,
            markers: 0,
            events: 0,
            classes: Vec::new(),
        }
    }

    /// Plays a recorded trial to the viewers at wall-clock speed, every channel as it was
    /// logged (frames at their arrival, markers and events at their times), in steps of one
    /// 60 fps frame. Returns `false` if `stop` was set before the trial's end.
    pub fn play(&self, trial: &Trial, stop: &AtomicBool) -> bool {
        const STEP_S: f64 = 1.0 / 60.0;
        let end = [
            trial.arrivals_s.last().copied(),
            trial.markers.last().map(|m| m.time_s),
            trial.events.last().map(|e| e.time_s),
        ]
        .into_iter()
        .flatten()
        .fold(0.0, f64::max);
        let mut publisher = self.trial(crate::trial::time_base_ns(&trial.meta), true);
        let mut t = 0.0;
        loop {
            // logs keep frames in arrival order and markers and events in time order
            let frames = trial.arrivals_s.partition_point(|&a| a <= t);
            let markers = trial.markers.partition_point(|m| m.time_s <= t);
            let events = trial.events.partition_point(|e| e.time_s <= t);
            publisher.publish(
                t,
                &trial.frames[..frames],
                &trial.arrivals_s[..frames],
                &trial.markers[..markers],
                &trial.events[..events],
            );
            if t > end {
                return true;
            }
            if stop.load(Ordering::Relaxed) {
                return false;
            }
            t += STEP_S;
        }
    }

    fn channel(&self, topic: &str) -> Option<Arc<RawChannel>> {
        let mut channels = self
            .inner
            .channels
            .lock()
            .unwrap_or_else(|e| e.into_inner());
        if let Some(c) = channels.get(topic) {
            return Some(c.clone());
        }
        let (name, text) = if topic.starts_with("/tactile/") {
            (schema::PIN_FRAME.0, schema::PIN_FRAME.1.to_string())
        } else if topic == "/marker" {
            (schema::MARKER.0, schema::MARKER.1.to_string())
        } else {
            schema::event_channel_schema(topic)
        };
        let channel = self
            .inner
            .ctx
            .channel_builder(topic)
            .message_encoding("json")
            .schema(Schema::new(name, "jsonschema", text.into_bytes()))
            .build_raw()
            .ok()?;
        channels.insert(topic.to_string(), channel.clone());
        Some(channel)
    }

    /// A pin frame on `/tactile/<sensor>` and, coloured by `class`, in the pin scene.
    fn send_frame(&self, f: &PinFrame, class: Option<Class>, log_time_ns: u64) {
        let body = serde_json::to_vec(&schema::PinFrameOut::from(f)).expect("frames serialise");
        self.publish(&format!("/tactile/{}", f.sensor), &body, log_time_ns);
        self.inner.scene.log_with_meta(
            &scene::pin_scene(f, class),
            foxglove::PartialMetadata {
                log_time: Some(log_time_ns),
            },
        );
    }

    fn send_marker(&self, m: &MarkerSample, log_time_ns: u64) {
        let body = serde_json::to_vec(m).expect("samples serialise");
        self.publish("/marker", &body, log_time_ns);
    }

    fn send_event(&self, e: &TrialEvent, log_time_ns: u64) {
        let body = serde_json::to_vec(e).expect("events serialise");
        self.publish(&e.topic, &body, log_time_ns);
        if let Some(line) = log_line(e, log_time_ns) {
            self.inner.log.log_with_meta(
                &line,
                foxglove::PartialMetadata {
                    log_time: Some(log_time_ns),
                },
            );
        }
    }

    fn publish(&self, topic: &str, message: &[u8], log_time_ns: u64) {
        self.inner
            .last_sent_ns
            .fetch_max(log_time_ns, Ordering::Relaxed);
        if let Some(c) = self.channel(topic) {
            c.log_with_meta(
                message,
                foxglove::PartialMetadata {
                    log_time: Some(log_time_ns),
                },
            );
        }
    }
}

/// The topic of the live view's `foxglove.Log` lines.
pub const LOG_TOPIC: &str = "/log";

/// An event as a `foxglove.Log` line: phases, commands and the detector being armed or
/// disarmed as info, a detection (the detector's reaction) as a warning, faults as errors;
/// the per-frame classifier outputs and state samples are left to the plots (a line per
/// frame would bury the rest).
pub fn log_line(e: &TrialEvent, log_time_ns: u64) -> Option<foxglove::messages::Log> {
    use foxglove::messages::log::Level;
    let level = match e.topic.as_str() {
        "/fault" => Level::Error,
        "/detector" if matches!(e.data["event"].as_str(), Some("armed" | "disarmed")) => {
            Level::Info
        }
        "/detector" => Level::Warning,
        "/phase" | "/command/hand" | "/command/arm" => Level::Info,
        _ => return None,
    };
    let ns = 1_000_000_000;
    Some(foxglove::messages::Log {
        timestamp: Some(foxglove::messages::Timestamp::new(
            u32::try_from(log_time_ns / ns).unwrap_or(u32::MAX),
            (log_time_ns % ns) as u32,
        )),
        level: level as i32,
        message: format!("{} {}", e.topic, e.data),
        name: "tmo".into(),
        file: String::new(),
        line: 0,
    })
}

/// Publishes one trial's messages as they are recorded.
pub struct LivePublisher {
    view: LiveView,
    base_ns: u64,
    /// Wall-clock instant and trial time of the first tick, when pacing.
    pace: Option<(Instant, Option<f64>)>,
    /// How many of the recording's frames and markers and the runner's events went out.
    frames: usize,
    markers: usize,
    events: usize,
    /// Each sensor's latest class from the classifier's events, for the pin scene.
    classes: Vec<Option<Class>>,
}

impl LivePublisher {
    /// Takes a `/classifier` event's sensor and class.
    fn note_class(&mut self, data: &serde_json::Value) {
        let sensor = data["sensor"]
            .as_u64()
            .and_then(|s| usize::try_from(s).ok());
        let class = serde_json::from_value::<Class>(data["class"].clone()).ok();
        if let (Some(sensor), Some(class)) = (sensor.filter(|&s| s < 256), class) {
            if self.classes.len() <= sensor {
                self.classes.resize(sensor + 1, None);
            }
            self.classes[sensor] = Some(class);
        }
    }

    fn at(&self, t: f64) -> u64 {
        self.base_ns
            .saturating_add((t.max(0.0) * 1e9).round() as u64)
    }

    /// Sends the frames (each at its arrival time), markers and events recorded since the
    /// last call; then, when pacing, waits until wall-clock time catches up with `now`.
    /// Runners call it before they wait for the next tick, so a tick's frames go out after
    /// the runner has acted on them, never in the way of a reaction.
    pub fn publish(
        &mut self,
        now: f64,
        frames: &[PinFrame],
        arrivals_s: &[f64],
        markers: &[MarkerSample],
        events: &[TrialEvent],
    ) {
        // a frame and its classification are recorded in the same tick: the scene takes
        // the tick's classes first, so a frame's pins show its own class
        for e in events.get(self.events..).unwrap_or_default() {
            if e.topic == "/classifier" {
                self.note_class(&e.data);
            }
        }
        let new = frames.get(self.frames..).unwrap_or_default();
        for (f, arrived) in new
            .iter()
            .zip(arrivals_s.get(self.frames..).unwrap_or_default())
        {
            let class = self.classes.get(usize::from(f.sensor)).copied().flatten();
            self.view.send_frame(f, class, self.at(*arrived));
        }
        self.frames = frames.len();
        for m in markers.get(self.markers..).unwrap_or_default() {
            self.view.send_marker(m, self.at(m.time_s));
        }
        self.markers = markers.len();
        for e in events.get(self.events..).unwrap_or_default() {
            self.view.send_event(e, self.at(e.time_s));
        }
        self.events = events.len();
        if let Some((wall0, trial0)) = &mut self.pace {
            let t0 = *trial0.get_or_insert(now);
            let due = Duration::from_secs_f64((now - t0).max(0.0));
            if let Some(wait) = due.checked_sub(wall0.elapsed()) {
                std::thread::sleep(wait);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn events_become_log_lines_by_their_weight() {
        use foxglove::messages::log::Level;
        let event = |topic: &str| TrialEvent {
            time_s: 1.0,
            topic: topic.into(),
            data: serde_json::json!({"phase": "lifting"}),
        };
        let line = log_line(&event("/phase"), 1_500_000_000).unwrap();
        assert_eq!(line.level, Level::Info as i32);
        assert_eq!(line.message, r#"/phase {"phase":"lifting"}"#);
        assert_eq!(line.timestamp.unwrap().sec(), 1);
        assert_eq!(
            log_line(&event("/fault"), 0).unwrap().level,
            Level::Error as i32
        );
        let detector = |what: &str| TrialEvent {
            time_s: 1.0,
            topic: "/detector".into(),
            data: serde_json::json!({ "event": what }),
        };
        assert_eq!(
            log_line(&detector("reaction"), 0).unwrap().level,
            Level::Warning as i32
        );
        for what in ["armed", "disarmed"] {
            assert_eq!(
                log_line(&detector(what), 0).unwrap().level,
                Level::Info as i32
            );
        }
        assert!(log_line(&event("/classifier"), 0).is_none());
        assert!(log_line(&event("/state/hand"), 0).is_none());
    }
}
