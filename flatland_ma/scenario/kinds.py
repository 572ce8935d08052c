"""Specs chosen by a tag in scenario files (a sensor's ``type``, a rule's ``rule``, a
generator's ``generator``, a part's ``type``), kept in registries that grow at run time.

The shipped specs register themselves where they are defined; a user's own join with
``flatland_ma.register`` or an entry point (``flatland_ma.kinds.entry_points``). A field typed
``SENSORS.field`` takes a mapping, looks its tag up in the registry and validates the
mapping with that spec; pydantic's discriminated unions are fixed when the models are
made, a registry is not. The errors of the spec keep their key paths (``Nested``, which
``messages.py`` unfolds), and the JSON schema lists every spec registered when it is
written, as a union tagged by the same key.
"""

from __future__ import annotations

import difflib
import typing
from typing import Any

from pydantic import BaseModel, GetCoreSchemaHandler, GetJsonSchemaHandler, ValidationError
from pydantic_core import ErrorDetails, core_schema

from flatland_ma.kinds.entry_points import (
    extension_failures,
    how_kinds_are_added,
    load_extensions,
)


class Nested(ValueError):
    """The errors of a registered spec validating one entry: ``model`` is the spec, each
    error's ``loc`` is within the entry (``messages.py`` puts the entry's path before it)."""

    def __init__(self, model: type[BaseModel], errors: list[ErrorDetails]):
        self.model, self.errors = model, errors
        lines = [f"{'.'.join(str(p) for p in e['loc']) or '.'}: {e['msg']}" for e in errors]
        super().__init__(f"{model.__name__}: " + "; ".join(lines))


class SpecKinds:
    """The specs of one family (``what``: "sensor"), by the value of their ``tag`` key;
    each is a subclass of ``base`` whose ``tag`` field is one ``Literal`` string."""

    def __init__(self, what: str, tag: str, base: type[BaseModel]):
        self.what, self.tag, self.base = what, tag, base
        self._specs: dict[str, type[BaseModel]] = {}
        self.field: Any = typing.Annotated[base, _Registered(self)]
        """The annotation of a field holding one such spec (pyright sees ``base``)."""

    def add(self, spec: type[BaseModel]) -> str:
        """Register ``spec``; return its tag. A tag taken by another spec is an error."""
        if not (isinstance(spec, type) and issubclass(spec, self.base)):
            raise TypeError(f"a {self.what} spec must subclass {self.base.__name__}: {spec!r}")
        name = tag_of(spec, self.tag)
        if name is None:
            raise TypeError(
                f"{spec.__name__} needs a field {self.tag}: Literal['...'] naming its kind"
            )
        known = self._specs.get(name)
        if known is not None and known is not spec:
            raise ValueError(
                f"a {self.what} {self.tag} {name!r} is registered already ({known.__module__}"
                f".{known.__qualname__}); choose another name"
            )
        self._specs[name] = spec
        return name

    def get(self, name: str) -> type[BaseModel] | None:
        """The spec of ``name``, or None; loads the extensions the first time one is missing."""
        if name not in self._specs:
            load_extensions()
        return self._specs.get(name)

    def names(self) -> list[str]:
        """Every tag, the extensions' included, in the order registered."""
        load_extensions()
        return list(self._specs)

    def every(self) -> list[type[BaseModel]]:
        """Every spec, the extensions' included, in the order registered."""
        return [self._specs[name] for name in self.names()]

    def validate(self, value: Any) -> BaseModel:
        """The spec that ``value`` (a mapping, or a spec made in Python) describes."""
        if isinstance(value, self.base):
            return value
        if not isinstance(value, dict):
            raise ValueError(f"expected a mapping with a {self.tag!r} key; got {value!r:.80}")
        if self.tag not in value:
            raise ValueError(f"missing required key {self.tag!r} ({self._choices()})")
        name = value[self.tag]
        spec = self.get(name) if isinstance(name, str) else None
        if spec is None:
            hint = difflib.get_close_matches(str(name), self.names(), n=1)
            maybe = f" (did you mean {hint[0]!r}?)" if hint else ""
            raise ValueError(
                f"unknown {self.what} {name!r}{maybe}; {self._choices()}"
                f"{extension_failures() or how_kinds_are_added(self.what)}",
            )
        try:
            return spec.model_validate(value)
        except ValidationError as err:
            raise Nested(spec, err.errors()) from None

    def _choices(self) -> str:
        return f"known {self.what}s: {', '.join(sorted(self.names())) or 'none'}"


def tag_of(spec: type[BaseModel], tag: str) -> str | None:
    """The one value a spec's ``tag`` field may take (``Literal["camera"]``), or None."""
    field = spec.model_fields.get(tag)
    values = typing.get_args(field.annotation) if field is not None else ()
    if typing.get_origin(field.annotation if field else None) is typing.Literal:
        if len(values) == 1 and isinstance(values[0], str):
            return values[0]
    return None


class _Registered:
    """The pydantic hooks of ``SpecKinds.field``: validate through the registry, serialise
    as the spec found, and write the JSON schema of every spec registered."""

    def __init__(self, kinds: SpecKinds):
        self.kinds = kinds

    def __get_pydantic_core_schema__(
        self, source: Any, handler: GetCoreSchemaHandler
    ) -> core_schema.CoreSchema:
        return core_schema.no_info_plain_validator_function(
            self.kinds.validate, serialization=core_schema.simple_ser_schema("any")
        )

    def __get_pydantic_json_schema__(
        self, schema: core_schema.CoreSchema, handler: GetJsonSchemaHandler
    ) -> dict[str, Any]:
        specs = self.kinds.every()
        # pydantic hands Annotated metadata a handler that writes models inline; its
        # generator writes each into ``$defs`` and refers to it, as for any other model.
        generator = getattr(handler, "generate_json_schema", None)
        inner = generator.generate_inner if generator is not None else handler
        refs = [inner(spec.__pydantic_core_schema__) for spec in specs]
        names = [tag_of(spec, self.kinds.tag) for spec in specs]
        mapping = {name: ref["$ref"] for name, ref in sorted(zip(names, refs)) if "$ref" in ref}
        if not refs:  # none registered: no entry is valid (``oneOf`` may not be empty)
            return {"not": {}, "description": f"No {self.kinds.what} kind is registered."}
        return {
            "discriminator": {"mapping": mapping, "propertyName": self.kinds.tag},
            "oneOf": refs,
        }
