"""A stored room's person-free record, ``SCENE/static.npz``: its one reader.

``SceneBuilder._write_static`` writes it once per room. Keys (T candidate spots, image H x W):

* ``los_vertices`` (V, 3), ``los_faces`` (T, 3): the LOS mesh whose faces are the candidates;
* ``aim_points`` (T, 3): where each candidate's spot is aimed; ``spot_landed`` (T,) bool: the
  projector's beam reaches it;
* ``direct`` (T, H, W, 3): the room lit by each candidate (direct and interreflected);
  ``ambient`` (H, W, 3): the room's own light; ``flash_direct`` (H, W, 3): the room under the flash;
* ``camera_to_world`` (4, 4): the camera pose (columns right, up, back, position);
* ``family`` (): the room family's name.

Read with ``allow_pickle=False`` (a shared room runs no code); a missing, torn or incomplete file is
one line naming it.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import NlosError

STATIC = "static.npz"


def static_path(scene_dir) -> Path:
    return Path(scene_dir) / STATIC


def read_static(scene_dir, *keys: str, optional: tuple[str, ...] = ()) -> dict[str, np.ndarray]:
    """The named arrays of ``scene_dir``'s record (every array if none is named), and those of
    ``optional`` it holds (older rooms lack the flash)."""
    path = static_path(scene_dir)
    try:
        with np.load(path, allow_pickle=False) as z:
            missing = [k for k in keys if k not in z.files]
            if missing:
                raise NlosError(f"{path}: no '{missing[0]}' (written by an older version: generate the room again)")
            return {k: z[k] for k in (*(keys or z.files), *(k for k in optional if k in z.files))}
    except NlosError:
        raise
    except FileNotFoundError:
        raise NlosError(f"{path}: missing (the room's person-free record)") from None
    except Exception as exc:  # numpy raises several types on torn files
        raise NlosError(f"{path}: unreadable ({type(exc).__name__})") from None


__all__ = ["STATIC", "read_static", "static_path"]
