//! `tmo sim serve --hardware hw.toml --out served.toml`: the simulated rig behind the real
//! rig's wire protocols — the fingertip and marker cameras and the Dynamixel bus on
//! pseudo-terminals, the UR controller (RTDE and URScript) on loopback TCP — so the real
//! backend's code path can drive the simulator. Writes a hardware file naming where each
//! device is served, and runs until Ctrl-C (or `--for` seconds).

use std::net::TcpListener;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use anyhow::{Context, Result};
use tmo::runner::hardware::ServedSimulator;
use tmo::runner::sim_presets::{Preset, PresetOptions};
use tmo_hal::real::model_o::ModelOConfig;
use tmo_sim::serve::control::ControlPort;
use tmo_sim::serve::dynamixel::PtyServoBus;
use tmo_sim::serve::UrEmulator;
use tmo_sim::serve::{serve_controlled, PtyCamera, PtyMarkerCamera, ServedDevices};
use tmo_sim::{HandSetup, ObjectStart, RigSetup, SimConfig, SimRig};

#[derive(clap::Args)]
pub struct ServeArgs {
    /// The hardware file to serve (its servo ids, calibration and marker ids are kept).
    #[arg(long)]
    hardware: PathBuf,
    /// Where to write the served hardware file (ports replaced by the served ones).
    #[arg(long, value_parser = super::output::a_file, default_value = "served-hardware.toml")]
    out: PathBuf,
    /// Which rig: the hand over the table, or the single finger on the slip rail (served
    /// with one fingertip camera).
    #[arg(long, value_enum, default_value = "hand")]
    rig: ServedRig,
    /// The object the served rig starts with (each trial's reset brings its own).
    #[arg(long)]
    object: Option<String>,
    /// Seed of the served world's randomness; each trial's reset derives its own from it.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Serve the UR controller at this loopback address on a controller's own ports (RTDE
    /// 30004, URScript 30002), for clients that cannot be given other ports (ur_rtde).
    /// Default: any free ports on 127.0.0.1.
    #[arg(long)]
    ur_address: Option<std::net::IpAddr>,
    /// Stop after this many seconds (default: until Ctrl-C).
    #[arg(long = "for", value_parser = serve_seconds)]
    for_s: Option<f64>,
    /// Show the served rig live over the Foxglove WebSocket protocol at ADDR (default
    /// 127.0.0.1:8765; port 0 picks a free one): its pins, markers and the hand's and
    /// arm's state, as its devices send them.
    #[arg(long, value_name = "ADDR", num_args = 0..=1, default_missing_value = "127.0.0.1:8765")]
    live: Option<std::net::SocketAddr>,
    /// A fault to provoke: every fingertip camera's link stalls this many seconds into each
    /// trial (each reset's world), holding its frames back for --stall-for seconds and then
    /// sending them at once, as a congested USB link does. For tests of the online loop's
    /// deadline (docs/online.md).
    #[arg(long, value_name = "SECONDS", requires = "stall_for", value_parser = serve_seconds)]
    stall_cameras_at: Option<f64>,
    /// How long the links stall (with --stall-cameras-at), s.
    #[arg(long, value_name = "SECONDS", requires = "stall_cameras_at", value_parser = serve_seconds)]
    stall_for: Option<f64>,
}

#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum ServedRig {
    Hand,
    Rail,
}

/// The world the served rig starts in, until the first trial's reset.
fn first_world(args: &ServeArgs) -> Result<(SimConfig, String)> {
    let base = SimConfig {
        seed: args.seed,
        ..SimConfig::default()
    };
    Ok(match args.rig {
        ServedRig::Hand => {
            let object = args.object.clone().unwrap_or_else(|| "crisps_can".into());
            let contact = tmo::runner::sim_presets::contact_closure(&base, &object)?;
            let config = SimConfig {
                rig: RigSetup::Hand(HandSetup {
                    object: object.clone(),
                    initial_closure: (contact - 0.04).max(0.0),
                    start: ObjectStart::OnTable,
                    ..Default::default()
                }),
                ..base
            };
            (config, object)
        }
        ServedRig::Rail => {
            let options = PresetOptions {
                object: args.object.clone(),
                ..Default::default()
            };
            let (config, _) = tmo::runner::sim_presets::build(Preset::Rail, &options, base)?;
            let object = match &config.rig {
                RigSetup::Rail(r) => r.object.clone(),
                RigSetup::Hand(h) => h.object.clone(),
            };
            (config, object)
        }
    })
}

/// Longest `--for`: a year (std's sleep panics on durations past u64 seconds).
const MAX_SERVE_S: f64 = 365.0 * 24.0 * 3600.0;

fn serve_seconds(text: &str) -> Result<f64, String> {
    let s: f64 = text
        .parse()
        .map_err(|_| format!("expected a number of seconds, got `{text}`"))?;
    if s.is_finite() && s > 0.0 && s <= MAX_SERVE_S {
        Ok(s)
    } else {
        Err(format!(
            "expected a positive number of seconds, at most {MAX_SERVE_S} (a year), got {text}"
        ))
    }
}

pub fn serve_cmd(args: ServeArgs) -> Result<()> {
    let hw = tmo::runner::hardware::load(&args.hardware)?;
    let (config, object) = first_world(&args)?;
    let rig = SimRig::new(config)?;
    let sensors = rig.tactile_sensors().len();
    anyhow::ensure!(
        hw.cameras.fingertips.len() >= sensors,
        "{}: cameras.fingertips: the served rig has {sensors} fingertip(s), the file names {}",
        args.hardware.display(),
        hw.cameras.fingertips.len()
    );
    let (ur_ip, rtde_port, script_port) = match args.ur_address {
        Some(ip) => {
            anyhow::ensure!(
                ip.is_loopback(),
                "--ur-address: expected a loopback address (127.x.y.z or ::1), got {ip}"
            );
            (ip, 30004, 30002)
        }
        None => (std::net::Ipv4Addr::LOCALHOST.into(), 0, 0),
    };
    let rtde = TcpListener::bind((ur_ip, rtde_port))
        .with_context(|| format!("cannot listen for RTDE on {ur_ip}:{rtde_port}"))?;
    let script = TcpListener::bind((ur_ip, script_port))
        .with_context(|| format!("cannot listen for URScript on {ur_ip}:{script_port}"))?;
    let control = TcpListener::bind("127.0.0.1:0").context("cannot listen for control")?;
    let (rtde_port, script_port) = (rtde.local_addr()?.port(), script.local_addr()?.port());
    let control_addr = control.local_addr()?.to_string();
    let mut control = ControlPort::new(control)?;
    let servo = ModelOConfig {
        port: String::new(),
        baud: hw.hand.baud,
        ids: hw.hand.ids,
        min: hw.hand.min,
        max: hw.hand.max,
        current_limit_ma: hw.hand.current_limit_ma,
    };
    let mut devices = ServedDevices {
        ur: Some(UrEmulator::new(rtde, script)?),
        cameras: rig
            .tactile_sensors()
            .into_iter()
            .map(|s| {
                let mut camera = PtyCamera::open(s, "pins")?;
                camera.stall = args
                    .stall_cameras_at
                    .zip(args.stall_for)
                    .map(|(from_s, for_s)| tmo_sim::serve::LinkStall { from_s, for_s });
                Ok(camera)
            })
            .collect::<std::io::Result<_>>()
            .context("cannot open a pseudo-terminal for a fingertip camera")?,
        markers: Some(
            PtyMarkerCamera::open(
                rig.marker_tracker(),
                &hw.marker_camera.object_marker,
                &hw.marker_camera.hand_marker,
            )
            .context("cannot open a pseudo-terminal for the marker camera")?,
        ),
        bus: Some(
            PtyServoBus::open(rig.hand(), servo)
                .context("cannot open a pseudo-terminal for the hand's bus")?,
        ),
    };
    let mut served = hw.clone();
    served.cameras.fingertips.truncate(sensors);
    served.served_simulator = Some(ServedSimulator {
        control: control_addr.clone(),
    });
    for (c, pty) in served.cameras.fingertips.iter_mut().zip(&devices.cameras) {
        c.port = pty.path.display().to_string();
    }
    if let Some(m) = &devices.markers {
        served.marker_camera.port = m.path.display().to_string();
    }
    if let Some(b) = &devices.bus {
        served.hand.port = b.path.display().to_string();
    }
    served.arm.host = ur_ip.to_string();
    served.arm.rtde_port = rtde_port;
    served.arm.script_port = script_port;
    let text = format!(
        "# written by `tmo sim serve --hardware {}`: the simulated rig, served\n{}",
        args.hardware.display(),
        toml::to_string_pretty(&served)?
    );
    tmo::output::atomic::write_atomic(&args.out, text.as_bytes())
        .with_context(|| format!("cannot write {}", args.out.display()))?;
    outln!(
        "serving the simulated rig ({object}): cameras {}, markers {}, hand bus {}, UR at {ur_ip} (RTDE {rtde_port}, URScript {script_port}), control {control_addr}",
        served
            .cameras
            .fingertips
            .iter()
            .map(|c| c.port.as_str())
            .collect::<Vec<_>>()
            .join(", "),
        served.marker_camera.port,
        served.hand.port,
    );
    outln!(
        "wrote {} (use it as --hardware); Ctrl-C stops",
        args.out.display()
    );

    let stop = Arc::new(AtomicBool::new(false));
    let flag = stop.clone();
    ctrlc::set_handler(move || flag.store(true, Ordering::Relaxed))
        .context("cannot install the Ctrl-C handler")?;
    if let Some(s) = args.for_s {
        let flag = stop.clone();
        // validated before anything was served
        std::thread::spawn(move || {
            std::thread::sleep(std::time::Duration::from_secs_f64(s.max(0.0)));
            flag.store(true, Ordering::Relaxed);
        });
    }
    let mut live = match args.live {
        Some(addr) => {
            let sensors = if args.rig == ServedRig::Rail { 1 } else { 3 };
            let view = tmo::live::LiveView::start(addr, sensors)?;
            eprintln!(
                "live view at {}: in Foxglove, Open connection > Foxglove WebSocket > {}",
                view.url(),
                view.url()
            );
            let started_unix_ns = std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map_or(0, |d| d.as_nanos() as u64);
            Some(tmo::live::served::ServedRigView::new(view, started_unix_ns))
        }
        None => None,
    };
    let tap = live
        .as_mut()
        .map(|v| v as &mut dyn tmo_sim::serve::ServeTap);
    serve_controlled(&rig, &mut devices, Some(&mut control), tap, &stop)?;
    let ur = devices.ur.map(|u| u.stats).unwrap_or_default();
    let sent: u64 = devices.cameras.iter().map(|c| c.sent_lines).sum();
    outln!(
        "stopped: {sent} camera lines, {} RTDE packages, {} URScript lines ({} refused), {} bus packets, {} resets",
        ur.data_packages,
        ur.script_lines,
        ur.script_errors,
        devices.bus.map_or(0, |b| b.stats.packets),
        control.resets
    );
    Ok(())
}
