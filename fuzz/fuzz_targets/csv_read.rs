//! Fuzz the CSV reader on arbitrary bytes: reading, then asking every cell
//! as a number, must never panic; every number accepted is finite and
//! within the magnitude bound of `mtwin::limits`.
#![no_main]

use std::path::Path;

use libfuzzer_sys::fuzz_target;
use mtwin::io::Table;

fuzz_target!(|data: &[u8]| {
    let Ok(table) = Table::from_reader(Path::new("fuzz.csv"), data) else {
        return;
    };
    for name in table.headers().to_vec() {
        let Some(col) = table.column(&name) else {
            continue;
        };
        if let Ok(values) = table.numbers(col) {
            for v in values {
                assert!(v.is_finite() && v.abs() <= mtwin::limits::MAX_ABS_VALUE);
            }
        }
    }
});
