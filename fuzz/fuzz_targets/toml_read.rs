//! Fuzz the TOML readers (machine model, servo model) on arbitrary text:
//! they must never panic, and a machine model accepted must have every
//! error function finite over its axis travel.
#![no_main]

use std::path::Path;

use libfuzzer_sys::fuzz_target;
use mtwin::model::parse_machine;
use mtwin::sysid::servo_from_toml_str;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let _ = servo_from_toml_str(Path::new("fuzz.toml"), text);
    let Ok(m) = parse_machine(Path::new("fuzz.toml"), text) else {
        return;
    };
    for axis in &m.axes {
        for f in axis.errors.pdge.iter().flatten() {
            for k in 0..=16 {
                let q = axis.travel[0] + (axis.travel[1] - axis.travel[0]) * f64::from(k) / 16.0;
                assert!(f.eval(q, axis.travel).is_finite());
            }
        }
    }
});
