//! The liblsl C functions, resolved once from the loaded library. Every
//! unsafe block of the crate is here; each calls one function of `lsl_c.h`
//! with its declared argument types, on handles liblsl returned and that
//! are destroyed exactly once (`RawOutlet` is not `Clone`).
#![allow(unsafe_code)]

use std::ffi::{CString, c_char, c_void};
use std::path::Path;

use super::{Content, Format, Node, StreamSpec};

/// `lsl_channel_format_t`: `cft_float32`.
const CFT_FLOAT32: i32 = 1;
/// `cft_string`.
const CFT_STRING: i32 = 3;

type VersionFn = unsafe extern "C" fn() -> i32;
type ClockFn = unsafe extern "C" fn() -> f64;
type CreateInfoFn =
    unsafe extern "C" fn(*const c_char, *const c_char, i32, f64, i32, *const c_char) -> *mut c_void;
type DestroyFn = unsafe extern "C" fn(*mut c_void);
type GetDescFn = unsafe extern "C" fn(*mut c_void) -> *mut c_void;
type AppendChildFn = unsafe extern "C" fn(*mut c_void, *const c_char) -> *mut c_void;
type AppendValueFn = unsafe extern "C" fn(*mut c_void, *const c_char, *const c_char) -> *mut c_void;
type CreateOutletFn = unsafe extern "C" fn(*mut c_void, i32, i32) -> *mut c_void;
type PushFloatFn = unsafe extern "C" fn(*mut c_void, *const f32, f64, i32) -> i32;
type PushStrFn = unsafe extern "C" fn(*mut c_void, *const *const c_char, f64, i32) -> i32;
type ConsumersFn = unsafe extern "C" fn(*mut c_void) -> i32;
type WaitFn = unsafe extern "C" fn(*mut c_void, f64) -> i32;
type ConfigFn = unsafe extern "C" fn(*const c_char);

/// Why a library could not be opened.
pub(super) enum OpenError {
    /// The system's loader refused it (not found, not a library).
    Load(String),
    /// It lacks this function.
    Missing(String),
    /// Its `lsl_library_version` is older than the minimum.
    TooOld(i32),
}

/// The functions an outlet needs, and the library that holds them (kept
/// open as long as they may be called).
pub(super) struct Api {
    library_version: VersionFn,
    local_clock: ClockFn,
    create_streaminfo: CreateInfoFn,
    destroy_streaminfo: DestroyFn,
    get_desc: GetDescFn,
    append_child: AppendChildFn,
    append_child_value: AppendValueFn,
    create_outlet: CreateOutletFn,
    destroy_outlet: DestroyFn,
    push_sample_ftp: PushFloatFn,
    push_sample_strtp: PushStrFn,
    have_consumers: ConsumersFn,
    wait_for_consumers: WaitFn,
    /// `lsl_set_config_content` (liblsl 1.16 and later).
    set_config_content: Option<ConfigFn>,
    _library: libloading::Library,
}

/// An outlet handle of liblsl, destroyed once by [`Api::destroy_outlet`].
pub(super) struct RawOutlet(*mut c_void);

// SAFETY: liblsl's outlets may be used from any thread (its documentation:
// "all functions are thread-safe"); the handle is only a pointer to one.
unsafe impl Send for RawOutlet {}

/// A C string of `s`, a NUL sent as a space.
fn c(s: &str) -> CString {
    CString::new(s.replace('\0', " ")).unwrap_or_default()
}

impl Api {
    /// Opens the library at `path`, checks its version against `min`
    /// (before anything else is resolved: an old library may lack newer
    /// functions) and resolves every function.
    pub(super) fn open(path: &Path, min: i32) -> Result<Api, OpenError> {
        // SAFETY: loading runs the library's initialisers; liblsl's only
        // set up its own state. The path is the user's choice, as with
        // pylsl's PYLSL_LIB.
        let library = unsafe { libloading::Library::new(path) }
            .map_err(|e| OpenError::Load(e.to_string()))?;
        macro_rules! get {
            ($name:literal) => {
                // SAFETY: the symbol is the liblsl function of that name;
                // its type is the one `lsl_c.h` declares.
                *unsafe { library.get(concat!($name, "\0").as_bytes()) }
                    .map_err(|_| OpenError::Missing($name.to_owned()))?
            };
        }
        let library_version: VersionFn = get!("lsl_library_version");
        // SAFETY: no arguments.
        let version = unsafe { library_version() };
        if version < min {
            return Err(OpenError::TooOld(version));
        }
        Ok(Api {
            library_version,
            local_clock: get!("lsl_local_clock"),
            create_streaminfo: get!("lsl_create_streaminfo"),
            destroy_streaminfo: get!("lsl_destroy_streaminfo"),
            get_desc: get!("lsl_get_desc"),
            append_child: get!("lsl_append_child"),
            append_child_value: get!("lsl_append_child_value"),
            create_outlet: get!("lsl_create_outlet"),
            destroy_outlet: get!("lsl_destroy_outlet"),
            push_sample_ftp: get!("lsl_push_sample_ftp"),
            push_sample_strtp: get!("lsl_push_sample_strtp"),
            have_consumers: get!("lsl_have_consumers"),
            wait_for_consumers: get!("lsl_wait_for_consumers"),
            // SAFETY: as `get!`; optional, older releases lack it.
            set_config_content: unsafe { library.get::<ConfigFn>(b"lsl_set_config_content\0") }
                .ok()
                .map(|f| *f),
            _library: library,
        })
    }

    /// Sets liblsl's configuration to `content` (an `lsl_api.cfg`'s text)
    /// before its first use; false if this liblsl cannot.
    pub(super) fn set_config(&self, content: &str) -> bool {
        let Some(set) = self.set_config_content else {
            return false;
        };
        let text = c(content);
        // SAFETY: a NUL-terminated string that outlives the call; liblsl
        // copies it.
        unsafe { set(text.as_ptr()) };
        true
    }

    pub(super) fn library_version(&self) -> i32 {
        // SAFETY: no arguments.
        unsafe { (self.library_version)() }
    }

    pub(super) fn local_clock(&self) -> f64 {
        // SAFETY: no arguments.
        unsafe { (self.local_clock)() }
    }

    /// A stream info for `spec` with `desc` under its `desc` element, an
    /// outlet from it (the info is copied by the outlet, then destroyed).
    pub(super) fn outlet(
        &self,
        spec: &StreamSpec<'_>,
        desc: &[Node],
        max_buffered_s: i32,
    ) -> Option<RawOutlet> {
        let (name, kind, source) = (c(spec.name), c(spec.kind), c(spec.source_id));
        let format = match spec.format {
            Format::Float32 => CFT_FLOAT32,
            Format::String => CFT_STRING,
        };
        let channels = i32::try_from(spec.channels).ok()?;
        // SAFETY: NUL-terminated strings that outlive the call.
        let info = unsafe {
            (self.create_streaminfo)(
                name.as_ptr(),
                kind.as_ptr(),
                channels,
                spec.rate_hz,
                format,
                source.as_ptr(),
            )
        };
        if info.is_null() {
            return None;
        }
        // SAFETY: `info` is a live stream info.
        let root = unsafe { (self.get_desc)(info) };
        self.append(root, desc);
        // SAFETY: `info` is live; chunk size 0 (per sample), the buffer in s.
        let outlet = unsafe { (self.create_outlet)(info, 0, max_buffered_s) };
        // SAFETY: `info` is live and destroyed once; the outlet holds a copy.
        unsafe { (self.destroy_streaminfo)(info) };
        (!outlet.is_null()).then_some(RawOutlet(outlet))
    }

    fn append(&self, parent: *mut c_void, nodes: &[Node]) {
        for node in nodes {
            let name = c(&node.name);
            match &node.content {
                Content::Value(v) => {
                    let value = c(v);
                    // SAFETY: `parent` is an element of a live info.
                    unsafe { (self.append_child_value)(parent, name.as_ptr(), value.as_ptr()) };
                }
                Content::Children(children) => {
                    // SAFETY: as above.
                    let child = unsafe { (self.append_child)(parent, name.as_ptr()) };
                    self.append(child, children);
                }
            }
        }
    }

    pub(super) fn push_f32(&self, outlet: &RawOutlet, sample: &[f32], timestamp_s: f64) -> bool {
        // SAFETY: the caller checked `sample` has the outlet's channel count.
        unsafe { (self.push_sample_ftp)(outlet.0, sample.as_ptr(), timestamp_s, 1) == 0 }
    }

    pub(super) fn push_str(&self, outlet: &RawOutlet, text: &str, timestamp_s: f64) -> bool {
        let text = c(text);
        let ptrs = [text.as_ptr()];
        // SAFETY: one string for a one-channel string outlet.
        unsafe { (self.push_sample_strtp)(outlet.0, ptrs.as_ptr(), timestamp_s, 1) == 0 }
    }

    pub(super) fn have_consumers(&self, outlet: &RawOutlet) -> bool {
        // SAFETY: a live outlet.
        unsafe { (self.have_consumers)(outlet.0) != 0 }
    }

    pub(super) fn wait_for_consumers(&self, outlet: &RawOutlet, timeout_s: f64) -> bool {
        // SAFETY: a live outlet; liblsl blocks at most `timeout_s`.
        unsafe { (self.wait_for_consumers)(outlet.0, timeout_s) != 0 }
    }

    pub(super) fn destroy_outlet(&self, outlet: &RawOutlet) {
        // SAFETY: called once, from `Outlet`'s drop.
        unsafe { (self.destroy_outlet)(outlet.0) }
    }
}
