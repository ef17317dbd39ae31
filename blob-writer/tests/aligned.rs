//! Format version 3 (`weights/FORMAT.md`): every weight and bias tensor of the shipped
//! blobs starts at a multiple of `TENSOR_ALIGN` bytes from the blob's start; the padding is
//! canonical (anything else is `Malformed`); version-2 blobs with the same tensors are
//! still read and re-write to the same version-3 bytes; a blob at an odd address still
//! validates (only the Cortex-M kernels' word-load paths depend on alignment).

use gpecnet_core::blob::{
    LayerWire, LayerWireQ, ModelInfo, Network, Preamble, CRC32, FORMAT_VERSION, MAGIC, TENSOR_ALIGN,
};
use gpecnet_core::{BlobError, Model, NumericKind};

/// The shipped blobs, without the signature trailer of those that are signed (the trailer
/// follows the blob; `gpecnet_core::blob::signed`).
fn shipped() -> Vec<(String, Vec<u8>)> {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../weights");
    let mut v: Vec<_> = [
        "sdd-tiny",
        "sdd-tiny-qe",
        "sdd-tiny-v2",
        "sdd-tiny-v2-qe",
        "sdd-small-q",
    ]
    .iter()
    .map(|n| {
        let bytes = std::fs::read(dir.join(format!("{n}.gpec"))).unwrap();
        let unsigned = gpecnet_core::blob::signed::split(&bytes)
            .map_or(&bytes[..], |(blob, _, _)| blob)
            .to_vec();
        (n.to_string(), unsigned)
    })
    .collect();
    v.sort();
    v
}

fn nets<'a>(m: &'a Model<'a>) -> [&'a Network<'a>; 5] {
    [
        m.encoder_past(),
        m.decoder(),
        m.encoder_dest(),
        m.predictor(),
        m.point_head(),
    ]
}

/// Offsets of every weight and bias tensor from the blob's start.
fn offsets(blob: &[u8]) -> Vec<usize> {
    let m = Model::from_blob(blob).unwrap();
    nets(&m)
        .iter()
        .flat_map(|n| n.layers())
        .flat_map(|l| {
            let (w, b, _) = l.tensors_q();
            [
                w.as_ptr() as usize - blob.as_ptr() as usize,
                b.as_ptr() as usize - blob.as_ptr() as usize,
            ]
        })
        .collect()
}

#[test]
fn shipped_blobs_are_version_3_or_4_with_aligned_tensors() {
    for (name, blob) in shipped() {
        // Version 4 exactly when the blob states its unit (the models trained since).
        let states_unit = gpecnet_core::blob::Meta::of_blob(&blob).unwrap().unit
            != gpecnet_core::blob::PositionUnit::Unknown;
        let want = if states_unit {
            FORMAT_VERSION
        } else {
            gpecnet_core::blob::ALIGNED_FORMAT_VERSION
        };
        assert_eq!(blob[4] as u16, want, "{name}");
        let offs = offsets(&blob);
        assert!(!offs.is_empty());
        assert!(
            offs.iter().all(|o| o % TENSOR_ALIGN == 0),
            "{name}: {offs:?}"
        );
        // Rewriting is the identity on a version-3 or 4 blob (canonical padding).
        assert_eq!(
            gpecnet_blob_writer::rewrite_blob(&blob).unwrap(),
            blob,
            "{name}"
        );
    }
}

/// The same model in format version 2 (no padding), written with the version-2 wire structs.
fn as_version_2(blob: &[u8]) -> Vec<u8> {
    let m = Model::from_blob(blob).unwrap();
    let mut out = postcard::to_allocvec(&Preamble {
        magic: MAGIC,
        version: 2,
    })
    .unwrap();
    let info = ModelInfo {
        numeric: m.numeric(),
        name: m.name(),
        config: *m.config(),
    };
    out.extend(postcard::to_allocvec(&info).unwrap());
    out.extend(postcard::to_allocvec(m.extensions()).unwrap());
    for net in nets(&m) {
        out.push(net.len() as u8);
        for l in net.layers() {
            let (weights, bias, shifts) = l.tensors_q();
            let (in_dim, out_dim, activation) =
                (l.in_dim() as u16, l.out_dim() as u16, l.activation());
            out.extend(
                match m.numeric() {
                    NumericKind::F32 => postcard::to_allocvec(&LayerWire {
                        in_dim,
                        out_dim,
                        activation,
                        weights,
                        bias,
                    }),
                    NumericKind::Int16Q15 => postcard::to_allocvec(&LayerWireQ {
                        in_dim,
                        out_dim,
                        activation,
                        in_exp: l.in_exp(),
                        out_exp: l.out_exp(),
                        weights,
                        bias,
                        shifts,
                    }),
                }
                .unwrap(),
            );
        }
    }
    let crc = CRC32.checksum(&out);
    out.extend(crc.to_le_bytes());
    out
}

#[test]
fn version_2_blobs_are_still_read_and_rewrite_to_the_same_bytes() {
    for (name, blob) in shipped() {
        let v2 = as_version_2(&blob);
        assert_eq!(v2[4], 2);
        let (a, b) = (
            Model::from_blob(&v2).unwrap(),
            Model::from_blob(&blob).unwrap(),
        );
        assert_eq!(a.name(), b.name());
        assert_eq!(a.parameter_count(), b.parameter_count(), "{name}");
        assert_eq!(
            gpecnet_blob_writer::rewrite_blob(&v2).unwrap(),
            blob,
            "{name}"
        );
    }
}

#[test]
fn non_canonical_padding_is_malformed() {
    let reseal = |mut b: Vec<u8>| {
        let n = b.len() - 4;
        let crc = CRC32.checksum(&b[..n]);
        b[n..].copy_from_slice(&crc.to_le_bytes());
        b
    };
    let (_, blob) = shipped().remove(0);
    let m = Model::from_blob(&blob).unwrap();
    // Tensors with a non-empty pad: [p][p zero bytes][length varint][data], 1 ≤ p < 4.
    let mut tried = 0;
    for l in nets(&m).iter().flat_map(|n| n.layers()) {
        let (w, _, _) = l.tensors_q();
        let at = w.as_ptr() as usize - blob.as_ptr() as usize;
        let lv = if w.len() < 0x80 {
            1
        } else if w.len() < 0x4000 {
            2
        } else {
            3
        };
        let end = at - lv; // one past the last pad byte
        let pad = (1..4).find(|&p| {
            blob[end - p - 1] as usize == p && blob[end - p..end].iter().all(|&z| z == 0)
        });
        if pad.is_some() {
            let mut b = blob.clone();
            b[end - 1] = 1;
            assert_eq!(
                Model::from_blob(&reseal(b)).unwrap_err(),
                BlobError::Malformed
            );
            tried += 1;
        }
    }
    assert!(tried > 0);
    // A version-3 label on the unpadded (version-2) body: the padding rule fails.
    let mut v2 = as_version_2(&blob);
    v2[4] = 3;
    assert!(Model::from_blob(&reseal(v2)).is_err());
}

#[test]
fn a_blob_at_an_odd_address_still_validates() {
    for (name, blob) in shipped() {
        let mut buf = vec![0u8; blob.len() + 8];
        let base = buf.as_ptr() as usize;
        let skew = (0..8).find(|s| (base + s) % TENSOR_ALIGN == 1).unwrap();
        buf[skew..skew + blob.len()].copy_from_slice(&blob);
        let odd = Model::from_blob(&buf[skew..skew + blob.len()]).unwrap();
        assert!(!odd.tensors_aligned(), "{name}");
        assert_eq!(odd.crc(), Model::from_blob(&blob).unwrap().crc());
    }
}
