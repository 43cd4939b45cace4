//! The staircase's results view: none, as it has no analysis (no object
//! of `summary.json`); the window shows any object under its name as a
//! tree.

use crate::kinds::figures::ResultsView;

/// No figures: the window's tree of the object stands instead.
pub const VIEW: Option<ResultsView> = None;
