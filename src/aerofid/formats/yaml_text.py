"""Reading and writing a YAML camera file without trusting it: PyYAML's safe loader (no Python objects) with
duplicate keys refused and nesting limited to :data:`aerofid.formats.text.MAX_DEPTH`. PyYAML is imported at the
first YAML file (a JSON or MicMac camera file, and the commands that read none, such as ``aerofid locate``, do not
load it: 20 ms of a cold call).
"""

from __future__ import annotations

import functools
from typing import Any

from aerofid.errors import AerofidInputError
from aerofid.formats.text import MAX_DEPTH, too_deep, too_long

__all__ = ["dump_yaml", "load_yaml"]


@functools.cache
def _loader() -> Any:
    """PyYAML's safe loader with duplicate keys refused and nesting limited (its composer recurses), made at the
    first YAML file."""
    import yaml

    class Loader(yaml.SafeLoader):
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

    Loader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, Loader.construct_mapping)
    return Loader


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
    import yaml

    loader = _loader()(text)
    loader.source = source
    try:
        return loader.get_single_data()
    except yaml.YAMLError as e:
        msg = " ".join(str(e).split())
        raise AerofidInputError(f"{source} is not valid YAML: {msg}") from None
    except AerofidInputError:                       # the file's own refusals (a ValueError too)
        raise
    except ValueError as e:                         # an integer of more digits than Python converts, or a bad value
        raise (too_long(source) if "digits" in str(e) else AerofidInputError(f"{source} is not valid YAML: {e}")
               ) from None
    except RecursionError:
        raise too_deep(source) from None
    finally:
        loader.dispose()


def dump_yaml(data: Any) -> str:
    """``data`` (plain dicts, lists and numbers) as YAML text, keys in their order."""
    import yaml

    return str(yaml.safe_dump(data, sort_keys=False))
