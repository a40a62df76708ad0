"""Recovery from a lost marker: a detour the map has learned (``SOMConfig.recover``).

MRS's loop stops a trial when a camera does not see the effector marker after a move, because a
fine move corrects from the position sensed and there is none. On the arms here the marker is
hidden by the arm's own links, above all at the target's own pose (docs/decisions.md,
"Recovery from a hidden marker"): going back to the same pose by another path would hide it
again, and the RIACS arm reaches each point in one configuration only. The recovery therefore
moves the arm to a pose near the target where the cameras see the marker, and corrects from
there:

    detour a   θ_d = the map's coarse command for the sub-goal  g_a = u + f_a (c − u)
               c = the mean of the w_r (the middle of the positions the map has seen targets
               at), f_a = ``DETOUR_FRACTIONS[a]``, tried in turn until both cameras see the
               marker (each attempt is one recovery move)
    then       θ_{k+1} = θ_d + Ā (u − v_d),  v_d sensed after θ_d (the usual fine move)

Everything comes from what the map learned (w, θ, A); neither the kinematics nor the camera
model is used. The detour shortens the fine move's lever; the hidden move's own error is not
learned from (its marker was not seen), and no Broyden step crosses it.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from learners.som.controller import VisuomotorSOM

#: Fractions of the way from the target to the middle of the map's inputs at which the detours
#: aim, one recovery move each, nearest first (docs/decisions.md says how they were chosen).
DETOUR_FRACTIONS = (0.1, 0.25, 0.5, 1.0)


def detour(som: VisuomotorSOM, u: np.ndarray, attempt: int) -> np.ndarray | None:
    """The clipped command (J,) of detour ``attempt`` for target u, or None after the last.

    Sets the map's fine-move memory so that the next ``act(u, v)`` corrects from the detour:
    its command is the detour's, and no earlier sensing is kept (Ā is taken afresh at u).
    """
    if attempt >= len(DETOUR_FRACTIONS):
        return None
    u = som._vector("u", u)
    if som._cmd is None:
        raise ValueError("a recovery move needs a coarse act(u) first (after reset)")
    middle = som._w.mean(axis=0)  # (D,)
    goal = u + DETOUR_FRACTIONS[attempt] * (middle - u)  # (D,), inside the box of u and w
    command = som.act_batch(goal[None])[0]  # (J,) clipped; the fine-move memory untouched
    som._cmd, som._v, som._cmd_before = command.copy(), None, None
    return command
