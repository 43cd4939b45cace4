//! frictionlab's outlets on the Lab Streaming Layer (LSL).
//!
//! liblsl, the reference implementation, is loaded at run time with
//! `libloading`, as pylsl loads it: nothing about LSL is needed to build
//! frictionlab, and nobody who does not stream needs the library.
//! [`Lsl::load`] finds it (an explicit path, then the usual library names),
//! checks its version ([`MIN_VERSION`]) and resolves the few C functions an
//! outlet needs; [`Lsl::outlet`] publishes a stream with its description
//! (LSL's meta-data conventions: `desc/channels/channel/{label,unit,type}`).
//!
//! Only `ffi` holds unsafe code: each call there is a liblsl C function
//! with the argument types of `lsl_c.h`, on pointers liblsl made and this
//! crate owns until it destroys them.

use std::path::{Path, PathBuf};
use std::sync::Arc;

mod ffi;

/// The oldest liblsl accepted: 1.14 (`lsl_library_version` 114). Chosen,
/// not measured: every function called here has the same C signature in
/// all 1.x releases, 1.14 (2020) is the first of the releases still
/// published on liblsl's release page, and the tests run 1.18 (the one
/// pylsl ships). Older ones are refused rather than trusted untested.
pub const MIN_VERSION: i32 = 114;

/// liblsl's default buffer of an outlet, s (what pylsl asks for).
const MAX_BUFFERED_S: i32 = 360;

/// Why liblsl could not be used.
#[derive(Debug, thiserror::Error)]
pub enum LoadError {
    /// No candidate could be opened.
    #[error(
        "liblsl not found (tried {}); install it: `python3 -m pip install pylsl` ships it as \
         <site-packages>/pylsl/lib/liblsl.so (give that path to --lsl-lib or FRICTIONLAB_LSL_LIB), \
         or take a release from https://github.com/sccn/liblsl/releases",
        tried.join("; ")
    )]
    NotFound {
        /// Each candidate and why it failed.
        tried: Vec<String>,
    },
    /// The library opened but is older than [`MIN_VERSION`].
    #[error("{path}: liblsl {major}.{minor} is too old: frictionlab needs {}.{} or newer", MIN_VERSION / 100, MIN_VERSION % 100)]
    TooOld {
        /// The library.
        path: String,
        /// Its major version.
        major: i32,
        /// Its minor version.
        minor: i32,
    },
    /// The library lacks a function an outlet needs.
    #[error("{path}: not a usable liblsl: it has no `{symbol}`")]
    Missing {
        /// The library.
        path: String,
        /// The missing function.
        symbol: String,
    },
}

/// Why a stream could not be published.
#[derive(Debug, thiserror::Error)]
pub enum OutletError {
    /// liblsl returned no stream info or outlet.
    #[error("liblsl could not create the {0} stream")]
    Create(String),
}

/// Where the library was looked for, in order: `explicit` (`--lsl-lib`),
/// then `env` (`FRICTIONLAB_LSL_LIB`), then the usual names, which the
/// system's loader searches for (`LD_LIBRARY_PATH`, the system's library
/// folders). A path given explicitly is the only candidate: a typo is not
/// hidden by another library found elsewhere.
#[must_use]
pub fn candidates(explicit: Option<&Path>, env: Option<&Path>) -> Vec<(String, PathBuf)> {
    if let Some(path) = explicit {
        return vec![("--lsl-lib".into(), path.to_path_buf())];
    }
    if let Some(path) = env {
        return vec![("FRICTIONLAB_LSL_LIB".into(), path.to_path_buf())];
    }
    let names: &[&str] = if cfg!(target_os = "windows") {
        &["lsl.dll", "liblsl64.dll", "liblsl32.dll"]
    } else if cfg!(target_os = "macos") {
        &["liblsl.dylib", "liblsl.2.dylib", "liblsl64.dylib"]
    } else {
        &["liblsl.so", "liblsl.so.2", "liblsl64.so"]
    };
    names
        .iter()
        .map(|n| ("system".to_owned(), PathBuf::from(n)))
        .collect()
}

/// liblsl logs at level INFO to stderr by default (two lines per run:
/// its configuration and build). Without a configuration of the user's
/// own (`LSLAPICFG`, `./lsl_api.cfg`, `~/lsl_api/lsl_api.cfg`,
/// `/etc/lsl_api/lsl_api.cfg`, which liblsl reads as always), it logs
/// warnings and errors only.
fn quiet(api: &ffi::Api) {
    let home = std::env::var_os("HOME").map(PathBuf::from);
    let own = std::env::var_os("LSLAPICFG").is_some()
        || Path::new("lsl_api.cfg").exists()
        || home.is_some_and(|h| h.join("lsl_api/lsl_api.cfg").exists())
        || Path::new("/etc/lsl_api/lsl_api.cfg").exists();
    if !own {
        let _ = api.set_config("[log]\nlevel = -1\n");
    }
}

/// The loaded library.
pub struct Lsl {
    api: ffi::Api,
    path: String,
    version: i32,
}

impl std::fmt::Debug for Lsl {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Lsl")
            .field("path", &self.path)
            .field("version", &self.version)
            .finish_non_exhaustive()
    }
}

impl Lsl {
    /// Opens the first of `candidates` that loads, checks its version and
    /// resolves the functions an outlet needs.
    ///
    /// # Errors
    /// None loads ([`LoadError::NotFound`], naming each and why), or the
    /// one that loads is too old or lacks a function.
    pub fn load(candidates: &[(String, PathBuf)]) -> Result<Arc<Lsl>, LoadError> {
        let mut tried = Vec::new();
        for (from, path) in candidates {
            let shown = path.display().to_string();
            match ffi::Api::open(path, MIN_VERSION) {
                Ok(api) => {
                    quiet(&api);
                    let version = api.library_version();
                    return Ok(Arc::new(Lsl {
                        api,
                        path: shown,
                        version,
                    }));
                }
                Err(ffi::OpenError::Load(why)) => tried.push(format!("{shown} ({from}): {why}")),
                Err(ffi::OpenError::TooOld(version)) => {
                    return Err(LoadError::TooOld {
                        path: shown,
                        major: version / 100,
                        minor: version % 100,
                    });
                }
                Err(ffi::OpenError::Missing(symbol)) => {
                    return Err(LoadError::Missing {
                        path: shown,
                        symbol,
                    });
                }
            }
        }
        Err(LoadError::NotFound { tried })
    }

    /// The library's file.
    #[must_use]
    pub fn path(&self) -> &str {
        &self.path
    }

    /// Its version, as `lsl_library_version` gives it (118 for 1.18).
    #[must_use]
    pub fn version(&self) -> i32 {
        self.version
    }

    /// LSL's clock (`lsl_local_clock`), s: the clock every stream's
    /// timestamps are on. On Linux it is `CLOCK_MONOTONIC`, the clock of
    /// Rust's `Instant`.
    #[must_use]
    pub fn local_clock(&self) -> f64 {
        self.api.local_clock()
    }

    /// Publishes a stream described by `spec`, its `desc` element holding
    /// `desc` (LSL's meta-data: `channels`, `acquisition`, ...).
    ///
    /// # Errors
    /// liblsl returned no stream info or outlet.
    pub fn outlet(
        self: &Arc<Self>,
        spec: &StreamSpec<'_>,
        desc: &[Node],
    ) -> Result<Outlet, OutletError> {
        let raw = self
            .api
            .outlet(spec, desc, MAX_BUFFERED_S)
            .ok_or_else(|| OutletError::Create(spec.name.to_owned()))?;
        Ok(Outlet {
            lsl: self.clone(),
            raw,
            channels: spec.channels,
        })
    }
}

/// A stream's channel format.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    /// `cft_float32`.
    Float32,
    /// `cft_string`.
    String,
}

/// What a stream is (LSL's `stream_info`).
#[derive(Debug, Clone, Copy)]
pub struct StreamSpec<'a> {
    /// Its name.
    pub name: &'a str,
    /// Its content type (`Markers`, `EEG`, ...).
    pub kind: &'a str,
    /// Channels per sample.
    pub channels: usize,
    /// Nominal rate, Hz (0: irregular).
    pub rate_hz: f64,
    /// Channel format.
    pub format: Format,
    /// A unique id of the source, stable across restarts, so recorders
    /// reconnect to it.
    pub source_id: &'a str,
}

/// An element of a stream's description.
#[derive(Debug, Clone, PartialEq)]
pub struct Node {
    /// The element's name.
    pub name: String,
    /// Its text, or its children.
    pub content: Content,
}

/// What an element holds.
#[derive(Debug, Clone, PartialEq)]
pub enum Content {
    /// A text value.
    Value(String),
    /// Child elements.
    Children(Vec<Node>),
}

impl Node {
    /// An element holding text.
    #[must_use]
    pub fn value(name: &str, value: impl Into<String>) -> Self {
        Node {
            name: name.to_owned(),
            content: Content::Value(value.into()),
        }
    }

    /// An element holding elements.
    #[must_use]
    pub fn parent(name: &str, children: Vec<Node>) -> Self {
        Node {
            name: name.to_owned(),
            content: Content::Children(children),
        }
    }
}

/// A published stream; dropping it ends the stream.
pub struct Outlet {
    lsl: Arc<Lsl>,
    raw: ffi::RawOutlet,
    channels: usize,
}

impl std::fmt::Debug for Outlet {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Outlet")
            .field("channels", &self.channels)
            .finish_non_exhaustive()
    }
}

impl Outlet {
    /// Pushes one float sample stamped `timestamp_s` (LSL's clock).
    /// A sample of the wrong length is not pushed (returns false).
    #[must_use]
    pub fn push_f32(&self, sample: &[f32], timestamp_s: f64) -> bool {
        sample.len() == self.channels && self.lsl.api.push_f32(&self.raw, sample, timestamp_s)
    }

    /// Pushes one string sample (one channel) stamped `timestamp_s`. A NUL
    /// in the text (which C strings cannot hold) is sent as a space.
    #[must_use]
    pub fn push_str(&self, text: &str, timestamp_s: f64) -> bool {
        self.channels == 1 && self.lsl.api.push_str(&self.raw, text, timestamp_s)
    }

    /// Waits until some inlet is connected, at most `timeout_s`; whether
    /// one is.
    #[must_use]
    pub fn wait_for_consumers(&self, timeout_s: f64) -> bool {
        self.lsl.api.wait_for_consumers(&self.raw, timeout_s)
    }

    /// Whether some inlet is connected.
    #[must_use]
    pub fn has_consumers(&self) -> bool {
        self.lsl.api.have_consumers(&self.raw)
    }
}

impl Drop for Outlet {
    fn drop(&mut self) {
        self.lsl.api.destroy_outlet(&self.raw);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_explicit_path_is_the_only_candidate() {
        let c = candidates(Some(Path::new("/x/liblsl.so")), Some(Path::new("/y")));
        assert_eq!(c, vec![("--lsl-lib".into(), PathBuf::from("/x/liblsl.so"))]);
        let c = candidates(None, Some(Path::new("/y/liblsl.so")));
        assert_eq!(
            c,
            vec![("FRICTIONLAB_LSL_LIB".into(), PathBuf::from("/y/liblsl.so"))]
        );
        assert!(candidates(None, None).len() >= 2);
    }

    #[test]
    fn a_missing_library_names_every_place_tried_and_how_to_install() {
        let err = Lsl::load(&candidates(Some(Path::new("/nonexistent/liblsl.so")), None))
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert!(err.contains("/nonexistent/liblsl.so (--lsl-lib)"), "{err}");
        assert!(err.contains("pip install pylsl"), "{err}");
        assert!(!err.contains('\n'), "{err}");
    }
}
