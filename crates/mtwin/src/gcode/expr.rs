//! RS-274/NGC expressions as LinuxCNC 2.9 evaluates them (its G-code manual,
//! chapter "Expressions"): `[1 + 2 * 3]`, `sqrt[2]`, `atan[1]/[1]`, with its
//! operators and precedence (`**`; `*` `/` `MOD`; `+` `-`; `EQ` `NE` `GT`
//! `GE` `LT` `LE`; `AND` `OR` `XOR`), its functions (trigonometric ones in
//! degrees), parameters `#5`, `#<name>`, `#<_global>`, indirection `#[..]`
//! and `##5`, and `EXISTS[#<name>]`.

use super::parameters::{ParamError, Parameters, normalise_name};

/// Why an expression has no value.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum ExprError {
    /// A parameter cannot be read (undefined named one, number out of range).
    Param(ParamError),
    /// It is malformed or its value is undefined (division by zero, ...).
    Invalid(String),
}

impl From<ParamError> for ExprError {
    fn from(e: ParamError) -> Self {
        ExprError::Param(e)
    }
}

impl std::fmt::Display for ExprError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ExprError::Param(e) => e.fmt(f),
            ExprError::Invalid(m) => f.write_str(m),
        }
    }
}

/// Where an assignment writes.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Target {
    /// `#n`.
    Numbered(u32),
    /// `#<name>` (normalised).
    Named(String),
}

/// Value of a word value text (a number, an expression, a function call, a
/// parameter, any of them signed) with parameters read from `params` (the
/// lexer guarantees balanced brackets).
pub(crate) fn eval(text: &[u8], params: &Parameters) -> Result<f64, ExprError> {
    let mut p = Parser {
        b: text,
        i: 0,
        params,
    };
    let v = p.operand()?;
    p.skip();
    if p.i != p.b.len() {
        return Err(ExprError::Invalid(format!(
            "unexpected text after the value at byte {}",
            p.i + 1
        )));
    }
    finite(v)
}

fn finite(v: f64) -> Result<f64, ExprError> {
    if v.is_finite() {
        Ok(v)
    } else {
        Err(ExprError::Invalid(
            "the expression has no finite value".into(),
        ))
    }
}

#[derive(Clone, Copy, PartialEq)]
enum Op {
    Pow,
    Mul,
    Div,
    Mod,
    Add,
    Sub,
    Eq,
    Ne,
    Gt,
    Ge,
    Lt,
    Le,
    And,
    Or,
    Xor,
}

impl Op {
    fn precedence(self) -> u8 {
        match self {
            Op::Pow => 4,
            Op::Mul | Op::Div | Op::Mod => 3,
            Op::Add | Op::Sub => 2,
            Op::Eq | Op::Ne | Op::Gt | Op::Ge | Op::Lt | Op::Le => 1,
            Op::And | Op::Or | Op::Xor => 0,
        }
    }

    fn apply(self, a: f64, b: f64) -> Result<f64, ExprError> {
        let truth = |c: bool| if c { 1.0 } else { 0.0 };
        Ok(match self {
            Op::Pow => {
                if a < 0.0 && b.fract() != 0.0 {
                    return Err(ExprError::Invalid(
                        "Attempt to raise negative to non-integer power".into(),
                    ));
                }
                a.powf(b)
            }
            Op::Mul => a * b,
            Op::Div => {
                if b == 0.0 {
                    return Err(ExprError::Invalid("Attempt to divide by zero".into()));
                }
                a / b
            }
            Op::Mod => {
                if b == 0.0 {
                    return Err(ExprError::Invalid("Attempt to divide by zero".into()));
                }
                // LinuxCNC: result has the sign of the divisor's modulus, in [0, |b|).
                let r = a % b;
                if r < 0.0 { r + b.abs() } else { r }
            }
            Op::Add => a + b,
            Op::Sub => a - b,
            Op::Eq => truth(a == b),
            Op::Ne => truth(a != b),
            Op::Gt => truth(a > b),
            Op::Ge => truth(a >= b),
            Op::Lt => truth(a < b),
            Op::Le => truth(a <= b),
            Op::And => truth(a != 0.0 && b != 0.0),
            Op::Or => truth(a != 0.0 || b != 0.0),
            Op::Xor => truth((a != 0.0) != (b != 0.0)),
        })
    }
}

/// The target and value of an assignment text `#.. = value`, both read with
/// the parameter values before the line (LinuxCNC applies a line's
/// assignments after reading the whole line).
pub(crate) fn assignment(text: &[u8], params: &Parameters) -> Result<(Target, f64), ExprError> {
    let mut p = Parser {
        b: text,
        i: 0,
        params,
    };
    p.expect(b'#')?;
    let target = p.reference()?;
    p.expect(b'=')?;
    let v = p.operand()?;
    p.skip();
    if p.i != p.b.len() {
        return Err(ExprError::Invalid(format!(
            "unexpected text after the value at byte {}",
            p.i + 1
        )));
    }
    Ok((target, finite(v)?))
}

/// The value of a sequence of `[expr]` arguments (O-word call arguments),
/// with the rest of the text (comments) after them ignored by the caller:
/// returns the values and the byte offset after the last one.
pub(crate) fn bracket_list(
    text: &[u8],
    params: &Parameters,
) -> Result<(Vec<f64>, usize), ExprError> {
    let mut p = Parser {
        b: text,
        i: 0,
        params,
    };
    let mut out = Vec::new();
    while p.peek() == Some(b'[') {
        out.push(finite(p.bracketed()?)?);
    }
    p.skip();
    Ok((out, p.i))
}

struct Parser<'a> {
    b: &'a [u8],
    i: usize,
    params: &'a Parameters,
}

impl Parser<'_> {
    /// What follows a `#`: `n`, `<name>`, `[expr]` or `#..` (indirection).
    fn reference(&mut self) -> Result<Target, ExprError> {
        match self.peek() {
            Some(b'<') => {
                let start = self.i + 1;
                let Some(k) = self.b[start..].iter().position(|&c| c == b'>') else {
                    return Err(ExprError::Invalid("'<' is not closed by '>'".into()));
                };
                let raw = String::from_utf8_lossy(&self.b[start..start + k]);
                self.i = start + k + 1;
                let name = normalise_name(&raw);
                if name.is_empty() {
                    return Err(ExprError::Invalid("empty parameter name".into()));
                }
                Ok(Target::Named(name))
            }
            Some(b'[') => {
                let n = self.bracketed()?;
                Ok(Target::Numbered(Parameters::index(n)?))
            }
            Some(b'#') => {
                self.i += 1;
                let t = self.reference()?;
                let n = self.read(&t)?;
                Ok(Target::Numbered(Parameters::index(n)?))
            }
            Some(b'0'..=b'9' | b'.') => {
                let n = self.number()?;
                Ok(Target::Numbered(Parameters::index(n)?))
            }
            // LinuxCNC reads any value after `#`, a function call too:
            // `#atan[1]/[1]` is `#45`.
            Some(c) if c.is_ascii_alphabetic() => {
                let n = self.function()?;
                Ok(Target::Numbered(Parameters::index(n)?))
            }
            _ => Err(ExprError::Invalid(format!(
                "'#' must be followed by a parameter number or <name> at byte {}",
                self.i + 1
            ))),
        }
    }

    fn read(&self, t: &Target) -> Result<f64, ExprError> {
        Ok(match t {
            Target::Numbered(n) => self.params.get(*n),
            Target::Named(name) => self.params.get_named(name)?,
        })
    }

    fn skip(&mut self) {
        while self
            .b
            .get(self.i)
            .is_some_and(|c| super::lexer::is_space(*c))
        {
            self.i += 1;
        }
    }

    fn peek(&mut self) -> Option<u8> {
        self.skip();
        self.b.get(self.i).copied()
    }

    fn expect(&mut self, c: u8) -> Result<(), ExprError> {
        if self.peek() == Some(c) {
            self.i += 1;
            Ok(())
        } else {
            Err(ExprError::Invalid(format!(
                "expected '{}' at byte {}",
                c as char,
                self.i + 1
            )))
        }
    }

    /// `[ expr ]`: binary operators with LinuxCNC precedence, left to right.
    fn bracketed(&mut self) -> Result<f64, ExprError> {
        self.expect(b'[')?;
        let mut values = vec![self.operand()?];
        let mut ops: Vec<Op> = Vec::new();
        while let Some(op) = self.operator()? {
            while ops
                .last()
                .is_some_and(|top| top.precedence() >= op.precedence())
            {
                reduce(&mut values, &mut ops)?;
            }
            ops.push(op);
            values.push(self.operand()?);
        }
        while !ops.is_empty() {
            reduce(&mut values, &mut ops)?;
        }
        self.expect(b']')?;
        values
            .pop()
            .ok_or_else(|| ExprError::Invalid("empty expression".into()))
    }

    fn operator(&mut self) -> Result<Option<Op>, ExprError> {
        let Some(c) = self.peek() else {
            return Ok(None);
        };
        let rest = &self.b[self.i..];
        let two = |s: &[u8]| rest.len() >= s.len() && rest[..s.len()].eq_ignore_ascii_case(s);
        let (op, len) = match c {
            b']' => return Ok(None),
            b'*' if two(b"**") => (Op::Pow, 2),
            b'*' => (Op::Mul, 1),
            b'/' => (Op::Div, 1),
            b'+' => (Op::Add, 1),
            b'-' => (Op::Sub, 1),
            _ => {
                let words: [(&[u8], Op); 10] = [
                    (b"MOD", Op::Mod),
                    (b"EQ", Op::Eq),
                    (b"NE", Op::Ne),
                    (b"GT", Op::Gt),
                    (b"GE", Op::Ge),
                    (b"LT", Op::Lt),
                    (b"LE", Op::Le),
                    (b"AND", Op::And),
                    (b"OR", Op::Or),
                    (b"XOR", Op::Xor),
                ];
                match words.iter().find(|(w, _)| two(w)) {
                    Some(&(w, op)) => (op, w.len()),
                    None => {
                        return Err(ExprError::Invalid(format!(
                            "unknown operation at byte {}",
                            self.i + 1
                        )));
                    }
                }
            }
        };
        self.i += len;
        Ok(Some(op))
    }

    /// A number, `[expr]`, a function call, or one of them after a sign.
    fn operand(&mut self) -> Result<f64, ExprError> {
        match self.peek() {
            Some(b'-') => {
                self.i += 1;
                Ok(-self.operand()?)
            }
            Some(b'+') => {
                self.i += 1;
                self.operand()
            }
            Some(b'[') => self.bracketed(),
            Some(b'#') => {
                self.i += 1;
                let t = self.reference()?;
                self.read(&t)
            }
            Some(b'0'..=b'9' | b'.') => self.number(),
            Some(c) if c.is_ascii_alphabetic() => self.function(),
            _ => Err(ExprError::Invalid(format!(
                "expected a value at byte {}",
                self.i + 1
            ))),
        }
    }

    fn number(&mut self) -> Result<f64, ExprError> {
        let mut text = String::new();
        while let Some(&c) = self.b.get(self.i) {
            if c.is_ascii_digit() || c == b'.' {
                text.push(c as char);
            } else if !super::lexer::is_space(c) {
                break;
            }
            self.i += 1;
        }
        text.parse()
            .map_err(|_| ExprError::Invalid(format!("malformed number {text}")))
    }

    fn function(&mut self) -> Result<f64, ExprError> {
        let start = self.i;
        while self.b.get(self.i).is_some_and(u8::is_ascii_alphabetic) {
            self.i += 1;
        }
        let name = self.b[start..self.i].to_ascii_uppercase();
        if name == b"EXISTS" {
            // EXISTS[#<name>]: whether a named parameter is defined;
            // EXISTS[#n] (n a number, `[expr]` or `#..`): whether n is a
            // valid parameter number (LinuxCNC's rule).
            self.expect(b'[')?;
            self.expect(b'#')?;
            let exists = if self.peek() == Some(b'<') {
                match self.reference()? {
                    Target::Named(n) => self.params.exists(&n),
                    Target::Numbered(_) => false,
                }
            } else {
                let n = match self.peek() {
                    Some(b'[') => self.bracketed()?,
                    Some(b'#') => {
                        self.i += 1;
                        let t = self.reference()?;
                        self.read(&t)?
                    }
                    Some(b'0'..=b'9' | b'.') => self.number()?,
                    _ => {
                        return Err(ExprError::Invalid(format!(
                            "'#' must be followed by a parameter number or <name> at byte {}",
                            self.i + 1
                        )));
                    }
                };
                let r = n.round();
                if (n - r).abs() > 1e-4 {
                    return Err(ExprError::Param(ParamError::NotInteger(n)));
                }
                (1.0..f64::from(super::parameters::MAX_NUMBERED)).contains(&r)
            };
            self.expect(b']')?;
            return Ok(if exists { 1.0 } else { 0.0 });
        }
        let x = self.bracketed()?;
        let deg = |r: f64| r.to_degrees();
        let domain = |ok: bool, what: &str| {
            if ok {
                Ok(())
            } else {
                Err(ExprError::Invalid(what.to_string()))
            }
        };
        Ok(match name.as_slice() {
            b"ABS" => x.abs(),
            b"ACOS" => {
                domain((-1.0..=1.0).contains(&x), "Argument to acos out of range")?;
                deg(x.acos())
            }
            b"ASIN" => {
                domain((-1.0..=1.0).contains(&x), "Argument to asin out of range")?;
                deg(x.asin())
            }
            b"ATAN" => {
                self.expect(b'/')?;
                let y = self.bracketed()?;
                deg(x.atan2(y))
            }
            b"COS" => x.to_radians().cos(),
            b"SIN" => x.to_radians().sin(),
            b"TAN" => x.to_radians().tan(),
            b"EXP" => x.exp(),
            b"LN" => {
                domain(x > 0.0, "Zero or negative argument to ln")?;
                x.ln()
            }
            b"SQRT" => {
                domain(x >= 0.0, "Attempt to take square root of negative number")?;
                x.sqrt()
            }
            b"FIX" => x.floor(),
            b"FUP" => x.ceil(),
            b"ROUND" => x.round(),
            _ => {
                return Err(ExprError::Invalid(format!(
                    "unknown function {}",
                    String::from_utf8_lossy(&name)
                )));
            }
        })
    }
}

fn reduce(values: &mut Vec<f64>, ops: &mut Vec<Op>) -> Result<(), ExprError> {
    let (Some(op), Some(b), Some(a)) = (ops.pop(), values.pop(), values.pop()) else {
        return Err(ExprError::Invalid("malformed expression".into()));
    };
    values.push(op.apply(a, b)?);
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ev(s: &str) -> f64 {
        eval(s.as_bytes(), &Parameters::new()).unwrap()
    }

    fn ev_with(s: &str, p: &Parameters) -> Result<f64, ExprError> {
        eval(s.as_bytes(), p)
    }

    #[test]
    fn precedence_and_associativity() {
        assert_eq!(ev("[1 + 2 * 3]"), 7.0);
        assert_eq!(ev("[2 ** 3 * 2]"), 16.0);
        assert_eq!(ev("[10 - 4 - 3]"), 3.0);
        assert_eq!(ev("[8 / 4 / 2]"), 1.0);
        assert_eq!(ev("[1 + 2 GT 2]"), 1.0);
        assert_eq!(ev("[7 mod 3]"), 1.0);
        assert_eq!(ev("[-7 MOD 3]"), 2.0);
        assert_eq!(ev("-[2]"), -2.0);
        assert_eq!(ev("[0 OR 1 AND 0]"), 0.0); // left to right at equal precedence
    }

    #[test]
    fn functions_use_degrees() {
        assert!((ev("sin[30]") - 0.5).abs() < 1e-15);
        assert!((ev("atan[1]/[1]") - 45.0).abs() < 1e-12);
        assert!(
            (ev("[3000 + [100 * [0.0101 * sqrt[2]]]]") - (3000.0 + 1.01 * 2f64.sqrt())).abs()
                < 1e-9
        );
        assert_eq!(ev("fup[1.2]"), 2.0);
        assert_eq!(ev("fix[-1.2]"), -2.0);
    }

    #[test]
    fn errors() {
        let p = Parameters::new();
        assert!(matches!(
            ev_with("[#<nope> + 2]", &p),
            Err(ExprError::Param(_))
        ));
        assert!(matches!(
            ev_with("EXISTS[1]", &p),
            Err(ExprError::Invalid(_))
        ));
        assert!(matches!(
            ev_with("EXISTS[#1+#2]", &p),
            Err(ExprError::Invalid(_))
        ));
        assert!(matches!(ev_with("[#5602]", &p), Err(ExprError::Param(_))));
        assert!(matches!(ev_with("[1/0]", &p), Err(ExprError::Invalid(_))));
        assert!(matches!(
            ev_with("sqrt[-1]", &p),
            Err(ExprError::Invalid(_))
        ));
        assert!(matches!(ev_with("[1 +]", &p), Err(ExprError::Invalid(_))));
        assert!(matches!(
            ev_with("[-8 ** 0.5]", &p),
            Err(ExprError::Invalid(_))
        ));
    }

    #[test]
    fn parameters_indirection_and_exists() {
        let mut p = Parameters::new();
        p.set(1, 3.0).unwrap();
        p.set(3, 7.5).unwrap();
        p.set(10, 2.0).unwrap();
        p.set_named("depth", -1.25).unwrap();
        p.set_named("_safe", 5.0).unwrap();
        assert_eq!(ev_with("#1", &p), Ok(3.0));
        assert_eq!(ev_with("-#1", &p), Ok(-3.0));
        assert_eq!(ev_with("##1", &p), Ok(7.5), "#[#1] = #3");
        assert_eq!(ev_with("#[#1]", &p), Ok(7.5));
        assert_eq!(ev_with("#[1 + 2]", &p), Ok(7.5));
        assert_eq!(ev_with("[#1 * #10 ** 2]", &p), Ok(12.0), "3 * 2^2");
        assert_eq!(ev_with("#<Depth>", &p), Ok(-1.25));
        assert_eq!(ev_with("#< d e p t h >", &p), Ok(-1.25));
        assert_eq!(ev_with("[#<_safe> - #<depth>]", &p), Ok(6.25));
        assert_eq!(ev_with("EXISTS[#<_safe>]", &p), Ok(1.0));
        assert_eq!(ev_with("exists[#<_other>]", &p), Ok(0.0));
        // A number: whether it is a valid parameter number (1 to 5601).
        assert_eq!(ev_with("EXISTS[#1]", &p), Ok(1.0));
        assert_eq!(ev_with("EXISTS[#5601]", &p), Ok(1.0));
        assert_eq!(ev_with("EXISTS[#5602]", &p), Ok(0.0));
        assert_eq!(ev_with("EXISTS[#[#1 * 0]]", &p), Ok(0.0));
        assert_eq!(ev_with("EXISTS[##10]", &p), Ok(1.0), "#2 exists");
        assert_eq!(
            ev_with("[#2]", &p),
            Ok(0.0),
            "an unset numbered parameter reads 0"
        );
        assert_eq!(ev_with("[#3 GT #1 AND #1 LT 4]", &p), Ok(1.0));
        assert_eq!(ev_with("round[#3]", &p), Ok(8.0));
        assert_eq!(ev_with("abs[-#3]", &p), Ok(7.5));
        assert_eq!(ev_with("[2 XOR 0]", &p), Ok(1.0));
        assert_eq!(ev_with("[5 NE 5]", &p), Ok(0.0));
        assert_eq!(ev_with("[5 LE 5]", &p), Ok(1.0));
        assert!((ev_with("acos[0.5]", &p).unwrap() - 60.0).abs() < 1e-12);
        assert!((ev_with("asin[1]", &p).unwrap() - 90.0).abs() < 1e-12);
        assert!((ev_with("tan[45]", &p).unwrap() - 1.0).abs() < 1e-12);
        assert!((ev_with("exp[1]", &p).unwrap() - std::f64::consts::E).abs() < 1e-15);
        assert!((ev_with("ln[exp[2]]", &p).unwrap() - 2.0).abs() < 1e-15);
        assert!((ev_with("cos[60]", &p).unwrap() - 0.5).abs() < 1e-15);
    }

    #[test]
    fn assignments_read_old_values() {
        let mut p = Parameters::new();
        p.set(1, 4.0).unwrap();
        assert_eq!(
            assignment(b"#2 = [#1 * 2]", &p),
            Ok((Target::Numbered(2), 8.0))
        );
        assert_eq!(
            assignment(b"#[#1 + 1] = -#1", &p),
            Ok((Target::Numbered(5), -4.0))
        );
        assert_eq!(
            assignment(b"#<My Var>=1.5", &p),
            Ok((Target::Named("myvar".into()), 1.5))
        );
        assert!(assignment(b"#0 = 1", &p).is_err());
        let (v, end) = bracket_list(b" [1] [#1+1] (c)", &p).unwrap();
        assert_eq!(v, vec![1.0, 5.0]);
        assert_eq!(&b" [1] [#1+1] (c)"[end..], b"(c)");
    }
}
