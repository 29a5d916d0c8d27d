//! `tmo hardware check FILE`: validates a hardware file.

use std::path::PathBuf;

use anyhow::Result;

#[derive(clap::Subcommand)]
pub enum HardwareCommand {
    /// Checks a hardware file and prints what it sets up.
    Check { file: PathBuf },
}

pub fn run(command: HardwareCommand) -> Result<()> {
    match command {
        HardwareCommand::Check { file } => {
            let hw = tmo::hardware::load(&file)?;
            let ports: Vec<&str> = hw
                .cameras
                .fingertips
                .iter()
                .map(|c| c.port.as_str())
                .collect();
            println!("{}: valid", file.display());
            println!(
                "  fingertip cameras {} ({} pins), marker camera {}",
                ports.join(", "),
                hw.cameras.pins,
                hw.marker_camera.port
            );
            println!(
                "  hand on {} at {} baud, servo ids {:?}",
                hw.hand.port, hw.hand.baud, hw.hand.ids
            );
            println!(
                "  arm at {} (RTDE {}, {} Hz; URScript {})",
                hw.arm.host, hw.arm.rtde_port, hw.arm.frequency_hz, hw.arm.script_port
            );
            Ok(())
        }
    }
}
