"""Read a YAML file into a plain tree of located nodes, with YAML 1.2 core-schema scalars.

PyYAML's composer gives nodes with marks; we convert them ourselves rather than let PyYAML
construct Python values, because its resolver follows YAML 1.1 (``on`` and ``yes`` would be
booleans) and silently keeps the last of duplicate keys.
"""

from __future__ import annotations

import bisect
import math
import re
from dataclasses import dataclass, field

import yaml

from ..errors import InputError, Problem
from .reading import MAX_BYTES

# Bounds on what one file may cost: PyYAML's composer is pure Python (~0.6 s a megabyte to
# scan, ~50 us a node), so these keep any file under a few seconds and ~100 MB. The largest
# example is 2 KB; a 100-link chain is about 25 KB.
MAX_NODES = 100_000  # composed (checked while composing) and after expanding aliases
MAX_NESTING = 64

Scalar = None | bool | int | float | str


@dataclass
class Node:
    """A YAML value with the 1-based line and column where it starts.

    ``value`` is a scalar, a ``list[Node]`` or a ``dict[str, Node]``. For a mapping,
    ``key_lines`` gives the line of each key. ``quoted`` is true for quoted or block scalars.
    """

    value: Scalar | list[Node] | dict[str, Node]
    line: int
    column: int
    quoted: bool = False
    key_lines: dict[str, int] = field(default_factory=dict)

    @property
    def is_map(self) -> bool:
        return isinstance(self.value, dict)

    @property
    def is_list(self) -> bool:
        return isinstance(self.value, list)

    @property
    def is_scalar(self) -> bool:
        return not isinstance(self.value, (dict, list))


_NULL = re.compile(r"null|Null|NULL|~|")
_BOOL = {"true": True, "True": True, "TRUE": True, "false": False, "False": False, "FALSE": False}
_INT = re.compile(r"[-+]?[0-9]+")
_OCT = re.compile(r"0o[0-7]+")
_HEX = re.compile(r"0x[0-9a-fA-F]+")
_FLOAT = re.compile(r"[-+]?(\.[0-9]+|[0-9]+(\.[0-9]*)?)([eE][-+]?[0-9]+)?")
_INF = re.compile(r"[-+]?\.(inf|Inf|INF)")
_NAN = re.compile(r"\.(nan|NaN|NAN)")


def resolve_plain(text: str) -> Scalar:
    """The value of a plain (unquoted) scalar under the YAML 1.2 core schema."""
    if _NULL.fullmatch(text):
        return None
    if text in _BOOL:
        return _BOOL[text]
    if _INT.fullmatch(text) and len(text) <= 1000:
        return int(text)
    if _OCT.fullmatch(text):
        return int(text[2:], 8)
    if _HEX.fullmatch(text):
        return int(text[2:], 16)
    if _FLOAT.fullmatch(text):
        return float(text)
    if _INF.fullmatch(text):
        return -math.inf if text.startswith("-") else math.inf
    if _NAN.fullmatch(text):
        return math.nan
    return text


def decode(data: bytes, file: str) -> str:
    """The text of ``data``: UTF-8 (a byte-order mark is allowed), not empty, not too big."""
    if len(data) > MAX_BYTES:
        raise _error(file, 1, f"file is too large ({len(data)} bytes, at most {MAX_BYTES})")
    try:
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        line = data.count(b"\n", 0, exc.start) + 1
        raise _error(file, line, f"file is not valid UTF-8 (byte 0x{data[exc.start]:02x} "
                                 f"at offset {exc.start})") from None
    if not text.strip():
        raise _error(file, 1, "file is empty; expected a mapping with name, bodies and joints")
    return text


def parse_text(text: str | bytes, file: str) -> Node:
    """Parse one YAML document into located nodes; raise InputError on bad YAML."""
    if isinstance(text, bytes):
        text = decode(text, file)
    elif len(text.encode("utf-8", "surrogatepass")) > MAX_BYTES:
        raise _error(file, 1, f"file is too large (more than {MAX_BYTES} bytes)")
    if not text.strip():
        raise _error(file, 1, "file is empty; expected a mapping with name, bodies and joints")
    lines = Lines(text)
    _refuse_unicode_line_breaks(text, file, lines)
    try:
        root = yaml.compose(text, Loader=_Loader)
    except yaml.MarkedYAMLError as exc:
        raise _syntax_error(exc, file, lines) from None
    except yaml.reader.ReaderError as exc:
        raise _error(file, lines.at(exc.position), f"invalid character in YAML: {exc.reason}") \
            from None
    except yaml.YAMLError as exc:
        raise _error(file, 1, f"YAML error: {exc}") from None
    except _TooDeep as exc:
        raise _error(file, lines.at(exc.index), f"YAML is nested more than {MAX_NESTING} levels "
                                                "deep") from None
    except _TooMany as exc:
        raise _error(file, lines.at(exc.index), f"document has more than {MAX_NODES} nodes") \
            from None
    if root is None:
        raise _error(file, 1, "file is empty (no YAML document); expected a mapping with "
                              "name, bodies and joints")
    converter = _Converter(file, Lines(text))
    tree = converter.convert(root, depth=0, path="")
    if converter.problems:
        raise InputError(converter.problems)
    return tree


class Lines:
    """Line numbers of character offsets, counting only \\n as a line end (as editors, grep -n
    and compilers do). PyYAML's marks also count NEL (U+0085), U+2028 and U+2029 as line breaks,
    so its line numbers would drift from the file's in a file holding those characters."""

    def __init__(self, text: str):
        self.starts = [match.end() for match in re.finditer("\n", text)]

    def at(self, index: int) -> int:
        """The 1-based line of the character at offset INDEX."""
        return bisect.bisect_right(self.starts, index) + 1

    def of(self, mark: yaml.Mark) -> int:
        return self.at(mark.index)


# YAML 1.1 (and so PyYAML) takes these as line breaks, YAML 1.2 as ordinary characters: the two
# readings of one file differ, so a file holding them is refused rather than read either way.
UNICODE_LINE_BREAKS = re.compile("[\x85\u2028\u2029]")
UNICODE_BREAK_NAMES = {"\x85": "NEL", "\u2028": "LINE SEPARATOR",
                       "\u2029": "PARAGRAPH SEPARATOR"}


def _refuse_unicode_line_breaks(text: str, file: str, lines: Lines) -> None:
    found = UNICODE_LINE_BREAKS.search(text)
    if found is None:
        return
    char = found.group()
    raise _error(file, lines.at(found.start()), f"character U+{ord(char):04X} "
                 f"({UNICODE_BREAK_NAMES[char]}) is not allowed: YAML readers disagree on whether"
                 " it ends a line; remove it (end lines with a plain newline)")


class _TooDeep(Exception):
    def __init__(self, index: int):
        super().__init__(index)
        self.index = index  # character offset where it happened


class _TooMany(Exception):
    def __init__(self, index: int):
        super().__init__(index)
        self.index = index


class _Loader(yaml.SafeLoader):
    """PyYAML's safe composer with a nesting limit (it recurses once per level) and a node
    limit (a megabyte of ``[0,0,0,...]`` would otherwise cost a minute and half a gigabyte)."""

    def __init__(self, stream: str):
        super().__init__(stream)
        self.nesting = 0
        self.nodes = 0

    def compose_node(self, parent: yaml.Node | None, index: object) -> yaml.Node:
        self.nesting += 1
        self.nodes += 1
        if self.nodes > MAX_NODES:
            raise _TooMany(self.peek_event().start_mark.index)
        if self.nesting > MAX_NESTING:
            raise _TooDeep(self.peek_event().start_mark.index)
        try:
            return super().compose_node(parent, index)
        finally:
            self.nesting -= 1


def _syntax_error(exc: yaml.MarkedYAMLError, file: str, lines: Lines) -> InputError:
    mark = exc.problem_mark or exc.context_mark
    line = lines.of(mark) if mark is not None else 1
    message = exc.problem or "invalid YAML"
    if exc.context:
        message = f"{exc.context}: {message}"
    if "'\\t'" in message:
        message += " (tabs are not allowed in YAML indentation; use spaces)"
    return _error(file, line, f"YAML syntax error: {message}")


MERGE_KEY_REFUSED = ("YAML merge keys ('<<') are not supported: write the keys out (an alias "
                     "'*name' may still repeat a whole value)")


def _is_merge_key(key: yaml.ScalarNode) -> bool:
    """A plain '<<' key: YAML 1.1's merge, which nemc does not perform (it is not YAML 1.2);
    taken as an ordinary key it would silently drop the merged keys."""
    return key.value == "<<" and key.style is None


def _error(file: str, line: int, message: str) -> InputError:
    return InputError([Problem(file, line, "", message)])


class _Converter:
    """Turns composed nodes into :class:`Node` trees, counting nodes to stop alias bombs."""

    def __init__(self, file: str, lines: Lines):
        self.file = file
        self.lines = lines
        self.count = 0
        self.active: set[int] = set()  # ids of nodes being converted (recursive aliases)
        self.problems: list[Problem] = []

    def convert(self, node: yaml.Node, depth: int, path: str) -> Node:
        self.count += 1
        line = self.lines.of(node.start_mark)
        if self.count > MAX_NODES:
            raise _error(self.file, line, f"document expands to more than {MAX_NODES} nodes "
                                          "(too many aliases?)")
        if depth > MAX_NESTING:
            raise _error(self.file, line, f"YAML is nested more than {MAX_NESTING} levels deep")
        if id(node) in self.active:
            raise _error(self.file, line, "recursive alias: a node cannot contain itself")
        self.active.add(id(node))
        try:
            return self._convert(node, depth, path, (line, node.start_mark.column + 1))
        finally:
            self.active.discard(id(node))

    def _convert(self, node: yaml.Node, depth: int, path: str, mark: tuple[int, int]) -> Node:
        line, column = mark
        if isinstance(node, yaml.ScalarNode):
            if node.style is None:
                return Node(resolve_plain(node.value), line, column)
            return Node(node.value, line, column, quoted=True)
        if isinstance(node, yaml.SequenceNode):
            items = [self.convert(item, depth + 1, f"{path}[{i}]")
                     for i, item in enumerate(node.value)]
            return Node(items, line, column)
        return self._mapping(node, depth, path, mark)

    def _mapping(self, node: yaml.MappingNode, depth: int, path: str,
                 mark: tuple[int, int]) -> Node:
        result = Node({}, *mark)
        mapping: dict[str, Node] = {}
        for key_node, value_node in node.value:
            key_line = self.lines.of(key_node.start_mark)
            if not isinstance(key_node, yaml.ScalarNode):
                raise _error(self.file, key_line, "a mapping key must be a plain word, "
                                                  "not a list or mapping")
            key = key_node.value
            key_path = f"{path}.{key}" if path else key
            if _is_merge_key(key_node):
                self.problems.append(Problem(self.file, key_line, key_path, MERGE_KEY_REFUSED))
                continue
            if key in mapping:
                self.problems.append(Problem(self.file, key_line, key_path, "duplicate key "
                                             f"(first at line {result.key_lines[key]})"))
                continue
            result.key_lines[key] = key_line
            mapping[key] = self.convert(value_node, depth + 1, key_path)
        result.value = mapping
        return result
