//! Metrics (owned by the data work).
