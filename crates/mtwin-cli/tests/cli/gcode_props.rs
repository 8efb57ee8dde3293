//! Property tests: the parser and interpreter never panic, round-trip is
//! the identity on whatever parses, and word edits keep the block coherent.

use mtwin::gcode::{Block, InterpOptions, Interpreter, NumberFormat, Program};
use proptest::prelude::*;

/// Strings drawn from G-code's own alphabet, so that many of them parse.
fn gcode_like() -> impl Strategy<Value = String> {
    proptest::string::string_regex("([GgXYZABCIJKRFSMPN][ ]?[-+]?[0-9]{0,3}(\\.[0-9]{0,4})?[ \t]?|\\([a-z ]{0,5}\\)|;[a-z]{0,3}|%|/|#1=[0-9]|\\[1\\+2\\]|\r?\n){0,24}")
        .unwrap()
}

fn interpret_all(program: &Program) {
    let mut it = Interpreter::new(InterpOptions::default());
    let mut events = Vec::new();
    for b in &program.blocks {
        // Errors are fine; panics are not.
        if it.execute(b, &mut events).is_err() {
            break;
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]

    #[test]
    fn arbitrary_bytes_never_panic_and_round_trip(bytes in proptest::collection::vec(any::<u8>(), 0..200)) {
        if let Ok(p) = Program::parse(&bytes) {
            prop_assert_eq!(p.to_bytes(), bytes);
            interpret_all(&p);
        }
    }

    #[test]
    fn gcode_like_text_round_trips(text in gcode_like()) {
        if let Ok(p) = Program::parse(text.as_bytes()) {
            prop_assert_eq!(p.to_bytes(), text.as_bytes());
            interpret_all(&p);
        }
    }

    #[test]
    fn set_word_keeps_the_block_coherent(text in gcode_like(), v in -1e4f64..1e4, letter in proptest::sample::select(vec!['X', 'Z', 'A', 'F'])) {
        let line = text.lines().next().unwrap_or("");
        let Ok(mut b) = Block::parse(line.as_bytes(), 1) else { return Ok(()) };
        if b.set_word(letter, v).is_ok() {
            let again = Block::parse(b.text(), 1).expect("an edited block parses");
            prop_assert_eq!(again.items(), b.items());
            let w = b.word(letter).unwrap().unwrap();
            let mut expected = String::new();
            NumberFormat::default().write(v, &mut expected);
            prop_assert_eq!(b.value_text(w), expected.as_str());
        }
    }

    #[test]
    fn numbers_read_exactly_as_the_standard_parser(text in "-?[0-9]{1,20}(\\.[0-9]{0,24})?") {
        let b = Block::parse(format!("X{text}").as_bytes(), 1).unwrap();
        let v = b.word('X').unwrap().unwrap().number().unwrap();
        let std: f64 = text.parse().unwrap();
        prop_assert_eq!(v.to_bits(), std.to_bits());
    }
}
