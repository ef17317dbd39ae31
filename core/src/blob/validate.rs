//! The rules a parsed blob must meet (`weights/FORMAT.md`, "Shape rules"
//! and the fixed-point extra rules): dims chain, tensor lengths are exact,
//! f32 values are finite, fixed-point exponents and shifts are in range.

use super::{
    pow2, Activation, BlobError, Model, Network, NetworkId, NumericKind, AFFINE_SHIFTS, MAX_EXP,
    MAX_FUTURE, MAX_PAST, MAX_PROPOSAL_LATENTS, MAX_TTS_SAMPLES, MIN_EXP, SINE_SHIFTS,
};

pub(super) fn validate(m: &Model<'_>) -> Result<(), BlobError> {
    let c = &m.config;
    let finite = [c.data_scale, c.sigma, c.initial_pos_divisor, c.w0]
        .iter()
        .all(|v| v.is_finite());
    if !finite || c.data_scale <= 0.0 || c.sigma < 0.0 || c.initial_pos_divisor <= 0.0 {
        return Err(BlobError::BadConfig);
    }
    if c.past_len < 2 || c.future_len < 2 || c.fdim == 0 || c.zdim == 0 {
        return Err(BlobError::BadConfig);
    }
    if c.past_len as usize > MAX_PAST || c.future_len as usize > MAX_FUTURE {
        return Err(BlobError::ExceedsCapacity);
    }
    let (fdim, zdim) = (c.fdim as usize, c.zdim as usize);
    let q = m.numeric;
    check_network(
        &m.encoder_past,
        NetworkId::EncoderPast,
        2 * c.past_len as usize,
        fdim,
        q,
    )?;
    check_network(&m.decoder, NetworkId::Decoder, fdim + zdim, 2, q)?;
    match (m.encoder_dest.is_empty(), m.predictor.is_empty()) {
        (true, true) => {}
        (false, false) => {
            let ddim = m.encoder_dest.out_dim();
            check_network(&m.encoder_dest, NetworkId::EncoderDest, 2, ddim, q)?;
            let out = 2 * (c.future_len as usize - 1);
            check_network(&m.predictor, NetworkId::Predictor, fdim + ddim + 2, out, q)?;
        }
        (true, false) => return Err(BlobError::ShapeMismatch(NetworkId::EncoderDest)),
        (false, true) => return Err(BlobError::ShapeMismatch(NetworkId::Predictor)),
    }
    if !m.point_head.is_empty() {
        let (p2, f2) = (2 * c.past_len as usize, 2 * c.future_len as usize);
        check_network(&m.point_head, NetworkId::PointHead, p2, f2, q)?;
    }
    check_proposal(m)?;
    let e = &m.ext;
    if e.heading_steps >= c.past_len || e.tts_init > 1 {
        return Err(BlobError::BadConfig);
    }
    if e.tts_samples as usize > MAX_TTS_SAMPLES {
        return Err(BlobError::ExceedsCapacity);
    }
    if q == NumericKind::Int16Q15 {
        check_boundary_exps(m)?;
    }
    Ok(())
}

/// The latent proposal (format version 5): present exactly when the bound
/// is (a finite value > 0, and +0.0 without a proposal; else
/// [`BlobError::BadConfig`]), `fdim → K·zdim`
/// with `1 ≤ K ≤` [`MAX_PROPOSAL_LATENTS`] and a linear last layer
/// ([`BlobError::ShapeMismatch`]), and never together with test-time
/// sampling (one endpoint protocol per model: [`BlobError::BadConfig`]).
///
/// Endpoint probabilities (format version 6): the radius multipliers
/// `[r50, r90]` are both +0.0 (none), or finite with `0 < r50 ≤ r90` on a
/// proposal model with a point-forecast head (the radii are around its
/// forecast; else [`BlobError::BadConfig`]); the last layer then has
/// `K·(zdim + 1)` rows, the `K` logits after the latents.
fn check_proposal(m: &Model<'_>) -> Result<(), BlobError> {
    let b = m.latent_bound;
    let [r50, r90] = m.radius_scales;
    let unscored = r50.to_bits() == 0 && r90.to_bits() == 0;
    if m.proposal.is_empty() {
        // +0.0 only: one encoding per blob (a -0.0 would not re-write to itself).
        return if b.to_bits() == 0 && unscored {
            Ok(())
        } else {
            Err(BlobError::BadConfig)
        };
    }
    if !(b.is_finite() && b > 0.0) || m.ext.tts_samples != 0 {
        return Err(BlobError::BadConfig);
    }
    let scored_ok = r90.is_finite() && r50 > 0.0 && r50 <= r90 && !m.point_head.is_empty();
    if !unscored && !scored_ok {
        return Err(BlobError::BadConfig);
    }
    let (fdim, zdim) = (m.config.fdim as usize, m.config.zdim as usize);
    let zdim = zdim + usize::from(!unscored);
    let out = m.proposal.out_dim();
    let k = out / zdim;
    let last_linear = m
        .proposal
        .layers()
        .last()
        .is_some_and(|l| l.activation == Activation::Linear);
    if !out.is_multiple_of(zdim) || k == 0 || k > MAX_PROPOSAL_LATENTS || !last_linear {
        return Err(BlobError::ShapeMismatch(NetworkId::Proposal));
    }
    check_network(&m.proposal, NetworkId::Proposal, fdim, out, m.numeric)
}

/// Exponent of a network's input (first layer) and output (last layer).
fn net_exps(net: &Network<'_>) -> (i8, i8) {
    (
        net.layers().next().map_or(0, |l| l.in_exp),
        net.layers().last().map_or(0, |l| l.out_exp),
    )
}

/// Fixed point: the vectors handed between networks share one exponent
/// (features = decoder input = encoder_dest output = predictor input;
/// decoder output = encoder_dest input), so no rescaling happens between them.
fn check_boundary_exps(m: &Model<'_>) -> Result<(), BlobError> {
    let (_, f) = net_exps(&m.encoder_past);
    let (d_in, d_out) = net_exps(&m.decoder);
    if d_in != f {
        return Err(BlobError::BadScale(NetworkId::Decoder));
    }
    if !m.predictor.is_empty() {
        let (g_in, g_out) = net_exps(&m.encoder_dest);
        if g_in != d_out || g_out != f {
            return Err(BlobError::BadScale(NetworkId::EncoderDest));
        }
        if net_exps(&m.predictor).0 != f {
            return Err(BlobError::BadScale(NetworkId::Predictor));
        }
    }
    // The point head reads the same quantised input vector as encoder_past.
    if !m.point_head.is_empty() && net_exps(&m.point_head).0 != net_exps(&m.encoder_past).0 {
        return Err(BlobError::BadScale(NetworkId::PointHead));
    }
    // The proposal reads the features; its output and the decoder's input
    // (the feature exponent) must both hold ±bound, so saturation only ever
    // meets values the clamp cuts to the bound anyway: nothing is clipped
    // that the format does not say.
    if !m.proposal.is_empty() {
        let (p_in, p_out) = net_exps(&m.proposal);
        let holds = |e: i8| m.latent_bound <= 32767.0 * pow2(-(e as i32));
        if p_in != f || !holds(d_in) || !holds(p_out) {
            return Err(BlobError::BadScale(NetworkId::Proposal));
        }
    }
    Ok(())
}

/// Fixed point: exponents in range and chaining, shifts in range, `Sine`
/// layers output Q15.
fn check_scales(net: &Network<'_>, id: NetworkId) -> Result<(), BlobError> {
    let bad = Err(BlobError::BadScale(id));
    let mut prev: Option<i8> = None;
    for l in net.layers() {
        let exps_ok =
            (MIN_EXP..=MAX_EXP).contains(&l.in_exp) && (MIN_EXP..=MAX_EXP).contains(&l.out_exp);
        if !exps_ok || prev.is_some_and(|p| p != l.in_exp) {
            return bad;
        }
        let range = match l.activation {
            Activation::Sine => {
                if l.out_exp != 15 {
                    return bad;
                }
                SINE_SHIFTS
            }
            Activation::Linear | Activation::Relu => AFFINE_SHIFTS,
        };
        if !l.shifts.iter().all(|&s| range.contains(&(s as i8))) {
            return bad;
        }
        prev = Some(l.out_exp);
    }
    Ok(())
}

fn check_network(
    net: &Network<'_>,
    id: NetworkId,
    input: usize,
    output: usize,
    numeric: NumericKind,
) -> Result<(), BlobError> {
    if net.is_empty() || net.in_dim() != input || net.out_dim() != output || output == 0 {
        return Err(BlobError::ShapeMismatch(id));
    }
    let mut width = input;
    for l in net.layers() {
        if l.in_dim != width || l.out_dim == 0 {
            return Err(BlobError::ShapeMismatch(id));
        }
        let wsize = match numeric {
            NumericKind::F32 => 4,
            NumericKind::Int16Q15 => 2,
        };
        let n = l
            .in_dim
            .checked_mul(l.out_dim)
            .and_then(|n| n.checked_mul(wsize));
        let shifts_len = match numeric {
            NumericKind::F32 => 0,
            NumericKind::Int16Q15 => l.out_dim,
        };
        if n != Some(l.weights.len())
            || l.bias.len() != l.out_dim * 4
            || l.shifts.len() != shifts_len
        {
            return Err(BlobError::ShapeMismatch(id));
        }
        if numeric == NumericKind::Int16Q15 {
            // Every i16 / i32 bit pattern is a valid value.
            width = l.out_dim;
            continue;
        }
        let all_finite = l
            .weights
            .chunks_exact(4)
            .chain(l.bias.chunks_exact(4))
            .all(|b| match b {
                &[a, b, c, d] => f32::from_le_bytes([a, b, c, d]).is_finite(),
                _ => false,
            });
        if !all_finite {
            return Err(BlobError::NonFinite(id));
        }
        width = l.out_dim;
    }
    if numeric == NumericKind::Int16Q15 {
        check_scales(net, id)?;
    }
    Ok(())
}
