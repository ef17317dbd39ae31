//! Which data set a command reads ([`DatasetSpec`]) and its three splits ([`Split`],
//! [`load`]): the one place that maps a dataset name to files, so `train`, `select`, `eval`,
//! `quantize` and `export` all read the same windows for the same name.
//!
//! | name | unit | train | val | test |
//! |---|---|---|---|---|
//! | `sdd` | pixels | `sdd/train` minus the validation scenes | the validation scenes of `sdd/train` | `sdd/test` |
//! | `sdd-m` | metres | the same windows as `sdd`, each scene times its metres per pixel | the same | the same |
//! | `eth_ucy:<scene>` | metres | `eth_ucy/<scene>/train` | `eth_ucy/<scene>/val` | `eth_ucy/<scene>/test` |
//! | a folder path (`./mydrone`, `/data/x`) | its `dataset.toml`'s | `<dir>/train` | `<dir>/val` | `<dir>/test` |
//! | `A+B` (e.g. `sdd-m+./mydrone`) | A's, which B must share | both | both | both |
//!
//! A folder is a user's own data (`super::folder`, `docs/own-data.md`); a name that is not one
//! of the built-in ones is taken as a folder when it contains a `/` (write `./mydrone` for a
//! folder in the working directory). An existing folder wins over the `+` split: `./a+b` is
//! the folder `a+b` when it exists, and `sdd-m+./a+b` is `sdd-m` and that folder.
//!
//! `sdd-m` multiplies every coordinate of a scene by that scene's factor in
//! `sdd/scales/sdd_meters_per_pixel.csv` ([`sdd_metres_per_pixel`]), in f32 (`x * s` with `s`
//! rounded to f32 once); a scene missing from the table is an error naming it, never a silent
//! pixel window in a metre set. A constant-velocity forecast is linear in the positions, so its
//! errors on `sdd-m` are the pixel errors times each scene's factor (up to f32 rounding).

use std::fmt;
use std::path::Path;

use super::*;

/// A data set, by name (see the module table).
///
/// `+` joins data sets, but a folder path (one with a `/`) that exists as a directory is
/// never split at a `+` in its name: the longest run of `+`-separated pieces that names an
/// existing directory is one folder.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum DatasetSpec {
    /// Stanford Drone Dataset, TrajNet split, pixels (`"sdd"`).
    Sdd,
    /// The same SDD windows in metres through the per-scene scale table (`"sdd-m"`).
    SddMetres,
    /// ETH/UCY leave-one-out (`"eth_ucy:<scene>"`, scene in eth|hotel|univ|zara1|zara2):
    /// train on `<scene>/train`, validate on `<scene>/val`, test on `<scene>/test`.
    EthUcy(String),
    /// A user's data-set folder (`dataset.toml` + `train/ val/ test/`), as given.
    Folder {
        /// The folder, as written on the command line or in the config.
        dir: String,
        /// Its unit (read from `dataset.toml` when the name was parsed).
        unit: Unit,
        /// Its licence (`dataset.toml`), empty when it states none.
        licence: String,
    },
    /// Several data sets of one unit, trained, validated and tested together (`"A+B"`).
    Combined(Vec<DatasetSpec>),
}

/// The names [`DatasetSpec::parse`] accepts, for error messages and `--help`.
pub const DATASET_NAMES: &str = "\"sdd\" (pixels), \"sdd-m\" (SDD in metres), \
                                 \"eth_ucy:<eth|hotel|univ|zara1|zara2>\" (metres), a data-set \
                                 folder with a '/' in its path (e.g. ./mydrone, docs/own-data.md), \
                                 or several of them joined by '+'";

impl DatasetSpec {
    /// Parse a name of the module table (a folder's `dataset.toml` is read and checked). An
    /// existing folder whose name contains `+` is one data set, not several.
    pub fn parse(s: &str) -> Result<Self, String> {
        if s.contains('+') {
            let parts = split_parts(s)
                .iter()
                .map(|p| Self::parse_one(p))
                .collect::<Result<Vec<_>, _>>()?;
            if let [one] = parts.as_slice() {
                return Ok(one.clone());
            }
            let unit = parts[0].unit();
            if let Some(p) = parts.iter().find(|p| p.unit() != unit) {
                return Err(format!(
                    "{s}: {} is in {} but {} is in {}; a combined data set needs one unit",
                    parts[0],
                    unit.suffix(),
                    p,
                    p.unit().suffix()
                ));
            }
            return Ok(Self::Combined(parts));
        }
        Self::parse_one(s)
    }

    fn parse_one(s: &str) -> Result<Self, String> {
        match s {
            "sdd" => return Ok(Self::Sdd),
            "sdd-m" => return Ok(Self::SddMetres),
            _ => {}
        }
        if let Some(scene) = s.strip_prefix("eth_ucy:") {
            if ETH_UCY_SCENES.contains(&scene) {
                return Ok(Self::EthUcy(scene.to_string()));
            }
            return Err(format!(
                "unknown ETH/UCY scene {scene:?} (expected one of {ETH_UCY_SCENES:?})"
            ));
        }
        if s.contains('/') {
            let info =
                super::folder_info::FolderInfo::read(Path::new(s)).map_err(|e| e.to_string())?;
            return Ok(Self::Folder {
                dir: s.to_string(),
                unit: info.unit(),
                licence: info.licence.unwrap_or_default(),
            });
        }
        Err(format!("unknown dataset {s:?}: expected {DATASET_NAMES}"))
    }

    /// The unit of the data set's coordinates.
    pub fn unit(&self) -> Unit {
        match self {
            Self::Sdd => Unit::Pixels,
            Self::SddMetres | Self::EthUcy(_) => Unit::Metres,
            Self::Folder { unit, .. } => *unit,
            Self::Combined(parts) => parts.first().map_or(Unit::Metres, Self::unit),
        }
    }

    /// The licence of the data set's files, as a model card and a blob state it.
    pub fn licence(&self) -> String {
        match self {
            Self::Folder { licence, dir, .. } => {
                if licence.is_empty() {
                    format!("no licence stated in {dir}/dataset.toml")
                } else {
                    licence.clone()
                }
            }
            Self::Combined(parts) => parts
                .iter()
                .map(|p| format!("{p}: {}", p.licence()))
                .collect::<Vec<_>>()
                .join("; "),
            Self::Sdd | Self::SddMetres => {
                "CC BY-NC-SA 3.0 (Stanford Drone Dataset: attribution, non-commercial, share-alike)"
                    .to_string()
            }
            Self::EthUcy(_) => "no licence stated for the ETH/UCY data (credit the original \
                                uploaders: Pellegrini et al. 2009, Lerner et al. 2007)"
                .to_string(),
        }
    }

    /// The training split in words, for a blob's and a card's description.
    pub fn describe_training(&self, val_scenes: &[String]) -> String {
        match self {
            Self::Sdd => format!(
                "SDD TrajNet split, sdd/train minus the validation scenes {val_scenes:?} (pixels)"
            ),
            Self::SddMetres => format!(
                "SDD TrajNet split, sdd/train minus the validation scenes {val_scenes:?}, \
                 in metres through the per-scene scales of sdd/scales/sdd_meters_per_pixel.csv"
            ),
            Self::EthUcy(scene) => format!(
                "ETH/UCY leave-one-scene-out split of {scene}: eth_ucy/{scene}/train, \
                 the other four scenes (metres)"
            ),
            Self::Folder { dir, unit, .. } => {
                format!("the data-set folder {dir}, train/ ({})", unit.suffix())
            }
            Self::Combined(parts) => parts
                .iter()
                .map(|p| p.describe_training(val_scenes))
                .collect::<Vec<_>>()
                .join(" + "),
        }
    }

    /// Where the set's files are, for messages: a folder's own path, `root` for the
    /// built-in sets, each once for a combined set. A folder set never names `root`, which
    /// it does not read.
    pub fn location(&self, root: &Path) -> String {
        let mut places: Vec<String> = Vec::new();
        self.collect_locations(root, &mut places);
        places.join(" and ")
    }

    fn collect_locations(&self, root: &Path, places: &mut Vec<String>) {
        let place = match self {
            Self::Combined(parts) => {
                for p in parts {
                    p.collect_locations(root, places);
                }
                return;
            }
            Self::Folder { dir, .. } => format!("the folder {dir}"),
            Self::Sdd | Self::SddMetres | Self::EthUcy(_) => {
                format!("{self} under the data root {}", root.display())
            }
        };
        if !places.contains(&place) {
            places.push(place);
        }
    }

    /// The data files of `split` in the set's folders that hold nothing but white space, so
    /// a split without windows can name them (empty for the built-in sets).
    pub fn empty_files(&self, split: Split) -> Vec<std::path::PathBuf> {
        match self {
            Self::Folder { dir, .. } => {
                let Ok(entries) = std::fs::read_dir(Path::new(dir).join(split.dir_name())) else {
                    return Vec::new();
                };
                let mut out: Vec<_> = entries
                    .filter_map(|e| e.ok().map(|e| e.path()))
                    .filter(|p| {
                        // Small files only: an empty file's emptiness needs no big read.
                        std::fs::metadata(p).is_ok_and(|m| m.is_file() && m.len() <= 4096)
                            && std::fs::read(p)
                                .is_ok_and(|b| b.iter().all(|c| c.is_ascii_whitespace()))
                    })
                    .collect();
                out.sort();
                out
            }
            Self::Combined(parts) => parts.iter().flat_map(|p| p.empty_files(split)).collect(),
            Self::Sdd | Self::SddMetres | Self::EthUcy(_) => Vec::new(),
        }
    }

    /// `true` for the SDD-based sets, whose validation split is a list of held-out scenes.
    pub fn is_sdd(&self) -> bool {
        matches!(self, Self::Sdd | Self::SddMetres)
    }

    /// Whether any part of the set is SDD (so its cards carry SDD's licence).
    pub fn uses_sdd(&self) -> bool {
        match self {
            Self::Combined(parts) => parts.iter().any(Self::uses_sdd),
            other => other.is_sdd(),
        }
    }
}

impl fmt::Display for DatasetSpec {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Sdd => f.write_str("sdd"),
            Self::SddMetres => f.write_str("sdd-m"),
            Self::EthUcy(scene) => write!(f, "eth_ucy:{scene}"),
            Self::Folder { dir, .. } => f.write_str(dir),
            Self::Combined(parts) => {
                for (i, p) in parts.iter().enumerate() {
                    if i > 0 {
                        f.write_str("+")?;
                    }
                    write!(f, "{p}")?;
                }
                Ok(())
            }
        }
    }
}

/// Splits `s` at `+` into data-set names, keeping together the longest run of pieces that
/// names an existing directory through a folder path (one with a `/`), so a folder such as
/// `./a+b` is never read as `./a` and `b`.
fn split_parts(s: &str) -> Vec<String> {
    let pieces: Vec<&str> = s.split('+').collect();
    let mut parts = Vec::new();
    let mut i = 0;
    while i < pieces.len() {
        let mut end = i + 1;
        for j in (i + 2..=pieces.len()).rev() {
            let joined = pieces[i..j].join("+");
            if joined.contains('/') && Path::new(&joined).is_dir() {
                end = j;
                break;
            }
        }
        parts.push(pieces[i..end].join("+"));
        i = end;
    }
    parts
}

/// One split of a data set.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Split {
    /// Training windows (never the validation scenes).
    Train,
    /// Validation windows: model selection only.
    Val,
    /// Test windows: touched once per shipped model.
    Test,
}

impl Split {
    /// The split's folder name (`train`, `val`, `test`) in a data-set folder.
    pub fn dir_name(self) -> &'static str {
        match self {
            Split::Train => "train",
            Split::Val => "val",
            Split::Test => "test",
        }
    }
}

/// The windows of one split of `spec` under `root`. `val_scenes` are the SDD scenes held out of
/// `sdd/train` for validation (ignored for ETH/UCY, whose validation split is its own folder);
/// each must exist, so a typo never validates on nothing.
pub fn load(
    root: &Path,
    spec: &DatasetSpec,
    split: Split,
    val_scenes: &[String],
) -> Result<Dataset, LoadError> {
    match spec {
        DatasetSpec::Sdd => load_sdd_split(root, split, val_scenes),
        DatasetSpec::SddMetres => sdd_in_metres(root, load_sdd_split(root, split, val_scenes)?),
        DatasetSpec::EthUcy(scene) => {
            let s = match split {
                Split::Train => EthUcySplit::Train,
                Split::Val => EthUcySplit::Val,
                Split::Test => EthUcySplit::Test,
            };
            Ok(load_eth_ucy(root, scene, s)?)
        }
        DatasetSpec::Folder { dir, .. } => Ok(super::folder::load_folder(
            Path::new(dir),
            split.dir_name(),
        )?),
        DatasetSpec::Combined(parts) => {
            let mut out: Option<Dataset> = None;
            for p in parts {
                let d = load(root, p, split, val_scenes)?;
                match &mut out {
                    None => out = Some(d),
                    Some(o) => {
                        o.name = format!("{}+{}", o.name, d.name);
                        o.windows.extend(d.windows);
                    }
                }
            }
            out.ok_or(LoadError::Empty)
        }
    }
}

fn load_sdd_split(root: &Path, split: Split, val_scenes: &[String]) -> Result<Dataset, LoadError> {
    if split == Split::Test {
        return Ok(load_sdd(root, SddSplit::Test)?);
    }
    // Validation reads only its scenes' files: the windows `split_by_scene` would keep.
    let all = match split {
        Split::Val => super::sdd::load_sdd_scenes(root, SddSplit::Train, val_scenes)?,
        _ => load_sdd(root, SddSplit::Train)?,
    };
    for s in val_scenes {
        if !all.windows.iter().any(|w| &w.scene == s) {
            // The scene's file is there but gives no window (empty, or no track long
            // enough): name the file rather than call the scene missing.
            let file = root
                .join("sdd")
                .join(SddSplit::Train.dir_name())
                .join(format!("{s}.txt"));
            if file.is_file() {
                return Err(LoadError::EmptyValScene {
                    scene: s.clone(),
                    file,
                });
            }
            return Err(LoadError::UnknownValScene {
                scene: s.clone(),
                dataset: all.name.clone(),
            });
        }
    }
    let (train, val) = split_by_scene(all, val_scenes);
    Ok(if split == Split::Train { train } else { val })
}

/// The `sdd-m` windows of `px`, windows of the pixel SDD (`sdd`) read under `root`: every
/// window times its scene's metres per pixel (`sdd/scales/`), exactly as [`load`] gives
/// `sdd-m`. A caller that needs a split in both units parses it once, in pixels, and converts.
pub fn sdd_in_metres(root: &Path, px: Dataset) -> Result<Dataset, LoadError> {
    let scales = sdd_metres_per_pixel(root)?;
    to_metres(px, &scales, root)
}

/// Every window of a pixel SDD set times its scene's metres per pixel.
fn to_metres(
    px: Dataset,
    scales: &std::collections::HashMap<String, f64>,
    root: &Path,
) -> Result<Dataset, LoadError> {
    let mut windows = px.windows;
    for w in &mut windows {
        let Some(&s) = scales.get(&w.scene) else {
            return Err(LoadError::NoScale {
                scene: w.scene.clone(),
                table: root
                    .join("sdd")
                    .join("scales")
                    .join("sdd_meters_per_pixel.csv"),
            });
        };
        w.scale(s as f32);
    }
    Ok(Dataset {
        name: format!("{} (metres)", px.name),
        unit: Unit::Metres,
        windows,
    })
}

/// Why a split could not be loaded.
#[derive(Debug, thiserror::Error)]
pub enum LoadError {
    /// A data file or folder problem (names the file and line).
    #[error(transparent)]
    Data(#[from] DataError),
    /// A validation scene that `sdd/train` does not have.
    #[error("validation scene {scene:?} is not in {dataset}")]
    UnknownValScene {
        /// The scene asked for.
        scene: String,
        /// The data set searched.
        dataset: String,
    },
    /// A validation scene whose file exists but gives no window.
    #[error(
        "validation scene {scene:?}: {file} is empty (no track of 20 rows): \
         a validation scene needs at least one window",
        file = .file.display()
    )]
    EmptyValScene {
        /// The scene asked for.
        scene: String,
        /// Its file.
        file: std::path::PathBuf,
    },
    /// A combined data set of no part.
    #[error("a combined data set needs at least one part")]
    Empty,
    /// A data-set folder's description or clock is wrong.
    #[error(transparent)]
    Folder(#[from] super::folder_info::FolderError),
    /// An SDD scene without a metres-per-pixel factor.
    #[error(
        "SDD scene {scene:?} has no metres-per-pixel factor in {table}: \
         it cannot be converted to metres",
        table = .table.display()
    )]
    NoScale {
        /// The scene.
        scene: String,
        /// The table read.
        table: std::path::PathBuf,
    },
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip() {
        for s in ["sdd", "sdd-m", "eth_ucy:zara1", "eth_ucy:eth"] {
            assert_eq!(DatasetSpec::parse(s).unwrap().to_string(), s);
        }
        assert!(DatasetSpec::parse("eth_ucy:mydrone")
            .unwrap_err()
            .contains("unknown ETH/UCY scene"));
        assert!(DatasetSpec::parse("sdd_m").is_err());
        assert_eq!(DatasetSpec::SddMetres.unit(), Unit::Metres);
        assert_eq!(DatasetSpec::Sdd.unit(), Unit::Pixels);
    }

    /// An empty validation scene file is reported as empty, naming the file; a scene
    /// without a file is still missing.
    #[test]
    fn an_empty_validation_file_is_named_not_missing() {
        let root = std::env::temp_dir().join(format!("gpecnet-spec-empty-{}", std::process::id()));
        let train = root.join("sdd").join("train");
        std::fs::create_dir_all(&train).unwrap();
        let rows: String = (0..20)
            .map(|t| format!("{} 1.0 {}.0 5.5\n", 12 * t, 10 + t))
            .collect();
        std::fs::write(train.join("a.txt"), rows).unwrap();
        std::fs::write(train.join("v.txt"), "").unwrap();
        let e = load(&root, &DatasetSpec::Sdd, Split::Val, &["v".to_string()])
            .unwrap_err()
            .to_string();
        assert!(
            e.contains(&train.join("v.txt").display().to_string())
                && e.contains("is empty")
                && !e.contains("is not in"),
            "{e}"
        );
        let e = load(&root, &DatasetSpec::Sdd, Split::Val, &["w".to_string()])
            .unwrap_err()
            .to_string();
        assert!(e.contains("is not in"), "{e}");
        let _ = std::fs::remove_dir_all(&root);
    }

    /// A folder set's messages name the folder, never the data root it does not read.
    #[test]
    fn a_folder_set_is_located_by_its_folder() {
        let root = Path::new("../shared/data");
        let folder = DatasetSpec::Folder {
            dir: "./mine".into(),
            unit: Unit::Metres,
            licence: String::new(),
        };
        assert_eq!(folder.location(root), "the folder ./mine");
        assert_eq!(
            DatasetSpec::Combined(vec![
                DatasetSpec::SddMetres,
                folder,
                DatasetSpec::EthUcy("eth".into())
            ])
            .location(root),
            "sdd-m under the data root ../shared/data and the folder ./mine and \
             eth_ucy:eth under the data root ../shared/data"
        );
    }

    /// An existing folder whose name holds a `+` is one data set, alone or joined to
    /// another; a `+` outside any existing folder still joins.
    #[test]
    fn an_existing_folder_with_a_plus_is_not_split() {
        let base = std::env::temp_dir().join(format!("gpecnet-spec-plus-{}", std::process::id()));
        let dir = base.join("a+b");
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(
            dir.join("dataset.toml"),
            "unit = \"m\"\nseconds_per_frame = 0.4\n",
        )
        .unwrap();
        let name = format!("{}", dir.display());
        assert_eq!(
            DatasetSpec::parse(&name).unwrap(),
            DatasetSpec::Folder {
                dir: name.clone(),
                unit: Unit::Metres,
                licence: String::new(),
            }
        );
        match DatasetSpec::parse(&format!("sdd-m+{name}")).unwrap() {
            DatasetSpec::Combined(parts) => {
                assert_eq!(parts.len(), 2);
                assert_eq!(parts[0], DatasetSpec::SddMetres);
                assert_eq!(parts[1].to_string(), name);
            }
            other => panic!("{other:?}"),
        }
        assert_eq!(
            split_parts(&format!("{name}+eth_ucy:zara1")),
            vec![name.clone(), "eth_ucy:zara1".to_string()]
        );
        assert_eq!(
            split_parts("sdd-m+eth_ucy:zara1"),
            vec!["sdd-m".to_string(), "eth_ucy:zara1".to_string()]
        );
        let _ = std::fs::remove_dir_all(&base);
    }
}
