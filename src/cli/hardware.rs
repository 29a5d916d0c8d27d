//! `tmo hardware check FILE`: validates a hardware file.

use std::path::PathBuf;

use anyhow::Result;

#[derive(clap::Subcommand)]
pub enum HardwareCommand {
    /// Checks a hardware file and prints what it sets up.
    Check {
        /// The hardware file (TOML; `hardware/tmo.toml` is a commented example).
        file: PathBuf,
    },
}

pub fn run(command: HardwareCommand) -> Result<()> {
    match command {
        HardwareCommand::Check { file } => {
            let hw = tmo::runner::hardware::load(&file)?;
            let ports: Vec<&str> = hw
                .cameras
                .fingertips
                .iter()
                .map(|c| c.port.as_str())
                .collect();
            outln!("{}: valid", file.display());
            outln!(
                "  fingertip cameras {} ({} pins), marker camera {}",
                ports.join(", "),
                hw.cameras.pins,
                hw.marker_camera.port
            );
            outln!(
                "  hand on {} at {} baud, servo ids {:?}",
                hw.hand.port,
                hw.hand.baud,
                hw.hand.ids
            );
            outln!(
                "  arm at {} (RTDE {}, {} Hz; URScript {})",
                hw.arm.host,
                hw.arm.rtde_port,
                hw.arm.frequency_hz,
                hw.arm.script_port
            );
            let s = &hw.safety;
            outln!(
                "  safety: grip <= {}, torque <= {}, arm <= {} mm/s within {:?} mm",
                s.max_grip,
                s.max_torque,
                s.max_arm_speed_mm_s,
                s.workspace_mm
            );
            match &hw.served_simulator {
                Some(served) => outln!(
                    "  the served simulator: each trial's world is set up through {}",
                    served.control
                ),
                None => outln!("  between trials an operator sets the rig up (or --unattended)"),
            }
            Ok(())
        }
    }
}
