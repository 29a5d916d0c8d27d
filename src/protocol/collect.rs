//! Collect mode as a preset: the protocol files that record the paper's training data, so
//! that `tmo sim collect` and `tmo reproduce` record it through the protocol runner exactly
//! as `tmo run` does with the same file and seed. Hand release: a grasp lifted 120 mm and
//! released at 0.5 % of the fingers' maximum speed until the object falls. Slip rail: the
//! arm retracts at a seeded random speed.

/// Which rig a collection records on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum CollectRig {
    Hand,
    Rail,
}

/// How high a collected hand trial lifts the object before the release: high enough that a
/// released object slides for more than 15 frames before it lands (the paper labels up to
/// 15), and above the 80 mm drop limit.
pub const COLLECT_LIFT_MM: f64 = 120.0;

/// The fingers' release speed in collect mode, as a share of their maximum speed.
pub const COLLECT_RELEASE_SPEED_OF_MAX: f64 = 0.005;

/// A collection: every object at every grasp `repetitions` times.
#[derive(Debug, Clone, PartialEq)]
pub struct CollectPreset<'a> {
    pub rig: CollectRig,
    pub repetitions: u32,
    pub seed: u64,
    pub objects: &'a [String],
    /// Grasp angles, deg (the hand's; the rail has none).
    pub grasps_deg: &'a [f64],
}

fn quoted(items: &[String]) -> String {
    items
        .iter()
        .map(|s| format!("\"{s}\""))
        .collect::<Vec<_>>()
        .join(", ")
}

impl CollectPreset<'_> {
    /// The protocol file's text.
    pub fn protocol(&self) -> String {
        match self.rig {
            CollectRig::Rail => format!(
                "kind = \"rail_catch\"\nmode = \"collect\"\nrepetitions = {}\nseed = {}\nobjects = [{}]\n",
                self.repetitions,
                self.seed,
                quoted(self.objects)
            ),
            CollectRig::Hand => format!(
                "kind = \"hand_release\"\nmode = \"collect\"\nrepetitions = {}\nseed = {}\nobjects = [{}]\ngrasps_deg = [{}]\n\n[hand_release]\nrelease_speed_of_max = {COLLECT_RELEASE_SPEED_OF_MAX}\nlift_mm = {COLLECT_LIFT_MM:?}\n",
                self.repetitions,
                self.seed,
                quoted(self.objects),
                self.grasps_deg
                    .iter()
                    .map(|g| g.to_string())
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_presets_are_the_protocols_reproduce_has_always_written() {
        let objects: Vec<String> = ["crisps_can", "toy_cat"].map(String::from).to_vec();
        let hand = CollectPreset {
            rig: CollectRig::Hand,
            repetitions: 10,
            seed: 21,
            objects: &objects,
            grasps_deg: &[0.0],
        };
        assert_eq!(
            hand.protocol(),
            "kind = \"hand_release\"\nmode = \"collect\"\nrepetitions = 10\nseed = 21\nobjects = [\"crisps_can\", \"toy_cat\"]\ngrasps_deg = [0]\n\n[hand_release]\nrelease_speed_of_max = 0.005\nlift_mm = 120.0\n"
        );
        let rail_object = vec!["rail_object".to_string()];
        let rail = CollectPreset {
            rig: CollectRig::Rail,
            repetitions: 50,
            seed: 11,
            objects: &rail_object,
            grasps_deg: &[],
        };
        assert_eq!(
            rail.protocol(),
            "kind = \"rail_catch\"\nmode = \"collect\"\nrepetitions = 50\nseed = 11\nobjects = [\"rail_object\"]\n"
        );
        for preset in [hand, rail] {
            let dir = tempfile::tempdir().unwrap();
            let path = dir.path().join("p.toml");
            std::fs::write(&path, preset.protocol()).unwrap();
            let plan = crate::protocol::load(&path, 3).unwrap();
            assert_eq!(plan.mode, crate::protocol::Mode::Collect);
        }
    }
}
