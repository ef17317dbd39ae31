//! The replay's integration tests, one binary (each file a module).
mod common;
mod lines;
mod online;
mod pack;
mod shipped;
