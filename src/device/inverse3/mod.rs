//! The Haply Inverse3, through the Haply Inverse Service: its local
//! WebSocket (JSON; service 3.5) and `GET /version` on the same port
//! (docs.haply.co; default `127.0.0.1:10001`). [`emulator`] is an Inverse
//! Service we ship for tests and for trying without hardware.
//!
//! Our own lean driver on `tungstenite`, not Haply's `haply` crate: the
//! crate runs on tokio and reqwest 0.11, whose default TLS needs OpenSSL
//! (a system package, or minutes of building it from source) for a
//! service on loopback that needs no TLS at all, and it brings a second
//! nalgebra. Its wire types are the reference instead:
//! `crates/haply-peer/` parses every message our driver and emulator send
//! with them, and connects the crate's own `HaplyDevice` to our emulator.
//!
//! [`open`] checks the service's version, connects, reads the inventory,
//! chooses the device, configures the session's profile (`frictionlab`)
//! and checks that the hand is in the workspace; it refuses, with one
//! line, a service that is missing or speaks another version, an
//! inventory with no Inverse3, or a cursor far from the track. Then one
//! force command goes out and one state frame comes back per tick, on the
//! haptic loop's thread. Where the service numbers its state frames (our
//! emulator in lockstep, [`emulator::Options::lockstep`]), each command
//! echoes the number of the newest frame read: the state it was computed
//! on. The inventory's configuration (filters, gravity
//! compensation, torque scaling) is logged in the session header.
//!
//! Never run on an Inverse3 here: written from the service's
//! documentation and tested against the vendor's crate on the emulator.

pub mod emulator;
pub mod messages;

use std::io::{ErrorKind, Read, Write};
use std::net::{SocketAddr, TcpStream, ToSocketAddrs};
use std::time::Duration;

use self::messages::ServiceFrame;
use super::backend::{Backend, Capabilities, LinkState, Reading, Vector};
use super::track::Track;
use crate::hand::HandDrive;

/// Where the service listens unless told otherwise.
pub const DEFAULT_ADDRESS: &str = "127.0.0.1:10001";

/// The oldest service version whose protocol this driver speaks.
pub const SERVICE_VERSION: (u32, u32) = (3, 5);

/// No state frame for this long: the link is lost, s.
pub const LOST_AFTER_S: f64 = 0.100;

/// How often a lost service is tried again, s.
pub const RECONNECT_EVERY_S: f64 = 0.5;

/// The loop rate this driver runs the service at, Hz (one message and one
/// frame per tick).
pub const RATE_HZ: f64 = 1000.0;

/// The profile the session configures.
pub const PROFILE: &str = "frictionlab";

/// The device kind, as listed in [`super::KINDS`].
pub const KIND: super::Kind = super::Kind {
    name: "inverse3",
    about: "Haply Inverse3 through the Haply Inverse Service, or `frictionlab device-emulator inverse3[:ADDRESS]`",
    target: "[HOST:PORT]",
    bare: false,
    check: |t| address(t).map(|_| ()),
    check_settings: |set| Config::with(set).map(|_| ()),
    open,
    find,
};

/// A target as `host:port` (default [`DEFAULT_ADDRESS`]; a `ws://` or
/// `http://` prefix and a trailing `/` are allowed).
///
/// # Errors
/// Not `host:port`.
pub fn address(target: &str) -> Result<String, String> {
    let t = target
        .trim_start_matches("ws://")
        .trim_start_matches("http://")
        .trim_end_matches('/');
    if t.is_empty() {
        return Ok(DEFAULT_ADDRESS.into());
    }
    match t.rsplit_once(':') {
        Some((host, port)) if !host.is_empty() && port.parse::<u16>().is_ok() => Ok(t.to_owned()),
        _ => Err(format!(
            "expected HOST:PORT, such as {DEFAULT_ADDRESS}, got '{target}'"
        )),
    }
}

fn resolve(address: &str) -> Result<SocketAddr, String> {
    address
        .to_socket_addrs()
        .map_err(|e| e.to_string())?
        .next()
        .ok_or_else(|| format!("{address} names no address"))
}

/// The service's version at `address` (`GET /version`: `project_version`,
/// bare or in the 3.5 `{ok, data}` envelope).
///
/// # Errors
/// Nothing listens, or the answer is not a version.
pub fn service_version(address: &str, timeout: Duration) -> Result<String, String> {
    let mut stream =
        TcpStream::connect_timeout(&resolve(address)?, timeout).map_err(|e| e.to_string())?;
    stream
        .set_read_timeout(Some(timeout))
        .map_err(|e| e.to_string())?;
    write!(
        stream,
        "GET /version HTTP/1.1\r\nHost: {address}\r\nConnection: close\r\n\r\n"
    )
    .map_err(|e| e.to_string())?;
    let mut text = String::new();
    let _ = stream.read_to_string(&mut text);
    let body = text.split_once("\r\n\r\n").map_or("", |(_, b)| b);
    let v: serde_json::Value =
        serde_json::from_str(body).map_err(|_| "answers GET /version with no JSON".to_owned())?;
    let v = v.get("data").unwrap_or(&v);
    v.get("project_version")
        .and_then(serde_json::Value::as_str)
        .map(str::to_owned)
        .ok_or_else(|| "answers GET /version with no project_version".to_owned())
}

/// Whether `version` (`3.5.0`, `v3.6.1-rc`) is at least [`SERVICE_VERSION`].
#[must_use]
pub fn speaks(version: &str) -> bool {
    let mut parts = version
        .trim_start_matches('v')
        .split(|c: char| !c.is_ascii_digit())
        .map(|p| p.parse::<u32>().unwrap_or(0));
    let (major, minor) = (parts.next().unwrap_or(0), parts.next().unwrap_or(0));
    (major, minor) >= SERVICE_VERSION
}

fn find() -> Vec<super::Found> {
    service_version(DEFAULT_ADDRESS, Duration::from_millis(50))
        .map(|v| super::Found {
            address: String::new(),
            what: format!("Haply Inverse Service {v} at {DEFAULT_ADDRESS}"),
        })
        .into_iter()
        .collect()
}

/// An Inverse3's settings, each overridable with `--device-set`.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Config {
    /// The device to use (its `device_id`); empty: the first listed.
    pub device_id: String,
    /// The track (its z must be 0 in direction: it lies on a horizontal
    /// surface, z up), and the wall. Default: along x through
    /// (0, -0.12, 0.15) m, the cursor position of the service's documented
    /// example; the wall 2000 N/m and 5 N s/m, as for the 2DIY.
    pub track: Track,
    /// The largest force sent, N: our conservative choice (no continuous
    /// force limit is stated in the documents read).
    pub force_limit_n: f64,
    /// A session starts only with the cursor within this of the track's
    /// origin, m.
    pub workspace_radius_m: f64,
}

impl Default for Config {
    fn default() -> Self {
        Config {
            device_id: String::new(),
            track: Track {
                origin_m: [0.0, -0.12, 0.15],
                direction: [1.0, 0.0, 0.0],
                wall_stiffness_n_m: 2000.0,
                wall_damping_n_s_m: 5.0,
            },
            force_limit_n: 3.0,
            workspace_radius_m: 0.1,
        }
    }
}

impl Config {
    /// The defaults with `set` applied.
    ///
    /// # Errors
    /// One line naming each setting that is wrong.
    pub fn with(set: &[String]) -> Result<Self, String> {
        let mut pairs = Vec::new();
        for s in set {
            pairs.push(crate::settings::split_setting(s).map_err(|p| p.to_string())?);
        }
        let c: Config = crate::settings::apply(&Config::default(), "", "inverse3", &pairs)
            .map_err(|p| {
                p.iter()
                    .map(ToString::to_string)
                    .collect::<Vec<_>>()
                    .join("; ")
            })?;
        if let Some(p) = c.track.problem() {
            return Err(p);
        }
        if c.track.direction[2] != 0.0 {
            return Err(
                "the track lies on a horizontal surface: its direction's z must be 0".into(),
            );
        }
        if !(c.force_limit_n > 0.0 && c.workspace_radius_m > 0.0) {
            return Err("force_limit_n and workspace_radius_m must be above 0".into());
        }
        Ok(c)
    }
}

type Socket = tungstenite::WebSocket<TcpStream>;

/// Connects and reads the inventory: the socket, the chosen device's id and
/// its configuration.
fn connect(
    address: &str,
    wanted: &str,
    timeout: Duration,
) -> Result<(Socket, String, serde_json::Value), String> {
    let stream =
        TcpStream::connect_timeout(&resolve(address)?, timeout).map_err(|e| e.to_string())?;
    stream
        .set_read_timeout(Some(timeout))
        .map_err(|e| e.to_string())?;
    stream.set_nodelay(true).map_err(|e| e.to_string())?;
    let (mut ws, _) = tungstenite::client(format!("ws://{address}/"), stream)
        .map_err(|e| format!("WebSocket: {e}"))?;
    let inventory = read_frame(&mut ws).ok_or("sent no inventory")?;
    let device = inventory
        .inverse3
        .iter()
        .find(|d| wanted.is_empty() || d.device_id == wanted)
        .ok_or_else(|| {
            if wanted.is_empty() {
                "lists no Inverse3 (is it plugged in and powered?)".to_owned()
            } else {
                format!("lists no Inverse3 '{wanted}'")
            }
        })?;
    Ok((
        ws,
        device.device_id.clone(),
        device.config.clone().unwrap_or(serde_json::Value::Null),
    ))
}

/// The next state frame, blocking up to the socket's timeout; None on a
/// timeout or an error.
fn read_frame(ws: &mut Socket) -> Option<ServiceFrame> {
    loop {
        match ws.read().ok()? {
            tungstenite::Message::Text(t) => return serde_json::from_str(t.as_str()).ok(),
            tungstenite::Message::Close(_) => return None,
            _ => {}
        }
    }
}

fn open(target: &str, settings: &super::Settings) -> Result<Box<dyn Backend>, String> {
    let config = Config::with(&settings.set)?;
    let address = address(target)?;
    let wait = Duration::from_secs(2);
    let version = service_version(&address, wait).map_err(|e| {
        format!("no Haply Inverse Service at {address}: {e} (is the service running?)")
    })?;
    if !speaks(&version) {
        return Err(format!(
            "the Inverse Service at {address} is version {version}; frictionlab speaks the protocol of version {}.{} and later",
            SERVICE_VERSION.0, SERVICE_VERSION.1
        ));
    }
    let (mut ws, device_id, device_config) = connect(&address, &config.device_id, wait)
        .map_err(|e| format!("the Inverse Service at {address} {e}"))?;
    ws.send(tungstenite::Message::text(
        serde_json::to_string(&messages::force(&device_id, [0.0; 3], Some(PROFILE)))
            .unwrap_or_default(),
    ))
    .map_err(|e| format!("the Inverse Service at {address}: {e}"))?;
    let no_state = || format!("the Inverse Service at {address} sent no state for {device_id}");
    let frame = read_frame(&mut ws).ok_or_else(no_state)?;
    let seen = frame.frictionlab_state;
    let state = frame
        .inverse3
        .into_iter()
        .find(|d| d.device_id == device_id)
        .ok_or_else(no_state)?;
    let p = state.state.cursor_position.unwrap_or_default().array();
    let o = config.track.origin_m;
    let off = ((p[0] - o[0]).powi(2) + (p[1] - o[1]).powi(2) + (p[2] - o[2]).powi(2)).sqrt();
    if off > config.workspace_radius_m {
        return Err(format!(
            "the hand is not in the workspace: the cursor is at ({:.3}, {:.3}, {:.3}) m, {off:.3} m from the track's origin (a session starts within {} m)",
            p[0], p[1], p[2], config.workspace_radius_m
        ));
    }
    ws.get_mut()
        .set_nonblocking(true)
        .map_err(|e| e.to_string())?;
    Ok(Box::new(Inverse3 {
        settings: serde_json::json!({
            "service_version": version,
            "address": address,
            "device_id": device_id,
            "device_config": device_config,
            "track": config.track,
            "force_limit_n": config.force_limit_n,
        }),
        config,
        address,
        device_id,
        ws: Some(ws),
        position: p,
        last_frame_s: None,
        tried_s: f64::NEG_INFINITY,
        hand: None,
        frames: 0,
        seen,
    }))
}

/// An Inverse3 through the service.
pub struct Inverse3 {
    config: Config,
    settings: serde_json::Value,
    address: String,
    device_id: String,
    ws: Option<Socket>,
    position: [f64; 3],
    last_frame_s: Option<f64>,
    tried_s: f64,
    hand: Option<HandDrive>,
    frames: u64,
    /// The newest state frame's number, where the service numbers them (our
    /// emulator in lockstep): each message echoes it.
    seen: Option<u64>,
}

impl Inverse3 {
    fn send(&mut self, force: [f64; 3]) {
        let mut m = messages::force(&self.device_id, force, None);
        m.frictionlab_hand = self.hand.take();
        m.frictionlab_state = self.seen;
        let Some(ws) = self.ws.as_mut() else {
            return;
        };
        let text = serde_json::to_string(&m).unwrap_or_default();
        match ws.send(tungstenite::Message::text(text)) {
            Ok(()) => {}
            Err(tungstenite::Error::Io(e)) if e.kind() == ErrorKind::WouldBlock => {}
            Err(_) => self.ws = None,
        }
    }
}

impl Backend for Inverse3 {
    fn capabilities(&self) -> Capabilities {
        Capabilities {
            axes: 3,
            vertical_axis: Some(2),
            force_limit_n: self.config.force_limit_n,
            travel_m: [
                -self.config.workspace_radius_m,
                self.config.workspace_radius_m,
            ],
            max_rate_hz: RATE_HZ,
            on_board: false,
        }
    }

    fn read(&mut self, now_s: f64) -> Reading {
        if self.ws.is_none() && now_s - self.tried_s >= RECONNECT_EVERY_S {
            self.tried_s = now_s;
            if let Ok((mut ws, id, _)) =
                connect(&self.address, &self.device_id, Duration::from_millis(50))
                && ws.get_mut().set_nonblocking(true).is_ok()
            {
                self.device_id = id;
                self.ws = Some(ws);
                self.seen = None;
            }
        }
        while let Some(ws) = self.ws.as_mut() {
            match ws.read() {
                Ok(tungstenite::Message::Text(t)) => {
                    if let Ok(f) = serde_json::from_str::<ServiceFrame>(t.as_str())
                        && let Some(d) = f.inverse3.iter().find(|d| d.device_id == self.device_id)
                        && let Some(p) = d.state.cursor_position
                    {
                        self.position = p.array();
                        self.last_frame_s = Some(now_s);
                        self.frames += 1;
                        self.seen = f.frictionlab_state;
                    }
                }
                Ok(_) => {}
                Err(tungstenite::Error::Io(e)) if e.kind() == ErrorKind::WouldBlock => break,
                Err(_) => self.ws = None,
            }
        }
        let link = match self.last_frame_s {
            Some(t) if self.ws.is_some() && now_s - t <= LOST_AFTER_S => LinkState::Connected,
            Some(_) => LinkState::Lost,
            None => LinkState::Connecting,
        };
        Reading {
            link,
            position_m: self.position,
            button: false,
            watchdog: false,
            problem: None,
        }
    }

    fn send_force(&mut self, _now_s: f64, force_n: Vector, _vibration: f64) {
        let f = if force_n.iter().all(|f| f.is_finite()) {
            force_n
        } else {
            [0.0; 3]
        };
        self.send(f);
    }

    fn close(&mut self) {
        self.send([0.0; 3]);
        if let Some(mut ws) = self.ws.take() {
            let _ = ws.get_mut().set_nonblocking(false);
            let _ = ws.close(None);
            let _ = ws.flush();
        }
    }

    fn drive_hand(&mut self, drive: &HandDrive) {
        self.hand = Some(*drive);
    }

    fn track(&self) -> Track {
        self.config.track
    }

    fn settings(&self) -> Option<serde_json::Value> {
        Some(self.settings.clone())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn addresses_and_versions_read_as_documented() {
        assert_eq!(address("").unwrap(), DEFAULT_ADDRESS);
        assert_eq!(address("ws://localhost:10001/").unwrap(), "localhost:10001");
        assert!(address("localhost").unwrap_err().contains("HOST:PORT"));
        assert!(speaks("3.5.0") && speaks("v3.6.1-rc") && speaks("4.0"));
        assert!(!speaks("3.1.1") && !speaks("garbage"));
    }
}
