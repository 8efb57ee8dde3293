"""Typed result documents of mtwin as Python objects."""

from __future__ import annotations

from typing import Any, Dict, Iterator


def _lists(value: Any) -> Any:
    """Tuples (serde tuples and fixed arrays) as lists, as in the JSON document."""
    if isinstance(value, dict):
        return {k: _lists(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_lists(v) for v in value]
    return value


def _wrap(value: Any) -> Any:
    if isinstance(value, dict):
        return Document("", value, "")
    if isinstance(value, list):
        return [_wrap(v) for v in value]
    return value


class Document:
    """One of the library's result documents (the JSON of ``--format json``).

    Fields are attributes (nested documents are ``Document`` too, lists are
    lists); ``to_dict()`` gives the plain dict, exactly the JSON document's
    structure; ``str(doc)`` is the CLI's human summary; ``kind`` names the
    library type (``TrackerIdentifyDoc``, ``GcodeStatsDoc``, ...).
    """

    __slots__ = ("kind", "_data", "_text")

    def __init__(self, kind: str, data: Dict[str, Any], text: str) -> None:
        object.__setattr__(self, "kind", kind)
        object.__setattr__(self, "_data", _lists(data) if kind else data)
        object.__setattr__(self, "_text", text)

    def __getattr__(self, name: str) -> Any:
        data = object.__getattribute__(self, "_data")
        try:
            return _wrap(data[name])
        except KeyError:
            raise AttributeError(
                f"{self.kind or 'Document'} has no field {name!r} "
                f"(fields: {', '.join(data)})"
            ) from None

    def __setattr__(self, name: str, value: Any) -> None:
        raise AttributeError("mtwin documents are read-only")

    def __getitem__(self, name: str) -> Any:
        return _wrap(self._data[name])

    def __contains__(self, name: object) -> bool:
        return name in self._data

    def __iter__(self) -> Iterator[str]:
        return iter(self._data)

    def __dir__(self) -> list:
        return sorted(set(self._data) | {"kind", "to_dict", "to_json"})

    def __eq__(self, other: object) -> bool:
        if isinstance(other, Document):
            return self._data == other._data
        return NotImplemented

    def to_dict(self) -> Dict[str, Any]:
        """The document as plain dicts, lists, numbers and strings."""
        import copy

        return copy.deepcopy(self._data)

    def to_json(self, **kwargs: Any) -> str:
        """The document as JSON text (``--format json`` of the CLI)."""
        import json

        return json.dumps(self._data, **kwargs)

    def __str__(self) -> str:
        return self._text or repr(self)

    def __repr__(self) -> str:
        fields = []
        for k, v in self._data.items():
            if isinstance(v, (dict, list)):
                n = len(v)
                v = f"<{type(v).__name__} of {n}>"
            else:
                v = repr(v)
            fields.append(f"{k}={v}")
        return f"{self.kind or 'Document'}({', '.join(fields)})"
