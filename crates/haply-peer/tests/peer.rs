//! Issue 43: Haply's own Rust client, the `haply` crate 1.3.1, against
//! frictionlab's emulated Inverse Service and Inverse3 driver: the crate's
//! `HaplyDevice` connects to the emulator, reads its state and sends forces
//! that the emulated device renders; every message our driver and our
//! emulator send parses with the crate's wire types. Issue 63: the crate's
//! listing calls list the emulated Inverse3 by its id, over HTTP and over
//! the WebSocket, and every HTTP route of the crate's `InverseHttpClient`
//! is answered in a shape its own types read.
#![allow(clippy::unwrap_used, clippy::expect_used, reason = "tests")]

use std::net::TcpListener;
use std::time::Duration;

use frictionlab::device::inverse3::{PROFILE, emulator, messages};
use haply::device_model::{
    Config, CoordinateSystem, DeviceType, GravityCompensation, Handedness, HomeReturn, ServiceData,
    ServiceState, TorqueScaling, Vec3D,
};
use haply::http::InverseHttpClient;
use haply::{
    DampingConfig, ForceGateConfig, ForceInput, HaplyDevice, MountConfig, NavigationConfigure,
    PresetConfig, ProfileConfig, SdfCommand, SdfCommandMode, SdfHfxObject, SdfObjectList,
    ServiceMsg, SessionConfigure, SetTransformCmd,
};

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
        }
        // The last message's state frame: the service sends nothing
        // more, and its physics stands still, until the next message, so
        // the position read stops changing once the client has taken
        // every frame sent. That frame answers the last message: the
        // force it reports is that message's. (A frame read while the
        // messages were sent may answer any earlier one: the client
        // reads the frames behind what it sends, by as many as the
        // scheduler lets pile up.)
        let state = async || {
            let s = device.read_state().await.unwrap();
            let d = &s.inverse3[0].state;
            (d.cursor_position.unwrap().z, d.current_cursor_force)
        };
        let mut last = state().await;
        loop {
            tokio::time::sleep(Duration::from_millis(50)).await;
            let now = state().await;
            if now.0 == last.0 {
                break now;
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
    // To our emulator in lockstep, the driver also echoes the number of the
    // state it read (issue 63).
    with_hand.frictionlab_state = Some(7);
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
    // In lockstep a frame carries its state's number (issue 63).
    let mut numbered = plant.frame(3, false);
    numbered.frictionlab_state = Some(12);
    let update = serde_json::to_string(&numbered).unwrap();
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

/// The ids of `configs`, as the crate gives them (`Config::id`).
fn ids(configs: &[Config]) -> Vec<&str> {
    configs.iter().map(Config::id).collect()
}

/// The one emulated Inverse3, by its id, as the crate's `Config` holds it.
fn assert_the_emulated_inverse3(what: &str, configs: &[Config]) {
    assert_eq!(ids(configs), [emulator::DEVICE_ID], "{what}");
    let Config::DeviceConfig(c) = &configs[0] else {
        panic!("{what}: not an Inverse3's config: {configs:?}");
    };
    assert_eq!(c.device_info.id, emulator::DEVICE_ID, "{what}");
    assert_eq!(c.device_info.device_type, DeviceType::Inverse3, "{what}");
}

/// A `HaplyDevice` on `address`, its inventory read (the WebSocket's first
/// frame), its session's profile `profile` configured.
async fn connected(address: &str, profile: &str) -> HaplyDevice {
    let mut device = HaplyDevice::new(&format!("http://{address}"), &format!("ws://{address}/"))
        .await
        .expect("the crate's HaplyDevice connects");
    let configure = SessionConfigure {
        profile: Some(ProfileConfig {
            name: profile.into(),
            required_version: None,
        }),
        ..SessionConfigure::default()
    };
    device
        .configure_session(configure, Some(true))
        .await
        .unwrap();
    for _ in 0..200 {
        let state = device.read_state().await.unwrap();
        if state.inverse3.first().is_some_and(|d| d.config.is_some()) {
            break;
        }
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
    device
}

/// Issue 63: `list_devices` (HTTP `GET /devices`) listed nothing, as the
/// emulator answered 404, and `get_devices()` (the WebSocket's inventory)
/// gave `[""]`, as the inventory's `config` had no `id`. Every listing call
/// of the crate now lists the emulated Inverse3 by its id.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn issue_63_the_crates_listing_calls_list_the_emulated_inverse3_by_its_id() {
    let address = service();
    let device = connected(&address, "issue-63").await;
    let listed = device.list_devices().await.expect("list_devices");
    let over_ws = device.get_devices().await.expect("get_devices");
    println!(
        "list_devices: {:?}; get_devices (WebSocket): {:?}",
        ids(&listed),
        ids(&over_ws)
    );
    assert_the_emulated_inverse3("list_devices", &listed);
    assert_the_emulated_inverse3("get_devices", &over_ws);
    let info = device
        .get_device_info(emulator::DEVICE_ID)
        .await
        .expect("get_device_info finds the device");
    assert_eq!(info.id(), emulator::DEVICE_ID);
    let http = InverseHttpClient::new(&format!("http://{address}"));
    assert_the_emulated_inverse3("get_devices", &http.get_devices().await.unwrap());
    for selector in [":0", ":-1", ":issue-63:0"] {
        let scoped = http.get_devices_for_session(selector).await.unwrap();
        assert_the_emulated_inverse3(selector, &scoped);
    }
    assert!(
        http.get_devices_for_session(":1").await.unwrap().is_empty(),
        "a session that does not exist lists nothing"
    );
    // What the listings hold is the inventory the WebSocket gave.
    let (Config::DeviceConfig(a), Config::DeviceConfig(b)) = (&listed[0], &over_ws[0]) else {
        unreachable!("checked above");
    };
    assert_eq!(a, b);
}

/// Issue 63: each HTTP route of the crate's `InverseHttpClient`, called
/// through the crate: the reads give the emulated Inverse3's documented
/// values in the crate's own types; the changes are refused with the
/// service's error envelope (the crate's `ApiResponse`), and change nothing.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn issue_63_each_route_the_crate_calls_parses_with_its_own_types() {
    let address = service();
    let device = connected(&address, "peer").await;
    let http = InverseHttpClient::new(&format!("http://{address}"));
    let id = emulator::DEVICE_ID;
    let s = Some(":peer:0");

    // System.
    assert_eq!(
        http.get_version().await.unwrap().project_version,
        emulator::VERSION
    );
    let expert = http.get_expert_status().await.expect("GET /expert/status");
    assert_eq!(expert.detection["inverse3"][0], id);
    // Sessions: ours, with its profile.
    let sessions = http.get_sessions().await.expect("GET /sessions");
    assert_eq!(sessions.session_count, 1);
    let session_id = sessions.sessions[0].session_id;
    assert_eq!(
        device.read_state().await.unwrap().session_id,
        session_id,
        "the session the WebSocket states"
    );
    let session = http.get_session(session_id).await.unwrap();
    let profile = session.config.unwrap().profile.unwrap();
    assert_eq!(profile.name, "peer");
    assert_eq!(
        http.get_session_profile(session_id).await.unwrap().name,
        "peer"
    );
    // Settings.
    let port: u16 = address.rsplit(':').next().unwrap().parse().unwrap();
    let settings = http.get_settings().await.unwrap();
    assert_eq!(settings["communication/http/port"], port);
    let setting = http
        .get_setting("communication/websocket/port")
        .await
        .unwrap();
    assert_eq!(setting["data"], port);
    // The device's own configuration.
    assert_eq!(
        http.get_handedness("inverse3", id).await.unwrap(),
        Handedness::Right
    );
    assert_eq!(
        http.get_torque_scaling("inverse3", "0").await.unwrap(),
        TorqueScaling { enabled: true }
    );
    assert_eq!(
        http.get_gravity_compensation("*inverse", id).await.unwrap(),
        GravityCompensation {
            enabled: true,
            scaling_factor: 1.0
        }
    );
    assert_eq!(
        http.get_home_return("inverse3", id).await.unwrap(),
        HomeReturn { enabled: false }
    );
    let paired = http.get_paired_with("inverse3", id).await.unwrap();
    assert_eq!(paired.inverse_id.as_deref(), Some(id));
    assert!(!paired.attached && paired.verse_grip_id.is_none());
    // The session's view of it.
    assert_eq!(
        http.get_basis("inverse3", id, s).await.unwrap().permutation,
        "XYZ"
    );
    let mount = http.get_mount("inverse3", id, s).await.unwrap().transform;
    let unit = Vec3D {
        x: 1.0,
        y: 1.0,
        z: 1.0,
    };
    assert_eq!(
        (mount.position, mount.scale),
        (Some(Vec3D::default()), Some(unit))
    );
    assert_eq!(
        http.get_preset("inverse3", id, s).await.unwrap().preset,
        "defaults"
    );
    let transform = http.get_state_transform("inverse3", id, s).await.unwrap();
    assert_eq!(transform.transform.scale, Some(unit));
    assert_eq!(
        http.get_filters_damping("inverse3", id, s)
            .await
            .unwrap()
            .scalar,
        Some(0.0)
    );
    assert_eq!(
        http.get_filters_force_gate("inverse3", id, s)
            .await
            .unwrap()
            .gain,
        0.3
    );
    let navigation = http.get_navigation("inverse3", id, s).await.unwrap();
    assert_eq!(navigation.status.unwrap().mode.as_deref(), Some("disabled"));
    assert!(http.get_sdf("inverse3", id, s).await.unwrap().is_empty());
    assert!(http.get_all_sdf().await.unwrap().is_empty());
    let missing = http.get_sdf_by_id("inverse3", id, "wall", s).await;
    assert!(missing.is_err_and(|e| e.to_string().contains("no SDF effect wall")));
    // As documented: a session-scoped GET needs a session, a GET one device.
    let unscoped = http.get_basis("inverse3", id, None).await.unwrap_err();
    assert!(unscoped.to_string().contains("session"), "{unscoped}");
    let wildcard = http.get_handedness("inverse3", "*").await.unwrap_err();
    assert!(wildcard.to_string().contains("wildcard"), "{wildcard}");

    // The changes: each answered with the service's error envelope, which
    // the crate reads as an error carrying the service's reason.
    let effect = SdfHfxObject {
        id: "wall".into(),
        ..SdfHfxObject::default()
    };
    let command = SdfCommand {
        mode: SdfCommandMode::Set,
        from_space: None,
        objects: vec![effect.clone()],
    };
    let list = SdfObjectList::default();
    let basis = CoordinateSystem {
        permutation: "XZY".into(),
    };
    let preset = PresetConfig {
        preset: "arm_front".into(),
    };
    let (i, g) = ("inverse3", "0");
    // The change's name and what the crate made of the service's answer.
    macro_rules! refused {
        ($call:ident($($arg:expr),*)) => {
            (stringify!($call), http.$call($($arg),*).await)
        };
    }
    let changes = [
        refused!(set_session_profile(session_id, &ProfileConfig::default())),
        refused!(delete_session_profile(session_id)),
        refused!(set_settings(&serde_json::json!({}))),
        refused!(set_setting(
            "communication/http/port",
            &serde_json::json!(1)
        )),
        refused!(delete_setting("communication/http/port")),
        refused!(set_handedness(i, g, &Handedness::Left)),
        refused!(delete_handedness(i, g)),
        refused!(set_torque_scaling(i, g, &TorqueScaling::default())),
        refused!(delete_torque_scaling(i, g)),
        refused!(set_gravity_compensation(
            i,
            g,
            &GravityCompensation::default()
        )),
        refused!(delete_gravity_compensation(i, g)),
        refused!(set_home_return(i, g, &HomeReturn { enabled: true })),
        refused!(delete_home_return(i, g)),
        refused!(set_basis(i, g, s, &basis)),
        refused!(delete_basis(i, g, s)),
        refused!(set_mount(i, g, s, &MountConfig::default())),
        refused!(patch_mount(i, g, s, &MountConfig::default())),
        refused!(delete_mount(i, g, s)),
        refused!(set_preset(i, g, s, &preset)),
        refused!(delete_preset(i, g, s)),
        refused!(set_state_transform(i, g, s, &SetTransformCmd::default())),
        refused!(patch_state_transform(i, g, s, &SetTransformCmd::default())),
        refused!(delete_state_transform(i, g, s)),
        refused!(set_filters_damping(i, g, s, &DampingConfig::default())),
        refused!(delete_filters_damping(i, g, s)),
        refused!(set_filters_force_gate(i, g, s, &ForceGateConfig::default())),
        refused!(delete_filters_force_gate(i, g, s)),
        refused!(set_navigation(i, g, s, &NavigationConfigure::default())),
        refused!(delete_navigation(i, g, s)),
        refused!(set_paired_with(i, g, &serde_json::json!({}))),
        refused!(delete_paired_with(i, g)),
        refused!(set_sdf(i, g, s, &command)),
        refused!(set_sdf_by_id(i, g, "wall", s, &effect)),
        refused!(patch_sdf(i, g, s, &command)),
        refused!(patch_sdf_by_id(i, g, "wall", s, &effect)),
        refused!(delete_sdf(i, g, s)),
        refused!(delete_sdf_by_id(i, g, "wall", s)),
        refused!(set_all_sdf(&list)),
        refused!(patch_all_sdf(&list)),
        refused!(delete_all_sdf()),
        refused!(reset_port("emulated")),
        refused!(save_configuration(id)),
    ];
    for (what, result) in &changes {
        let error = result.as_ref().expect_err(what).to_string();
        assert!(
            error.contains("is not emulated"),
            "{what}: the service's reason, not a decoding error: {error}"
        );
    }
    // Nothing changed.
    assert_eq!(
        http.get_handedness("inverse3", id).await.unwrap(),
        Handedness::Right
    );
    assert_eq!(
        http.get_session_profile(session_id).await.unwrap().name,
        "peer"
    );
    println!(
        "every read of the crate's InverseHttpClient answered in its types; {} changes refused with the service's reason",
        changes.len()
    );
}
