"""Reading a YAML camera file without trusting it: PyYAML's safe loader (no Python objects) with duplicate keys
refused and nesting limited to :data:`aerofid.formats.text.MAX_DEPTH` (a module of its own: the commands that read
no camera file, such as ``aerofid locate``, do not import PyYAML).
"""

from __future__ import annotations

from typing import Any

import yaml

from aerofid.errors import AerofidInputError
from aerofid.formats.text import MAX_DEPTH, too_deep

__all__ = ["load_yaml"]


class _Loader(yaml.SafeLoader):
    """PyYAML's safe loader with duplicate keys refused and nesting limited (its composer recurses)."""

    source = ""
    depth = 0

    def compose_node(self, parent, index):
        self.depth += 1
        try:
            if self.depth > MAX_DEPTH:
                raise too_deep(self.source)
            return super().compose_node(parent, index)
        finally:
            self.depth -= 1

    def construct_mapping(self, node, deep=False):
        keys = [self.construct_object(k, deep=deep) for k, _ in node.value]
        dup = sorted({str(k) for k in keys if keys.count(k) > 1})
        if dup:
            raise AerofidInputError(f"duplicate key(s) {', '.join(dup)} in {self.source}; each key once")
        return super().construct_mapping(node, deep=deep)


_Loader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, _Loader.construct_mapping)


def load_yaml(text: str, source: str) -> Any:
    """Parse YAML ``text`` safely (no Python objects): duplicate keys and nesting deeper than :data:`MAX_DEPTH`
    refused.

    Examples
    --------
    >>> load_yaml("a: [1, 2]", "x.yaml")
    {'a': [1, 2]}
    >>> load_yaml("a: " + "[" * 40 + "]" * 40, "x.yaml")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    aerofid.errors.AerofidInputError: x.yaml nests deeper than 32 levels; ...
    """
    loader = _Loader(text)
    loader.source = source
    try:
        return loader.get_single_data()
    except yaml.YAMLError as e:
        msg = " ".join(str(e).split())
        raise AerofidInputError(f"{source} is not valid YAML: {msg}") from None
    except RecursionError:
        raise too_deep(source) from None
    finally:
        loader.dispose()
