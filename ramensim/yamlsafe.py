"""Reading YAML that a careless or hostile user wrote, in bounded time and memory.

``yaml.safe_load`` alone builds no arbitrary objects, but it still accepts documents that
hurt later: aliases that expand to billions of nodes when the data is copied ("billion
laughs"), nesting deep enough to overflow Python's stack, integers with thousands of digits,
and duplicate keys (the last one silently wins). :func:`safe_load_bounded` composes the node
graph first, checks it, and only then builds Python objects:

- the size of the document *with every alias expanded* is at most ``max_nodes`` nodes, and
  an alias may not refer to a node that contains it (a cycle);
- nesting is at most ``max_depth`` levels;
- an integer has at most ``max_int_digits`` digits;
- a mapping never repeats a key (merge keys ``<<`` excepted); the error names both lines.

Every refusal is a :class:`YAMLLimitError` (a ``yaml.YAMLError``) with a one-line reason.
"""
from __future__ import annotations

import re
from typing import Any

import yaml
from yaml.nodes import MappingNode, Node, ScalarNode, SequenceNode

MAX_NODES = 100_000
"""Most nodes (scalars, sequences, mappings) a document may have with its aliases expanded."""
MAX_DEPTH = 64
"""Deepest nesting of sequences and mappings."""
MAX_INT_DIGITS = 40
"""Most digits of an integer literal (a 64-bit integer has at most 20)."""
MAX_BYTES = 1024 * 1024
"""Largest YAML text read (bytes)."""


class YAMLLimitError(yaml.YAMLError):
    """A document refused by a bound; ``line`` is 1-based where known."""

    def __init__(self, message: str, line: int | None = None) -> None:
        super().__init__(message)
        self.problem = message
        self.line = line


class _BoundedLoader(yaml.SafeLoader):
    max_int_digits = MAX_INT_DIGITS

    def construct_yaml_int(self, node: ScalarNode) -> int:
        digits = sum(ch.isdigit() for ch in str(node.value))
        if digits > self.max_int_digits:
            raise YAMLLimitError(f"an integer with {digits} digits at line {node.start_mark.line + 1} "
                                 f"(at most {self.max_int_digits} digits are accepted)",
                                 node.start_mark.line + 1)
        return super().construct_yaml_int(node)

    def construct_mapping(self, node: MappingNode, deep: bool = False) -> dict[Any, Any]:
        if isinstance(node, MappingNode):
            seen: dict[Any, int] = {}
            for key_node, _ in node.value:
                if key_node.tag == "tag:yaml.org,2002:merge" or not isinstance(key_node, ScalarNode):
                    continue
                key = self.construct_object(key_node, deep=True)
                try:
                    first = seen.get(key)
                except TypeError:
                    continue
                line = key_node.start_mark.line + 1
                if first is not None:
                    raise YAMLLimitError(f"duplicate key {_short(key)!r} at lines {first} and {line} (a "
                                         f"mapping may name each key once; remove one of them)", line)
                seen[key] = line
        return super().construct_mapping(node, deep=deep)


_BoundedLoader.add_constructor("tag:yaml.org,2002:int", _BoundedLoader.construct_yaml_int)
_BoundedLoader.add_constructor("tag:yaml.org,2002:map", _BoundedLoader.construct_yaml_map)


def _short(value: Any, n: int = 60) -> str:
    text = str(value)
    return text if len(text) <= n else text[:n - 3] + "..."


def check_node(root: Node, max_nodes: int = MAX_NODES, max_depth: int = MAX_DEPTH) -> int:
    """Expanded size of a composed document (nodes, counting every alias expansion);
    raises YAMLLimitError past ``max_nodes`` or ``max_depth``, or on a cyclic alias.
    Iterative with memoised subtree sizes, so a hostile document costs O(distinct nodes)."""
    size: dict[int, int] = {}
    on_path: set[int] = set()
    # explicit stack of (node, depth, expanded?)
    stack: list[tuple[Node, int, bool]] = [(root, 1, False)]
    while stack:
        node, depth, done = stack.pop()
        nid = id(node)
        if done:
            on_path.discard(nid)
            total = 1 + sum(size[id(c)] for c in _children(node))
            if total > max_nodes:
                raise YAMLLimitError(f"the document expands (aliases included) to more than {max_nodes} "
                                     f"values (near line {node.start_mark.line + 1}); expected a small "
                                     f"scenario file", node.start_mark.line + 1)
            size[nid] = total
            continue
        if nid in size:
            continue
        if nid in on_path:
            raise YAMLLimitError(f"an alias at line {node.start_mark.line + 1} refers to a value that "
                                 f"contains it (a cycle)", node.start_mark.line + 1)
        if depth > max_depth:
            raise YAMLLimitError(f"nesting deeper than {max_depth} levels at line {node.start_mark.line + 1}",
                                 node.start_mark.line + 1)
        if isinstance(node, ScalarNode):
            size[nid] = 1
            continue
        on_path.add(nid)
        stack.append((node, depth, True))
        for child in _children(node):
            if id(child) in on_path:
                raise YAMLLimitError(f"an alias at line {child.start_mark.line + 1} refers to a value that "
                                     f"contains it (a cycle)", child.start_mark.line + 1)
            if id(child) not in size:
                stack.append((child, depth + 1, False))
    return size[id(root)]


def _children(node: Node) -> list[Node]:
    if isinstance(node, SequenceNode):
        return list(node.value)
    if isinstance(node, MappingNode):
        return [n for pair in node.value for n in pair]
    return []


_MERGE = "tag:yaml.org,2002:merge"


def node_lines(root: Node) -> dict[tuple[str, ...], int]:
    """1-based line of every key and list item of a composed document, by its path of keys
    and indices (as strings): ``{("channel", "path_loss", "curve"): 12, ...}``. Keys brought
    in by a merge (``<<: *base``) get the line where the merged value is written, unless the
    mapping names them itself. Call after :func:`check_node` (no cycles, bounded size)."""
    lines: dict[tuple[str, ...], int] = {}
    stack: list[tuple[tuple[str, ...], Node, bool]] = [((), root, False)]
    while stack:
        path, node, merged = stack.pop()
        if isinstance(node, MappingNode):
            for key, value in node.value:
                if not isinstance(key, ScalarNode):
                    continue
                if key.tag == _MERGE:
                    for target in (value.value if isinstance(value, SequenceNode) else [value]):
                        stack.append((path, target, True))
                    continue
                sub = path + (str(key.value),)
                if merged:
                    lines.setdefault(sub, key.start_mark.line + 1)
                else:
                    lines[sub] = key.start_mark.line + 1
                stack.append((sub, value, merged))
        elif isinstance(node, SequenceNode):
            for i, item in enumerate(node.value):
                sub = path + (str(i),)
                lines.setdefault(sub, item.start_mark.line + 1)
                stack.append((sub, item, merged))
    return lines


_NOT_BRACKETS = re.compile(r"[^\[\]{}]+")


def flow_depth(text: str) -> int:
    """Deepest nesting of flow brackets (``[`` ``{``) in ``text``, quotes ignored: an upper
    bound of the flow nesting the YAML scanner meets. Checked before parsing because the
    scanner's work per token grows with the number of open brackets (a line of 3,000 ``[``
    cost a second before the composer's recursion limit refused it)."""
    depth = deepest = 0
    for ch in _NOT_BRACKETS.sub("", text):
        if ch in "[{":
            depth += 1
            if depth > deepest:
                deepest = depth
        elif depth:
            depth -= 1
    return deepest


def safe_load_bounded(text: str, max_nodes: int = MAX_NODES, max_depth: int = MAX_DEPTH,
                      lines: dict[tuple[str, ...], int] | None = None) -> Any:
    """Parse one YAML document like ``yaml.safe_load`` within the bounds above; raises
    ``yaml.YAMLError`` (a :class:`YAMLLimitError` for a refused bound). ``lines``, when
    given, receives the line of every key (:func:`node_lines`)."""
    if len(text) > MAX_BYTES:
        raise YAMLLimitError(f"the text is {len(text)} characters long (at most {MAX_BYTES} are read)")
    flow = flow_depth(text)
    if flow > max_depth:
        raise YAMLLimitError(f"brackets nested deeper than {max_depth} levels ({flow} '[' or '{{' open at once)")
    loader = _BoundedLoader(text)
    try:
        try:  # the composer recurses once per nesting level
            root = loader.get_single_node()
        except RecursionError:
            raise YAMLLimitError(f"nesting deeper than {max_depth} levels") from None
        if root is None:
            return None
        check_node(root, max_nodes=max_nodes, max_depth=max_depth)
        if lines is not None:
            lines.update(node_lines(root))
        try:
            return loader.construct_document(root)
        except RecursionError:
            raise YAMLLimitError(f"nesting deeper than {max_depth} levels") from None
        except ValueError as exc:  # e.g. an out-of-range date or float literal
            raise YAMLLimitError(f"a value could not be read ({_short(exc, 120)})") from None
    finally:
        loader.dispose()
