//! The desktop's file and folder choosers (the `rfd` crate, through the
//! XDG desktop portal), beside the typed paths, which stay: a machine
//! with no portal (a bare X server, a remote shell) answers no path, and
//! the experimenter types it.

use std::path::{Path, PathBuf};

/// What is chosen.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Choose {
    /// An existing protocol file.
    Protocol,
    /// Where to save a protocol.
    SaveProtocol,
    /// A results folder.
    Folder,
}

/// Asks the desktop for a path, starting beside `typed` (the path in the
/// field, if any). `Err` says why none came back, for the window to show.
pub(super) fn choose(what: Choose, typed: &str) -> Result<PathBuf, String> {
    let typed = Path::new(typed.trim());
    let dir = if typed.is_dir() {
        Some(typed.to_path_buf())
    } else {
        typed.parent().filter(|p| p.is_dir()).map(Path::to_path_buf)
    };
    let mut dialog = rfd::FileDialog::new();
    if let Some(dir) = dir {
        dialog = dialog.set_directory(dir);
    }
    // An existing file or folder typed in is where the chooser opens, with
    // it selected (zenity takes the path itself; the portal, the folder).
    if matches!(what, Choose::Protocol | Choose::Folder) && typed.exists() {
        let absolute = std::path::absolute(typed).unwrap_or_else(|_| typed.to_path_buf());
        let mut name = absolute.display().to_string();
        if absolute.is_dir() && !name.ends_with('/') {
            name.push('/');
        }
        dialog = dialog.set_file_name(name);
    }
    let protocols = |d: rfd::FileDialog| d.add_filter("protocol (JSON)", &["json"]);
    let chosen = match what {
        Choose::Protocol => protocols(dialog).set_title("Open a protocol").pick_file(),
        Choose::SaveProtocol => {
            let name = typed.file_name().map(|n| n.to_string_lossy().into_owned());
            let d = protocols(dialog).set_title("Save the protocol as");
            match name {
                Some(n) => d.set_file_name(n),
                None => d,
            }
            .save_file()
        }
        Choose::Folder => dialog.set_title("Results folder").pick_folder(),
    };
    chosen.ok_or_else(|| {
        "no path chosen (cancelled, or no desktop file chooser here: type the path)".to_owned()
    })
}
