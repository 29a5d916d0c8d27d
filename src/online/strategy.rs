//! The `NFr x NSen` decision: a sensor is slipping when its last `NFr` frames were all
//! classified slip; the hand reacts when at least `NSen` sensors are slipping at once.
//!
//! Pure state, fed one classified frame at a time in arrival order; no clocks, no devices.

use crate::slip::Class;

/// `frames` consecutive slip frames per sensor, on at least `sensors` sensors at once.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
pub struct Strategy {
    pub frames: u32,
    pub sensors: u32,
}

#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum StrategyError {
    #[error("`{0}`: expected NFrMSen (or NxM) with N from 1 to 1000 frames and M from 1 to 255 sensors, e.g. 2Fr2Sen or 2x2")]
    Syntax(String),
    #[error("strategy {0} needs {1} sensors, but the rig has {2}")]
    TooManySensors(Strategy, u32, u32),
}

impl std::fmt::Display for Strategy {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}Fr{}Sen", self.frames, self.sensors)
    }
}

impl std::str::FromStr for Strategy {
    type Err = StrategyError;

    /// Accepts the paper's `2Fr2Sen` and the short `2x2`.
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let err = || StrategyError::Syntax(s.to_string());
        let lower = s.trim().to_ascii_lowercase();
        let (a, b) = if let Some(rest) = lower.strip_suffix("sen") {
            rest.split_once("fr").ok_or_else(err)?
        } else {
            lower.split_once('x').ok_or_else(err)?
        };
        // a strategy that waits for more frames than a trial has can never react
        let n = |t: &str, most: u32| {
            t.parse::<u32>()
                .ok()
                .filter(|v| (1..=most).contains(v))
                .ok_or_else(err)
        };
        Ok(Strategy {
            frames: n(a, 1000)?,
            sensors: n(b, 255)?,
        })
    }
}

impl Strategy {
    pub fn check(&self, rig_sensors: u32) -> Result<(), StrategyError> {
        if self.sensors > rig_sensors {
            return Err(StrategyError::TooManySensors(
                *self,
                self.sensors,
                rig_sensors,
            ));
        }
        Ok(())
    }
}

/// Running state of one trial's detector.
#[derive(Debug, Clone, PartialEq)]
pub struct Detector {
    strategy: Strategy,
    /// Consecutive slip frames per sensor, up to the latest frame.
    run: Vec<u32>,
}

impl Detector {
    pub fn new(strategy: Strategy, sensors: usize) -> Self {
        Self {
            strategy,
            run: vec![0; sensors],
        }
    }

    pub fn strategy(&self) -> Strategy {
        self.strategy
    }

    /// Records one classified frame of `sensor`; true when, after it, the hand should react.
    /// Sensors outside the rig are ignored (a fault the runner reports elsewhere).
    pub fn observe(&mut self, sensor: usize, class: Class) -> bool {
        let Some(run) = self.run.get_mut(sensor) else {
            return false;
        };
        *run = match class {
            Class::Slip => run.saturating_add(1),
            Class::Static => 0,
        };
        self.slipping_sensors() >= self.strategy.sensors as usize
    }

    /// Sensors whose last `NFr` frames were all slip.
    pub fn slipping_sensors(&self) -> usize {
        self.run
            .iter()
            .filter(|r| **r >= self.strategy.frames)
            .count()
    }

    /// Forgets every run, e.g. after a reaction so the next one needs fresh evidence.
    pub fn reset(&mut self) {
        self.run.iter_mut().for_each(|r| *r = 0);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use Class::{Slip, Static};

    fn s(text: &str) -> Strategy {
        text.parse().unwrap()
    }

    #[test]
    fn strategies_parse_in_both_spellings() {
        assert_eq!(
            s("2Fr2Sen"),
            Strategy {
                frames: 2,
                sensors: 2
            }
        );
        assert_eq!(
            s("1x3"),
            Strategy {
                frames: 1,
                sensors: 3
            }
        );
        assert_eq!(s("1fr1sen").to_string(), "1Fr1Sen");
        for bad in [
            "",
            "0x1",
            "2x",
            "x2",
            "2Fr",
            "a x b",
            "2y2",
            "4294967295x1",
            "65536x1",
            "1x256",
        ] {
            assert!(bad.parse::<Strategy>().is_err(), "{bad}");
        }
        assert!(s("1x3").check(3).is_ok());
        assert!(s("1x3").check(1).is_err());
    }

    #[test]
    fn two_by_two_reacts_on_the_second_consecutive_slip_frame_of_the_second_sensor() {
        let mut d = Detector::new(s("2x2"), 3);
        // interleaved as the asynchronous sensors deliver
        let events = [
            (0, Slip),   // sensor 0: 1
            (1, Slip),   // sensor 1: 1
            (0, Slip),   // sensor 0: 2 -> slipping (1 sensor)
            (2, Slip),   // sensor 2: 1
            (0, Static), // sensor 0 resets
            (1, Slip),   // sensor 1: 2 -> slipping, but sensor 0 stopped: 1 sensor
            (0, Slip),   // sensor 0: 1
            (2, Slip),   // sensor 2: 2 -> sensors 1 and 2 slipping: react
        ];
        let reactions: Vec<bool> = events.iter().map(|&(k, c)| d.observe(k, c)).collect();
        assert_eq!(
            reactions,
            [false, false, false, false, false, false, false, true]
        );
        assert_eq!(d.slipping_sensors(), 2);
        d.reset();
        assert_eq!(d.slipping_sensors(), 0);
    }

    #[test]
    fn one_by_one_reacts_on_the_first_slip_frame_and_ignores_unknown_sensors() {
        let mut d = Detector::new(s("1Fr1Sen"), 3);
        assert!(!d.observe(1, Static));
        assert!(!d.observe(7, Slip));
        assert!(d.observe(2, Slip));
    }
}
