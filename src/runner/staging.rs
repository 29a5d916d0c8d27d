//! Between trials on the real backend, the rig is set up for the next one: by an operator
//! at a terminal on hardware, by a reset request when the rig is `tmo sim serve`, or by
//! nobody when the trials end as they began (the lifts) or the user says the rig resets
//! itself (`--unattended`).

use std::io::{BufRead, IsTerminal};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc;
use std::time::Duration;

use tmo_sim::serve::control::SimControlClient;

use super::batch::{BatchError, PlannedTrial};
use super::sim_trial::world_for;
use crate::protocol::{Kind, KindParams, Plan};
use crate::runner::hardware::HardwareFile;

pub enum Staging {
    /// The served simulator: each trial's world (the sim backend's, seed for seed) is sent
    /// to its control port.
    Served(SimControlClient),
    /// Somebody at the terminal sets the rig up and presses Enter.
    Operator,
    Unattended,
}

/// Does `kind` end each trial as it began (object on the table, hand open)?
pub fn ends_as_it_began(kind: Kind) -> bool {
    matches!(kind, Kind::FirstTimeLift | Kind::CalibrateLift)
}

impl Staging {
    /// How a batch of `kind` on the rig `hw` describes is set up between trials.
    pub fn for_batch(hw: &HardwareFile, kind: Kind, unattended: bool) -> Result<Self, BatchError> {
        if let Some(s) = &hw.served_simulator {
            return Ok(Staging::Served(SimControlClient::connect(&s.control)?));
        }
        if unattended || ends_as_it_began(kind) {
            return Ok(Staging::Unattended);
        }
        if !std::io::stdin().is_terminal() {
            return Err(BatchError::NeedsOperator(kind));
        }
        Ok(Staging::Operator)
    }

    /// Sets the rig up for `planned`; `Ok(false)` if it was not (`stop` was set, or the
    /// operator's terminal closed, while waiting).
    pub fn stage(
        &mut self,
        plan: &Plan,
        planned: &PlannedTrial,
        stop: &AtomicBool,
    ) -> Result<bool, BatchError> {
        match self {
            Staging::Served(control) => {
                control.reset(&world_for(plan, planned)?)?;
                Ok(true)
            }
            Staging::Unattended => Ok(true),
            Staging::Operator => {
                eprintln!(
                    "\n{}: {} Then press Enter (Ctrl-C stops the batch).",
                    planned.trial_id,
                    instructions(plan, planned)
                );
                Ok(wait_for_enter(stop))
            }
        }
    }
}

/// What the operator does before a trial of `plan`.
pub fn instructions(plan: &Plan, planned: &PlannedTrial) -> String {
    let (o, deg) = (&planned.object, planned.grasp_deg);
    match &plan.params {
        KindParams::HandRelease(_) => format!(
            "stand {o}{} on the table between the open fingers, hand at {deg} deg; the hand closes on it",
            if planned.extra_mass_g > 0.0 {
                format!(" with {:.0} g added", planned.extra_mass_g)
            } else {
                String::new()
            }
        ),
        KindParams::RailCatch(_) => format!(
            "put {o} on the rail, pressed against the fingertip, clear of the end stops"
        ),
        KindParams::RicePour(p) => format!(
            "hold {o}{} between the open fingers, hand at {deg} deg; the hand closes on it: let go once it holds, and pour {:.0} g at {:.0} g/s from a second later",
            if o.ends_with("_empty") { "" } else { " (emptied)" },
            p.total_g,
            p.pour_rate_g_per_s
        ),
        KindParams::FirstTimeLift(_) | KindParams::CalibrateLift(_) => format!(
            "stand {o} with {:.0} g added on the table between the open fingers",
            planned.extra_mass_g
        ),
    }
}

/// Waits for a line on stdin, checking `stop` meanwhile (a blocking read does not see
/// Ctrl-C: the handler only sets the flag). `false` if stopped or stdin closed.
fn wait_for_enter(stop: &AtomicBool) -> bool {
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        let mut line = String::new();
        let ok = std::io::stdin()
            .lock()
            .read_line(&mut line)
            .is_ok_and(|n| n > 0);
        let _ = tx.send(ok);
    });
    loop {
        if stop.load(Ordering::Relaxed) {
            return false;
        }
        match rx.recv_timeout(Duration::from_millis(100)) {
            Ok(ok) => return ok,
            Err(mpsc::RecvTimeoutError::Timeout) => {}
            Err(mpsc::RecvTimeoutError::Disconnected) => return false,
        }
    }
}
