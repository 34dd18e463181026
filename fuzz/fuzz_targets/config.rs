//! Any text as each TOML file a user writes: the host configuration, the
//! grasp parameters, a skin file and a topology file.
#![no_main]

use libfuzzer_sys::fuzz_target;
use skin_host::config::Config;
use skin_host::control::params::Params;
use skin_sim::network::Topology;
use skin_sim::robot::hrp2;
use skin_sim::skin::Skin;

fuzz_target!(|text: &str| {
    let _ = Config::from_toml(text, "fuzz");
    let _ = Params::from_toml_str(text);
    let _ = Skin::from_toml_str(&hrp2::robot(), text);
    let _ = Topology::from_text(text, false);
    let _ = Topology::parse(text);
});
