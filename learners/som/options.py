"""What the two map configurations share: how an option is declared, the checks of its value, and
the checkpoint entries generated from the declarations.

An option is one dataclass field declared with :func:`option`; its metadata is the one place that
says what it means and how it is stored, and the command-line programs and a training run's
configuration read the same metadata:

- ``"help"``: one line saying what the option does;
- ``"choices"``: the values it takes (a tuple of str), absent when it is not a choice;
- ``"run"``: whether a training run exposes and stores the option;
- ``"added_later"``: the value of files written before the option existed (absent: such files
  do not exist, the entry is required);
- ``"stored_as"``, ``"stored_values"``: the entry name and values a checkpoint writes when they
  differ from the option's (a renamed option keeps its files);
- ``"omit_default"``: the entry is left out of a checkpoint while the option holds its default
  (files written before it existed stay the same bytes);
- ``"run_as"``: the name a training run, its sweep axes and its checkpoint give the option when
  it is not the entry's (the grasp map's ``position_lattice`` is a run's ``lattice``).

:func:`entries` and :func:`from_entries` turn a configuration into a checkpoint's JSON entries
and back, from the fields' annotations and metadata: schedules go together into one
``"schedules"`` entry at the place of the first, tuples become lists.
"""

from __future__ import annotations

import dataclasses
import types
import typing
from collections.abc import Callable
from dataclasses import MISSING, Field, asdict, fields
from typing import Any, TypeVar

from learners.guards import option_number
from learners.som.schedules import Continual, Schedule

#: The entry that holds every schedule of a configuration, as {name: [initial, final]}.
SCHEDULES_ENTRY = "schedules"
#: The reasons a map counts skipped trials by (its checkpoint's ``skipped`` entry).
SKIP_REASONS = ("not_visible", "small_dv")
#: No number of a map's options lies beyond this (a schedule's ends, a distance, a noise level):
#: σ of 10^9 lattice units or 10^9 px is damage or a typing error, not a setting.
OPTION_LIMIT = 1e9

T = TypeVar("T")


def option(
    default: Any,
    help: str,  # the metadata key, as argparse names it
    *,
    choices: tuple[str, ...] | None = None,
    run: bool = False,
    added_later: Any = MISSING,
    stored_as: str | None = None,
    stored_values: dict[str, str] | None = None,
    omit_default: bool = False,
    run_as: str | None = None,
) -> Any:
    """A configuration field with its metadata (the module docstring lists the keys)."""
    metadata: dict[str, Any] = {"help": help, "run": run}
    if choices is not None:
        metadata["choices"] = choices
    if added_later is not MISSING:
        metadata["added_later"] = added_later
    if stored_as is not None:
        metadata["stored_as"] = stored_as
    if stored_values is not None:
        metadata["stored_values"] = stored_values
    if omit_default:
        metadata["omit_default"] = True
    if run_as is not None:
        metadata["run_as"] = run_as
    return dataclasses.field(default=default, metadata=metadata)


def run_options(config_cls: type) -> tuple[Field[Any], ...]:
    """The fields of ``config_cls`` that a training run exposes and stores (metadata "run")."""
    return tuple(f for f in fields(config_cls) if f.metadata.get("run"))


def run_key(f: Field[Any]) -> str:
    """The name a training run gives the run option ``f``: its ``run_as``, else its entry's."""
    return f.metadata.get("run_as", f.metadata.get("stored_as", f.name))


def run_spelling(f: Field[Any], value: Any) -> Any:
    """The value of the run option ``f`` as a run spells it (a sweep axis, a checkpoint)."""
    if isinstance(value, tuple):
        return list(value)
    return f.metadata["stored_values"][value] if "stored_values" in f.metadata else value


def run_entries(config: Any) -> dict[str, Any]:
    """The run options of ``config`` as a training run stores them, by :func:`run_key`, left out
    while default where the option says so (``omit_default``)."""
    return {
        run_key(f): run_spelling(f, getattr(config, f.name))
        for f in run_options(type(config))
        if not (f.metadata.get("omit_default") and getattr(config, f.name) == f.default)
    }


def run_defaults(config_cls: type) -> dict[str, Any]:
    """:func:`run_key` -> the run option's default, as a run spells it."""
    return {run_key(f): run_spelling(f, f.default) for f in run_options(config_cls)}


def from_run_settings(config_cls: Callable[..., T], settings: dict[str, Any]) -> T:
    """``config_cls`` with the run options in ``settings`` (by :func:`run_key`, spelled as a run
    spells them: lists for tuples, stored values), its other options at their defaults; a key
    that is not a run option of ``config_cls`` is left to the caller. ValueError for a value
    the option does not take (the config's own checks)."""
    options: dict[str, Any] = {}
    for f in run_options(config_cls):  # type: ignore[arg-type]
        key = run_key(f)
        if key not in settings:
            continue
        value = settings[key]
        if isinstance(value, list):
            value = tuple(value)
        if "stored_values" in f.metadata:
            named = {v: k for k, v in f.metadata["stored_values"].items()}
            if value not in named:
                raise ValueError(f"unknown {key} {value!r}; valid: {', '.join(named)}")
            value = named[value]
        options[f.name] = value
    return config_cls(**options)


def field_types(config_cls: type) -> dict[str, Any]:
    """The fields' annotations of ``config_cls`` as types (the module uses postponed ones)."""
    return typing.get_type_hints(config_cls)


# ------------------------------------------------------------------------------------ checks
def number(
    owner: str, name: str, value: Any, kind: type, least: float | None = None,
    most: float | None = None, strict: bool = False,
) -> Any:  # fmt: skip
    """``value`` as ``kind`` (int or float) in [least, most] (``strict``: > least), else
    ValueError naming ``owner.name``."""
    value = option_number(owner, name, value, kind)
    if least is not None and (value < least or (strict and value == least)):
        raise ValueError(f"{owner}.{name} must be {'>' if strict else '>='} {least}, got {value}")
    if most is not None and value > most:
        raise ValueError(f"{owner}.{name} must be <= {most:g}, got {value:.3g}")
    return value


def schedule(owner: str, name: str, value: Any) -> Schedule:
    """``value`` (a Schedule, an (initial, final) pair or one number) as a Schedule, else
    ValueError naming ``owner.name``."""
    try:
        result = Schedule.of(value)
    except ValueError as exc:
        raise ValueError(f"{owner}.{name}: {exc}") from None
    except TypeError:
        raise ValueError(
            f"{owner}.{name} must be a Schedule, an (initial, final) pair or a number, "
            f"got {value!r}"
        ) from None
    for end in (result.initial, result.final):
        number(owner, name, end, float, most=OPTION_LIMIT)
    return result


def check_common(config: Any) -> None:
    """The checks every map configuration makes of its fields, from their annotations: a
    choice among its declared values, a flag True or False, a schedule converted (rates in
    [0, 1] for ``eps`` and ``eps_out``); the converted values are written into the frozen
    ``config``."""
    owner = type(config).__name__
    kinds = field_types(type(config))
    for f in fields(config):
        value = getattr(config, f.name)
        choices = f.metadata.get("choices")
        if choices is not None and value not in choices:
            raise ValueError(f"unknown {f.name} {value!r}; valid: {', '.join(choices)}")
        if kinds[f.name] is bool and not isinstance(value, bool):
            raise ValueError(f"{owner}.{f.name} must be True or False, got {value!r}")
        if kinds[f.name] is Schedule:
            object.__setattr__(config, f.name, schedule(owner, f.name, value))
    for name in ("eps", "eps_out"):
        rate = getattr(config, name)
        if max(rate.initial, rate.final) > 1.0:
            raise ValueError(f"{name} is a learning rate in [0, 1], got {rate}")


def schedule_names(config_cls: type) -> tuple[str, ...]:
    """The fields of ``config_cls`` that are schedules, in declaration order."""
    kinds = field_types(config_cls)
    return tuple(f.name for f in fields(config_cls) if kinds[f.name] is Schedule)


# ------------------------------------------------------------------------------- checkpoint
def entries(config: Any) -> dict[str, Any]:
    """The configuration as a checkpoint's JSON entries (module docstring)."""
    kinds = field_types(type(config))
    out: dict[str, Any] = {}
    for f in fields(config):
        value = getattr(config, f.name)
        if f.metadata.get("omit_default") and value == f.default:
            continue
        if kinds[f.name] is Schedule:
            out.setdefault(SCHEDULES_ENTRY, {})[f.name] = [value.initial, value.final]
            continue
        if isinstance(value, tuple):
            value = list(value)
        elif isinstance(value, Continual):
            value = asdict(value)
        elif "stored_values" in f.metadata:
            value = f.metadata["stored_values"][value]
        out[f.metadata.get("stored_as", f.name)] = value
    return out


def _entry_type(kind: Any) -> type | tuple[type, ...]:
    """The JSON type an entry of a field annotated ``kind`` holds."""
    if kind is float:
        return (int, float)
    if typing.get_origin(kind) is tuple:
        return list
    if typing.get_origin(kind) in (typing.Union, types.UnionType):
        return dict  # Continual | None: absent for None
    return kind


def from_entries(config_cls: Callable[..., T], stored: dict[str, Any]) -> T:
    """The configuration ``config_cls`` stored by :func:`entries` (other entries are ignored).

    An entry missing from the file takes the field's ``added_later`` value, or its default when
    it is left out while default (``omit_default``). Raises ValueError naming the entry that is
    missing or of the wrong type or value (a damaged or foreign file).
    """
    kinds = field_types(config_cls)  # type: ignore[arg-type]
    options: dict[str, Any] = {}
    schedules: dict[str, Any] = {}
    scheduled = [f for f in fields(config_cls) if kinds[f.name] is Schedule]  # type: ignore[arg-type]
    for f in fields(config_cls):  # type: ignore[arg-type]
        if kinds[f.name] is Schedule:
            continue
        key = f.metadata.get("stored_as", f.name)
        if key not in stored:
            if "added_later" in f.metadata:
                options[f.name] = f.metadata["added_later"]
            elif not f.metadata.get("omit_default"):
                raise ValueError(f"config entry {key!r} is missing")
            continue
        value, kind = stored[key], _entry_type(kinds[f.name])
        wrong_bool = isinstance(value, bool) and kind is not bool
        if not isinstance(value, kind) or wrong_bool:
            raise ValueError(f"config entry {key!r} is {value!r}, not of type {kind}")
        if "stored_values" in f.metadata:
            named = {v: k for k, v in f.metadata["stored_values"].items()}
            if value not in named:
                raise ValueError(f"unknown {key} {value!r}; valid: {', '.join(named)}")
            value = named[value]
        elif kind is dict:
            try:
                value = Continual(**typing.cast(dict[str, Any], value))
            except TypeError as exc:
                raise ValueError(f"config entry {key!r} is damaged ({exc})") from None
        options[f.name] = value
    if scheduled:
        schedules = stored.get(SCHEDULES_ENTRY, MISSING)
        if not isinstance(schedules, dict):
            raise ValueError(f"config entry {SCHEDULES_ENTRY!r} is {schedules!r}, not a dict")
        names = {f.name for f in scheduled}
        for name, pair in schedules.items():
            ok = isinstance(pair, list) and len(pair) == 2
            if name not in names or not ok or any(isinstance(x, bool) for x in pair):
                raise ValueError(f"config entry {SCHEDULES_ENTRY!r} holds {name!r}: {pair!r}")
            options[name] = tuple(pair)
        for f in scheduled:
            if f.name not in schedules:
                if "added_later" not in f.metadata:
                    raise ValueError(f"config entry {SCHEDULES_ENTRY!r} lacks {f.name!r}")
                options[f.name] = f.metadata["added_later"]
    return config_cls(**options)


def positive_shape(owner: str, name: str, value: Any) -> tuple[int, ...]:
    """``value`` as a tuple of integer sizes >= 1 (empty if it is not a sequence of numbers)."""
    try:
        shape = tuple(number(owner, name, n, int) for n in value)
    except TypeError:
        shape = ()
    return shape if shape and min(shape) >= 1 else ()
