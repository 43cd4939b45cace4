//! The staircase's results view: none (a test-only template); the window
//! shows its object of `summary.json` as a tree.

use crate::kinds::figures::ResultsView;

/// No figures: the window's tree of the object stands instead.
pub const VIEW: Option<ResultsView> = None;
