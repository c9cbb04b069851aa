"""Reading scenario YAML: Drake's variant tags kept, a key given twice refused, errors as one
line naming the field, and overlays merged onto a base in Drake's style (a later document
changes only the fields it names)."""

import dataclasses
import typing

import yaml
from pydrake.common.yaml import yaml_load_typed

from tangle_drake.common.errors import TangleDrakeError


class Tagged(typing.NamedTuple):
    """A YAML node with a type tag (e.g. ``!FovDegrees``), kept so it can be written back."""

    tag: str
    value: object


class TaggedLoader(yaml.SafeLoader):
    """Safe loader that keeps Drake's variant tags instead of refusing them, and refuses a key
    given twice in one mapping (YAML would keep the last one silently)."""

    def construct_mapping(self, node: yaml.MappingNode, deep: bool = False) -> dict:
        seen: set = set()
        for key_node, _ in node.value:
            key = self.construct_object(key_node, deep=True)
            if key in seen:
                raise yaml.constructor.ConstructorError(
                    "while reading a mapping", node.start_mark,
                    f"found the key {key!r} twice", key_node.start_mark)
            seen.add(key)
        return super().construct_mapping(node, deep=deep)


class TaggedDumper(yaml.SafeDumper):
    """Safe dumper that writes :class:`Tagged` nodes with their tags."""


def _construct_tagged(loader: yaml.SafeLoader, suffix: str, node: yaml.Node) -> Tagged:
    if isinstance(node, yaml.MappingNode):
        value: object = loader.construct_mapping(node, deep=True)
    elif isinstance(node, yaml.SequenceNode):
        value = loader.construct_sequence(node, deep=True)
    else:
        value = loader.construct_scalar(node)
    return Tagged("!" + suffix, value)


def _represent_tagged(dumper: yaml.SafeDumper, data: Tagged) -> yaml.Node:
    if isinstance(data.value, dict):
        return dumper.represent_mapping(data.tag, data.value)
    if isinstance(data.value, list):
        return dumper.represent_sequence(data.tag, data.value)
    return dumper.represent_scalar(data.tag, str(data.value))


TaggedLoader.add_multi_constructor("!", _construct_tagged)
TaggedDumper.add_representer(Tagged, _represent_tagged)


def one_line(error: yaml.YAMLError) -> str:
    """A YAML error as one line: where and what (PyYAML's own text quotes the lines)."""
    if isinstance(error, yaml.MarkedYAMLError) and error.problem_mark is not None:
        return f"line {error.problem_mark.line + 1}: {error.problem}"
    return str(error).replace("\n", " ")


def read_mapping(text: str, source: str) -> dict:
    """A scenario document's fields, tags kept (an empty document has none); what is not
    YAML, or not a mapping, is refused naming ``source``."""
    try:
        raw = yaml.load(text, Loader=TaggedLoader)
    except yaml.YAMLError as error:
        raise TangleDrakeError(f"{source} is not valid YAML: {one_line(error)}") from error
    if raw is None:
        return {}
    if not isinstance(raw, dict):
        raise TangleDrakeError(f"{source}: a scenario must be a mapping of fields")
    return raw


def find_bad_field(schema: type, raw: object, prefix: str) -> str:
    """The dotted path of the first field of ``raw`` that does not load as ``schema`` says.

    Drake's loader reports the problem but not always where; this retries field by field.
    """
    if not (dataclasses.is_dataclass(schema) and isinstance(raw, dict)):
        return prefix or "<top level>"
    hints = typing.get_type_hints(schema)
    for key, value in raw.items():
        path = f"{prefix}.{key}" if prefix else str(key)
        if key not in hints:
            return path
        field_type = hints[key]
        if dataclasses.is_dataclass(field_type) and isinstance(value, dict):
            inner = find_bad_field(field_type, value, path)
            if inner != path:
                return inner
        probe = dataclasses.make_dataclass("Probe", [(str(key), field_type)])
        try:
            yaml_load_typed(schema=probe, data=yaml.dump({key: value}, Dumper=TaggedDumper),
                            defaults=probe(**{str(key): _default_of(schema, key)}))
        except (RuntimeError, ValueError, TypeError):
            if isinstance(value, list) and _list_item_type(field_type) is not None:
                for i, item in enumerate(value):
                    inner = find_bad_field(_list_item_type(field_type), item, f"{path}[{i}]")
                    if inner != f"{path}[{i}]":
                        return inner
            return path
    return prefix or "<top level>"


def _default_of(schema: type, name: str) -> object:
    for f in dataclasses.fields(schema):
        if f.name == name:
            if f.default is not dataclasses.MISSING:
                return f.default
            if f.default_factory is not dataclasses.MISSING:
                return f.default_factory()
    return None


def _list_item_type(field_type: object) -> type | None:
    if typing.get_origin(field_type) is list:
        (item,) = typing.get_args(field_type)
        return item if dataclasses.is_dataclass(item) else None
    return None


def merge(base: object, overlay: object) -> object:
    """``overlay`` onto ``base``, as Drake merges a YAML document onto defaults: mappings key
    by key (recursively), a driver variant's fields into the variant (an untagged mapping
    keeps the base's tag; another tag replaces it), anything else replaced (lists whole)."""
    if isinstance(base, Tagged) and isinstance(overlay, dict | Tagged):
        if isinstance(overlay, Tagged) and overlay.tag != base.tag:
            return overlay
        value = overlay.value if isinstance(overlay, Tagged) else overlay
        return Tagged(base.tag, merge(base.value, value))
    if isinstance(base, dict) and isinstance(overlay, dict):
        merged = dict(base)
        for key, value in overlay.items():
            merged[key] = merge(base[key], value) if key in base else value
        return merged
    return overlay


def dump(raw: object) -> str:
    """YAML text of a document read with :class:`TaggedLoader`, in its own key order."""
    return yaml.dump(raw, Dumper=TaggedDumper, sort_keys=False, default_flow_style=False)
