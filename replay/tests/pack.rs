//! The model pack: what `pack::write` puts in is what `ModelPack::parse` gives
//! back, a pack replays with the same lines as its models replayed directly, and
//! a pack that does not hold what it says is an error, never a partial replay.
use gpecnet_replay::pack::{self, ModelPack, PackError};
use gpecnet_replay::{verify_all, verify_pack, EmbeddedModel, Line};

fn read(name: &str) -> Vec<u8> {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../weights/").to_string() + name;
    std::fs::read(&path).unwrap_or_else(|e| panic!("{path}: {e}"))
}

fn leak(bytes: Vec<u8>) -> &'static [u8] {
    Box::leak(bytes.into_boxed_slice())
}

/// A pack of `models` (name, blob, golden) in an area `slack` bytes larger than
/// the bound `max_entry_len` gives.
fn packed(models: &[(&str, &[u8], &[u8])], slack: usize) -> (&'static [u8], usize) {
    let bound = pack::HEADER_LEN
        + models
            .iter()
            .map(|(n, b, g)| pack::max_entry_len(n.len(), b.len(), g.len()))
            .sum::<usize>();
    let mut area = vec![0xa5; bound + slack];
    let used = pack::write(models, &mut area).expect("fits its bound");
    assert!(used <= bound, "{used} > bound {bound}");
    assert!(area[used..].iter().all(|&b| b == 0), "the rest is zeroed");
    (leak(area), used)
}

/// Every line `run` prints, as text.
fn lines(run: impl FnOnce(&mut dyn FnMut(Line<'_>))) -> Vec<String> {
    let mut out = Vec::new();
    run(&mut |l| l.print(&mut |text, _| out.push(text.to_string())));
    out
}

#[test]
fn what_is_written_is_read_back_with_aligned_blobs() {
    let names = ["a", "model-two", "ü"];
    let blobs: Vec<Vec<u8>> = (0..3).map(|i| vec![i as u8 + 1; 5 + 3 * i]).collect();
    let goldens: Vec<Vec<u8>> = (0..3).map(|i| vec![0x40 + i as u8; 7 - i]).collect();
    let models: Vec<(&str, &[u8], &[u8])> = (0..3)
        .map(|i| (names[i], &blobs[i][..], &goldens[i][..]))
        .collect();
    let (area, _) = packed(&models, 13);
    let pack = ModelPack::parse(area).unwrap();
    assert_eq!(pack.len(), 3);
    for (i, (name, blob, golden)) in models.iter().enumerate() {
        let m = pack.get(i).unwrap();
        assert_eq!((m.name, m.blob, m.golden), (*name, *blob, *golden));
        // Aligned from the pack's first byte (the firmware places that at 8).
        assert_eq!((m.blob.as_ptr() as usize - area.as_ptr() as usize) % 8, 0);
    }
    assert!(pack.get(3).is_none());
}

#[test]
fn a_pack_replays_like_its_models() {
    let files: Vec<(&str, Vec<u8>, Vec<u8>)> = ["ethucy-eth", "ethucy-eth-qe"]
        .into_iter()
        .map(|n| (n, read(&format!("{n}.gpec")), read(&format!("{n}.golden"))))
        .collect();
    let models: Vec<(&str, &[u8], &[u8])> =
        files.iter().map(|(n, b, g)| (*n, &b[..], &g[..])).collect();
    let (area, _) = packed(&models, 0);
    let direct: Vec<EmbeddedModel> = files
        .iter()
        .map(|(n, b, g)| EmbeddedModel {
            name: n,
            blob: leak(b.clone()),
            golden: leak(g.clone()),
        })
        .collect();
    let mut sums = Vec::new();
    let from_pack = lines(|out| sums.push(verify_pack::<128, true>(area, true, out)));
    let from_models = lines(|out| sums.push(verify_all::<128, true>(&direct, true, out)));
    assert_eq!(from_pack, from_models);
    assert!(
        from_pack
            .iter()
            .filter(|l| l.starts_with("golden "))
            .count()
            > 30
    );
    let (p, d) = (sums[0], sums[1]);
    assert!(p.ok() && d.ok());
    assert_eq!(
        (p.models, p.cases, p.xchecks, p.mismatches),
        (d.models, d.cases, d.xchecks, d.mismatches)
    );
}

#[test]
fn an_area_without_a_pack_is_one_error_line() {
    let area = leak(vec![0; 4096]);
    assert_eq!(ModelPack::parse(area).err(), Some(PackError::BadMagic));
    let mut s = None;
    let printed = lines(|out| s = Some(verify_pack::<128, true>(area, true, out)));
    assert_eq!(
        printed,
        ["golden pack: model pack: no pack written into the image (bad magic)"]
    );
    let s = s.unwrap();
    assert!(!s.ok());
    assert_eq!((s.models, s.errors), (0, 1));
}

#[test]
fn every_damaged_or_cut_pack_is_refused() {
    let models: &[(&str, &[u8], &[u8])] = &[("x", &[1, 2, 3], &[4, 5]), ("yz", &[6; 9], &[7])];
    let (area, used) = packed(models, 0);
    // Cut anywhere before its last byte: an error, never a shorter pack.
    for cut in 0..used {
        let short = leak(area[..cut].to_vec());
        assert!(ModelPack::parse(short).is_err(), "cut at {cut}");
    }
    let with = |at: usize, v: u32| {
        let mut b = area.to_vec();
        b[at..at + 4].copy_from_slice(&v.to_le_bytes());
        ModelPack::parse(leak(b)).err()
    };
    assert_eq!(with(4, 2), Some(PackError::BadVersion));
    assert_eq!(with(8, 0), Some(PackError::BadCount));
    assert_eq!(
        with(8, pack::MAX_MODELS as u32 + 1),
        Some(PackError::BadCount)
    );
    let entry = |i: usize, k: usize| pack::HEADER_LEN + i * pack::ENTRY_LEN + 4 * k;
    // A range past the end, an offset + length that overflows, a misaligned blob.
    assert_eq!(with(entry(1, 3), used as u32), Some(PackError::BadEntry));
    assert_eq!(with(entry(0, 4), u32::MAX), Some(PackError::BadEntry));
    let blob_at = u32::from_le_bytes(area[entry(0, 2)..entry(0, 2) + 4].try_into().unwrap());
    assert_eq!(with(entry(0, 2), blob_at + 1), Some(PackError::BadEntry));
    // An empty name, a name that is not UTF-8.
    assert_eq!(with(entry(1, 1), 0), Some(PackError::BadName));
    let mut bad = area.to_vec();
    let name_at = u32::from_le_bytes(area[entry(0, 0)..entry(0, 0) + 4].try_into().unwrap());
    bad[name_at as usize] = 0xff;
    assert_eq!(ModelPack::parse(leak(bad)).err(), Some(PackError::BadName));
}

#[test]
fn write_refuses_what_it_cannot_pack() {
    let mut small = [0u8; 40];
    assert_eq!(
        pack::write(&[("x", &[0; 32], &[])], &mut small),
        Err(PackError::TooLarge)
    );
    assert_eq!(pack::write(&[], &mut small), Err(PackError::BadCount));
    assert_eq!(
        pack::write(&[("", &[1], &[])], &mut small),
        Err(PackError::BadName)
    );
}
