//! Writing a machine model back to TOML (00 §5), at full precision.

use std::fmt::Write as _;

use super::{Component, ErrorFunction, Machine};

/// A TOML float at full precision (shortest round-trip text; always a float literal).
fn num(x: f64) -> String {
    let mut b = ryu::Buffer::new();
    if x.is_finite() {
        b.format_finite(x).to_string()
    } else {
        "nan".to_string()
    }
}

fn arr(v: &[f64]) -> String {
    format!(
        "[{}]",
        v.iter().map(|&x| num(x)).collect::<Vec<_>>().join(", ")
    )
}

fn names(m: &Machine, chain: &[usize]) -> String {
    format!(
        "[{}]",
        chain
            .iter()
            .map(|&i| format!("\"{}\"", m.axes[i].name))
            .collect::<Vec<_>>()
            .join(", ")
    )
}

fn escape(s: &str) -> String {
    s.replace('\\', "\\\\").replace('"', "\\\"")
}

fn function(f: &ErrorFunction) -> String {
    match f {
        ErrorFunction::Constant(c) => num(*c),
        ErrorFunction::Poly(c) => format!("{{ poly = {} }}", arr(c)),
        ErrorFunction::Cheb(c) => format!("{{ cheb = {} }}", arr(c)),
        ErrorFunction::Table { q, e } => {
            format!("{{ table = {{ q = {}, e = {} }} }}", arr(q), arr(e))
        }
    }
}

/// The machine as machine-file TOML. `header` lines are written first as `#` comments.
/// Zero location errors and absent PDGEs are omitted; everything else is written at full
/// precision, so reading the text back gives an identical [`Machine`].
pub fn machine_to_toml(m: &Machine, header: &[&str]) -> String {
    let mut s = String::new();
    for h in header {
        let _ = writeln!(s, "# {h}");
    }
    let _ = writeln!(s, "name = \"{}\"", escape(&m.name));
    let _ = writeln!(
        s,
        "tool_chain = {}          # base -> spindle",
        names(m, &m.tool_chain)
    );
    let _ = writeln!(
        s,
        "workpiece_chain = {}     # base -> table",
        names(m, &m.workpiece_chain)
    );
    if m.rapid_feed != super::machine::DEFAULT_RAPID_FEED {
        let _ = writeln!(s, "rapid_feed = {}          # mm/min", num(m.rapid_feed));
    }
    let _ = writeln!(s, "\n[tool]");
    let _ = writeln!(s, "tip = {}", arr(m.tool_tip.as_slice()));
    let _ = writeln!(s, "direction = {}", arr(m.tool_direction.as_slice()));
    let _ = writeln!(s, "\n[workpiece]");
    let _ = writeln!(s, "origin = {}", arr(m.workpiece_origin.as_slice()));
    for a in &m.axes {
        let _ = writeln!(s, "\n[[axes]]");
        let _ = writeln!(s, "name = \"{}\"", a.name);
        let _ = writeln!(s, "kind = \"{}\"", a.kind.as_str());
        let _ = writeln!(s, "direction = {}", arr(a.direction.as_slice()));
        let _ = writeln!(s, "origin = {}", arr(a.origin.as_slice()));
        let _ = writeln!(s, "travel = {}", arr(&a.travel));
        if let Some(v) = a.max_velocity {
            let _ = writeln!(s, "max_velocity = {}", num(v));
        }
        if let Some(v) = a.max_acceleration {
            let _ = writeln!(s, "max_acceleration = {}", num(v));
        }
        let has_errors = a.errors.pdge.iter().any(|f| f.is_some())
            || a.errors.location.iter().any(|&v| v != 0.0);
        if has_errors {
            let _ = writeln!(s, "  [axes.errors]");
            for c in Component::ALL {
                if let Some(f) = &a.errors.pdge[c.index()] {
                    let _ = writeln!(s, "  E{}{} = {}", c.letter(), a.name, function(f));
                }
            }
            for c in Component::ALL {
                let v = a.errors.location[c.index()];
                if v != 0.0 {
                    let _ = writeln!(s, "  E{}0{} = {}", c.letter(), a.name, num(v));
                }
            }
        }
        if let Some(sv) = &a.servo {
            let _ = writeln!(s, "  [axes.servo]");
            let _ = writeln!(s, "  ts = {}", num(sv.ts));
            let _ = writeln!(s, "  b = {}", arr(&sv.b));
            let _ = writeln!(s, "  a = {}", arr(&sv.a));
            let _ = writeln!(s, "  nk = {}", sv.nk);
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::parse_machine;
    use std::path::Path;

    #[test]
    fn round_trip_of_shipped_examples() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/machines");
        let mut n = 0;
        for e in std::fs::read_dir(&dir).unwrap() {
            let p = e.unwrap().path();
            if p.extension().is_some_and(|x| x == "toml") {
                let m = crate::model::read_machine(&p).unwrap_or_else(|e| panic!("{e}"));
                let text = machine_to_toml(&m, &["round trip"]);
                let back = parse_machine(Path::new("back.toml"), &text)
                    .unwrap_or_else(|e| panic!("{e}\n{text}"));
                assert_eq!(m, back, "{}", p.display());
                n += 1;
            }
        }
        assert!(n >= 3);
    }
}
