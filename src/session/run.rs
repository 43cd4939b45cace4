//! The shell every runner puts around a [`Session`]: it feeds the session
//! ([`Run::feed`]) and hands each [`Event`] to the session's publisher on
//! the Lab Streaming Layer, if it has one ([`super::lsl::Publishing`]),
//! which answers the session's waits ([`Event::Ready`] with [`Feed::Go`],
//! the run's end with [`Feed::Close`]). The headless runners and the window
//! differ only in how they feed it.
//!
//! With masking noise ([`crate::audio::Masker`], issue 64) it switches the
//! noise as the protocol's `masking.during` says: on from the run's start,
//! or on at each [`Event::TrialStarted`] and off when the trial's record
//! is [`Event::Written`]; at the run's end it ramps the noise down and
//! closes the stream.

use super::lsl::Publishing;
use super::{Event, Feed, Person, Responder, Session, SessionError, SessionRequest};
use crate::audio::{During, Masker};
use crate::kinds::Header;
use crate::lsl::Streaming;
use crate::results::{ResultsDir, ResultsError};
use std::sync::Arc;

/// A session a person runs from the window.
pub type LiveSession = Run<Person>;

/// A session and its shell's publisher: see the module docs.
pub struct Run<R: Responder> {
    session: Session<R>,
    lsl: Option<Publishing>,
    masker: Option<Arc<Masker>>,
}

impl<R: Responder> std::ops::Deref for Run<R> {
    type Target = Session<R>;

    fn deref(&self) -> &Session<R> {
        &self.session
    }
}

impl<R: Responder> Run<R> {
    /// Runs `session`, published on LSL with `streaming` if given (with
    /// the simulated device both streams open now; on a port when the
    /// device is ready), with `masker`'s noise if given (on now for a
    /// whole session's masking).
    ///
    /// # Errors
    /// liblsl made no outlet, or its worker could not start.
    pub fn new(
        mut session: Session<R>,
        streaming: Option<&Streaming>,
        masker: Option<Arc<Masker>>,
    ) -> Result<Self, SessionError> {
        let lsl = match streaming {
            Some(streaming) => Some(Publishing::start(streaming, &mut session)?),
            None => None,
        };
        if let Some(m) = &masker {
            session = session.with_events();
            m.set_on(m.masking().during == During::Session);
        }
        Ok(Run {
            session,
            lsl,
            masker,
        })
    }

    /// Switches the masking noise for `event` (see the module docs).
    fn mask(&self, event: &Event) {
        let Some(m) = &self.masker else { return };
        let trials = m.masking().during == During::Trials;
        match event {
            Event::TrialStarted { .. } if trials => m.set_on(true),
            Event::Written { .. } if trials => m.set_on(false),
            Event::Finished { .. } | Event::Stopped { .. } => m.finish(),
            _ => {}
        }
    }

    /// Plans (or resumes) a session ([`Session::begin`]) and runs it,
    /// published as `req.lsl` says.
    ///
    /// # Errors
    /// As [`Session::begin`] and [`Run::new`].
    pub fn begin(
        dir: &ResultsDir,
        req: &SessionRequest<'_>,
        responder: impl FnOnce(&Header) -> R,
    ) -> Result<Self, SessionError> {
        Run::new(
            Session::begin(dir, req, responder)?,
            req.lsl,
            req.masker.clone(),
        )
    }

    /// Feeds the session and publishes what followed.
    ///
    /// # Errors
    /// I/O on the log or CSV; streams that could not open.
    pub fn feed(&mut self, feed: Feed) -> Result<(), ResultsError> {
        self.session.handle(feed)?;
        while let Some(event) = self.session.poll_event() {
            self.mask(&event);
            let Some(lsl) = &mut self.lsl else { continue };
            let ends = matches!(event, Event::Finished { .. } | Event::Stopped { .. });
            lsl.on(event, &mut self.session)
                .map_err(|e| ResultsError::Io {
                    path: String::new(),
                    source: std::io::Error::other(e.to_string()),
                })?;
            if ends && let Some(lsl) = self.lsl.take() {
                self.session.handle(Feed::Close(lsl.finish()))?;
            }
        }
        Ok(())
    }

    /// Paces a published simulated session: its time runs `pace` times
    /// real time on LSL's clock, held there by [`Run::hold`]. False (and
    /// nothing done) when not published.
    pub fn pace_on_lsl(&mut self, pace: f64) -> bool {
        self.lsl.as_mut().is_some_and(|lsl| {
            lsl.pace(pace);
            true
        })
    }

    /// Waits until LSL's clock reaches the session's next tick (after
    /// [`Run::pace_on_lsl`]), so each tick's sample and the events right
    /// after it are handled at, or just after, their timestamps.
    pub fn hold(&self) {
        if let Some(lsl) = &self.lsl {
            lsl.hold(&self.session);
        }
    }

    /// LSL's clock now, when published.
    #[must_use]
    pub fn lsl_now(&self) -> Option<f64> {
        self.lsl.as_ref().map(Publishing::now)
    }

    /// The session, its run over.
    #[must_use]
    pub fn into_session(self) -> Session<R> {
        self.session
    }
}

impl Run<Person> {
    /// Starts (or resumes) a session a person runs from the window (logged
    /// with responder `gui`), with a live trace.
    ///
    /// # Errors
    /// As [`Run::begin`].
    pub fn start(dir: &ResultsDir, req: &SessionRequest<'_>) -> Result<Self, SessionError> {
        let session = Session::begin(dir, req, |_| Person::default())?.with_trace();
        Run::new(session, req.lsl, req.masker.clone())
    }

    /// Where the mouse holds the hand, m (`None`: the pointer is away).
    pub fn set_hand_target(&mut self, x_m: Option<f64>) {
        self.session.set_hand_target(x_m);
    }
}
