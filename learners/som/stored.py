"""What a saved map holds beside its options, read as strictly as construction checks it: the
counts (t, the skipped trials), the generator's state and the arrays (dtype, shape, finiteness,
range). Both maps' loaders (``VisuomotorSOM.load``, ``HierarchicalSOM.load``) and the fine-move
memory's call these; each raises ValueError with one short line naming the entry (shapes and
ranges, never an array's values), which a loader turns into a ``CheckpointError`` naming the
file.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from learners.guards import bounds
from learners.som.options import SKIP_REASONS

#: |A_ij| beyond this many joint spans per input span is refused as damage: a Widrow-Hoff step
#: changes A by at most a joint span per |Δv| >= ``min_dv``, so learning never gets near it.
A_LIMIT = 1e9
#: Counts (trials learned, skipped, scheduled) above this are damage: 2^53 trials would take a
#: thousand years at a million a second, and every count up to it is exact as a float.
COUNT_LIMIT = 2**53
#: The numpy bit generators a saved map may name: those whose state is plain integers, which
#: the map's JSON configuration holds (the others' states hold arrays).
BIT_GENERATORS = ("PCG64", "PCG64DXSM")
#: PCG's state and increment are 128-bit integers; its buffered half draw a 32-bit one.
_PCG_BITS, _UINT_BITS = 128, 32
#: The continual mode's running means are of log errors: |log e| beyond this is no float error.
_LOG_LIMIT = 710.0


def count(name: str, value: Any, least: int = 0) -> int:
    """``value`` as a count in [least, ``COUNT_LIMIT``] (an int, not a bool), else ValueError."""
    if not isinstance(value, int) or isinstance(value, bool) or not least <= value <= COUNT_LIMIT:
        shown = value if isinstance(value, (int, float, bool)) else type(value).__name__
        raise ValueError(f"{name} = {shown!r:.40} is not a count in [{least}, 2**53]")
    return value


def counts(stored: dict[str, Any]) -> tuple[int, dict[str, int]]:
    """The ``t`` and ``skipped`` entries of a saved map: a count, and a count per reason of
    ``SKIP_REASONS``."""
    t, skipped = count("t", stored["t"]), stored["skipped"]
    if not isinstance(skipped, dict) or sorted(skipped) != sorted(SKIP_REASONS):
        raise ValueError(f"skipped is not the counts of {', '.join(SKIP_REASONS)}")
    return t, {reason: count(f"skipped[{reason!r}]", skipped[reason]) for reason in SKIP_REASONS}


def generator(state: Any, name: str = "rng_state") -> np.random.Generator:
    """A Generator in the state of the entry ``name``: the exact form numpy gives a bit generator
    of ``BIT_GENERATORS`` (its keys, integers in their ranges), else ValueError."""
    if not isinstance(state, dict) or sorted(state) != [
        "bit_generator", "has_uint32", "state", "uinteger",
    ]:  # fmt: skip
        raise ValueError(f"{name} is not a generator's state (bit_generator, state, ...)")
    kind, inner = state["bit_generator"], state["state"]
    if kind not in BIT_GENERATORS:
        raise ValueError(
            f"{name} names bit generator {str(kind)!r:.40}; valid: {', '.join(BIT_GENERATORS)}"
        )
    if not isinstance(inner, dict) or sorted(inner) != ["inc", "state"]:
        raise ValueError(f"{name} of {kind} lacks its state and increment")
    for key, value, bits in (
        ("state", inner["state"], _PCG_BITS), ("inc", inner["inc"], _PCG_BITS),
        ("uinteger", state["uinteger"], _UINT_BITS), ("has_uint32", state["has_uint32"], 1),
    ):  # fmt: skip
        if not isinstance(value, int) or isinstance(value, bool) or not 0 <= value < 2**bits:
            allowed = "0 or 1" if bits == 1 else f"an integer in [0, 2**{bits})"
            raise ValueError(f"{name}'s {key} is not {allowed}")
    if inner["inc"] % 2 == 0:  # seeding makes it odd, as PCG needs
        raise ValueError(f"{name}'s increment is even, which no seeded PCG generator has")
    bit_generator = getattr(np.random, kind)()
    try:
        bit_generator.state = state
    except Exception as exc:  # whatever numpy refuses is damage
        raise ValueError(f"{name} refused by numpy ({type(exc).__name__})") from None
    if bit_generator.state != state:
        raise ValueError(f"{name} does not read back as stored")
    return np.random.Generator(bit_generator)


def monitor_state(stored: Any, t: int) -> dict[str, float]:
    """The continual mode's ``continual_state`` entry: running means of log errors (both NaN
    before the first trial, else finite), the re-adaptation's start (-1, or a trial <= t) and
    the count of re-adaptations (<= t)."""
    keys = ["fast", "readaptations", "reference", "start"]
    if not isinstance(stored, dict) or sorted(stored) != keys:
        raise ValueError(f"continual_state is not the monitor's {', '.join(keys)}")
    means = [stored["fast"], stored["reference"]]
    if not all(isinstance(x, float) for x in means):
        raise ValueError("continual_state's fast and reference are not floats")
    unset = np.isnan(means)
    if not (unset.all() or (not unset.any() and np.all(np.abs(means) <= _LOG_LIMIT))):
        raise ValueError("continual_state's running means are not both unset or finite logs")
    if stored["start"] != -1:
        count("continual_state's start", stored["start"])
    if stored["start"] > t:
        raise ValueError(f"continual_state's start {stored['start']} is after t = {t}")
    count("continual_state's readaptations", stored["readaptations"])
    if stored["readaptations"] > t:
        raise ValueError("continual_state counts more re-adaptations than trials")
    return dict(stored)


def array(arrays: dict[str, np.ndarray], name: str, shape: tuple[int, ...]) -> np.ndarray:
    """``arrays[name]``: float64 of ``shape``, finite, else ValueError."""
    a = arrays[name]
    if a.dtype != np.float64 or a.shape != shape:
        raise ValueError(f"array {name!r} is {a.dtype} {a.shape}, not float64 {shape}")
    if not np.isfinite(a).all():
        raise ValueError(f"array {name!r} {a.shape} holds NaN or inf")
    return a


def ranges(
    arrays: dict[str, np.ndarray], low: str, high: str, size: int | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """The stored bounds ``arrays[low]``, ``arrays[high]``: float64 vectors (of ``size``
    entries if given) that pass construction's checks (``learners.guards.bounds``)."""
    for name in (low, high):
        a = arrays[name]
        if a.dtype != np.float64 or a.ndim != 1:
            raise ValueError(f"array {name!r} is {a.dtype} {a.shape}, not a float64 vector")
    return bounds((low, high), arrays[low], arrays[high], size)


def within(name: str, a: np.ndarray, low: Any, high: Any, what: str) -> None:
    """ValueError unless every entry of ``a`` lies in [low, high] (broadcast), ``what`` the
    interval's name."""
    if not np.all((low <= a) & (a <= high)):
        raise ValueError(f"array {name!r} {a.shape} has entries outside {what}")


def check_linear_map(
    name: str, a: np.ndarray, joint_span: np.ndarray, input_span: np.ndarray
) -> None:
    """ValueError unless |a_jd| <= ``A_LIMIT`` joint_span_j / input_span_d for a local linear
    map a (..., J, D) from inputs to joints."""
    limit = A_LIMIT * joint_span[:, None] / input_span  # (J, D)
    if not np.all(np.abs(a) <= limit):
        raise ValueError(
            f"{name} has entries up to {np.abs(a).max():.3g}, beyond {A_LIMIT:g} joint spans per "
            "input span, which no trial can teach; the values are damaged"
        )
