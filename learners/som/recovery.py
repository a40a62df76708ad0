"""Recovery from a lost marker: moves the map has learned (``SOMConfig.recover``).

MRS's loop stops a trial when a camera does not see the effector marker after a move, because a
fine move corrects from the position sensed and there is none. On the arms here the marker is
hidden by the arm's own links, above all at the target's own pose (docs/decisions.md,
"Recovery from a hidden marker"): going back to the same pose would hide it again, and the RIACS
arm reaches each point in one configuration only. The recovery therefore takes the arm to a pose
near the target where both cameras see the marker, and the next fine move corrects from there.
Each recovery move is one attempt; attempts are tried in turn until the marker is seen:

    nothing seen yet in this trial (the coarse move hid it): a detour,
        θ_d = the map's coarse command for the sub-goal  g_a = u + f_a (c − u),
        c the mean of the w_r (the middle of where the map has seen targets),
        f_a = ``DETOUR_FRACTIONS[a]``
    else, from the last pose θ_s where both cameras saw the marker, at v_s: a shorter step,
        θ_d = θ_s + Ā (g_a − v_s),  g_a = v_s + h_a (u − v_s),  h_a = ``APPROACH_FRACTIONS[a]``
        and the Broyden step of the next fine move uses this sensed move (θ_s, v_s) -> (θ_d, v_d);
        the last fraction is 0: back to θ_s itself, which the cameras saw (no Broyden step: the
        move is too short to measure Ā)

then, as always, θ_{k+1} = θ_d + Ā (u − v_d) with v_d sensed after θ_d. When the target's own
pose hides the marker, every fine move ends hidden and each recovery halves the lever of the
next one: the last fine move, which needs no sighting after it, starts from the nearest pose
seen. Everything comes from what the map learned (w, θ, A, Ā) and what it sensed; neither the
kinematics nor the camera model is used. A hidden move is never learned from.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from learners.som.fine_memory import FineMemory

#: Fractions of the way from the target to the middle of the map's inputs at which the detours
#: aim when nothing has been seen yet, nearest first (docs/decisions.md says how they were
#: chosen).
DETOUR_FRACTIONS = (0.1, 0.25, 0.5, 1.0)
#: Fractions of the way from the last pose seen to the target at which the shorter steps aim.
APPROACH_FRACTIONS = (0.5, 0.25, 0.0)


def recovery_move(
    memory: FineMemory,
    u: np.ndarray,
    attempt: int,
    middle: np.ndarray,
    coarse: Callable[[np.ndarray], np.ndarray],
    clip: Callable[[np.ndarray], np.ndarray],
) -> np.ndarray | None:
    """The clipped command (J,) of recovery ``attempt`` for the checked target u (D,), or None
    after the last.

    Args:
        memory: the trial's fine-move memory; set so that the next ``act(u, v)`` corrects from
            the recovery pose (see the module docstring).
        middle: (D,) the mean of the w_r.
        coarse: the map's coarse command (J,) for a sub-goal (D,), not touching ``memory``.
        clip: joint angles (J,) clipped into the joint ranges.
    """
    if memory.cmd is None:
        raise ValueError("a recovery move needs a coarse act(u) first (after reset)")
    if memory.seen_cmd is None or memory.seen_v is None or memory.abar is None:
        if attempt >= len(DETOUR_FRACTIONS):
            return None
        goal = u + DETOUR_FRACTIONS[attempt] * (middle - u)  # (D,), between u and the w_r
        command = coarse(goal)  # (J,) clipped
        memory.cmd, memory.v, memory.cmd_before = command.copy(), None, None
        return command
    if attempt >= len(APPROACH_FRACTIONS):
        return None
    theta_s, v_s = memory.seen_cmd, memory.seen_v
    goal = v_s + APPROACH_FRACTIONS[attempt] * (u - v_s)  # (D,)
    command = clip(theta_s + memory.abar @ (goal - v_s))  # (J,)
    memory.cmd = command.copy()
    if APPROACH_FRACTIONS[attempt] > 0:
        memory.v, memory.cmd_before = v_s.copy(), theta_s.copy()
    else:
        memory.v, memory.cmd_before = None, None
    return command
