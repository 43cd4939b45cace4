//! frictionlab's psychophysics, pure (no clock, no file; randomness is a
//! seeded RNG argument):
//! - [`psychometric`]: the two-interval forced-choice psychometric
//!   functions (Weibull, logistic, cumulative normal) and the threshold at
//!   a criterion;
//! - [`fit`]: their maximum-likelihood fit with the lapse rate free within
//!   a bound, and parametric-bootstrap intervals on the threshold;
//! - [`adaptive`]: the adaptive methods that choose each trial's stimulus
//!   from the answers so far: transformed up-down staircases (1-up-n-down,
//!   with Kaernbach's weighted steps) and QUEST+ (Watson 2017).
//! - [`decimal`]: values derived from a design's decimals, computed on
//!   those decimals (issue 42).

pub mod adaptive;
pub mod decimal;
pub mod fit;
pub mod psychometric;
