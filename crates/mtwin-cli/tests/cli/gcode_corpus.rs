//! The real programs of the corpus: every one round-trips byte for byte, and
//! the five-axis TCP programs interpret without error.

use std::path::PathBuf;

use mtwin::gcode::{self, EventKind, InterpOptions, Program, StatsOptions};

fn corpus() -> Option<PathBuf> {
    crate::shared::shared_dir("corpus/gcode/linuxcnc")
}

#[test]
fn every_corpus_program_round_trips_byte_for_byte() {
    let Some(dir) = corpus() else { return };
    let mut n = 0;
    for entry in std::fs::read_dir(&dir).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_none_or(|e| e != "ngc") {
            continue;
        }
        let bytes = std::fs::read(&path).unwrap();
        let program = Program::parse(&bytes).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        assert!(
            program.to_bytes() == bytes,
            "{} does not round-trip",
            path.display()
        );
        // Streaming writer gives the same bytes.
        let mut w = gcode::BlockWriter::new(Vec::new());
        for b in &program.blocks {
            w.write_block(b).unwrap();
        }
        assert!(w.into_inner().unwrap() == bytes);
        n += 1;
    }
    assert!(n >= 5, "expected the corpus programs, found {n}");
}

#[test]
fn five_axis_tcp_programs_interpret() {
    let Some(dir) = corpus() else { return };
    for name in ["boat-xyzac.ngc", "impeller-7bl-xyzac.ngc"] {
        let bytes = std::fs::read(dir.join(name)).unwrap();
        let mut moves = 0usize;
        let mut tcp_switches = Vec::new();
        let mut inverse_time = 0usize;
        let mut ended = false;
        gcode::interpret(&bytes[..], InterpOptions::default(), |_, events| {
            for e in events {
                match e.kind {
                    EventKind::Traverse(_) | EventKind::Feed(_) | EventKind::Arc(_) => moves += 1,
                    EventKind::Tcp(on) => tcp_switches.push(on),
                    EventKind::ProgramEnd => ended = true,
                    _ => {}
                }
                if let EventKind::Feed(m) = e.kind {
                    inverse_time += usize::from(matches!(m.feed, gcode::Feed::InverseTime(_)));
                    assert!(m.tcp, "{name}: a feed move outside M428/M429");
                }
            }
            Ok(())
        })
        .unwrap_or_else(|e| panic!("{name}: {e}"));
        assert!(moves > 100, "{name}: only {moves} moves");
        assert_eq!(tcp_switches, [true, false], "{name}: M428 … M429");
        assert!(inverse_time > 0, "{name}: G93 moves expected");
        assert!(ended, "{name}: M30");
        let st = gcode::stats(&bytes[..], &StatsOptions::default()).unwrap();
        assert!(st.feed_time > 0.0 && st.feed_length > 0.0);
    }
}

#[test]
fn impeller_inverse_time_total_equals_sum_of_inverse_feeds() {
    // Independent check of the G93 time: sum 60/F over the G1 blocks of the
    // file, read with a plain text scan.
    let Some(dir) = corpus() else { return };
    let text = std::fs::read_to_string(dir.join("impeller-7bl-xyzac.ngc")).unwrap();
    let mut expected = 0.0;
    let mut mode93 = false;
    for line in text.lines() {
        let code = line.split(';').next().unwrap_or("");
        let compact: String = code.chars().filter(|c| !c.is_whitespace()).collect();
        if compact.contains("G93") {
            mode93 = true;
        }
        if compact.contains("G94") {
            mode93 = false;
        }
        if mode93 && compact.starts_with("G1") {
            let f = compact.split('F').nth(1).expect("G93 G1 lines carry F");
            expected += 60.0 / f.parse::<f64>().unwrap();
        }
    }
    let st = gcode::stats(text.as_bytes(), &StatsOptions::default()).unwrap();
    assert!(
        (st.feed_time - expected).abs() < 1e-6 * expected,
        "{} vs {expected}",
        st.feed_time
    );
}
