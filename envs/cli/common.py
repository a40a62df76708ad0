"""What every script shares: help that shows the whole description and every default, argument
types that check their values (counts bounded, output paths usable), line-buffered output, user
errors as one short line (exit 2) on a line of its own, and Ctrl-C as one line (exit 130)."""

from __future__ import annotations

import argparse
import math
import os
import signal
import sys
import threading
from collections.abc import Callable, Iterable, Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from types import FrameType
from typing import Any, NoReturn, TypeVar

from tqdm import tqdm

from envs import sizes
from envs.harness.ray_cluster import check_address
from envs.limits import MAX_COUNT, MAX_ERRORS, MAX_FINE_MOVES, MAX_TARGETS  # noqa: F401
from models.puma560.grasp import OrientationRange

T = TypeVar("T")
#: Exit status of a command-line mistake (as argparse uses).
USAGE_ERROR = 2
#: Exit status after Ctrl-C (the shell's 128 + SIGINT).
INTERRUPTED = 128 + signal.SIGINT
#: Longest error message printed (characters); a longer one keeps its start and its end.
MAX_MESSAGE = 200


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
        _close_bars()
        said = f"{self.prog}: error: "
        text = short(f"{message} (see {self.prog} --help)", MAX_MESSAGE - len(said))
        self.exit(USAGE_ERROR, f"{said}{text}\n")

    def parse_args(self, args=None, namespace=None):  # type: ignore[override]
        """Parsed as argparse does; then output paths (:func:`out_folder`, :func:`out_file`,
        defaults too) are checked: a file where a folder is needed, a parent that is not a
        folder, a folder that cannot be written. Nothing is created."""
        parsed = super().parse_args(args, namespace)
        for action in self._actions:
            value = getattr(parsed, action.dest, None)
            if action.type in (out_folder, out_file) and value is not None:
                check_out(action.option_strings[0], Path(value), folder=action.type is out_folder)
        return parsed


def parser(doc: str | None) -> argparse.ArgumentParser:
    """An ArgumentParser whose help shows ``doc`` (the script's docstring) and the defaults."""
    return _Parser(description=doc, formatter_class=argparse.RawDescriptionHelpFormatter)


def add_count(
    parser: argparse.ArgumentParser, flag: str, default: int, help: str, *, least: int = 1
) -> argparse.Action:
    """A program's own count option: an integer from ``least`` (1 or 0) to ``MAX_COUNT`` with a
    default."""
    kind = {1: positive_int, 0: nonnegative_int}[least]
    return parser.add_argument(flag, type=kind, default=default, help=help)


def _shown(text: str) -> str:
    """A command-line value as an error quotes it: its repr, at most 40 characters."""
    return repr(text) if len(text) <= 40 else repr(text[:30]) + f"... ({len(text)} characters)"


def _number(kind: Callable[[str], T], test: Callable[[T], bool], wanted: str):
    def parse(text: str) -> T:
        try:
            value = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"wants {wanted}, got {_shown(text)}") from None
        if not test(value):
            raise argparse.ArgumentTypeError(f"wants {wanted}, got {_shown(text)}")
        return value

    parse.__name__ = wanted  # argparse names the type in its messages
    return parse


def count(least: int = 1, most: int = MAX_COUNT, why: str = "") -> Callable[[str], int]:
    """An argparse type: an integer from ``least`` to ``most``; ``why`` (the bound's reason)
    follows the upper bound in the message."""
    wanted = "an integer > 0" if least == 1 else f"an integer >= {least}"
    below = _number(int, lambda n: n >= least, wanted)
    above = f"at most {most:,}" + (f" ({why})" if why else "")

    def parse(text: str) -> int:
        value = below(text)
        if value > most:
            raise argparse.ArgumentTypeError(f"wants {above}, got {_shown(text)}")
        return value

    parse.__name__ = f"an integer from {least} to {most}"
    return parse


positive_int = count(1)
nonnegative_int = count(0)
#: A seed of numpy's generators: any integer >= 0.
seed = _number(int, lambda n: n >= 0, "an integer >= 0")
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


def _lattice(text: str) -> tuple[int, ...]:
    """:func:`envs.sizes.parse_lattice`, and no more neurons than fit in memory."""
    from learners.som.config import MAX_NEURONS

    shape = sizes.parse_lattice(text)
    if math.prod(shape) > MAX_NEURONS:
        raise ValueError(
            f"{_shown(text)} has {math.prod(shape):,} neurons; at most {MAX_NEURONS:,} fit in "
            "memory (40x40x40 has 64,000)"
        )
    return shape


#: ``--lattice 12x7x4``: the shape as a tuple (:func:`envs.sizes.parse_lattice`), of at most
#: ``learners.som.config.MAX_NEURONS`` neurons.
lattice = _text_type(_lattice, "lattice")
#: ``--orientations yaw:90,tilt:45`` or ``ball:30``: the grasp task's range, as its spelling
#: (:meth:`models.puma560.grasp.OrientationRange.parse`).
orientation_range = _text_type(
    lambda text: OrientationRange.parse(text).spec(), "yaw:DEG,tilt:DEG or ball:DEG"
)
#: ``--address auto``, ``HOST:PORT`` or ``local``: a Ray cluster's address
#: (:func:`envs.harness.ray_cluster.check_address`).
ray_address = _text_type(check_address, "Ray address")
#: ``--big 40x40x40`` or ``--big none``: a lattice or None.
lattice_or_none = _text_type(
    lambda text: None if text == "none" else _lattice(text), "lattice or none"
)


def out_folder(text: str) -> Path:
    """An argparse type: an output folder, checked after parsing (:func:`check_out`)."""
    return Path(text)


def out_file(text: str) -> Path:
    """An argparse type: an output file, checked after parsing (:func:`check_out`)."""
    return Path(text)


def check_out(flag: str, path: Path, folder: bool) -> None:
    """Exit with one line (status 2) unless ``path`` can become the output folder (``folder``)
    or file: not a file where a folder is needed nor a folder where a file is, under a folder
    (not a file) that can be written (a probe file, removed: nothing is created)."""
    from envs.harness.run_folder import check_writable
    from learners.persistence import OutputError

    if folder and path.exists() and not path.is_dir():
        fail(f"{flag} {path} is a file, not a folder; choose another {flag}")
    if not folder and path.is_dir():
        fail(f"{flag} {path} is a folder; give the name of a file (in it or elsewhere)")
    existing = next(p for p in path.absolute().parents if p.exists())
    if not existing.is_dir():
        fail(f"{flag} {path}: {existing} is a file, not a folder; choose another {flag}")
    try:
        check_writable(path if folder else path.parent)
    except OutputError as exc:
        fail(str(exc))


@contextmanager
def removed_if_refused(folder: Path) -> Iterator[None]:
    """Remove ``folder`` and the parents it created if the block fails (a user error, Ctrl-C,
    any exception) and leaves them empty: a refused run leaves no folder behind."""
    made = [p for p in (folder, *folder.parents) if not p.exists()]  # deepest first
    try:
        yield
    except BaseException:
        for path in made:
            try:
                path.rmdir()
            except OSError:  # not empty (work was kept) or already gone
                break
        raise


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
    from envs.harness.ray_cluster import RayUnavailableError
    from envs.harness.run_folder import RunFolderError
    from envs.sensing.rendering import RenderingUnavailableError
    from learners.persistence import CheckpointError, OutputError

    return (
        CheckpointError,
        RunFolderError,
        RenderingUnavailableError,
        sizes.ImageSizeError,
        OutputError,
        RayUnavailableError,
    )


def short(message: str, limit: int = MAX_MESSAGE) -> str:
    """``message`` on one line of at most ``limit`` characters besides the folders of the paths
    it names (a path is not cut for being long): line breaks become spaces, and a longer one
    keeps its start (what) and its end (what to do) around " ... ". Messages should be short
    where they are made; this is the limit."""
    text = " ".join(message.split())
    limit += sum(len(word) - len(os.path.basename(word)) for word in text.split() if "/" in word)
    if len(text) <= limit:
        return text
    head = limit * 3 // 5
    return f"{text[:head]} ... {text[head + 5 - limit :]}"


def _close_bars() -> None:
    """Close the progress bars still shown, so that what follows starts on a line of its own."""
    for bar in list(getattr(tqdm, "_instances", ())):  # tqdm keeps no public list
        bar.close()


def _say(message: str) -> None:
    """Print ``prog: message`` on stderr as one line of at most ``MAX_MESSAGE`` characters
    (:func:`short`), on a line of its own after any progress bar."""
    _close_bars()
    said = f"{os.path.basename(sys.argv[0])}: "
    print(said + short(message, MAX_MESSAGE - len(said)), file=sys.stderr)


def fail(message: str) -> NoReturn:
    """Print ``prog: error: message`` as one short line and exit with status 2."""
    _say(f"error: {message}")
    raise SystemExit(USAGE_ERROR)


def run(main: Callable[[], object]) -> None:
    """Run a script's ``main`` with line-buffered stdout and user errors as one line, exit 2;
    a write that failed for lack of space or permission is one too (naming its file). Ctrl-C
    (where a program does not stop on it itself) is one line, exit 130, also when a library
    turned it into another error."""
    from learners.persistence import output_error

    sys.stdout.reconfigure(line_buffering=True)
    errors = user_errors()
    interrupts: list[int] = []

    def interrupt(signum: int, frame: FrameType | None) -> None:
        interrupts.append(signum)
        signal.default_int_handler(signum, frame)  # raises KeyboardInterrupt

    try:
        if threading.current_thread() is threading.main_thread():
            # Ctrl-C raises KeyboardInterrupt from here on (visuomotor_startup.py exits before).
            signal.signal(signal.SIGINT, interrupt)
        main()
    except errors as exc:
        if not interrupts:
            fail(str(exc))
        _stopped()  # a library turned the interrupt into an error (a GL start cut short)
    except KeyboardInterrupt:
        _stopped()
    except OSError as exc:
        if interrupts:
            _stopped()  # a call the interrupt cut short
        error = output_error(exc, "the output")
        if error is None:
            raise
        fail(str(error))


def _stopped() -> NoReturn:
    """End a program stopped by Ctrl-C: one line, exit 130."""
    _say("interrupted (Ctrl-C); outputs not finished were not kept")
    # An object the interrupt left half-built (numba's LLVM pass manager while it compiled)
    # fails in its finalizer at exit; that message would follow the one line.
    sys.unraisablehook = _ignore_after_interrupt
    raise SystemExit(INTERRUPTED) from None


def _ignore_after_interrupt(unraisable: Any) -> None:
    """``sys.unraisablehook`` of a program ending on Ctrl-C: errors in finalizers are dropped."""


def entry_point(main: Callable[[], object]) -> Callable[[], None]:
    """A program's console entry point: its ``main`` (which reads ``sys.argv``) under
    :func:`run`."""

    def run_main() -> None:
        run(main)

    return run_main
