//! The parser: [`Token`]s to the syntax tree of one `scene { ... }`, every node with its place.
//!
//! The parser knows which keyword belongs in which block, so a misplaced item (a `radius` in a
//! `plane`, a `light` in a `union`) or an unknown keyword is an error at its own position. It
//! evaluates nothing: variables, loops and references are left to [`super::expand`]. Nesting
//! (blocks, parentheses, operators) is limited, so hostile input ends in an error, never in a
//! stack overflow.

use super::lexer::{Token, TokenKind};
use super::{FartError, Pos};
use strahl_core::geom::solid::CsgOp;

/// The deepest nesting of blocks and parentheses the parser accepts.
pub const MAX_NESTING: u32 = 128;

/// The most levels an expression's tree may have (operators applied to operators).
pub const MAX_EXPR_HEIGHT: u32 = 256;

// The word tables below repeat words on purpose: KEYWORDS lists every reserved word once, the
// `*_KEYS` tables say which of them each block takes.

/// The words that cannot name a variable or a definition.
pub const KEYWORDS: &[&str] = &[
    "scene",
    "options",
    "camera",
    "light",
    "material",
    "sphere",
    "plane",
    "box",
    "cyl",
    "mesh",
    "union",
    "intersect",
    "subtract",
    "translate",
    "rotate",
    "scale",
    "radius",
    "size",
    "position",
    "file",
    "vertices",
    "triangles",
    "let",
    "define",
    "for",
    "in",
    "step",
    "if",
    "else",
    "on",
    "off",
    "pi",
    "width",
    "height",
    "multisample",
    "max_depth",
    "ambient_occlusion",
    "background",
    "look_at",
    "up",
    "vfov",
    "color",
    "intensity",
    "shadows",
    "ambient",
    "diffuse",
    "specular",
    "shininess",
    "reflectance",
    "transparency",
    "ior",
];

/// The functions an expression may call, with their number of arguments.
pub const FUNCTIONS: &[(&str, usize)] = &[
    ("sin", 1),
    ("cos", 1),
    ("tan", 1),
    ("sqrt", 1),
    ("abs", 1),
    ("floor", 1),
    ("ceil", 1),
    ("min", 2),
    ("max", 2),
    ("pow", 2),
];

const OPTIONS_KEYS: &[&str] = &[
    "width",
    "height",
    "multisample",
    "max_depth",
    "ambient_occlusion",
    "background",
];
const CAMERA_KEYS: &[&str] = &["position", "look_at", "up", "vfov"];
const LIGHT_KEYS: &[&str] = &["position", "color", "intensity", "shadows"];
const MATERIAL_KEYS: &[&str] = &[
    "color",
    "ambient",
    "diffuse",
    "specular",
    "shininess",
    "reflectance",
    "transparency",
    "ior",
];
const SHAPE_ITEM_KEYS: &[&str] = &[
    "radius",
    "size",
    "position",
    "file",
    "vertices",
    "triangles",
    "translate",
    "rotate",
    "scale",
    "material",
];

/// A name as written, with its place.
#[derive(Clone, Debug, PartialEq)]
pub struct Name {
    /// The name.
    pub text: String,
    /// Its first character.
    pub pos: Pos,
}

/// The whole file: `scene { body }`.
#[derive(Clone, Debug, PartialEq)]
pub struct SceneAst {
    /// The `scene` keyword.
    pub pos: Pos,
    /// The statements between the braces.
    pub body: Vec<Stmt>,
    /// The closing `}`.
    pub end: Pos,
}

/// A statement of the scene or of a CSG body.
#[derive(Clone, Debug, PartialEq)]
pub enum Stmt {
    /// `let NAME = EXPR`
    Let {
        /// The variable.
        name: Name,
        /// Its new value.
        value: Expr,
    },
    /// `define NAME material {...}` or `define NAME SHAPE`
    Define {
        /// The defined name.
        name: Name,
        /// What it stands for.
        item: Definable,
    },
    /// `for NAME in A .. B [step S] { ... }`
    For(ForLoop),
    /// `if E { ... } else if E { ... } else { ... }`
    If(IfChain),
    /// `options { ... }`
    Options(SettingsBlock),
    /// `camera { ... }`
    Camera(SettingsBlock),
    /// `light { ... }`
    Light(SettingsBlock),
    /// A shape, CSG node or use of a defined shape.
    Shape(ShapeAst),
}

/// What a `define` names.
#[derive(Clone, Debug, PartialEq)]
pub enum Definable {
    /// A material.
    Material(MaterialAst),
    /// A shape or CSG node.
    Shape(ShapeAst),
}

/// A counted loop.
#[derive(Clone, Debug, PartialEq)]
pub struct ForLoop {
    /// The `for` keyword.
    pub pos: Pos,
    /// The loop variable.
    pub var: Name,
    /// First value (inclusive).
    pub start: Expr,
    /// Bound (exclusive).
    pub end: Expr,
    /// Step, 1 if not written.
    pub step: Option<Expr>,
    /// The statements run for each value.
    pub body: Vec<Stmt>,
}

/// An `if` with its `else if` branches and optional `else`.
#[derive(Clone, Debug, PartialEq)]
pub struct IfChain {
    /// Conditions and their bodies, in order.
    pub branches: Vec<(Expr, Vec<Stmt>)>,
    /// The `else` body.
    pub otherwise: Option<Vec<Stmt>>,
}

/// A block of `key value` settings: `options`, `camera`, `light` or `material`.
#[derive(Clone, Debug, PartialEq)]
pub struct SettingsBlock {
    /// The block's keyword.
    pub pos: Pos,
    /// The settings in the order written.
    pub items: Vec<Setting>,
}

/// One `key value` of a [`SettingsBlock`].
#[derive(Clone, Debug, PartialEq)]
pub struct Setting {
    /// The key (one the block allows).
    pub key: Name,
    /// Its value.
    pub value: SettingValue,
}

/// The value of a setting.
#[derive(Clone, Debug, PartialEq)]
pub enum SettingValue {
    /// A number or vector expression.
    Expr(Expr),
    /// `on` (true) or `off` (false).
    Switch(bool),
}

/// A material: written out, or the name of a defined one.
#[derive(Clone, Debug, PartialEq)]
pub enum MaterialAst {
    /// `material { ... }`
    Block(SettingsBlock),
    /// `material NAME`
    Named(Name),
}

/// Which kind of shape a [`ShapeAst`] is.
#[derive(Clone, Debug, PartialEq)]
pub enum ShapeKind {
    /// `sphere`
    Sphere,
    /// `plane`
    Plane,
    /// `box`
    Box,
    /// `cyl`
    Cyl,
    /// `mesh`
    Mesh,
    /// `union`, `intersect` or `subtract`
    Csg(CsgOp),
    /// A use of a name given by `define`.
    Defined(String),
}

impl ShapeKind {
    /// The keyword (or defined name) as written.
    pub fn word(&self) -> &str {
        match self {
            ShapeKind::Sphere => "sphere",
            ShapeKind::Plane => "plane",
            ShapeKind::Box => "box",
            ShapeKind::Cyl => "cyl",
            ShapeKind::Mesh => "mesh",
            ShapeKind::Csg(CsgOp::Union) => "union",
            ShapeKind::Csg(CsgOp::Intersect) => "intersect",
            ShapeKind::Csg(CsgOp::Subtract) => "subtract",
            ShapeKind::Defined(name) => name,
        }
    }

    fn items(&self) -> &'static [&'static str] {
        match self {
            ShapeKind::Sphere => &["radius", "translate", "rotate", "scale", "material"],
            ShapeKind::Plane => &["position", "translate", "rotate", "scale", "material"],
            ShapeKind::Box | ShapeKind::Cyl => {
                &["size", "translate", "rotate", "scale", "material"]
            }
            ShapeKind::Mesh => &[
                "file",
                "vertices",
                "triangles",
                "translate",
                "rotate",
                "scale",
                "material",
            ],
            ShapeKind::Csg(_) => &["translate", "rotate", "scale", "material"],
            // A use of a defined shape takes every shape item here; the expander says which
            // ones it cannot change once it knows what the name stands for.
            ShapeKind::Defined(_) => SHAPE_ITEM_KEYS,
        }
    }
}

/// A shape, CSG node or use of a defined shape, with its items.
#[derive(Clone, Debug, PartialEq)]
pub struct ShapeAst {
    /// Which shape.
    pub kind: ShapeKind,
    /// Its keyword (or name).
    pub pos: Pos,
    /// Parameters, transforms and material, in the order written.
    pub items: Vec<ShapeItem>,
    /// A CSG node's statements (its operands); empty for other shapes.
    pub body: Vec<Stmt>,
    /// The closing `}`.
    pub end: Pos,
}

/// A transform step.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TransformKind {
    /// `translate <v>`
    Translate,
    /// `rotate <ax, ay, az>` (degrees, X then Y then Z)
    Rotate,
    /// `scale <v>` or `scale s`
    Scale,
}

/// One item in a shape's braces, with the place of its keyword.
#[derive(Clone, Debug, PartialEq)]
pub struct ShapeItem {
    /// The keyword.
    pub pos: Pos,
    /// What it says.
    pub item: ShapeItemKind,
}

/// The items a shape may hold (which ones depends on the shape).
#[derive(Clone, Debug, PartialEq)]
pub enum ShapeItemKind {
    /// `radius r` (sphere)
    Radius(Expr),
    /// `size ...` (box, cyl)
    Size(Expr),
    /// `position <n>, d` (plane)
    PlanePosition {
        /// The normal.
        normal: Expr,
        /// The plane's distance: `n·p = d`.
        d: Expr,
    },
    /// `translate`, `rotate` or `scale`
    Transform(TransformKind, Expr),
    /// `material ...`
    Material(MaterialAst),
    /// `file "name.obj"` (mesh)
    File(String),
    /// `vertices { <v> ... }` (mesh)
    Vertices(Vec<Expr>),
    /// `triangles { <i, j, k> ... }` (mesh)
    Triangles(Vec<Expr>),
}

/// An expression, with the place of its first character.
#[derive(Clone, Debug, PartialEq)]
pub struct Expr {
    /// Where the expression starts.
    pub pos: Pos,
    /// Its form.
    pub kind: ExprKind,
    /// Levels of the tree below and including this node.
    pub height: u32,
}

/// The forms of an [`Expr`].
#[derive(Clone, Debug, PartialEq)]
pub enum ExprKind {
    /// A number literal.
    Number(f64),
    /// A variable (or the constant `pi`).
    Var(String),
    /// `<x, y, z>`
    Vector(Box<[Expr; 3]>),
    /// `-e` or `!e`
    Unary(UnaryOp, Box<Expr>),
    /// `a op b`, with the place of the operator.
    Binary(BinaryOp, Pos, Box<Expr>, Box<Expr>),
    /// `f(args)`
    Call(String, Vec<Expr>),
}

/// Prefix operators.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum UnaryOp {
    /// `-`
    Neg,
    /// `!`
    Not,
}

/// Infix operators.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BinaryOp {
    /// `+`
    Add,
    /// `-`
    Sub,
    /// `*`
    Mul,
    /// `/`
    Div,
    /// `%`
    Rem,
    /// `<`
    Lt,
    /// `<=`
    Le,
    /// `>`
    Gt,
    /// `>=`
    Ge,
    /// `==`
    Eq,
    /// `!=`
    Ne,
    /// `&&`
    And,
    /// `||`
    Or,
}

impl BinaryOp {
    /// The operator as written.
    pub fn symbol(self) -> &'static str {
        match self {
            BinaryOp::Add => "+",
            BinaryOp::Sub => "-",
            BinaryOp::Mul => "*",
            BinaryOp::Div => "/",
            BinaryOp::Rem => "%",
            BinaryOp::Lt => "<",
            BinaryOp::Le => "<=",
            BinaryOp::Gt => ">",
            BinaryOp::Ge => ">=",
            BinaryOp::Eq => "==",
            BinaryOp::Ne => "!=",
            BinaryOp::And => "&&",
            BinaryOp::Or => "||",
        }
    }
}

/// Parses the tokens of a whole file (ending in [`TokenKind::Eof`]).
///
/// # Errors
/// A [`FartError`] at the first token that does not fit the grammar.
pub fn parse(tokens: &[Token]) -> Result<SceneAst, FartError> {
    let mut p = Parser {
        tokens,
        at: 0,
        depth: 0,
    };
    let Some(first) = tokens.first() else {
        return Err(FartError::new(
            Pos { line: 1, column: 1 },
            "expected `scene {` at the start of the file, found nothing",
        ));
    };
    let start = first.clone();
    if start.kind != TokenKind::Ident("scene".to_string()) {
        return Err(FartError::new(
            start.pos,
            format!(
                "expected `scene {{` at the start of the file, found {}",
                start.kind.describe()
            ),
        ));
    }
    p.bump();
    p.expect_open("scene")?;
    let (body, _, end) = p.statements(&Ctx::Scene, "scene", start.pos)?;
    let after = p.peek();
    if after.kind != TokenKind::Eof {
        return Err(FartError::new(
            after.pos,
            format!(
                "expected the end of the file after the scene's closing `}}`, found {}",
                after.kind.describe()
            ),
        ));
    }
    Ok(SceneAst {
        pos: start.pos,
        body,
        end,
    })
}

/// Where a statement list stands, for what it may contain and for messages.
enum Ctx {
    /// The scene's braces (or a `for`/`if` body at scene level).
    Scene,
    /// A CSG node's braces (or a `for`/`if` body in one): the node's keyword, and whether
    /// transforms and a material may be written here (only directly in the node's braces).
    Csg { owner: String, items: bool },
}

impl Ctx {
    fn place(&self) -> String {
        match self {
            Ctx::Scene => "at scene level".to_string(),
            Ctx::Csg { owner, items: true } => format!("in a `{owner}`"),
            Ctx::Csg {
                owner,
                items: false,
            } => format!("in a `for` or `if` inside a `{owner}`"),
        }
    }

    fn expected(&self) -> &'static str {
        match self {
            Ctx::Scene => {
                "a shape, `light`, `camera`, `options`, `let`, `define`, `for`, `if` or `}`"
            }
            Ctx::Csg { items: true, .. } => {
                "a shape, `translate`, `rotate`, `scale`, `material`, `let`, `define`, `for`, `if` or `}`"
            }
            Ctx::Csg { items: false, .. } => "a shape, `let`, `define`, `for`, `if` or `}`",
        }
    }

    fn inner(&self) -> Ctx {
        match self {
            Ctx::Scene => Ctx::Scene,
            Ctx::Csg { owner, .. } => Ctx::Csg {
                owner: owner.clone(),
                items: false,
            },
        }
    }
}

struct Parser<'t> {
    tokens: &'t [Token],
    at: usize,
    depth: u32,
}

fn is_reserved(name: &str) -> bool {
    KEYWORDS.contains(&name) || FUNCTIONS.iter().any(|(f, _)| *f == name)
}

fn list(words: &[&str]) -> String {
    words
        .iter()
        .map(|w| format!("`{w}`"))
        .collect::<Vec<_>>()
        .join(", ")
}

impl<'t> Parser<'t> {
    fn peek(&self) -> &'t Token {
        let last = self.tokens.len().saturating_sub(1);
        &self.tokens[self.at.min(last)]
    }

    fn peek2(&self) -> &'t Token {
        let last = self.tokens.len().saturating_sub(1);
        &self.tokens[(self.at + 1).min(last)]
    }

    fn bump(&mut self) -> &'t Token {
        let t = self.peek();
        if self.at < self.tokens.len() {
            self.at += 1;
        }
        t
    }

    /// Takes the next token if it is `kind`; otherwise the error `expected WHAT, found ...` at
    /// it, WHAT from `what` (made only then).
    fn expect(&mut self, kind: &TokenKind, what: impl FnOnce() -> String) -> Result<(), FartError> {
        let t = self.bump();
        if t.kind != *kind {
            return Err(FartError::new(
                t.pos,
                format!("expected {}, found {}", what(), t.kind.describe()),
            ));
        }
        Ok(())
    }

    fn enter(&mut self, pos: Pos) -> Result<(), FartError> {
        self.depth += 1;
        if self.depth > MAX_NESTING {
            return Err(FartError::new(
                pos,
                format!("nested more than {MAX_NESTING} levels deep"),
            ));
        }
        Ok(())
    }

    fn leave(&mut self) {
        self.depth = self.depth.saturating_sub(1);
    }

    fn expect_open(&mut self, after: &str) -> Result<Pos, FartError> {
        let t = self.bump();
        if t.kind == TokenKind::LBrace {
            Ok(t.pos)
        } else {
            Err(FartError::new(
                t.pos,
                format!("expected `{{` after `{after}`, found {}", t.kind.describe()),
            ))
        }
    }

    fn unclosed(owner: &str, open: Pos, found: &Token) -> FartError {
        FartError::new(
            found.pos,
            format!(
                "expected `}}` to close the `{owner}` opened at {}:{}, found {}",
                open.line,
                open.column,
                found.kind.describe()
            ),
        )
    }

    /// A variable's or definition's name after `let`, `define` or `for`.
    fn new_name(&mut self, after: &str) -> Result<Name, FartError> {
        let t = self.bump();
        match &t.kind {
            TokenKind::Ident(s) if is_reserved(s) => Err(FartError::new(
                t.pos,
                format!("expected a name after `{after}`, found the keyword `{s}`, which cannot be a name"),
            )),
            TokenKind::Ident(s) => Ok(Name {
                text: s.clone(),
                pos: t.pos,
            }),
            other => Err(FartError::new(
                t.pos,
                format!("expected a name after `{after}`, found {}", other.describe()),
            )),
        }
    }

    /// Statements up to and including the closing `}`; returns them, the CSG items among them
    /// and the place of the `}`.
    fn statements(
        &mut self,
        ctx: &Ctx,
        owner: &str,
        open: Pos,
    ) -> Result<(Vec<Stmt>, Vec<ShapeItem>, Pos), FartError> {
        self.enter(open)?;
        let mut stmts = Vec::new();
        let mut items = Vec::new();
        loop {
            let t = self.peek();
            let word = match &t.kind {
                TokenKind::RBrace => {
                    self.bump();
                    self.leave();
                    return Ok((stmts, items, t.pos));
                }
                TokenKind::Eof => return Err(Self::unclosed(owner, open, t)),
                TokenKind::Ident(w) => w.as_str(),
                other => {
                    return Err(FartError::new(
                        t.pos,
                        format!(
                            "expected {} {}, found {}",
                            ctx.expected(),
                            ctx.place(),
                            other.describe()
                        ),
                    ))
                }
            };
            match word {
                "let" => stmts.push(self.let_stmt()?),
                "define" => stmts.push(self.define()?),
                "for" => stmts.push(self.for_loop(ctx)?),
                "if" => stmts.push(self.if_chain(ctx)?),
                "options" | "camera" | "light" => stmts.push(self.scene_block(ctx, word, t.pos)?),
                "sphere" | "plane" | "box" | "cyl" | "mesh" | "union" | "intersect"
                | "subtract" => stmts.push(Stmt::Shape(self.shape()?)),
                "translate" | "rotate" | "scale" | "material"
                    if matches!(ctx, Ctx::Csg { items: true, .. }) =>
                {
                    self.bump();
                    items.push(self.shape_item(word, t.pos)?);
                }
                w if is_reserved(w) => return Err(Self::misplaced(ctx, w, t.pos)),
                w => {
                    if self.peek2().kind == TokenKind::LBrace {
                        stmts.push(Stmt::Shape(self.shape()?));
                    } else {
                        return Err(Self::unknown(ctx, w, t.pos));
                    }
                }
            }
        }
    }

    /// An `options`, `camera` or `light` block (`word`, at `pos`), which only the scene level
    /// may hold.
    fn scene_block(&mut self, ctx: &Ctx, word: &str, pos: Pos) -> Result<Stmt, FartError> {
        if !matches!(ctx, Ctx::Scene) {
            return Err(FartError::new(
                pos,
                format!(
                    "`{word}` does not belong {}; lights, the camera and options are written at scene level",
                    ctx.place()
                ),
            ));
        }
        self.bump();
        let keys = match word {
            "options" => OPTIONS_KEYS,
            "camera" => CAMERA_KEYS,
            _ => LIGHT_KEYS,
        };
        let block = self.settings(word, pos, keys)?;
        Ok(match word {
            "options" => Stmt::Options(block),
            "camera" => Stmt::Camera(block),
            _ => Stmt::Light(block),
        })
    }

    /// The error for the reserved word `w` at `pos` where `ctx` does not take it.
    fn misplaced(ctx: &Ctx, w: &str, pos: Pos) -> FartError {
        let hint = match w {
            "translate" | "rotate" | "scale" | "material" => {
                "; write it inside the shape it belongs to"
            }
            "else" => "; `else` follows the `}` of an `if`",
            _ => "",
        };
        FartError::new(pos, format!("`{w}` does not belong {}{hint}", ctx.place()))
    }

    /// The error for the unknown word `w` at `pos`, not followed by a `{` that would make it a
    /// use of a defined shape.
    fn unknown(ctx: &Ctx, w: &str, pos: Pos) -> FartError {
        FartError::new(
            pos,
            format!(
                "unknown keyword `{w}` {}; expected {} (a defined shape is used as `{w} {{ ... }}`)",
                ctx.place(),
                ctx.expected()
            ),
        )
    }

    fn let_stmt(&mut self) -> Result<Stmt, FartError> {
        self.bump();
        let name = self.new_name("let")?;
        self.expect(&TokenKind::Assign, || {
            format!("`=` after `let {}`", name.text)
        })?;
        let what = format!("a number or a vector after `let {} =`", name.text);
        let value = self.expr_expecting(&what)?;
        Ok(Stmt::Let { name, value })
    }

    fn define(&mut self) -> Result<Stmt, FartError> {
        self.bump();
        let name = self.new_name("define")?;
        let t = self.peek();
        let item = match &t.kind {
            TokenKind::Ident(w) if w == "material" => {
                self.bump();
                Definable::Material(self.material(t.pos)?)
            }
            TokenKind::Ident(w) if !is_reserved(w) || shape_word(w).is_some() => {
                Definable::Shape(self.shape()?)
            }
            other => {
                return Err(FartError::new(
                    t.pos,
                    format!(
                        "expected a shape or `material` after `define {}`, found {}",
                        name.text,
                        other.describe()
                    ),
                ))
            }
        };
        Ok(Stmt::Define { name, item })
    }

    fn for_loop(&mut self, ctx: &Ctx) -> Result<Stmt, FartError> {
        let pos = self.bump().pos;
        let var = self.new_name("for")?;
        self.expect(&TokenKind::Ident("in".to_string()), || {
            format!("`in` after `for {}`", var.text)
        })?;
        let start = self.expr_expecting("the first number of the range after `in`")?;
        self.expect(&TokenKind::DotDot, || {
            format!("`..` in the range of `for {}`", var.text)
        })?;
        let end = self.expr_expecting("the end of the range after `..`")?;
        let step = if self.peek().kind == TokenKind::Ident("step".to_string()) {
            self.bump();
            Some(self.expr_expecting("a number after `step`")?)
        } else {
            None
        };
        self.expect(&TokenKind::LBrace, || {
            format!("`{{` or `step` after the range of `for {}`", var.text)
        })?;
        let (body, _, _) = self.statements(&ctx.inner(), "for", pos)?;
        Ok(Stmt::For(ForLoop {
            pos,
            var,
            start,
            end,
            step,
            body,
        }))
    }

    fn if_chain(&mut self, ctx: &Ctx) -> Result<Stmt, FartError> {
        let mut branches = Vec::new();
        let mut otherwise = None;
        let mut pos = self.bump().pos;
        loop {
            let cond = self.expr_expecting("a condition after `if`")?;
            self.expect(&TokenKind::LBrace, || {
                "`{` after the condition of `if`".to_string()
            })?;
            let (body, _, _) = self.statements(&ctx.inner(), "if", pos)?;
            branches.push((cond, body));
            if self.peek().kind != TokenKind::Ident("else".to_string()) {
                break;
            }
            let else_pos = self.bump().pos;
            let t = self.peek();
            match &t.kind {
                TokenKind::Ident(w) if w == "if" => {
                    pos = self.bump().pos;
                }
                TokenKind::LBrace => {
                    self.bump();
                    let (body, _, _) = self.statements(&ctx.inner(), "else", else_pos)?;
                    otherwise = Some(body);
                    break;
                }
                other => {
                    return Err(FartError::new(
                        t.pos,
                        format!(
                            "expected `{{` or `if` after `else`, found {}",
                            other.describe()
                        ),
                    ))
                }
            }
        }
        Ok(Stmt::If(IfChain {
            branches,
            otherwise,
        }))
    }

    /// `{ key value ... }` after the keyword `owner` at `pos`.
    fn settings(
        &mut self,
        owner: &str,
        pos: Pos,
        keys: &[&str],
    ) -> Result<SettingsBlock, FartError> {
        self.expect_open(owner)?;
        let mut items = Vec::new();
        loop {
            let t = self.bump();
            let key = match &t.kind {
                TokenKind::RBrace => return Ok(SettingsBlock { pos, items }),
                TokenKind::Eof => return Err(Self::unclosed(owner, pos, t)),
                TokenKind::Ident(k) if keys.contains(&k.as_str()) => k.clone(),
                TokenKind::Ident(k) if is_reserved(k) => {
                    return Err(FartError::new(
                        t.pos,
                        format!(
                            "`{k}` does not belong in `{owner}`; expected {} or `}}`",
                            list(keys)
                        ),
                    ))
                }
                TokenKind::Ident(k) => {
                    return Err(FartError::new(
                        t.pos,
                        format!(
                            "unknown keyword `{k}` in `{owner}`; expected {} or `}}`",
                            list(keys)
                        ),
                    ))
                }
                other => {
                    return Err(FartError::new(
                        t.pos,
                        format!(
                            "expected {} or `}}` in `{owner}`, found {}",
                            list(keys),
                            other.describe()
                        ),
                    ))
                }
            };
            let value = if key == "shadows" {
                let v = self.bump();
                match &v.kind {
                    TokenKind::Ident(w) if w == "on" => SettingValue::Switch(true),
                    TokenKind::Ident(w) if w == "off" => SettingValue::Switch(false),
                    other => {
                        return Err(FartError::new(
                            v.pos,
                            format!(
                                "expected `on` or `off` after `shadows`, found {}",
                                other.describe()
                            ),
                        ))
                    }
                }
            } else {
                let what = match key.as_str() {
                    "background" | "position" | "look_at" | "up" | "color" => "a vector",
                    _ => "a number",
                };
                SettingValue::Expr(self.expr_expecting(&format!("{what} after `{key}`"))?)
            };
            items.push(Setting {
                key: Name {
                    text: key,
                    pos: t.pos,
                },
                value,
            });
        }
    }

    /// After `material`: a block or the name of a defined material.
    fn material(&mut self, pos: Pos) -> Result<MaterialAst, FartError> {
        let t = self.peek();
        match &t.kind {
            TokenKind::LBrace => Ok(MaterialAst::Block(self.settings(
                "material",
                pos,
                MATERIAL_KEYS,
            )?)),
            TokenKind::Ident(w) if !is_reserved(w) => {
                self.bump();
                Ok(MaterialAst::Named(Name {
                    text: w.clone(),
                    pos: t.pos,
                }))
            }
            other => Err(FartError::new(
                t.pos,
                format!(
                    "expected `{{` or the name of a defined material after `material`, found {}",
                    other.describe()
                ),
            )),
        }
    }

    /// A shape, CSG node or defined shape's use, starting at its keyword or name.
    fn shape(&mut self) -> Result<ShapeAst, FartError> {
        let t = self.bump();
        let TokenKind::Ident(word) = &t.kind else {
            return Err(FartError::new(
                t.pos,
                format!("expected a shape, found {}", t.kind.describe()),
            ));
        };
        let kind = shape_word(word).unwrap_or_else(|| ShapeKind::Defined(word.clone()));
        self.expect_open(word)?;
        if let ShapeKind::Csg(_) = kind {
            let inner = Ctx::Csg {
                owner: word.clone(),
                items: true,
            };
            let (body, items, end) = self.statements(&inner, word, t.pos)?;
            return Ok(ShapeAst {
                kind,
                pos: t.pos,
                items,
                body,
                end,
            });
        }
        let allowed = kind.items();
        let mut items = Vec::new();
        loop {
            let k = self.bump();
            match &k.kind {
                TokenKind::RBrace => {
                    return Ok(ShapeAst {
                        kind,
                        pos: t.pos,
                        items,
                        body: Vec::new(),
                        end: k.pos,
                    })
                }
                TokenKind::Eof => return Err(Self::unclosed(word, t.pos, k)),
                TokenKind::Ident(w) if allowed.contains(&w.as_str()) => {
                    items.push(self.shape_item(w, k.pos)?);
                }
                TokenKind::Ident(w) => {
                    let what = if SHAPE_ITEM_KEYS.contains(&w.as_str()) || is_reserved(w) {
                        format!("`{w}` does not belong in a `{word}`")
                    } else {
                        format!("unknown keyword `{w}` in a `{word}`")
                    };
                    return Err(FartError::new(
                        k.pos,
                        format!("{what}; expected {} or `}}`", list(allowed)),
                    ));
                }
                other => {
                    return Err(FartError::new(
                        k.pos,
                        format!(
                            "expected {} or `}}` in a `{word}`, found {}",
                            list(allowed),
                            other.describe()
                        ),
                    ))
                }
            }
        }
    }

    /// The value of the shape item `word` (already taken) at `pos`.
    fn shape_item(&mut self, word: &str, pos: Pos) -> Result<ShapeItem, FartError> {
        let item = match word {
            "radius" => ShapeItemKind::Radius(self.expr_expecting("a number after `radius`")?),
            "size" => ShapeItemKind::Size(self.expr_expecting("a vector after `size`")?),
            "position" => {
                let normal = self.expr_expecting("the plane's normal vector after `position`")?;
                self.expect(&TokenKind::Comma, || {
                    "`,` and the plane's distance after its normal".to_string()
                })?;
                let d = self.expr_expecting("the plane's distance after `,`")?;
                ShapeItemKind::PlanePosition { normal, d }
            }
            "translate" => ShapeItemKind::Transform(
                TransformKind::Translate,
                self.expr_expecting("a vector after `translate`")?,
            ),
            "rotate" => ShapeItemKind::Transform(
                TransformKind::Rotate,
                self.expr_expecting("a vector of angles after `rotate`")?,
            ),
            "scale" => ShapeItemKind::Transform(
                TransformKind::Scale,
                self.expr_expecting("a number or a vector after `scale`")?,
            ),
            "material" => ShapeItemKind::Material(self.material(pos)?),
            "file" => {
                let t = self.bump();
                match &t.kind {
                    TokenKind::Str(s) => ShapeItemKind::File(s.clone()),
                    other => {
                        return Err(FartError::new(
                            t.pos,
                            format!(
                                "expected a file name in double quotes after `file`, found {}",
                                other.describe()
                            ),
                        ))
                    }
                }
            }
            "vertices" | "triangles" => self.mesh_list(word)?,
            other => {
                return Err(FartError::new(
                    pos,
                    format!("`{other}` does not belong here"),
                ))
            }
        };
        Ok(ShapeItem { pos, item })
    }

    /// The `{ ... }` list after `vertices` or `triangles` (`word`).
    fn mesh_list(&mut self, word: &str) -> Result<ShapeItemKind, FartError> {
        let open = self.expect_open(word)?;
        let mut list = Vec::new();
        loop {
            let t = self.peek();
            match t.kind {
                TokenKind::RBrace => {
                    self.bump();
                    break;
                }
                TokenKind::Eof => return Err(Self::unclosed(word, open, t)),
                _ => {
                    let what = if word == "vertices" {
                        "a vector `<x, y, z>` or `}` in `vertices`"
                    } else {
                        "three point indices `<i, j, k>` or `}` in `triangles`"
                    };
                    list.push(self.expr_with(what, true)?);
                }
            }
        }
        Ok(if word == "vertices" {
            ShapeItemKind::Vertices(list)
        } else {
            ShapeItemKind::Triangles(list)
        })
    }

    // ---- expressions ----

    fn can_start_expr(kind: &TokenKind) -> bool {
        match kind {
            TokenKind::Number(_)
            | TokenKind::LParen
            | TokenKind::Less
            | TokenKind::Minus
            | TokenKind::Not => true,
            TokenKind::Ident(w) => !KEYWORDS.contains(&w.as_str()) || w == "pi",
            _ => false,
        }
    }

    /// An expression where `what` is expected (the message if none starts here).
    fn expr_expecting(&mut self, what: &str) -> Result<Expr, FartError> {
        self.expr_with(what, false)
    }

    fn expr_with(&mut self, what: &str, no_compare: bool) -> Result<Expr, FartError> {
        let t = self.peek();
        if !Self::can_start_expr(&t.kind) {
            return Err(FartError::new(
                t.pos,
                format!("expected {what}, found {}", t.kind.describe()),
            ));
        }
        self.or_expr(no_compare)
    }

    fn binary(op: BinaryOp, op_pos: Pos, a: Expr, b: Expr) -> Result<Expr, FartError> {
        let height = 1 + a.height.max(b.height);
        if height > MAX_EXPR_HEIGHT {
            return Err(FartError::new(
                op_pos,
                format!("this expression has more than {MAX_EXPR_HEIGHT} levels of operators"),
            ));
        }
        Ok(Expr {
            pos: a.pos,
            kind: ExprKind::Binary(op, op_pos, Box::new(a), Box::new(b)),
            height,
        })
    }

    fn or_expr(&mut self, nc: bool) -> Result<Expr, FartError> {
        self.left_assoc(nc, Self::and_expr, |k| {
            (*k == TokenKind::OrOr).then_some(BinaryOp::Or)
        })
    }

    fn and_expr(&mut self, nc: bool) -> Result<Expr, FartError> {
        self.left_assoc(nc, Self::cmp_expr, |k| {
            (*k == TokenKind::AndAnd).then_some(BinaryOp::And)
        })
    }

    /// Comparisons, unless `nc` (inside `< >`, where `<` and `>` close the vector).
    fn cmp_expr(&mut self, nc: bool) -> Result<Expr, FartError> {
        if nc {
            return self.add_expr(nc);
        }
        self.left_assoc(nc, Self::add_expr, |k| match k {
            TokenKind::Less => Some(BinaryOp::Lt),
            TokenKind::LessEq => Some(BinaryOp::Le),
            TokenKind::Greater => Some(BinaryOp::Gt),
            TokenKind::GreaterEq => Some(BinaryOp::Ge),
            TokenKind::EqEq => Some(BinaryOp::Eq),
            TokenKind::NotEq => Some(BinaryOp::Ne),
            _ => None,
        })
    }

    fn add_expr(&mut self, nc: bool) -> Result<Expr, FartError> {
        self.left_assoc(nc, Self::mul_expr, |k| match k {
            TokenKind::Plus => Some(BinaryOp::Add),
            TokenKind::Minus => Some(BinaryOp::Sub),
            _ => None,
        })
    }

    fn mul_expr(&mut self, nc: bool) -> Result<Expr, FartError> {
        self.left_assoc(nc, Self::unary, |k| match k {
            TokenKind::Star => Some(BinaryOp::Mul),
            TokenKind::Slash => Some(BinaryOp::Div),
            TokenKind::Percent => Some(BinaryOp::Rem),
            _ => None,
        })
    }

    /// One level of left-associative operators: operands parsed by `next`, joined by the
    /// operators `op` picks from the next token, as long as it picks one.
    fn left_assoc(
        &mut self,
        nc: bool,
        next: fn(&mut Self, bool) -> Result<Expr, FartError>,
        op: fn(&TokenKind) -> Option<BinaryOp>,
    ) -> Result<Expr, FartError> {
        let mut a = next(self, nc)?;
        while let Some(op) = op(&self.peek().kind) {
            let pos = self.bump().pos;
            let b = self.operand(op.symbol(), nc, next)?;
            a = Self::binary(op, pos, a, b)?;
        }
        Ok(a)
    }

    /// The right operand of `symbol`, parsed by `next`.
    fn operand(
        &mut self,
        symbol: &str,
        nc: bool,
        next: fn(&mut Self, bool) -> Result<Expr, FartError>,
    ) -> Result<Expr, FartError> {
        let t = self.peek();
        if !Self::can_start_expr(&t.kind) {
            return Err(FartError::new(
                t.pos,
                format!(
                    "expected a number or a vector after `{symbol}`, found {}",
                    t.kind.describe()
                ),
            ));
        }
        next(self, nc)
    }

    fn unary(&mut self, nc: bool) -> Result<Expr, FartError> {
        let t = self.peek();
        let op = match t.kind {
            TokenKind::Minus => UnaryOp::Neg,
            TokenKind::Not => UnaryOp::Not,
            _ => return self.primary(),
        };
        self.bump();
        self.enter(t.pos)?;
        let symbol = if op == UnaryOp::Neg { "-" } else { "!" };
        let inner = self.operand(symbol, nc, Self::unary)?;
        self.leave();
        let height = inner.height + 1;
        if height > MAX_EXPR_HEIGHT {
            return Err(FartError::new(
                t.pos,
                format!("this expression has more than {MAX_EXPR_HEIGHT} levels of operators"),
            ));
        }
        Ok(Expr {
            pos: t.pos,
            kind: ExprKind::Unary(op, Box::new(inner)),
            height,
        })
    }

    fn primary(&mut self) -> Result<Expr, FartError> {
        let t = self.bump();
        let leaf = |kind| Expr {
            pos: t.pos,
            kind,
            height: 1,
        };
        match &t.kind {
            TokenKind::Number(v) => Ok(leaf(ExprKind::Number(*v))),
            TokenKind::Ident(name) => {
                if self.peek().kind != TokenKind::LParen {
                    return Ok(leaf(ExprKind::Var(name.clone())));
                }
                self.call(name, t.pos)
            }
            TokenKind::LParen => {
                self.enter(t.pos)?;
                let mut inner = self.expr_expecting("an expression after `(`")?;
                self.expect(&TokenKind::RParen, || {
                    format!("`)` to close the `(` at {}:{}", t.pos.line, t.pos.column)
                })?;
                self.leave();
                inner.pos = t.pos;
                Ok(inner)
            }
            TokenKind::Less => {
                self.enter(t.pos)?;
                let x = self.expr_with("the x component of a vector after `<`", true)?;
                self.vector_sep(t.pos, ",", "y")?;
                let y = self.expr_with("the y component of the vector", true)?;
                self.vector_sep(t.pos, ",", "z")?;
                let z = self.expr_with("the z component of the vector", true)?;
                self.vector_sep(t.pos, ">", "")?;
                self.leave();
                let height = 1 + x.height.max(y.height).max(z.height);
                Ok(Expr {
                    pos: t.pos,
                    kind: ExprKind::Vector(Box::new([x, y, z])),
                    height,
                })
            }
            other => Err(FartError::new(
                t.pos,
                format!("expected a number or a vector, found {}", other.describe()),
            )),
        }
    }

    /// A call of the function `name` written at `pos`, after its name: the arguments in
    /// parentheses.
    fn call(&mut self, name: &str, pos: Pos) -> Result<Expr, FartError> {
        let open = self.bump().pos;
        self.enter(open)?;
        let mut args = Vec::new();
        if self.peek().kind == TokenKind::RParen {
            self.bump();
        } else {
            loop {
                args.push(self.expr_expecting(&format!("an argument of `{name}`"))?);
                let sep = self.bump();
                match sep.kind {
                    TokenKind::Comma => {}
                    TokenKind::RParen => break,
                    _ => {
                        return Err(FartError::new(
                            sep.pos,
                            format!(
                                "expected `,` or `)` after an argument of `{name}`, found {}",
                                sep.kind.describe()
                            ),
                        ))
                    }
                }
            }
        }
        self.leave();
        let height = 1 + args.iter().map(|a| a.height).max().unwrap_or(0);
        Ok(Expr {
            pos,
            kind: ExprKind::Call(name.to_string(), args),
            height,
        })
    }

    fn vector_sep(&mut self, open: Pos, sep: &str, next: &str) -> Result<(), FartError> {
        let t = self.bump();
        let ok = match sep {
            "," => t.kind == TokenKind::Comma,
            _ => t.kind == TokenKind::Greater,
        };
        if ok {
            return Ok(());
        }
        let what = if sep == "," {
            format!("`,` and the {next} component")
        } else {
            "`>` to close the vector".to_string()
        };
        let hint = match (&t.kind, sep) {
            (TokenKind::Greater, ",") => " (a vector has three components)",
            (
                TokenKind::Less
                | TokenKind::LessEq
                | TokenKind::Greater
                | TokenKind::GreaterEq
                | TokenKind::EqEq
                | TokenKind::NotEq,
                _,
            ) => " (a comparison inside `< >` needs parentheses)",
            _ => "",
        };
        Err(FartError::new(
            t.pos,
            format!(
                "expected {what} of the vector opened at {}:{}, found {}{hint}",
                open.line,
                open.column,
                t.kind.describe()
            ),
        ))
    }
}

/// The shape keyword `w` names, if any.
fn shape_word(w: &str) -> Option<ShapeKind> {
    Some(match w {
        "sphere" => ShapeKind::Sphere,
        "plane" => ShapeKind::Plane,
        "box" => ShapeKind::Box,
        "cyl" => ShapeKind::Cyl,
        "mesh" => ShapeKind::Mesh,
        "union" => ShapeKind::Csg(CsgOp::Union),
        "intersect" => ShapeKind::Csg(CsgOp::Intersect),
        "subtract" => ShapeKind::Csg(CsgOp::Subtract),
        _ => return None,
    })
}
