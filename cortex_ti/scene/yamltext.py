"""YAML for scenes: a safe loader that reads ``1e-3`` as a number and rejects duplicate keys,
and a dumper writing the canonical text stored with every trajectory."""

from __future__ import annotations

import re
from typing import Any

import yaml

__all__ = ["load_yaml", "dump_yaml", "yaml_problem"]


# --------------------------------------------------------------------------------------
# YAML
# --------------------------------------------------------------------------------------


class _Loader(yaml.SafeLoader):
    """Safe YAML loader that reads ``1e-3`` as a float and rejects duplicate keys.

    PyYAML follows YAML 1.1, where a float needs a dot (``1.0e-3``) and ``1e-3``
    is a string; scientists write ``1e-3``.
    """

    def construct_mapping(self, node, deep=False):  # noqa: D102 (PyYAML hook)
        if isinstance(node, yaml.MappingNode):
            self.flatten_mapping(node)
            seen = set()
            for key_node, _ in node.value:
                key = self.construct_object(key_node, deep=deep)
                try:
                    duplicate = key in seen
                    seen.add(key)
                except TypeError:  # unhashable key: let PyYAML report it
                    continue
                if duplicate:
                    raise yaml.constructor.ConstructorError(
                        None, None, f"found duplicate key {key!r}", key_node.start_mark
                    )
        return super().construct_mapping(node, deep=deep)


_Loader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(
        r"""^(?:[-+]?(?:[0-9][0-9_]*)(?:\.[0-9_]*)?[eE][-+]?[0-9]+)$""",
        re.X,
    ),
    list("-+0123456789"),
)


class _Dumper(yaml.SafeDumper):
    """Safe YAML dumper writing multi-line strings as literal blocks."""


def _represent_str(dumper: yaml.SafeDumper, value: str):
    style = "|" if "\n" in value else None
    return dumper.represent_scalar("tag:yaml.org,2002:str", value, style=style)


def _represent_list(dumper: yaml.SafeDumper, value: list):
    flat = all(isinstance(v, (str, int, float, bool)) or v is None for v in value)
    return dumper.represent_sequence("tag:yaml.org,2002:seq", value, flow_style=flat)


_Dumper.add_representer(str, _represent_str)
_Dumper.add_representer(list, _represent_list)


def load_yaml(text: str) -> Any:
    return yaml.load(text, Loader=_Loader)  # noqa: S506 (_Loader derives from SafeLoader)


def yaml_problem(exc: yaml.YAMLError) -> str:
    """One line describing a YAML syntax error, with its line and column."""
    problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
    mark = getattr(exc, "problem_mark", None)
    if mark is not None:
        return f"{problem} (line {mark.line + 1}, column {mark.column + 1})"
    return problem


def dump_yaml(data) -> str:
    """The canonical YAML text of a scene mapping (stored with every trajectory; floats at ``repr``
    precision, so reading it back gives the same numbers)."""
    return yaml.dump(data, Dumper=_Dumper, sort_keys=False, default_flow_style=False, allow_unicode=True, width=100)
