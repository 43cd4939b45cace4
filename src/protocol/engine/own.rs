//! A screen a kind draws itself ([`super::Action::ShowOwn`]).
//!
//! The shared screens ([`Screen`]) are the participant's tasks: explore,
//! compare two stimuli, tap targets, read. A kind that wants its own look
//! for one of them (its words, its figure, its buttons) shows an
//! [`OwnScreen`]: a value of its own type ([`KindScreen`]) that names the
//! shared screen whose task it sets. The window draws it with the kind's
//! own code (`view.rs`'s `SCREEN` in the kind's folder, listed by the
//! registry); the simulated participant does its task, and the LSL markers
//! mark it by its name, with no code of theirs for it.

use std::any::Any;
use std::fmt::Debug;
use std::sync::Arc;

use super::Screen;

/// A kind's own screen type: what its window code draws, and the shared
/// task it sets the participant.
pub trait KindScreen: Debug + Clone + PartialEq + Send + Sync + 'static {
    /// Its name: the LSL marker's (`snake_case`, unique to the kind).
    fn name(&self) -> &'static str;
    /// The shared screen whose task it sets: what the simulated
    /// participant does, what the session asks, and what the window shows
    /// for a kind without its own drawing.
    fn task(&self) -> Screen;
}

/// [`KindScreen`] as an object: any kind's screen behind one type.
trait Shown: Debug + Send + Sync {
    fn name(&self) -> &'static str;
    fn task(&self) -> Screen;
    fn as_any(&self) -> &dyn Any;
    fn same(&self, other: &dyn Shown) -> bool;
}

impl<S: KindScreen> Shown for S {
    fn name(&self) -> &'static str {
        KindScreen::name(self)
    }
    fn task(&self) -> Screen {
        KindScreen::task(self)
    }
    fn as_any(&self) -> &dyn Any {
        self
    }
    fn same(&self, other: &dyn Shown) -> bool {
        other.as_any().downcast_ref::<S>() == Some(self)
    }
}

/// A kind's own screen, shown by [`super::Action::ShowOwn`].
#[derive(Debug, Clone)]
pub struct OwnScreen(Arc<dyn Shown>);

impl OwnScreen {
    /// The kind's screen `screen`.
    pub fn new(screen: impl KindScreen) -> OwnScreen {
        OwnScreen(Arc::new(screen))
    }

    /// Its name ([`KindScreen::name`]).
    #[must_use]
    pub fn name(&self) -> &'static str {
        self.0.name()
    }

    /// The shared screen whose task it sets ([`KindScreen::task`]).
    #[must_use]
    pub fn task(&self) -> Screen {
        self.0.task()
    }

    /// The kind's own value, if it is an `S` (how the kind's window code
    /// gets it back).
    #[must_use]
    pub fn get<S: KindScreen>(&self) -> Option<&S> {
        self.0.as_any().downcast_ref::<S>()
    }
}

impl PartialEq for OwnScreen {
    fn eq(&self, other: &OwnScreen) -> bool {
        self.0.same(other.0.as_ref())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::time::Time;

    /// A screen type per `KIND` (two kinds' screens are two types).
    #[derive(Debug, Clone, PartialEq)]
    struct Card<const KIND: u8>(u8);

    impl<const KIND: u8> KindScreen for Card<KIND> {
        fn name(&self) -> &'static str {
            ["card", "other"][usize::from(KIND)]
        }
        fn task(&self) -> Screen {
            Screen::Break { until: Time::ZERO }
        }
    }

    #[test]
    fn an_own_screen_is_its_kinds_value_equal_only_to_the_same_value() {
        let card = OwnScreen::new(Card::<0>(1));
        assert_eq!(card.get::<Card<0>>(), Some(&Card(1)));
        assert_eq!(card.get::<Card<1>>(), None);
        assert_eq!(
            (card.name(), card.task()),
            ("card", Screen::Break { until: Time::ZERO })
        );
        assert_eq!(card, OwnScreen::new(Card::<0>(1)));
        assert_ne!(card, OwnScreen::new(Card::<0>(2)));
        assert_ne!(card, OwnScreen::new(Card::<1>(1)));
    }
}
