"""Robot descriptions: MJCF files (``<robot>/<robot>.xml``, ``<robot>/scene.xml``) and the
analytic kinematics of each robot in pure numpy.

A robot is a subpackage of ``models`` with a ``scene.xml``: normally a folder of ``models/``,
found in any folder of the package's search path ``models.__path__`` (a test adds a throwaway
robot there). Its ``__init__.py`` defines ``MODEL`` (:mod:`models.robot_model`).

>>> from models import scene_path, available_models
>>> available_models()
('panda', 'puma560', 'riacs', 'ur5e')
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # mujoco is only needed to compile a model, not for the kinematics
    import mujoco

MODELS_DIR = Path(__file__).resolve().parent


class UnknownModelError(ValueError):
    """Raised for a robot name that has no model folder."""


def _folders() -> dict[str, Path]:
    """Robot name -> its folder: every folder with a ``scene.xml`` in the package's search path
    (the first one found for a name, as ``import models.<name>`` finds it)."""
    found: dict[str, Path] = {}
    for root in __path__:
        for scene in sorted(Path(root).glob("*/scene.xml")):
            found.setdefault(scene.parent.name, scene.parent)
    return found


def available_models() -> tuple[str, ...]:
    """Names of the robots that have a ``scene.xml``, sorted."""
    return tuple(sorted(_folders()))


def model_dir(name: str) -> Path:
    """Folder of robot ``name``; raises :class:`UnknownModelError` listing the valid names."""
    folders = _folders()
    if name not in folders:
        raise UnknownModelError(
            f"no robot model named {name!r}; available models: {', '.join(sorted(folders))}"
        )
    return folders[name]


def scene_path(name: str) -> Path:
    """``models/<name>/scene.xml``: robot, floor, lights, cameras and target."""
    return model_dir(name) / "scene.xml"


def robot_path(name: str) -> Path:
    """``models/<name>/<name>.xml``: the robot alone."""
    return model_dir(name) / f"{name}.xml"


def load_model(name: str, scene: bool = True, scene_file: str = "scene.xml") -> mujoco.MjModel:
    """Compile the scene (or the robot alone) of robot ``name``.

    Args:
        scene_file: which scene of the robot's folder (``scene_grasp.xml``: the grasp task's).
    """
    import mujoco

    path = model_dir(name) / scene_file if scene else robot_path(name)
    if not path.is_file():
        raise UnknownModelError(f"robot {name!r} has no scene file {scene_file!r} in {path.parent}")
    return mujoco.MjModel.from_xml_path(str(path))
