//! The value rules of a machine, shared by the file reader (which adds the
//! line of the value) and [`Machine::validate`] (which checks a machine built
//! in code): one copy of each rule and of its message.

use nalgebra::Vector3;

use super::{AxisKind, Component, ErrorFunction, ErrorKind, ErrorName, Machine};
use crate::limits;

/// Tolerance on |d| − 1 for a direction to count as a unit vector.
pub const UNIT_TOLERANCE: f64 = 1e-9;

/// Why `x` is not accepted as a number of a machine file, after `must be `:
/// `None` when it is finite and within [`limits::MAX_ABS_VALUE`].
pub(crate) fn why_not_number(x: f64) -> Option<String> {
    if x.is_finite() && x.abs() <= limits::MAX_ABS_VALUE {
        None
    } else if x.is_finite() {
        Some(format!(
            "within ±{} (it is {}): no quantity in these files is that large",
            limits::fmt_message_number(limits::MAX_ABS_VALUE),
            limits::fmt_message_number(x)
        ))
    } else {
        Some(format!("a finite number, not {}", crate::io::fmt_f64(x)))
    }
}

/// `rapid_feed` (mm/min) must be positive.
pub(crate) fn rapid_feed(f: f64) -> Result<(), String> {
    if f > 0.0 {
        Ok(())
    } else {
        Err("`rapid_feed` (mm/min) must be positive".into())
    }
}

/// A unit vector: |‖d‖ − 1| ≤ `tolerance`; `what` names it.
pub(crate) fn unit(what: &str, d: &Vector3<f64>, tolerance: f64) -> Result<(), String> {
    let norm = d.norm();
    if (norm - 1.0).abs() > tolerance {
        Err(format!(
            "{what} must be a unit vector, its length is {}",
            limits::fmt_message_number(norm)
        ))
    } else {
        Ok(())
    }
}

/// An axis name starts with a letter and holds only letters, digits and `_`.
pub(crate) fn axis_name(n: &str) -> Result<(), String> {
    let valid = !n.is_empty()
        && n.chars().next().is_some_and(|c| c.is_ascii_alphabetic())
        && n.chars().all(|c| c.is_ascii_alphanumeric() || c == '_');
    if valid {
        Ok(())
    } else {
        Err(format!(
            "axis name `{n}` must start with a letter and hold only letters, digits and `_`"
        ))
    }
}

/// Two axis names that case does not separate (names become column headers
/// and G-code letters): the message after the second, given the first's line
/// when known.
pub(crate) fn same_name(a: &str, b: &str) -> bool {
    !a.is_empty() && a.eq_ignore_ascii_case(b)
}

/// `travel` of an axis (`what`) must be a non-empty interval lo < hi.
pub(crate) fn travel(what: &str, t: [f64; 2]) -> Result<(), String> {
    if t[0] >= t[1] {
        Err(format!(
            "`travel` of {what} is empty: lo = {} is not below hi = {}",
            limits::fmt_message_number(t[0]),
            limits::fmt_message_number(t[1])
        ))
    } else {
        Ok(())
    }
}

/// `key` of `what` (a velocity or acceleration limit) must be positive.
pub(crate) fn positive(key: &str, what: &str, x: f64) -> Result<(), String> {
    if x <= 0.0 {
        Err(format!("`{key}` of {what} must be positive"))
    } else {
        Ok(())
    }
}

/// How many times axis `i` appears in the chains: exactly once is right.
pub(crate) fn chain_count(name: &str, count: usize) -> Result<(), String> {
    match count {
        1 => Ok(()),
        0 => Err(format!(
            "axis `{name}` is in neither `tool_chain` nor `workpiece_chain`"
        )),
        n => Err(format!(
            "axis `{name}` appears {n} times in the chains; each axis belongs to exactly one place"
        )),
    }
}

/// The shape of an error function `k`: coefficients present, a table with
/// `q` and `e` of one non-zero length and `q` strictly increasing; then its
/// value and derivative within [`limits::MAX_ERROR_VALUE`] over `travel`
/// (so that coefficients which overflow are refused where they are written).
pub(crate) fn error_function(
    k: &str,
    f: &ErrorFunction,
    travel: Option<[f64; 2]>,
) -> Result<(), String> {
    match f {
        ErrorFunction::Constant(_) => {}
        ErrorFunction::Poly(c) | ErrorFunction::Cheb(c) => {
            if c.is_empty() {
                let form = if matches!(f, ErrorFunction::Poly(_)) {
                    "poly"
                } else {
                    "cheb"
                };
                return Err(format!(
                    "`{form}` of error `{k}` needs at least one coefficient"
                ));
            }
        }
        ErrorFunction::Table { q, e } => {
            if q.len() != e.len() || q.is_empty() {
                return Err(format!(
                    "`table` of error `{k}`: `q` and `e` must have the same, non-zero length ({} and {})",
                    q.len(),
                    e.len()
                ));
            }
            if q.windows(2).any(|w| w[1] <= w[0]) {
                return Err(format!(
                    "`q` of the table of `{k}` must be strictly increasing"
                ));
            }
        }
    }
    if let Some(travel) = travel
        && let Some((q, what, x)) = overflow_over_travel(f, travel)
    {
        return Err(format!(
            "error `{k}` is out of range over the axis travel: its {what} at {} is {} (the limit is ±{})",
            limits::fmt_message_number(q),
            limits::fmt_message_number(x),
            limits::fmt_message_number(limits::MAX_ERROR_VALUE)
        ));
    }
    Ok(())
}

/// The first point of `travel` where `f` or its derivative is non-finite or
/// beyond [`limits::MAX_ERROR_VALUE`]: (position, "value" or "derivative",
/// the value there). Checked on 1025 evenly spaced points with both ends (a
/// polynomial's magnitude is largest at an end or between points that close;
/// tables are checked at their own points too).
fn overflow_over_travel(f: &ErrorFunction, travel: [f64; 2]) -> Option<(f64, &'static str, f64)> {
    const N: usize = 1024;
    let bad = |x: f64| !x.is_finite() || x.abs() > limits::MAX_ERROR_VALUE;
    let mut points: Vec<f64> = (0..=N)
        .map(|i| travel[0] + (travel[1] - travel[0]) * i as f64 / N as f64)
        .collect();
    if let ErrorFunction::Table { q, .. } = f {
        points.extend(q.iter().copied());
    }
    for q in points {
        let x = f.eval(q, travel);
        if bad(x) {
            return Some((q, "value", x));
        }
        let d = f.deriv(q, travel);
        if bad(d) {
            return Some((q, "derivative", d));
        }
    }
    None
}

/// `ts` (s) of the servo table `what` must be positive.
pub(crate) fn servo_ts(what: &str, ts: f64) -> Result<(), String> {
    if ts <= 0.0 {
        Err(format!(
            "`ts` of {what} must be positive, not {}",
            limits::fmt_message_number(ts)
        ))
    } else {
        Ok(())
    }
}

/// `b` of the servo table `what` needs b_0.
pub(crate) fn servo_b(what: &str, b: &[f64]) -> Result<(), String> {
    if b.is_empty() {
        Err(format!(
            "`b` of {what} needs at least one coefficient (b_0)"
        ))
    } else {
        Ok(())
    }
}

/// `a` of the servo table `what` starts with a_0 = 1.
pub(crate) fn servo_a(what: &str, a: &[f64]) -> Result<(), String> {
    if a.first() != Some(&1.0) {
        let a0 = a
            .first()
            .map_or("nothing".to_string(), |&x| limits::fmt_message_number(x));
        Err(format!("`a` of {what} must start with a_0 = 1, not {a0}"))
    } else {
        Ok(())
    }
}

/// `nk` (samples) of the servo table `what` within [`limits::MAX_DELAY_SAMPLES`].
pub(crate) fn servo_nk(what: &str, nk: usize) -> Result<(), String> {
    limits::check(
        &format!("`nk` of {what} (samples)"),
        nk as f64,
        limits::MAX_DELAY_SAMPLES,
        "a servo dead time is a few samples",
    )
    .map_err(|e| e.to_string())
}

/// The servo of a whole table (after its keys passed their own rules).
pub(crate) fn servo(
    what: &str,
    ts: f64,
    b: Vec<f64>,
    a: Vec<f64>,
    nk: usize,
) -> Result<crate::sysid::Servo, String> {
    crate::sysid::Servo::new(ts, b, a, nk).map_err(|e| format!("{what}: {e}"))
}

/// Every problem of a machine held in memory, by the rules above, in the
/// reader's words (keys name the place). Empty when the machine is one a
/// machine file could hold.
pub(crate) fn machine_problems(m: &Machine) -> Vec<String> {
    let mut out = Vec::new();
    let mut ok = |r: Result<(), String>| {
        if let Err(e) = r {
            out.push(e);
        }
    };
    let number = |what: &str, x: f64| match why_not_number(x) {
        Some(why) => Err(format!("{what} must be {why}")),
        None => Ok(()),
    };
    let numbers = |what: &str, xs: &[f64]| {
        xs.iter().try_for_each(|&x| match why_not_number(x) {
            Some(why) => Err(format!("every element of {what} must be {why}")),
            None => Ok(()),
        })
    };
    let n = m.n_axes();
    let mut chains_ok = true;
    for (what, chain) in [("tool", &m.tool_chain), ("workpiece", &m.workpiece_chain)] {
        if let Some(i) = chain.iter().find(|&&i| i >= n) {
            ok(Err(format!(
                "the {what} chain names axis index {i}, but the machine has {n} axes"
            )));
            chains_ok = false;
        }
    }
    ok(number("`rapid_feed` (mm/min)", m.rapid_feed).and_then(|()| rapid_feed(m.rapid_feed)));
    ok(numbers("`tip` of [tool] (mm)", m.tool_tip.as_slice()));
    ok(
        numbers("`direction` of [tool]", m.tool_direction.as_slice())
            .and_then(|()| unit("`direction` of [tool]", &m.tool_direction, UNIT_TOLERANCE)),
    );
    ok(numbers(
        "`origin` of [workpiece] (mm)",
        m.workpiece_origin.as_slice(),
    ));
    for (i, a) in m.axes.iter().enumerate() {
        if let Err(e) = axis_name(&a.name) {
            ok(Err(e));
            continue;
        }
        if m.axes[..i].iter().any(|b| same_name(&b.name, &a.name)) {
            ok(Err(format!("axis `{}` is defined twice", a.name)));
            continue;
        }
        let what = format!("axis `{}`", a.name);
        ok(
            numbers(&format!("`direction` of {what}"), a.direction.as_slice()).and_then(|()| {
                unit(
                    &format!("`direction` of {what}"),
                    &a.direction,
                    UNIT_TOLERANCE,
                )
            }),
        );
        ok(numbers(
            &format!("`origin` of {what} (mm)"),
            a.origin.as_slice(),
        ));
        let travel_ok = numbers(&format!("`travel` of {what}"), &a.travel)
            .and_then(|()| travel(&what, a.travel));
        let travel_known = travel_ok.is_ok();
        ok(travel_ok);
        let (vu, au, ju) = match a.kind {
            AxisKind::Rotary => ("deg/s", "deg/s²", "deg/s³"),
            AxisKind::Linear => ("mm/s", "mm/s²", "mm/s³"),
        };
        for (key, unit_name, v) in [
            ("max_velocity", vu, a.max_velocity),
            ("max_acceleration", au, a.max_acceleration),
            ("max_jerk", ju, a.max_jerk),
        ] {
            if let Some(x) = v {
                ok(number(&format!("`{key}` of {what} ({unit_name})"), x)
                    .and_then(|()| positive(key, &what, x)));
            }
        }
        for c in Component::ALL {
            let i = c.index();
            let loc = ErrorName {
                kind: ErrorKind::Location,
                component: c,
                axis: a.name.clone(),
            }
            .to_string();
            ok(number(&format!("error `{loc}`"), a.errors.location[i]));
            if let Some(f) = &a.errors.pdge[i] {
                let k = ErrorName {
                    kind: ErrorKind::Pdge,
                    component: c,
                    axis: a.name.clone(),
                }
                .to_string();
                let coefficients: Vec<f64> = match f {
                    ErrorFunction::Constant(x) => vec![*x],
                    ErrorFunction::Poly(c) | ErrorFunction::Cheb(c) => c.clone(),
                    ErrorFunction::Table { q, e } => q.iter().chain(e).copied().collect(),
                };
                ok(numbers(&format!("error `{k}`"), &coefficients)
                    .and_then(|()| error_function(&k, f, travel_known.then_some(a.travel))));
            }
        }
        if let Some(s) = &a.servo {
            let sw = format!("the servo table of {what}");
            let keys = number(&format!("`ts` of {sw} (s)"), s.ts)
                .and_then(|()| servo_ts(&sw, s.ts))
                .and_then(|()| numbers(&format!("`b` of {sw}"), &s.b))
                .and_then(|()| servo_b(&sw, &s.b))
                .and_then(|()| numbers(&format!("`a` of {sw}"), &s.a))
                .and_then(|()| servo_a(&sw, &s.a))
                .and_then(|()| servo_nk(&sw, s.nk));
            ok(keys.and_then(|()| servo(&sw, s.ts, s.b.clone(), s.a.clone(), s.nk).map(|_| ())));
        }
    }
    if chains_ok {
        for (i, a) in m.axes.iter().enumerate() {
            let count = m
                .tool_chain
                .iter()
                .chain(&m.workpiece_chain)
                .filter(|&&j| j == i)
                .count();
            ok(chain_count(&a.name, count));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{ServoTable, machine_to_toml, parse_machine};

    /// Each refusal of [`Machine::validate`] on a machine built in code is
    /// also the reader's refusal of the same machine written as a file, with
    /// the same message (where the file can be written at all: non-finite
    /// numbers are refused at write time).
    #[test]
    fn validate_refuses_what_the_reader_refuses_with_its_message() {
        let good = crate::examples::machine("ac-trunnion-with-errors").unwrap();
        assert!(good.validate().is_ok());
        let x = good.axis_index("X").unwrap();
        let c = good.axis_index("C").unwrap();
        type Mutation = (&'static str, Box<dyn Fn(&mut Machine)>);
        let cases: Vec<Mutation> = vec![
            (
                "`rapid_feed` (mm/min) must be positive",
                Box::new(|m| m.rapid_feed = 0.0),
            ),
            (
                "`direction` of [tool] must be a unit vector",
                Box::new(|m| m.tool_direction = Vector3::new(0.0, 0.0, 2.0)),
            ),
            (
                "`direction` of axis `X` must be a unit vector",
                Box::new(move |m| m.axes[x].direction = Vector3::new(1.0, 0.1, 0.0)),
            ),
            (
                "`travel` of axis `X` is empty",
                Box::new(move |m| m.axes[x].travel = [5.0, 5.0]),
            ),
            (
                "`max_velocity` of axis `X` must be positive",
                Box::new(move |m| m.axes[x].max_velocity = Some(-1.0)),
            ),
            (
                "`max_jerk` of axis `X` must be positive",
                Box::new(move |m| m.axes[x].max_jerk = Some(0.0)),
            ),
            (
                "axis name `1bad` must start with a letter",
                Box::new(move |m| m.axes[x].name = "1bad".into()),
            ),
            (
                "axis `x` is defined twice",
                Box::new(move |m| m.axes[c].name = "x".into()),
            ),
            (
                "appears 2 times in the chains",
                Box::new(|m| m.tool_chain.push(m.workpiece_chain[0])),
            ),
            (
                "is in neither `tool_chain` nor `workpiece_chain`",
                Box::new(|m| {
                    m.workpiece_chain.pop();
                }),
            ),
            (
                "must be strictly increasing",
                Box::new(move |m| {
                    m.axes[x].errors.pdge[0] = Some(ErrorFunction::Table {
                        q: vec![0.0, 0.0],
                        e: vec![0.0, 1e-3],
                    })
                }),
            ),
            (
                "`poly` of error `EXX` needs at least one coefficient",
                Box::new(move |m| m.axes[x].errors.pdge[0] = Some(ErrorFunction::Poly(vec![]))),
            ),
            (
                "error `EXX` is out of range over the axis travel",
                Box::new(move |m| {
                    m.axes[x].errors.pdge[0] = Some(ErrorFunction::Poly(vec![0.0, 0.0, 0.0, 1e4]))
                }),
            ),
            (
                "must start with a_0 = 1, not 2",
                Box::new(move |m| {
                    m.axes[x].servo = Some(ServoTable {
                        ts: 0.001,
                        b: vec![0.0, 0.5],
                        a: vec![2.0, -0.5],
                        nk: 0,
                    })
                }),
            ),
            (
                "`ts` of the servo table of axis `X` must be positive",
                Box::new(move |m| {
                    m.axes[x].servo = Some(ServoTable {
                        ts: -0.001,
                        b: vec![0.0, 0.5],
                        a: vec![1.0, -0.5],
                        nk: 0,
                    })
                }),
            ),
            (
                "error `EX0C` must be within ±",
                Box::new(move |m| m.axes[c].errors.location[0] = 1e300),
            ),
        ];
        for (needle, mutate) in &cases {
            let mut m = good.clone();
            mutate(&mut m);
            let e = m.validate().unwrap_err();
            assert!(e.to_string().contains(needle), "wanted `{needle}` in {e}");
            let text = machine_to_toml(&m, &[]).unwrap();
            let read = parse_machine(std::path::Path::new("m.toml"), &text).unwrap_err();
            let from_file: Vec<&str> = read.0.iter().map(|d| d.message.as_str()).collect();
            for d in &e.0 {
                assert!(
                    from_file.iter().any(|f| f.starts_with(d.message.as_str())),
                    "validate said `{}`, the reader said {from_file:?}",
                    d.message
                );
            }
        }
        // Only in memory: a chain index beyond the axes, a non-finite number.
        let mut m = good.clone();
        m.tool_chain.push(17);
        assert!(m.validate().unwrap_err().to_string().contains("index 17"));
        let mut m = good.clone();
        m.axes[x].max_jerk = Some(f64::INFINITY);
        let e = m.validate().unwrap_err().to_string();
        assert!(
            e.contains("`max_jerk` of axis `X` (mm/s³) must be a finite number"),
            "{e}"
        );
        let mut m = good;
        m.tool_tip.x = f64::NAN;
        let e = m.validate().unwrap_err().to_string();
        assert!(
            e.contains("`tip` of [tool] (mm) must be a finite number, not NaN"),
            "{e}"
        );
    }
}
