//! Issue 43: Haply's own Rust client, the `haply` crate 1.3.1, against
//! frictionlab's emulated Inverse Service and Inverse3 driver: the crate's
//! `HaplyDevice` connects to the emulator, reads its state and sends forces
//! that the emulated device renders; every message our driver and our
//! emulator send parses with the crate's wire types.
#![allow(clippy::unwrap_used, clippy::expect_used, reason = "tests")]

use std::net::TcpListener;
use std::time::Duration;

use frictionlab::device::inverse3::{PROFILE, emulator, messages};
use haply::device_model::{ServiceData, ServiceState, Vec3D};
use haply::{ForceInput, HaplyDevice, ServiceMsg};

/// Our emulated service on a free loopback port, in a thread, in lockstep
/// (1 ms of its physics per client message), so what the client reads
/// follows from what it sent, however fast the machine runs.
fn service() -> String {
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let address = listener.local_addr().unwrap().to_string();
    let track = frictionlab::device::inverse3::Config::default().track;
    let options = emulator::Options {
        lockstep: true,
        ..emulator::Options::default()
    };
    std::thread::spawn(move || emulator::serve(&listener, track, &options));
    address
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_vendors_haply_device_connects_reads_state_and_sends_forces_to_our_service() {
    let address = service();
    let mut device = HaplyDevice::new(&format!("http://{address}"), &format!("ws://{address}/"))
        .await
        .expect("the crate's HaplyDevice connects");
    let version = device.get_service_version().await.expect("GET /version");
    assert_eq!(version.project_version, emulator::VERSION);
    // The inventory, then a state frame per message.
    let mut state = ServiceData::default();
    for _ in 0..200 {
        state = device.read_state().await.unwrap();
        if !state.inverse3.is_empty() {
            break;
        }
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
    let inverse3 = state
        .inverse3
        .first()
        .expect("an Inverse3 in the inventory");
    assert_eq!(inverse3.device_id, emulator::DEVICE_ID);
    let config = inverse3
        .config
        .as_ref()
        .expect("the inventory carries config");
    assert_eq!(
        config.filters.as_ref().unwrap().force_gate.unwrap().gain,
        0.3
    );
    assert!(
        inverse3.state.cursor_position.is_some(),
        "a cursor position"
    );
    // Hold with no force, then push up (z) with 1.5 N, each for one
    // period of the hand's press (2 s of the service's physics, 2000
    // messages in lockstep): the cursor, held by the emulated hand
    // (200 N/m), rises by 1.5 / 200 m, and the state reports the force
    // rendered. Read a whole period apart, the press's swing is the same
    // at both readings (read 1 s apart, it added up to 4 mm either way,
    // depending on when the client connected).
    let (_, _, press_hz) = emulator::HAND_PRESS_M;
    let period_messages = (1.0 / press_hz / 0.001).round() as u32;
    let mut settle = async |z: f32| {
        let mut rendered = None;
        for _ in 0..period_messages {
            let force = Vec3D { x: 0.0, y: 0.0, z };
            let input = ForceInput {
                device_id: emulator::DEVICE_ID.into(),
                forces: force,
            };
            device
                .update_force(vec![input], Some(true), Some(true))
                .await
                .unwrap();
            let s = device.read_state().await.unwrap();
            rendered = s
                .inverse3
                .first()
                .and_then(|d| d.state.current_cursor_force)
                .or(rendered);
        }
        // The last message's state frame: the service sends nothing
        // more, and its physics stands still, until the next message, so
        // the position read stops changing once the client has taken
        // every frame sent.
        let z = async || {
            let s = device.read_state().await.unwrap();
            s.inverse3[0].state.cursor_position.unwrap().z
        };
        let mut last = z().await;
        loop {
            tokio::time::sleep(Duration::from_millis(50)).await;
            let now = z().await;
            if now == last {
                break (now, rendered);
            }
            last = now;
        }
    };
    let (z0, _) = settle(0.0).await;
    let (z1, rendered) = settle(1.5).await;
    let rise = f64::from(z1 - z0);
    let expected = 1.5 / emulator::HAND_STIFFNESS_N_M;
    println!(
        "haply {}: cursor z {z0:.4} m at rest, {z1:.4} m under 1.5 N up (a rise of {:.2} mm, {:.2} mm expected); force rendered {rendered:?}",
        version.project_version,
        rise * 1e3,
        expected * 1e3
    );
    assert_eq!(rendered.map(|f| f.z), Some(1.5));
    assert!(
        (rise - expected).abs() < 0.001,
        "rise {rise} m, expected {expected} m"
    );
    device.shutdown().await.expect("the client shuts down");
}

#[test]
fn every_message_our_driver_and_emulator_send_parses_with_the_crates_types() {
    // Our driver: the first message (profile and a zero force), a force,
    // and a force with the emulated hand's drive.
    let first = messages::force("E3M1", [0.0; 3], Some(PROFILE));
    let plain = messages::force("E3M1", [0.25, -1.0, 2.0], None);
    let mut with_hand = plain.clone();
    with_hand.frictionlab_hand = Some(frictionlab::hand::HandDrive {
        x_m: 0.01,
        stiffness_n_m: 300.0,
        ..Default::default()
    });
    for (what, m) in [
        ("first", &first),
        ("force", &plain),
        ("with hand", &with_hand),
    ] {
        let text = serde_json::to_string(m).unwrap();
        let theirs: ServiceMsg =
            serde_json::from_str(&text).unwrap_or_else(|e| panic!("{what}: {e}: {text}"));
        let cmd = theirs.inverse3[0]
            .commands
            .as_ref()
            .unwrap()
            .set_cursor_force
            .unwrap();
        let ours = m.inverse3[0]
            .commands
            .unwrap()
            .set_cursor_force
            .unwrap()
            .vector;
        assert_eq!(
            [
                f64::from(cmd.vector.x),
                f64::from(cmd.vector.y),
                f64::from(cmd.vector.z)
            ],
            ours.array(),
            "{what}"
        );
        assert!(cmd.execute, "{what}: executed");
    }
    let theirs: ServiceMsg = serde_json::from_str(&serde_json::to_string(&first).unwrap()).unwrap();
    assert_eq!(
        theirs.session.configure.unwrap().profile.unwrap().name,
        PROFILE
    );
    // Our emulator: the inventory (with config) as the crate's ServiceData,
    // a state update as its ServiceState.
    let mut plant = emulator::Plant::new(frictionlab::device::inverse3::Config::default().track);
    plant.apply(&plain);
    plant.advance(0.01);
    let inventory = serde_json::to_string(&plant.frame(3, true)).unwrap();
    let data: ServiceData =
        serde_json::from_str(&inventory).unwrap_or_else(|e| panic!("{e}: {inventory}"));
    assert_eq!(data.session_id, 3);
    let d = &data.inverse3[0];
    assert!(d.config.as_ref().unwrap().gravity_compensation.enabled);
    assert!(d.status.calibrated && d.status.ready);
    let update = serde_json::to_string(&plant.frame(3, false)).unwrap();
    let state: ServiceState =
        serde_json::from_str(&update).unwrap_or_else(|e| panic!("{e}: {update}"));
    let p = state.inverse3[0].state.cursor_position.unwrap();
    let ours = plant.position();
    assert!((f64::from(p.x) - ours[0]).abs() < 1e-6 && (f64::from(p.z) - ours[2]).abs() < 1e-6);
    let f = state.inverse3[0].state.current_cursor_force.unwrap();
    assert_eq!((f.x, f.y, f.z), (0.25, -1.0, 2.0));
    println!(
        "3 driver messages parsed as ServiceMsg, the inventory as ServiceData, an update as ServiceState"
    );
}
