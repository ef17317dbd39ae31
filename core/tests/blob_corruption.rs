//! The blob reader's contract: every byte string gives `Ok` or a typed error,
//! never a panic or an out-of-bounds read.
use crate::common;

use common::*;
use gpecnet_core::blob::{
    Activation, NetworkId, NumericKind, FORMAT_VERSION, MAX_LAYERS, MIN_FORMAT_VERSION,
};
use gpecnet_core::{BlobError, Model};

#[test]
fn valid_blob_parses() {
    let blob = small_blob();
    let m = Model::from_blob(&blob).unwrap();
    assert_eq!(m.name(), "test-small");
    assert_eq!(m.config().fdim, 4);
    assert_eq!(m.encoder_past().len(), 2);
    assert_eq!(m.decoder().out_dim(), 2);
    assert!(m.has_predictor());
    assert_eq!(m.max_width(), 22);
    let params: usize = small_nets(Activation::Sine)
        .iter()
        .flatten()
        .map(|l| (l.weights.len() + l.bias.len()) / 4)
        .sum();
    assert_eq!(m.parameter_count(), params);
    assert_eq!(
        m.crc(),
        u32::from_le_bytes(blob[blob.len() - 4..].try_into().unwrap())
    );
}

#[test]
fn every_truncation_and_bit_flip_is_rejected() {
    let counts = assert_damage_rejected(&small_blob());
    assert_eq!(counts[0], 32, "{counts:?}");
}

#[test]
fn every_bit_flip_with_valid_checksum_never_panics() {
    // The CRC hides structural damage from the parser; remove that shield and
    // make sure the parser itself still answers with an error or a model.
    let blob = small_blob();
    let body_len = blob.len() - 4;
    for byte in 6..body_len {
        for bit in 0..8 {
            let mut b = blob[..body_len].to_vec();
            b[byte] ^= 1 << bit;
            let b = seal(b);
            if let Ok(m) = Model::from_blob(&b) {
                // Only a weight or hyper-parameter value changed: still a consistent model.
                assert!(m.max_width() <= 22);
            }
        }
    }
}

#[test]
fn random_bytes_never_panic() {
    let mut next = xorshift32(0x1234_5678);
    for len in 0..2_000usize {
        let mut b: Vec<u8> = (0..len % 300).map(|_| next() as u8).collect();
        if len % 2 == 0 && b.len() >= 6 {
            b[..4].copy_from_slice(b"GPEC");
            b[4] = 1;
            b = seal(b);
        }
        let _ = Model::from_blob(&b);
    }
}

fn with(
    config_edit: impl Fn(&mut gpecnet_core::ModelConfig),
    nets_edit: impl Fn(&mut [Vec<WireLayer>; 4]),
) -> Result<(), Refused> {
    let mut c = config();
    config_edit(&mut c);
    let mut nets = small_nets(Activation::Sine);
    nets_edit(&mut nets);
    try_encode("edited", c, &nets).map(|_| ())
}

#[test]
fn error_paths() {
    assert_eq!(
        Model::from_blob(b"XPEC\x01").unwrap_err(),
        BlobError::BadMagic
    );
    assert_eq!(Model::from_blob(b"GPE").unwrap_err(), BlobError::Truncated);
    assert_eq!(Model::from_blob(b"GPX").unwrap_err(), BlobError::BadMagic);
    assert_eq!(Model::from_blob(b"GPEC").unwrap_err(), BlobError::Truncated);
    // Versions outside MIN_FORMAT_VERSION..=FORMAT_VERSION are refused as such.
    for v in [0u16, FORMAT_VERSION + 1, 0xffff] {
        let b = with_version(&small_blob(), v);
        assert_eq!(
            Model::from_blob(&b).unwrap_err(),
            BlobError::UnsupportedVersion(v)
        );
    }
    // Each version has its own layout (2 adds extensions and a fifth network, 3 aligns the
    // tensors): the writer's bytes labelled as any other version fail to decode.
    let blob = small_blob();
    for v in (MIN_FORMAT_VERSION..=FORMAT_VERSION).filter(|&v| v != version_of(&blob)) {
        assert!(Model::from_blob(&with_version(&blob, v)).is_err(), "as {v}");
    }

    let mut bad_crc = small_blob();
    let n = bad_crc.len();
    bad_crc[n - 1] ^= 0x80;
    assert!(matches!(
        Model::from_blob(&bad_crc).unwrap_err(),
        BlobError::ChecksumMismatch { .. }
    ));

    let mut trailing = small_blob();
    trailing.truncate(trailing.len() - 4);
    trailing.push(0);
    assert_eq!(
        Model::from_blob(&seal(trailing)).unwrap_err(),
        BlobError::TrailingBytes
    );

    // Config out of range.
    assert_eq!(
        with(|c| c.data_scale = 0.0, |_| ()),
        refused(BlobError::BadConfig)
    );
    assert_eq!(
        with(|c| c.sigma = f32::NAN, |_| ()),
        refused(BlobError::BadConfig)
    );
    assert_eq!(
        with(|c| c.initial_pos_divisor = -1.0, |_| ()),
        refused(BlobError::BadConfig)
    );
    assert_eq!(with(|c| c.zdim = 0, |_| ()), refused(BlobError::BadConfig));
    assert_eq!(
        with(|c| c.past_len = 40, |_| ()),
        refused(BlobError::ExceedsCapacity)
    );
    // Shapes.
    assert_eq!(
        with(|c| c.fdim = 5, |_| ()),
        refused(BlobError::ShapeMismatch(NetworkId::EncoderPast))
    );
    assert_eq!(
        with(|c| c.zdim = 4, |_| ()),
        refused(BlobError::ShapeMismatch(NetworkId::Decoder))
    );
    assert_eq!(
        with(|c| c.future_len = 10, |_| ()),
        refused(BlobError::ShapeMismatch(NetworkId::Predictor))
    );
    assert_eq!(
        with(
            |_| (),
            |n| n[1][1] = layer(4, 2, Activation::Linear, 9, 1.0)
        ),
        refused(BlobError::ShapeMismatch(NetworkId::Decoder))
    );
    assert_eq!(
        with(
            |_| (),
            |n| {
                n[1][0].weights.drain(..4);
            }
        ),
        refused(BlobError::ShapeMismatch(NetworkId::Decoder))
    );
    assert_eq!(
        with(
            |_| (),
            |n| {
                n[0][0].bias.extend(0f32.to_le_bytes());
            }
        ),
        refused(BlobError::ShapeMismatch(NetworkId::EncoderPast))
    );
    assert_eq!(
        with(|_| (), |n| n[2].clear()),
        refused(BlobError::ShapeMismatch(NetworkId::EncoderDest))
    );
    assert_eq!(
        with(|_| (), |n| n[3].clear()),
        refused(BlobError::ShapeMismatch(NetworkId::Predictor))
    );
    assert_eq!(
        with(|_| (), |n| n[0].clear()),
        refused(BlobError::ShapeMismatch(NetworkId::EncoderPast))
    );
    assert_eq!(
        with(|_| (), |n| n[1][0].out_dim = 0),
        refused(BlobError::ShapeMismatch(NetworkId::Decoder))
    );
    // Endpoint-only models are valid.
    assert_eq!(
        with(
            |_| (),
            |n| {
                n[2].clear();
                n[3].clear();
            }
        ),
        Ok(())
    );
    // Non-finite weights.
    assert_eq!(
        with(
            |_| (),
            |n| set(&mut n[3][1].weights, 7, f32::INFINITY.to_le_bytes())
        ),
        refused(BlobError::NonFinite(NetworkId::Predictor))
    );
    assert_eq!(
        with(
            |_| (),
            |n| set(&mut n[0][0].bias, 0, f32::NAN.to_le_bytes())
        ),
        refused(BlobError::NonFinite(NetworkId::EncoderPast))
    );
    // Capacity.
    let too_many = |n: &mut [Vec<WireLayer>; 4]| {
        n[0] = (0..=MAX_LAYERS)
            .map(|i| layer(16, 16, Activation::Sine, i as u32, 0.1))
            .collect();
        n[0].push(layer(16, 4, Activation::Linear, 99, 0.1));
    };
    assert_eq!(with(|_| (), too_many), refused(BlobError::ExceedsCapacity));
}

#[test]
fn malformed_values_are_typed() {
    // `small_blob` with byte `at` replaced by `v`, the CRC recomputed.
    let patched = |at: usize, v: u8| {
        let mut b = small_blob();
        b[at] = v;
        Model::from_blob(&reseal(&b)).map(|_| ())
    };
    // Bad enum tag for the numeric kind (the byte right after the preamble).
    assert_eq!(patched(5, 7).unwrap_err(), BlobError::Malformed);
    // Invalid UTF-8 in the name (name length at [6], bytes from [7]).
    assert_eq!(patched(7, 0xff).unwrap_err(), BlobError::Malformed);
    // A name length running past the end.
    assert!(patched(6, 0x7f).is_err());
}

#[test]
fn byte_level_prefix_matches_format_md() {
    // The example in weights/FORMAT.md: preamble, numeric kind, name.
    let b = small_blob();
    assert_eq!(&b[..4], b"GPEC");
    // The writer's format version, one varint byte.
    assert!((MIN_FORMAT_VERSION..=FORMAT_VERSION).contains(&u16::from(b[4])));
    assert_eq!(b[5], 0x00); // NumericKind::F32
    assert_eq!(b[6], 10); // name length
    assert_eq!(&b[7..17], b"test-small");
    assert_eq!(b[17], 8); // past_len (u8, raw)
    assert_eq!(b[18], 12); // future_len
    assert_eq!(b[19], 4); // fdim varint
    assert_eq!(b[20], 3); // zdim varint
    assert_eq!(&b[21..25], &1.86f32.to_le_bytes()); // data_scale
}

#[test]
#[ignore = "prints the FORMAT.md example; run with --ignored --nocapture"]
fn print_format_example() {
    let b = small_blob();
    for (i, chunk) in b[..40].chunks(8).enumerate() {
        let hex: Vec<String> = chunk.iter().map(|x| format!("{x:02x}")).collect();
        println!("{:04x}: {}", i * 8, hex.join(" "));
    }
    println!("len {}", b.len());
}

/// Format 2 (extensions + point head): it parses, every truncation and every single bit flip
/// (with and without a re-computed CRC) gives `Ok` or a typed error, and whatever parses
/// predicts without panicking.
#[test]
fn format2_blob_survives_truncation_and_bit_flips() {
    use gpecnet_core::{LibmSine, Predictor};
    let blob = encode_v2("v2", &small_nets(Activation::Sine), 1, 24);
    let m = Model::from_blob(&blob).unwrap();
    assert!(m.has_point_head());
    assert_eq!(m.extensions().heading_steps, 1);
    assert_eq!(m.extensions().tts_samples, 24);
    let past: Vec<[f32; 2]> = (0..8).map(|t| [3.0 * t as f32, 1.0 - t as f32]).collect();
    let mut p = Predictor::<LibmSine, 32>::new(m).unwrap();
    assert_eq!(p.predict_point(&past).unwrap().len(), 12);
    let mut ends = [[0.0f32; 2]; 20];
    p.predict_endpoint_set::<32>(&past, 3, &mut ends).unwrap();
    assert!(ends.iter().flatten().all(|v| v.is_finite()));
    // Fewer samples than the blob asks for: refused, not truncated silently.
    assert!(p.predict_endpoint_set::<16>(&past, 3, &mut ends).is_err());
    for n in 0..blob.len() {
        assert!(Model::from_blob(&blob[..n]).is_err(), "len {n}");
        let _ = Model::from_blob(&seal(blob[..n.saturating_sub(4)].to_vec()));
    }
    for i in 0..blob.len() * 8 {
        let mut b = blob.clone();
        b[i / 8] ^= 1 << (i % 8);
        assert!(Model::from_blob(&b).is_err(), "bit {i}");
        if let Ok(m) = Model::from_blob(&reseal(&b)) {
            if let Ok(mut p) = Predictor::<LibmSine, 32>::new(m) {
                let _ = p.predict_point(&past);
                let _ = p.predict_endpoint_set::<64>(&past, 1, &mut ends);
            }
        }
    }
}

/// Format 4 (the description record): the writer emits it only when given a `Meta`, the
/// reader returns unit, period, data and licence, older versions read as `Meta::UNKNOWN`,
/// every rule of the record is a typed `BadConfig`, and damage is refused like any other.
#[test]
fn format4_meta_is_read_checked_and_optional() {
    use gpecnet_core::blob::{Meta, PositionUnit, MAX_META_TEXT};
    let meta = Meta {
        unit: PositionUnit::Metre,
        metres_per_pixel: 0.0,
        period_s: 0.4,
        data: "SDD in metres",
        licence: "CC BY-NC-SA 3.0",
    };
    let write_meta = |meta: Meta<'_>| {
        let head = gpecnet_blob_writer::BlobHead {
            numeric: NumericKind::F32,
            name: "v4",
            config: config(),
            extensions: None,
            meta: Some(meta),
        };
        let [a, b, c, d] = &small_nets(Activation::Sine);
        gpecnet_blob_writer::blob_bytes(&head, [a, b, c, d, &[]]).map_err(|e| match e {
            gpecnet_blob_writer::WriteError::Rejected { reason, .. } => reason,
            other => panic!("the writer failed before the reader: {other}"),
        })
    };
    let blob = write_meta(meta).unwrap();
    assert_eq!(version_of(&blob), 4);
    assert!(Model::from_blob(&blob).is_ok());
    assert_eq!(Meta::of_blob(&blob), Ok(meta));
    assert_eq!(Meta::of_blob(&blob).unwrap().period(), Some(0.4));
    // Without a Meta: version 3, and nothing stated.
    let v3 = small_blob();
    assert_eq!(version_of(&v3), 3);
    let old = Meta::of_blob(&v3).unwrap();
    assert_eq!(old, Meta::UNKNOWN);
    assert_eq!((old.unit, old.period()), (PositionUnit::Unknown, None));
    // A damaged blob has no description either.
    let mut bad = blob.clone();
    let last = bad.len() - 1;
    bad[last] ^= 1;
    assert!(Meta::of_blob(&bad).is_err());
    // A pixel model with one scale says so.
    let px = Meta {
        unit: PositionUnit::Pixel,
        metres_per_pixel: 0.04,
        ..meta
    };
    let px_blob = write_meta(px).unwrap();
    assert_eq!(Meta::of_blob(&px_blob).unwrap().metres_per_pixel, 0.04);
    // The record's rules.
    let long = "x".repeat(MAX_META_TEXT + 1);
    for bad in [
        Meta {
            unit: PositionUnit::Unknown,
            ..meta
        },
        Meta {
            metres_per_pixel: 0.04,
            ..meta
        },
        Meta {
            unit: PositionUnit::Pixel,
            metres_per_pixel: f32::NAN,
            ..meta
        },
        Meta {
            unit: PositionUnit::Pixel,
            metres_per_pixel: -1.0,
            ..meta
        },
        Meta {
            period_s: 0.0,
            ..meta
        },
        Meta {
            period_s: f32::INFINITY,
            ..meta
        },
        Meta {
            period_s: 61.0,
            ..meta
        },
        Meta {
            data: &long,
            ..meta
        },
        Meta {
            licence: &long,
            ..meta
        },
    ] {
        assert_eq!(
            write_meta(bad).unwrap_err(),
            BlobError::BadConfig.to_string(),
            "{bad:?}"
        );
    }
    // Damage to a version-4 blob is refused like any other.
    let [magic, ..] = assert_damage_rejected(&blob);
    assert!(magic > 0);
}
