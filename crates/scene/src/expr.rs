//! Height expressions `z = f(x, y)`: a small parser and evaluator.
//!
//! Written here rather than taken from a crate because the expression crates
//! at hand either do integer arithmetic on integer literals (`1/2` is `0`) or
//! report parse errors without a position, and a user typing `z = "..."`
//! needs the character that is wrong. The grammar is the usual one:
//!
//! ```text
//! sum     = product (('+' | '-') product)*
//! product = unary (('*' | '/') unary)*
//! unary   = ('-' | '+') unary | power
//! power   = atom ('^' unary)?          right-associative: 2^3^2 = 2^9
//! atom    = number | name | name '(' sum (',' sum)* ')' | '(' sum ')'
//! ```
//!
//! Names: the variables `x`, `y`, the constants `pi`, `e`, and the functions
//! `sin cos tan asin acos atan sinh cosh tanh exp ln log10 sqrt abs floor ceil
//! round` (one argument), `min max atan2 hypot pow` (two arguments).

use rayon::prelude::*;
use std::fmt;
use thiserror::Error;

/// A parse error: what is wrong and at which character (0-based, in chars).
#[derive(Clone, Debug, Error, PartialEq)]
pub struct ExprError {
    /// The expression as written.
    pub text: String,
    /// Character index of the problem (0-based).
    pub at: usize,
    /// What is wrong.
    pub message: String,
}

impl fmt::Display for ExprError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        // A window of the text around the fault, so a 100 KB expression
        // does not become a 100 KB message.
        const SIDE: usize = 30;
        let chars: Vec<char> = self.text.chars().collect();
        let (from, to) = (self.at.saturating_sub(SIDE), (self.at + SIDE).min(chars.len()));
        let lead = if from > 0 { "..." } else { "" };
        let tail = if to < chars.len() { "..." } else { "" };
        let shown: String = chars[from..to].iter().collect();
        let caret = " ".repeat(lead.len() + self.at - from);
        write!(f, "{} at character {}:\n    {lead}{shown}{tail}\n    {caret}^", self.message, self.at + 1)
    }
}

/// The most nodes an expression may have (a typed expression is far smaller;
/// the limit only bounds recursion on hostile input).
pub const MAX_NODES: usize = 10_000;

/// The deepest nesting of parentheses, signs and powers (bounds recursion).
pub const MAX_DEPTH: usize = 200;

/// A function of one argument.
type Unary = fn(f64) -> f64;
/// A function of two arguments.
type Binary = fn(f64, f64) -> f64;

/// Functions of one argument.
const UNARY: &[(&str, Unary)] = &[
    ("sin", f64::sin),
    ("cos", f64::cos),
    ("tan", f64::tan),
    ("asin", f64::asin),
    ("acos", f64::acos),
    ("atan", f64::atan),
    ("sinh", f64::sinh),
    ("cosh", f64::cosh),
    ("tanh", f64::tanh),
    ("exp", f64::exp),
    ("ln", f64::ln),
    ("log10", f64::log10),
    ("sqrt", f64::sqrt),
    ("abs", f64::abs),
    ("floor", f64::floor),
    ("ceil", f64::ceil),
    ("round", f64::round),
];

/// Functions of two arguments.
const BINARY: &[(&str, Binary)] = &[("min", f64::min), ("max", f64::max), ("atan2", f64::atan2), ("hypot", f64::hypot), ("pow", f64::powf)];

#[derive(Clone, Debug)]
enum Node {
    Num(f64),
    X,
    Y,
    Neg(Box<Node>),
    Add(Box<Node>, Box<Node>),
    Sub(Box<Node>, Box<Node>),
    Mul(Box<Node>, Box<Node>),
    Div(Box<Node>, Box<Node>),
    Pow(Box<Node>, Box<Node>),
    /// `a^2`, the commonest power in a surface's formula, as one product:
    /// the correctly rounded square, at a fraction of `powf`'s cost (heights
    /// of a large grid were a fifth pow calls).
    Square(Box<Node>),
    F1(fn(f64) -> f64, Box<Node>),
    F2(fn(f64, f64) -> f64, Box<Node>, Box<Node>),
}

/// A parsed expression in `x` and `y`.
#[derive(Clone, Debug)]
pub struct Expr {
    root: Node,
}

impl Expr {
    /// Parses `text`.
    ///
    /// # Errors
    /// An [`ExprError`] pointing at the offending character.
    pub fn parse(text: &str) -> Result<Expr, ExprError> {
        let mut p = Parser { chars: text.chars().collect(), pos: 0, text, nodes: 0, depth: 0 };
        p.skip_ws();
        if p.pos == p.chars.len() {
            return Err(p.error("empty expression"));
        }
        let root = p.sum()?;
        p.skip_ws();
        if p.pos < p.chars.len() {
            let c = p.chars[p.pos];
            return Err(p.error(&format!("unexpected `{c}`")));
        }
        Ok(Expr { root })
    }

    /// The value at `(x, y)`; may be NaN or infinite (the caller decides).
    #[must_use]
    pub fn eval(&self, x: f64, y: f64) -> f64 {
        eval(&self.root, x, y)
    }
}

impl Expr {
    /// [`Expr::eval`] at every point of the grid `xs` x `ys`, row by row
    /// (`z[j * xs.len() + i]` at `(xs[i], ys[j])`), the rows in parallel;
    /// each value is exactly `eval`'s. Evaluated a row at a time, so a part
    /// in `x` alone is computed once per column and a part in `y` alone
    /// once per row: on a surface like `exp(-(x^2 + y^2)) + sin(3 x) cos(2 y)`
    /// one of its three functions is left for every point. The work is the
    /// expression's size times the points, as for `eval` at each.
    #[must_use]
    pub fn eval_grid(&self, xs: &[f64], ys: &[f64]) -> Vec<f64> {
        let mut shape = Vec::new();
        shape_of(&self.root, &mut shape);
        let mut row = RowProgram { xs, steps: Vec::new(), columns: Vec::new() };
        row.compile(&self.root, 0, &shape);
        let mut z = vec![0.0; xs.len() * ys.len()];
        z.par_chunks_mut(xs.len().max(1)).zip(ys.par_iter()).for_each(|(out, &y)| row.run(y, out));
        z
    }
}

/// Per node in pre-order: whether it reads `x`, whether it reads `y`, and
/// its subtree's size (so a subtree can be stepped over).
fn shape_of(n: &Node, out: &mut Vec<(bool, bool, usize)>) -> (bool, bool) {
    let at = out.len();
    out.push((false, false, 0));
    let reads = match n {
        Node::Num(_) => (false, false),
        Node::X => (true, false),
        Node::Y => (false, true),
        Node::Neg(a) | Node::Square(a) | Node::F1(_, a) => shape_of(a, out),
        Node::Add(a, b) | Node::Sub(a, b) | Node::Mul(a, b) | Node::Div(a, b) | Node::Pow(a, b) | Node::F2(_, a, b) => {
            let (a, b) = (shape_of(a, out), shape_of(b, out));
            (a.0 || b.0, a.1 || b.1)
        }
    };
    out[at] = (reads.0, reads.1, out.len() - at);
    reads
}

/// One step of a row's evaluation, on a stack of rows of values.
enum Step<'a> {
    /// Push the xs.
    X,
    /// Push a part in x alone: `columns[k]`.
    Column(usize),
    /// Push a part that reads no x, evaluated once for the row.
    Scalar(&'a Node),
    /// Replace the top with its values mapped.
    Unary(Unary),
    /// Replace the two on top (first below) with their values combined.
    Binary(Binary),
}

/// An expression as steps over the rows of fixed `xs`, with its parts in
/// `x` alone evaluated once.
struct RowProgram<'a> {
    xs: &'a [f64],
    steps: Vec<Step<'a>>,
    columns: Vec<Vec<f64>>,
}

impl<'a> RowProgram<'a> {
    /// Appends the steps of `n`, node `at` of `shape` (in pre-order).
    fn compile(&mut self, n: &'a Node, at: usize, shape: &[(bool, bool, usize)]) {
        match (n, shape[at]) {
            (Node::X, _) => self.steps.push(Step::X),
            (_, (false, _, _)) => self.steps.push(Step::Scalar(n)),
            (_, (true, false, _)) => {
                self.columns.push(self.xs.iter().map(|&x| eval(n, x, 0.0)).collect());
                self.steps.push(Step::Column(self.columns.len() - 1));
            }
            (Node::Neg(a), _) => self.unary(a, at, shape, |v| -v),
            (Node::Square(a), _) => self.unary(a, at, shape, |v| v * v),
            (Node::F1(f, a), _) => self.unary(a, at, shape, *f),
            (Node::Add(a, b), _) => self.binary(a, b, at, shape, |v, w| v + w),
            (Node::Sub(a, b), _) => self.binary(a, b, at, shape, |v, w| v - w),
            (Node::Mul(a, b), _) => self.binary(a, b, at, shape, |v, w| v * w),
            (Node::Div(a, b), _) => self.binary(a, b, at, shape, |v, w| v / w),
            (Node::Pow(a, b), _) => self.binary(a, b, at, shape, f64::powf),
            (Node::F2(f, a, b), _) => self.binary(a, b, at, shape, *f),
            (Node::Num(_) | Node::Y, _) => unreachable!("reads no x: a scalar step"),
        }
    }

    fn unary(&mut self, a: &'a Node, at: usize, shape: &[(bool, bool, usize)], f: Unary) {
        self.compile(a, at + 1, shape);
        self.steps.push(Step::Unary(f));
    }

    fn binary(&mut self, a: &'a Node, b: &'a Node, at: usize, shape: &[(bool, bool, usize)], f: Binary) {
        self.compile(a, at + 1, shape);
        self.compile(b, at + 1 + shape[at + 1].2, shape);
        self.steps.push(Step::Binary(f));
    }

    /// The row at `y` into `out`, with the same operations on each value as
    /// [`eval`].
    fn run(&self, y: f64, out: &mut [f64]) {
        let mut stack: Vec<Vec<f64>> = Vec::new();
        let mut spare: Vec<Vec<f64>> = Vec::new();
        let fresh = |spare: &mut Vec<Vec<f64>>| spare.pop().unwrap_or_else(|| vec![0.0; out.len()]);
        for step in &self.steps {
            match step {
                Step::X => {
                    let mut v = fresh(&mut spare);
                    v.copy_from_slice(self.xs);
                    stack.push(v);
                }
                Step::Column(k) => {
                    let mut v = fresh(&mut spare);
                    v.copy_from_slice(&self.columns[*k]);
                    stack.push(v);
                }
                Step::Scalar(n) => {
                    let mut v = fresh(&mut spare);
                    v.fill(eval(n, 0.0, y));
                    stack.push(v);
                }
                Step::Unary(f) => {
                    let top = stack.last_mut().expect("a unary step follows its operand");
                    top.iter_mut().for_each(|v| *v = f(*v));
                }
                Step::Binary(f) => {
                    let second = stack.pop().expect("a binary step follows its operands");
                    let first = stack.last_mut().expect("a binary step follows its operands");
                    first.iter_mut().zip(&second).for_each(|(v, &w)| *v = f(*v, w));
                    spare.push(second);
                }
            }
        }
        out.copy_from_slice(&stack.pop().expect("an expression leaves one row"));
    }
}

fn eval(n: &Node, x: f64, y: f64) -> f64 {
    match n {
        Node::Num(v) => *v,
        Node::X => x,
        Node::Y => y,
        Node::Neg(a) => -eval(a, x, y),
        Node::Add(a, b) => eval(a, x, y) + eval(b, x, y),
        Node::Sub(a, b) => eval(a, x, y) - eval(b, x, y),
        Node::Mul(a, b) => eval(a, x, y) * eval(b, x, y),
        Node::Div(a, b) => eval(a, x, y) / eval(b, x, y),
        Node::Pow(a, b) => eval(a, x, y).powf(eval(b, x, y)),
        Node::Square(a) => {
            let v = eval(a, x, y);
            v * v
        }
        Node::F1(f, a) => f(eval(a, x, y)),
        Node::F2(f, a, b) => f(eval(a, x, y), eval(b, x, y)),
    }
}

struct Parser<'a> {
    chars: Vec<char>,
    pos: usize,
    text: &'a str,
    nodes: usize,
    depth: usize,
}

impl Parser<'_> {
    fn error(&self, message: &str) -> ExprError {
        ExprError { text: self.text.to_string(), at: self.pos.min(self.chars.len()), message: message.to_string() }
    }

    fn skip_ws(&mut self) {
        while self.pos < self.chars.len() && self.chars[self.pos].is_whitespace() {
            self.pos += 1;
        }
    }

    fn peek(&mut self) -> Option<char> {
        self.skip_ws();
        self.chars.get(self.pos).copied()
    }

    fn node(&mut self, n: Node) -> Result<Node, ExprError> {
        self.nodes += 1;
        if self.nodes > MAX_NODES {
            return Err(self.error(&format!("expression too long (more than {MAX_NODES} terms)")));
        }
        Ok(n)
    }

    fn sum(&mut self) -> Result<Node, ExprError> {
        let mut a = self.product()?;
        while let Some(c @ ('+' | '-')) = self.peek() {
            self.pos += 1;
            let b = self.product()?;
            a = self.node(if c == '+' { Node::Add(Box::new(a), Box::new(b)) } else { Node::Sub(Box::new(a), Box::new(b)) })?;
        }
        Ok(a)
    }

    fn product(&mut self) -> Result<Node, ExprError> {
        let mut a = self.unary()?;
        while let Some(c @ ('*' | '/')) = self.peek() {
            self.pos += 1;
            let b = self.unary()?;
            a = self.node(if c == '*' { Node::Mul(Box::new(a), Box::new(b)) } else { Node::Div(Box::new(a), Box::new(b)) })?;
        }
        Ok(a)
    }

    fn unary(&mut self) -> Result<Node, ExprError> {
        self.depth += 1;
        if self.depth > MAX_DEPTH {
            return Err(self.error(&format!("expression nested too deeply (more than {MAX_DEPTH} levels)")));
        }
        let r = self.unary_inner();
        self.depth -= 1;
        r
    }

    fn unary_inner(&mut self) -> Result<Node, ExprError> {
        match self.peek() {
            Some('-') => {
                self.pos += 1;
                let a = self.unary()?;
                self.node(Node::Neg(Box::new(a)))
            }
            Some('+') => {
                self.pos += 1;
                self.unary()
            }
            _ => self.power(),
        }
    }

    fn power(&mut self) -> Result<Node, ExprError> {
        let a = self.atom()?;
        if self.peek() == Some('^') {
            self.pos += 1;
            let b = self.unary()?;
            if matches!(b, Node::Num(n) if n == 2.0) {
                return self.node(Node::Square(Box::new(a)));
            }
            return self.node(Node::Pow(Box::new(a), Box::new(b)));
        }
        Ok(a)
    }

    fn atom(&mut self) -> Result<Node, ExprError> {
        match self.peek() {
            None => Err(self.error("expression ends too early")),
            Some('(') => {
                self.pos += 1;
                let a = self.sum()?;
                if self.peek() != Some(')') {
                    return Err(self.error("expected `)`"));
                }
                self.pos += 1;
                Ok(a)
            }
            Some(c) if c.is_ascii_digit() || c == '.' => self.number(),
            Some(c) if c.is_alphabetic() || c == '_' => self.name(),
            Some(c) => Err(self.error(&format!("unexpected `{c}`"))),
        }
    }

    fn number(&mut self) -> Result<Node, ExprError> {
        let start = self.pos;
        let digits = |p: &mut Self| {
            while p.pos < p.chars.len() && p.chars[p.pos].is_ascii_digit() {
                p.pos += 1;
            }
        };
        digits(self);
        if self.pos < self.chars.len() && self.chars[self.pos] == '.' {
            self.pos += 1;
            digits(self);
        }
        // An exponent only when digits follow.
        if self.pos < self.chars.len() && matches!(self.chars[self.pos], 'e' | 'E') {
            let mut q = self.pos + 1;
            if q < self.chars.len() && matches!(self.chars[q], '+' | '-') {
                q += 1;
            }
            if q < self.chars.len() && self.chars[q].is_ascii_digit() {
                self.pos = q;
                digits(self);
            }
        }
        let s: String = self.chars[start..self.pos].iter().collect();
        match s.parse::<f64>() {
            Ok(v) => self.node(Node::Num(v)),
            Err(_) => {
                self.pos = start;
                Err(self.error(&format!("`{}` is not a number", crate::excerpt::excerpt(&s))))
            }
        }
    }

    fn name(&mut self) -> Result<Node, ExprError> {
        let start = self.pos;
        while self.pos < self.chars.len() && (self.chars[self.pos].is_alphanumeric() || self.chars[self.pos] == '_') {
            self.pos += 1;
        }
        let name: String = self.chars[start..self.pos].iter().collect();
        let after = self.pos;
        if self.peek() == Some('(') {
            let f1 = UNARY.iter().find(|(n, _)| *n == name).map(|(_, f)| *f);
            let f2 = BINARY.iter().find(|(n, _)| *n == name).map(|(_, f)| *f);
            if f1.is_none() && f2.is_none() {
                self.pos = start;
                return Err(self.error(&format!("unknown function `{}`", crate::excerpt::excerpt(&name))));
            }
            self.pos += 1;
            let mut args = vec![self.sum()?];
            while self.peek() == Some(',') {
                self.pos += 1;
                args.push(self.sum()?);
            }
            if self.peek() != Some(')') {
                return Err(self.error("expected `)` or `,`"));
            }
            let close = self.pos;
            self.pos += 1;
            let want = if f1.is_some() { 1 } else { 2 };
            if args.len() != want {
                self.pos = close;
                return Err(self.error(&format!("`{name}` takes {want} argument(s), got {}", args.len())));
            }
            let mut it = args.into_iter();
            let a = Box::new(it.next().expect("one argument"));
            return match (f1, f2) {
                (Some(f), _) => self.node(Node::F1(f, a)),
                (None, Some(f)) => {
                    let b = Box::new(it.next().expect("two arguments"));
                    self.node(Node::F2(f, a, b))
                }
                (None, None) => unreachable!("checked above"),
            };
        }
        self.pos = after;
        match name.as_str() {
            "x" => self.node(Node::X),
            "y" => self.node(Node::Y),
            "pi" => self.node(Node::Num(std::f64::consts::PI)),
            "e" => self.node(Node::Num(std::f64::consts::E)),
            _ => {
                self.pos = start;
                if UNARY.iter().any(|(n, _)| *n == name) || BINARY.iter().any(|(n, _)| *n == name) {
                    Err(self.error(&format!("`{name}` is a function: write `{name}(...)`")))
                } else {
                    Err(self.error(&format!("unknown name `{}` (variables are x and y)", crate::excerpt::excerpt(&name))))
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_grid_is_evaluated_exactly_as_point_by_point() {
        // Parts in x alone, y alone, both, neither, nested; powers, two-
        // argument functions, values that overflow or are not numbers.
        let xs: Vec<f64> = (0..37).map(|i| -2.0 + 0.113 * i as f64).collect();
        let ys: Vec<f64> = (0..23).map(|j| -1.5 + 0.137 * j as f64).collect();
        for text in [
            "0.6 * exp(-(x^2 + y^2)) + 0.15 * sin(3 * x) * cos(2 * y)",
            "x",
            "y",
            "2.5",
            "-x^2 - y + 1/x",
            "sqrt(x) * atan2(y, x) - pow(2, x * y) + hypot(3, y)",
            "max(sin(x), cos(y)) / min(x, 2 * x)",
            "(x + 1)^(y - 0.5) + 2^3^x",
            "exp(x * 800) - exp(y * 800)",
            "sin(cos(tan(x))) * -(y^2)",
        ] {
            let e = Expr::parse(text).unwrap();
            let z = e.eval_grid(&xs, &ys);
            assert_eq!(z.len(), xs.len() * ys.len());
            for (j, &y) in ys.iter().enumerate() {
                for (i, &x) in xs.iter().enumerate() {
                    assert_eq!(z[j * xs.len() + i].to_bits(), e.eval(x, y).to_bits(), "{text} at ({x}, {y})");
                }
            }
        }
        assert!(Expr::parse("x + y").unwrap().eval_grid(&[], &ys).is_empty());
        // The longest expression: its steps are made once, not per row.
        let long = vec!["sin(x)*y"; MAX_NODES / 6].join("+");
        let e = Expr::parse(&long).unwrap();
        let z = e.eval_grid(&xs, &ys);
        assert_eq!(z[5 * xs.len() + 7].to_bits(), e.eval(xs[7], ys[5]).to_bits());
    }

    fn v(s: &str, x: f64, y: f64) -> f64 {
        Expr::parse(s).unwrap().eval(x, y)
    }

    #[test]
    fn arithmetic_precedence_and_functions() {
        assert_eq!(v("1/2", 0.0, 0.0), 0.5);
        assert_eq!(v("2+3*4", 0.0, 0.0), 14.0);
        assert_eq!(v("(2+3)*4", 0.0, 0.0), 20.0);
        assert_eq!(v("-x^2", 3.0, 0.0), -9.0);
        assert_eq!(v("2^3^2", 0.0, 0.0), 512.0);
        assert_eq!(v("2^-1", 0.0, 0.0), 0.5);
        // A square is a product; every other power goes through powf.
        for x in [0.1, -3.7, 1e200, -0.0, f64::INFINITY, f64::NEG_INFINITY, 1.0 / 3.0] {
            assert_eq!(v("x^2", x, 0.0).to_bits(), (x * x).to_bits(), "{x}");
            assert_eq!(v("x^2", x, 0.0), x.powf(2.0), "{x}");
            assert_eq!(v("x^2.5", x.abs(), 0.0).to_bits(), x.abs().powf(2.5).to_bits(), "{x}");
        }
        assert!(v("x^2", f64::NAN, 0.0).is_nan());
        assert_eq!(v("x^2^3", 2.0, 0.0), 256.0);
        assert_eq!(v("x - y - 1", 5.0, 2.0), 2.0);
        assert_eq!(v("1e3 + 2E-1", 0.0, 0.0), 1000.2);
        assert!((v("2*e", 0.0, 0.0) - 2.0 * std::f64::consts::E).abs() < 1e-15);
        assert!((v("sin(pi/2) + cos(0) + ln(e) + log10(100)", 0.0, 0.0) - 5.0).abs() < 1e-12);
        assert_eq!(v("min(x, y) + max(x, y) + abs(-2) + floor(2.7) + sqrt(9)", 1.0, 4.0), 12.0);
        assert!((v("exp(-x^2 - y^2)", 1.0, 1.0) - (-2.0f64).exp()).abs() < 1e-15);
        assert!((v("tan(0.3)", 0.0, 0.0) - 0.3f64.tan()).abs() < 1e-15);
    }

    #[test]
    fn errors_point_at_the_character() {
        let cases: &[(&str, usize, &str)] = &[
            ("sinn(x)", 0, "unknown function"),
            ("x + * y", 4, "unexpected `*`"),
            ("(x + y", 6, "expected `)`"),
            ("x + z", 4, "unknown name `z`"),
            ("sin x", 0, "is a function"),
            ("min(x)", 5, "takes 2"),
            ("x y", 2, "unexpected `y`"),
            ("", 0, "empty"),
            ("x +", 3, "ends too early"),
            ("1..2", 2, "unexpected `.`"),
            ("x # 2", 2, "unexpected `#`"),
        ];
        for &(text, at, msg) in cases {
            let e = Expr::parse(text).unwrap_err();
            assert_eq!(e.at, at, "{text}: {e}");
            assert!(e.message.contains(msg), "{text}: {e}");
        }
        let shown = Expr::parse("x + * y").unwrap_err().to_string();
        assert!(shown.ends_with("x + * y\n        ^"), "{shown}");
        // Issue #20: a long expression is shown as a window around the fault.
        let long = format!("{}x + * y", " ".repeat(100_000));
        let shown = Expr::parse(&long).unwrap_err().to_string();
        assert!(
            shown.len() < 200 && shown.ends_with("...                          x + * y\n                                     ^"),
            "{shown}"
        );
    }

    #[test]
    fn nan_and_infinity_are_values_not_errors() {
        assert!(v("ln(x)", -1.0, 0.0).is_nan());
        assert!(v("1/x", 0.0, 0.0).is_infinite());
    }

    #[test]
    fn hostile_input_is_bounded() {
        let deep = "(".repeat(100) + "x" + &")".repeat(100);
        assert_eq!(v(&deep, 2.0, 0.0), 2.0);
        let long = vec!["x"; MAX_NODES + 5].join("+");
        assert!(Expr::parse(&long).is_err());
        assert!(Expr::parse(&("(".repeat(100_000) + "x")).unwrap_err().message.contains("deeply"));
        assert!(Expr::parse(&("-".repeat(100_000) + "x")).unwrap_err().message.contains("deeply"));
    }
}
