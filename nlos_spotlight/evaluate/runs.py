"""Train (or find) the run of every method and seed the evaluation needs; resumable.

Layout under the evaluated run ``RUN``::

    RUN/                      ours, seed = its config's seed (trained by ``nlos train``)
    RUN/methods/<method>/seed<k>/   every other method and seed (same config, policy and network swapped)

A finished run has ``final.pt`` and is reused; an interrupted one resumes from ``checkpoint.pt``.
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

from ..errors import NlosError
from ..train.config import TrainConfig
from .methods import Method


def run_config(run_dir: Path) -> TrainConfig:
    """The resolved training config of ``nlos train``'s run in ``run_dir``."""
    path = run_dir / "config.json"
    try:
        return TrainConfig.from_dict(json.loads(path.read_text())["train"])
    except FileNotFoundError:
        raise NlosError(f"{run_dir}: not a training run (no config.json; make one with nlos train)") from None
    except (json.JSONDecodeError, KeyError, TypeError) as exc:
        raise NlosError(f"{path}: corrupted run config ({type(exc).__name__})") from None


def seeds_of(base: TrainConfig, count: int) -> list[int]:
    """Training seeds: the run's own seed, then the next ``count - 1``."""
    if count < 1:
        raise NlosError(f"--seeds: expected at least 1, got {count}")
    return [base.seed + k for k in range(count)]


def run_path(run_dir: Path, base: TrainConfig, method: Method, seed: int) -> Path:
    if method.name == "ours" and seed == base.seed:
        return run_dir
    return run_dir / "methods" / method.name / f"seed{seed}"


def method_config(base: TrainConfig, method: Method, seed: int) -> TrainConfig:
    return dataclasses.replace(base, seed=seed, policy=method.policy, arch=method.arch,
                               name=f"{base.name}-{method.name}", **dict(method.overrides))


def ensure_run(run_dir: Path, base: TrainConfig, method: Method, seed: int, data: Path,
               progress: bool = True) -> Path:
    """The finished run of ``method`` at ``seed``, training or resuming it if needed."""
    path = run_path(run_dir, base, method, seed)
    if (path / "final.pt").is_file():
        return path
    if path == run_dir:
        raise NlosError(f"{run_dir}: the run has no final.pt (finish it with nlos train ... --resume)")
    from ..train.loop import train

    train(method_config(base, method, seed), data, path, resume=True, progress=progress)
    return path
