//! The JeVois camera backend against the simulated fingertip cameras served on
//! pseudo-terminals: frames arrive at the camera rate with every pin, and a camera that
//! goes away is a fault of the next read.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{mpsc, Arc};
use std::time::{Duration, Instant};

use tmo_hal::real::clock::RealClock;
use tmo_hal::real::jevois_sensor::JevoisSensor;
use tmo_hal::real::marker_camera::MarkerCamera;
use tmo_hal::{ErrorKind, MarkerTracker, TactileSensor};
use tmo_sim::serve::{serve, PtyCamera, PtyMarkerCamera, ServedDevices};
use tmo_sim::{SimConfig, SimRig};

#[test]
fn frames_cross_the_serial_line_at_the_camera_rate() {
    let stop = Arc::new(AtomicBool::new(false));
    let (tx, rx) = mpsc::channel();
    let flag = stop.clone();
    let server = std::thread::spawn(move || {
        let rig = SimRig::new(SimConfig::default()).unwrap();
        let mut devices = ServedDevices {
            cameras: rig
                .tactile_sensors()
                .into_iter()
                .map(|s| PtyCamera::open(s, "pins").unwrap())
                .collect(),
            markers: Some(PtyMarkerCamera::open(rig.marker_tracker(), "U42", "U7").unwrap()),
            ..Default::default()
        };
        let paths: Vec<_> = devices.cameras.iter().map(|c| c.path.clone()).collect();
        tx.send((paths, devices.markers.as_ref().unwrap().path.clone()))
            .unwrap();
        serve(&rig, &mut devices, &flag).unwrap();
        devices
            .cameras
            .iter()
            .map(|c| (c.sent_lines, c.dropped_lines))
            .collect::<Vec<_>>()
    });
    let (paths, marker_path) = rx.recv().unwrap();
    assert_eq!(paths.len(), 3);
    let clock = RealClock::new();
    let mut markers = MarkerCamera::open(
        marker_path.to_str().unwrap(),
        115200,
        "U42",
        "U7",
        0.25,
        clock.clone(),
    )
    .unwrap();
    let mut samples = Vec::new();
    let mut sensors: Vec<JevoisSensor> = paths
        .iter()
        .enumerate()
        .map(|(k, p)| {
            JevoisSensor::open(
                p.to_str().unwrap(),
                115200,
                k as u8,
                30,
                0.25,
                clock.clone(),
            )
            .unwrap()
        })
        .collect();
    let mut counts = [0usize; 3];
    let until = Instant::now() + Duration::from_millis(600);
    while Instant::now() < until {
        while let Some(m) = markers.next_sample().unwrap() {
            samples.push(m);
        }
        for (k, s) in sensors.iter_mut().enumerate() {
            while let Some(f) = s.next_frame().unwrap() {
                assert_eq!(f.pins.len(), 30);
                assert_eq!(f.sensor, k as u8);
                counts[k] += 1;
            }
        }
        std::thread::sleep(Duration::from_millis(2));
    }
    // 60 fps for 0.6 s, give or take start-up and a loaded machine
    assert!(counts.iter().all(|&n| n >= 15), "{counts:?}");
    // the tracker runs at 60 Hz too; the default rig's object falls out of an open hand
    assert!(samples.len() >= 15, "{} marker samples", samples.len());
    let hand =
        SimConfig::default().arm.start_mm[2] + SimConfig::default().arm.hand_marker_offset_mm;
    assert!(
        samples.iter().all(|s| (s.hand_mm - hand).abs() < 5.0),
        "{:?}",
        samples[0]
    );
    assert!(
        samples.last().unwrap().object_mm < samples[0].object_mm - 10.0,
        "the object fell"
    );
    for s in &sensors {
        let st = s.stats();
        assert_eq!(st.wrong_pin_count, 0, "{st:?}");
        assert_eq!(st.reader.dropped_total(), 0, "{st:?}");
    }

    stop.store(true, Ordering::Relaxed);
    let sent = server.join().unwrap();
    assert!(sent.iter().all(|&(n, _)| n >= 15), "{sent:?}");
    let deadline = Instant::now() + Duration::from_secs(2);
    let failed = loop {
        match sensors[0].next_frame() {
            Err(e) => break Some(e),
            Ok(_) if Instant::now() > deadline => break None,
            Ok(_) => std::thread::sleep(Duration::from_millis(10)),
        }
    };
    let e = failed.expect("a camera that went away is a fault");
    let kind = tmo_hal::Error::kind(&e);
    assert!(
        matches!(kind, ErrorKind::Timeout | ErrorKind::Disconnected),
        "{e}"
    );
}
