//! The calibration the loop learns: per motion state and horizon, the two
//! radius multipliers (quantile tracking) and the experts' discounted losses
//! (exponentially weighted aggregation), with their bounds, reset, and a
//! byte form that survives a power cycle ([`Calibration::state`],
//! [`Calibration::restore`]).
//!
//! Every update is f32 arithmetic in the order written in the parent
//! module's docs ("The update rules"), so the state is the same bits on
//! every target.

use super::{Config, MotionState, OnlineError, BINS, EXPERTS, HORIZONS, LEVELS};
use crate::blob::CRC32;

/// Bytes of [`Calibration::state`]: a 12-byte header (magic `GPOL`, then one
/// byte each: version, bins, horizons, levels, experts, three reserved zeros), the multipliers
/// `[bin][horizon][level]` and the losses `[bin][horizon][expert]` as f32
/// little endian, the feedback counts `[bin]` as u32 little endian, and a
/// CRC-32/ISO-HDLC of everything before it (little endian).
pub const STATE_LEN: usize = 12 + 4 * (BINS * HORIZONS * (LEVELS + EXPERTS)) + 4 * BINS + 4;

/// The magic of a calibration state.
const STATE_MAGIC: [u8; 4] = *b"GPOL";
/// The layout version of a calibration state.
const STATE_VERSION: u8 = 1;

/// What the loop has learned (see the module docs). Its size does not depend
/// on the number of tracks: about 1.3 KiB.
#[derive(Clone, Debug, PartialEq)]
pub struct Calibration {
    config: Config,
    /// Radius multipliers `[bin][horizon − 1][level]` (level 0: r50, 1: r90).
    mult: [[[f32; LEVELS]; HORIZONS]; BINS],
    /// Discounted absolute errors `[bin][horizon − 1][expert]`.
    loss: [[[f32; EXPERTS]; HORIZONS]; BINS],
    /// Feedback updates applied per bin (saturating).
    feedback: [u32; BINS],
    /// The multipliers a reset returns to.
    initial: [f32; LEVELS],
    /// Per level, the factor after a miss, `expf(γ·(1 − α))`.
    up: [f32; LEVELS],
    /// Per level, the factor after a hit, `expf(−γ·α)`.
    down: [f32; LEVELS],
    /// The largest loss a cell can reach, `loss_cap / (1 − λ)`.
    loss_max: f32,
}

impl Calibration {
    /// A calibration starting from the multipliers `initial` (`[c50, c90]`,
    /// usually the blob's [`crate::Model::radius_scales`]) under `config`.
    /// [`OnlineError::BadConfig`] when the config fails
    /// [`Config::validate`] or `initial` is not within its multiplier bounds
    /// with `c50 ≤ c90`.
    pub fn new(config: Config, initial: [f32; LEVELS]) -> Result<Self, OnlineError> {
        config.validate()?;
        let [lo, hi] = config.multiplier_bounds;
        let in_bounds = |c: f32| c.is_finite() && lo <= c && c <= hi;
        if !(in_bounds(initial[0]) && in_bounds(initial[1]) && initial[0] <= initial[1]) {
            return Err(OnlineError::BadConfig);
        }
        let mut up = [0.0; LEVELS];
        let mut down = [0.0; LEVELS];
        for l in 0..LEVELS {
            up[l] = libm::expf(config.gamma * (1.0 - config.alpha[l]));
            down[l] = libm::expf(-(config.gamma * config.alpha[l]));
        }
        let loss_max = config.loss_cap / (1.0 - config.forgetting);
        let mut c = Calibration {
            config,
            mult: [[initial; HORIZONS]; BINS],
            loss: [[[0.0; EXPERTS]; HORIZONS]; BINS],
            feedback: [0; BINS],
            initial,
            up,
            down,
            loss_max,
        };
        c.reset();
        Ok(c)
    }

    /// The config it runs under.
    pub fn config(&self) -> &Config {
        &self.config
    }

    /// Forgets everything learned: every multiplier back to the initial
    /// ones, every loss back to its prior (0 for the model's point head,
    /// `expert_prior · h / 12` for each constant-velocity expert at horizon
    /// `h`), the feedback counts to 0.
    pub fn reset(&mut self) {
        self.mult = [[self.initial; HORIZONS]; BINS];
        for bin in self.loss.iter_mut() {
            for (h, cell) in bin.iter_mut().enumerate() {
                let prior = self.config.expert_prior * horizon_fraction(h + 1);
                *cell = [0.0, prior, prior, prior];
            }
        }
        self.feedback = [0; BINS];
    }

    /// The multipliers `[c50, c90]` of `state` at horizon `h` (1-based;
    /// `h` outside `1..=12` gives the initial ones).
    pub fn multipliers(&self, state: MotionState, h: usize) -> [f32; LEVELS] {
        let bin = self.bin(state);
        h.checked_sub(1)
            .and_then(|i| self.mult.get(bin).and_then(|b| b.get(i)))
            .copied()
            .unwrap_or(self.initial)
    }

    /// Feedback updates applied to `state`'s cells so far (saturating).
    pub fn feedback_count(&self, state: MotionState) -> u32 {
        self.feedback.get(self.bin(state)).copied().unwrap_or(0)
    }

    /// The experts' weights at horizon `h` (1-based) for a forecast in
    /// `state`: rule 3 of the module docs over the experts marked
    /// `available` (an unavailable one gets 0). Every weight is in `[0, 1]`
    /// and they sum to 1 up to rounding; with no expert available, all 0.
    pub fn weights(
        &self,
        state: MotionState,
        h: usize,
        available: [bool; EXPERTS],
    ) -> [f32; EXPERTS] {
        let mut w = [0.0f32; EXPERTS];
        let bin = self.bin(state);
        let Some(loss) = h
            .checked_sub(1)
            .and_then(|i| self.loss.get(bin).and_then(|b| b.get(i)))
        else {
            return w;
        };
        let mut m = f32::INFINITY;
        for (l, &a) in loss.iter().zip(&available) {
            if a && *l < m {
                m = *l;
            }
        }
        if !m.is_finite() {
            return w;
        }
        let eta = self.config.eta / horizon_fraction(h);
        let mut s = 0.0f32;
        for ((w, l), &a) in w.iter_mut().zip(loss).zip(&available) {
            if a {
                *w = libm::expf(-(eta * (*l - m)));
                s += *w;
            }
        }
        // The best expert contributes exp(0) = 1, so s >= 1.
        for w in w.iter_mut() {
            *w /= s;
        }
        w
    }

    /// Applies the feedback of one horizon of one forecast (rules 1 and 2 of
    /// the module docs): `miss_distance` is the distance from the issued
    /// point to the truth, `scale` the forecast's scale at that horizon
    /// (`> 0`), `errors` each expert's distance to the truth (ignored where
    /// `available` is false). Feedback that is not finite (a distance, the
    /// scale) changes nothing and returns `false`; with `Config::adapt` off
    /// nothing changes either.
    pub fn update(
        &mut self,
        state: MotionState,
        h: usize,
        miss_distance: f32,
        scale: f32,
        errors: [f32; EXPERTS],
        available: [bool; EXPERTS],
    ) -> bool {
        if !self.config.adapt {
            return false;
        }
        let ok = miss_distance.is_finite()
            && scale.is_finite()
            && scale > 0.0
            && errors
                .iter()
                .zip(&available)
                .all(|(e, &a)| !a || e.is_finite());
        let bin = self.bin(state);
        let Some(i) = h.checked_sub(1).filter(|&i| i < HORIZONS) else {
            return false;
        };
        if !ok {
            return false;
        }
        let [lo, hi] = self.config.multiplier_bounds;
        if let Some(cell) = self.mult.get_mut(bin).and_then(|b| b.get_mut(i)) {
            for (l, c) in cell.iter_mut().enumerate() {
                let radius = *c * scale;
                let f = if miss_distance <= radius {
                    self.down[l]
                } else {
                    self.up[l]
                };
                // Comparisons, not `f32::clamp`: its check of the bounds' order (which
                // `Config::validate` already made) links float formatting into a firmware
                // image, about 12 KB of flash; the result is the same, NaN included.
                let v = *c * f;
                *c = if v < lo {
                    lo
                } else if v > hi {
                    hi
                } else {
                    v
                };
            }
            // The median radius never exceeds the 90 % one.
            if cell[0] > cell[1] {
                cell[0] = cell[1];
            }
        }
        let (lambda, cap, max) = (self.config.forgetting, self.config.loss_cap, self.loss_max);
        if let Some(cell) = self.loss.get_mut(bin).and_then(|b| b.get_mut(i)) {
            for ((l, &e), &a) in cell.iter_mut().zip(&errors).zip(&available) {
                if a {
                    *l = (lambda * *l + e.min(cap)).min(max);
                }
            }
        }
        if let Some(n) = self.feedback.get_mut(bin) {
            *n = n.saturating_add(1);
        }
        true
    }

    /// Writes the calibration into `out` (at least [`STATE_LEN`] bytes;
    /// layout at [`STATE_LEN`]) and returns the bytes written.
    /// [`OnlineError::BufferTooSmall`] when `out` is shorter.
    pub fn state(&self, out: &mut [u8]) -> Result<usize, OnlineError> {
        let out = out
            .get_mut(..STATE_LEN)
            .ok_or(OnlineError::BufferTooSmall)?;
        let mut w = Writer { out, at: 0 };
        w.bytes(&STATE_MAGIC);
        w.bytes(&[STATE_VERSION, BINS as u8, HORIZONS as u8, LEVELS as u8]);
        w.bytes(&[EXPERTS as u8, 0, 0, 0]);
        for v in self.mult.iter().flatten().flatten() {
            w.bytes(&v.to_le_bytes());
        }
        for v in self.loss.iter().flatten().flatten() {
            w.bytes(&v.to_le_bytes());
        }
        for v in &self.feedback {
            w.bytes(&v.to_le_bytes());
        }
        let crc = CRC32.checksum(w.out.get(..w.at).unwrap_or(&[]));
        w.bytes(&crc.to_le_bytes());
        Ok(w.at)
    }

    /// Replaces the learned part (multipliers, losses, feedback counts) by
    /// `bytes` written by [`Calibration::state`], after checking all of it:
    /// length, magic, version, shape, CRC, and every value within the bounds
    /// this calibration's config keeps (finite multipliers within
    /// `multiplier_bounds` with `c50 ≤ c90`, losses in `[0, loss_cap/(1 −
    /// λ)]`). On any error nothing changes.
    pub fn restore(&mut self, bytes: &[u8]) -> Result<(), OnlineError> {
        if bytes.len() != STATE_LEN {
            return Err(OnlineError::StateLength);
        }
        let (body, crc) = bytes.split_at(STATE_LEN - 4);
        if body.get(..4) != Some(&STATE_MAGIC[..]) {
            return Err(OnlineError::StateMagic);
        }
        if body.get(4) != Some(&STATE_VERSION) {
            return Err(OnlineError::StateVersion);
        }
        let shape = [BINS as u8, HORIZONS as u8, LEVELS as u8, EXPERTS as u8];
        if body.get(5..9) != Some(&shape[..]) || body.get(9..12) != Some(&[0, 0, 0][..]) {
            return Err(OnlineError::StateShape);
        }
        if u32::from_le_bytes(le4(crc)) != CRC32.checksum(body) {
            return Err(OnlineError::StateCrc);
        }
        let mut r = Reader {
            bytes: body,
            at: 12,
        };
        let mut next = self.clone();
        let [lo, hi] = self.config.multiplier_bounds;
        for cell in next.mult.iter_mut().flatten() {
            for c in cell.iter_mut() {
                *c = f32::from_le_bytes(r.le4());
                if !(c.is_finite() && lo <= *c && *c <= hi) {
                    return Err(OnlineError::StateValue);
                }
            }
            if cell[0] > cell[1] {
                return Err(OnlineError::StateValue);
            }
        }
        for l in next.loss.iter_mut().flatten().flatten() {
            *l = f32::from_le_bytes(r.le4());
            if !(l.is_finite() && 0.0 <= *l && *l <= self.loss_max.max(self.config.expert_prior)) {
                return Err(OnlineError::StateValue);
            }
        }
        for n in next.feedback.iter_mut() {
            *n = u32::from_le_bytes(r.le4());
        }
        *self = next;
        Ok(())
    }

    /// The index of `state`'s cells (0 for every state without motion bins).
    fn bin(&self, state: MotionState) -> usize {
        if self.config.motion_bins {
            state as usize
        } else {
            0
        }
    }
}

/// `h / 12` in f32 (the scale of horizon `h` relative to the endpoint's).
pub(crate) fn horizon_fraction(h: usize) -> f32 {
    h as f32 / HORIZONS as f32
}

/// Four bytes of `b` (zeros where it is shorter).
fn le4(b: &[u8]) -> [u8; 4] {
    let mut o = [0; 4];
    for (o, b) in o.iter_mut().zip(b) {
        *o = *b;
    }
    o
}

/// Appends to a byte buffer known to be long enough ([`STATE_LEN`]).
struct Writer<'a> {
    out: &'a mut [u8],
    at: usize,
}

impl Writer<'_> {
    fn bytes(&mut self, b: &[u8]) {
        if let Some(o) = self.out.get_mut(self.at..self.at + b.len()) {
            o.copy_from_slice(b);
        }
        self.at += b.len();
    }
}

/// Reads little-endian words from a state already checked for length.
struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl Reader<'_> {
    fn le4(&mut self) -> [u8; 4] {
        let v = le4(self.bytes.get(self.at..).unwrap_or(&[]));
        self.at += 4;
        v
    }
}
