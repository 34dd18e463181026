//! With the `mujoco` feature, the binaries and tests of this package find
//! libmujoco at run time without `LD_LIBRARY_PATH`: the folder mujoco-rs
//! links against (`MUJOCO_DYNAMIC_LINK_DIR`, set in `.cargo/config.toml`)
//! goes into their rpath. skin-host builds with this same script.

fn main() {
    println!("cargo::rerun-if-env-changed=MUJOCO_DYNAMIC_LINK_DIR");
    if std::env::var_os("CARGO_FEATURE_MUJOCO").is_none() {
        return;
    }
    if let Ok(dir) = std::env::var("MUJOCO_DYNAMIC_LINK_DIR") {
        println!("cargo::rustc-link-arg=-Wl,-rpath,{dir}");
    }
}
