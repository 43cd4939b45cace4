//! Bring-up check reports kept with the results (issue 63):
//! `DIR/device-checks/<device>_<time>.json`, each written whole and never
//! over another ([`write`]), and the last check of a device in a folder
//! ([`last`]), which a new session's header names.

use std::io::Write as _;
use std::path::{Path, PathBuf};

use super::{ResultsDir, ResultsError, io_err};

/// The folder the reports are kept in, under the results folder.
pub const FOLDER: &str = "device-checks";

/// A check a session's header names: the last one made on its device in
/// the results folder when the session began.
#[derive(
    Debug, Clone, PartialEq, Eq, serde::Serialize, serde::Deserialize, schemars::JsonSchema,
)]
pub struct DeviceCheckRef {
    /// The report, relative to the results folder.
    pub file: String,
    /// When the check was made, UTC (RFC 3339).
    pub time_utc: String,
    /// Whether every step passed.
    pub passed: bool,
}

/// What [`last`] reads of a report.
#[derive(serde::Deserialize)]
struct Stamp {
    device: String,
    time_utc: String,
    passed: bool,
}

/// A device's name as a file name's part: letters and digits kept, every
/// run of anything else one `-`.
fn file_part(text: &str) -> String {
    let mut out = String::new();
    for c in text.chars() {
        if c.is_ascii_alphanumeric() {
            out.push(c);
        } else if !out.ends_with('-') {
            out.push('-');
        }
    }
    let out = out.trim_matches('-');
    if out.is_empty() {
        "device".to_owned()
    } else {
        out.to_owned()
    }
}

/// Writes `report` (JSON) of a check on `device` at `time_utc` (RFC 3339)
/// as `DIR/device-checks/<device>_<time>.json`: written to a temporary,
/// synced, then linked in under a name no file has (`_2`, `_3`, ... after
/// the time when one has), so no report is ever overwritten or seen half
/// written. Returns its path.
///
/// # Errors
/// The folder or the file cannot be written.
pub fn write(
    dir: &ResultsDir,
    device: &str,
    time_utc: &str,
    report: &[u8],
) -> Result<PathBuf, ResultsError> {
    let folder = dir.root().join(FOLDER);
    std::fs::create_dir_all(&folder).map_err(io_err(&folder))?;
    let stamp: String = time_utc
        .chars()
        .filter(|c| *c != '-' && *c != ':')
        .collect();
    let stem = format!("{}_{}", file_part(device), file_part(&stamp));
    let tmp = folder.join(format!(".{stem}.{}.partial", std::process::id()));
    let written = (|| {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(report)?;
        f.sync_all()
    })();
    if let Err(e) = written {
        let _ = std::fs::remove_file(&tmp);
        return Err(io_err(&tmp)(e));
    }
    let mut n = 1_u32;
    let result = loop {
        let name = if n == 1 {
            format!("{stem}.json")
        } else {
            format!("{stem}_{n}.json")
        };
        let path = folder.join(name);
        match std::fs::hard_link(&tmp, &path) {
            Ok(()) => break Ok(path),
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists && n < 1000 => n += 1,
            Err(e) => break Err(io_err(&path)(e)),
        }
    };
    let _ = std::fs::remove_file(&tmp);
    if result.is_ok()
        && let Ok(d) = std::fs::File::open(&folder)
    {
        let _ = d.sync_all();
    }
    result
}

/// The last check made on `device` (as `--device` names it) in the results
/// folder: the report with the latest time (then the last name), or None.
/// Reports that do not read are passed over.
#[must_use]
pub fn last(dir: &ResultsDir, device: &str) -> Option<DeviceCheckRef> {
    let folder = dir.root().join(FOLDER);
    let mut best: Option<(String, String, bool)> = None;
    for entry in std::fs::read_dir(&folder).ok()?.filter_map(Result::ok) {
        let name = entry.file_name().to_string_lossy().into_owned();
        let json = Path::new(&name)
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("json"));
        if name.starts_with('.') || !json {
            continue;
        }
        let Some(stamp) = read_stamp(&entry.path()) else {
            continue;
        };
        if stamp.device != device {
            continue;
        }
        let key = (stamp.time_utc.clone(), name.clone());
        if best
            .as_ref()
            .is_none_or(|(t, n, _)| key > (t.clone(), n.clone()))
        {
            best = Some((stamp.time_utc, name, stamp.passed));
        }
    }
    best.map(|(time_utc, name, passed)| DeviceCheckRef {
        file: format!("{FOLDER}/{name}"),
        time_utc,
        passed,
    })
}

fn read_stamp(path: &Path) -> Option<Stamp> {
    let bytes = std::fs::read(path).ok()?;
    serde_json::from_slice(&bytes).ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reports_are_never_overwritten_and_the_last_of_the_device_is_found() {
        let tmp = tempfile::tempdir().unwrap();
        let dir = ResultsDir::new(tmp.path());
        assert_eq!(last(&dir, "haply2diy:/dev/ttyACM0"), None);
        let put = |device: &str, time: &str, passed: bool| {
            let report = serde_json::json!({"device": device, "time_utc": time, "passed": passed});
            write(&dir, device, time, report.to_string().as_bytes()).unwrap()
        };
        let a = put("haply2diy:/dev/ttyACM0", "2026-12-01T10:00:00Z", false);
        assert!(a.ends_with("device-checks/haply2diy-dev-ttyACM0_20261201T100000Z.json"));
        let b = put("haply2diy:/dev/ttyACM0", "2026-12-01T10:00:00Z", true);
        assert_ne!(a, b, "the same second gets another name");
        put("sim", "2026-12-02T10:00:00Z", true);
        let found = last(&dir, "haply2diy:/dev/ttyACM0").unwrap();
        assert_eq!(
            found.file,
            "device-checks/haply2diy-dev-ttyACM0_20261201T100000Z_2.json"
        );
        assert!(found.passed);
        assert!(
            std::fs::read_to_string(&a).unwrap().contains("false"),
            "the first kept"
        );
    }
}
