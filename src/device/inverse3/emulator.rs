//! An emulated Haply Inverse Service with one Inverse3 on it, on loopback:
//! the documented messages (service 3.5: the inventory on connecting, one
//! state frame per client message, `set_cursor_force` applied until the
//! next message, `GET /version` on the same port), and a hand on the
//! cursor.
//!
//! The physics: along the default track, the simulated apparatus model of
//! [`Rig`] with the simulated participant's hand (it follows the
//! session's drive, sent in the messages' `frictionlab_hand` key, which
//! the real service ignores as it does every key it does not know);
//! across the track and vertically, a point mass held by the hand's own
//! impedance. The hand rests 3 mm beside the track and 1 to 5 mm below its
//! surface (it presses on it, harder and softer at 0.5 Hz). The service's gravity compensation is
//! taken as perfect (no weight), and its filters as letting the force
//! through: both are reported as set in the inventory. Free constants
//! (not from a source): [`CURSOR_MASS_KG`], [`CURSOR_FRICTION_N`],
//! [`HAND_STIFFNESS_N_M`], [`HAND_DAMPING_N_S_M`], [`HAND_REST_ACROSS_M`],
//! [`HAND_PRESS_M`].

use std::io::{Read, Write};
use std::net::{TcpListener, TcpStream};
use std::sync::{Arc, Mutex};
use std::time::Instant;

use super::messages::{ClientMessage, DeviceFrame, ServiceFrame, State, Status, Vec3};
use crate::device::miswiring::Miswiring;
use crate::device::track::Track;
use frictionlab_core::plant::{Apparatus, Rig};

/// The cursor's moving mass, kg (free).
pub const CURSOR_MASS_KG: f64 = 0.2;
/// The arm's friction at the cursor, N (free).
pub const CURSOR_FRICTION_N: f64 = 0.02;
/// The hand's stiffness across the track and vertically, N/m (free).
pub const HAND_STIFFNESS_N_M: f64 = 200.0;
/// The hand's damping across and vertically, N s/m (free).
pub const HAND_DAMPING_N_S_M: f64 = 5.0;
/// Where the hand rests beside the track, m (free).
pub const HAND_REST_ACROSS_M: f64 = 0.003;
/// How deep below the track's surface the hand rests on average, m, how far
/// that swings either way, and how often, Hz (free: a person's press on a
/// surface varies as they slide; the swing makes the press, and a normal
/// force taken from it, vary within a trial).
pub const HAND_PRESS_M: (f64, f64, f64) = (0.003, 0.002, 0.5);
/// The hand's mass, kg (as the simulated participant's elsewhere).
pub const HAND_MASS_KG: f64 = 0.4;
/// How far along the track the arm moves before its stops, m: twice the
/// driver's default `workspace_radius_m`, the travel it states (issue 63:
/// a bring-up check of the emulator measures what the driver states).
pub const TRACK_RANGE_M: f64 = 0.2;
/// A force command lasts this long without another, s ("applied once and
/// forgotten": the device returns to idle).
pub const COMMAND_LASTS_S: f64 = 0.05;
/// Physics step, s.
pub const STEP_S: f64 = 0.0005;
/// Physics steps per client message in lockstep ([`Options::lockstep`]):
/// 1 ms, one period of the host's loop ([`super::RATE_HZ`]).
const LOCKSTEP_STEPS: u32 = 2;
/// The service version the emulator states.
pub const VERSION: &str = "3.5.0";
/// The emulated device's id.
pub const DEVICE_ID: &str = "E3M1";

/// The Inverse3's cursor with a hand on it.
#[derive(Debug, Clone)]
pub struct Plant {
    track: Track,
    rig: Rig,
    /// Across the track (horizontal) and vertical: offset, m, velocity, m/s.
    across: [(f64, f64); 2],
    force_n: [f64; 3],
    commanded_s: f64,
    t_s: f64,
    /// How the arm is wired wrong along the track, if it is (tests of the
    /// bring-up check).
    miswiring: Miswiring,
}

impl Plant {
    /// The cursor at rest 2 cm above the track's origin.
    #[must_use]
    pub fn new(track: Track) -> Self {
        let apparatus = Apparatus {
            mass_kg: CURSOR_MASS_KG,
            static_friction_n: CURSOR_FRICTION_N,
            max_force_n: 1e3,
            range_m: TRACK_RANGE_M,
            encoder_m: 1e-9,
            ..Apparatus::default()
        };
        Plant {
            track,
            rig: Rig::new(apparatus, HAND_MASS_KG),
            across: [(0.0, 0.0), (0.02, 0.0)],
            force_n: [0.0; 3],
            commanded_s: f64::NEG_INFINITY,
            t_s: 0.0,
            miswiring: Miswiring::default(),
        }
    }

    /// This arm wired wrong along the track as `miswiring` says: the
    /// position it reports along the track counted the other way, or
    /// `encoder_scale` times as far, from the track's origin; the force
    /// along the track applied the other way (as a service set up for the
    /// other hand mirrors an axis).
    #[must_use]
    pub fn miswired(mut self, miswiring: Miswiring) -> Self {
        self.miswiring = miswiring;
        self
    }

    /// The track's direction, across it horizontally, and up.
    fn axes(&self) -> [[f64; 3]; 3] {
        let d = self.track.direction;
        let n = d[0].hypot(d[1]).max(1e-12);
        let u = [d[0] / n, d[1] / n, 0.0];
        [u, [-u[1], u[0], 0.0], [0.0, 0.0, 1.0]]
    }

    /// Advances to `t_s` in steps of [`STEP_S`].
    pub fn advance(&mut self, t_s: f64) {
        while self.t_s + STEP_S <= t_s {
            self.step(STEP_S);
            self.t_s += STEP_S;
        }
    }

    /// Advances one host period ([`Options::lockstep`]).
    pub fn advance_lockstep(&mut self) {
        for _ in 0..LOCKSTEP_STEPS {
            self.step(STEP_S);
            self.t_s += STEP_S;
        }
    }

    fn step(&mut self, dt: f64) {
        let f = if self.t_s - self.commanded_s <= COMMAND_LASTS_S {
            self.force_n
        } else {
            [0.0; 3]
        };
        let axes = self.axes();
        let along: f64 = (0..3).map(|i| f[i] * axes[0][i]).sum();
        let along = self.miswiring.motor(along);
        self.rig.step(dt, |_| along);
        let (depth, swing, hz) = HAND_PRESS_M;
        let rest = [
            HAND_REST_ACROSS_M,
            -(depth + swing * (2.0 * std::f64::consts::PI * hz * self.t_s).sin()),
        ];
        for k in 0..2 {
            let push: f64 = (0..3).map(|i| f[i] * axes[k + 1][i]).sum();
            let (y, v) = self.across[k];
            let a = (push - HAND_STIFFNESS_N_M * (y - rest[k]) - HAND_DAMPING_N_S_M * v)
                / (CURSOR_MASS_KG + HAND_MASS_KG);
            let v = v + a * dt;
            self.across[k] = (y + v * dt, v);
        }
    }

    /// The cursor's position, m.
    #[must_use]
    pub fn position(&self) -> [f64; 3] {
        let axes = self.axes();
        let x = self.miswiring.encoder(self.rig.x_m());
        let o = self.track.origin_m;
        [0, 1, 2].map(|i| {
            o[i] + x * axes[0][i] + self.across[0].0 * axes[1][i] + self.across[1].0 * axes[2][i]
        })
    }

    /// Applies a message: its force on [`DEVICE_ID`] (from now until the
    /// next, or [`COMMAND_LASTS_S`]), and the hand's drive if it has one.
    pub fn apply(&mut self, m: &ClientMessage) {
        if let Some(d) = m.inverse3.iter().find(|d| d.device_id == DEVICE_ID)
            && let Some(f) = d.commands.and_then(|c| c.set_cursor_force)
        {
            let v = f.vector.array();
            self.force_n = if v.iter().all(|x| x.is_finite()) {
                v
            } else {
                [0.0; 3]
            };
            self.commanded_s = self.t_s;
        }
        if let Some(h) = &m.frictionlab_hand {
            self.rig.drive(*h);
        }
    }

    /// The state frame: `config` with it in the inventory.
    #[must_use]
    pub fn frame(&self, session_id: u64, inventory: bool) -> ServiceFrame {
        let now = self.t_s - self.commanded_s <= COMMAND_LASTS_S;
        ServiceFrame {
            session_id,
            inverse3: vec![DeviceFrame {
                device_id: DEVICE_ID.into(),
                config: inventory.then(config),
                state: State {
                    cursor_position: Some(Vec3::of(self.position())),
                    cursor_velocity: Some(Vec3::default()),
                    current_cursor_force: Some(Vec3::of(if now { self.force_n } else { [0.0; 3] })),
                    mode: "idle".into(),
                },
                status: Status {
                    calibrated: true,
                    in_use: true,
                    power_supply: true,
                    ready: true,
                    started: true,
                },
            }],
        }
    }
}

/// The emulated device's configuration, as the inventory states it
/// (the documented example's keys; the filters as the service's defaults
/// are documented in its example).
fn config() -> serde_json::Value {
    serde_json::json!({
        "type": "inverse3",
        "port": "emulated",
        "device_info": {"id": DEVICE_ID, "major_version": 7, "minor_version": 4,
                        "device_type": "inverse3", "uuid": "00000000-0000-0000-0000-00000000e3e1"},
        "extended_device_id": DEVICE_ID,
        "extended_firmware_version": "frictionlab-emulator",
        "gravity_compensation": {"enabled": true, "scaling_factor": 1.0},
        "handedness": "right",
        "torque_scaling": {"enabled": true},
        "streaming_mode": "USB",
        "preset": "defaults",
        "filters": {"force_gate": {"gain": 0.3}, "damping": {"scalar": 0.0}}
    })
}

/// What the emulated service answers with.
#[derive(Debug, Clone)]
pub struct Options {
    /// The version it states at `GET /version`.
    pub version: String,
    /// Whether it lists an Inverse3 (false: an inventory with none).
    pub with_device: bool,
    /// Advances the physics one host period (1 ms) per client
    /// message instead of in real time: a host the machine stalls stalls
    /// the device with it, so what a client reads follows from what it
    /// sent, whatever the load.
    pub lockstep: bool,
    /// How the arm is wired wrong, if it is ([`Plant::miswired`]).
    pub miswiring: Miswiring,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            version: VERSION.into(),
            with_device: true,
            lockstep: false,
            miswiring: Miswiring::default(),
        }
    }
}

/// Serves clients on `listener` until it fails: each WebSocket client in
/// its own thread, on one shared plant advanced in real time (or in
/// lockstep with the messages, [`Options::lockstep`]); plain HTTP requests
/// get `/version`.
///
/// # Errors
/// The listener failed.
pub fn serve(listener: &TcpListener, track: Track, options: &Options) -> std::io::Result<()> {
    let plant = Arc::new(Mutex::new(Plant::new(track).miswired(options.miswiring)));
    let start = Instant::now();
    for (sessions, stream) in (1_u64..).zip(listener.incoming()) {
        let stream = stream?;
        let (plant, options) = (plant.clone(), options.clone());
        std::thread::spawn(move || {
            let _ = client(stream, &plant, start, sessions, &options);
        });
    }
    Ok(())
}

fn is_websocket(stream: &TcpStream) -> bool {
    let mut head = [0_u8; 2048];
    let n = stream.peek(&mut head).unwrap_or(0);
    String::from_utf8_lossy(&head[..n])
        .to_ascii_lowercase()
        .contains("upgrade: websocket")
}

fn client(
    mut stream: TcpStream,
    plant: &Mutex<Plant>,
    start: Instant,
    session_id: u64,
    options: &Options,
) -> std::io::Result<()> {
    stream.set_nodelay(true)?;
    // Wait for the request's head before deciding what it is.
    std::thread::sleep(std::time::Duration::from_millis(5));
    if !is_websocket(&stream) {
        return http(&mut stream, options);
    }
    let mut ws = tungstenite::accept(stream).map_err(std::io::Error::other)?;
    let frame = |inventory: bool| {
        let mut p = plant
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        if !options.lockstep {
            p.advance(start.elapsed().as_secs_f64());
        }
        let mut f = p.frame(session_id, inventory);
        if !options.with_device {
            f.inverse3.clear();
        }
        serde_json::to_string(&f).unwrap_or_default()
    };
    ws.send(tungstenite::Message::text(frame(true)))
        .map_err(std::io::Error::other)?;
    loop {
        let m = ws.read().map_err(std::io::Error::other)?;
        let text = match m {
            tungstenite::Message::Text(t) => t.to_string(),
            tungstenite::Message::Close(_) => return Ok(()),
            _ => continue,
        };
        let message: ClientMessage = serde_json::from_str(&text).unwrap_or_default();
        {
            let mut p = plant
                .lock()
                .unwrap_or_else(std::sync::PoisonError::into_inner);
            if options.lockstep {
                p.advance_lockstep();
            } else {
                p.advance(start.elapsed().as_secs_f64());
            }
            if options.with_device {
                p.apply(&message);
            }
        }
        let full = message.session.force_render_full_state.is_some();
        ws.send(tungstenite::Message::text(frame(full)))
            .map_err(std::io::Error::other)?;
    }
}

/// A plain HTTP request: `GET /version` answered, anything else 404.
fn http(stream: &mut TcpStream, options: &Options) -> std::io::Result<()> {
    let mut head = [0_u8; 2048];
    let n = stream.read(&mut head)?;
    let request = String::from_utf8_lossy(&head[..n]);
    let (status, body) = if request.starts_with("GET /version") {
        (
            "200 OK",
            serde_json::json!({
                "build_time": "",
                "git_branch": "",
                "git_describe": options.version,
                "git_hash": "",
                "git_tag": options.version,
                "project_name": "haply-inverse-service (frictionlab emulator)",
                "project_version": options.version,
            })
            .to_string(),
        )
    } else {
        (
            "404 Not Found",
            r#"{"ok":false,"error":"not found"}"#.to_owned(),
        )
    };
    write!(
        stream,
        "HTTP/1.1 {status}\r\nContent-Type: application/json\r\nContent-Length: {}\r\nConnection: close\r\n\r\n{body}",
        body.len()
    )
}
