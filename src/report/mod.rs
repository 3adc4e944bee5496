//! Measurements of results (`../shared/design/MEASURING.md`): error metrics per frame.

pub mod metrics;
pub mod timings;
