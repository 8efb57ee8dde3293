//! Fuzz the lossless G-code parser and the interpreter on arbitrary bytes.
#![no_main]

use libfuzzer_sys::fuzz_target;
use mtwin::gcode::{InterpOptions, Interpreter, Program};

fuzz_target!(|data: &[u8]| {
    let Ok(program) = Program::parse(data) else {
        return;
    };
    assert_eq!(program.to_bytes(), data, "round trip must be the identity");
    let mut interp = Interpreter::new(InterpOptions::default());
    // Events of one block at a time, as the program driver consumes them
    // (keeping a whole program's events would measure the harness's memory).
    let mut events = Vec::new();
    for block in &program.blocks {
        events.clear();
        if interp.execute(block, &mut events).is_err() {
            return;
        }
    }
    // The end of the input, as the program driver ends it (moves held back
    // by cutter radius compensation).
    let _ = interp.finish();
});
