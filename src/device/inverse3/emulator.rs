//! An emulated Haply Inverse Service with one Inverse3 on it, on loopback:
//! the documented messages (service 3.5: the inventory on connecting, one
//! state frame per client message, `set_cursor_force` applied until the
//! next message), and a hand on the cursor. On the same port, the HTTP
//! API that Haply's `haply` crate 1.3.1 calls ([`rest`]: `GET /version`,
//! `GET /devices`, the sessions, settings and the device's configuration,
//! read-only; anything else 404 with a JSON error body).
//!
//! The inventory's `config` holds the keys of the service's documented
//! example and `id`, the device's id: the crate's `get_devices()` reads a
//! device's id from there (its `DeviceConfig::id`), and without it gave
//! `[""]` over the WebSocket (issue 63).
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

pub mod rest;

use std::collections::BTreeMap;
use std::io::{Read, Write};
use std::net::{TcpListener, TcpStream};
use std::sync::{Arc, Mutex, PoisonError};
use std::time::{Duration, Instant};

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
    /// Host periods advanced in lockstep: the number of the state a frame
    /// shows ([`Options::lockstep`]).
    periods: u64,
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
            periods: 0,
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
        self.periods += 1;
    }

    /// Host periods advanced in lockstep: the number of the state it is in.
    #[must_use]
    pub fn periods(&self) -> u64 {
        self.periods
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
        ServiceFrame {
            session_id,
            inverse3: vec![self.device(inventory)],
            frictionlab_state: None,
        }
    }

    /// The Inverse3 in a frame (with its `config` in the inventory).
    #[must_use]
    pub fn device(&self, inventory: bool) -> DeviceFrame {
        let now = self.t_s - self.commanded_s <= COMMAND_LASTS_S;
        DeviceFrame {
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
        }
    }
}

/// The emulated device's configuration, as the inventory and the HTTP API
/// state it: the keys of the service's documented inventory (3.5: device
/// info with `device_type` 4, the Inverse3's code; home return off; basis
/// `XYZ`; the mount the identity; the filters as the documented example's
/// defaults), and `id`, the device's id, which the `haply` crate reads as
/// the device's id (`DeviceConfig::id`; issue 63).
fn config() -> serde_json::Value {
    serde_json::json!({
        "id": DEVICE_ID,
        "type": "inverse3",
        "port": "emulated",
        "device_info": {"id": DEVICE_ID, "major_version": 7, "minor_version": 4,
                        "device_type": 4, "uuid": "00000000-0000-0000-0000-00000000e3e1"},
        "extended_device_id": DEVICE_ID,
        "extended_firmware_version": "frictionlab-emulator",
        "gravity_compensation": {"enabled": true, "scaling_factor": 1.0},
        "handedness": "right",
        "torque_scaling": {"enabled": true},
        "home_return": {"enabled": false},
        "streaming_mode": "USB",
        "preset": "defaults",
        "basis": {"permutation": "XYZ"},
        "mount": *rest::IDENTITY,
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
    /// Advances the physics one host period (1 ms) per client message
    /// instead of in real time: a host the machine stalls stalls the device
    /// with it, so what a client reads follows from what it sent, whatever
    /// the load. Each state frame then carries its number
    /// (`frictionlab_state`); a message that echoes one advances the
    /// physics only if it is the newest, computed on the state the device
    /// is in. One computed on an older state (sent before the client had
    /// read the newest: the emulator stalled, or the client's loop caught
    /// up on ticks it missed) applies its force without a period of its
    /// own, as on the real device, where such messages arrive within one
    /// period. A client that echoes nothing (Haply's own, which reads one
    /// frame behind what it sends) gets one period per message.
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

/// What the clients share: the plant, the sessions (each WebSocket
/// client's id and profile), when the service started, the port it
/// listens on and what it answers with.
struct Shared {
    plant: Mutex<Plant>,
    sessions: Mutex<BTreeMap<u64, Option<String>>>,
    start: Instant,
    port: u16,
    options: Options,
}

impl Shared {
    fn plant(&self) -> std::sync::MutexGuard<'_, Plant> {
        self.plant.lock().unwrap_or_else(PoisonError::into_inner)
    }

    fn sessions(&self) -> std::sync::MutexGuard<'_, BTreeMap<u64, Option<String>>> {
        self.sessions.lock().unwrap_or_else(PoisonError::into_inner)
    }

    /// The plant, advanced to now unless in lockstep (where only the
    /// WebSocket's messages advance it).
    fn now(&self) -> std::sync::MutexGuard<'_, Plant> {
        let mut p = self.plant();
        if !self.options.lockstep {
            p.advance(self.start.elapsed().as_secs_f64());
        }
        p
    }

    /// What the HTTP API answers from.
    fn view(&self) -> rest::View {
        let device = self
            .options
            .with_device
            .then(|| serde_json::to_value(self.now().device(true)).unwrap_or_default());
        rest::View {
            version: self.options.version.clone(),
            device,
            sessions: self
                .sessions()
                .iter()
                .map(|(&id, profile)| rest::Session {
                    id,
                    profile: profile.clone(),
                })
                .collect(),
            port: self.port,
        }
    }
}

/// A WebSocket client's session, listed from its handshake until it ends.
struct Listed<'a> {
    shared: &'a Shared,
    id: u64,
}

impl Drop for Listed<'_> {
    fn drop(&mut self) {
        self.shared.sessions().remove(&self.id);
    }
}

/// Serves clients on `listener` until it fails: each WebSocket client in
/// its own thread, on one shared plant advanced in real time (or in
/// lockstep with the messages, [`Options::lockstep`]); plain HTTP requests
/// get the HTTP API ([`rest`]).
///
/// # Errors
/// The listener failed.
pub fn serve(listener: &TcpListener, track: Track, options: &Options) -> std::io::Result<()> {
    // A device keeps its own time: at real-time priority where allowed
    // (crate::device::realtime, inherited by each client's thread; issue 63).
    let _ = crate::device::realtime::ask_fifo(); // granted or not, it serves
    let shared = Arc::new(Shared {
        plant: Mutex::new(Plant::new(track).miswired(options.miswiring)),
        sessions: Mutex::new(BTreeMap::new()),
        start: Instant::now(),
        port: listener.local_addr()?.port(),
        options: options.clone(),
    });
    for (sessions, stream) in (1_u64..).zip(listener.incoming()) {
        let stream = stream?;
        let shared = shared.clone();
        std::thread::spawn(move || {
            let _ = client(stream, &shared, sessions);
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

fn client(mut stream: TcpStream, shared: &Shared, session_id: u64) -> std::io::Result<()> {
    let options = &shared.options;
    stream.set_nodelay(true)?;
    // Wait for the request's head before deciding what it is.
    std::thread::sleep(Duration::from_millis(5));
    if !is_websocket(&stream) {
        return http(&mut stream, shared);
    }
    let mut ws = tungstenite::accept(stream).map_err(std::io::Error::other)?;
    shared.sessions().insert(session_id, None);
    let _listed = Listed {
        shared,
        id: session_id,
    };
    let frame = |inventory: bool| {
        let p = shared.now();
        let mut f = p.frame(session_id, inventory);
        if options.lockstep {
            f.frictionlab_state = Some(p.periods());
        }
        drop(p);
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
        if let Some(profile) = message
            .session
            .configure
            .as_ref()
            .and_then(|c| c.profile.as_ref())
        {
            shared
                .sessions()
                .insert(session_id, Some(profile.name.clone()));
        }
        {
            let mut p = if options.lockstep {
                let mut p = shared.plant();
                // A period for a message computed on the newest state (or
                // from a client that does not say): see Options::lockstep.
                if message.frictionlab_state.is_none_or(|n| n == p.periods()) {
                    p.advance_lockstep();
                }
                p
            } else {
                shared.now()
            };
            if options.with_device {
                p.apply(&message);
            }
        }
        let full = message.session.force_render_full_state.is_some();
        ws.send(tungstenite::Message::text(frame(full)))
            .map_err(std::io::Error::other)?;
    }
}

/// The longest request (head and body) the emulated service reads, bytes.
const REQUEST_LIMIT: usize = 1 << 20;

/// How much of a request is read at a time, bytes.
const CHUNK: usize = 4096;

/// How long a client may take to send its request.
const REQUEST_TIMEOUT: Duration = Duration::from_secs(5);

/// A plain HTTP request: answered by the HTTP API ([`rest`]), one request
/// per connection.
fn http(stream: &mut TcpStream, shared: &Shared) -> std::io::Result<()> {
    stream.set_read_timeout(Some(REQUEST_TIMEOUT))?;
    let reply = match read_request(stream)? {
        Some((method, target)) => rest::route(&method, &target, &shared.view()),
        None => rest::Reply::error(400, "not an HTTP request the emulated service can read"),
    };
    let body = reply.body.to_string();
    write!(
        stream,
        "HTTP/1.1 {} {}\r\nContent-Type: application/json\r\nContent-Length: {}\r\nConnection: close\r\n\r\n{body}",
        reply.status,
        reply.reason(),
        body.len()
    )
}

/// Reads a request's head (method and target) and its body, which no route
/// takes but which is read so that closing the connection does not reset
/// it before the client has the answer. `None`: not HTTP, or longer than
/// [`REQUEST_LIMIT`].
fn read_request(stream: &mut TcpStream) -> std::io::Result<Option<(String, String)>> {
    let mut read = Vec::new();
    let mut chunk = [0_u8; CHUNK];
    loop {
        let mut headers = [httparse::EMPTY_HEADER; 64];
        let mut request = httparse::Request::new(&mut headers);
        match request.parse(&read) {
            Ok(httparse::Status::Complete(head)) => {
                let length = request
                    .headers
                    .iter()
                    .find(|h| h.name.eq_ignore_ascii_case("content-length"))
                    .and_then(|h| std::str::from_utf8(h.value).ok()?.trim().parse().ok())
                    .unwrap_or(0_usize);
                let (Some(method), Some(target)) = (request.method, request.path) else {
                    return Ok(None);
                };
                let (method, target) = (method.to_owned(), target.to_owned());
                let whole = head.saturating_add(length);
                if whole > REQUEST_LIMIT {
                    return Ok(None);
                }
                let mut left = whole.saturating_sub(read.len());
                while left > 0 {
                    let n = stream.read(&mut chunk[..left.min(CHUNK)])?;
                    if n == 0 {
                        break;
                    }
                    left -= n;
                }
                return Ok(Some((method, target)));
            }
            Ok(httparse::Status::Partial) if read.len() < REQUEST_LIMIT => {}
            _ => return Ok(None),
        }
        let n = stream.read(&mut chunk)?;
        if n == 0 {
            return Ok(None);
        }
        read.extend_from_slice(&chunk[..n]);
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, reason = "tests")]
    use super::*;

    /// An emulated service on a free loopback port (lockstep).
    fn service() -> std::net::SocketAddr {
        let listener = TcpListener::bind("127.0.0.1:0").unwrap();
        let address = listener.local_addr().unwrap();
        let options = Options {
            lockstep: true,
            ..Options::default()
        };
        let track = crate::device::inverse3::Config::default().track;
        std::thread::spawn(move || serve(&listener, track, &options));
        address
    }

    /// Sends `parts` (with a pause between them), reads the answer: its
    /// status code and JSON body.
    fn ask(address: std::net::SocketAddr, parts: &[&str]) -> (u16, serde_json::Value) {
        let mut stream = TcpStream::connect(address).unwrap();
        for part in parts {
            stream.write_all(part.as_bytes()).unwrap();
            std::thread::sleep(Duration::from_millis(20));
        }
        let mut text = String::new();
        stream.read_to_string(&mut text).unwrap();
        let (head, body) = text.split_once("\r\n\r\n").unwrap();
        let status = head.split(' ').nth(1).unwrap().parse().unwrap();
        assert!(head.contains("Content-Type: application/json"), "{head}");
        (status, serde_json::from_str(body).unwrap())
    }

    fn get(address: std::net::SocketAddr, path: &str) -> (u16, serde_json::Value) {
        ask(
            address,
            &[&format!("GET {path} HTTP/1.1\r\nHost: x\r\n\r\n")],
        )
    }

    /// Issue 63: over the socket, `GET /devices` answers 200 with the
    /// inventory (it answered 404), an unknown path 404 with a JSON error,
    /// and `GET /version` as before.
    #[test]
    fn issue_63_the_service_answers_its_http_api_on_its_port() {
        let address = service();
        let (status, devices) = get(address, "/devices");
        assert_eq!(status, 200, "{devices}");
        let device = &devices["inverse3"][0];
        assert_eq!(device["device_id"], DEVICE_ID);
        assert_eq!(device["config"]["id"], DEVICE_ID);
        assert!(
            device["state"]["cursor_position"]["z"].is_number(),
            "{device}"
        );
        let (status, error) = get(address, "/no/such/route");
        assert_eq!((status, &error["ok"]), (404, &serde_json::json!(false)));
        let (status, version) = get(address, "/version");
        assert_eq!(
            (status, &version["project_version"]),
            (200, &serde_json::json!(VERSION))
        );
        let (status, port) = get(address, "/settings/communication/http/port");
        assert_eq!(
            (status, &port["data"]),
            (200, &serde_json::json!(address.port()))
        );
    }

    /// A request that arrives in pieces (head split, body later) is read
    /// whole; a change is refused (501) with the documented error envelope.
    #[test]
    fn a_request_in_pieces_is_read_whole_and_a_change_is_refused() {
        let address = service();
        let body = r#"{"handedness":"left"}"#;
        let (status, reply) = ask(
            address,
            &[
                "POST /inverse3/0/config/hand",
                &format!(
                    "edness HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\nContent-Length: {}\r\n\r\n",
                    body.len()
                ),
                body,
            ],
        );
        assert_eq!(
            (status, &reply["ok"]),
            (501, &serde_json::json!(false)),
            "{reply}"
        );
        let (_, still) = get(address, "/inverse3/0/config/handedness");
        assert_eq!(still["data"], "right");
        let (status, _) = ask(address, &["\x16\x03\x01 not http\r\n\r\n"]);
        assert_eq!(status, 400);
    }

    /// Issue 63: in lockstep each state frame carries its number. A message
    /// that echoes the newest advances the physics one period, and so does
    /// one that echoes nothing (Haply's client); of two computed on the same
    /// state (a burst: the client's loop catching up, or the emulator
    /// stalled while the client sent on), the second applies its force
    /// without advancing. Before, each advanced 1 ms on a state the client
    /// had not seen, and the loop's wall acted on positions as old as the
    /// stall (the hand 2.1 mm off the track under load).
    #[test]
    fn issue_63_in_lockstep_only_a_message_computed_on_the_newest_state_advances_the_physics() {
        let address = service();
        let (mut ws, _) = tungstenite::connect(format!("ws://{address}/")).unwrap();
        let inventory: ServiceFrame =
            serde_json::from_str(ws.read().unwrap().to_text().unwrap()).unwrap();
        let n0 = inventory.frictionlab_state.unwrap();
        for (echo, z) in [
            (None, 0.0),
            (Some(n0 + 1), 0.0),
            (Some(n0 + 2), 1.0),
            (Some(n0 + 2), 1.5),
        ] {
            let mut m = super::super::messages::force(DEVICE_ID, [0.0, 0.0, z], None);
            m.frictionlab_state = echo;
            ws.send(tungstenite::Message::text(
                serde_json::to_string(&m).unwrap(),
            ))
            .unwrap();
        }
        let frames: Vec<ServiceFrame> = (0..4)
            .map(|_| serde_json::from_str(ws.read().unwrap().to_text().unwrap()).unwrap())
            .collect();
        let states: Vec<_> = frames.iter().map(|f| f.frictionlab_state).collect();
        assert_eq!(
            states,
            [n0 + 1, n0 + 2, n0 + 3, n0 + 3].map(Some),
            "a period each for no echo and the newest, none for a stale one"
        );
        let state = |k: usize| frames[k].inverse3[0].state.clone();
        assert_eq!(state(2).cursor_position, state(3).cursor_position);
        assert_eq!(
            state(3).current_cursor_force.map(|f| f.z),
            Some(1.5),
            "the stale message's force applies"
        );
    }

    /// Each WebSocket client is a session, listed with the profile it
    /// configured while it is connected, and gone when it leaves.
    #[test]
    fn websocket_clients_are_listed_as_sessions_with_their_profiles() {
        let address = service();
        let (mut ws, _) = tungstenite::connect(format!("ws://{address}/")).unwrap();
        let inventory: ServiceFrame =
            serde_json::from_str(ws.read().unwrap().to_text().unwrap()).unwrap();
        let id = inventory.session_id;
        let message = super::super::messages::force(DEVICE_ID, [0.0; 3], Some("frictionlab"));
        ws.send(tungstenite::Message::text(
            serde_json::to_string(&message).unwrap(),
        ))
        .unwrap();
        ws.read().unwrap();
        let (_, sessions) = get(address, "/sessions");
        assert_eq!(sessions["data"]["session_count"], 1, "{sessions}");
        assert_eq!(sessions["data"]["sessions"][0]["session_id"], id);
        let (status, profile) = get(address, &format!("/sessions/{id}/profile"));
        assert_eq!(
            (status, &profile["data"]["name"]),
            (200, &serde_json::json!("frictionlab"))
        );
        let (status, basis) = get(
            address,
            "/inverse3/E3M1/config/basis?session=:frictionlab:0",
        );
        assert_eq!(
            (status, &basis["data"]["permutation"]),
            (200, &serde_json::json!("XYZ"))
        );
        ws.close(None).unwrap();
        while ws.read().is_ok() {}
        let mut count = serde_json::Value::Null;
        for _ in 0..100 {
            count = get(address, "/sessions").1["data"]["session_count"].clone();
            if count == 0 {
                break;
            }
            std::thread::sleep(Duration::from_millis(10));
        }
        assert_eq!(count, 0, "the session ends with its client");
    }
}
