"""The expression grammar: a whitelist of numbers, names, operators and functions -> sympy.

Strings are tokenized and parsed here by recursive descent; nothing is ever handed to
``eval`` or ``sympify``. Grammar (``**`` is right-associative and binds tighter than unary
minus, so ``-x**2`` is ``-(x**2)`` and ``2**-1`` is ``2**(-1)``)::

    sum     := product (("+" | "-") product)*
    product := unary (("*" | "/") unary)*
    unary   := ("+" | "-") unary | power
    power   := atom ("**" unary)?
    atom    := NUMBER | NAME | NAME "(" sum ("," sum)* ")" | "(" sum ")"

Names resolve through a :class:`Scope`; ``pi`` is sympy's pi, ``t`` is time (where the scope
allows it) and ``dot(q)`` is the rate of coordinate ``q``.
"""

from __future__ import annotations

import difflib
import math
import re
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field

import sympy

from ..kinds.terms import TIME, post_order, rate_symbol

MAX_DEPTH = 100
MAX_LENGTH = 100_000
MAX_DIGITS = 1000  # of an integer literal, and roughly of an exact power's result
MAX_FILE_TOKENS = 50_000  # in all the expressions of one file: bounds a file's parse time
MAX_MINMAX_ARGUMENTS = 16  # in all min() and max() calls of one expression (see call())

# name -> (sympy function, least and most number of arguments; None: no upper bound)
FUNCTIONS: dict[str, tuple[Callable[..., sympy.Expr], int, int | None]] = {
    "sin": (sympy.sin, 1, 1),
    "cos": (sympy.cos, 1, 1),
    "tan": (sympy.tan, 1, 1),
    "asin": (sympy.asin, 1, 1),
    "acos": (sympy.acos, 1, 1),
    "atan": (sympy.atan, 1, 1),
    "atan2": (sympy.atan2, 2, 2),
    "sinh": (sympy.sinh, 1, 1),
    "cosh": (sympy.cosh, 1, 1),
    "tanh": (sympy.tanh, 1, 1),
    "exp": (sympy.exp, 1, 1),
    "log": (sympy.log, 1, 1),
    "sqrt": (sympy.sqrt, 1, 1),
    "abs": (sympy.Abs, 1, 1),
    "sign": (sympy.sign, 1, 1),
    "min": (sympy.Min, 2, None),
    "max": (sympy.Max, 2, None),
}

# Words users may not take as names: the grammar's own words and every function name.
RESERVED = frozenset({"t", "pi", "ground", "dot", "ddot", *FUNCTIONS})


class ExprError(ValueError):
    """A bad expression; ``offset`` is the 0-based position in the text where it went wrong."""

    def __init__(self, message: str, offset: int):
        super().__init__(message)
        self.message = message
        self.offset = offset


class Budget:
    """The tokens all the expressions of one file may still use; shared by their scopes.

    Parsing costs up to ~0.1 ms a token (sympy evaluates every function call), so a file
    of many long expressions is refused rather than parsed for minutes."""

    def __init__(self, tokens: int = MAX_FILE_TOKENS):
        self.tokens = tokens

    @property
    def exhausted(self) -> bool:
        return self.tokens < 0

    def charge(self, count: int) -> None:
        self.tokens -= count
        if self.exhausted:
            raise ExprError(f"the file's expressions have more than {MAX_FILE_TOKENS} tokens in "
                            "all; simplify them or use parameters", 0)


@dataclass(frozen=True)
class Scope:
    """What an expression may refer to.

    ``names`` maps each allowed name to its value; ``rates`` are the coordinates ``dot()`` may
    take; ``time`` allows ``t``. ``refused`` maps names that exist elsewhere in the file but are
    not allowed here to the reason, so the message can say so rather than "unknown name".
    """

    names: Mapping[str, sympy.Expr] = field(default_factory=dict)
    rates: frozenset[str] = frozenset()
    time: bool = False
    refused: Mapping[str, str] = field(default_factory=dict)
    where: str = "here"  # e.g. "in body fields (parameters and constants only)"
    budget: Budget | None = None  # the file's, shared by every scope of one file


_TOKEN = re.compile(
    r"\s*(?:(?P<num>(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?)"
    r"|(?P<name>[A-Za-z_][A-Za-z0-9_]*)"
    r"|(?P<op>\*\*|[-+*/(),]))"
)


@dataclass(frozen=True)
class Token:
    kind: str  # "num", "name", "op" or "end"
    text: str
    offset: int


def tokenize(text: str) -> list[Token]:
    """Split ``text`` into tokens, refusing any character outside the grammar."""
    tokens: list[Token] = []
    pos = 0
    while pos < len(text):
        if text[pos:].strip() == "":
            break
        match = _TOKEN.match(text, pos)
        if match is None or match.end() == pos:
            start = len(text) - len(text[pos:].lstrip())
            raise ExprError(_bad_character(text, start), start)
        kind = match.lastgroup or "op"
        tokens.append(Token(kind, match.group(kind), match.start(kind)))
        pos = match.end()
    tokens.append(Token("end", "", len(text)))
    return tokens


def _bad_character(text: str, pos: int) -> str:
    char = text[pos]
    if char == "^":
        return "'^' is not an operator here; write '**' for a power"
    if char in "'\"":
        return "strings are not allowed in expressions"
    if char == ".":
        return "unexpected '.': attribute access is not part of the expression grammar"
    if char in "[]{}":
        return f"unexpected {char!r}: use parentheses '(' and ')' for grouping"
    return f"unexpected character {char!r}"


def parse_expression(text: str, scope: Scope) -> sympy.Expr:
    """Parse ``text`` into a sympy expression over the names ``scope`` allows."""
    if len(text) > MAX_LENGTH:
        raise ExprError(f"expression is too long ({len(text)} characters, at most {MAX_LENGTH})", 0)
    if not text.strip():
        raise ExprError("expected an expression, got an empty string", 0)
    tokens = tokenize(text)
    if scope.budget is not None:
        scope.budget.charge(len(tokens))
    try:
        result = _Parser(tokens, scope).parse()
    except ExprError:
        raise
    except ZeroDivisionError:
        raise ExprError("expression divides by zero", 0) from None
    except (ArithmeticError, ValueError, TypeError) as exc:
        raise ExprError(f"expression cannot be computed ({type(exc).__name__}: {exc})",
                        0) from None
    if result.has(sympy.zoo, sympy.nan, sympy.oo, -sympy.oo):
        raise ExprError(f"expression is not finite (it simplifies to {result})", 0)
    _check_double_range(result)
    return result


def _check_double_range(expr: sympy.Expr) -> None:
    """Refuse an exact number C cannot hold as a double: 10**400, or 1/10**400 (sympy keeps
    them exact; the generated C would otherwise get an infinite or zero literal)."""
    for number in expr.atoms(sympy.Rational):
        if number.is_zero:
            continue
        try:
            value = abs(int(number.p) / int(number.q))
        except OverflowError:
            value = math.inf
        if value == math.inf or value == 0:
            raise ExprError("a number in the expression is out of range (beyond about 1e308 or "
                            "below about 1e-308)", 0)


def tree_depth(expr: sympy.Basic, leaves: Mapping[sympy.Basic, int] | None = None) -> int:
    """The levels of EXPR's tree: a number or a name is 1, f(a, b) one more than its deepest
    argument. A symbol in LEAVES counts as that many levels: a parameter or constant stands for
    its definition, substituted before the later stages. Iterative: any depth is measured."""
    leaves = leaves or {}
    depth: dict[sympy.Basic, int] = {}
    for node in post_order(expr):
        depth[node] = 1 + max((depth[arg] for arg in node.args), default=leaves.get(node, 1) - 1)
    return depth[expr]


def number(text: str, offset: int = 0) -> sympy.Expr:
    """A numeric literal: integers stay exact, decimals and exponents become sympy Floats."""
    if re.fullmatch(r"\d+", text):
        if len(text) > MAX_DIGITS:
            raise ExprError(f"integer literal has more than {MAX_DIGITS} digits", offset)
        return sympy.Integer(int(text))
    value = float(text)  # correctly rounded, and fast even for absurd exponents
    if not math.isfinite(value) or (value == 0 and re.search(r"[1-9]", text.split("e")[0]
                                                             .split("E")[0])):
        raise ExprError(f"number {text} is out of range (beyond about 1e308 or below about "
                        "1e-308)", offset)
    return sympy.Float(value)


class _Parser:
    def __init__(self, tokens: list[Token], scope: Scope):
        self.tokens = tokens
        self.pos = 0
        self.depth = 0
        self.scope = scope
        self.minmax_arguments = 0

    @property
    def token(self) -> Token:
        return self.tokens[self.pos]

    def advance(self) -> Token:
        token = self.tokens[self.pos]
        self.pos += 1
        return token

    def expect(self, op: str) -> None:
        token = self.token
        if token.kind == "op" and token.text == op:
            self.advance()
            return
        raise ExprError(f"expected {op!r}, got {_describe(token)}", token.offset)

    def parse(self) -> sympy.Expr:
        result = self.sum()
        token = self.token
        if token.kind != "end":
            message = f"expected an operator or the end, got {_describe(token)}"
            raise ExprError(message, token.offset)
        return result

    def sum(self) -> sympy.Expr:
        """Terms are added in one step: adding them one by one costs time quadratic in their
        number (sympy rebuilds the growing sum each time)."""
        terms = [self.product()]
        while self.token.kind == "op" and self.token.text in "+-":
            op = self.advance().text
            right = self.product()
            terms.append(right if op == "+" else -right)
        if len(terms) == 1:
            return terms[0]
        return _check_size(sympy.Add(*terms), self.token.offset)

    def product(self) -> sympy.Expr:
        """Numerator and denominator factors are each multiplied in one step (see sum)."""
        factors: tuple[list[sympy.Expr], list[sympy.Expr]] = ([self.unary()], [])
        while self.token.kind == "op" and self.token.text in ("*", "/"):
            op = self.advance().text
            factors[op == "/"].append(_check_size(self.unary(), self.token.offset))
        numerator, denominator = factors
        if len(numerator) == 1 and not denominator:
            return numerator[0]
        result = sympy.Mul(*numerator)
        if denominator:
            result = _check_size(result, self.token.offset) / sympy.Mul(*denominator)
        return _check_size(result, self.token.offset)

    def unary(self) -> sympy.Expr:
        self.depth += 1
        if self.depth > MAX_DEPTH:
            raise ExprError(f"expression is nested too deeply (more than {MAX_DEPTH} levels)",
                            self.token.offset)
        token = self.token
        if token.kind == "op" and token.text in "+-":
            self.advance()
            operand = self.unary()
            result = -operand if token.text == "-" else operand
        else:
            result = self.power()
        self.depth -= 1
        return result

    def power(self) -> sympy.Expr:
        base = self.atom()
        if not (self.token.kind == "op" and self.token.text == "**"):
            return base
        offset = self.advance().offset
        exponent = self.unary()
        _check_power_size(base, exponent, offset)
        return _check_size(base**exponent, offset)

    def atom(self) -> sympy.Expr:
        token = self.advance()
        if token.kind == "num":
            return number(token.text, token.offset)
        if token.kind == "name":
            if self.token.kind == "op" and self.token.text == "(":
                return self.call(token)
            return self.name(token)
        if token.kind == "op" and token.text == "(":
            result = self.sum()
            self.expect(")")
            return result
        raise ExprError(f"expected a number, a name or '(', got {_describe(token)}", token.offset)

    def arguments(self) -> list[sympy.Expr]:
        self.expect("(")
        args = [self.sum()]
        while self.token.kind == "op" and self.token.text == ",":
            self.advance()
            args.append(self.sum())
        self.expect(")")
        return args

    def call(self, name: Token) -> sympy.Expr:
        if name.text == "dot":
            return self.rate(name)
        if name.text not in FUNCTIONS:
            hint = suggest(name.text, list(FUNCTIONS) + ["dot"])
            raise ExprError(f"unknown function {name.text!r}{hint}", name.offset)
        function, least, most = FUNCTIONS[name.text]
        args = self.arguments()
        if len(args) < least or (most is not None and len(args) > most):
            raise ExprError(f"{name.text}() takes {_arity(least, most)}, got {len(args)}",
                            name.offset)
        if most is None:  # sympy compares every pair of min/max arguments: quadratic, slow
            self.minmax_arguments += len(args)
            if self.minmax_arguments > MAX_MINMAX_ARGUMENTS:
                raise ExprError(f"min() and max() take at most {MAX_MINMAX_ARGUMENTS} arguments "
                                "in all in one expression", name.offset)
        return _check_size(function(*args), name.offset)

    def rate(self, name: Token) -> sympy.Expr:
        self.expect("(")
        arg = self.advance()
        if arg.kind != "name":
            raise ExprError(f"dot() takes a coordinate name, got {_describe(arg)}", arg.offset)
        self.expect(")")
        if arg.text not in self.scope.rates:
            if not self.scope.rates:
                raise ExprError(f"dot() is not allowed {self.scope.where}", name.offset)
            hint = suggest(arg.text, sorted(self.scope.rates))
            raise ExprError(f"dot() takes a coordinate, {arg.text!r} is not one{hint}", arg.offset)
        return rate_symbol(arg.text)

    def name(self, token: Token) -> sympy.Expr:
        text = token.text
        if text in self.scope.names:
            return self.scope.names[text]
        if text == "pi":
            return sympy.pi
        if text == "t" and self.scope.time:
            return TIME
        if text == "t":
            raise ExprError(f"time 't' is not allowed {self.scope.where}", token.offset)
        if text in self.scope.refused:
            raise ExprError(self.scope.refused[text], token.offset)
        if text in FUNCTIONS or text == "dot":
            raise ExprError(f"{text} is a function: write {text}(...)", token.offset)
        hint = suggest(text, self.known_names())
        raise ExprError(f"unknown name {text!r}{hint}", token.offset)

    def known_names(self) -> list[str]:
        names = [*self.scope.names, "pi"]
        return names + ["t"] if self.scope.time else names


def _check_power_size(base: sympy.Expr, exponent: sympy.Expr, offset: int) -> None:
    """Refuse exact powers whose result would have an enormous number of digits."""
    if not (isinstance(base, sympy.Rational) and isinstance(exponent, sympy.Rational)):
        return
    if abs(base) in (0, 1):
        return
    size = max(abs(base.p), abs(base.q)).bit_length() * abs(exponent)
    if size > MAX_DIGITS * 4:
        raise ExprError("power is too large to compute exactly; write the base as a decimal",
                        offset)


def _check_size(value: sympy.Expr, offset: int) -> sympy.Expr:
    """Refuse numbers beyond double range or with huge exact digits (they make sympy crawl)."""
    if isinstance(value, sympy.Float) and value.is_finite:
        try:
            magnitude = abs(float(value))
        except (OverflowError, ValueError):
            magnitude = math.inf
        if magnitude == math.inf or (magnitude == 0 and not value.is_zero):
            raise ExprError("a number in the expression is out of range (beyond about 1e308 "
                            "or below about 1e-308)", offset)
    elif isinstance(value, sympy.Rational) and _bits(value) > 4 * MAX_DIGITS:
        raise ExprError(f"an exact number in the expression has more than about {MAX_DIGITS} "
                        "digits", offset)
    return value


def _bits(value: sympy.Rational) -> int:
    return max(abs(value.p), value.q).bit_length()


def _arity(least: int, most: int | None) -> str:
    if most is None:
        return f"{least} or more arguments"
    return f"{least} argument" if least == most == 1 else f"{least} arguments"


def _describe(token: Token) -> str:
    return "the end of the expression" if token.kind == "end" else repr(token.text)


def suggest(word: str, candidates: Iterable[str]) -> str:
    """``" (did you mean 'x'?)"`` for the closest candidate (ignoring case first), or ``""``."""
    candidates = list(candidates)
    same = [c for c in candidates if c.lower() == word.lower()]
    close = same or difflib.get_close_matches(word, candidates, n=1, cutoff=0.5)
    return f" (did you mean {close[0]!r}?)" if close else ""
