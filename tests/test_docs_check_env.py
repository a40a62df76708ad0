"""The Gymnasium ``check_env`` calls that the RL page (docs/rl.md) gives, run exactly as written
(warnings as errors, save the one the page names), so that the sentence stays true on a headless
machine."""

from __future__ import annotations

import re
from pathlib import Path

import gymnasium as gym
import pytest
from gymnasium.utils.env_checker import check_env

import envs  # noqa: F401  (registers the envs)

PAGE = Path(__file__).resolve().parents[1] / "docs" / "rl.md"
CALLS = re.findall(r"`(check_env\(gym\.make\([^`]*\))`", PAGE.read_text())


def test_the_page_gives_the_call_that_passes_headless():
    assert CALLS and all("skip_render_check=True" in call for call in CALLS)


@pytest.mark.filterwarnings("ignore:.*symmetric and normalized")
@pytest.mark.filterwarnings("error")
@pytest.mark.parametrize("call", CALLS)
def test_the_pages_check_env_call_passes(call):
    eval(call, {"check_env": check_env, "gym": gym})  # the page's own text


@pytest.mark.filterwarnings("error")
@pytest.mark.parametrize("call", [c for c in CALLS if "normalize=True" in c])
def test_the_normalised_call_passes_without_any_warning(call):
    eval(call, {"check_env": check_env, "gym": gym})
