//! The shell every runner puts around a [`Session`]: it feeds the session
//! ([`Run::feed`]) and hands each [`Event`] to the session's publisher on
//! the Lab Streaming Layer, if it has one ([`super::lsl::Publishing`]),
//! which answers the session's waits ([`Event::Ready`] with [`Feed::Go`],
//! the run's end with [`Feed::Close`]). The headless runners and the window
//! differ only in how they feed it.
//!
//! It plays the session's sound, if it has any ([`super::sound`]): the
//! masking noise and the tactile display, switched on the session's
//! events, and feeds the session for their faults.

use super::lsl::Publishing;
use super::sound::{Playback, Sound};
use super::{Event, Feed, Person, Responder, Session, SessionError, SessionRequest};
use crate::kinds::Header;
use crate::lsl::Streaming;
use crate::results::{ResultsDir, ResultsError};

/// A session a person runs from the window.
pub type LiveSession = Run<Person>;

/// A session and its shell's publisher: see the module docs.
pub struct Run<R: Responder> {
    session: Session<R>,
    lsl: Option<Publishing>,
    sound: Option<Playback>,
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
    /// device is ready), playing `sound` ([`super::sound`]).
    ///
    /// # Errors
    /// liblsl made no outlet, or its worker could not start.
    pub fn new(
        mut session: Session<R>,
        streaming: Option<&Streaming>,
        sound: Sound,
    ) -> Result<Self, SessionError> {
        let lsl = match streaming {
            Some(streaming) => Some(Publishing::start(streaming, &mut session)?),
            None => None,
        };
        let sound = Playback::start(sound, &mut session);
        if sound.is_some() {
            // Its line goes in the log before the last ([`Feed::Close`]).
            session.wait_for_shell();
        }
        Ok(Run {
            session,
            lsl,
            sound,
        })
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
            req.sound.clone(),
        )
    }

    /// Feeds the session and publishes what followed.
    ///
    /// # Errors
    /// I/O on the log or CSV; streams that could not open.
    pub fn feed(&mut self, feed: Feed) -> Result<(), ResultsError> {
        self.session.handle(feed)?;
        self.follow()?;
        // The sound's faults: each feed's events followed before the next.
        while let Some(feed) = self
            .sound
            .as_mut()
            .and_then(|s| s.check(std::time::Instant::now()))
        {
            self.session.handle(feed)?;
            self.follow()?;
        }
        Ok(())
    }

    /// Why the run stopped for its sound, if it did (a lost output not
    /// back within the timeout).
    #[must_use]
    pub fn sound_failed(&self) -> Option<&str> {
        self.sound.as_ref().and_then(Playback::failed)
    }

    /// How long a sound output has been lost, s, while it is: the session
    /// is held until it is back.
    #[must_use]
    pub fn sound_lost_for_s(&self) -> Option<f64> {
        self.sound.as_ref().and_then(Playback::lost_for_s)
    }

    /// Hands the session's events to the sound and the publisher.
    fn follow(&mut self) -> Result<(), ResultsError> {
        while let Some(event) = self.session.poll_event() {
            if let Some(sound) = &mut self.sound {
                sound.on(&event);
            }
            let ends = matches!(event, Event::Finished { .. } | Event::Stopped { .. });
            let ready = matches!(event, Event::Ready { .. });
            let waits = self.lsl.is_some() || self.sound.is_some();
            if let Some(lsl) = &mut self.lsl {
                lsl.on(event, &mut self.session)
                    .map_err(|e| ResultsError::Io {
                        path: String::new(),
                        source: std::io::Error::other(e.to_string()),
                    })?;
            } else if ready {
                // The sound's wait: nothing to open (its outputs are).
                self.session.handle(Feed::Go)?;
            }
            if ends && waits {
                let mut lines = self.lsl.take().map(Publishing::finish).unwrap_or_default();
                lines.extend(self.sound.as_ref().map(Playback::stats));
                self.session.handle(Feed::Close(lines))?;
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
        Run::new(session, req.lsl, req.sound.clone())
    }

    /// Where the mouse holds the hand, m (`None`: the pointer is away).
    pub fn set_hand_target(&mut self, x_m: Option<f64>) {
        self.session.set_hand_target(x_m);
    }
}
