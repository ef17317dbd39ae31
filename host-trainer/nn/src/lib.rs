//! Neural-network building blocks of the gpecnet trainer on candle (CPU): the seeded RNG
//! every initialisation and sample comes from ([`rng`]), MLPs ([`mlp`]), fused ops whose
//! forward and backward passes are bit-identical to candle's plain graph ([`ops`]), the thread
//! pool of their elementwise passes ([`pool`]) and Adam ([`optim`]).
//!
//! Depends on `gpecnet-reference` (the network description an MLP exports to).
pub mod mlp;
pub mod ops;
pub mod optim;
pub mod pool;
pub mod rng;
