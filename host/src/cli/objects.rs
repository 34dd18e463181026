//! The objects `skin grasp` puts in front of the robot, and where, and
//! `skin objects`, which writes generated object files for it.
//!
//! Built-in names (the five of Figure 16, `all`, `none`), object files
//! (`--object-file`, repeatable, a file or a folder of them), and a
//! placement for all of them: `--offset`/`--yaw`, or `--jitter SEED` for a
//! seeded random one each within the envelope of
//! [`skin_sim::scene::placement`] (forward 0 to 2 cm, sideways +-3 cm, yaw
//! +-0.3 rad). A placement flag replaces the placement in object files.

use std::fs::OpenOptions;
use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;

use skin_host::grasping::GraspError;
use skin_model::robot::hrp2;
use skin_sim::scene::experiment::Setup;
use skin_sim::scene::generated::{object_files, Reach};
use skin_sim::scene::object::Object;
use skin_sim::scene::object_error::ObjectError;
use skin_sim::scene::object_file;
use skin_sim::scene::placement::{ObjectAt, Placement};
use skin_sim::scene::SkinModel;

/// The object arguments of `skin grasp`.
#[derive(clap::Args)]
pub struct ObjectArgs {
    /// The object: trash_bin, sponge_rock, moving_box, box_lid, delivery_box, all, or none
    /// [default: all, or none of these when --object-file is given].
    #[arg(long)]
    object: Option<String>,
    /// An object file (TOML, see sim/objects/), or a folder of them; repeatable.
    #[arg(long, value_name = "PATH")]
    object_file: Vec<PathBuf>,
    /// Move every object from the default spot: forward,left,up in m (e.g. 0,0.03,0).
    #[arg(long, value_name = "X,Y,Z", value_parser = offset, allow_hyphen_values = true, conflicts_with = "jitter")]
    offset: Option<[f64; 3]>,
    /// Turn every object about the vertical, rad.
    #[arg(long, value_name = "RAD", allow_hyphen_values = true, conflicts_with = "jitter")]
    yaw: Option<f64>,
    /// Put each object at a random spot within the envelope (forward 0 to 0.02 m, sideways +-0.03 m, yaw +-0.3 rad), drawn from this seed.
    #[arg(long, value_name = "SEED")]
    jitter: Option<u64>,
}

/// Why the placement flags cannot be used.
#[derive(Debug, thiserror::Error)]
#[error("--offset/--yaw: {0}")]
pub struct PlacementError(#[source] ObjectError);

fn offset(text: &str) -> Result<[f64; 3], String> {
    let parts: Vec<&str> = text.split(',').collect();
    let numbers: Result<Vec<f64>, _> = parts.iter().map(|p| p.trim().parse::<f64>()).collect();
    match numbers.as_deref() {
        Ok(&[x, y, z]) => Ok([x, y, z]),
        _ => Err(format!("expected forward,left,up in m (three numbers), not {text:?}")),
    }
}

impl ObjectArgs {
    /// What to grasp, in order, each where it is put.
    pub fn chosen(&self) -> Result<Vec<Option<ObjectAt>>, Box<dyn std::error::Error>> {
        let default = if self.object_file.is_empty() { Some("all") } else { None };
        let mut chosen: Vec<Option<ObjectAt>> = match self.object.as_deref().or(default) {
            Some(choice) => built_in(choice)?
                .into_iter()
                .map(|o| o.map(|object| ObjectAt { object, placement: Placement::default() }))
                .collect(),
            None => Vec::new(),
        };
        for path in &self.object_file {
            chosen.extend(object_file::read(path)?.into_iter().map(Some));
        }
        let placements = match self.jitter {
            Some(seed) => Some(Placement::jitters(seed, chosen.len())),
            None if self.offset.is_some() || self.yaw.is_some() => {
                let p = Placement {
                    offset_m: self.offset.unwrap_or_default().into(),
                    yaw_rad: self.yaw.unwrap_or_default(),
                };
                p.check().map_err(PlacementError)?;
                Some(vec![p; chosen.len()])
            }
            None => None,
        };
        if let Some(placements) = placements {
            for (at, p) in chosen.iter_mut().flatten().zip(placements) {
                at.placement = p;
            }
        }
        Ok(chosen)
    }
}

/// The objects a built-in choice names: one, all of Figure 16, or none.
pub fn built_in(choice: &str) -> Result<Vec<Option<Object>>, GraspError> {
    match choice {
        "all" => Ok(Object::figure_16().into_iter().map(Some).collect()),
        "none" => Ok(vec![None]),
        name => Object::by_name(name).map(|o| vec![Some(o)]).ok_or_else(|| GraspError::UnknownObject(name.into())),
    }
}

/// Arguments of `skin objects`.
#[derive(clap::Args)]
pub struct GenerateArgs {
    /// Folder to write the object files into (made if missing; a file already there is never overwritten).
    #[arg(long, value_name = "DIR")]
    out: PathBuf,
    /// Generator seed, repeatable: `--count` objects from each, named `gen<SEED>_<k>` [default: 1].
    #[arg(long = "seed", value_name = "SEED")]
    seeds: Vec<u64>,
    /// Objects per seed.
    #[arg(long, default_value_t = 25, value_parser = clap::value_parser!(u64).range(1..=10_000))]
    count: u64,
    /// Write no placement (place them with `skin grasp --jitter` or `--offset`); by default each is put anywhere both arms of the built-in robot reach around it, turned up to 0.3 rad.
    #[arg(long)]
    unplaced: bool,
}

/// Writes the generated object files; the same seeds give the same files.
pub fn generate(args: GenerateArgs) -> Result<ExitCode, Box<dyn std::error::Error>> {
    let seeds = if args.seeds.is_empty() { vec![1] } else { args.seeds };
    let reach = if args.unplaced {
        None
    } else {
        let robot = hrp2::robot();
        Some(Reach::new(&robot, &Setup::new(&robot, 0)?, SkinModel::default().surface_offset_m))
    };
    let count = usize::try_from(args.count)?;
    std::fs::create_dir_all(&args.out).map_err(|e| format!("--out {}: {e}", args.out.display()))?;
    let mut written = 0;
    for seed in seeds {
        for (name, text) in object_files(seed, count, reach.as_ref())? {
            let path = args.out.join(format!("{name}.toml"));
            let mut file = OpenOptions::new().write(true).create_new(true).open(&path).map_err(|e| {
                format!("{}: {e} (objects are never overwritten: choose another --out)", path.display())
            })?;
            file.write_all(text.as_bytes()).map_err(|e| format!("{}: {e}", path.display()))?;
            written += 1;
        }
    }
    println!("wrote {written} object files to {} (grasp them: skin grasp --object-file {0})", args.out.display());
    Ok(ExitCode::SUCCESS)
}
