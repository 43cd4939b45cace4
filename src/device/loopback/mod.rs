//! A device kind for tests only: the simulated apparatus's real-time
//! backend ([`super::sim::RealTime`]) registered as a kind of its own. It
//! is here to show the seam: a kind registered in one line of
//! [`super::KINDS`] runs a whole session (`src/session/headless.rs`'s
//! test, which asks for `--device loopback:test` by name), and no module
//! names it.

/// The device kind: `loopback:` with any target.
pub const KIND: super::Kind = super::Kind {
    name: "loopback",
    about: "an apparatus in this process (tests only)",
    target: "NAME",
    bare: false,
    check: |_| Ok(()),
    check_settings: |_| Ok(()),
    open: |_, _| Ok(Box::new(super::sim::RealTime::new())),
    find: Vec::new,
};
