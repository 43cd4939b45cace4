//! Haptic devices. [`sim`] is the simulated apparatus of seed 002, stepped in
//! virtual time. A real device (or an emulated one) is a [`backend::Backend`]
//! that the haptic loop ([`haptic`]) drives, rendering friction along a
//! [`track::Track`]. Each kind of device is one folder, listed once in
//! [`KINDS`]: [`frictionlab`] (our own board and wire protocol),
//! [`haply2diy`] (the Haply 2DIY), [`inverse3`] (the Haply Inverse3).

pub mod backend;
pub mod check;
pub mod frictionlab;
pub mod hand_link;
pub mod haply2diy;
pub mod haptic;
pub mod inverse3;
#[cfg(test)]
mod loopback;
pub mod miswiring;
pub mod pty;
pub use crate::realtime;
pub mod sim;
pub mod stepped;
pub mod track;
pub mod transport;

pub use backend::LinkState;

/// A kind of device the loop can drive: how `--device` names it, and how
/// to find, check and open one.
#[derive(Debug)]
pub struct Kind {
    /// Its name, the prefix of its `--device` spelling (`haply2diy:PATH`).
    pub name: &'static str,
    /// What it is, for `frictionlab ports` and `--help`.
    pub about: &'static str,
    /// What follows the prefix (`PATH`, `[URL]`).
    pub target: &'static str,
    /// A bare target (no prefix) is this kind.
    pub bare: bool,
    /// Checks a target without opening it (nothing is touched).
    pub check: fn(&str) -> Result<(), String>,
    /// Checks `--device-set` settings without opening anything.
    pub check_settings: fn(&[String]) -> Result<(), String>,
    /// Opens the device at a target, with the `--device-set` settings.
    pub open: Opener,
    /// The devices of this kind the machine has now.
    pub find: fn() -> Vec<Found>,
}

/// How a [`Kind`] opens a device at a target with its settings.
pub type Opener = fn(&str, &Settings) -> Result<Box<dyn backend::Backend>, String>;

/// The kinds of device, in the order `frictionlab ports` lists them.
pub const KINDS: &[&Kind] = &[
    &frictionlab::KIND,
    &haply2diy::KIND,
    &inverse3::KIND,
    #[cfg(test)]
    &loopback::KIND,
];

/// A device found on the machine.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Found {
    /// How `--device` names it (without the kind's prefix).
    pub address: String,
    /// What it looks like (`usb 2341:003d Arduino Due`).
    pub what: String,
}

/// A device's settings from the command line: `NAME=VALUE` pairs, each
/// kind applying those of its own settings.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Settings {
    /// The pairs, in order.
    pub set: Vec<String>,
}

/// A device as `--device` names it: a kind and its target.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Address {
    /// The kind's name ([`Kind::name`]).
    pub kind: &'static str,
    /// Its target (a path, a URL; may be empty).
    pub target: String,
    /// Its settings (`--device-set`).
    pub settings: Settings,
}

impl Address {
    /// Reads `KIND:TARGET`, or a bare target of the bare kind (a path).
    ///
    /// # Errors
    /// An empty spelling.
    pub fn parse(text: &str) -> Result<Self, String> {
        if text.is_empty() {
            return Err("empty device".into());
        }
        for kind in KINDS {
            if let Some(rest) = text.strip_prefix(kind.name) {
                if rest.is_empty() {
                    return Ok(Address {
                        kind: kind.name,
                        target: String::new(),
                        settings: Settings::default(),
                    });
                }
                if let Some(target) = rest.strip_prefix(':') {
                    return Ok(Address {
                        kind: kind.name,
                        target: target.to_owned(),
                        settings: Settings::default(),
                    });
                }
            }
        }
        let bare = KINDS.iter().find(|k| k.bare).map_or("", |k| k.name);
        Ok(Address {
            kind: bare,
            target: text.to_owned(),
            settings: Settings::default(),
        })
    }

    /// Its kind.
    #[must_use]
    pub fn kind(&self) -> &'static Kind {
        KINDS
            .iter()
            .find(|k| k.name == self.kind)
            .copied()
            .unwrap_or(KINDS[0])
    }

    /// Checks the target without opening it.
    ///
    /// # Errors
    /// What is wrong, for `error: --device: <address>: <what>`.
    pub fn check(&self) -> Result<(), String> {
        (self.kind().check)(&self.target)
    }

    /// Checks its settings without opening the device.
    ///
    /// # Errors
    /// What is wrong, for `error: --device-set: <what>`.
    pub fn check_settings(&self) -> Result<(), String> {
        (self.kind().check_settings)(&self.settings.set)
    }

    /// Opens the device.
    ///
    /// # Errors
    /// What is wrong, for `error: --device: <address>: <what>`.
    pub fn open(&self) -> Result<Box<dyn backend::Backend>, String> {
        (self.kind().open)(&self.target, &self.settings)
    }

    /// The address of our own board at `path`.
    #[must_use]
    pub fn port(path: &std::path::Path) -> Self {
        Address {
            kind: frictionlab::KIND.name,
            target: path.display().to_string(),
            settings: Settings::default(),
        }
    }
}

impl std::fmt::Display for Address {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.kind().bare {
            f.write_str(&self.target)
        } else if self.target.is_empty() {
            f.write_str(self.kind)
        } else {
            write!(f, "{}:{}", self.kind, self.target)
        }
    }
}

/// Every device of every kind the machine has now, with its kind.
#[must_use]
pub fn find_all() -> Vec<(&'static Kind, Found)> {
    KINDS
        .iter()
        .flat_map(|k| (k.find)().into_iter().map(move |f| (*k, f)))
        .collect()
}

/// A serial port that may carry a haptic device.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PortInfo {
    /// Its path (`/dev/ttyACM0`, `COM3`).
    pub path: String,
    /// `usb VID:PID product`, `pci`, `bluetooth` or `unknown`.
    pub kind: String,
}

/// Lists the serial ports (without opening any).
///
/// # Errors
/// The system's port list cannot be read.
pub fn list_ports() -> Result<Vec<PortInfo>, String> {
    let ports = serialport::available_ports().map_err(|e| e.to_string())?;
    Ok(ports
        .into_iter()
        .map(|p| PortInfo {
            kind: match p.port_type {
                serialport::SerialPortType::UsbPort(u) => format!(
                    "usb {:04x}:{:04x} {}",
                    u.vid,
                    u.pid,
                    u.product.unwrap_or_default()
                ),
                serialport::SerialPortType::PciPort => "pci".into(),
                serialport::SerialPortType::BluetoothPort => "bluetooth".into(),
                serialport::SerialPortType::Unknown => "unknown".into(),
            },
            path: p.port_name,
        })
        .collect())
}

/// Checks that `path` can be a serial port (it exists and is a character
/// device, following links) without opening it: opening a port toggles
/// its control lines, which resets some boards.
///
/// # Errors
/// What is wrong, for `error: --device: <path>: <what>`.
pub fn check_port(path: &std::path::Path) -> Result<(), String> {
    let meta = std::fs::metadata(path).map_err(|_| {
        "no such serial port (frictionlab ports lists them; 'sim' is the simulated device)"
            .to_owned()
    })?;
    match not_a_port(&meta) {
        None => Ok(()),
        Some(what) => Err(format!(
            "{what}, not a serial port (frictionlab ports lists them; 'sim' is the simulated device)"
        )),
    }
}

/// What a file is if it cannot be a serial port (`a directory`, ...); `None`
/// for a character device.
pub(crate) fn not_a_port(meta: &std::fs::Metadata) -> Option<&'static str> {
    use std::os::unix::fs::FileTypeExt as _;
    if meta.file_type().is_char_device() {
        None
    } else if meta.is_dir() {
        Some("a directory")
    } else if meta.is_file() {
        Some("a regular file")
    } else {
        Some("not a character device")
    }
}

pub use frictionlab_core::plant::DeviceSample;
