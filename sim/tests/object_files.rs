//! The shipped object files read by a TOML reader we did not write
//! (Python's `tomllib`) give the very objects the simulator compiles in: the
//! format is plain TOML, so users' tools can write and check it.

use std::path::Path;
use std::process::Command;

use serde_json::Value;
use skin_sim::scene::object::Object;
use skin_sim::scene::shape::Shape;

/// An object file as Python's standard TOML reader sees it.
fn python_reads(file: &Path) -> Value {
    let out = Command::new("python3")
        .args(["-c", "import json, sys, tomllib; print(json.dumps(tomllib.load(open(sys.argv[1], 'rb'))))"])
        .arg(file)
        .output()
        .expect("python3 runs (cargo xtask install installs it)");
    assert!(out.status.success(), "{}: {}", file.display(), String::from_utf8_lossy(&out.stderr));
    serde_json::from_slice(&out.stdout).unwrap()
}

#[test]
fn python_reads_the_shipped_objects_as_we_do() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("objects");
    let ours = Object::figure_16();
    let mut files: Vec<_> = std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().path()).collect();
    files.sort();
    assert_eq!(files.len(), ours.len());
    for file in files {
        let theirs = python_reads(&file);
        let o = ours.iter().find(|o| o.name == theirs["name"]).unwrap_or_else(|| panic!("{theirs}"));
        for (key, value) in [
            ("mass_kg", o.mass_kg),
            ("stiffness_n_per_m", o.stiffness_n_per_m),
            ("reflectance", o.reflectance),
            ("friction", o.friction),
        ] {
            assert_eq!(theirs[key].as_f64(), Some(value), "{}: {key}", o.name);
        }
        let shape = &theirs["shape"];
        let n = |v: &Value| v.as_f64().unwrap();
        let xyz = |v: &Value| [n(&v[0]), n(&v[1]), n(&v[2])];
        match o.shape {
            Shape::Box { half, round_m } => {
                assert_eq!(xyz(&shape["box"]["half"]), [half.x, half.y, half.z]);
                assert_eq!(n(&shape["box"]["round_m"]), round_m);
            }
            Shape::Cylinder { radius, half_height, round_m } => {
                let c = &shape["cylinder"];
                let rim = c.get("round_m").map_or(0.0, n);
                assert_eq!([n(&c["radius"]), n(&c["half_height"]), rim], [radius, half_height, round_m]);
            }
            Shape::Sphere { radius } => assert_eq!(n(&shape["sphere"]["radius"]), radius),
            Shape::Blob { semi, bump_m, bump_rad_per_m } => {
                let b = &shape["blob"];
                assert_eq!(xyz(&b["semi"]), [semi.x, semi.y, semi.z]);
                assert_eq!([n(&b["bump_m"]), n(&b["bump_rad_per_m"])], [bump_m, bump_rad_per_m]);
            }
        }
    }
}
