//! Haptic devices. [`sim`] is the simulated apparatus of seed 002, stepped in
//! virtual time. [`wire`] is the serial wire protocol (frames, sans-IO
//! decoder), [`link`] its host side (sans-IO), [`transport`] the serial port
//! that carries it, and [`emulator`] firmware for the simulated apparatus
//! that speaks it.

pub mod emulator;
pub mod haptic;
pub mod link;
pub mod qemu;
pub mod sim;
pub mod transport;
pub mod wire;

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
fn not_a_port(meta: &std::fs::Metadata) -> Option<&'static str> {
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
