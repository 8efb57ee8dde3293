//! Reading a machine model file (docs/machine-model.md) with every problem reported by file and line.

use std::path::Path;

use nalgebra::Vector3;
use toml_edit::{Item, TableLike, Value};

use super::machine::DEFAULT_RAPID_FEED;
use super::rules;
pub use super::rules::UNIT_TOLERANCE;
use super::{Axis, AxisErrors, AxisKind, ErrorFunction, ErrorKind, ErrorName, Machine, ServoTable};
use crate::io::toml::{Span, TomlReader, parse};
use crate::io::{Diagnostic, Diagnostics};
use crate::sysid::read_servo_table;

/// Read and validate a machine model file.
pub fn read_machine(path: &Path) -> Result<Machine, Diagnostics> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| Diagnostic::whole(path, format!("cannot read the machine file: {e}")))?;
    parse_machine(path, &text)
}

/// Parse and validate machine-model TOML text; `path` names it in messages.
pub fn parse_machine(path: &Path, text: &str) -> Result<Machine, Diagnostics> {
    let doc = parse(path, text)?;
    let mut cx = Cx(TomlReader::new(path, text));
    let m = cx.machine(doc.as_table());
    cx.0.diags
        .into_result(())
        .map(|()| m.expect("no diagnostics means a machine was built"))
}

/// The machine schema, read through the shared span-aware reader.
struct Cx<'a>(TomlReader<'a>);

impl<'a> std::ops::Deref for Cx<'a> {
    type Target = TomlReader<'a>;
    fn deref(&self) -> &TomlReader<'a> {
        &self.0
    }
}

impl<'a> std::ops::DerefMut for Cx<'a> {
    fn deref_mut(&mut self) -> &mut TomlReader<'a> {
        &mut self.0
    }
}

impl Cx<'_> {
    fn machine(&mut self, root: &toml_edit::Table) -> Option<Machine> {
        self.check_keys(
            root,
            &[
                "name",
                "tool_chain",
                "workpiece_chain",
                "tool",
                "workpiece",
                "axes",
                "rapid_feed",
            ],
            "the machine file",
        );
        let name = match root.get("name") {
            Some(Item::Value(Value::String(s))) => s.value().clone(),
            Some(other) => {
                self.error(other.span(), "`name` must be a string");
                String::new()
            }
            None => String::new(),
        };
        let rapid_feed = match self.value(root, "rapid_feed", "the machine file", None) {
            Some(v) => match self.number(v, "`rapid_feed` (mm/min)") {
                Some(f) => match rules::rapid_feed(f) {
                    Ok(()) => f,
                    Err(e) => {
                        self.error(v.span(), e);
                        DEFAULT_RAPID_FEED
                    }
                },
                None => DEFAULT_RAPID_FEED,
            },
            None => DEFAULT_RAPID_FEED,
        };

        // [tool]
        let (mut tool_tip, mut tool_direction) = (Vector3::zeros(), Vector3::z());
        match root.get("tool") {
            Some(Item::Table(t)) => {
                let span = t.span();
                self.check_keys(t, &["tip", "direction"], "[tool]");
                if let Some(v) = self.required_value(t, "tip", "[tool]", span.clone()) {
                    tool_tip = self.vec3(v, "`tip` of [tool] (mm)").unwrap_or(tool_tip);
                }
                if let Some(v) = self.value(t, "direction", "[tool]", span) {
                    tool_direction = self
                        .unit3(v, "`direction` of [tool]", UNIT_TOLERANCE)
                        .unwrap_or(tool_direction);
                }
            }
            Some(other) => self.error(other.span(), "`tool` must be a table [tool]"),
            None => self.error(
                None,
                "the machine file has no [tool] table (with `tip` and `direction`)",
            ),
        }
        // [workpiece]
        let mut workpiece_origin = Vector3::zeros();
        match root.get("workpiece") {
            Some(Item::Table(t)) => {
                let span = t.span();
                self.check_keys(t, &["origin"], "[workpiece]");
                if let Some(v) = self.required_value(t, "origin", "[workpiece]", span) {
                    workpiece_origin = self
                        .vec3(v, "`origin` of [workpiece] (mm)")
                        .unwrap_or(workpiece_origin);
                }
            }
            Some(other) => self.error(other.span(), "`workpiece` must be a table [workpiece]"),
            None => self.error(
                None,
                "the machine file has no [workpiece] table (with `origin`)",
            ),
        }

        // [[axes]]: names are collected even when an axis is otherwise invalid, so the
        // chains can still be checked without cascading messages.
        let mut names: Vec<(String, Span)> = Vec::new();
        let mut axes: Vec<Option<Axis>> = Vec::new();
        match root.get("axes") {
            Some(Item::ArrayOfTables(arr)) => {
                for t in arr.iter() {
                    let name = match t.get("name") {
                        Some(Item::Value(Value::String(s))) => s.value().clone(),
                        _ => String::new(),
                    };
                    // Names become column headers and G-code letters, where case
                    // does not separate them: `x` beside `X` is a duplicate.
                    if let Some((_, first)) = names.iter().find(|(n, _)| rules::same_name(n, &name))
                    {
                        let first_line = self.line(first.clone());
                        self.error(
                            t.span(),
                            format!("axis `{name}` is defined twice (first at line {first_line})"),
                        );
                        continue;
                    }
                    names.push((name, t.span()));
                    axes.push(self.axis(t));
                }
            }
            Some(other) => self.error(other.span(), "`axes` must be a list of [[axes]] tables"),
            None => {}
        }

        // Chains.
        let chain = |cx: &mut Self, key: &str| -> Vec<usize> {
            let Some(v) = cx.value(root, key, "the machine file", None) else {
                if root.get(key).is_none() {
                    cx.error(
                        None,
                        format!("the machine file has no `{key}` (use [] for an empty chain)"),
                    );
                }
                return Vec::new();
            };
            let Some(listed) = cx.strings(v, &format!("`{key}`"), "axis names", "an axis name")
            else {
                return Vec::new();
            };
            let mut out = Vec::new();
            for (n, span) in listed {
                match names.iter().position(|(a, _)| *a == n) {
                    Some(i) => out.push(i),
                    None => cx.error(
                        span,
                        format!("`{key}` names axis `{n}`, which is not defined by any [[axes]]"),
                    ),
                }
            }
            out
        };
        let tool_chain = chain(self, "tool_chain");
        let workpiece_chain = chain(self, "workpiece_chain");
        for (i, (a, span)) in names.iter().enumerate() {
            let n = tool_chain
                .iter()
                .chain(&workpiece_chain)
                .filter(|&&j| j == i)
                .count();
            if a.is_empty() {
                continue;
            }
            if let Err(e) = rules::chain_count(a, n) {
                self.error(span.clone(), e);
            }
        }
        Some(Machine {
            name,
            axes: axes.into_iter().collect::<Option<Vec<Axis>>>()?,
            tool_chain,
            workpiece_chain,
            tool_tip,
            tool_direction,
            workpiece_origin,
            rapid_feed,
        })
    }

    fn axis(&mut self, t: &toml_edit::Table) -> Option<Axis> {
        let span = t.span();
        self.check_keys(
            t,
            &[
                "name",
                "kind",
                "direction",
                "origin",
                "travel",
                "errors",
                "servo",
                "max_velocity",
                "max_acceleration",
                "max_jerk",
            ],
            "[[axes]]",
        );
        let name = match self.required_value(t, "name", "an [[axes]] table", span.clone()) {
            Some(Value::String(s)) => {
                let n = s.value().clone();
                if let Err(e) = rules::axis_name(&n) {
                    self.error(s.span(), e);
                    return None;
                }
                n
            }
            Some(v) => {
                self.error(v.span(), "`name` of an axis must be a string");
                return None;
            }
            None => return None,
        };
        let what = format!("axis `{name}`");
        let kind = match self.required_value(t, "kind", &what, span.clone()) {
            Some(Value::String(s)) if s.value() == "linear" => Some(AxisKind::Linear),
            Some(Value::String(s)) if s.value() == "rotary" => Some(AxisKind::Rotary),
            Some(v) => {
                self.error(
                    v.span(),
                    format!("`kind` of {what} must be \"linear\" or \"rotary\""),
                );
                None
            }
            None => None,
        };
        let direction = self
            .required(t, "direction", &what, span.clone())
            .and_then(|v| self.unit3(v, &format!("`direction` of {what}"), UNIT_TOLERANCE));
        let origin = match self.value(t, "origin", &what, span.clone()) {
            Some(v) => self.vec3(v, &format!("`origin` of {what} (mm)")),
            None => Some(Vector3::zeros()),
        };
        let travel = self
            .required(t, "travel", &what, span.clone())
            .and_then(|v| {
                let n = self.numbers(v, &format!("`travel` of {what}"))?;
                if n.len() != 2 {
                    self.error(
                        v.span(),
                        format!(
                            "`travel` of {what} must be [lo, hi], it has {} numbers",
                            n.len()
                        ),
                    );
                    return None;
                }
                if let Err(e) = rules::travel(&what, [n[0], n[1]]) {
                    self.error(v.span(), e);
                    return None;
                }
                Some([n[0], n[1]])
            });
        let positive = |cx: &mut Self, key: &str, unit: &str| -> Option<f64> {
            let v = cx.value(t, key, &what, None)?;
            let x = cx.number(v, &format!("`{key}` of {what} ({unit})"))?;
            if let Err(e) = rules::positive(key, &what, x) {
                cx.error(v.span(), e);
                return None;
            }
            Some(x)
        };
        let (vu, au, ju) = match kind {
            Some(AxisKind::Rotary) => ("deg/s", "deg/s²", "deg/s³"),
            _ => ("mm/s", "mm/s²", "mm/s³"),
        };
        let max_velocity = positive(self, "max_velocity", vu);
        let max_acceleration = positive(self, "max_acceleration", au);
        let max_jerk = positive(self, "max_jerk", ju);
        let errors = match t.get("errors") {
            Some(Item::Table(e)) => self.errors(e, &name, travel),
            Some(other) => {
                self.error(
                    other.span(),
                    format!("`errors` of {what} must be a table [axes.errors]"),
                );
                AxisErrors::default()
            }
            None => AxisErrors::default(),
        };
        let servo = match t.get("servo") {
            Some(Item::Table(s)) => self.servo(s, &what),
            Some(Item::Value(Value::InlineTable(s))) => self.servo(s, &what),
            Some(other) => {
                self.error(
                    other.span(),
                    format!("`servo` of {what} must be a table [axes.servo]"),
                );
                None
            }
            None => None,
        };
        Some(Axis {
            name,
            kind: kind?,
            direction: direction?,
            origin: origin?,
            travel: travel?,
            errors,
            max_velocity,
            max_acceleration,
            max_jerk,
            servo,
        })
    }

    fn errors(&mut self, t: &toml_edit::Table, axis: &str, travel: Option<[f64; 2]>) -> AxisErrors {
        let mut out = AxisErrors::default();
        for (k, item) in t.iter() {
            let span = TomlReader::key_span(t, k);
            let name: ErrorName = match k.parse() {
                Ok(n) => n,
                Err(e) => {
                    self.error(span, e.to_string());
                    continue;
                }
            };
            if name.axis != axis {
                self.error(
                    span,
                    format!("error `{k}` names axis `{}` but is listed under axis `{axis}`; move it to that axis or rename it", name.axis),
                );
                continue;
            }
            let Item::Value(v) = item else {
                self.error(
                    item.span().or(span),
                    format!(
                        "error `{k}` must be a number or an inline table like {{ cheb = [..] }}"
                    ),
                );
                continue;
            };
            let i = name.component.index();
            match name.kind {
                ErrorKind::Location => match v {
                    Value::Float(_) | Value::Integer(_) => {
                        if let Some(x) = self.number(v, &format!("error `{k}`")) {
                            out.location[i] = x;
                        }
                    }
                    _ => self.error(
                        v.span().or(span),
                        format!("location error `{k}` must be a constant number, not a function of the axis position"),
                    ),
                },
                ErrorKind::Pdge => {
                    if let Some(f) = self.function(v, k, travel) {
                        out.pdge[i] = Some(f);
                    }
                }
            }
        }
        out
    }

    /// An error function, checked over the axis travel: its value and
    /// derivative must stay within [`crate::limits::MAX_ERROR_VALUE`]
    /// everywhere, so that coefficients which overflow (`cheb = [0, 1e308]`
    /// or a high power of a long travel) are refused here with their line
    /// instead of giving NaN later.
    fn function(&mut self, v: &Value, k: &str, travel: Option<[f64; 2]>) -> Option<ErrorFunction> {
        let f = self.function_unchecked(v, k, travel)?;
        if let Err(e) = rules::error_function(k, &f, travel) {
            self.error(v.span(), e);
            return None;
        }
        Some(f)
    }

    fn function_unchecked(
        &mut self,
        v: &Value,
        k: &str,
        travel: Option<[f64; 2]>,
    ) -> Option<ErrorFunction> {
        let unit = if k
            .parse::<ErrorName>()
            .is_ok_and(|n| n.component.is_rotation())
        {
            "rad"
        } else {
            "mm"
        };
        match v {
            Value::Float(_) | Value::Integer(_) => self
                .number(v, &format!("error `{k}` ({unit})"))
                .map(ErrorFunction::Constant),
            Value::InlineTable(it) => {
                let keys: Vec<&str> = it.iter().map(|(k, _)| k).collect();
                if keys.len() != 1 {
                    self.error(
                        it.span(),
                        format!("error `{k}` must have exactly one of `poly`, `cheb`, `table`, it has {}", keys.len()),
                    );
                    return None;
                }
                let form = keys[0];
                let val = it.get(form)?;
                match form {
                    "poly" | "cheb" => {
                        let c = self.numbers(val, &format!("`{form}` of error `{k}`"))?;
                        let f = if form == "poly" {
                            ErrorFunction::Poly(c)
                        } else {
                            ErrorFunction::Cheb(c)
                        };
                        if let Err(e) = rules::error_function(k, &f, None) {
                            self.error(val.span(), e);
                            return None;
                        }
                        if form == "cheb" && travel.is_none() {
                            return None;
                        }
                        Some(f)
                    }
                    "table" => {
                        let Value::InlineTable(tt) = val else {
                            self.error(
                                val.span(),
                                format!("`table` of error `{k}` must be {{ q = [..], e = [..] }}"),
                            );
                            return None;
                        };
                        for (kk, _) in tt.iter() {
                            if kk != "q" && kk != "e" {
                                let span = tt.get_key_value(kk).and_then(|(key, _)| key.span());
                                self.error(span.or(tt.span()), format!("unknown key `{kk}` in `table` of error `{k}` (allowed: q, e)"));
                            }
                        }
                        let q = tt
                            .get("q")
                            .and_then(|x| self.numbers(x, &format!("`q` of the table of `{k}`")));
                        let e = tt
                            .get("e")
                            .and_then(|x| self.numbers(x, &format!("`e` of the table of `{k}`")));
                        let (Some(q), Some(e)) = (q, e) else {
                            self.error(
                                tt.span(),
                                format!("`table` of error `{k}` needs both `q` and `e`"),
                            );
                            return None;
                        };
                        let f = ErrorFunction::Table { q, e };
                        if let Err(e) = rules::error_function(k, &f, None) {
                            self.error(tt.span(), e);
                            return None;
                        }
                        Some(f)
                    }
                    other => {
                        let span = it.get_key_value(other).and_then(|(key, _)| key.span());
                        self.error(
                            span.or(it.span()),
                            format!(
                                "unknown error form `{other}` in `{k}` (allowed: poly, cheb, table)"
                            ),
                        );
                        None
                    }
                }
            }
            _ => {
                self.error(
                    v.span(),
                    format!(
                        "error `{k}` must be a number or an inline table like {{ cheb = [..] }}"
                    ),
                );
                None
            }
        }
    }

    /// `[axes.servo]`: the same rules and messages as `SERVO.toml`.
    fn servo(&mut self, t: &dyn TableLike, what: &str) -> Option<ServoTable> {
        let servo = read_servo_table(&mut self.0, t, &format!("the servo table of {what}"), None)?;
        Some(ServoTable {
            ts: servo.ts(),
            b: servo.b().to_vec(),
            a: servo.a().to_vec(),
            nk: servo.nk(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(s: &str) -> Result<Machine, Diagnostics> {
        parse_machine(Path::new("m.toml"), s)
    }

    const GOOD: &str = r#"
name = "t"
tool_chain = ["X"]
workpiece_chain = ["C"]
[tool]
tip = [0, 0, 0]
direction = [0, 0, 1]
[workpiece]
origin = [0, 0, -10]
[[axes]]
name = "X"
kind = "linear"
direction = [1, 0, 0]
travel = [-100, 100]
  [axes.errors]
  EXX = { cheb = [0.0, 0.004] }
  EC0X = 1e-5
[[axes]]
name = "C"
kind = "rotary"
direction = [0, 0, 1]
origin = [0, 0, 0]
travel = [-360, 360]
  [axes.errors]
  EX0C = 0.01
  ECC = { table = { q = [0, 90], e = [0, 1e-5] } }
  [axes.servo]
  ts = 0.001
  b = [0.0, 0.5]
  a = [1.0, -0.5]
"#;

    #[test]
    fn good_file() {
        let m = parse(GOOD).unwrap();
        assert_eq!(m.axes.len(), 2);
        assert_eq!(m.tool_chain, vec![0]);
        assert_eq!(m.axes[1].errors.location[0], 0.01);
        assert_eq!(m.axes[0].errors.location[5], 1e-5);
        assert!(m.axes[1].servo.is_some());
    }

    /// `max_jerk` is read in the axis's unit, written back and read again
    /// unchanged; a non-positive one is refused at its line.
    #[test]
    fn max_jerk_is_read_written_and_checked() {
        let text = GOOD.replace(
            "travel = [-100, 100]",
            "travel = [-100, 100]\nmax_velocity = 200.0\nmax_acceleration = 2000.0\nmax_jerk = 40000.0",
        );
        let m = parse(&text).unwrap();
        assert_eq!(m.axes[0].max_jerk, Some(40000.0));
        assert_eq!(m.axes[1].max_jerk, None);
        let again = parse(&crate::model::machine_to_toml(&m, &[]).unwrap()).unwrap();
        assert_eq!(again.axes[0].max_jerk, Some(40000.0));
        assert_eq!(again.axes[0].max_acceleration, Some(2000.0));
        assert_eq!(again.axes[1].max_jerk, None);
        expect_error(
            &GOOD.replace(
                "travel = [-100, 100]",
                "travel = [-100, 100]\nmax_jerk = -5",
            ),
            15,
            "`max_jerk` of axis `X` must be positive",
        );
        expect_error(
            &GOOD.replace(
                "travel = [-100, 100]",
                "travel = [-100, 100]\nmax_jerk = \"fast\"",
            ),
            15,
            "`max_jerk` of axis `X` (mm/s³)",
        );
    }

    fn expect_error(s: &str, line: usize, needle: &str) {
        let e = parse(s).unwrap_err();
        assert!(
            e.0.iter()
                .any(|d| d.line == line && d.message.contains(needle)),
            "wanted line {line} `{needle}` in:\n{e}"
        );
    }

    #[test]
    fn every_problem_has_its_line() {
        expect_error(
            &GOOD.replace("origin = [0, 0, -10]", "origin = [0, 0, -10]\ncolour = 3"),
            10,
            "unknown key `colour`",
        );
        expect_error(
            &GOOD.replace("EC0X = 1e-5", "EC0Y = 1e-5"),
            17,
            "names axis `Y`",
        );
        expect_error(
            &GOOD.replace("direction = [1, 0, 0]", "direction = [1, 0.1, 0]"),
            13,
            "unit vector",
        );
        expect_error(
            &GOOD.replace("travel = [-100, 100]", "travel = [100, 100]"),
            14,
            "empty",
        );
        expect_error(
            &GOOD.replace("EX0C = 0.01", "EX0C = { poly = [0.01] }"),
            25,
            "must be a constant",
        );
        expect_error(
            &GOOD.replace("name = \"C\"", "name = \"X\""),
            18,
            "defined twice",
        );
        expect_error(
            &GOOD.replace(
                "workpiece_chain = [\"C\"]",
                "workpiece_chain = [\"C\", \"B\"]",
            ),
            4,
            "axis `B`",
        );
        expect_error(
            &GOOD.replace("ECC = { table", "ECC = { spline"),
            26,
            "unknown error form",
        );
        expect_error(
            &GOOD.replace("a = [1.0, -0.5]", "a = [2.0, -0.5]"),
            30,
            "a_0 = 1",
        );
        expect_error(
            &GOOD.replace("EXX = {", "EQX = {"),
            16,
            "not an ISO 230-1 error name",
        );
        expect_error("name = [", 1, "not valid TOML");
    }

    /// Coefficients that overflow over the travel, numbers beyond the
    /// magnitude bound and axis names differing only in case are refused
    /// with their line.
    #[test]
    fn overflowing_errors_and_case_duplicates_are_refused() {
        // T_1 + T_2 at u = 1 is 2e308: overflows (line 17 holds EXX).
        expect_error(
            &GOOD.replace("[0.0, 0.004]", "[0, 1e14, 1e14]"),
            16,
            "out of range over the axis travel",
        );
        // c3 q^3 at q = 100 mm: 1e-3 * 1e6 = 1e3 mm, fine; c3 = 1e4: 1e10, refused.
        assert!(
            parse(&GOOD.replace("{ cheb = [0.0, 0.004] }", "{ poly = [0, 0, 0, 1e-3] }")).is_ok()
        );
        expect_error(
            &GOOD.replace("{ cheb = [0.0, 0.004] }", "{ poly = [0, 0, 0, 1e4] }"),
            16,
            "its value at -100 is -1e10",
        );
        expect_error(
            &GOOD.replace("EC0X = 1e-5", "EC0X = 1e308"),
            17,
            "within ±1e15",
        );
        let e = parse(
            &GOOD
                .replace("name = \"C\"", "name = \"x\"")
                .replace("[\"C\"]", "[\"x\"]"),
        )
        .unwrap_err();
        assert!(e.to_string().contains("axis `x` is defined twice"), "{e}");
    }

    #[test]
    fn reports_all_problems_at_once_without_cascades() {
        let bad = GOOD
            .replace("direction = [1, 0, 0]", "direction = [2, 0, 0]")
            .replace("EC0X = 1e-5", "EC0Y = 1e-5");
        let e = parse(&bad).unwrap_err();
        assert_eq!(e.0.len(), 2, "{e}");
    }

    #[test]
    fn axis_in_no_chain() {
        expect_error(
            &GOOD.replace("workpiece_chain = [\"C\"]", "workpiece_chain = []"),
            18,
            "neither",
        );
    }

    proptest::proptest! {
        #[test]
        fn arbitrary_text_never_panics(s in ".{0,400}") {
            let _ = parse(&s);
        }

        #[test]
        fn mutated_good_file_never_panics(pos in 0usize..800, ins in "[\\[\\]{}=,.\"a-zA-Z0-9 \n-]{0,8}", del in 0usize..6) {
            let mut s = GOOD.to_string();
            let p = pos.min(s.len());
            let p = (0..=p).rev().find(|&i| s.is_char_boundary(i)).unwrap_or(0);
            let end = (p + del).min(s.len());
            let end = (end..=s.len()).find(|&i| s.is_char_boundary(i)).unwrap_or(s.len());
            s.replace_range(p..end, &ins);
            let _ = parse(&s);
        }
    }
}
