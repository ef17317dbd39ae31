//! `gpecnet data`: a data-set folder as the model will see it; argument parsing and printing
//! only (the report is `gpecnet_data::check_folder`'s).
// Doc comments here are the CLI --help text, where <name> placeholders are plain text.
#![allow(rustdoc::invalid_html_tags)]

use std::path::PathBuf;

use anyhow::{Context, Result};
use gpecnet_trainer::data::{check_folder, FolderCheck, SPEED_BINS_M_S};

/// What `gpecnet data` does.
#[derive(clap::Subcommand, Debug)]
pub(crate) enum DataCommand {
    /// Validate a data-set folder and print what a model will see of it.
    ///
    /// The folder: dataset.toml + train/ val/ test/ (docs/own-data.md). Per split and file:
    /// the detections, pedestrians,
    /// the native clock against the models' 0.4 s grid, the windows (8 observed + 12
    /// predicted positions), the windows' observed speeds (metres only), and the pedestrians
    /// that give no window (no 7.6 s of track without a gap longer than max_gap_s) with their
    /// detections. Reads every file exactly as train, eval and stream do, so any problem is
    /// the same error, naming the file, the line and the key. Writes nothing. For example:
    /// gpecnet data check ./mydrone
    Check(DataCheckArgs),
}

/// `gpecnet data check`.
#[derive(clap::Args, Debug)]
pub(crate) struct DataCheckArgs {
    /// The data-set folder.
    #[arg(value_name = "DIR")]
    dir: PathBuf,
    /// Print one JSON object instead of the tables.
    #[arg(long)]
    json: bool,
}

/// Runs `gpecnet data …`.
pub(crate) fn cmd_data(c: DataCommand) -> Result<()> {
    match c {
        DataCommand::Check(a) => {
            let r = check_folder(&a.dir)
                .with_context(|| format!("checking the data-set folder {}", a.dir.display()))?;
            if a.json {
                println!("{}", serde_json::to_string_pretty(&r)?);
            } else {
                print!("{}", text(&r));
            }
            Ok(())
        }
    }
}

/// The report as tables.
fn text(r: &FolderCheck) -> String {
    let mut s = format!(
        "data set {:?} at {}\n  positions: {} (files in {}, windows in {})\n  clock: {}\n",
        r.name,
        r.dir.display(),
        r.camera,
        r.file_unit,
        r.unit,
        r.clock
    );
    let [a, b, c] = SPEED_BINS_M_S;
    for sp in &r.splits {
        s += &format!("\n{}/", sp.split);
        if let Some(why) = &sp.absent {
            s += &format!(": {why}\n");
            continue;
        }
        s += &format!(
            "\n  {:<24} {:>10} {:>11} {:>9} {:>8} {:>26}  {}\n",
            "file",
            "detections",
            "pedestrians",
            "native s",
            "windows",
            format!("speeds <{a} / <{b} / <{c} / more m/s"),
            "no window: pedestrians (detections)"
        );
        let (mut d, mut p, mut w, mut pw, mut dw) = (0, 0, 0, 0, 0);
        for f in &sp.files {
            let speeds = f.speeds.map_or("-".to_string(), |v| {
                format!("{} / {} / {} / {}", v[0], v[1], v[2], v[3])
            });
            let step = f.native_step_s.map_or("-".into(), |v| format!("{v:.4}"));
            s += &format!(
                "  {:<24} {:>10} {:>11} {:>9} {:>8} {:>26}  {} ({})\n",
                f.scene,
                f.detections,
                f.pedestrians,
                step,
                f.windows,
                speeds,
                f.pedestrians_without_window,
                f.detections_without_window
            );
            d += f.detections;
            p += f.pedestrians;
            w += f.windows;
            pw += f.pedestrians_without_window;
            dw += f.detections_without_window;
        }
        s += &format!(
            "  {:<24} {:>10} {:>11} {:>9} {:>8} {:>26}  {} ({})\n",
            "total", d, p, "", w, "", pw, dw
        );
        if w == 0 {
            s += "  no window: no pedestrian is tracked for 7.6 s without a gap longer than \
                  max_gap_s (check the clock and max_gap_s)\n";
        }
    }
    s
}
