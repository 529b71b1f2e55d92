//! Fuzz target: lente::fuzz::Target::Curve (see src/fuzz.rs).
#![no_main]

use lente::fuzz::{configure, run, Target};
use libfuzzer_sys::fuzz_target;

fuzz_target!(init: configure(), |data: &[u8]| {
    let _ = run(Target::Curve, data);
});
