//! Hostile files and specs for every text parser a user feeds the
//! programs that has no fuzz target elsewhere: the configuration, the grasp
//! parameters, skin files (TOML and JSON) and topology files and specs.
//! (The frame, the interface datagram, the robot link and URDF have theirs
//! beside their parsers: `protocol/tests/wire.rs`,
//! `protocol/src/robot_link.rs`, `host/tests/interface_fuzz.rs`,
//! `model/tests/urdf_input.rs`.) Each input gives `Ok` or a typed error,
//! never a panic or an allocation the size of a number in the input: any
//! text, and mutations of valid documents (cut short, a character changed,
//! an extreme value put anywhere). A stable-toolchain stand-in for
//! `cargo fuzz`; `PROPTEST_CASES=100000` runs it longer.

use proptest::prelude::*;
use skin_host::config::Config;
use skin_host::control::params::Params;
use skin_model::robot::hrp2;
use skin_model::skin::Skin;
use skin_sim::network::Topology;

/// Values that break parsers that trust numbers.
const EXTREMES: [&str; 15] = [
    "1e300",
    "-1e300",
    "nan",
    "inf",
    "-inf",
    "0",
    "-0.0",
    "1e38",
    "18446744073709551616",
    "4294967296",
    "100000000",
    "\"\"",
    "[]",
    "{",
    "\n[[x]]\n",
];

/// One parser and a valid document of its format.
struct Format {
    name: &'static str,
    valid: String,
    parse: fn(&str) -> bool,
}

fn formats() -> Vec<Format> {
    let link = hrp2::robot().links().iter().find(|l| l.name.starts_with("RARM")).unwrap().name.clone();
    vec![
        Format { name: "config", valid: Config::default().to_toml(), parse: |t| Config::from_toml(t, "fuzz").is_ok() },
        Format {
            name: "grasp parameters",
            valid: Params::default().to_toml(),
            parse: |t| Params::from_toml_str(t).is_ok(),
        },
        Format {
            name: "skin TOML",
            valid: format!(
                "[[link]]\nname = \"{link}\"\ncell = [{{ xyz = [0.0, 0.05, 0.2], rpy = [-1.5708, 0.0, 0.0] }}, {{ xyz = [0.05, 0.0, 0.1], id = 9 }}]\n"
            ),
            parse: |t| Skin::from_toml_str(&hrp2::robot(), t).is_ok(),
        },
        Format {
            name: "skin JSON",
            valid: format!(
                "{{\"link\": [{{\"name\": \"{link}\", \"cell\": [{{\"xyz\": [0, 0.05, 0.2], \"rpy\": [0, 1.5708, 0]}}]}}]}}"
            ),
            parse: |t| Skin::from_json_str(&hrp2::robot(), t).is_ok(),
        },
        Format {
            name: "topology TOML",
            valid: "cells = 3\npositions_m = [[0.0, 0.0], [0.03, 0.0], [0.06, 0.0]]\nlinks = [[0, 0, 1, 2], [1, 0, 2, 2]]\ninterfaces = [[0, 2]]\n"
                .into(),
            parse: |t| Topology::from_text(t, false).is_ok(),
        },
        Format {
            name: "topology JSON",
            valid: "{\"cells\": 2, \"links\": [[0, 0, 1, 2]], \"interfaces\": [[0, 2]]}".into(),
            parse: |t| Topology::from_text(t, true).is_ok(),
        },
        Format { name: "patch spec", valid: "hex:3x4+hex:2x2".into(), parse: |t| Topology::parse(t).is_ok() },
        Format { name: "chain spec", valid: "chain:5".into(), parse: |t| Topology::parse(t).is_ok() },
    ]
}

#[test]
fn the_valid_documents_parse() {
    for f in formats() {
        assert!((f.parse)(&f.valid), "{}: {}", f.name, f.valid);
    }
}

/// How a valid document is spoiled.
#[derive(Clone, Debug)]
enum Mutation {
    /// Cut at a character.
    Cut(usize),
    /// A character replaced.
    Replace(usize, char),
    /// An extreme value put in at a character.
    Insert(usize, &'static str),
    /// Every number from the `n`th on replaced by an extreme value.
    Numbers(usize, &'static str),
}

fn mutation() -> impl Strategy<Value = Mutation> {
    let extreme = proptest::sample::select(EXTREMES.to_vec());
    prop_oneof![
        any::<usize>().prop_map(Mutation::Cut),
        (any::<usize>(), any::<char>()).prop_map(|(i, c)| Mutation::Replace(i, c)),
        (any::<usize>(), extreme.clone()).prop_map(|(i, e)| Mutation::Insert(i, e)),
        (0usize..40, extreme).prop_map(|(n, e)| Mutation::Numbers(n, e)),
    ]
}

fn spoil(valid: &str, m: &Mutation) -> String {
    let chars: Vec<char> = valid.chars().collect();
    let at = |i: usize| i % (chars.len() + 1);
    let text = |c: &[char]| c.iter().collect::<String>();
    match *m {
        Mutation::Cut(i) => text(&chars[..at(i)]),
        Mutation::Replace(i, c) => {
            let mut out = chars.clone();
            if let Some(x) = out.get_mut(i % chars.len().max(1)) {
                *x = c;
            }
            text(&out)
        }
        Mutation::Insert(i, e) => text(&chars[..at(i)]) + e + &text(&chars[at(i)..]),
        Mutation::Numbers(n, e) => {
            let mut seen = 0;
            let mut out = String::new();
            let mut in_number = false;
            for c in chars {
                let digit = c.is_ascii_digit() || (in_number && c == '.');
                if digit && !in_number {
                    seen += 1;
                    if seen > n {
                        out += e;
                    }
                }
                in_number = digit;
                if !(digit && seen > n) {
                    out.push(c);
                }
            }
            out
        }
    }
}

proptest! {
    #[test]
    fn any_text_is_ok_or_a_typed_error(text in ".{0,300}", which in 0usize..8) {
        let f = &formats()[which];
        (f.parse)(&text);
    }

    #[test]
    fn spoiled_documents_are_ok_or_a_typed_error(which in 0usize..8, mutations in proptest::collection::vec(mutation(), 1..4)) {
        let f = &formats()[which];
        let text = mutations.iter().fold(f.valid.clone(), |t, m| spoil(&t, m));
        (f.parse)(&text);
    }
}
