//! Adaptive methods (being written).
