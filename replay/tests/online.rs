//! The streamed scene through the online loop (`online_scene`): one line per
//! camera frame, the same lines at the Cortex-M0's scratch width as at the
//! host's, the loop fed and forecasting, the scene's faults visible, and the
//! lines after the model's golden cases in `verify_all`.
use gpecnet_replay::{online_scene, verify_all, EmbeddedModel, Line, ONLINE_FRAMES, ONLINE_MODEL};

use crate::common::read;

/// (frame, t_ms, forecasts, feedback, hash) of every line of the scene at width `W`,
/// read back from the text the host prints, `online <model> <frame> <t_ms> <forecasts>
/// <feedback> <hash>`.
fn scene<const W: usize>() -> Vec<(u32, u32, u32, u32, u32)> {
    let blob = read(&format!("{ONLINE_MODEL}.gpec"));
    let mut text = Vec::new();
    online_scene::<W>(ONLINE_MODEL, blob, &mut |l| {
        assert!(matches!(l, Line::Online { .. }), "only online lines");
        l.print(&mut |line, error| {
            assert!(!error, "{line}");
            text.push(line.to_string())
        })
    })
    .unwrap();
    text.iter()
        .map(|line| {
            let words: Vec<&str> = line.split(' ').collect();
            assert_eq!(words[..2], ["online", ONLINE_MODEL], "{line}");
            let n = |i: usize| words[i].parse::<u32>().unwrap();
            let hash = u32::from_str_radix(words[6], 16).unwrap();
            assert_eq!(words.len(), 7, "{line}");
            (n(2), n(3), n(4), n(5), hash)
        })
        .collect()
}

#[test]
fn the_online_scene_is_one_line_per_frame_whatever_the_scratch_width() {
    let host = scene::<128>();
    assert_eq!(
        host,
        scene::<64>(),
        "the Cortex-M0's width gives other bits"
    );
    assert_eq!(host.len() as u32, ONLINE_FRAMES);
    assert!(host.iter().enumerate().all(|(i, l)| l.0 == i as u32));
    let forecasts: u32 = host.iter().map(|l| l.2).sum();
    let feedback: u32 = host.iter().map(|l| l.3).sum();
    assert!(forecasts > 200, "{forecasts} forecasts");
    assert!(feedback > 300, "{feedback} feedback updates");
    // The clock wraps 10 s in; the stale frame 150 forecasts nothing.
    assert!(host[99].1 > host[101].1);
    assert_eq!((host[150].2, host[150].3), (0, 0));
    // Every frame's hash covers the state, so frames with feedback differ.
    let mut hashes: Vec<u32> = host.iter().filter(|l| l.3 > 0).map(|l| l.4).collect();
    let n = hashes.len();
    hashes.sort_unstable();
    hashes.dedup();
    assert_eq!(hashes.len(), n);
}

#[test]
fn verify_all_runs_the_scene_after_the_models_cases() {
    let m = EmbeddedModel {
        name: ONLINE_MODEL,
        blob: read(&format!("{ONLINE_MODEL}.gpec")),
        golden: read(&format!("{ONLINE_MODEL}.golden")),
    };
    let mut kinds = Vec::new();
    let s = verify_all::<128, true>(core::slice::from_ref(&m), false, &mut |l| {
        kinds.push(match l {
            Line::Model { .. } => 'm',
            Line::Golden { .. } => 'g',
            Line::Online { .. } => 'o',
            _ => 'e',
        })
    });
    assert!(s.ok());
    let text: String = kinds.into_iter().collect();
    let online = "o".repeat(ONLINE_FRAMES as usize);
    assert!(text.starts_with("mg"), "{text}");
    assert!(text.ends_with(&format!("g{online}")), "{text}");
}
