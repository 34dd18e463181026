//! Object files: an object of the simulator's shapes, and where it is put;
//! the five objects of Figure 16 ship as such files, compiled in.
//!
//! ```toml
//! name = "paint_bucket"
//! shape = { cylinder = { radius = 0.12, half_height = 0.15 } }
//! # or { cylinder = { radius = 0.12, half_height = 0.15, round_m = 0.005 } } (rims rounded),
//! #    { box = { half = [0.1, 0.15, 0.1], round_m = 0.01 } }, { sphere = { radius = 0.1 } },
//! #    { blob = { semi = [0.1, 0.12, 0.1], bump_m = 0.01, bump_rad_per_m = 25.0 } }
//! mass_kg = 0.6
//! stiffness_n_per_m = 3000.0
//! reflectance = 0.6
//! friction = 0.4
//! offset_m = [0.0, 0.03, 0.0]   # optional, from the default spot: forward, left, up
//! yaw_rad = 0.3                 # optional
//! ```
//!
//! Every key but the placement is required and unknown keys are refused, so
//! a typo cannot silently keep a default; every value is range-checked and
//! a mistake names its key. Physically impossible values (a size, mass or
//! stiffness of zero or less, edges or rims rounder than the body, bumps deeper than
//! the blob) are refused, and so are values past what the simulated arms
//! could ever meet (a half size over 1 m, a mass over 1000 kg), which are
//! typos.

use std::path::{Path, PathBuf};

use nalgebra::Vector3;
use serde::Deserialize;

use super::object::Object;
use super::object_error::ObjectError;
use super::placement::{in_range, ObjectAt, Placement};
use super::shape::Shape;

/// Largest half size of a shape, m.
const MAX_HALF_M: f64 = 1.0;
/// Longest object name, bytes.
const MAX_NAME: usize = 64;

/// The object files of Figure 16, (A) to (E).
const FIGURE_16: [&str; 5] = [
    include_str!("../../objects/trash_bin.toml"),
    include_str!("../../objects/sponge_rock.toml"),
    include_str!("../../objects/moving_box.toml"),
    include_str!("../../objects/box_lid.toml"),
    include_str!("../../objects/delivery_box.toml"),
];

impl Object {
    /// The five objects of Figure 16, (A) to (E).
    pub fn figure_16() -> Vec<Object> {
        FIGURE_16.iter().map(|text| parse(text).expect("the shipped object files are valid").object).collect()
    }

    /// An object of Figure 16 by name.
    pub fn by_name(name: &str) -> Option<Object> {
        Object::figure_16().into_iter().find(|o| o.name == name)
    }
}

/// The file as written.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct File {
    name: String,
    shape: Shape,
    mass_kg: f64,
    stiffness_n_per_m: f64,
    reflectance: f64,
    friction: f64,
    #[serde(default)]
    offset_m: [f64; 3],
    #[serde(default)]
    yaw_rad: f64,
}

/// A half size in (0, 1] m.
fn half(key: &str, v: f64) -> Result<(), ObjectError> {
    in_range(key, v, f64::MIN_POSITIVE, MAX_HALF_M, "a size in (0, 1] m")
}

fn halves(key: &str, v: &Vector3<f64>) -> Result<(), ObjectError> {
    for (i, h) in v.iter().enumerate() {
        half(&format!("{key}[{i}]"), *h)?;
    }
    Ok(())
}

/// Checks a shape is a body: sizes in (0, 1] m, edges and rims no rounder
/// than the body, bumps no deeper than half the blob.
fn check_shape(shape: &Shape) -> Result<(), ObjectError> {
    match *shape {
        Shape::Box { half, round_m } => {
            halves("shape.box.half", &half)?;
            in_range("shape.box.round_m", round_m, 0.0, half.min(), "from 0 to the smallest half size")
        }
        Shape::Cylinder { radius, half_height, round_m } => {
            self::half("shape.cylinder.radius", radius)?;
            self::half("shape.cylinder.half_height", half_height)?;
            let most = radius.min(half_height);
            in_range("shape.cylinder.round_m", round_m, 0.0, most, "from 0 to the smaller of radius and half height")
        }
        Shape::Sphere { radius } => self::half("shape.sphere.radius", radius),
        Shape::Blob { semi, bump_m, bump_rad_per_m } => {
            halves("shape.blob.semi", &semi)?;
            in_range("shape.blob.bump_m", bump_m, 0.0, semi.min() / 2.0, "from 0 to half the smallest semi-axis")?;
            in_range("shape.blob.bump_rad_per_m", bump_rad_per_m, 0.0, 1000.0, "from 0 to 1000 rad/m")
        }
    }
}

fn check_name(name: &str) -> Result<(), ObjectError> {
    let ok = !name.is_empty()
        && name.len() <= MAX_NAME
        && name.bytes().all(|b| b.is_ascii_alphanumeric() || b == b'_' || b == b'-')
        && !matches!(name, "all" | "none");
    if ok {
        Ok(())
    } else {
        Err(ObjectError::Name(name.to_owned()))
    }
}

/// Parses and checks an object file's text.
pub fn parse(text: &str) -> Result<ObjectAt, ObjectError> {
    let f: File = toml::from_str(text).map_err(ObjectError::Toml)?;
    check_name(&f.name)?;
    check_shape(&f.shape)?;
    let shape = f.shape;
    in_range("mass_kg", f.mass_kg, f64::MIN_POSITIVE, 1000.0, "a mass in (0, 1000] kg")?;
    in_range("stiffness_n_per_m", f.stiffness_n_per_m, 1.0, 1e7, "a stiffness in [1, 1e7] N/m")?;
    in_range("reflectance", f.reflectance, 0.0, 2.0, "an infrared reflectance relative to skin in [0, 2]")?;
    in_range("friction", f.friction, 0.0, 2.0, "a friction coefficient in [0, 2]")?;
    let placement = Placement { offset_m: Vector3::from(f.offset_m), yaw_rad: f.yaw_rad };
    placement.check()?;
    let object = Object {
        name: f.name,
        shape,
        mass_kg: f.mass_kg,
        stiffness_n_per_m: f.stiffness_n_per_m,
        reflectance: f.reflectance,
        friction: f.friction,
    };
    Ok(ObjectAt { object, placement })
}

/// Reads an object file, or every `*.toml` of a folder (by name).
pub fn read(path: &Path) -> Result<Vec<ObjectAt>, ObjectError> {
    let shown = || path.display().to_string();
    let read_error = |source| ObjectError::Read { path: shown(), source };
    let files: Vec<PathBuf> = if path.is_dir() {
        let mut files = Vec::new();
        for entry in std::fs::read_dir(path).map_err(read_error)? {
            let p = entry.map_err(read_error)?.path();
            if p.extension().is_some_and(|e| e == "toml") && p.is_file() {
                files.push(p);
            }
        }
        if files.is_empty() {
            return Err(ObjectError::EmptyFolder(shown()));
        }
        files.sort();
        files
    } else {
        vec![path.to_path_buf()]
    };
    files
        .iter()
        .map(|file| {
            let path = file.display().to_string();
            let text = skin_model::file::read_text_capped(file, skin_model::file::MIB)
                .map_err(|source| ObjectError::Read { path: path.clone(), source })?;
            parse(&text).map_err(|e| ObjectError::InFile { path, source: Box::new(e) })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    const BUCKET: &str = "name = \"paint_bucket\"\nshape = { cylinder = { radius = 0.12, half_height = 0.15 } }\n\
        mass_kg = 0.6\nstiffness_n_per_m = 3000.0\nreflectance = 0.6\nfriction = 0.4\n\
        offset_m = [0.0, 0.03, 0.0]\nyaw_rad = 0.3\n";

    #[test]
    fn the_issue_example_reads() {
        let at = parse(BUCKET).unwrap();
        assert_eq!(at.object.name, "paint_bucket");
        assert_eq!(at.object.shape, Shape::Cylinder { radius: 0.12, half_height: 0.15, round_m: 0.0 });
        assert_eq!((at.object.mass_kg, at.object.friction), (0.6, 0.4));
        assert_eq!(at.placement, Placement { offset_m: Vector3::new(0.0, 0.03, 0.0), yaw_rad: 0.3 });
        for shape in [
            "{ box = { half = [0.1, 0.15, 0.1], round_m = 0.01 } }",
            "{ cylinder = { radius = 0.12, half_height = 0.15, round_m = 0.005 } }",
            "{ sphere = { radius = 0.1 } }",
            "{ blob = { semi = [0.1, 0.12, 0.1], bump_m = 0.01, bump_rad_per_m = 25.0 } }",
        ] {
            let text = BUCKET.replace("{ cylinder = { radius = 0.12, half_height = 0.15 } }", shape);
            parse(&text).unwrap_or_else(|e| panic!("{shape}: {e}"));
        }
        let plain = BUCKET.replace("offset_m = [0.0, 0.03, 0.0]\nyaw_rad = 0.3\n", "");
        assert_eq!(parse(&plain).unwrap().placement, Placement::default(), "placement is optional");
    }

    #[test]
    fn mistakes_name_the_key() {
        let cyl = "{ cylinder = { radius = 0.12, half_height = 0.15 } }";
        for (from, to, key) in [
            ("mass_kg = 0.6", "mass_kg = 0.0", "mass_kg"),
            ("mass_kg = 0.6", "mass_kg = -1.0", "mass_kg"),
            ("mass_kg = 0.6", "mass_kg = 1e9", "mass_kg"),
            ("mass_kg = 0.6", "mass_kg = nan", "mass_kg"),
            ("stiffness_n_per_m = 3000.0", "stiffness_n_per_m = 0.0", "stiffness_n_per_m"),
            ("reflectance = 0.6", "reflectance = -0.1", "reflectance"),
            ("friction = 0.4", "friction = inf", "friction"),
            ("radius = 0.12", "radius = -0.12", "shape.cylinder.radius"),
            ("half_height = 0.15", "half_height = 5.0", "shape.cylinder.half_height"),
            ("half_height = 0.15", "half_height = 0.15, round_m = 0.13", "shape.cylinder.round_m"),
            (cyl, "{ box = { half = [0.1, 0.0, 0.1] } }", "shape.box.half[1]"),
            (cyl, "{ box = { half = [0.1, 0.1, 0.1], round_m = 0.2 } }", "shape.box.round_m"),
            (cyl, "{ blob = { semi = [0.1, 0.1, 0.1], bump_m = 0.09 } }", "shape.blob.bump_m"),
            (cyl, "{ sphere = { radius = 0.0 } }", "shape.sphere.radius"),
            ("offset_m = [0.0, 0.03, 0.0]", "offset_m = [-0.1, 0.03, 0.0]", "offset_m[0]"),
            ("yaw_rad = 0.3", "yaw_rad = 7.0", "yaw_rad"),
            ("\"paint_bucket\"", "\"../etc/passwd\"", "name"),
            ("\"paint_bucket\"", "\"all\"", "name"),
            ("mass_kg = 0.6", "mass_kg = \"heavy\"", "mass_kg"),
            ("mass_kg = 0.6", "mass_g = 600.0", "mass_g"),
            ("mass_kg = 0.6\n", "", "mass_kg"),
            (cyl, "{ cone = { radius = 0.1 } }", "cone"),
            ("radius = 0.12", "radius = 0.12, height = 0.1", "height"),
        ] {
            let text = BUCKET.replace(from, to);
            assert_ne!(text, BUCKET, "{from}");
            let e = parse(&text).expect_err(to).to_string();
            assert!(e.contains(key), "{to}: {e}");
        }
    }

    #[test]
    fn a_folder_reads_every_toml_file_and_names_the_bad_one() {
        let dir = std::env::temp_dir().join(format!("skin-objects-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join("b.toml"), BUCKET.replace("paint_bucket", "b")).unwrap();
        std::fs::write(dir.join("a.toml"), BUCKET.replace("paint_bucket", "a")).unwrap();
        std::fs::write(dir.join("notes.txt"), "not an object").unwrap();
        let names: Vec<String> = read(&dir).unwrap().into_iter().map(|o| o.object.name).collect();
        assert_eq!(names, ["a", "b"]);
        assert_eq!(read(&dir.join("a.toml")).unwrap()[0].object.name, "a");
        std::fs::write(dir.join("c.toml"), BUCKET.replace("mass_kg = 0.6", "mass_kg = 0")).unwrap();
        let e = read(&dir).unwrap_err().to_string();
        assert!(e.contains("c.toml") && e.contains("mass_kg"), "{e}");
        assert!(read(&dir.join("missing.toml")).unwrap_err().to_string().contains("cannot read"));
        let empty = dir.join("empty");
        std::fs::create_dir_all(&empty).unwrap();
        assert!(matches!(read(&empty), Err(ObjectError::EmptyFolder(_))));
        std::fs::remove_dir_all(&dir).unwrap();
    }

    proptest! {
        /// Any text gives an object or a typed error, never a panic; what
        /// is accepted is a body the scene can work with.
        #[test]
        fn any_text_is_an_object_or_an_error(text in "\\PC{0,300}") {
            if let Ok(at) = parse(&text) {
                prop_assert!(at.object.shape.bounding_radius().is_finite());
            }
        }

        /// Spoiled versions of a valid file: any number anywhere.
        #[test]
        fn any_number_anywhere_is_checked(k in 0usize..10, v in proptest::num::f64::ANY) {
            let text = BUCKET.replacen(["0.12", "0.15", "0.6", "3000.0", "0.6", "0.4", "0.0", "0.03", "0.0", "0.3"][k], &format!("{v:?}"), 1);
            if let Ok(at) = parse(&text) {
                let o = at.object;
                prop_assert!(o.mass_kg > 0.0 && o.stiffness_n_per_m > 0.0 && o.shape.bounding_radius() > 0.0);
                prop_assert!(at.placement.check().is_ok());
            }
        }
    }
}
