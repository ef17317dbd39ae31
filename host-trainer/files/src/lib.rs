//! File handling shared by every stage of the gpecnet trainer, so that no command can lose a
//! file: bounded reads of user-given paths that never block on FIFOs ([`inpath`]), outputs
//! that never write over an input or anything but a regular file ([`outpath`]), run folders
//! with their lock and atomic writes ([`rundir`]), and CSV reading and writing ([`csvfile`]).
//!
//! The bottom of the trainer's crates: it depends on none of them.
pub mod csvfile;
pub mod inpath;
pub mod outpath;
pub mod rundir;
