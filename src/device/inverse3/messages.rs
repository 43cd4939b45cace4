//! The Inverse Service's WebSocket messages we send and read (service 3.5,
//! docs.haply.co: websocket protocol, control commands, JSON conventions),
//! in the shapes of the vendor's `haply` crate 1.3.1 (`ServiceMsg`,
//! `ServiceData`, `ServiceState`): `crates/haply-peer` parses every message
//! our driver and our emulated service send with the crate's own types.
//!
//! Client to service: `{"session": {...}, "inverse3": [{"device_id": ...,
//! "commands": {"set_cursor_force": {"vector": {"x","y","z"}}}}],
//! "verse_grip": [], "wireless_verse_grip": []}`; the service answers
//! every message with one state frame; the first frame after connecting is
//! the inventory, each device with its `config`.

use serde::{Deserialize, Serialize};

/// A vector in metres, metres per second or newtons.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Vec3 {
    /// x.
    pub x: f64,
    /// y.
    pub y: f64,
    /// z.
    pub z: f64,
}

impl Vec3 {
    /// As an array.
    #[must_use]
    pub fn array(&self) -> [f64; 3] {
        [self.x, self.y, self.z]
    }

    /// From an array.
    #[must_use]
    pub fn of(v: [f64; 3]) -> Self {
        Vec3 {
            x: v[0],
            y: v[1],
            z: v[2],
        }
    }
}

/// An empty object (`{}`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct Empty {}

/// A message to the service.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct ClientMessage {
    /// Session-wide settings and requests (always present, may be empty).
    pub session: SessionPart,
    /// Per device.
    #[serde(default)]
    pub inverse3: Vec<DeviceMessage>,
    /// None here (the crate's message has the key).
    #[serde(default)]
    pub verse_grip: Vec<serde_json::Value>,
    /// None here (the crate's message has the key).
    #[serde(default)]
    pub wireless_verse_grip: Vec<serde_json::Value>,
    /// The hand of an emulated service's simulated participant (a key the
    /// real service ignores, as every key it does not know; sent only
    /// when a simulated participant drives the hand).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub frictionlab_hand: Option<crate::hand::HandDrive>,
    /// The `frictionlab_state` of the newest state frame read when the
    /// message was computed, echoed (sent only to a service whose frames
    /// carry one: our emulator in lockstep; a key the real service ignores).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub frictionlab_state: Option<u64>,
}

/// The `session` part of a message to the service.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct SessionPart {
    /// Asks for a frame with every device's `config`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub force_render_full_state: Option<Empty>,
    /// The session's settings.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub configure: Option<SessionConfigure>,
}

/// `session.configure`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct SessionConfigure {
    /// The session's profile.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub profile: Option<Profile>,
}

/// `session.configure.profile`.
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct Profile {
    /// Its name.
    pub name: String,
}

/// A device's part of a message to the service.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct DeviceMessage {
    /// The device.
    pub device_id: String,
    /// This tick's commands.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub commands: Option<Commands>,
}

/// A device's commands for a tick (applied once, then forgotten).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Commands {
    /// The force on the cursor, N.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub set_cursor_force: Option<SetCursorForce>,
}

/// `set_cursor_force`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct SetCursorForce {
    /// The force, N.
    pub vector: Vec3,
}

/// A frame from the service: the inventory (each device with `config`)
/// or a state update.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct ServiceFrame {
    /// The session's number.
    #[serde(default)]
    pub session_id: u64,
    /// The Inverse3s.
    #[serde(default)]
    pub inverse3: Vec<DeviceFrame>,
    /// Our emulator in lockstep numbers the states it sends: the host
    /// periods its physics has run (a key the real service does not send).
    /// A client that echoes it tells the emulator which state each message
    /// was computed on.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub frictionlab_state: Option<u64>,
}

/// One Inverse3 in a frame.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct DeviceFrame {
    /// Its id.
    pub device_id: String,
    /// Its configuration (the inventory, or a full-state frame).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub config: Option<serde_json::Value>,
    /// Its state.
    pub state: State,
    /// Its status.
    pub status: Status,
}

/// A device's state (what we read of it; other keys are kept).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct State {
    /// The cursor (the handle's tip), m.
    #[serde(default)]
    pub cursor_position: Option<Vec3>,
    /// Its velocity, m/s.
    #[serde(default)]
    pub cursor_velocity: Option<Vec3>,
    /// The force the device renders now, N.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub current_cursor_force: Option<Vec3>,
    /// `idle`, `position` or `angular`.
    pub mode: String,
}

/// A device's status.
#[expect(clippy::struct_excessive_bools, reason = "the service's flags")]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct Status {
    /// Calibrated.
    pub calibrated: bool,
    /// In use by a session.
    pub in_use: bool,
    /// Powered.
    pub power_supply: bool,
    /// Ready.
    pub ready: bool,
    /// Started.
    pub started: bool,
}

/// A message that sends `force` to `device_id` (and, the first time, the
/// session's profile).
#[must_use]
pub fn force(device_id: &str, force_n: [f64; 3], profile: Option<&str>) -> ClientMessage {
    ClientMessage {
        session: SessionPart {
            force_render_full_state: None,
            configure: profile.map(|name| SessionConfigure {
                profile: Some(Profile { name: name.into() }),
            }),
        },
        inverse3: vec![DeviceMessage {
            device_id: device_id.into(),
            commands: Some(Commands {
                set_cursor_force: Some(SetCursorForce {
                    vector: Vec3::of(force_n),
                }),
            }),
        }],
        verse_grip: Vec::new(),
        wireless_verse_grip: Vec::new(),
        frictionlab_hand: None,
        frictionlab_state: None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The control-commands page's example reads as a force command.
    #[test]
    fn the_documented_force_command_reads() {
        let text = r#"{"inverse3":[{"device_id":"049D","commands":{"set_cursor_force":{"vector":{"x":0.0,"y":0.0,"z":1.5}}}}],"session":{}}"#;
        let m: ClientMessage = serde_json::from_str(text).unwrap();
        let f = m.inverse3[0].commands.unwrap().set_cursor_force.unwrap();
        assert_eq!(f.vector.array(), [0.0, 0.0, 1.5]);
        let ours =
            serde_json::to_value(force("049D", [0.0, 0.0, 1.5], Some("frictionlab"))).unwrap();
        assert_eq!(
            ours["session"]["configure"]["profile"]["name"],
            "frictionlab"
        );
        assert_eq!(
            ours["inverse3"][0]["commands"]["set_cursor_force"]["vector"]["z"],
            1.5
        );
    }
}
