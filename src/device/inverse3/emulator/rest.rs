//! The emulated Inverse Service's HTTP API (issue 63): every route Haply's
//! `haply` crate 1.3.1 can call (`InverseHttpClient`; `HaplyDevice`'s
//! `list_devices`, `get_device_info` and `get_service_version` go through
//! it), answered for the one emulated Inverse3 in the shapes the service
//! documents (docs.haply.co: Inverse Service 3.5, HTTP API, device and
//! session selectors) and the crate parses.
//!
//! - Bare JSON, as documented and as the crate reads them: `GET /version`,
//!   `GET /devices[?session=S]` (the inventory: each device with its
//!   `config`, `state` and `status`, and empty `verse_grip` and
//!   `wireless_verse_grip`), `GET /expert/status`.
//! - In the `{"ok": true, "data": ...}` envelope: `GET /sessions`,
//!   `/sessions/{id}`, `/sessions/{id}/profile`, `/settings`,
//!   `/settings/{key}`, `/sdf`, and the device routes
//!   `/{type}/{id}/config/{handedness, torque_scaling,
//!   gravity_compensation, home_return, paired_with}` and, given
//!   `?session=S`, `/{type}/{id}/config/{basis, mount, preset,
//!   filters/damping, filters/force_gate, navigation}`,
//!   `/{type}/{id}/state/transform` and `/{type}/{id}/sdf[/{hfx_id}]`.
//!   The values are the inventory's (one source: the emulator's
//!   `config`); the session's workspace transform is the identity,
//!   no SDF effect is set, navigation is `disabled`, and no grip is paired.
//! - The service's changes (POST, PATCH, DELETE on those routes,
//!   `POST /ports/{port}/reset`, `POST /save_configuration`) answer 501
//!   with `{"ok": false, "error": ...}`: the emulated device's
//!   configuration is the one its physics models, and stays so.
//! - Errors in the same envelope: an unknown path 404, a method a route
//!   does not take 405, a wildcard device on a GET or a session-scoped GET
//!   without `?session=` 400 (as documented), a device or session that
//!   nothing matches 404.
//!
//! Devices: `inverse3/{id}` or `*inverse/{id}`, the id being
//! [`super::DEVICE_ID`] or the index `0`. Sessions (one per WebSocket
//! client): `#N` or `N` (its id), `:I` (by index, `-1` the last),
//! `[:]PROFILE:I` (the I-th with that profile; `*` matches any run of
//! characters in it). Settings: `communication/http/port` and
//! `communication/websocket/port` (both the port the emulator listens on);
//! `GET /settings` gives them as one flat object of key and value (the
//! form of the service's settings file), without the listing's type hints
//! and metadata, which the documentation read here names but does not show.
//! `GET /expert/status` has the crate's four keys (`detection`, `devices`,
//! `sessions`, `global`); the documentation read here shows no example, so
//! their contents are the emulator's own: the device ids found, the
//! inventory, the sessions and the version.

use serde_json::{Value, json};

/// One WebSocket client's session on the emulated service.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Session {
    /// Its id (the service's `session_id`).
    pub id: u64,
    /// The profile it configured (`session.configure.profile.name`).
    pub profile: Option<String>,
}

/// What the emulated service holds when a request comes in.
#[derive(Debug, Clone)]
pub struct View {
    /// The version it states.
    pub version: String,
    /// The Inverse3 as the inventory lists it (`device_id`, `config`,
    /// `state`, `status`); `None`: no device on the service.
    pub device: Option<Value>,
    /// The sessions, oldest first.
    pub sessions: Vec<Session>,
    /// The port it listens on (HTTP and WebSocket alike).
    pub port: u16,
}

/// An answer: its HTTP status and JSON body.
#[derive(Debug, Clone, PartialEq)]
pub struct Reply {
    /// The HTTP status code.
    pub status: u16,
    /// The body.
    pub body: Value,
}

impl Reply {
    fn bare(body: Value) -> Self {
        Reply { status: 200, body }
    }

    fn data(data: Value) -> Self {
        let mut body = json!({"ok": true});
        body["data"] = data;
        Reply::bare(body)
    }

    /// `{"ok": false, "error": what}` with `status`.
    #[must_use]
    pub fn error(status: u16, what: &str) -> Self {
        Reply {
            status,
            body: json!({"ok": false, "error": what}),
        }
    }

    /// The status line's reason phrase.
    #[must_use]
    pub fn reason(&self) -> &'static str {
        match self.status {
            200 => "OK",
            400 => "Bad Request",
            404 => "Not Found",
            405 => "Method Not Allowed",
            501 => "Not Implemented",
            _ => "",
        }
    }
}

/// The methods a route takes, GET first if it takes it.
type Methods = &'static [&'static str];
const GET: Methods = &["GET"];
const GET_SET: Methods = &["GET", "POST", "DELETE"];
const GET_SET_PATCH: Methods = &["GET", "POST", "PATCH", "DELETE"];
const POST: Methods = &["POST"];

/// Answers `method target` (the request line's path and query).
#[must_use]
pub fn route(method: &str, target: &str, view: &View) -> Reply {
    let (path, query) = target.split_once('?').unwrap_or((target, ""));
    let session = form_urlencoded::parse(query.as_bytes())
        .find(|(k, _)| k == "session")
        .map(|(_, v)| v.into_owned());
    let segments: Vec<&str> = path.trim_matches('/').split('/').collect();
    let Some((methods, answer)) = find(&segments) else {
        return Reply::error(404, &format!("no route {method} {path}"));
    };
    if !methods.contains(&method) {
        return Reply::error(
            405,
            &format!("{path} takes {}, not {method}", methods.join(", ")),
        );
    }
    if method != "GET" {
        return refused(method, path);
    }
    answer(&Request {
        segments: &segments,
        session: session.as_deref(),
        view,
    })
}

/// A GET request, routed.
struct Request<'a> {
    segments: &'a [&'a str],
    session: Option<&'a str>,
    view: &'a View,
}

type Answer = fn(&Request) -> Reply;

/// A change the service would make: refused, since the emulated device's
/// configuration is the one its physics models.
fn refused(method: &str, path: &str) -> Reply {
    Reply::error(
        501,
        &format!(
            "the emulated Inverse Service changes nothing: {method} {path} is not emulated (its device's configuration is the one its physics models)"
        ),
    )
}

/// The GET answer of a route that only changes things (never called: the
/// route takes no GET).
fn change_only(r: &Request) -> Reply {
    refused("GET", &r.segments.join("/"))
}

/// The route `segments` names: the methods it takes and its GET answer.
fn find(segments: &[&str]) -> Option<(Methods, Answer)> {
    let found: (Methods, Answer) = match segments {
        ["version"] => (GET, version),
        ["devices"] => (GET, devices),
        ["expert", "status"] => (GET, expert_status),
        ["sessions"] => (GET, sessions),
        ["sessions", _] => (GET, session),
        ["sessions", _, "profile"] => (GET_SET, profile),
        ["settings"] => (&["GET", "POST"], settings),
        ["settings", _, ..] => (GET_SET, setting),
        ["sdf"] => (GET_SET_PATCH, all_sdf),
        ["ports", _, "reset"] | ["save_configuration"] => (POST, change_only),
        [kind, _, rest @ ..] if DEVICE_TYPES.contains(kind) => match rest {
            ["config", "mount"] | ["state", "transform"] | ["sdf"] | ["sdf", _] => {
                (GET_SET_PATCH, device)
            }
            ["config", setting] if CONFIG.contains(setting) => (GET_SET, device),
            ["config", "filters", "damping" | "force_gate"] => (GET_SET, device),
            _ => return None,
        },
        _ => return None,
    };
    Some(found)
}

/// The device types the service's selectors name.
const DEVICE_TYPES: &[&str] = &[
    "inverse3",
    "inverse3x",
    "minverse",
    "verse_grip",
    "wireless_verse_grip",
    "custom_verse_grip",
    "*inverse",
    "*verse_grip",
];

/// The one-word settings under `/{type}/{id}/config/` (mount is routed
/// with PATCH, the filters under `filters/`).
const CONFIG: &[&str] = &[
    "handedness",
    "torque_scaling",
    "gravity_compensation",
    "home_return",
    "paired_with",
    "basis",
    "preset",
    "navigation",
];

fn version(r: &Request) -> Reply {
    let v = &r.view.version;
    Reply::bare(json!({
        "build_time": "",
        "git_branch": "",
        "git_describe": v,
        "git_hash": "",
        "git_tag": v,
        "project_name": "haply-inverse-service (frictionlab emulator)",
        "project_version": v,
    }))
}

fn inventory(view: &View, session: Option<&Session>) -> Value {
    let mut listed = json!({
        "inverse3": view.device.iter().collect::<Vec<_>>(),
        "verse_grip": [],
        "wireless_verse_grip": [],
    });
    if let Some(s) = session {
        listed["session_id"] = json!(s.id);
    }
    listed
}

fn devices(r: &Request) -> Reply {
    match r.session {
        None => Reply::bare(inventory(r.view, None)),
        // The session's application space is the device's own (basis XYZ,
        // mount and workspace the identity), so only the session changes.
        Some(selector) => match select_session(selector, &r.view.sessions) {
            Some(s) => Reply::bare(inventory(r.view, Some(s))),
            None => no_session(selector),
        },
    }
}

fn session_info(s: &Session) -> Value {
    let mut info = json!({"session_id": s.id, "config": {}});
    if let Some(name) = &s.profile {
        info["config"]["profile"] = json!({"name": name});
    }
    info
}

fn expert_status(r: &Request) -> Reply {
    let ids: Vec<&Value> = r.view.device.iter().map(|d| &d["device_id"]).collect();
    Reply::bare(json!({
        "detection": {"inverse3": ids},
        "devices": inventory(r.view, None),
        "sessions": r.view.sessions.iter().map(session_info).collect::<Vec<_>>(),
        "global": {"version": r.view.version},
    }))
}

fn sessions(r: &Request) -> Reply {
    Reply::data(json!({
        "session_count": r.view.sessions.len(),
        "sessions": r.view.sessions.iter().map(session_info).collect::<Vec<_>>(),
    }))
}

/// The session `/sessions/{id}` names.
fn by_id<'a>(r: &Request<'a>) -> Result<&'a Session, Reply> {
    let id = r.segments[1];
    id.parse::<u64>()
        .ok()
        .and_then(|id| r.view.sessions.iter().find(|s| s.id == id))
        .ok_or_else(|| Reply::error(404, &format!("no session {id}")))
}

fn session(r: &Request) -> Reply {
    by_id(r).map_or_else(|e| e, |s| Reply::data(session_info(s)))
}

fn profile(r: &Request) -> Reply {
    match by_id(r) {
        Err(e) => e,
        Ok(Session {
            profile: Some(name),
            ..
        }) => Reply::data(json!({"name": name})),
        Ok(s) => Reply::error(404, &format!("session {} has no profile", s.id)),
    }
}

/// The settings the emulated service has, key and value.
fn all_settings(view: &View) -> Value {
    json!({
        "communication/http/port": view.port,
        "communication/websocket/port": view.port,
    })
}

fn settings(r: &Request) -> Reply {
    Reply::data(all_settings(r.view))
}

fn setting(r: &Request) -> Reply {
    let key = r.segments[1..].join("/");
    match all_settings(r.view).get(&key) {
        Some(v) => Reply::data(v.clone()),
        None => Reply::error(404, &format!("no setting {key} on the emulated service")),
    }
}

fn all_sdf(_: &Request) -> Reply {
    Reply::data(json!([]))
}

fn no_session(selector: &str) -> Reply {
    Reply::error(404, &format!("no session matches {selector}"))
}

/// A device route: `/{type}/{id}/...`.
fn device(r: &Request) -> Reply {
    let (kind, id, rest) = (r.segments[0], r.segments[1], &r.segments[2..]);
    if id == "*" {
        return Reply::error(
            400,
            &format!("GET takes one device, not the wildcard {kind}/{id}"),
        );
    }
    let Some(device) =
        r.view.device.as_ref().filter(|d| {
            matches!(kind, "inverse3" | "*inverse") && (id == "0" || d["device_id"] == id)
        })
    else {
        return Reply::error(404, &format!("no device matches {kind}/{id}"));
    };
    let config = &device["config"];
    // Settings of the device itself, then those of a session's view of it.
    let own = match rest {
        ["config", "paired_with"] => Some(json!({
            "inverse_id": device["device_id"],
            "verse_grip_id": null,
            "attached": false,
            "force_attached": false,
        })),
        [
            "config",
            setting @ ("handedness" | "torque_scaling" | "gravity_compensation" | "home_return"),
        ] => Some(config[*setting].clone()),
        _ => None,
    };
    if let Some(value) = own {
        return Reply::data(value);
    }
    let Some(selector) = r.session else {
        return Reply::error(
            400,
            &format!("{} is session-scoped: give ?session=", rest.join("/")),
        );
    };
    if select_session(selector, &r.view.sessions).is_none() {
        return no_session(selector);
    }
    Reply::data(match rest {
        ["config", "basis"] => config["basis"].clone(),
        ["config", "mount"] => json!({"transform": config["mount"]}),
        ["config", "preset"] => json!({"preset": config["preset"]}),
        ["config", "filters", filter] => config["filters"][*filter].clone(),
        ["config", "navigation"] => json!({"status": {"mode": "disabled"}}),
        ["state", "transform"] => json!({"transform": IDENTITY.clone()}),
        ["sdf"] => json!([]),
        ["sdf", effect] => {
            return Reply::error(404, &format!("no SDF effect {effect}"));
        }
        _ => return Reply::error(404, &format!("no route GET {}", r.segments.join("/"))),
    })
}

/// The identity transform (position, rotation as a quaternion, scale).
pub static IDENTITY: std::sync::LazyLock<Value> = std::sync::LazyLock::new(|| {
    json!({
        "position": {"x": 0.0, "y": 0.0, "z": 0.0},
        "rotation": {"w": 1.0, "x": 0.0, "y": 0.0, "z": 0.0},
        "scale": {"x": 1.0, "y": 1.0, "z": 1.0},
    })
});

/// The session `selector` names among `sessions` (oldest first): `#N` or
/// `N` by id, `:I` by index (negative from the last), `[:]PROFILE:I` the
/// I-th with that profile (`*` in it matches any run of characters).
#[must_use]
pub fn select_session<'a>(selector: &str, sessions: &'a [Session]) -> Option<&'a Session> {
    let bare = selector.strip_prefix('#').unwrap_or(selector);
    if let Ok(id) = bare.parse::<u64>() {
        return sessions.iter().find(|s| s.id == id);
    }
    let (name, index) = selector.rsplit_once(':')?;
    let index: i64 = index.parse().ok()?;
    let name = name.strip_prefix(':').unwrap_or(name);
    let matching: Vec<&Session> = sessions
        .iter()
        .filter(|s| name.is_empty() || s.profile.as_deref().is_some_and(|p| glob(name, p)))
        .collect();
    let at = if index < 0 {
        matching
            .len()
            .checked_sub(usize::try_from(index.unsigned_abs()).ok()?)?
    } else {
        usize::try_from(index).ok()?
    };
    matching.get(at).copied()
}

/// Whether `text` matches `pattern`, whose `*` matches any run of
/// characters.
fn glob(pattern: &str, text: &str) -> bool {
    let mut parts = pattern.split('*');
    let first = parts.next().unwrap_or_default();
    let Some(mut rest) = text.strip_prefix(first) else {
        return false;
    };
    let parts: Vec<&str> = parts.collect();
    let Some((last, middle)) = parts.split_last() else {
        return rest.is_empty();
    };
    for part in middle {
        match rest.find(part) {
            Some(i) => rest = &rest[i + part.len()..],
            None => return false,
        }
    }
    rest.len() >= last.len() && rest.ends_with(last)
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, reason = "tests")]
    use super::*;

    fn view() -> View {
        let mut device = json!({
            "device_id": "E3M1",
            "config": super::super::config(),
            "state": {"mode": "idle"},
            "status": {"ready": true},
        });
        device["config"]["id"] = json!("E3M1");
        View {
            version: "3.5.0".into(),
            device: Some(device),
            sessions: vec![
                Session {
                    id: 2,
                    profile: Some("co.haply.hub::demo-orb".into()),
                },
                Session {
                    id: 5,
                    profile: Some("frictionlab".into()),
                },
                Session {
                    id: 9,
                    profile: None,
                },
            ],
            port: 10001,
        }
    }

    fn get(target: &str) -> Reply {
        route("GET", target, &view())
    }

    /// Issue 63: `GET /devices` lists the emulated Inverse3 (it answered
    /// 404, so the crate's `list_devices` listed nothing), bare as the
    /// service's documented example, with an empty list of each grip.
    #[test]
    fn issue_63_get_devices_answers_the_documented_inventory() {
        let r = get("/devices");
        assert_eq!(r.status, 200);
        assert_eq!(r.body["inverse3"][0]["device_id"], "E3M1");
        assert_eq!(r.body["inverse3"][0]["config"]["device_info"]["id"], "E3M1");
        assert_eq!(r.body["verse_grip"], json!([]));
        assert_eq!(r.body["wireless_verse_grip"], json!([]));
        assert!(r.body.get("ok").is_none(), "bare, not enveloped");
        let scoped = get("/devices?session=%3A-1");
        assert_eq!(
            (scoped.status, &scoped.body["session_id"]),
            (200, &json!(9))
        );
        let none = View {
            device: None,
            ..view()
        };
        assert_eq!(route("GET", "/devices", &none).body["inverse3"], json!([]));
    }

    /// Each route the crate reads answers 200 with its documented body.
    #[test]
    fn known_paths_answer_200_with_the_documented_body() {
        let data = |target: &str| {
            let r = get(target);
            assert_eq!(r.status, 200, "{target}: {}", r.body);
            assert_eq!(r.body["ok"], true, "{target}");
            r.body["data"].clone()
        };
        assert_eq!(get("/version").body["project_version"], "3.5.0");
        assert_eq!(data("/inverse3/E3M1/config/handedness"), "right");
        assert_eq!(
            data("/inverse3/0/config/torque_scaling"),
            json!({"enabled": true})
        );
        assert_eq!(
            data("/*inverse/0/config/gravity_compensation"),
            json!({"enabled": true, "scaling_factor": 1.0})
        );
        assert_eq!(
            data("/inverse3/0/config/home_return"),
            json!({"enabled": false})
        );
        assert_eq!(data("/inverse3/0/config/paired_with")["inverse_id"], "E3M1");
        assert_eq!(
            data("/inverse3/0/config/basis?session=:0"),
            json!({"permutation": "XYZ"})
        );
        assert_eq!(
            data("/inverse3/0/config/mount?session=%235"),
            json!({"transform": *IDENTITY})
        );
        assert_eq!(
            data("/inverse3/0/config/preset?session=frictionlab:0"),
            json!({"preset": "defaults"})
        );
        assert_eq!(
            data("/inverse3/0/config/filters/force_gate?session=5"),
            json!({"gain": 0.3})
        );
        assert_eq!(
            data("/inverse3/0/config/filters/damping?session=5"),
            json!({"scalar": 0.0})
        );
        assert_eq!(
            data("/inverse3/0/config/navigation?session=5")["status"]["mode"],
            "disabled"
        );
        assert_eq!(
            data("/inverse3/0/state/transform?session=5"),
            json!({"transform": *IDENTITY})
        );
        assert_eq!(data("/inverse3/0/sdf?session=5"), json!([]));
        assert_eq!(data("/sdf"), json!([]));
        let sessions = data("/sessions");
        assert_eq!(sessions["session_count"], 3);
        assert_eq!(
            sessions["sessions"][1]["config"]["profile"]["name"],
            "frictionlab"
        );
        assert_eq!(data("/sessions/5")["session_id"], 5);
        assert_eq!(data("/sessions/5/profile"), json!({"name": "frictionlab"}));
        assert_eq!(data("/settings")["communication/http/port"], 10001);
        assert_eq!(data("/settings/communication/websocket/port"), 10001);
        let expert = get("/expert/status");
        assert_eq!(expert.body["detection"]["inverse3"], json!(["E3M1"]));
        assert_eq!(expert.body["sessions"][2]["session_id"], 9);
    }

    /// Unknown paths answer 404 with a JSON error body; so do devices,
    /// sessions and effects that nothing matches.
    #[test]
    fn unknown_paths_answer_404_with_a_json_error() {
        for target in [
            "/",
            "/nothing",
            "/devices/E3M1",
            "/3.0/version",
            "/inverse3/0/config/colour",
            "/inverse3/0",
            "/robot/0/config/handedness",
            "/inverse3/049D/config/handedness",
            "/verse_grip/0/config/handedness",
            "/sessions/7",
            "/sessions/nine",
            "/sessions/9/profile",
            "/settings/communication/events/port",
            "/inverse3/0/config/basis?session=:3",
            "/inverse3/0/config/basis?session=nobody:0",
            "/inverse3/0/sdf/wall?session=5",
            "/devices?session=%2342",
        ] {
            let r = get(target);
            assert_eq!(r.status, 404, "{target}: {}", r.body);
            assert_eq!(r.body["ok"], false, "{target}");
            assert!(
                r.body["error"].as_str().is_some_and(|e| !e.is_empty()),
                "{target}"
            );
        }
    }

    /// As documented: a GET takes one device and a session-scoped GET a
    /// session (400); the changes answer 501 and change nothing; a method
    /// a route does not take 405.
    #[test]
    fn wildcards_missing_sessions_changes_and_other_methods_answer_errors() {
        assert_eq!(get("/inverse3/*/config/handedness").status, 400);
        assert_eq!(get("/inverse3/0/config/basis").status, 400);
        let v = view();
        for (method, target) in [
            ("POST", "/inverse3/0/config/handedness"),
            ("DELETE", "/inverse3/*/config/torque_scaling"),
            ("PATCH", "/inverse3/0/config/mount?session=5"),
            ("POST", "/sessions/5/profile"),
            ("POST", "/settings/communication/http/port"),
            ("POST", "/sdf"),
            ("POST", "/ports/emulated/reset"),
            ("POST", "/save_configuration"),
        ] {
            let r = route(method, target, &v);
            assert_eq!(
                (r.status, &r.body["ok"]),
                (501, &json!(false)),
                "{method} {target}"
            );
        }
        assert_eq!(
            route("GET", "/inverse3/0/config/handedness", &v).body["data"],
            "right"
        );
        assert_eq!(route("PUT", "/version", &v).status, 405);
        assert_eq!(
            route("PATCH", "/inverse3/0/config/handedness", &v).status,
            405
        );
        assert_eq!(route("GET", "/save_configuration", &v).status, 405);
    }

    #[test]
    fn session_selectors_follow_the_documented_forms() {
        let v = view();
        let id = |sel: &str| select_session(sel, &v.sessions).map(|s| s.id);
        assert_eq!(id("#5"), Some(5));
        assert_eq!(id("9"), Some(9));
        assert_eq!(id(":0"), Some(2));
        assert_eq!(id(":-1"), Some(9));
        assert_eq!(id(":-3"), Some(2));
        assert_eq!(id(":-4"), None);
        assert_eq!(id(":frictionlab:0"), Some(5));
        assert_eq!(id("frictionlab:0"), Some(5));
        assert_eq!(id("frictionlab:1"), None);
        assert_eq!(id("co.haply.hub::*:0"), Some(2));
        assert_eq!(id("*lab:-1"), Some(5));
        assert_eq!(id("#7"), None);
        assert_eq!(id("frictionlab"), None);
    }
}
