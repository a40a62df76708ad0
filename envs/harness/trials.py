"""One visuomotor trial on a reach env: a coarse move, then fine moves, each sensed.

This is the loop of Ritter, Martinetz & Schulten: the cameras see the target at u; the controller
gives θ0; after the move the cameras see the marker at v0; the controller corrects to θ1 from v0;
the cameras see v1; and so on. A learner learns from (u, θ0, v0, θ1, v1).

Brause's protocol (§3, ``protocol="brause"``) senses the same positions (x = u, x_I = v0,
x_F = v1), but his fine move (3.7) does not use x_I (``Controller.fine_moves_need_sight`` is
False): a trial goes on when a marker is not seen.

Recovery (a controller whose ``recovers`` is True, e.g. ``VisuomotorSOM(recover=True)``): when
the fine moves need sight and a camera loses the marker after a move that is not the last, the
loop asks the controller for recovery moves until both cameras see the marker again, and the
next move corrects from there. Recovery moves are extra: they are counted in
``Trial.recovery_moves``, and the lists of a trial hold the coarse and fine moves only.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from learners.base import Controller, Learner


@dataclass
class Trial:
    """What one trial saw. Index k = 0 is the coarse move, k ≥ 1 the fine moves."""

    target_px: np.ndarray  # (4,) u
    commands: list[np.ndarray] = field(default_factory=list)  # θ_k, (J,) each
    sensed_px: list[np.ndarray] = field(default_factory=list)  # v_k, (4,) NaN if not visible
    distances: list[float] = field(default_factory=list)  # m, ground truth after move k
    pixel_errors: list[float] = field(default_factory=list)  # px, after move k
    visible: list[bool] = field(default_factory=list)  # both markers seen after move k
    reached: list[np.ndarray] = field(default_factory=list)  # (3,) world m, after move k
    target_pos: np.ndarray | None = None  # (3,) world, m
    start_distance: float = float("nan")  # m, ground truth before the coarse move
    start_pixel_error: float = float("nan")  # px, before the coarse move
    start_pos: np.ndarray | None = None  # (3,) world m, the sensed point before the coarse move
    recovery_moves: int = 0  # extra moves made to see the marker again (controller.recovers)
    #: rad, ground truth after move k, when the env reports the hand's orientation (grasp envs)
    orientation_errors: list[float] = field(default_factory=list)
    start_orientation_error: float = float("nan")  # rad, before the coarse move (grasp envs)

    @property
    def target_visible(self) -> bool:
        return bool(np.all(np.isfinite(self.target_px)))


FrameHook = Callable[[int, Trial], None]


def run_trial(
    env,
    controller: Controller,
    fine_moves: int = 2,
    keep_arm: bool = False,
    on_move: FrameHook | None = None,
    explore: bool = False,
) -> Trial:
    """Reset ``env`` (a new target) and make one coarse and ``fine_moves`` fine moves.

    Args:
        env: a ReachEnv (or a wrapper of one), stepped once per move.
        controller: gives the commands; ``reset()`` is called first.
        keep_arm: start from where the last move left the arm instead of ``home``.
        on_move: called after the reset (k = -1) and after every move k with the trial so far
            (for videos).
        explore: ask a learner for exploratory fine moves (training only; see
            ``VisuomotorSOM.act``).
    Returns:
        the :class:`Trial`. If a marker is not visible, sensed pixels are NaN; when the
        controller's fine moves need sight (``Controller.fine_moves_need_sight``) the trial
        stops there (it cannot correct from a position it did not see) unless the controller
        recovers (``Controller.recovers``: its recovery moves found a pose where the marker is
        seen); otherwise it goes on (Brause's fine command (3.7) does not use what was sensed).
    """
    need_sight = controller.fine_moves_need_sight
    _, info = env.reset(options={"keep_arm": keep_arm})
    base = env.unwrapped
    trial = Trial(
        target_px=base.sensed_target(),
        target_pos=info["target_pos"],
        start_distance=info.get("distance", np.nan),  # every ReachEnv reports these at reset
        start_pixel_error=info.get("pixel_error", np.nan),
        start_pos=info.get("effector_pos"),
        start_orientation_error=info.get("orientation_error", np.nan),
    )
    controller.reset()
    if on_move is not None:
        on_move(-1, trial)
    if not trial.target_visible:
        return trial
    sensed = None
    for k in range(fine_moves + 1):
        if sensed is None or not explore:
            command = controller.act(trial.target_px, sensed)
        else:
            command = controller.act(trial.target_px, sensed, explore=True)
        _, _, _, _, info = env.step(command)
        sensed = base.sensed_effector()
        trial.commands.append(np.asarray(command, dtype=float))
        trial.sensed_px.append(sensed)
        trial.distances.append(info["distance"])
        trial.pixel_errors.append(info["pixel_error"])
        trial.visible.append(info["visible"])
        trial.reached.append(info["effector_pos"])
        if "orientation_error" in info:
            trial.orientation_errors.append(info["orientation_error"])
        if on_move is not None:
            on_move(k, trial)
        if need_sight and not np.all(np.isfinite(sensed)):
            if k == fine_moves or not controller.recovers:
                break
            sensed = _recover(env, controller, trial)
            if sensed is None:
                break
    return trial


def _recover(env, controller: Controller, trial: Trial) -> np.ndarray | None:
    """Recovery moves until both cameras see the marker: the pixels (4,) sensed there, or None
    when the controller has no attempt left."""
    base = env.unwrapped
    attempt = 0
    while (command := controller.recovery_move(trial.target_px, attempt)) is not None:
        env.step(command)
        trial.recovery_moves += 1
        sensed = base.sensed_effector()
        if np.all(np.isfinite(sensed)):
            return sensed
        attempt += 1
    return None


def learn_from(controller: Learner, trial: Trial, pairs: int = 1, stale: bool = False) -> int:
    """Give a learner consecutive moves of a trial: the coarse and first fine move, then, for
    ``pairs`` > 1, fine move k and k + 1 for k = 1 … pairs − 1 (as many as the trial made),
    with the same target and ``coarse=False`` (a learner whose ``learn`` takes that keyword:
    ``HierarchicalSOM``). ``stale``: an earlier state of the learner made the trial's moves; a
    learner with ``learn_stale`` (``VisuomotorSOM``) learns the coarse pair by it. Returns how
    many pairs it learned from (0: the trial was not usable).
    """
    if pairs < 1:
        raise ValueError(f"pairs must be >= 1, got {pairs}")
    learned = 0
    by_stale = getattr(controller, "learn_stale", None) if stale else None
    for k in range(min(pairs, len(trial.commands) - 1)):
        later = {"coarse": False} if k else {}
        learn = by_stale if by_stale is not None and k == 0 else controller.learn
        learned += bool(
            learn(
                trial.target_px,
                trial.commands[k],
                trial.sensed_px[k],
                trial.commands[k + 1],
                trial.sensed_px[k + 1],
                **later,
            )
        )
    return learned
