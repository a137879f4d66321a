"""Find the line of a dotted key in TOML text, so that errors can say ``scene.toml:12``.

Python's TOML parser keeps no positions, so this is a small line scanner: it follows table
headers (``[a.b]``) and arrays of tables (``[[geometry]]``, counting them) and the keys set
under them, and returns the line whose key path shares the longest prefix with the one asked
for. It is a best effort for messages only: when in doubt it returns ``None``.
"""

from __future__ import annotations

import re

_PART = re.compile(r'"((?:[^"\\]|\\.)*)"|\'([^\']*)\'|([A-Za-z0-9_-]+)')
_KEY_LINE = re.compile(r'^\s*((?:"(?:[^"\\]|\\.)*"|\'[^\']*\'|[A-Za-z0-9_.\- ]+?))\s*=')
_INDEXED = re.compile(r"^(.*?)((?:\[\d+\])*)$")

Token = tuple[str, "int | None"]


def split_dotted(text: str) -> list[str]:
    """``a."b.c".d`` -> ``['a', 'b.c', 'd']``."""
    return [m.group(1) if m.group(1) is not None else (m.group(2) if m.group(2) is not None
            else m.group(3)) for m in _PART.finditer(text)]


def parse_key_path(key: str) -> list[Token]:
    """``geometry[0].materials.floor`` -> ``[('geometry', 0), ('materials', None), ...]``.

    Names may contain dots only in the last components of ``materials.NAME``-style paths that
    the scene itself produced, so a plain split on dots outside brackets is enough here.
    """
    tokens: list[Token] = []
    for part in re.split(r"\.(?![^\[]*\])", key):
        m = _INDEXED.match(part)
        name, idx = (m.group(1), m.group(2)) if m else (part, "")
        indices = [int(i) for i in re.findall(r"\d+", idx)]
        tokens.append((name, indices[0] if indices else None))
    return tokens


def _strip_comment(line: str) -> str:
    out, quote = [], None
    for ch in line:
        if quote:
            if ch == quote:
                quote = None
        elif ch in "\"'":
            quote = ch
        elif ch == "#":
            break
        out.append(ch)
    return "".join(out)


def find_line(text: str | None, key: str | None) -> int | None:
    """1-based line where ``key`` (a dotted path with ``[i]`` indices) is set, or None."""
    if not text or not key:
        return None
    target = parse_key_path(key)
    # An index on the last component points into a value (a list), not a table.
    if target and target[-1][1] is not None and _is_value_index(text, target):
        target = target[:-1] + [(target[-1][0], None)]

    counts: dict[tuple[str, ...], int] = {}
    table: list[Token] = []
    best_line, best_score = None, 0
    for lineno, raw in enumerate(text.splitlines(), start=1):
        line = _strip_comment(raw).strip()
        if not line:
            continue
        if line.startswith("[["):
            names = split_dotted(line[2:line.find("]]")] if "]]" in line else line[2:])
            counts[tuple(names)] = counts.get(tuple(names), -1) + 1
            table = _resolve(names, counts)
            path = table
        elif line.startswith("["):
            names = split_dotted(line[1:line.find("]")] if "]" in line else line[1:])
            table = _resolve(names, counts)
            path = table
        else:
            m = _KEY_LINE.match(line)
            if not m:
                continue
            path = table + [(n, None) for n in split_dotted(m.group(1))]
        score = _common_prefix(path, target)
        if score == len(path) and score > best_score:
            best_line, best_score = lineno, score
            if score == len(target):
                return best_line
    return best_line


def _is_value_index(text: str, target: list[Token]) -> bool:
    """True unless the last component names an array of tables (``[[name]]``)."""
    name = target[-1][0]
    return not re.search(r"^\s*\[\[\s*([^\]]*\.)?" + re.escape(name) + r"\s*\]\]", text,
                         flags=re.MULTILINE)


def _resolve(names: list[str], counts: dict[tuple[str, ...], int]) -> list[Token]:
    out: list[Token] = []
    for i, n in enumerate(names):
        prefix = tuple(names[: i + 1])
        out.append((n, counts.get(prefix)))
    return out


def _common_prefix(a: list[Token], b: list[Token]) -> int:
    k = 0
    for x, y in zip(a, b):
        if x != y:
            break
        k += 1
    return k
