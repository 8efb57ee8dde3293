//! Reading a machine model file (00 §5) with every problem reported by file and line.

use std::ops::Range;
use std::path::Path;

use nalgebra::Vector3;
use toml_edit::{Item, TableLike, Value};

use super::machine::DEFAULT_RAPID_FEED;
use super::{Axis, AxisErrors, AxisKind, ErrorFunction, ErrorKind, ErrorName, Machine, ServoTable};
use crate::io::toml::{Reader, parse};
use crate::io::{Diagnostic, Diagnostics};
use crate::sysid::read_servo_table;

/// Tolerance on |d| − 1 for a direction to count as a unit vector.
pub const UNIT_TOLERANCE: f64 = 1e-9;

/// Read and validate a machine model file.
pub fn read_machine(path: &Path) -> Result<Machine, Diagnostics> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| Diagnostic::whole(path, format!("cannot read the machine file: {e}")))?;
    parse_machine(path, &text)
}

/// Parse and validate machine-model TOML text; `path` names it in messages.
pub fn parse_machine(path: &Path, text: &str) -> Result<Machine, Diagnostics> {
    let doc = parse(path, text)?;
    let mut cx = Cx {
        r: Reader::new(path, text),
    };
    let m = cx.machine(doc.as_table());
    cx.r.diags
        .into_result(())
        .map(|()| m.expect("no diagnostics means a machine was built"))
}

/// The machine schema on top of the shared [`Reader`]: values read as
/// `toml_edit::Value`s, problems worded for the machine file.
struct Cx<'a> {
    r: Reader<'a>,
}

type Span = Option<Range<usize>>;

impl Cx<'_> {
    fn line(&self, span: Span) -> usize {
        self.r.line(span)
    }

    fn err(&mut self, span: Span, msg: impl Into<String>) {
        self.r.error(span, msg);
    }

    fn key_span(t: &dyn TableLike, k: &str) -> Span {
        Reader::key_span(t, k)
    }

    fn check_keys(&mut self, t: &dyn TableLike, allowed: &[&str], what: &str) {
        self.r.check_keys(t, allowed, what);
    }

    fn number(&mut self, v: &Value, what: &str) -> Option<f64> {
        match v {
            Value::Float(f) if f.value().is_finite() => Some(*f.value()),
            Value::Integer(i) => Some(*i.value() as f64),
            _ => {
                self.err(v.span(), format!("{what} must be a finite number"));
                None
            }
        }
    }

    fn numbers(&mut self, v: &Value, what: &str) -> Option<Vec<f64>> {
        let Value::Array(a) = v else {
            self.err(v.span(), format!("{what} must be an array of numbers"));
            return None;
        };
        let mut out = Vec::with_capacity(a.len());
        let mut ok = true;
        for x in a.iter() {
            match self.number(x, &format!("every element of {what}")) {
                Some(n) => out.push(n),
                None => ok = false,
            }
        }
        ok.then_some(out)
    }

    fn vec3(&mut self, v: &Value, what: &str) -> Option<Vector3<f64>> {
        let n = self.numbers(v, what)?;
        if n.len() != 3 {
            self.err(
                v.span(),
                format!("{what} must have 3 numbers, it has {}", n.len()),
            );
            return None;
        }
        Some(Vector3::new(n[0], n[1], n[2]))
    }

    fn unit3(&mut self, v: &Value, what: &str) -> Option<Vector3<f64>> {
        let d = self.vec3(v, what)?;
        let norm = d.norm();
        if (norm - 1.0).abs() > UNIT_TOLERANCE {
            self.err(
                v.span(),
                format!("{what} must be a unit vector, its length is {norm}"),
            );
            return None;
        }
        Some(d)
    }

    fn value<'t>(
        &mut self,
        t: &'t dyn TableLike,
        k: &str,
        what: &str,
        span: Span,
    ) -> Option<&'t Value> {
        match t.get(k) {
            Some(Item::Value(v)) => Some(v),
            Some(other) => {
                self.err(
                    other.span().or(span),
                    format!("`{k}` in {what} must be a value, not a table"),
                );
                None
            }
            None => None,
        }
    }

    fn required<'t>(
        &mut self,
        t: &'t dyn TableLike,
        k: &str,
        what: &str,
        span: Span,
    ) -> Option<&'t Value> {
        let v = self.value(t, k, what, span.clone());
        if v.is_none() && t.get(k).is_none() {
            self.err(span, format!("{what} has no `{k}`"));
        }
        v
    }

    fn strings(&mut self, v: &Value, what: &str) -> Option<Vec<(String, Span)>> {
        let Value::Array(a) = v else {
            self.err(v.span(), format!("{what} must be an array of axis names"));
            return None;
        };
        let mut out = Vec::new();
        for x in a.iter() {
            match x {
                Value::String(s) => out.push((s.value().clone(), x.span())),
                _ => {
                    self.err(
                        x.span(),
                        format!("every element of {what} must be an axis name in quotes"),
                    );
                    return None;
                }
            }
        }
        Some(out)
    }

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
                self.err(other.span(), "`name` must be a string");
                String::new()
            }
            None => String::new(),
        };
        let rapid_feed = match self.value(root, "rapid_feed", "the machine file", None) {
            Some(v) => match self.number(v, "`rapid_feed` (mm/min)") {
                Some(f) if f > 0.0 => f,
                Some(_) => {
                    self.err(v.span(), "`rapid_feed` (mm/min) must be positive");
                    DEFAULT_RAPID_FEED
                }
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
                if let Some(v) = self.required(t, "tip", "[tool]", span.clone()) {
                    tool_tip = self.vec3(v, "`tip` of [tool] (mm)").unwrap_or(tool_tip);
                }
                if let Some(v) = self.value(t, "direction", "[tool]", span) {
                    tool_direction = self
                        .unit3(v, "`direction` of [tool]")
                        .unwrap_or(tool_direction);
                }
            }
            Some(other) => self.err(other.span(), "`tool` must be a table [tool]"),
            None => self.err(
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
                if let Some(v) = self.required(t, "origin", "[workpiece]", span) {
                    workpiece_origin = self
                        .vec3(v, "`origin` of [workpiece] (mm)")
                        .unwrap_or(workpiece_origin);
                }
            }
            Some(other) => self.err(other.span(), "`workpiece` must be a table [workpiece]"),
            None => self.err(
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
                    if let Some((_, first)) =
                        names.iter().find(|(n, _)| !n.is_empty() && *n == name)
                    {
                        let first_line = self.line(first.clone());
                        self.err(
                            t.span(),
                            format!("axis `{name}` is defined twice (first at line {first_line})"),
                        );
                        continue;
                    }
                    names.push((name, t.span()));
                    axes.push(self.axis(t));
                }
            }
            Some(other) => self.err(other.span(), "`axes` must be a list of [[axes]] tables"),
            None => {}
        }

        // Chains.
        let chain = |cx: &mut Self, key: &str| -> Vec<usize> {
            let Some(v) = cx.value(root, key, "the machine file", None) else {
                if root.get(key).is_none() {
                    cx.err(
                        None,
                        format!("the machine file has no `{key}` (use [] for an empty chain)"),
                    );
                }
                return Vec::new();
            };
            let Some(listed) = cx.strings(v, &format!("`{key}`")) else {
                return Vec::new();
            };
            let mut out = Vec::new();
            for (n, span) in listed {
                match names.iter().position(|(a, _)| *a == n) {
                    Some(i) => out.push(i),
                    None => cx.err(
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
            if n == 0 {
                self.err(
                    span.clone(),
                    format!("axis `{a}` is in neither `tool_chain` nor `workpiece_chain`"),
                );
            } else if n > 1 {
                self.err(span.clone(), format!("axis `{a}` appears {n} times in the chains; each axis belongs to exactly one place"));
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
            ],
            "[[axes]]",
        );
        let name = match self.required(t, "name", "an [[axes]] table", span.clone()) {
            Some(Value::String(s)) => {
                let n = s.value().clone();
                let valid = !n.is_empty()
                    && n.chars().next().is_some_and(|c| c.is_ascii_alphabetic())
                    && n.chars().all(|c| c.is_ascii_alphanumeric() || c == '_');
                if !valid {
                    self.err(s.span(), format!("axis name `{n}` must start with a letter and hold only letters, digits and `_`"));
                    return None;
                }
                n
            }
            Some(v) => {
                self.err(v.span(), "`name` of an axis must be a string");
                return None;
            }
            None => return None,
        };
        let what = format!("axis `{name}`");
        let kind = match self.required(t, "kind", &what, span.clone()) {
            Some(Value::String(s)) if s.value() == "linear" => Some(AxisKind::Linear),
            Some(Value::String(s)) if s.value() == "rotary" => Some(AxisKind::Rotary),
            Some(v) => {
                self.err(
                    v.span(),
                    format!("`kind` of {what} must be \"linear\" or \"rotary\""),
                );
                None
            }
            None => None,
        };
        let direction = self
            .required(t, "direction", &what, span.clone())
            .and_then(|v| self.unit3(v, &format!("`direction` of {what}")));
        let origin = match self.value(t, "origin", &what, span.clone()) {
            Some(v) => self.vec3(v, &format!("`origin` of {what} (mm)")),
            None => Some(Vector3::zeros()),
        };
        let travel = self
            .required(t, "travel", &what, span.clone())
            .and_then(|v| {
                let n = self.numbers(v, &format!("`travel` of {what}"))?;
                if n.len() != 2 {
                    self.err(
                        v.span(),
                        format!(
                            "`travel` of {what} must be [lo, hi], it has {} numbers",
                            n.len()
                        ),
                    );
                    return None;
                }
                if n[0] >= n[1] {
                    self.err(
                        v.span(),
                        format!(
                            "`travel` of {what} is empty: lo = {} is not below hi = {}",
                            n[0], n[1]
                        ),
                    );
                    return None;
                }
                Some([n[0], n[1]])
            });
        let positive = |cx: &mut Self, key: &str, unit: &str| -> Option<f64> {
            let v = cx.value(t, key, &what, None)?;
            let x = cx.number(v, &format!("`{key}` of {what} ({unit})"))?;
            if x <= 0.0 {
                cx.err(v.span(), format!("`{key}` of {what} must be positive"));
                return None;
            }
            Some(x)
        };
        let (vu, au) = match kind {
            Some(AxisKind::Rotary) => ("deg/s", "deg/s²"),
            _ => ("mm/s", "mm/s²"),
        };
        let max_velocity = positive(self, "max_velocity", vu);
        let max_acceleration = positive(self, "max_acceleration", au);
        let errors = match t.get("errors") {
            Some(Item::Table(e)) => self.errors(e, &name, travel),
            Some(other) => {
                self.err(
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
                self.err(
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
            servo,
        })
    }

    fn errors(&mut self, t: &toml_edit::Table, axis: &str, travel: Option<[f64; 2]>) -> AxisErrors {
        let mut out = AxisErrors::default();
        for (k, item) in t.iter() {
            let span = Self::key_span(t, k);
            let name: ErrorName = match k.parse() {
                Ok(n) => n,
                Err(e) => {
                    self.err(span, e.to_string());
                    continue;
                }
            };
            if name.axis != axis {
                self.err(
                    span,
                    format!("error `{k}` names axis `{}` but is listed under axis `{axis}`; move it to that axis or rename it", name.axis),
                );
                continue;
            }
            let Item::Value(v) = item else {
                self.err(
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
                    _ => self.err(
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

    fn function(&mut self, v: &Value, k: &str, travel: Option<[f64; 2]>) -> Option<ErrorFunction> {
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
                    self.err(
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
                        if c.is_empty() {
                            self.err(
                                val.span(),
                                format!("`{form}` of error `{k}` needs at least one coefficient"),
                            );
                            return None;
                        }
                        if form == "cheb" && travel.is_none() {
                            return None;
                        }
                        Some(if form == "poly" {
                            ErrorFunction::Poly(c)
                        } else {
                            ErrorFunction::Cheb(c)
                        })
                    }
                    "table" => {
                        let Value::InlineTable(tt) = val else {
                            self.err(
                                val.span(),
                                format!("`table` of error `{k}` must be {{ q = [..], e = [..] }}"),
                            );
                            return None;
                        };
                        for (kk, _) in tt.iter() {
                            if kk != "q" && kk != "e" {
                                let span = tt.get_key_value(kk).and_then(|(key, _)| key.span());
                                self.err(span.or(tt.span()), format!("unknown key `{kk}` in `table` of error `{k}` (allowed: q, e)"));
                            }
                        }
                        let q = tt
                            .get("q")
                            .and_then(|x| self.numbers(x, &format!("`q` of the table of `{k}`")));
                        let e = tt
                            .get("e")
                            .and_then(|x| self.numbers(x, &format!("`e` of the table of `{k}`")));
                        let (Some(q), Some(e)) = (q, e) else {
                            self.err(
                                tt.span(),
                                format!("`table` of error `{k}` needs both `q` and `e`"),
                            );
                            return None;
                        };
                        if q.len() != e.len() || q.is_empty() {
                            self.err(tt.span(), format!("`table` of error `{k}`: `q` and `e` must have the same, non-zero length ({} and {})", q.len(), e.len()));
                            return None;
                        }
                        if q.windows(2).any(|w| w[1] <= w[0]) {
                            self.err(
                                tt.span(),
                                format!("`q` of the table of `{k}` must be strictly increasing"),
                            );
                            return None;
                        }
                        Some(ErrorFunction::Table { q, e })
                    }
                    other => {
                        let span = it.get_key_value(other).and_then(|(key, _)| key.span());
                        self.err(
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
                self.err(
                    v.span(),
                    format!(
                        "error `{k}` must be a number or an inline table like {{ cheb = [..] }}"
                    ),
                );
                None
            }
        }
    }

    /// The `[axes.servo]` table, read and validated exactly as a `SERVO.toml`.
    fn servo(&mut self, t: &dyn TableLike, what: &str) -> Option<ServoTable> {
        let w = format!("the servo table of {what}");
        read_servo_table(&mut self.r, t, &w).map(|s| ServoTable {
            ts: s.ts(),
            b: s.b().to_vec(),
            a: s.a().to_vec(),
            nk: s.nk(),
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
        // The servo table follows the SERVO.toml rules (one reader for both).
        expect_error(
            &GOOD.replace("ts = 0.001", "ts = 0.0"),
            28,
            "the servo table of",
        );
        expect_error(
            &GOOD.replace("ts = 0.001", "ts = 0.001\n  nk = -1"),
            29,
            "`nk` must be a non-negative integer",
        );
        expect_error(
            &GOOD.replace("b = [0.0, 0.5]", "b = []"),
            29,
            "no `b` coefficient",
        );
        expect_error(
            &GOOD.replace("EXX = {", "EQX = {"),
            16,
            "not an ISO 230-1 error name",
        );
        expect_error("name = [", 1, "not valid TOML");
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
