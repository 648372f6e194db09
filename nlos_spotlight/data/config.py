"""Typed dataset configuration with named presets (``tiny``, ``small``, ``paper``) and YAML files."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from pathlib import Path

from ..errors import NlosError
from ..render.settings import DATASET_SAMPLING, ImageSampling


@dataclass
class DatasetConfig:
    """Everything that determines a dataset's content (with the code version)."""

    name: str = "tiny"
    """Preset or user name, recorded in the manifest."""
    seed: int = 0
    """Master seed; every scene and sample seed derives from it."""
    train_scenes: int = 2
    """Procedural rooms in the training split."""
    val_scenes: int = 1
    """Rooms in the validation split."""
    test_scenes: int = 1
    """Rooms in the test split (never seen in training)."""
    samples_per_scene: int = 6
    """Static-pose samples per room (postures balanced, positions uniform)."""
    transport_samples_per_scene: int = -1
    """People per room with full transport (samples 0..M-1); the rest are image samples of stored spots (-1: all)."""
    stored_spots_top: int = 6
    """Image samples: best candidates by NLOS SNR stored besides the adaptive, center and random policies' spots."""
    trajectories_per_test_scene: int = 1
    """Walking trajectories per test room, for tracking."""
    trajectories_per_train_scene: int = 0
    """Walking trajectories per training room, for tracking in seen rooms (always held out of training)."""
    trajectory_frames: int = 12
    """Frames per trajectory."""
    frame_rate_hz: float = 5.0
    """Frames per second along a trajectory."""
    resolution: int = 32
    """Camera image width and height, pixels."""
    los_vertices: int = 120
    """Target vertex count of the decimated LOS mesh the IEN reads (its faces are the spot candidates)."""
    transport_rank: int = 48
    """Rank of the stored per-sample transport matrix F (0 stores it in full)."""
    body_faces: int = 1500
    """Target face count of decimated bodies."""
    render: ImageSampling = field(default_factory=lambda: dataclasses.replace(DATASET_SAMPLING))
    """How the people's photographs are sampled (``render.settings.ImageSampling``; YAML: a
    ``render:`` mapping of its fields over the preset's)."""
    families: list[str] = field(default_factory=list)
    """Room layout families to cycle through (empty: all)."""
    extra_spots: list[int] = field(default_factory=list)
    """Candidates every room also stores for its image samples (``nlos fit``: a trained IEN's choice)."""
    room: str = ""
    """An nlos-scene/1 directory every scene is built on instead of a procedural room (``nlos fit``:
    a user's room; its people differ per scene), relative to the dataset directory unless absolute;
    empty: procedural rooms."""

    FLAT_BLOCKS = ("render",)
    """Blocks whose fields a YAML file, a flag or an older (flat) record may give by their own names
    (``config_file.nest``)."""

    def __post_init__(self) -> None:
        from ..config_file import as_block

        self.render = as_block(self.render, DATASET_SAMPLING, "config: render")  # a record's mapping too

    @property
    def num_scenes(self) -> int:
        return self.train_scenes + self.val_scenes + self.test_scenes

    def split_of(self, index: int) -> str:
        if index < self.train_scenes:
            return "train"
        return "val" if index < self.train_scenes + self.val_scenes else "test"

    def to_dict(self) -> dict:
        return dataclasses.asdict(self)

    @classmethod
    def from_dict(cls, d: dict) -> "DatasetConfig":
        """The config a dataset's ``config.json`` (or manifest) records, nested or in the flat form
        of datasets made before the ``render`` block (``config_file.nest``)."""
        from ..config_file import nest

        return cls(**nest(cls, d))

    def render_settings(self, **overrides):
        """The renderer's settings of this dataset's people (``render.settings.RenderSettings`` of the
        ``render`` block, on the CPU), with ``overrides`` (execution: ``device``, ``fuse``, ``rays``;
        or a shadow's ``shadow_samples``)."""
        from ..render.settings import RenderSettings

        return RenderSettings.of(self.render, **{"device": "cpu", **overrides})


def read_dataset_config(data: Path) -> DatasetConfig:
    """The config a dataset directory records (``config.json``, flat or nested: ``from_dict``), or
    a one-line ``NlosError``: the one reader of a dataset's config."""
    import json

    path = Path(data) / "config.json"
    try:
        return DatasetConfig.from_dict(json.loads(path.read_text()))
    except FileNotFoundError:
        raise NlosError(f"{data}: not a dataset (no config.json; make one with nlos generate)") from None
    except (OSError, ValueError, TypeError, AttributeError, NlosError) as exc:
        raise NlosError(f"{path}: unreadable dataset config ({type(exc).__name__})") from None


SET_BLOCK = 100
"""Samples per block of sampling sets: a fit's shadow file holds one block (``fit/shadow.py``)."""
SETS_PER_BLOCK = 8
"""Sampling sets a block draws (shadow relay points, jittered footprints): each set's precompute
(static visibility, camera sub-samples) is done once and shared by the block's samples that use it."""


def sampling_set(k: int) -> int:
    """The sampling set of dataset sample ``k``: set ``k mod SETS_PER_BLOCK`` of its block of
    :data:`SET_BLOCK` (consecutive samples use different sets, every block its own)."""
    return k // SET_BLOCK * SETS_PER_BLOCK + k % SETS_PER_BLOCK


def footprint_draw(cfg: "DatasetConfig", k: int) -> int | None:
    """The footprint draw sample ``k``'s person terms are rendered with (``Renderer.use_footprint``):
    its sampling set when ``render.footprint_jitter``, else None (the renderer's one fixed set)."""
    return sampling_set(k) if cfg.render.footprint_jitter and cfg.render.pixel_footprint > 0 else None


PRESETS = {
    # the body light of every preset is within 0.5% of a converged render (faces rule, 3500 -> ~3850
    # samples: worst of six postures 0.42% at these settings; benchmarks/person_convergence.py)
    "tiny": DatasetConfig(),
    # make demo's 20-minute budget: ~0.7 s per full-transport person at these settings
    "demo": DatasetConfig(name="demo", train_scenes=10, val_scenes=0, test_scenes=3, samples_per_scene=16,
                          trajectories_per_test_scene=1, trajectories_per_train_scene=1, trajectory_frames=12,
                          resolution=32, los_vertices=120),
    # make demo's seen room: one room, its people by the hundred as image samples (learning that works)
    "demo-room": DatasetConfig(name="demo-room", train_scenes=1, val_scenes=0, test_scenes=0, samples_per_scene=1000,
                               transport_samples_per_scene=8, trajectories_per_test_scene=0,
                               trajectories_per_train_scene=0, resolution=32, los_vertices=200),
    "small": DatasetConfig(name="small", train_scenes=16, val_scenes=4, test_scenes=6, samples_per_scene=36,
                           trajectories_per_test_scene=2, trajectories_per_train_scene=1, trajectory_frames=30,
                           resolution=32, los_vertices=300,
                           render=dataclasses.replace(DATASET_SAMPLING, person_samples=4000)),  # <= 0.5% from converged
    "paper": DatasetConfig(name="paper", train_scenes=300, val_scenes=30, test_scenes=60, samples_per_scene=120,
                           trajectories_per_test_scene=4, trajectories_per_train_scene=1, trajectory_frames=60,
                           resolution=64, los_vertices=800,
                           transport_rank=96, render=dataclasses.replace(DATASET_SAMPLING, pixel_samples=4,
                                                                         transport_pixel_samples=2, spot_samples=32,
                                                                         person_samples=4000)),
}


def load_config(spec: str) -> DatasetConfig:
    """A preset name or a YAML file of ``DatasetConfig`` fields (optionally ``base: PRESET``),
    validated (``config_file.load_config_file``)."""
    from ..config_file import load_config_file

    cfg, path = load_config_file(spec, PRESETS)
    if path is not None:
        validate(cfg, str(path))
    return cfg


def validate(cfg: DatasetConfig, where: str) -> None:
    """Raise one NlosError naming the first bad field (``where``: the file or 'config')."""
    for k in ("seed", "val_scenes", "test_scenes", "trajectories_per_test_scene", "trajectories_per_train_scene",
              "transport_rank"):  # transport_rank 0 stores the transport in full
        if getattr(cfg, k) < 0:
            raise NlosError(f"{where}: {k} must be at least 0, got {getattr(cfg, k)}")
    if cfg.trajectory_frames < 1:
        raise NlosError(f"{where}: trajectory_frames must be at least 1, got {cfg.trajectory_frames}")
    if not 0 < cfg.frame_rate_hz < 1e4:
        raise NlosError(f"{where}: frame_rate_hz must be a positive number below 10000, got {cfg.frame_rate_hz}")
    if cfg.train_scenes < 0 or cfg.num_scenes < 1:  # 0 training rooms: a test set for models trained elsewhere
        raise NlosError(f"{where}: train_scenes must be at least 0 and the dataset hold at least one scene")
    for k in ("samples_per_scene", "resolution", "los_vertices", "body_faces"):
        if getattr(cfg, k) < 1:
            raise NlosError(f"{where}: {k} must be at least 1")
    for k in ("spot_samples", "person_samples", "pixel_samples", "transport_pixel_samples"):
        if getattr(cfg.render, k) < 1:
            raise NlosError(f"{where}: render.{k} must be at least 1")
    if cfg.resolution > 1024 or cfg.samples_per_scene > 100000 or cfg.num_scenes > 1000000:
        raise NlosError(f"{where}: absurd size (resolution {cfg.resolution}, {cfg.num_scenes} scenes)")
    if cfg.los_vertices < 8:
        raise NlosError(f"{where}: los_vertices must be at least 8")
    if cfg.transport_samples_per_scene == 0 or cfg.transport_samples_per_scene < -1:
        raise NlosError(f"{where}: transport_samples_per_scene must be -1 (all) or at least 1")
    from ..render.person import QUADRATURES

    if cfg.render.person_quadrature not in QUADRATURES:
        raise NlosError(f"{where}: render.person_quadrature must be one of {', '.join(QUADRATURES)}")
    if cfg.stored_spots_top < 0:
        raise NlosError(f"{where}: stored_spots_top must be at least 0")
    if not 0 <= cfg.render.pixel_footprint <= 64:
        raise NlosError(f"{where}: render.pixel_footprint must be 0 (off) to 64, got {cfg.render.pixel_footprint}")


def memory_needed_bytes(cfg: DatasetConfig) -> int:
    """A lower bound on the peak memory of one room's precompute, from its largest arrays: the direct image of
    every candidate spot (about two faces per LOS vertex; float32, kept with one working copy) and
    the camera sub-samples of the per-scene terms (~200 bytes each: points, normals, materials, rays)."""
    pixels = cfg.resolution ** 2
    candidates = 2 * cfg.los_vertices
    direct = 2 * candidates * pixels * 3 * 4
    r = cfg.render
    person = r.pixel_footprint ** 2 if r.pixel_footprint > 0 else r.transport_pixel_samples ** 2
    subsamples = (r.pixel_samples ** 2 + person) * pixels * 200
    return int(direct + subsamples)


def available_memory_bytes() -> int | None:
    """MemAvailable of /proc/meminfo (Linux), else physical memory, else None."""
    import os

    try:
        for line in Path("/proc/meminfo").read_text().splitlines():
            if line.startswith("MemAvailable:"):
                return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (ValueError, OSError, AttributeError):
        return None


def check_memory(cfg: DatasetConfig, where: str, available: int | None = None) -> None:
    """NlosError before any work when one room would need more memory than this machine has free
    (``available`` bytes; default: measured)."""
    need, have = memory_needed_bytes(cfg), available if available is not None else available_memory_bytes()
    if have is not None and need > have:
        raise NlosError(f"{where}: resolution {cfg.resolution} with {cfg.los_vertices} LOS vertices needs about "
                        f"{need / 2**30:.1f} GiB per room, this machine has {have / 2**30:.1f} GiB free "
                        "(lower resolution or los_vertices)")


ROOM_FAMILY = "room"
"""The family recorded for scenes built on a given room (``DatasetConfig.room``)."""


def room_dir(out: Path, room: str) -> Path:
    """``DatasetConfig.room`` as a directory: relative paths are relative to the dataset directory
    (a room model can move as a whole)."""
    p = Path(room)
    return (p if p.is_absolute() else Path(out) / p).resolve()


def sample_count(cfg: DatasetConfig, split: str) -> int:
    return cfg.samples_per_scene + trajectory_count(cfg, split) * cfg.trajectory_frames


def trajectory_count(cfg: DatasetConfig, split: str) -> int:
    """Walking trajectories per room of ``split`` (validation rooms have none)."""
    return {"test": cfg.trajectories_per_test_scene, "train": cfg.trajectories_per_train_scene}.get(split, 0)


def transport_count(cfg: DatasetConfig, split: str) -> int:
    """How many of a room's samples (the first ones) store full transport; the rest are image samples."""
    n = sample_count(cfg, split)
    return n if cfg.transport_samples_per_scene < 0 else min(n, cfg.transport_samples_per_scene)
