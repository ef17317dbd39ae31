//! The work behind `gpecnet abscore | classify | synth | rl-train`: each function writes its
//! files into `out` and returns the report printed by the CLI (markdown tables).

use std::fmt::Write as _;
use std::path::Path;

use anyhow::{Context, Result};

use crate::data::{load_sdd, Dataset, SddSplit};
use crate::mlp::Mlp;

use crate::synthetic::abscore::{self, filter_by_abscore, Which};
use crate::synthetic::agent;
use crate::synthetic::classify::{self, TrajType};
use crate::synthetic::plot::{self, Panel};
use crate::synthetic::sample;
use crate::synthetic::Stats;

fn write(out: &Path, name: &str, text: &str) -> Result<()> {
    std::fs::create_dir_all(out).with_context(|| format!("{}: cannot create", out.display()))?;
    let p = out.join(name);
    crate::rundir::write_atomic(&p, text.as_bytes())
        .with_context(|| format!("{}: cannot write", p.display()))
}

/// `gpecnet abscore`: statistics table, per-trajectory CSV, distribution plot (tail thresholded
/// at the 95th percentile of train), and, with `max`, the outlier filter's effect.
pub fn run_abscore(data: &Path, out: &Path, max: Option<f64>, which: Which) -> Result<String> {
    let train = load_sdd(data, SddSplit::Train)?;
    let test = load_sdd(data, SddSplit::Test)?;
    let mut rep = String::new();
    let mut rows = Vec::new();
    let mut all = Vec::new();
    for ds in [&train, &test] {
        let (u, s) = abscore::scores(ds);
        for ((w, a), b) in ds.windows.iter().zip(&u).zip(&s) {
            rows.push([
                ds.name.clone(),
                w.scene.clone(),
                w.ped_id.to_string(),
                a.to_string(),
                b.to_string(),
            ]);
        }
        all.push((ds.name.clone(), u, s));
    }
    let csv = crate::csvfile::to_csv(
        &["split", "scene", "ped_id", "abscore", "abscore_scaled"],
        rows,
    )?;
    let _ = writeln!(rep, "AbScore (unscaled, px²)\n\n{}", Stats::md_header());
    for (n, u, _) in &all {
        let _ = writeln!(rep, "{}", Stats::of(u).md_row(n));
    }
    let _ = writeln!(
        rep,
        "\nAreal-scaled AbScore (÷ bbox area; ÷ length if the area is 0)\n\n{}",
        Stats::md_header()
    );
    for (n, _, s) in &all {
        let _ = writeln!(rep, "{}", Stats::of(s).md_row(n));
    }
    for (scaled, name) in [
        (false, "abscore_hist.svg"),
        (true, "abscore_scaled_hist.svg"),
    ] {
        let pick =
            |x: &(String, Vec<f64>, Vec<f64>)| if scaled { x.2.clone() } else { x.1.clone() };
        let thr = Stats::of(&pick(&all[0])).p95;
        let series: Vec<(String, Vec<f64>)> = all.iter().map(|x| (x.0.clone(), pick(x))).collect();
        let refs: Vec<(&str, &[f64])> = series
            .iter()
            .map(|(n, v)| (n.as_str(), v.as_slice()))
            .collect();
        let title = format!(
            "SDD {}AbScore distribution (tail above the train 95th percentile {thr:.2} not shown)",
            if scaled { "areal-scaled " } else { "" }
        );
        write(
            out,
            name,
            &plot::histogram_svg(&title, "AbScore", &refs, thr, 40),
        )?;
    }
    write(out, "abscore.csv", &csv)?;
    if let Some(m) = max {
        let _ = writeln!(
            rep,
            "\nOutlier filter: {which:?} AbScore <= {m}\n\n| set | kept | removed |\n|---|---|---|"
        );
        for ds in [&train, &test] {
            let (kept, removed) = filter_by_abscore(ds, which, m);
            let _ = writeln!(rep, "| {} | {} | {removed} |", ds.name, kept.len());
        }
    }
    write(out, "abscore.md", &rep)?;
    Ok(rep)
}

fn type_table(rows: &[(&str, [usize; 10])]) -> String {
    let mut s = String::from("| type |");
    for (n, _) in rows {
        let _ = write!(s, " {n} | % |");
    }
    s.push_str("\n|---|");
    for _ in rows {
        s.push_str("---|---|");
    }
    s.push('\n');
    for t in TrajType::ALL {
        let _ = write!(s, "| {} |", t.label());
        for (_, c) in rows {
            let n: usize = c.iter().sum();
            let _ = write!(
                s,
                " {} | {:.1} |",
                c[t.index()],
                100.0 * c[t.index()] as f64 / n.max(1) as f64
            );
        }
        s.push('\n');
    }
    s
}

/// Each count's share of the total (all zeros when the total is 0).
fn fractions(counts: &[usize]) -> Vec<f64> {
    let n: usize = counts.iter().sum();
    counts.iter().map(|&c| c as f64 / n.max(1) as f64).collect()
}

fn windows_of(ds: &Dataset) -> impl Iterator<Item = &[[f32; 2]]> {
    ds.windows.iter().map(|w| &w.pos[..])
}

/// `gpecnet classify`: type table and unique-points histogram for SDD train and test (+ SVGs).
pub fn run_classify(data: &Path, out: &Path) -> Result<String> {
    let train = load_sdd(data, SddSplit::Train)?;
    let test = load_sdd(data, SddSplit::Test)?;
    let ct = classify::type_counts(windows_of(&train));
    let ce = classify::type_counts(windows_of(&test));
    let mut rep = format!(
        "Trajectory types (rules: host-trainer/train/src/synthetic/classify.rs)\n\n{}",
        type_table(&[(&train.name, ct), (&test.name, ce)])
    );
    let ht = classify::unique_histogram(windows_of(&train));
    let he = classify::unique_histogram(windows_of(&test));
    let _ = writeln!(
        rep,
        "\nUnique points per trajectory\n\n| unique points | {} | {} |\n|---|---|---|",
        train.name, test.name
    );
    for u in 1..ht.len() {
        let _ = writeln!(rep, "| {u} | {} | {} |", ht[u], he[u]);
    }
    let labels: Vec<String> = (1..ht.len()).map(|u| u.to_string()).collect();
    // Index 0 (no points) counts in the total but has no bar.
    let frac = |h: &[usize]| fractions(h)[1..].to_vec();
    write(
        out,
        "unique_points.svg",
        &plot::bars_svg(
            "SDD: unique points per trajectory",
            "fraction",
            &labels,
            &[(&train.name, frac(&ht)), (&test.name, frac(&he))],
        ),
    )?;
    let tl: Vec<String> = TrajType::ALL
        .iter()
        .map(|t| t.label().to_string())
        .collect();
    write(
        out,
        "types.svg",
        &plot::bars_svg(
            "SDD: trajectory types",
            "fraction",
            &tl,
            &[(&train.name, fractions(&ct)), (&test.name, fractions(&ce))],
        ),
    )?;
    // Examples: the first 3 trajectories of each type in train.
    let mut panels = Vec::new();
    for t in TrajType::ALL {
        for w in train
            .windows
            .iter()
            .filter(|w| classify::classify(&w.pos) == t)
            .take(3)
        {
            panels.push(Panel {
                caption: format!("type {} · {} #{}", t.label(), w.scene, w.ped_id),
                main: Some(w.pos.to_vec()),
                goal: None,
                others: vec![],
                marks: vec![],
            });
        }
    }
    write(
        out,
        "type_examples.svg",
        &plot::panels_svg("SDD train: first 3 trajectories of each type", &panels, 6),
    )?;
    write(out, "classify.md", &rep)?;
    Ok(rep)
}

/// Pins candle's matmul thread count to 1 for the policy's tiny matmuls. Unset, candle reads
/// the machine's core count from `/proc` for every matmul, which made the per-step rollouts
/// (one `[1, 8]` forward each) about 15 times slower; see [`crate::train::set_num_threads`].
fn pin_policy_threads() {
    crate::train::set_num_threads(1);
}

/// `gpecnet rl-train`: learning curve, sample-episode picture, curve CSV and the policy
/// (candle's matmuls pinned to one thread).
pub fn run_rl_train(
    episodes: usize,
    batch: usize,
    lr: f64,
    seed: u64,
    out: &Path,
) -> Result<(String, Mlp)> {
    pin_policy_threads();
    let tr = agent::train(episodes, batch, lr, seed)?;
    let csv = crate::csvfile::to_csv(
        &["episodes", "mean_reward", "mean_final_dist_px", "mean_ics"],
        tr.curve.iter().map(|c| {
            [
                c.episodes.to_string(),
                c.mean_reward.to_string(),
                c.mean_final_dist.to_string(),
                c.mean_ics.to_string(),
            ]
        }),
    )?;
    write(out, "rl_curve.csv", &csv)?;
    let x: Vec<f64> = tr.curve.iter().map(|c| c.episodes as f64).collect();
    let smooth = |f: &dyn Fn(&agent::CurvePoint) -> f64| {
        let v: Vec<f64> = tr.curve.iter().map(f).collect();
        (0..v.len())
            .map(|i| {
                let lo = i.saturating_sub(9);
                v[lo..=i].iter().sum::<f64>() / (i - lo + 1) as f64
            })
            .collect::<Vec<_>>()
    };
    write(
        out,
        "rl_curve_reward.svg",
        &plot::lines_svg(
            "REINFORCE: mean episode reward Σ R_t (10-update moving average)",
            "episodes",
            "Σ R_t",
            &x,
            &[("mean reward", smooth(&|c| c.mean_reward))],
        ),
    )?;
    write(
        out,
        "rl_curve_distance.svg",
        &plot::lines_svg(
            "REINFORCE: final distance to goal and impending collisions (10-update moving average)",
            "episodes",
            "px / count",
            &x,
            &[
                (
                    "final distance to goal (px)",
                    smooth(&|c| c.mean_final_dist),
                ),
                ("n_ICS per episode × 10", smooth(&|c| 10.0 * c.mean_ics)),
            ],
        ),
    )?;
    let panels: Vec<Panel> = tr
        .snapshots
        .iter()
        .map(|(n, e)| Panel {
            caption: format!(
                "after {n} episodes: end {:.0} px from goal, n_ICS {}",
                e.final_distance(),
                e.n_ics.iter().sum::<usize>()
            ),
            main: Some(e.track.to_vec()),
            goal: Some(e.goal),
            others: e.others.iter().map(|t| t.to_vec()).collect(),
            marks: e.track[1..]
                .iter()
                .zip(&e.n_ics)
                .filter(|(_, &n)| n > 0)
                .map(|(p, _)| *p)
                .collect(),
        })
        .collect();
    write(out, "rl_episodes.svg", &plot::panels_svg("Policy-gradient agent (turquoise) in the HMM playground (grey); red ×: goal; circles: impending collisions", &panels, 4))?;
    write(
        out,
        "policy.json",
        &serde_json::to_string(&agent::policy_params(&tr.net)?)?,
    )?;
    let first = &tr.curve[..tr.curve.len().min(10)];
    let last = &tr.curve[tr.curve.len().saturating_sub(10)..];
    let avg = |s: &[agent::CurvePoint], f: &dyn Fn(&agent::CurvePoint) -> f64| {
        s.iter().map(f).sum::<f64>() / s.len().max(1) as f64
    };
    let mut rep = format!("REINFORCE: {episodes} episodes, batch {batch}, lr {lr}, seed {seed}\n\n| | first 10 updates | last 10 updates |\n|---|---|---|\n");
    let _ = writeln!(
        rep,
        "| mean Σ R_t | {:.5} | {:.5} |",
        avg(first, &|c| c.mean_reward),
        avg(last, &|c| c.mean_reward)
    );
    let _ = writeln!(
        rep,
        "| mean final distance to goal (px) | {:.1} | {:.1} |",
        avg(first, &|c| c.mean_final_dist),
        avg(last, &|c| c.mean_final_dist)
    );
    let _ = writeln!(
        rep,
        "| mean n_ICS per episode | {:.2} | {:.2} |",
        avg(first, &|c| c.mean_ics),
        avg(last, &|c| c.mean_ics)
    );
    write(out, "rl_train.md", &rep)?;
    Ok((rep, tr.net))
}

/// `gpecnet synth`: train a policy (`rl_episodes`), build the `n`-trajectory pool with SDD
/// train's type shares, write it as CSV plus a type table and an example picture (candle's
/// matmuls pinned to one thread; a later `gpecnet train` in the same process pins its own).
pub fn run_synth(
    data: &Path,
    n: usize,
    seed: u64,
    rl_episodes: usize,
    out_csv: &Path,
) -> Result<String> {
    let train = load_sdd(data, SddSplit::Train)?;
    let ct = classify::type_counts(windows_of(&train));
    let dir = out_csv
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let (_, policy) = run_rl_train(rl_episodes, 16, 3e-3, seed, &dir.join("rl"))?;
    let pool = sample::build_pool(n, &sample::shares(&ct), &policy, seed)?;
    crate::rundir::write_atomic(out_csv, sample::pool_csv(&pool)?.as_bytes())
        .with_context(|| format!("{}: cannot write", out_csv.display()))?;
    let mut cp = [0usize; 10];
    for it in &pool {
        cp[it.ty.index()] += 1;
    }
    let mut rep = format!(
        "Synthetic pool: {n} trajectories, seed {seed}, {}\n\n{}",
        out_csv.display(),
        type_table(&[(&train.name, ct), ("pool", cp)])
    );
    let mut src = std::collections::BTreeMap::new();
    for it in &pool {
        *src.entry(it.source.name()).or_insert(0usize) += 1;
    }
    let _ = writeln!(rep, "\nSources: {src:?}");
    let panels: Vec<Panel> = pool
        .iter()
        .take(24)
        .enumerate()
        .map(|(i, it)| Panel {
            caption: format!("#{i} type {} ({})", it.ty.label(), it.source.name()),
            main: Some(it.traj.to_vec()),
            goal: None,
            others: vec![],
            marks: vec![],
        })
        .collect();
    let stem = out_csv
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "pool".into());
    write(
        dir,
        &format!("{stem}_first24.svg"),
        &plot::panels_svg("Synthetic pool: the first 24 trajectories", &panels, 6),
    )?;
    write(dir, &format!("{stem}.md"), &rep)?;
    Ok(rep)
}
