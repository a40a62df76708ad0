"""Command-line options generated from a configuration dataclass, one per field marked for it.

A field takes part when its metadata has ``"run": True``; its flag is ``--field-name``, its help
the metadata's ``"help"``, its default the field's default, and its type follows the annotation:

| annotation | on the command line |
|---|---|
| ``int``, ``float`` | a number (``--t-max 5000``) |
| ``bool`` | ``--refine`` / ``--no-refine`` |
| ``tuple[int, ...]`` | a size such as ``12x7x4`` (as ``--lattice`` always took) |
| ``str`` | one of the metadata's ``"choices"`` if it has them, else any text |
| ``X | None`` | as ``X``; left out, the field's default |

:func:`config_values` reads the parsed values back as keyword arguments of the dataclass, so
that the dataclass stays the one list of these options (its ``__post_init__`` checks them).
"""

from __future__ import annotations

import argparse
import math
import types
import typing
from collections.abc import Callable, Iterable, Mapping
from dataclasses import MISSING, Field, fields
from typing import Any

from envs.cli import common as cli
from envs.sizes import format_lattice

#: The metadata keys read here ("added_later", for old checkpoints, is the config's own).
HELP, CHOICES, RUN = "help", "choices", "run"


def _integer(text: str) -> int:
    try:
        return int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"wants an integer, got {text!r}") from None


def _finite(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"wants a finite number, got {text!r}")
    return value


_integer.__name__, _finite.__name__ = "an integer", "a finite number"  # argparse's messages
_SIMPLE: dict[Any, Callable[[str], Any]] = {int: _integer, float: _finite, str: str}


def run_fields(config_cls: type) -> list[Field]:
    """The fields of the dataclass ``config_cls`` whose metadata has ``"run": True``."""
    return [f for f in fields(config_cls) if f.metadata.get(RUN, False)]


def flag(f: Field) -> str:
    """A field's flag: ``--field-name``."""
    return "--" + f.name.replace("_", "-")


def _default(f: Field) -> Any:
    if f.default is not MISSING:
        return f.default
    if f.default_factory is not MISSING:
        return f.default_factory()
    raise TypeError(f"{f.name} has no default; a command-line option needs one")


def _without_none(annotation: Any) -> Any:
    """``X`` for ``X | None`` (or ``Optional[X]``), else ``annotation``."""
    if typing.get_origin(annotation) in (typing.Union, types.UnionType):
        rest = [a for a in typing.get_args(annotation) if a is not type(None)]
        if len(rest) == 1:
            return rest[0]
    return annotation


def _settings(f: Field, annotation: Any) -> dict[str, Any]:
    """The keyword arguments of ``add_argument`` for the field ``f`` of type ``annotation``."""
    kind = _without_none(annotation)
    settings: dict[str, Any] = {"dest": f.name, "default": _default(f)}
    if f.metadata.get(HELP):
        settings["help"] = f.metadata[HELP]
    choices = f.metadata.get(CHOICES)
    if kind is bool:
        return settings | {"action": argparse.BooleanOptionalAction}
    if typing.get_origin(kind) is tuple and typing.get_args(kind) == (int, Ellipsis):
        return settings | {"type": cli.lattice}
    if kind in _SIMPLE:
        if choices is not None:
            settings["choices"] = tuple(choices)
        return settings | {"type": _SIMPLE[kind]}
    raise TypeError(
        f"{f.name}: a command-line option cannot be made from {annotation!r}; run fields may "
        "be int, float, bool, str (with metadata 'choices' or without) or tuple[int, ...], "
        "each also with | None"
    )


def add_config_options(
    parser: argparse.ArgumentParser | argparse._ArgumentGroup,
    config_cls: type,
    *,
    skip: Iterable[str] = (),
    defaults: Mapping[str, Any] | None = None,
    notes: Mapping[str, str] | None = None,
) -> list[str]:
    """Add a flag to ``parser`` for every field of ``config_cls`` marked ``"run": True``.

    Args:
        skip: fields to leave out (a program that takes them otherwise).
        defaults: a program's own defaults by field name, instead of the fields' (None: the
            program decides after parsing, e.g. by env).
        notes: text added to a field's help, by field name (what the program does with it).
    Returns:
        The names of the fields (the destinations of the flags), in the dataclass's order.
    Raises:
        TypeError: a marked field whose type has no command-line form, or without a default;
            ValueError: a name in ``skip`` or ``defaults`` that is no marked field.
    """
    marked = run_fields(config_cls)
    own, noted = dict(defaults or {}), dict(notes or {})
    unknown = (set(skip) | set(own) | set(noted)) - {f.name for f in marked}
    if unknown:
        valid = ", ".join(f.name for f in marked)
        raise ValueError(f"{sorted(unknown)} are no run fields of {config_cls.__name__}: {valid}")
    hints = typing.get_type_hints(config_cls)
    names = []
    for f in marked:
        if f.name in skip:
            continue
        settings = _settings(f, hints[f.name])
        if f.name in own:
            settings["default"] = own[f.name]
        if f.name in noted:
            settings["help"] = f"{settings.get('help', '')} ({noted[f.name]})".lstrip()
        elif settings["default"] is not None and settings.get("action") is None:
            shown = settings["default"]  # BooleanOptionalAction shows its own default
            shown = format_lattice(shown) if isinstance(shown, tuple) else shown
            settings["help"] = f"{settings.get('help', '')} (default: {shown})".lstrip()
        parser.add_argument(flag(f), **settings)
        names.append(f.name)
    return names


def config_values(
    args: argparse.Namespace, config_cls: type, *, skip: Iterable[str] = ()
) -> dict[str, Any]:
    """The values of ``config_cls``'s marked fields (but ``skip``) in the parsed ``args``, by
    field name: keyword arguments of ``config_cls``."""
    return {f.name: getattr(args, f.name) for f in run_fields(config_cls) if f.name not in skip}
