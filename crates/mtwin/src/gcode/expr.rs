//! Constant RS-274/NGC expressions: `[1 + 2 * 3]`, `sqrt[2]`,
//! `atan[1]/[1]`, with LinuxCNC's operators and precedence (`**`; `*` `/`
//! `MOD`; `+` `-`; `EQ` `NE` `GT` `GE` `LT` `LE`; `AND` `OR` `XOR`) and its
//! trigonometric functions in degrees. Parameters (`#..`) and `EXISTS` are
//! not evaluated: they are reported as such.

/// Why an expression has no value.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum ExprError {
    /// It refers to a parameter (not supported).
    Parameter,
    /// It is malformed or its value is undefined (division by zero, ...).
    Invalid(String),
}

/// Value of a word value text that is an expression, a function call or a
/// signed one (the lexer guarantees balanced brackets).
pub(crate) fn eval(text: &[u8]) -> Result<f64, ExprError> {
    if text.contains(&b'#') {
        return Err(ExprError::Parameter);
    }
    let mut p = Parser { b: text, i: 0 };
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

struct Parser<'a> {
    b: &'a [u8],
    i: usize,
}

impl Parser<'_> {
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
            return Err(ExprError::Parameter);
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
        eval(s.as_bytes()).unwrap()
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
        assert_eq!(eval(b"[#1 + 2]"), Err(ExprError::Parameter));
        assert_eq!(eval(b"EXISTS[1]"), Err(ExprError::Parameter));
        assert!(matches!(eval(b"[1/0]"), Err(ExprError::Invalid(_))));
        assert!(matches!(eval(b"sqrt[-1]"), Err(ExprError::Invalid(_))));
        assert!(matches!(eval(b"[1 +]"), Err(ExprError::Invalid(_))));
    }
}
