//! Serving the live view from `tmo run` and `tmo replay`: the address, the subprotocols a
//! viewer must speak, and waiting for the first viewer before the first trial.

use std::net::SocketAddr;
use std::sync::atomic::AtomicBool;
use std::time::Duration;

use anyhow::Result;
use tmo::live::LiveView;

/// Where to serve the live view, and how long to wait for a viewer before the first trial.
#[derive(Debug, Clone, Copy)]
pub struct LiveArgs {
    pub addr: SocketAddr,
    pub wait_s: Option<f64>,
}

/// `--live-wait`'s value: seconds, more than 0 and at most a day.
pub fn parse_wait(text: &str) -> Result<f64, String> {
    match text.parse::<f64>() {
        Ok(s) if s > 0.0 && s <= 86_400.0 => Ok(s),
        _ => Err(format!(
            "expected seconds, more than 0 and at most 86400, got {text:?}"
        )),
    }
}

/// Starts the view for `sensors` fingertips, says where it is (and `how` the trials play),
/// and with `--live-wait` waits for a viewer, saying whether one came.
pub fn serve(live: LiveArgs, sensors: u8, how: &str, stop: &AtomicBool) -> Result<LiveView> {
    let view = LiveView::start(live.addr, sensors)?;
    eprintln!(
        "live view at {url}: in Foxglove, Open connection > Foxglove WebSocket > {url} ({how}; \
         the server speaks foxglove.sdk.v1 and foxglove.sdk.v1.1, and refuses a client that \
         asks only for the older foxglove.websocket.v1)",
        url = view.url()
    );
    if let Some(wait_s) = live.wait_s {
        super::output::note(format!(
            "waiting up to {} s for a viewer before the first trial",
            tmo::quote::number(wait_s)
        ));
        if view.wait_for_viewer(Duration::from_secs_f64(wait_s), stop) {
            super::output::note("a viewer is watching; starting");
        } else {
            eprintln!(
                "warning: no viewer subscribed within {} s; starting without one",
                tmo::quote::number(wait_s)
            );
        }
    }
    Ok(view)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_wait_is_a_positive_number_of_seconds() {
        assert_eq!(parse_wait("30"), Ok(30.0));
        assert_eq!(parse_wait("0.5"), Ok(0.5));
        for bad in ["0", "-1", "inf", "NaN", "ten", "1e300"] {
            let e = parse_wait(bad).unwrap_err();
            assert!(e.contains("expected seconds"), "{bad}: {e}");
        }
    }
}
