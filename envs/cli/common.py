"""What every script shares: help that shows the whole description and every default, argument
types that check their values, line-buffered output, and user errors as one line (exit 2)."""

from __future__ import annotations

import argparse
import math
import os
import sys
from collections.abc import Callable, Iterable, Sequence
from typing import NoReturn, TypeVar

from tqdm import tqdm

from envs import sizes
from models.puma560.grasp import OrientationRange

T = TypeVar("T")
#: Exit status of a command-line mistake (as argparse uses).
USAGE_ERROR = 2


def _help_with_default(action: argparse.Action) -> str:
    """An option's help with its default appended (sizes and lattices as ``WxH``, ``12x7x4``),
    unless the help already speaks of its default or the option is required or a flag."""
    text, default = action.help or "", action.default
    if action.required:
        return f"{text} (required)".strip()
    if (
        "default" in text
        or default is argparse.SUPPRESS
        or isinstance(default, bool)
        or not action.option_strings
    ):
        return text
    if default is None or default == []:
        return f"{text} (no default)".strip()
    shown = "x".join(map(str, default)) if isinstance(default, tuple) else str(default)
    return f"{text} (default: {shown.replace('%', '%%')})".strip()


class _Parser(argparse.ArgumentParser):
    """Help for every option (its default at least), the description printed as written, and a
    command-line mistake as one line."""

    def add_argument(self, *args, **kwargs):  # type: ignore[override]
        action = super().add_argument(*args, **kwargs)
        if action.help is not argparse.SUPPRESS:
            action.help = _help_with_default(action)
        return action

    def error(self, message: str) -> NoReturn:
        self.exit(USAGE_ERROR, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def parser(doc: str | None) -> argparse.ArgumentParser:
    """An ArgumentParser whose help shows ``doc`` (the script's docstring) and the defaults."""
    return _Parser(description=doc, formatter_class=argparse.RawDescriptionHelpFormatter)


def add_count(
    parser: argparse.ArgumentParser, flag: str, default: int, help: str, *, least: int = 1
) -> argparse.Action:
    """A program's own count option: an integer >= ``least`` (1 or 0) with a default."""
    kind = {1: positive_int, 0: nonnegative_int}[least]
    return parser.add_argument(flag, type=kind, default=default, help=help)


def _number(kind: Callable[[str], T], test: Callable[[T], bool], wanted: str):
    def parse(text: str) -> T:
        try:
            value = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"wants {wanted}, got {text!r}") from None
        if not test(value):
            raise argparse.ArgumentTypeError(f"wants {wanted}, got {text!r}")
        return value

    parse.__name__ = wanted  # argparse names the type in its messages
    return parse


positive_int = _number(int, lambda n: n > 0, "an integer > 0")
nonnegative_int = _number(int, lambda n: n >= 0, "an integer >= 0")
positive_float = _number(float, lambda x: math.isfinite(x) and x > 0, "a finite number > 0")
nonnegative_float = _number(float, lambda x: math.isfinite(x) and x >= 0, "a finite number >= 0")


def _text_type(parse: Callable[[str], T], name: str) -> Callable[[str], T]:
    """An argparse type from a parser of text that raises ValueError with the message."""

    def convert(text: str) -> T:
        try:
            return parse(text)
        except ValueError as exc:
            raise argparse.ArgumentTypeError(str(exc)) from None

    convert.__name__ = name
    return convert


#: ``--image-size 640x480``: (width, height) px (:func:`envs.sizes.parse_size`).
image_size = _text_type(sizes.parse_size, "WIDTHxHEIGHT")
#: ``--lattice 12x7x4``: the shape as a tuple (:func:`envs.sizes.parse_lattice`).
lattice = _text_type(sizes.parse_lattice, "lattice")
#: ``--orientations yaw:90,tilt:45`` or ``ball:30``: the grasp task's range, as its spelling
#: (:meth:`models.puma560.grasp.OrientationRange.parse`).
orientation_range = _text_type(
    lambda text: OrientationRange.parse(text).spec(), "yaw:DEG,tilt:DEG or ball:DEG"
)
#: ``--big 40x40x40`` or ``--big none``: a lattice or None.
lattice_or_none = _text_type(
    lambda text: None if text == "none" else sizes.parse_lattice(text), "lattice or none"
)


def check_image_size(env_id: str, size: tuple[int, int]) -> None:
    """Exit with one line (status 2) unless ``size`` (width, height) px suits the cameras of
    ``env_id`` (a registered reach env)."""
    from envs.harness.training import check_env_image_size

    try:
        check_env_image_size(env_id, *size)
    except sizes.ImageSizeError as exc:
        fail(f"--image-size for {env_id}: {exc}")


def progress(items: Iterable[T], what: str, unit: str) -> Iterable[T]:
    """``items`` with a progress bar on stderr (shown for loops that take a while)."""
    return tqdm(items, desc=what, unit=unit, file=sys.stderr, mininterval=0.5, leave=False)


def progress_bar(total: int, what: str, unit: str) -> tqdm:
    """A bar like :func:`progress` of ``total`` steps, advanced by its ``update()``, for work
    that is not a loop of the caller's (a context manager: removed when done)."""
    return tqdm(total=total, desc=what, unit=unit, file=sys.stderr, mininterval=0.5, leave=False)


def given_options(p: argparse.ArgumentParser, argv: Sequence[str] | None) -> set[str]:
    """The destinations of the options written on the command line (not left at default)."""
    actions = p._actions  # argparse has no public way to ask this
    defaults = [a.default for a in actions]
    try:
        for a in actions:
            a.default = argparse.SUPPRESS
        return set(vars(p.parse_args(argv)))
    finally:
        for a, default in zip(actions, defaults, strict=True):
            a.default = default


def user_errors() -> tuple[type[BaseException], ...]:
    """The project's errors that mean "your input or setup", not "a bug"."""
    from envs.harness.run_folder import RunFolderError
    from envs.sensing.rendering import RenderingUnavailableError
    from learners.persistence import CheckpointError, OutputError

    return (
        CheckpointError,
        RunFolderError,
        RenderingUnavailableError,
        sizes.ImageSizeError,
        OutputError,
    )


def fail(message: str) -> None:
    """Print ``prog: error: message`` as one line and exit with status 2."""
    print(f"{os.path.basename(sys.argv[0])}: error: {message}", file=sys.stderr)
    raise SystemExit(USAGE_ERROR)


def run(main: Callable[[], object]) -> None:
    """Run a script's ``main`` with line-buffered stdout and user errors as one line, exit 2;
    a write that failed for lack of space or permission is one too (naming its file)."""
    from learners.persistence import output_error

    sys.stdout.reconfigure(line_buffering=True)
    errors = user_errors()
    try:
        main()
    except errors as exc:
        fail(str(exc))
    except OSError as exc:
        error = output_error(exc, "the output")
        if error is None:
            raise
        fail(str(error))


def entry_point(main: Callable[[], object]) -> Callable[[], None]:
    """A program's console entry point: its ``main`` (which reads ``sys.argv``) under
    :func:`run`."""

    def run_main() -> None:
        run(main)

    return run_main
