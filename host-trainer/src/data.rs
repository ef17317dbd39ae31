//! TrajNet loading (owned by the data work).
