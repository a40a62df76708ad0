"""One way to write image sizes and lattice shapes, in Python, on command lines and in sweeps.

An image size is width × height in pixels, the way people say "640×480": in Python the keywords
``width=`` and ``height=`` (as Gymnasium's MuJoCo envs take them), in text ``"640x480"``. Arrays
stay (rows, columns) = (height, width), as numpy and OpenCV have them. A lattice shape is written
``"12x7x4"`` everywhere: command lines, sweep grids, printed tables and run folder names.

The sensing cameras of a scene have a fixed aspect ratio (``envs.robots.RobotSpec.image_aspect``):
an image of another shape would stretch or crop their field of view, so it is refused.
"""

from __future__ import annotations

from collections.abc import Sequence
from numbers import Integral
from typing import Any

#: Between the numbers of a size or a lattice shape in text.
SEPARATOR = "x"
#: Smallest sensing image side, px (a marker must cover a few pixels).
MIN_IMAGE_SIDE = 16


class ImageSizeError(ValueError):
    """An image size that is not whole pixels, too small, or not the cameras' aspect ratio."""


def _whole(n: Any) -> bool:
    return isinstance(n, Integral) and not isinstance(n, bool)


def check_image_size(width: Any, height: Any, aspect: tuple[int, int]) -> tuple[int, int]:
    """(width, height) as ints, each >= MIN_IMAGE_SIDE and in the cameras' ``aspect``
    (width, height) ratio; else ImageSizeError naming the size asked for and the aspect."""
    if not (_whole(width) and _whole(height)) or min(width, height) < MIN_IMAGE_SIDE:
        raise ImageSizeError(
            f"width and height must be whole numbers of pixels >= {MIN_IMAGE_SIDE}, e.g. "
            f"width=320, height=240; got width={width!r}, height={height!r}"
        )
    across, down = aspect
    if width * down != height * across:
        raise ImageSizeError(
            f"image size {format_size(width, height)} (width x height) does not have the "
            f"cameras' aspect ratio {across}:{down}; choose e.g. "
            f"{format_size(across * 80, down * 80)} or {format_size(across * 160, down * 160)}"
        )
    return int(width), int(height)


def parse_size(text: str) -> tuple[int, int]:
    """``"640x480"`` -> (width, height) = (640, 480); ValueError for anything else."""
    try:
        width, height = (int(n) for n in str(text).lower().split(SEPARATOR))
    except ValueError:
        raise ValueError(
            f"an image size is WIDTHxHEIGHT in pixels like 640x480, got {text!r}"
        ) from None
    return width, height


def format_size(width: int, height: int) -> str:
    """(640, 480) -> ``"640x480"``."""
    return f"{width}{SEPARATOR}{height}"


def parse_lattice(text: str) -> tuple[int, ...]:
    """``"12x7x4"`` -> (12, 7, 4); ValueError (with the way to write it) for anything else."""
    text = str(text).strip().lower()
    hint = f"a lattice is written like 12x7x4, got {text!r}"
    if all(part.strip().isdigit() for part in text.split(",")):  # 12,7,4: the old way
        hint += f"; write {SEPARATOR.join(part.strip() for part in text.split(','))}"
    try:
        shape = tuple(int(n) for n in text.split(SEPARATOR))
    except ValueError:
        raise ValueError(hint) from None
    if min(shape) < 1:
        raise ValueError(f"lattice sizes must be >= 1, got {text!r}")
    return shape


def format_lattice(shape: Sequence[int]) -> str:
    """(12, 7, 4) -> ``"12x7x4"``."""
    return SEPARATOR.join(str(int(n)) for n in shape)
