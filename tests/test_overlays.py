"""The sensing overlays of the frames people watch: a reached target is one symbol (a green ring
round a red dot), not a circle crossed by a crosshair; one word, "error", for the distance of the
sensed point from the target in every film overlay."""

from __future__ import annotations

import numpy as np
import pytest

from envs import composite
from envs.composite import draw_marker, reached

HEIGHT = 240  # panel pixels
RED, GREEN = 0, 1  # channels: the crosshair is red, the detection green (composite's colours)
MARGIN = 50  # a pixel is of a colour when that channel exceeds both others by this much


def _near(image: np.ndarray, channel: int) -> np.ndarray:
    """Pixels whose ``channel`` dominates (anti-aliased edges included)."""
    rgb = image.astype(int)
    others = np.delete(rgb, channel, axis=-1).max(axis=-1)
    return rgb[..., channel] - others > MARGIN


def _ring(image: np.ndarray, centre: tuple[int, int], radius: float) -> np.ndarray:
    """The image's pixels at ``radius`` ± 1 px from ``centre`` (u, v)."""
    v, u = np.mgrid[: image.shape[0], : image.shape[1]]
    return np.abs(np.hypot(u - centre[0], v - centre[1]) - radius) <= 1.0


def _drawn(target, effector) -> np.ndarray:
    image = np.full((HEIGHT, 320, 3), 128, dtype=np.uint8)
    draw_marker(image, np.array(target, float), np.array(effector, float), HEIGHT)
    return image


def test_a_detection_on_its_target_is_a_ring_round_a_red_dot_without_crosshair():
    image = _drawn((100, 100), (101, 100.5))
    ring = _ring(image, (100, 100), HEIGHT * composite.RING_FRACTION)
    assert _near(image, GREEN)[ring].mean() > 0.3  # the green ring
    assert _near(image, RED)[100, 100]  # the red dot at the target
    # No crosshair: nothing red along its arms (from the gap out to the arm's end).
    arms = np.arange(round(HEIGHT * 0.03), round(HEIGHT * composite.CROSSHAIR_FRACTION))
    assert not _near(image, RED)[100, 100 + arms].any()
    assert not _near(image, RED)[100 + arms, 100].any()


def test_a_detection_off_its_target_is_a_circle_beside_a_crosshair():
    image = _drawn((100, 100), (160, 100))
    arms = np.arange(round(HEIGHT * 0.03), round(HEIGHT * composite.CROSSHAIR_FRACTION))
    assert _near(image, RED)[100, 100 - arms].mean() > 0.8  # the crosshair's left arm
    circle = _ring(image, (160, 100), HEIGHT * composite.CIRCLE_FRACTION)
    assert _near(image, GREEN)[circle].mean() > 0.3
    assert not _near(image, GREEN)[_ring(image, (100, 100), HEIGHT * 0.045)].any()


def test_nothing_is_drawn_for_an_unseen_target_and_marker():
    image = _drawn((np.nan, np.nan), (np.nan, np.nan))
    assert (image == 128).all()


@pytest.mark.parametrize(
    ("offset", "on_target"), [(0.0, True), (5.9, True), (6.1, False), (30.0, False)]
)
def test_reached_is_inside_the_crosshair_gap(offset, on_target):
    # The gap of a 240-pixel panel: 0.025 × 240 = 6 px from the centre.
    assert reached(np.array([50.0, 50.0]), np.array([50.0, 50.0 + offset]), HEIGHT) is on_target


def test_the_film_overlays_call_the_distance_error_while_moving_and_after():
    import inspect

    from envs.harness import film

    source = inspect.getsource(film.TrialFilm.trial)
    assert "distance {" not in source  # the quantity's one word in the overlay is "error"
    assert source.count("error {") == 2  # while moving and after the move


def _colour_counts(image: np.ndarray) -> tuple[int, int]:
    """Pixels of clear red and of clear green in an RGB image."""
    return int(_near(image, RED).sum()), int(_near(image, GREEN).sum())


@pytest.mark.parametrize("robot", ["riacs", "puma560"])
def test_a_reached_target_is_a_glass_shell_not_a_speckle_of_two_spheres(robot, monkeypatch):
    from envs.cli.controllers import make_controller
    from envs.composite import CompositeView
    from envs.reach import ReachEnv

    env = ReachEnv(robot=robot, sensing="project", control="kinematic")
    obs, info = env.reset(seed=3)
    unseen = np.full(4, np.nan)  # no 2-D overlays: the rendered spheres alone
    shells = composite.SEE_THROUGH

    def panels(see_through: tuple[str, ...]) -> list[np.ndarray]:
        monkeypatch.setattr(composite, "SEE_THROUGH", see_through)
        view = CompositeView(env.model, HEIGHT, 320)
        rgba, size = env.model.geom_rgba.copy(), env.model.geom_size.copy()
        drawn = view.panels(env.data, unseen, unseen)
        view.close()
        # The model is as it was: sensing renders see the target unchanged.
        np.testing.assert_array_equal(env.model.geom_rgba, rgba)
        np.testing.assert_array_equal(env.model.geom_size, size)
        return drawn

    assert info["distance"] > 0.1  # at home, the marker far from the target
    apart = panels(shells)
    for image, plain in zip(apart, panels(()), strict=True):
        np.testing.assert_array_equal(image, plain)  # an untouched target is drawn as it is
    _, _, _, _, info = env.step(make_controller("analytic", env).act(obs["desired_goal"]))
    assert info["distance"] < 1e-9  # the marker's sphere is the target's, same place and size

    # Drawn as they are, the two coinciding spheres fight: red and green pixels side by side.
    for image in panels(()):
        red, green = _colour_counts(image)
        assert red > 10 and green > 10
    # As a larger see-through shell, the target holds the marker: no clear green pixel left.
    for image in panels(shells):
        red, green = _colour_counts(image)
        assert red > 10 and green == 0
    env.close()
